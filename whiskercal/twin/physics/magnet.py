"""The magnet under the suspension and the field it makes at the magnetometer.

An axially magnetized NdFeB cylinder hangs under the suspension, its axis along the whisker's
x axis, and moves rigidly with it: it turns by the root rotation about the centre of rotation (the
whisker frame's origin) and shifts by the root shift. The MLX90393 sits on the axis below it,
fixed to the base. Contacts that turn the whisker to -y swing the magnet, which sits on the far
side of the pivot, to +y and tilt its axis; the sensor's Y axis sees that.

Frames
------
Whisker frame: x along the undeflected whisker, y in the bending plane, w = x × y out of plane.
Sensor axes (what the MLX90393 reports): Z is the chip normal, pointing up at the magnet (+x);
Y is the deflection axis (+y); X = Y × Z (-w). A mounting misalignment tilts the chip about its
X axis by ``sensor_tilt_rad`` and moves it by ``sensor_offset_mm``; the tilt leaks the large
axial field into Y, which is the static Y reading a real sensor shows at rest.

The exact field of a uniformly magnetized cylinder comes from magpylib (Derby's closed form).
The simulated world needs one pose every 3.3 ms of simulated time and must run much faster than
real time, so :func:`field_uT` interpolates a table of exact values over (rotation, shift x,
shift y) with cubic B-splines (compiled with numba); poses outside the table fall back to the
exact field. :func:`interpolation_error_uT` measures how far the two differ.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import magpylib.core
import numba
import numpy as np
from scipy import ndimage

from whiskercal.errors import UsageError

TESLA_TO_UT = 1e6


# the field table's nodes, at most: each holds the exact field and its spline coefficients (3 + 3
# floats) besides the temporaries that compute them; a finer grid is refused before it is built
MAX_FIELD_GRID_NODES = 2_000_000


@dataclass(frozen=True)
class FieldGrid:
    """Where the interpolation table is valid: root rotation (rad) and root shift (mm) ranges.

    Poses outside these ranges are evaluated exactly (slower, still correct). ``pad_cells``
    extra nodes on every side keep the spline's boundary condition away from the valid box.
    The defaults cover every tip contact of the shipped sensors (root rotation within ±0.2 rad,
    shift within ±0.2 mm) with room to spare.
    """

    rotation_rad: tuple[float, float] = (-0.6, 0.6)
    shift_mm: tuple[float, float] = (-0.6, 0.6)
    rotation_step_rad: float = 0.01
    shift_step_mm: float = 0.1
    pad_cells: int = 8

    def __post_init__(self) -> None:
        for name in ("rotation_rad", "shift_mm"):
            low, high = getattr(self, name)
            if not (np.isfinite(low) and np.isfinite(high) and low < high):
                raise UsageError(f"FieldGrid.{name} must be an increasing pair of finite numbers.")
        if not (self.rotation_step_rad > 0 and self.shift_step_mm > 0 and self.pad_cells >= 2):
            raise UsageError("FieldGrid steps must be positive and pad_cells at least 2.")
        nodes = self.nodes()
        if nodes > MAX_FIELD_GRID_NODES:
            raise UsageError(f"the magnet's field grid (rotation step {self.rotation_step_rad:g} "
                             f"rad, shift step {self.shift_step_mm:g} mm) asks for {nodes:.3g} "
                             f"nodes, more than {MAX_FIELD_GRID_NODES:.0e}: choose coarser steps")

    def nodes(self) -> int:
        """How many nodes the field table holds (rotation x shift x shift, with the padding)."""
        count = [int(np.ceil((high - low) / step - 1e-9)) + 2 * self.pad_cells + 1
                 for (low, high), step in ((self.rotation_rad, self.rotation_step_rad),
                                           (self.shift_mm, self.shift_step_mm))]
        return count[0] * count[1] ** 2


@dataclass(frozen=True)
class MagnetParams:
    """The magnet, where it sits, and where the magnetometer sits (whisker frame, mm).

    Attributes
    ----------
    diameter_mm, height_mm : float
        Cylinder size; the axis lies along the whisker's x axis.
    polarization_T : float
        Magnetic polarization J (remanence of the material, T) along +x; negative means the
        north face looks down at the sensor, which makes contacts read negative on Y.
    magnet_center_mm : float
        Position of the magnet's centre on the x axis relative to the centre of rotation
        (negative: under the suspension, on the far side from the whisker).
    gap_mm : float
        Distance from the magnet's lower face to the magnetometer's sensing point.
    sensor_offset_mm : tuple of 3 float
        Mounting error of the sensing point (x, y, w) from its nominal place on the axis.
    sensor_tilt_rad : float
        Mounting tilt of the chip about its X axis; leaks the axial field into Y at rest.
    grid : FieldGrid
        Range and resolution of the interpolation table.
    """

    diameter_mm: float = 4.0
    height_mm: float = 2.0
    polarization_T: float = -1.3
    magnet_center_mm: float = -4.0
    gap_mm: float = 3.0
    sensor_offset_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    sensor_tilt_rad: float = 0.0
    grid: FieldGrid = field(default_factory=FieldGrid)

    def __post_init__(self) -> None:
        for name in ("diameter_mm", "height_mm", "gap_mm"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise UsageError(f"MagnetParams.{name} must be a positive number, got {value!r}.")
        numbers = (self.polarization_T, self.magnet_center_mm, self.sensor_tilt_rad, *self.sensor_offset_mm)
        if not (len(self.sensor_offset_mm) == 3 and np.all(np.isfinite(numbers))):
            raise UsageError("MagnetParams needs finite numbers and a sensor_offset_mm of (x, y, w).")

    def sensor_position_mm(self) -> np.ndarray:
        """Sensing point in the whisker frame (x, y, w), mm."""
        nominal_x = self.magnet_center_mm - self.height_mm / 2.0 - self.gap_mm
        return np.array([nominal_x, 0.0, 0.0]) + np.asarray(self.sensor_offset_mm, float)

    def sensor_axes(self) -> np.ndarray:
        """Rows are the sensor's X, Y, Z axes as unit vectors in the whisker frame (x, y, w)."""
        tilt = self.sensor_tilt_rad
        x_axis = np.array([0.0, 0.0, -1.0])
        # A tilt about X turns Y towards Z: Y picks up the axial (x) field.
        y_axis = np.array([np.sin(tilt), np.cos(tilt), 0.0])
        z_axis = np.array([np.cos(tilt), -np.sin(tilt), 0.0])
        return np.stack([x_axis, y_axis, z_axis])

    def volume_mm3(self) -> float:
        """Magnet volume, mm³."""
        return np.pi * (self.diameter_mm / 2.0) ** 2 * self.height_mm


