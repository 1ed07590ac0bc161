"""Shared HDF5 conventions: provenance attributes, schema versions, datasets with units."""

from __future__ import annotations


import contextlib
import datetime as _dt
import hashlib
import io
import json
import re
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping

import h5py
import numpy as np

from whiskercal import __version__
from whiskercal.errors import ArtifactError, UsageError
from whiskercal.jsontools import jsonable
from whiskercal.paths import not_regular_reason


def sha256_file(path: str | Path, chunk_bytes: int = 1 << 20) -> str:
    """Hex SHA-256 of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for chunk in iter(lambda: handle.read(chunk_bytes), b""):
            digest.update(chunk)
    return digest.hexdigest()


def now_iso() -> str:
    """The current time, ISO 8601 with the local zone."""
    return _dt.datetime.now().astimezone().isoformat(timespec="seconds")


def write_provenance(group: h5py.Group, *, schema: str, schema_version: str, sensor_id: str,
                     inputs: Mapping[str, str] | None = None,
                     config: Mapping[str, Any] | None = None) -> None:
    """Write the root attributes every whiskercal file carries.

    ``inputs`` maps an input's role to its SHA-256; ``config`` is stored as JSON text.
    """
    group.attrs["schema"] = schema
    group.attrs["schema_version"] = schema_version
    group.attrs["created"] = now_iso()
    group.attrs["whiskercal_version"] = __version__
    group.attrs["sensor_id"] = sensor_id
    group.attrs["inputs_sha256"] = json.dumps(dict(inputs or {}), sort_keys=True)
    group.attrs["config"] = json.dumps(dict(config or {}), sort_keys=True, default=jsonable)


def read_json_attr(group: h5py.Group, name: str, default: Any = None) -> Any:
    """Parse a JSON text attribute (``config``, ``inputs_sha256``, ...)."""
    if name not in group.attrs:
        return default
    return json.loads(as_text(group.attrs[name]))


def as_text(value: Any) -> str:
    """An attribute's value as text (h5py returns bytes for some string attributes)."""
    return value.decode() if isinstance(value, bytes) else str(value)


def check_schema(group: h5py.Group, schema: str, supported_major: int, path: str | Path = "") -> str:
    """Refuse a file of another schema or an unknown major version; return its version string."""
    where = f"{path}: " if path else ""
    found = as_text(group.attrs.get("schema", ""))
    if found != schema:
        raise ArtifactError(f"{where}not a {schema} file (schema attribute is {found or 'missing'!r})")
    version = as_text(group.attrs.get("schema_version", ""))
    try:
        major = int(version.split(".")[0])
    except ValueError:
        raise ArtifactError(f"{where}bad schema_version {version!r}") from None
    if major != supported_major:
        raise ArtifactError(
            f"{where}{schema} schema version {version} is not supported by whiskercal {__version__} "
            f"(this version reads {supported_major}.x); upgrade whiskercal or re-create the file")
    return version


def write_array(group: h5py.Group, name: str, data: Any, units: str, **attrs: Any) -> h5py.Dataset:
    """Create (or replace) a dataset with its ``units`` attribute (use "1" for dimensionless)."""
    if name in group:
        del group[name]
    dataset = group.create_dataset(name, data=np.asarray(data))
    dataset.attrs["units"] = units
    for key, value in attrs.items():
        dataset.attrs[key] = value
    return dataset


def read_array(group: h5py.Group, name: str, path: str | Path = "") -> np.ndarray:
    """Read a dataset as an array, with a clear error when it is missing."""
    if name not in group:
        where = f"{path}: " if path else ""
        raise ArtifactError(f"{where}missing dataset {group.name.rstrip('/')}/{name}")
    return group[name][()]


def open_h5(path: str | Path, mode: str = "r") -> h5py.File:
    """Open an HDF5 file, turning 'not found', 'not a regular file' and 'not HDF5' into one clear
    error; a file opened for reading that holds a soft or external link, or a dataset stored
    outside it, is refused (the recorded SHA-256 covers only this file's bytes)."""
    path = Path(path)
    if mode == "r" and not path.exists():
        raise ArtifactError(f"{path}: no such file")
    reason = not_regular_reason(path)
    if reason is not None:
        raise ArtifactError(f"{path}: {reason}")
    handle = _open(path, mode)
    if mode in ("r", "r+", "a"):
        try:
            refuse_links(handle, path)
        except BaseException:
            handle.close()
            raise
    return handle


def _open(path: Path, mode: str) -> h5py.File:
    try:
        return h5py.File(path, mode)
    except OSError as error:
        torn = _TRUNCATED.search(str(error))
        if torn:  # the write was cut short (a crash, a full disk, an interrupted copy)
            raise ArtifactError(f"{path}: truncated: {int(torn['eof'])} of {int(torn['stored'])} "
                                "bytes (the write was cut short)") from None
        if "file signature not found" in str(error):
            raise ArtifactError(f"{path}: not an HDF5 file") from None
        raise ArtifactError(f"{path}: cannot open as HDF5 ({error})") from None


