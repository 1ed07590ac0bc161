"""A whole sensor as the twin builds it, and the sensors it ships with.

`SensorParams` bundles the whisker (mechanics), the magnet and where the magnetometer sits, and
the magnetometer. `DEFAULT_SENSOR` resembles the paper's sensor: its z -> tip curve lies close to
the authors' characterized model and it reads about 1160 µT on Y at rest with 5.6 µT of noise;
docs/twin.md ("Default sensor and how it was chosen") records how its magnet was fitted and how
close it came. `SECOND_SENSOR` is a different build (shorter wire, stiffer suspension, its own
magnet placement) for regression datasets that must not share every number with the default.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from whiskercal.errors import UsageError
from whiskercal.twin.physics.magnet import FieldGrid, MagnetParams
from whiskercal.twin.physics.magnetometer import MagnetometerParams
from whiskercal.twin.physics.whisker import WhiskerParams

__all__ = [
    "DEFAULT_SENSOR", "SECOND_SENSOR", "SENSORS", "FieldGrid", "MagnetParams",
    "MagnetometerParams", "SensorParams", "WhiskerParams", "sensor_by_id",
]


@dataclass(frozen=True)
class SensorParams:
    """One whisker sensor: an identifier and its three physical parts.

    Attributes
    ----------
    sensor_id : str
        Written into every dataset and artifact as ``sensor_id``.
    whisker : WhiskerParams
        Wire and suspension (twin.whisker).
    magnet : MagnetParams
        Magnet, its mounting and the magnetometer's position (twin.magnet).
    magnetometer : MagnetometerParams
        MLX90393 settings and imperfections (twin.magnetometer).
    """

    sensor_id: str
    whisker: WhiskerParams = field(default_factory=WhiskerParams)
    magnet: MagnetParams = field(default_factory=MagnetParams)
    magnetometer: MagnetometerParams = field(default_factory=MagnetometerParams)

    def __post_init__(self) -> None:
        if not (isinstance(self.sensor_id, str) and self.sensor_id.strip()):
            raise UsageError("sensor_id must be a non-empty string.")


# Fitted by scripts/fit_default_magnet.py against the authors' characterized model (a target for
# choosing defaults only; nothing computes results from it), whose input is the raw Y reading
# (rest near +447 µT): a 2.07 x 0.59 mm NdFeB disc 4.7 mm below the centre of rotation, 1.9 mm
# above the chip (docs/twin.md, "Default sensor and how it was chosen").
DEFAULT_SENSOR = SensorParams(
    sensor_id="twin-paper-75mm",
    whisker=WhiskerParams(),
    magnet=MagnetParams(
        diameter_mm=2.074,
        height_mm=0.585,
        polarization_T=-1.2361,
        magnet_center_mm=-4.674,
        gap_mm=1.911,
        sensor_offset_mm=(0.0, 0.197, 0.0),
        sensor_tilt_rad=0.06838,
    ),
    magnetometer=MagnetometerParams(),
)

# A shorter (60 mm) build on a stiffer suspension, with a larger magnet mounted further down and
# its own mounting errors and chip offset.
SECOND_SENSOR = SensorParams(
    sensor_id="twin-short-60mm",
    whisker=WhiskerParams(
        length_mm=60.0,
        root_rotational_stiffness_n_mm_per_rad=6.0,
        root_translational_stiffness_n_per_mm=0.1,
    ),
    magnet=MagnetParams(
        diameter_mm=2.5,
        height_mm=0.8,
        polarization_T=-1.30,
        magnet_center_mm=-6.0,
        gap_mm=2.6,
        sensor_offset_mm=(0.05, -0.1, 0.08),
        sensor_tilt_rad=-0.03,
    ),
    magnetometer=MagnetometerParams(noise_uT_rms=(6.0, 6.0, 9.5), offset_uT=(-25.0, 40.0, 12.0)),
)

SENSORS = {sensor.sensor_id: sensor for sensor in (DEFAULT_SENSOR, SECOND_SENSOR)}


def sensor_by_id(sensor_id: str) -> SensorParams:
    """The shipped sensor with this identifier, or a UsageError naming the known ones."""
    try:
        return SENSORS[sensor_id]
    except KeyError:
        known = ", ".join(sorted(SENSORS))
        raise UsageError(f"unknown sensor {sensor_id!r}; known sensors: {known}.") from None