def _poses(root_rotation_rad, root_shift_mm) -> tuple[np.ndarray, np.ndarray, tuple]:
    """Broadcast rotations (...) and shifts (..., 2) to flat arrays and the common shape."""
    rotation = np.asarray(root_rotation_rad, dtype=float)
    shift = np.asarray(root_shift_mm, dtype=float)
    if shift.shape[-1:] != (2,):
        raise UsageError(f"root_shift_mm must end in an axis of length 2, got shape {shift.shape}.")
    shape = np.broadcast_shapes(rotation.shape, shift.shape[:-1])
    rotation = np.broadcast_to(rotation, shape).reshape(-1)
    shift = np.broadcast_to(shift, shape + (2,)).reshape(-1, 2)
    return rotation, shift, shape


def _magnet_pose(magnet: MagnetParams, rotation: np.ndarray, shift: np.ndarray):
    """Magnet centre (n, 3) and axis (n, 3) in the whisker frame for flat pose arrays."""
    cos, sin = np.cos(rotation), np.sin(rotation)
    center = np.zeros((rotation.size, 3))
    center[:, 0] = magnet.magnet_center_mm * cos + shift[:, 0]
    center[:, 1] = magnet.magnet_center_mm * sin + shift[:, 1]
    axis = np.zeros((rotation.size, 3))
    axis[:, 0], axis[:, 1] = cos, sin
    return center, axis


def _to_sensor_axes(magnet: MagnetParams, field_frame_T: np.ndarray) -> np.ndarray:
    """Whisker-frame field (n, 3) in T to sensor readings (n, 3) in µT."""
    return field_frame_T @ magnet.sensor_axes().T * TESLA_TO_UT


