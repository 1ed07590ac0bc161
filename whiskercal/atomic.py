"""Files that are never destroyed: atomic replacement, inputs kept apart from outputs, paths kept
inside their folder.

Every final file whiskercal writes (artifacts, JSON, PNG figures, the HTML report, golden results)
is written under a temporary name in its own directory, flushed to disk, and renamed over the
destination; the directory is flushed too. A process killed at any moment therefore leaves the
old file or the new one, never a partial one (at worst a hidden ``.NAME.*.partial`` file beside
it). The rename also gives the destination a new inode, so writing never changes another name
that shares the old file (a hard link).

The incremental writers that checkpoint while a run goes (the raw grid's journal, the study's
per-trial updates) keep their own crash-safety design and do not use this module.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import IO

from whiskercal.errors import UsageError


def _fsync_path(path: Path, directory: bool = False) -> None:
    """Flush ``path`` (a file, or a directory's entries) to disk."""
    flags = os.O_RDONLY | (getattr(os, "O_DIRECTORY", 0) if directory else 0)
    fd = os.open(path, flags)
    try:
        os.fsync(fd)
    except OSError:
        if not directory:  # some file systems cannot flush a directory; the rename still holds
            raise
    finally:
        os.close(fd)


def _new_file_mode(path: Path) -> int:
    """The mode the destination would get from a plain ``open(path, "w")``: the old file's mode,
    else 0o666 less the umask (mkstemp creates 0o600)."""
    try:
        return path.stat().st_mode & 0o7777
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def _scratch_beside(path: Path) -> Path:
    """A new empty hidden file in ``path``'s folder; one clear error when the folder is read-only,
    full or missing."""
    try:
        fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".partial", dir=path.parent)
    except OSError as error:
        raise UsageError(f"cannot write {path}: {error.strerror or error}") from None
    os.close(fd)
    return Path(name)


def _put_in_place(scratch: Path, path: Path) -> None:
    try:
        _fsync_path(scratch)
        os.replace(scratch, path)
    except OSError as error:
        raise _write_failed(path, error) from None


def _write_failed(path: Path, error: OSError) -> UsageError:
    return UsageError(f"cannot write {path}: {error.strerror or error} (any old file is kept)")


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; when the block ends without an exception, the
    temporary file is flushed to disk and renamed over ``path`` (and the directory flushed).

    The temporary file exists (empty) when yielded: writers that truncate it (``h5py.File(.., "w")``,
    ``open(.., "w")``) may use it directly. On an exception it is removed and ``path`` is left as it
    was. The parent directory must exist. The temporary name does not end with ``path``'s suffix:
    writers that choose a format by suffix must be told the format.
    """
    path = Path(path)
    scratch = _scratch_beside(path)
    try:
        os.chmod(scratch, _new_file_mode(path))
        yield scratch
        _put_in_place(scratch, path)
    except BaseException:
        scratch.unlink(missing_ok=True)
        raise
    _fsync_path(path.parent, directory=True)


@contextlib.contextmanager
def atomic_open(path: str | Path, mode: str = "w", encoding: str | None = "utf-8") -> Iterator[IO]:
    """``open(path, mode)`` on a temporary file that replaces ``path`` atomically when the block
    ends without an exception (see :func:`atomic_path`). ``mode`` is "w" or "wb"."""
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_open writes a whole file: mode 'w' or 'wb', not {mode!r}")
    with atomic_path(path) as scratch:
        with open(scratch, mode, encoding=None if "b" in mode else encoding) as handle:
            yield handle


def write_text(path: str | Path, text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` atomically; return the path. A full disk or a read-only folder is
    one :class:`UsageError`, and the old file is left whole."""
    try:
        with atomic_open(path, "w", encoding=encoding) as handle:
            handle.write(text)
    except OSError as error:
        raise _write_failed(Path(path), error) from None
    return Path(path)


def write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; return the path (errors as :func:`write_text`)."""
    try:
        with atomic_open(path, "wb") as handle:
            handle.write(data)
    except OSError as error:
        raise _write_failed(Path(path), error) from None
    return Path(path)


@contextlib.contextmanager
def atomic_set(paths: Mapping[str, str | Path]) -> Iterator[dict[str, Path]]:
    """Like :func:`atomic_path` for a set of files written together: yield a temporary path for
    each, and rename them all over their destinations only when the block ends without an
    exception, so a failure while writing any of them (a full disk) leaves the old set whole.

    The renames come last and need no space; a kill between two of them leaves some files new.
    """
    scratch: dict[str, Path] = {}
    try:
        for key, path in paths.items():
            scratch[key] = _scratch_beside(Path(path))
            os.chmod(scratch[key], _new_file_mode(Path(path)))
        yield scratch
        for key, path in paths.items():
            _fsync_path(scratch[key])
        for key, path in paths.items():
            os.replace(scratch[key], path)
    except BaseException:
        for temporary in scratch.values():
            temporary.unlink(missing_ok=True)
        raise
    for folder in {Path(path).parent for path in paths.values()}:
        _fsync_path(folder, directory=True)


def refuse_existing(paths: Iterable[str | Path], force: bool, what: str = "the output") -> None:
    """The one rule for outputs: an existing output is refused with :class:`UsageError` unless
    ``force`` is set, and then the command replaces it atomically (by :func:`atomic_path`)."""
    if force:
        return
    for path in paths:
        if os.path.lexists(path):
            raise UsageError(f"{what} {path} already exists: pass --force to replace it")


def _same_file(a: Path, b: Path) -> bool:
    """True when both names reach one file (same name, a symbolic link, or a hard link)."""
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist (yet): compare where they would be
        return a.resolve() == b.resolve()


def refuse_input_as_output(out_path: str | Path, inputs: Iterable[str | Path | None],
                           what: str = "the output") -> None:
    """Raise :class:`UsageError` when ``out_path`` is one of ``inputs`` (the same file under any
    name: identical path, symbolic link or hard link: same device and inode).

    Writing it would replace a file the command reads.
    """
    out_path = Path(out_path)
    for source in inputs:
        if source is not None and _same_file(out_path, Path(source)):
            raise UsageError(f"{what} {out_path} is the input {source}: choose another output "
                             "path (an input is never overwritten)")


def inside(folder: str | Path, name: str | Path, what: str = "a path") -> Path:
    """``folder / name`` resolved (links followed), refused with :class:`UsageError` unless it
    lies inside ``folder``; for names taken from data files (``../x``, absolute paths, links out).
    """
    root = Path(folder).resolve()
    target = (root / name).resolve()
    if target != root and root not in target.parents:
        raise UsageError(f"{what} {name!s} leads outside {folder} (to {target}): refused")
    return target
