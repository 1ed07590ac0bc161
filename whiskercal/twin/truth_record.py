"""The twin's ground-truth record: what the rig really did at every sample the sensor converted."""

from __future__ import annotations

import numpy as np

from whiskercal.twin.physics.whisker import EQUILIBRIUM_KINDS

_KINDS = (*EQUILIBRIUM_KINDS, "failed")


class TruthRecord:
    """Ground truth of every converted sample, stored in growing numpy blocks.

    Columns: ``t_s``; ``stage_mm`` (2, true carriage position, machine coordinates);
    ``tool_mm`` (2, the end effector in the whisker frame); ``contact_mm`` (2, NaN when free);
    ``tip_mm`` (2); ``root_rotation_rad``; ``z_true_uT`` (noise-free Y minus static Y);
    ``field_true_uT`` (3, noise-free field in sensor axes); ``kind`` (``free``, ``shaft``,
    ``tip``, ``tangential``, or ``failed`` where the solver gave up and the previous
    equilibrium was kept); ``slips`` (stick-slip events of the plane's tip since the previous
    sample).
    """

    _COLUMNS = {"t_s": 1, "stage_mm": 2, "tool_mm": 2, "contact_mm": 2, "tip_mm": 2,
                "root_rotation_rad": 1, "z_true_uT": 1, "field_true_uT": 3, "slips": 1}
    _WIDTH = sum(_COLUMNS.values())

    def __init__(self, block_rows: int = 65536) -> None:
        self._block_rows = block_rows
        self._blocks: list[np.ndarray] = []
        self._kinds: list[np.ndarray] = []
        self._rows_in_last = block_rows

    def __len__(self) -> int:
        return max(len(self._blocks) - 1, 0) * self._block_rows + (self._rows_in_last if self._blocks else 0)

    @classmethod
    def width(cls) -> int:
        """Floats in one row."""
        return cls._WIDTH

    @staticmethod
    def fill_row(row: np.ndarray, t_s: float, stage_mm: np.ndarray, tool_mm: np.ndarray,
                 equilibrium, field_uT: np.ndarray, z_uT: float, slips: int) -> None:
        """Fill one row of ``width()`` floats in place, in column order."""
        row[0] = t_s
        row[1:3] = stage_mm
        row[3:5] = tool_mm
        row[5:7] = equilibrium.contact_mm
        row[7:9] = equilibrium.tip_mm
        row[9] = equilibrium.root_rotation_rad
        row[10] = z_uT
        row[11:14] = field_uT
        row[14] = slips

    def extend(self, rows: np.ndarray, kinds: list[str]) -> None:
        """Rows of ``width()`` floats in column order, and their equilibrium kinds."""
        codes = np.array([_KINDS.index(k) if k in _KINDS else len(_KINDS) - 1 for k in kinds], dtype=np.int8)
        done = 0
        while done < len(rows):
            if self._rows_in_last == self._block_rows:
                self._blocks.append(np.empty((self._block_rows, self._WIDTH)))
                self._kinds.append(np.empty(self._block_rows, dtype=np.int8))
                self._rows_in_last = 0
            take = min(len(rows) - done, self._block_rows - self._rows_in_last)
            self._blocks[-1][self._rows_in_last:self._rows_in_last + take] = rows[done:done + take]
            self._kinds[-1][self._rows_in_last:self._rows_in_last + take] = codes[done:done + take]
            self._rows_in_last += take
            done += take

    def arrays(self) -> dict[str, np.ndarray]:
        """All records as named arrays (a copy)."""
        if not self._blocks:
            table, kinds = np.empty((0, self._WIDTH)), np.empty(0, dtype=np.int8)
        else:
            table = np.concatenate(self._blocks[:-1] + [self._blocks[-1][:self._rows_in_last]])
            kinds = np.concatenate(self._kinds[:-1] + [self._kinds[-1][:self._rows_in_last]])
        out, column = {}, 0
        for name, width in self._COLUMNS.items():
            values = table[:, column:column + width]
            out[name] = values[:, 0] if width == 1 else values
            column += width
        out["kind"] = np.array(_KINDS)[kinds] if len(kinds) else np.empty(0, dtype="<U10")
        return out

    def __getattr__(self, name: str) -> np.ndarray:
        if name in self._COLUMNS or name == "kind":
            return self.arrays()[name]
        raise AttributeError(name)