def exact_field_uT(magnet: MagnetParams, root_rotation_rad, root_shift_mm) -> np.ndarray:
    """Exact field of the cylinder at the sensor (magpylib, Derby's closed form).

    Parameters
    ----------
    magnet : MagnetParams
    root_rotation_rad : array_like, shape (...)
        Rotation of the suspension about the centre of rotation, rad.
    root_shift_mm : array_like, shape (..., 2)
        Translation of the suspension in the bending plane, mm.

    Returns
    -------
    ndarray, shape (..., 3)
        Field in the sensor's axes (X, Y, Z), µT.
    """
    rotation, shift, shape = _poses(root_rotation_rad, root_shift_mm)
    center, axis = _magnet_pose(magnet, rotation, shift)
    rel = magnet.sensor_position_mm() - center
    axial = np.einsum("ij,ij->i", rel, axis)
    radial_vec = rel - axial[:, None] * axis
    radial = np.linalg.norm(radial_vec, axis=1)
    radius = magnet.diameter_mm / 2.0
    half_height = np.full(rotation.size, magnet.height_mm / 2.0 / radius)
    b_r, _, b_z = magpylib.core.magnet_cylinder_axial_Bfield(half_height, radial / radius, axial / radius)
    # On the axis the radial direction is undefined and B_r is zero there anyway.
    radial_dir = np.divide(radial_vec, radial[:, None], out=np.zeros_like(radial_vec), where=radial[:, None] > 1e-12)
    field_T = magnet.polarization_T * (b_z[:, None] * axis + b_r[:, None] * radial_dir)
    return _to_sensor_axes(magnet, field_T).reshape(shape + (3,))


def dipole_field_uT(magnet: MagnetParams, root_rotation_rad, root_shift_mm) -> np.ndarray:
    """Field of a point dipole with the magnet's moment, at the sensor, µT (..., 3).

    The moment is J·V/µ0, so B = J·V/(4π) · (3(u·r̂)r̂ - u)/r³; only valid far from the magnet.
    Same arguments as :func:`exact_field_uT`.
    """
    rotation, shift, shape = _poses(root_rotation_rad, root_shift_mm)
    center, axis = _magnet_pose(magnet, rotation, shift)
    rel = magnet.sensor_position_mm() - center
    distance = np.linalg.norm(rel, axis=1)
    unit = rel / distance[:, None]
    along = np.einsum("ij,ij->i", unit, axis)
    strength = magnet.polarization_T * magnet.volume_mm3() / (4.0 * np.pi * distance**3)
    field_T = strength[:, None] * (3.0 * along[:, None] * unit - axis)
    return _to_sensor_axes(magnet, field_T).reshape(shape + (3,))


@dataclass(frozen=True)
class _FieldTable:
    """B-spline coefficients (rotation, shift x, shift y, component) on a uniform grid."""

    coefficients: np.ndarray
    origin: np.ndarray  # first node of each axis (rad, mm, mm)
    step: np.ndarray  # node spacing of each axis
    valid_low: np.ndarray
    valid_high: np.ndarray


def _axis_nodes(bounds: tuple[float, float], step: float, pad: int) -> np.ndarray:
    count = int(np.ceil((bounds[1] - bounds[0]) / step - 1e-9))
    return bounds[0] + step * np.arange(-pad, count + pad + 1)


@functools.lru_cache(maxsize=16)
def _field_table(magnet: MagnetParams) -> _FieldTable:
    """Exact field on the grid, prefiltered to cubic B-spline coefficients (cached per magnet)."""
    grid = magnet.grid
    rot = _axis_nodes(grid.rotation_rad, grid.rotation_step_rad, grid.pad_cells)
    sx = _axis_nodes(grid.shift_mm, grid.shift_step_mm, grid.pad_cells)
    rr, xx, yy = np.meshgrid(rot, sx, sx, indexing="ij")
    values = exact_field_uT(magnet, rr, np.stack([xx, yy], axis=-1))
    coefficients = np.empty_like(values)
    for component in range(3):
        coefficients[..., component] = ndimage.spline_filter(values[..., component], order=3, mode="mirror")
    step = np.array([grid.rotation_step_rad, grid.shift_step_mm, grid.shift_step_mm])
    return _FieldTable(
        coefficients=np.ascontiguousarray(coefficients),
        origin=np.array([rot[0], sx[0], sx[0]]),
        step=step,
        valid_low=np.array([grid.rotation_rad[0], grid.shift_mm[0], grid.shift_mm[0]]),
        valid_high=np.array([rot[-1 - grid.pad_cells], sx[-1 - grid.pad_cells], sx[-1 - grid.pad_cells]]),
    )