def refuse_links(handle: h5py.File, path: str | Path) -> None:
    """Refuse a file whose content reaches outside it or through another name: a soft or external
    link, or a dataset with external or virtual storage. whiskercal never writes any of them."""
    def link_kind(name: str) -> str | None:  # a value other than None ends h5py's visit there
        link = handle.get(name, getlink=True)
        if isinstance(link, h5py.ExternalLink):
            return f"/{name} is an external link"
        return f"/{name} is a soft link" if isinstance(link, h5py.SoftLink) else None

    def outside(name: str, item) -> str | None:
        if isinstance(item, h5py.Dataset) and (item.is_virtual or item.external is not None):
            return f"dataset /{name} is stored outside the file"
        return None

    # raising inside h5py's visit callback would surface as a SystemError: return, then raise
    found = handle.visit_links(link_kind) or handle.visititems(outside)
    if found:
        raise ArtifactError(f"{path}: {found}: refused (a whiskercal file holds its data itself)")


# HDF5's own words for a file shorter than its superblock says it is
_TRUNCATED = re.compile(r"truncated file: eof = (?P<eof>\d+).*stored_eof = (?P<stored>\d+)")


def write_whole(path: str | Path, write: Callable[[h5py.File], None]) -> Path:
    """Build a new HDF5 file with ``write(handle)`` in memory, then write its bytes to ``path``
    atomically (:func:`whiskercal.atomic.write_bytes`).

    HDF5 left to write a file itself meets a full disk halfway through its own buffers and may
    crash the process when it later closes that file; in memory, only a plain write can fail,
    as one clear error, with the old file left whole.
    """
    from whiskercal.atomic import write_bytes

    buffer = io.BytesIO()
    with h5py.File(buffer, "w") as handle:
        write(handle)
    return write_bytes(path, buffer.getvalue())


def update_copy(path: str | Path, write) -> None:
    """Apply ``write(handle)`` to a copy of the HDF5 file at ``path`` (made in memory) and write
    it over the file atomically: a crash or a full disk leaves the old file or the new one, never
    a torn one."""
    from whiskercal.atomic import write_bytes

    with open_h5(path):  # the checks every read gets (links, a regular file)
        pass
    buffer = io.BytesIO(Path(path).read_bytes())
    with h5py.File(buffer, "r+") as handle:
        write(handle)
    write_bytes(path, buffer.getvalue())


def create_trials_file(path: str | Path, *, schema: str, schema_version: str, sensor_id: str,
                       config: Mapping[str, Any]) -> None:
    """Write a new, empty file of trials (provenance, ``complete`` false, a ``trials`` group)
    atomically: the study writers' start."""
    def write(handle: h5py.File) -> None:
        write_provenance(handle, schema=schema, schema_version=schema_version,
                         sensor_id=sensor_id, config=config)
        handle.attrs["complete"] = False
        handle.create_group("trials")

    write_whole(path, write)


def read_sensor_id(path: str | Path) -> str:
    """The ``sensor_id`` a whiskercal file was written for ("" when it names none)."""
    with open_h5(path) as handle:
        return as_text(handle.attrs.get("sensor_id", ""))


def refuse_to_replace_run(path: Path, resume: bool, force: bool, what: str,
                          journal: Path | None = None) -> None:
    """The output rule for a file a run writes as it goes (a raw dataset, a study): an existing
    one is refused unless ``force``; a partial one (readable, not marked ``complete``, or with
    its ``journal`` beside it) is continued with ``resume``, never replaced, even with
    ``force``; and there must be something to continue."""
    if resume and force:
        raise UsageError(f"--resume continues the {what} in --out and --force replaces it: "
                         "give one")
    journaled = journal is not None and journal.exists()
    if resume:
        if not path.exists() and not journaled:
            raise UsageError(f"{path} does not exist: nothing to resume")
        return
    if journaled:
        raise UsageError(f"{journal} is the journal of an interrupted run of {path}; continue "
                         "it with --resume, or delete the journal to discard it")
    if not path.exists():
        return
    if not force:
        raise UsageError(f"the {what} {path} already exists: pass --force to replace it, or "
                         "--resume to continue it")
    if _marked_incomplete(path):
        raise UsageError(f"{path} is a partial {what}: continue it with --resume (--force "
                         f"replaces only a finished one; delete a partial one to discard it)")


def _marked_incomplete(path: Path) -> bool:
    """True for a readable file whose ``complete`` attribute is false (an unreadable file holds
    no run to continue)."""
    try:
        with open_h5(path) as handle:
            return not bool(handle.attrs.get("complete", False))
    except ArtifactError:
        return False


def other_sensor(expected_id: str, path: str | Path, what: str, allow: bool) -> str | None:
    """Refuse a file of another sensor than ``expected_id`` (its ``sensor_id`` attribute) with
    :class:`UsageError`; with ``allow``, return the warning instead. None when they match."""
    found = read_sensor_id(path)
    if found == expected_id:
        return None
    message = (f"{what} {path} was recorded on sensor {found or 'unnamed'!r}, the calibration "
               f"on {expected_id!r}")
    if not allow:
        raise UsageError(f"{message}: its results would not be this sensor's (pass "
                         "--allow-other-sensor to use it anyway)")
    return message


# what reading a file of a known schema raises when its content is not what the schema says
_MALFORMED = (KeyError, ValueError, TypeError, IndexError, AttributeError)


@contextlib.contextmanager
def malformed_is_an_error(path: str | Path, what: str) -> Iterator[None]:
    """Turn what a reader raises on content the schema does not allow (a missing group or
    attribute, text where a number belongs, a non-JSON config, columns of other lengths) into
    one :class:`ArtifactError` naming the file and the fault (``--debug`` shows the cause)."""
    try:
        yield
    except _MALFORMED as error:
        detail = f"missing {error}" if isinstance(error, KeyError) else f"{error}"
        raise ArtifactError(f"{path}: malformed {what} ({detail})") from error
