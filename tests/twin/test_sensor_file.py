"""Sensor files: defaults, every kind of bad value, round trips, the shipped examples."""

import dataclasses
import json
from pathlib import Path

import pytest

from whiskercal.errors import UsageError
from whiskercal.twin.params import DEFAULT_SENSOR, SECOND_SENSOR, SENSORS
from whiskercal.twin.physics.magnet import FieldGrid, MagnetParams
from whiskercal.twin.physics.magnetometer import MagnetometerParams
from whiskercal.twin.physics.whisker import WhiskerParams
from whiskercal.twin.sensor_file import (RULES, load_sensor, resolve_sensor, sensor_from_dict,
                                         sensor_to_dict, sensor_to_toml)

EXAMPLES = Path(__file__).resolve().parents[2] / "sensors"


def _write(tmp_path, text: str, name: str = "sensor.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_keys_left_out_take_the_default_sensors_values(tmp_path):
    sensor = load_sensor(_write(tmp_path, 'sensor_id = "lab-1"\n[whisker]\nlength_mm = 110\n'))
    assert sensor.sensor_id == "lab-1"
    assert sensor.whisker == dataclasses.replace(DEFAULT_SENSOR.whisker, length_mm=110.0)
    assert sensor.magnet == DEFAULT_SENSOR.magnet  # the fitted magnet, not MagnetParams()
    assert sensor.magnetometer == DEFAULT_SENSOR.magnetometer


def test_integers_are_accepted_for_numbers_and_vectors_become_tuples(tmp_path):
    sensor = load_sensor(_write(tmp_path, 'sensor_id = "lab-1"\n[magnet]\nsensor_offset_mm = [0, 1, 0]\n'
                                          "[magnet.grid]\npad_cells = 4\n"))
    assert sensor.magnet.sensor_offset_mm == (0.0, 1.0, 0.0)
    assert isinstance(sensor.magnet.sensor_offset_mm[1], float)
    assert sensor.magnet.grid == FieldGrid(pad_cells=4)
    hash(sensor)  # usable as a cache key, as the truth's caches need


_BAD = [
    ("[whisker]\nlength_mm = -3", r"^sensor.toml \[whisker\] length_mm: must be a positive number of mm, not -3$"),
    ("[whisker]\nlength_mm = 0", r"\[whisker\] length_mm: must be a positive number of mm, not 0$"),
    ('[whisker]\nlength_mm = "75"', r'\[whisker\] length_mm: must be a positive number of mm, not "75"$'),
    ("[whisker]\nlength_mm = true", r"\[whisker\] length_mm: must be .*, not true$"),
    ("[whisker]\nlength_mm = inf", r"\[whisker\] length_mm: must be .*, not inf$"),
    ("[whisker]\ndiameter_mm = nan", r"\[whisker\] diameter_mm: must be .*, not nan$"),
    ("[whisker]\nroot_rotational_stiffness_n_mm_per_rad = 0.0",
     r"\[whisker\] root_rotational_stiffness_n_mm_per_rad: must be a positive number of N·mm/rad"),
    ("[whisker]\nroot_translational_stiffness_n_per_mm = -0.1",
     r"\[whisker\] root_translational_stiffness_n_per_mm: must be a positive number of N/mm"),
    ("[whisker]\nroot_offset_mm = -1", r"\[whisker\] root_offset_mm: must be a number of mm >= 0, not -1$"),
    ("[whisker]\nyoungs_modulus_n_per_mm2 = -75000", r"\[whisker\] youngs_modulus_n_per_mm2: must be"),
    ("[whisker]\nlenght_mm = 75", r"\[whisker\] lenght_mm: unknown key \(known: length_mm, "),
    ("[magnet]\npolarization_T = 0", r"\[magnet\] polarization_T: must be a non-zero number of T within ±2"),
    ("[magnet]\npolarization_T = -3.5", r"\[magnet\] polarization_T: must be"),
    ("[magnet]\ngap_mm = 0", r"\[magnet\] gap_mm: must be a positive number of mm"),
    ("[magnet]\nsensor_offset_mm = [0.0, 0.1]",
     r"\[magnet\] sensor_offset_mm: must be a list of 3 numbers of mm \(x, y, w\), not \[0.0, 0.1\]$"),
    ('[magnet]\nsensor_offset_mm = [0.0, "a", 0.0]', r"\[magnet\] sensor_offset_mm: must be a list of 3"),
    ("[magnet]\nsensor_offset_mm = 0.1", r"\[magnet\] sensor_offset_mm: must be a list of 3 .*, not 0.1$"),
    ("[magnet]\nsensor_tilt_rad = 2.0", r"\[magnet\] sensor_tilt_rad: must be a number of rad within ±π/2"),
    ("[magnet.grid]\nrotation_rad = [0.6, -0.6]", r"\[magnet.grid\] rotation_rad: must be an increasing pair"),
    ("[magnet.grid]\npad_cells = 1", r"\[magnet.grid\] pad_cells: must be an integer in 2..64, not 1$"),
    ("[magnet.grid]\nstep = 1", r"\[magnet.grid\] step: unknown key"),
    ("[magnetometer]\ngain = 8", r"\[magnetometer\] gain: must be an integer in 0..7, not 8$"),
    ("[magnetometer]\nres = 2.0", r"\[magnetometer\] res: must be an integer in 0..3, not 2.0$"),
    ("[magnetometer]\nrate_hz = -300", r"\[magnetometer\] rate_hz: must be a positive number of Hz"),
    ("[magnetometer]\nnoise_uT_rms = [5.6, -1, 9]", r"\[magnetometer\] noise_uT_rms: must be a list of 3"),
    ("[magnetometer]\nosr = 3\nfilt = 7", r"\[magnetometer\] osr 3 with filt 7 takes .* ms a sample, longer "
                                          r"than the 3.33 ms period at rate_hz 300$"),
    ("whisker = 3", r"\[whisker\]: must be a table of keys, not 3$"),
    ("[mechanics]\nlength_mm = 75", r"\[mechanics\]: unknown table "
                                    r"\(known: sensor_id, whisker, magnet, magnetometer, nuisances, dynamics\)$"),
]


@pytest.mark.parametrize("body, message", _BAD, ids=[f"bad-{i}" for i in range(len(_BAD))])
def test_bad_values_are_refused_in_one_line_naming_file_and_key(tmp_path, body, message):
    path = _write(tmp_path, 'sensor_id = "lab-1"\n' + body + "\n")
    with pytest.raises(UsageError) as error:
        load_sensor(path)
    text = str(error.value).replace(str(path), "sensor.toml")
    assert "\n" not in text
    assert text.startswith("sensor.toml ")
    assert __import__("re").search(message, text), text


@pytest.mark.parametrize("body, message", [
    ("[whisker]\nlength_mm = 75", r"sensor_id is missing"),
    ("sensor_id = 3", r"sensor_id: must be a string, not 3$"),
    ('sensor_id = " "', r'sensor_id: must be a non-empty string without surrounding spaces, not " "$'),
    ('sensor_id = "twin-paper-75mm"\n[whisker]\nlength_mm = 110',
     r"sensor_id 'twin-paper-75mm' names a shipped sensor, but \[whisker\] length_mm \(110.0 here, "
     r"75.0 there\) differs; give this build its own sensor_id$"),
    ("sensor_id = ", r"not valid TOML"),
])
def test_the_sensor_id_is_required_and_a_shipped_id_names_only_its_own_build(tmp_path, body, message):
    with pytest.raises(UsageError, match=message):
        load_sensor(_write(tmp_path, body + "\n"))


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(UsageError, match=r"nothere.toml: no such sensor file$"):
        load_sensor(tmp_path / "nothere.toml")


@pytest.mark.parametrize("section, params", [("whisker", WhiskerParams), ("magnet", MagnetParams),
                                             ("magnetometer", MagnetometerParams)])
def test_every_parameter_has_a_rule(section, params):
    assert set(RULES[section]) == {f.name for f in dataclasses.fields(params)}
    if section == "magnet":
        assert set(RULES["magnet"]["grid"]) == {f.name for f in dataclasses.fields(FieldGrid)}


_BUILD = dataclasses.replace(
    SECOND_SENSOR, sensor_id="lab \"quoted\" 1",
    whisker=dataclasses.replace(SECOND_SENSOR.whisker, diameter_mm=0.2, youngs_modulus_n_per_mm2=1e-5),
    magnet=dataclasses.replace(SECOND_SENSOR.magnet, grid=FieldGrid(rotation_rad=(-1.0, 0.25), pad_cells=3)),
    magnetometer=dataclasses.replace(SECOND_SENSOR.magnetometer, gain=7, res=0, rate_hz=123.456789))


@pytest.mark.parametrize("sensor", [DEFAULT_SENSOR, SECOND_SENSOR, _BUILD], ids=["default", "second", "build"])
def test_dict_and_toml_round_trips_give_the_same_sensor(tmp_path, sensor):
    as_json = json.loads(json.dumps(sensor_to_dict(sensor)))
    assert sensor_from_dict(as_json) == sensor
    again = load_sensor(_write(tmp_path, sensor_to_toml(sensor)))
    assert again == sensor and hash(again) == hash(sensor)


def test_the_dict_holds_every_parameter():
    data = sensor_to_dict(DEFAULT_SENSOR)
    assert data["whisker"]["root_rotational_stiffness_n_mm_per_rad"] == 3.0
    assert data["magnet"]["sensor_offset_mm"] == [0.0, 0.197, 0.0]
    assert data["magnet"]["grid"]["pad_cells"] == 8
    assert data["magnetometer"]["noise_uT_rms"] == [5.6, 5.6, 9.0]


def test_a_dict_with_a_bad_value_names_its_source():
    data = sensor_to_dict(DEFAULT_SENSOR) | {"sensor_id": "lab-2"}
    data["whisker"]["length_mm"] = -1
    with pytest.raises(UsageError, match=r"^dataset \[whisker\] length_mm: must be a positive"):
        sensor_from_dict(data, "dataset")


def test_every_shipped_example_loads_and_is_named_after_its_id():
    paths = sorted(EXAMPLES.glob("*.toml"))
    assert len(paths) >= 5
    sensors = {path.stem: load_sensor(path) for path in paths}
    assert all(stem == sensor.sensor_id for stem, sensor in sensors.items())
    for sensor_id, shipped in SENSORS.items():
        assert sensors[sensor_id] == shipped


def test_example_family_builds_are_the_documented_ones():
    long = load_sensor(EXAMPLES / "long-110mm.toml").whisker
    assert (long.length_mm, long.diameter_mm) == (110.0, 0.20)
    short = load_sensor(EXAMPLES / "short-45mm-soft.toml").whisker
    assert (short.length_mm, short.diameter_mm) == (45.0, 0.35)
    assert short.root_rotational_stiffness_n_mm_per_rad < DEFAULT_SENSOR.whisker.root_rotational_stiffness_n_mm_per_rad
    stiff = load_sensor(EXAMPLES / "stiff-root-75mm.toml").whisker
    default = DEFAULT_SENSOR.whisker
    assert stiff.root_rotational_stiffness_n_mm_per_rad == 4 * default.root_rotational_stiffness_n_mm_per_rad
    assert stiff.root_translational_stiffness_n_per_mm == 4 * default.root_translational_stiffness_n_per_mm


def test_resolve_takes_a_shipped_id_or_a_file(tmp_path):
    assert resolve_sensor("twin-short-60mm") is SECOND_SENSOR
    assert resolve_sensor(EXAMPLES / "long-110mm.toml").sensor_id == "long-110mm"
    with pytest.raises(UsageError, match=r"unknown sensor 'twin-paper': give a shipped sensor id "
                                         r"\(twin-paper-75mm, twin-short-60mm\) or the path of a .toml"):
        resolve_sensor("twin-paper")
    with pytest.raises(UsageError, match="no such sensor file"):
        resolve_sensor(tmp_path / "lab.toml")
