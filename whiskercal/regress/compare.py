"""Compare recomputed quantities with their golden values, each within its tolerance."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from whiskercal.regress.tolerances import CLASSES, EXACT, ToleranceClass


@dataclass(frozen=True)
class Change:
    """One quantity that differs from its golden value beyond its tolerance.

    ``kind`` is ``"moved"`` (both present), ``"added"`` (no golden value) or ``"removed"``
    (no recomputed value).
    """

    name: str
    kind: str
    golden: Any
    value: Any
    tolerance: ToleranceClass

    @property
    def difference(self) -> float | None:
        """value - golden for two finite numbers, else None."""
        if _is_number(self.golden) and _is_number(self.value):
            return float(self.value) - float(self.golden)
        return None

    def describe(self) -> str:
        """One line: the quantity, both values, by how much it moved and the allowed bound."""
        if self.kind != "moved":
            return f"{self.name}: {self.kind} (golden {_show(self.golden)}, now {_show(self.value)})"
        bound = self.tolerance
        line = f"{self.name}: {_show(self.golden)} -> {_show(self.value)}"
        if self.difference is not None and math.isfinite(self.difference):
            line += (f", moved {self.difference:+.3g} (allowed {bound.abs_tol:.3g} + "
                     f"{bound.rel_tol:.3g}·|golden|, {bound.name})")
        return line

    def as_dict(self) -> dict:
        """JSON-able form."""
        return {"name": self.name, "kind": self.kind, "golden": _json(self.golden),
                "value": _json(self.value), "difference": _json(self.difference),
                "tolerance": self.tolerance.name, "abs_tol": self.tolerance.abs_tol,
                "rel_tol": self.tolerance.rel_tol}


def compare(golden: dict[str, Any], classes: dict[str, str], new: dict[str, Any]) -> list[Change]:
    """Every quantity of ``golden`` or ``new`` that is not within its tolerance.

    Parameters
    ----------
    golden
        Name -> golden value (None stands for NaN, as JSON has no NaN).
    classes
        Name -> tolerance class name of each golden quantity.
    new
        Name -> recomputed value.
    """
    changes = []
    for name in list(golden) + [n for n in new if n not in golden]:
        tolerance = CLASSES.get(classes.get(name, ""), EXACT)
        if name not in new:
            changes.append(Change(name, "removed", golden[name], None, tolerance))
        elif name not in golden:
            changes.append(Change(name, "added", None, new[name], tolerance))
        elif not _agrees(golden[name], new[name], tolerance):
            changes.append(Change(name, "moved", golden[name], new[name], tolerance))
    return changes


def _agrees(golden: Any, new: Any, tolerance: ToleranceClass) -> bool:
    golden, new = _nan_for_none(golden), _nan_for_none(new)
    if not (_is_number(golden) and _is_number(new)):  # flags, labels, lists: equal or not
        return golden == new
    return tolerance.allows(float(golden), float(new))


def _nan_for_none(value: Any) -> Any:
    return math.nan if value is None else value


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _show(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.10g}"
    return "NaN" if value is None else str(value)


def _json(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