@numba.njit(cache=True, inline="always")
def _bspline_weights(t, out):
    """Cubic B-spline weights of the four nodes around fractional position t in [0, 1)."""
    s = 1.0 - t
    out[0] = s * s * s / 6.0
    out[1] = (3.0 * t * t * t - 6.0 * t * t + 4.0) / 6.0
    out[2] = (-3.0 * t * t * t + 3.0 * t * t + 3.0 * t + 1.0) / 6.0
    out[3] = t * t * t / 6.0


@numba.njit(cache=True)
def _spline_eval(coefficients, origin, step, points, out):
    """Evaluate the tricubic B-spline at points (n, 3) into out (n, 3)."""
    wa = np.empty(4)
    wb = np.empty(4)
    wc = np.empty(4)
    for n in range(points.shape[0]):
        fa = (points[n, 0] - origin[0]) / step[0]
        fb = (points[n, 1] - origin[1]) / step[1]
        fc = (points[n, 2] - origin[2]) / step[2]
        ia, ib, ic = int(np.floor(fa)), int(np.floor(fb)), int(np.floor(fc))
        _bspline_weights(fa - ia, wa)
        _bspline_weights(fb - ib, wb)
        _bspline_weights(fc - ic, wc)
        for k in range(3):
            out[n, k] = 0.0
        for a in range(4):
            for b in range(4):
                wab = wa[a] * wb[b]
                for c in range(4):
                    w = wab * wc[c]
                    for k in range(3):
                        out[n, k] += w * coefficients[ia + a - 1, ib + b - 1, ic + c - 1, k]


def field_uT(magnet: MagnetParams, root_rotation_rad, root_shift_mm) -> np.ndarray:
    """Field at the sensor for suspension poses, interpolated from exact values.

    Parameters
    ----------
    magnet : MagnetParams
    root_rotation_rad : array_like, shape (...)
        Rotation of the suspension about the centre of rotation, rad (negative for contacts
        that push the whisker to -y).
    root_shift_mm : array_like, shape (..., 2)
        Translation of the suspension in the bending plane, mm.

    Returns
    -------
    ndarray, shape (..., 3)
        Field in the sensor's axes (X, Y, Z), µT. Poses inside ``magnet.grid`` are
        interpolated (error: :func:`interpolation_error_uT`); others are evaluated exactly.
    """
    rotation, shift, shape = _poses(root_rotation_rad, root_shift_mm)
    table = _field_table(magnet)
    points = np.column_stack([rotation, shift])
    inside = np.all((points >= table.valid_low) & (points <= table.valid_high), axis=1)
    out = np.empty((rotation.size, 3))
    if inside.all():
        _spline_eval(table.coefficients, table.origin, table.step, points, out)
    else:
        inner = np.empty((int(inside.sum()), 3))
        _spline_eval(table.coefficients, table.origin, table.step, np.ascontiguousarray(points[inside]), inner)
        out[inside] = inner
        out[~inside] = exact_field_uT(magnet, rotation[~inside], shift[~inside])
    return out.reshape(shape + (3,))


def interpolation_error_uT(magnet: MagnetParams, n_poses: int = 2000, seed: int = 0) -> np.ndarray:
    """Largest |interpolated - exact| per sensor axis over random poses inside the grid, µT (3,).

    Poses are drawn uniformly from the grid's valid box with a seeded generator.
    """
    rng = np.random.default_rng(seed)
    grid = magnet.grid
    rotation = rng.uniform(*grid.rotation_rad, size=n_poses)
    shift = rng.uniform(*grid.shift_mm, size=(n_poses, 2))
    difference = field_uT(magnet, rotation, shift) - exact_field_uT(magnet, rotation, shift)
    return np.abs(difference).max(axis=0)
