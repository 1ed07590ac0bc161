"""A measurement surface made of radial patches, blended smoothly where they meet.

One polynomial over the whole reach of a whisker cannot follow z near the root, where a
millimetre across the whisker moves z by hundreds of µT, and still stay within a few µT of the
grid elsewhere. A patched surface gives each band of radial distance from the root its own
polynomial (:class:`~whiskercal.model.surface.Surface`) and blends neighbours over a band of
``blend_mm`` around each edge with a smoothstep in r, so value and gradient stay continuous.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from whiskercal.model.surface import Surface


def _smoothstep(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """3t² - 2t³ on [0, 1] (clipped) and its derivative in t."""
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t), 6.0 * t * (1.0 - t)


@dataclass
class PatchedSurface:
    """z = f(x, y) (µT, whisker frame mm) from patches ordered by radial distance.

    ``patches[k]`` holds between ``edges_mm[k - 1]`` and ``edges_mm[k]`` (radial distance from
    the origin, mm); across each edge the two neighbours are blended over ``blend_mm``.
    """

    patches: list[Surface]
    edges_mm: np.ndarray
    blend_mm: float = 4.0

    def __post_init__(self) -> None:
        self.edges_mm = np.asarray(self.edges_mm, float).reshape(-1)
        if len(self.patches) != len(self.edges_mm) + 1 or np.any(np.diff(self.edges_mm) <= 0):
            raise ValueError("a patched surface needs one more patch than its increasing edges")
        if len(self.edges_mm) > 1 and np.min(np.diff(self.edges_mm)) < self.blend_mm:
            raise ValueError("the blends of neighbouring edges must not overlap")

    def _weights(self, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each patch's weight (k, ...) at radial distances r, and its derivative in r."""
        t = (r[None, ...] - self.edges_mm.reshape((-1,) + (1,) * r.ndim)) / self.blend_mm + 0.5
        step, step_slope = _smoothstep(t)
        ones, zeros = np.ones((1,) + r.shape), np.zeros((1,) + r.shape)
        below, above = np.concatenate([ones, step]), np.concatenate([step, zeros])
        below_slope = np.concatenate([zeros, step_slope])
        above_slope = np.concatenate([step_slope, zeros])
        weights = below * (1.0 - above)
        slopes = (below_slope * (1.0 - above) - below * above_slope) / self.blend_mm
        return weights, slopes

    def _only_patch(self, r: np.ndarray) -> Surface | None:
        """The one patch that alone holds every r (outside every blend), if there is one; the
        common case of a contact's batch, which then costs what one polynomial costs."""
        if r.size == 0:
            return self.patches[0]
        half = 0.5 * self.blend_mm
        low = int(np.searchsorted(self.edges_mm + half, r.min(), side="right"))
        high = int(np.searchsorted(self.edges_mm - half, r.max(), side="left"))
        return self.patches[low] if low == high else None

    def __call__(self, points_mm: np.ndarray) -> np.ndarray:
        """f at points (..., 2) mm -> (...) µT."""
        points_mm = np.asarray(points_mm, float)
        r = np.hypot(points_mm[..., 0], points_mm[..., 1])
        only = self._only_patch(r)
        if only is not None:
            return only(points_mm)
        weights, _ = self._weights(r)
        total = np.zeros(points_mm.shape[:-1])
        for weight, patch in zip(weights, self.patches):
            used = weight > 0.0  # a patch is evaluated only where it counts: the cost of one
            if np.any(used):
                total[used] += weight[used] * patch(points_mm[used])
        return total

    def gradient(self, points_mm: np.ndarray) -> np.ndarray:
        """(df/dx, df/dy) at points (..., 2) mm -> (..., 2) µT/mm."""
        points_mm = np.asarray(points_mm, float)
        r = np.hypot(points_mm[..., 0], points_mm[..., 1])
        only = self._only_patch(r)
        if only is not None:
            return only.gradient(points_mm)
        weights, slopes = self._weights(r)
        radial = points_mm / np.maximum(r, 1e-12)[..., None]
        total = np.zeros(points_mm.shape)
        for weight, slope, patch in zip(weights, slopes, self.patches):
            used = weight > 0.0
            if not np.any(used):
                continue
            at = points_mm[used]
            total[used] += weight[used][:, None] * patch.gradient(at)
            blended = used & (slope != 0.0)
            if np.any(blended):
                total[blended] += (slope[blended] * patch(points_mm[blended]))[:, None] \
                    * radial[blended]
        return total
