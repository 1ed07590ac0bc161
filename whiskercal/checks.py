"""One checker for every number a user hands in: options, URL query values, config keys.

Each reader names where a value came from (``--speed``, ``sim:// option seed``, ``CFG.toml
[grid] reach_min_mm``) and what it expects; a value that is not a number, not finite, or out of
range becomes one :class:`UsageError` line naming both, before anything moves or is written.
"""

from __future__ import annotations

import math

from whiskercal.errors import UsageError


def number(value, name: str, *, low: float = -math.inf, high: float = math.inf,
           low_open: bool = False, unit: str = "") -> float:
    """``value`` (a number or its text) as a finite float in [low, high] (low excluded when
    ``low_open``), or a UsageError naming ``name``."""
    try:
        result = float(value)
    except (TypeError, ValueError):
        raise UsageError(f"{name} must be a number, not {value!r}") from None
    below = result <= low if low_open else result < low
    if not math.isfinite(result) or below or result > high:
        raise UsageError(f"{name} must be {_range_text(low, high, low_open, unit)}, not {value!r}")
    return result


def positive(value, name: str, *, high: float = math.inf, unit: str = "") -> float:
    """``value`` as a finite number > 0 (and <= ``high``)."""
    return number(value, name, low=0.0, low_open=True, high=high, unit=unit)


def integer(value, name: str, *, low: int | None = None, high: int | None = None) -> int:
    """``value`` (an int or its decimal text) as an int in [``low``, ``high``], or a UsageError."""
    if isinstance(value, bool):
        raise UsageError(f"{name} must be an integer, not {value!r}")
    try:
        result = int(value) if isinstance(value, int) else int(str(value).strip(), 10)
    except ValueError:
        raise UsageError(f"{name} must be an integer, not {value!r}") from None
    if low is not None and result < low:
        raise UsageError(f"{name} must be an integer >= {low}, not {value!r}")
    if high is not None and result > high:
        raise UsageError(f"{name} must be an integer <= {high}, not {value!r}")
    return result


# seeds are stored as 64-bit HDF5 attributes and fed to numpy's generators: 0 .. 2**32 - 1
SEED_MAX = 2**32 - 1


def seed(value, name: str = "--seed") -> int:
    """``value`` as a random seed in [0, :data:`SEED_MAX`], or a UsageError."""
    return integer(value, name, low=0, high=SEED_MAX)


def _range_text(low: float, high: float, low_open: bool, unit: str) -> str:
    unit = f" {unit}" if unit else ""
    if low == 0 and low_open and high == math.inf:
        return f"a finite number > 0{unit}"
    if high == math.inf:
        return "a finite number" + ("" if low == -math.inf else f" {'>' if low_open else '>='} {low:g}") + unit
    if low == -math.inf:
        return f"a finite number <= {high:g}{unit}"
    return f"a finite number in {'(' if low_open else '['}{low:g}, {high:g}]{unit}"
