"""Typed configuration tables: the value types every config file's keys are checked against.

Every TOML table whiskercal reads (collect, study, shaft study, follow, sensor files) is a
:class:`Table`, a frozen pydantic model. Its types are strict: a TOML boolean is not a number, a
float is not an integer and a string is not a number, so ``kp_mm_s_per_uT = true`` is refused
rather than run as 1.0. Every number is finite (a NaN compares false with everything, so it
would silently switch off a limit such as an overload guard), and a key no table declares is
refused, so a typo never silently falls back to a default.

A refusal is one :class:`~whiskercal.errors.UsageError` line naming the file, the table and the
key, e.g. ``cfg.toml [follow] kp_mm_s_per_uT: must be a number >= 0, not true``
(:func:`validate`).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Annotated, Any, Literal, TypeVar

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from whiskercal.errors import UsageError

__all__ = ["Flag", "Says", "Table", "Text", "choice", "integer", "number", "numbers", "says_of",
           "shown", "validate"]

TableT = TypeVar("TableT", bound="Table")
SHOWN_CHARS = 40  # a value in an error is cut to this many characters (a huge array stays one line)


@dataclass(frozen=True)
class Says:
    """What a value must be, completing "must be ..." in an error (kept in a type's metadata)."""

    text: str


Flag = Annotated[bool, Field(strict=True), Says("true or false")]
Text = Annotated[str, Field(strict=True), Says("a string")]


def _bounds_text(bounds: dict[str, float]) -> str:
    low = next((f"{'>' if op == 'gt' else '>='} {bounds[op]:g}" for op in ("gt", "ge")
                if bounds.get(op) is not None), "")
    high = next((f"{'<' if op == 'lt' else '<='} {bounds[op]:g}" for op in ("lt", "le")
                 if bounds.get(op) is not None), "")
    return " and ".join(part for part in (low, high) if part)


def number(*, gt: float | None = None, ge: float | None = None, lt: float | None = None,
           le: float | None = None, says: str = "") -> Any:
    """The type of a finite number (an int is taken as a float; a bool or a string is not)
    within the bounds given."""
    bounds = {"gt": gt, "ge": ge, "lt": lt, "le": le}
    text = says or " ".join(part for part in ("a number", _bounds_text(bounds)) if part)
    return Annotated[float, Field(strict=True, allow_inf_nan=False, **bounds), Says(text)]


def choice(*options: str) -> Any:
    """The type of a string that is one of ``options``."""
    return Annotated[Literal[options], Says(f"one of {', '.join(options)}")]


def integer(*, ge: int | None = None, le: int | None = None) -> Any:
    """The type of a whole number (a float such as 3.0 or a bool is not one) in ge..le."""
    if ge is not None and le is not None:
        text = f"an integer in {ge}..{le}"
    else:
        text = " ".join(part for part in ("an integer", _bounds_text({"ge": ge, "le": le})) if part)
    return Annotated[int, Field(strict=True, ge=ge, le=le), Says(text)]


def numbers(length: int | None = None, *, least: int = 1, most: int | None = None,
            gt: float | None = None, ge: float | None = None, says: str = "") -> Any:
    """The type of a list of finite numbers (a tuple once read): exactly ``length`` of them, or
    ``least`` to ``most``; each within the bounds given."""
    item = Annotated[float, Field(strict=True, allow_inf_nan=False, gt=gt, ge=ge)]
    least, most = (length, length) if length is not None else (least, most)
    count = f"{least}" if least == most else f"{least} to {most}" if most else f"at least {least}"
    bound = _bounds_text({"gt": gt, "ge": ge})
    text = says or f"a list of {count} numbers" + (f" {bound}" if bound else "")
    return Annotated[tuple[item, ...], Field(min_length=least, max_length=most), Says(text)]


class Table(BaseModel):
    """A config table: frozen, typed, unknown keys refused; read like a frozen dataclass."""

    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able values (tuples become lists), in the order the keys are declared."""
        return self.model_dump(mode="json")

    def replace(self: TableT, **changes: Any) -> TableT:
        """A copy with some keys changed, checked as a new table is (one UsageError line)."""
        return validate(type(self), {**dict(self), **changes}, type(self).__name__)


def validate(model: type[TableT], values: Any, where: str) -> TableT:
    """``values`` (nested dicts, as TOML gives them) as ``model``, or one UsageError line.

    Parameters
    ----------
    model : type of Table
        The table (its fields may be tables themselves: TOML's nested tables).
    values : Any
        What the file holds.
    where : str
        Names the source at the start of the error (a file's path).
    """
    try:
        return model.model_validate(values)
    except ValidationError as error:
        raise refusal(error, model, values, where) from None
    except RecursionError:  # values nested past what can be walked
        raise UsageError(f"{where}: values nested too deep") from None


def refusal(error: ValidationError, model: type[Table], values: Any, where: str) -> UsageError:
    """The first problem ``error`` reports, as ``where [table] key: must be ..., not ...``."""
    problem = error.errors(include_url=False)[0]
    tables, key, field = _locate(model, problem["loc"])
    place = where + (f" [{'.'.join(tables)}]" if tables else "") + (f" {key}" if key else "")
    given = _value_at(values, [*tables, key] if key else tables)
    kind = problem["type"]
    if kind == "extra_forbidden":
        known = ", ".join(_fields(model, tables))
        if not tables and isinstance(given, dict):
            return UsageError(f"{where} [{key}]: unknown table (known: {known})")
        return UsageError(f"{place}: unknown key (known: {known})")
    if kind in ("value_error", "assertion_error"):
        return UsageError(f"{place}: {problem['ctx']['error']}")
    if kind == "finite_number":  # TOML's nan and inf are floats, but no limit holds with them
        inside = len(problem["loc"]) > len(tables) + 1
        what = f"{says_of(field)}, each finite" if inside else "a finite number"
        return UsageError(f"{place}: must be {what}, not {shown(given)}")
    if kind == "missing" and len(problem["loc"]) == len(tables) + 1:
        return UsageError(f"{place}: missing; it must be {says_of(field)}")
    return UsageError(f"{place}: must be {says_of(field)}, not {shown(given)}")


def _locate(model: type[Table], loc: tuple) -> tuple[list[str], str, Any]:
    """The tables, the key and the key's field along a pydantic error location."""
    tables, current = [], model
    for part in loc:
        field = current.model_fields.get(part) if isinstance(part, str) else None
        if field is None:
            return tables, str(part), None
        kind = field.annotation
        if isinstance(kind, type) and issubclass(kind, Table):
            tables.append(part)
            current = kind
            continue
        return tables, part, field
    return tables, "", None


def _fields(model: type[Table], tables: list[str]) -> list[str]:
    for name in tables:
        model = model.model_fields[name].annotation
    return list(model.model_fields)


def _value_at(values: Any, path: list[str]) -> Any:
    for name in path:
        if not isinstance(values, dict):
            return values
        values = values.get(name)
    return values


def says_of(field: Any) -> str:
    """What a model field's value must be (completing "must be ..."); ``field`` is a pydantic
    FieldInfo, or None for a table."""
    if field is None:
        return "a table of keys"
    for item in field.metadata:
        if isinstance(item, Says):
            return item.text
    kind = field.annotation
    if isinstance(kind, type) and issubclass(kind, Table):
        return "a table of keys"
    return {bool: "true or false", str: "a string"}.get(kind, str(kind))


def shown(value: Any, room: int = SHOWN_CHARS) -> str:
    """A value as TOML writes it (strings quoted, true/false, nan), cut to ``room`` characters."""
    text = _toml(value, depth=4)
    return text if len(text) <= room else text[:room - 3] + "..."


def _toml(value: Any, depth: int) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    if isinstance(value, str):
        return json.dumps(value[:SHOWN_CHARS], ensure_ascii=False)
    if isinstance(value, (list, tuple, dict)) and depth == 0:
        return "..."
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(item, depth - 1) for item in value[:8]) + "]"
    if isinstance(value, dict):
        items = list(value.items())[:8]
        return "{" + ", ".join(f"{key} = {_toml(item, depth - 1)}" for key, item in items) + "}"
    return repr(value)
