"""JSON for numpy values: one ``default=`` hook for every JSON whiskercal writes."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np


def jsonable(value: Any) -> Any:
    """``json.dumps(default=...)`` hook: arrays become lists, numpy scalars numbers, paths text."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"not JSON serializable: {type(value).__name__}")
