"""The measurement model z = f(x, y): a bivariate polynomial fitted in a scaled Legendre basis.

The polynomial's two variables are either the whisker-frame coordinates (x, y) in mm
("cartesian", the paper's model) or polar coordinates about the frame's origin, (r mm, θ rad)
("polar", the default). Deflection is mostly a function of the contact's direction from the
root, so in polar coordinates z is far smoother: at the same degree it leaves a smaller
residual than in Cartesian coordinates, and the lookup traced from it lies closer to the twin's
true tips (``whiskercal regress`` and ``bench --only surface-degree`` measure both).

Either pair is mapped to u, v in [-1, 1] from the data's bounding box, so no raw powers of
millimetres enter the least squares. The basis is the total-degree Legendre set P_i(u) P_j(v),
i + j <= degree. For evaluation the Legendre coefficients are converted once to monomials in
(u, v), which on [-1, 1] stay well conditioned up to degree 8, and evaluated with small matrix
products (vectorized) or a scalar path for the tracer.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import math

import numpy as np
from numpy.polynomial import legendre as _leg

from whiskercal.model.errors import FitError

MAX_DEGREE = 8
MAX_CONDITION = 1e8  # of the scaled design matrix; beyond it the fit is refused, not trusted


def to_coordinates(points_mm: np.ndarray, coordinates: str) -> np.ndarray:
    """The basis' variables (..., 2): (x, y) mm, or (r mm, θ rad) about the frame's origin."""
    points_mm = np.asarray(points_mm, float)
    if coordinates == "cartesian":
        return points_mm
    if coordinates == "polar":
        return np.stack([np.hypot(points_mm[..., 0], points_mm[..., 1]),
                         np.arctan2(points_mm[..., 1], points_mm[..., 0])], axis=-1)
    raise FitError(f"unknown surface coordinates {coordinates!r}; choose polar or cartesian")


def term_indices(degree: int) -> np.ndarray:
    """(n_terms, 2) exponent pairs (i, j) with i + j <= degree, in a fixed order."""
    return np.array([(i, total - i) for total in range(degree + 1) for i in range(total, -1, -1)])


@dataclass(frozen=True)
class Scaling:
    """Affine map of the basis' variables onto [-1, 1]: u = (a - center) / half_width.

    ``center`` and ``half_width`` are in the variables' units (mm, or mm and rad for polar).
    """

    center: np.ndarray
    half_width: np.ndarray

    @classmethod
    def from_points(cls, variables: np.ndarray) -> "Scaling":
        """Scaling that maps the bounding box of ``variables`` (n, 2) onto [-1, 1]^2."""
        low, high = variables.min(axis=0), variables.max(axis=0)
        half = (high - low) / 2.0
        if np.any(half <= 0):
            raise FitError("the grid spans no area: all points share one coordinate")
        return cls((high + low) / 2.0, half)

    def apply(self, variables: np.ndarray) -> np.ndarray:
        """Scaled variables (..., 2) in [-1, 1] over the data."""
        return (np.asarray(variables, float) - self.center) / self.half_width


def design_matrix(uv: np.ndarray, degree: int) -> np.ndarray:
    """Legendre design matrix (n, n_terms) at scaled points ``uv`` (n, 2)."""
    vu = _leg.legvander(uv[:, 0], degree)
    vv = _leg.legvander(uv[:, 1], degree)
    terms = term_indices(degree)
    return vu[:, terms[:, 0]] * vv[:, terms[:, 1]]


def _legendre_to_monomial(coefficients: np.ndarray, degree: int) -> np.ndarray:
    """(degree+1, degree+1) matrix M with f = sum M[i, j] u^i v^j."""
    legendre_grid = np.zeros((degree + 1, degree + 1))
    for (i, j), c in zip(term_indices(degree), coefficients):
        legendre_grid[i, j] = c
    to_mono = np.zeros((degree + 1, degree + 1))  # column k: monomial coefficients of P_k
    for k in range(degree + 1):
        unit = np.zeros(k + 1)
        unit[k] = 1.0
        to_mono[: k + 1, k] = _leg.leg2poly(unit)
    return to_mono @ legendre_grid @ to_mono.T


@dataclass
class Surface:
    """A fitted z = f(x, y) (z in µT, x and y in mm, whisker frame).

    Attributes
    ----------
    degree : int
        Total polynomial degree.
    coefficients : ndarray
        Legendre coefficients in the order of :func:`term_indices`.
    scaling : Scaling
        The map of the basis' variables onto [-1, 1].
    coordinates : str
        "polar" (r, θ about the origin) or "cartesian" (x, y).
    """

    degree: int
    coefficients: np.ndarray
    scaling: Scaling
    coordinates: str = "polar"
    _mono: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.coefficients = np.asarray(self.coefficients, float)
        self._mono = _legendre_to_monomial(self.coefficients, self.degree)
        powers = np.arange(self.degree + 1)
        self._du = (self._mono * powers[:, None])[1:, :] / self.scaling.half_width[0]
        self._dv = (self._mono * powers[None, :])[:, 1:] / self.scaling.half_width[1]
        # the monomial matrix is upper-left triangular (i + j <= degree): keep only that part
        self._mono_list = [row[: self.degree + 1 - i] for i, row in enumerate(self._mono.tolist())]
        self._scalar_map = (float(self.scaling.center[0]), float(self.scaling.center[1]),
                            float(self.scaling.half_width[0]), float(self.scaling.half_width[1]))
        self._polar = self.coordinates == "polar"
        to_coordinates(np.zeros(2), self.coordinates)  # refuse an unknown name now

    @staticmethod
    def _powers(s: np.ndarray, n: int) -> np.ndarray:
        out = np.empty(s.shape + (n,))
        out[..., 0] = 1.0
        for k in range(1, n):
            out[..., k] = out[..., k - 1] * s
        return out

    @staticmethod
    def _bilinear(pu: np.ndarray, matrix: np.ndarray, pv: np.ndarray) -> np.ndarray:
        return np.sum((pu @ matrix) * pv, axis=-1)

    def __call__(self, points_mm: np.ndarray) -> np.ndarray:
        """f at points (..., 2) mm -> (...) µT, vectorized."""
        uv = self.scaling.apply(to_coordinates(points_mm, self.coordinates))
        pu, pv = self._powers(uv[..., 0], self.degree + 1), self._powers(uv[..., 1], self.degree + 1)
        return self._bilinear(pu, self._mono, pv)

    def gradient(self, points_mm: np.ndarray) -> np.ndarray:
        """(df/dx, df/dy) at points (..., 2) mm -> (..., 2) µT/mm, vectorized."""
        points_mm = np.asarray(points_mm, float)
        uv = self.scaling.apply(to_coordinates(points_mm, self.coordinates))
        n = self.degree + 1
        pu, pv = self._powers(uv[..., 0], n), self._powers(uv[..., 1], n)
        da = self._bilinear(pu[..., : n - 1], self._du, pv)
        db = self._bilinear(pu, self._dv, pv[..., : n - 1])
        if not self._polar:
            return np.stack([da, db], axis=-1)
        x, y = points_mm[..., 0], points_mm[..., 1]
        r2 = x * x + y * y
        r = np.sqrt(r2)
        return np.stack([da * x / r - db * y / r2, da * y / r + db * x / r2], axis=-1)

    def value_and_gradient(self, x_mm: float, y_mm: float) -> tuple[float, float, float]:
        """f, df/dx, df/dy at one point, in plain floats (the tracer's inner loop)."""
        if not self._polar:
            return self._scalar(x_mm, y_mm)
        r2 = x_mm * x_mm + y_mm * y_mm
        r = math.sqrt(r2)
        f, fr, ft = self._scalar(r, math.atan2(y_mm, x_mm))
        return f, fr * x_mm / r - ft * y_mm / r2, fr * y_mm / r + ft * x_mm / r2

    def _scalar(self, a: float, b: float) -> tuple[float, float, float]:
        ca, cb, ha, hb = self._scalar_map
        u, v = (a - ca) / ha, (b - cb) / hb
        f = fu = fv = 0.0
        # Horner in u over rows, each row a polynomial in v (and its v-derivative)
        for row in reversed(self._mono_list):
            row_value = row_dv = 0.0
            for c in reversed(row):
                row_dv = row_dv * v + row_value
                row_value = row_value * v + c
            fu = fu * u + f
            f = f * u + row_value
            fv = fv * u + row_dv
        return f, fu / ha, fv / hb


@dataclass(frozen=True)
class FitReport:
    """How well a surface fits its data (µT) and the per-degree cross-validation evidence."""

    rmse_uT: float
    r2: float
    cv_rmse_uT: float
    condition_number: float
    degrees: np.ndarray          # degrees tried
    cv_rmse_by_degree: np.ndarray  # mean k-fold RMSE per degree (NaN when not identifiable)
    cv_se_by_degree: np.ndarray    # its standard error across folds


def _lstsq(variables: np.ndarray, z_uT: np.ndarray, degree: int,
           scaling: Scaling) -> tuple[np.ndarray, float]:
    a = design_matrix(scaling.apply(variables), degree)
    if a.shape[0] < a.shape[1]:
        raise FitError(f"degree {degree} needs {a.shape[1]} points, the grid has {a.shape[0]}")
    column_norms = np.linalg.norm(a, axis=0)
    condition = float(np.linalg.cond(a / column_norms))
    if not np.isfinite(condition) or condition > MAX_CONDITION:
        raise FitError(f"degree {degree} is ill-conditioned on this grid (condition {condition:.3g})")
    solution, *_ = np.linalg.lstsq(a / column_norms, z_uT, rcond=None)
    return solution / column_norms, condition


def fit_fixed(points_mm: np.ndarray, z_uT: np.ndarray, degree: int, coordinates: str = "polar",
              scaling: Scaling | None = None) -> tuple[Surface, float]:
    """Least-squares surface of one degree; returns it with its design condition number."""
    variables, z_uT = to_coordinates(points_mm, coordinates), np.asarray(z_uT, float)
    scaling = scaling or Scaling.from_points(variables)
    coefficients, condition = _lstsq(variables, z_uT, degree, scaling)
    return Surface(degree, coefficients, scaling, coordinates), condition


def kfold_rmse(points_mm: np.ndarray, z_uT: np.ndarray, degree: int, coordinates: str = "polar",
               folds: int = 5, seed: int = 0) -> tuple[float, float]:
    """Mean and standard error of the k-fold cross-validated RMSE (µT) at one degree."""
    order = np.random.default_rng(seed).permutation(len(z_uT))
    # one scaling for all folds, so a fold does not extrapolate its own basis
    scaling = Scaling.from_points(to_coordinates(points_mm, coordinates))
    fold_rmse = []
    for held in np.array_split(order, folds):
        train = np.setdiff1d(order, held)
        surface, _ = fit_fixed(points_mm[train], z_uT[train], degree, coordinates, scaling)
        fold_rmse.append(np.sqrt(np.mean((surface(points_mm[held]) - z_uT[held]) ** 2)))
    fold_rmse = np.asarray(fold_rmse)
    return float(fold_rmse.mean()), float(fold_rmse.std(ddof=1) / np.sqrt(folds))


def cross_validate(points_mm: np.ndarray, z_uT: np.ndarray, degrees=range(1, MAX_DEGREE + 1),
                   coordinates: str = "polar", folds: int = 5, seed: int = 0,
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-degree CV RMSE mean and standard error; NaN where a degree cannot be fitted."""
    degrees = np.asarray(list(degrees))
    means, errors = np.full(len(degrees), np.nan), np.full(len(degrees), np.nan)
    for k, degree in enumerate(degrees):
        try:
            means[k], errors[k] = kfold_rmse(points_mm, z_uT, int(degree), coordinates, folds, seed)
        except FitError:
            continue
    return degrees, means, errors


def choose_degree(degrees: np.ndarray, cv_mean: np.ndarray, cv_se: np.ndarray) -> int:
    """The smallest degree whose CV RMSE is within one standard error of the best (1-SE rule)."""
    if not np.any(np.isfinite(cv_mean)):
        raise FitError("no polynomial degree could be fitted to this grid")
    best = int(np.nanargmin(cv_mean))
    limit = cv_mean[best] + cv_se[best]
    return int(degrees[np.flatnonzero(cv_mean <= limit)[0]])


def fit_surface(points_mm: np.ndarray, z_uT: np.ndarray, degree: int | str = 5,
                coordinates: str = "polar", folds: int = 5, seed: int = 0,
                ) -> tuple[Surface, FitReport]:
    """Fit z = f(x, y) and report RMSE, R², CV RMSE and the per-degree evidence.

    Parameters
    ----------
    points_mm : ndarray (n, 2)
        Contact positions in the whisker frame, mm.
    z_uT : ndarray (n,)
        Deflection measurements, µT.
    degree : int or "auto"
        Total degree, or "auto" for the 1-SE rule over k-fold CV RMSE (degrees 1..8).
    coordinates : str
        "polar" (r, θ about the origin; the default) or "cartesian" (x, y; the paper's).
    folds, seed : int
        k of the cross-validation and the seed of its shuffle.
    """
    points_mm, z_uT = np.asarray(points_mm, float), np.asarray(z_uT, float)
    if points_mm.ndim != 2 or points_mm.shape[1] != 2 or len(points_mm) != len(z_uT):
        raise FitError("points must be (n, 2) mm and z (n,) µT of the same length")
    if not (np.all(np.isfinite(points_mm)) and np.all(np.isfinite(z_uT))):
        raise FitError("the grid holds non-finite positions or deflections")
    if degree != "auto" and not 1 <= int(degree) <= MAX_DEGREE:
        raise FitError(f"degree must be 1..{MAX_DEGREE} or 'auto', not {degree}")
    degrees, cv_mean, cv_se = cross_validate(points_mm, z_uT, coordinates=coordinates, folds=folds,
                                             seed=seed)
    chosen = choose_degree(degrees, cv_mean, cv_se) if degree == "auto" else int(degree)
    surface, condition = fit_fixed(points_mm, z_uT, chosen, coordinates)
    residual = surface(points_mm) - z_uT
    rmse = float(np.sqrt(np.mean(residual ** 2)))
    r2 = float(1.0 - np.sum(residual ** 2) / np.sum((z_uT - z_uT.mean()) ** 2))
    report = FitReport(rmse, r2, float(cv_mean[degrees == chosen][0]), condition, degrees, cv_mean,
                       cv_se)
    return surface, report
