"""The TOML configs under arbitrary input: a valid config or one UsageError line, nothing else.

Covers the collect config, the study config and the sensor file. A NaN compares false with
everything, so a non-finite number would silently switch off a limit (the overload and encoder
guards): every numeric key refuses NaN and inf, naming the key. Short derandomized runs.
"""

import math
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from toml_values import VALUES, all_finite, overrides, toml_text

from whiskercal.collect import config as collect_config
from whiskercal.errors import UsageError
from whiskercal.study import config as study_config
from whiskercal.tomlconfig import read_toml
from whiskercal.twin.sensor_file import RULES, load_sensor, sensor_from_dict, sensor_to_dict

FUZZ = settings(max_examples=300, derandomize=True, deadline=None,
                suppress_health_check=[HealthCheck.too_slow])
COLLECT_DEFAULTS = read_toml(collect_config.DEFAULT_CONFIG_PATH)
STUDY_DEFAULTS = study_config.default_config()


def _load(loader, text: str):
    """``loader(path)`` on a file holding ``text``: the result, or the UsageError's message."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "config.toml"
        path.write_text(text, encoding="utf-8")
        try:
            return loader(path), None
        except UsageError as error:
            return None, str(error)


def _numeric_keys(defaults: dict) -> list[str]:
    return [f"{section}.{key}" for section, table in defaults.items()
            for key, value in table.items()
            if not isinstance(value, (bool, str))]


def _check(result, message):
    if result is None:
        assert message and "\n" not in message
    return result


@FUZZ
@given(st.one_of(overrides(COLLECT_DEFAULTS).map(toml_text), st.text(max_size=60)))
def test_any_collect_config_file_loads_finite_or_is_refused(text):
    config = _check(*_load(collect_config.load_config, text))
    if config is not None:
        assert all_finite(config.to_dict())
        assert config.safety.overload_z_uT > 0 and config.safety.encoder_tolerance_mm > 0


@FUZZ
@given(st.one_of(overrides(STUDY_DEFAULTS).map(toml_text), st.text(max_size=60)))
def test_any_study_config_file_loads_finite_or_is_refused(text):
    config = _check(*_load(study_config.load_config, text))
    if config is not None:
        assert all_finite(config)
        assert config["safety"]["overload_uT"] > config["contact"]["threshold_uT"] > 0


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("key", _numeric_keys(COLLECT_DEFAULTS))
def test_every_numeric_collect_key_refuses_non_finite_numbers(key, bad):
    section, name = key.split(".")
    value = [bad, 1.0] if isinstance(COLLECT_DEFAULTS[section][name], list) else bad
    config, message = _load(collect_config.load_config, toml_text({section: {name: value}}))
    assert config is None and f"[{section}] {name} =" in message and "config.toml" in message


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("key", _numeric_keys(STUDY_DEFAULTS))
def test_every_numeric_study_key_refuses_non_finite_numbers(key, bad):
    section, name = key.split(".")
    value = [1.0, bad] if isinstance(STUDY_DEFAULTS[section][name], list) else bad
    config, message = _load(study_config.load_config, toml_text({section: {name: value}}))
    assert config is None and f"{key} =" in message and "config.toml" in message


@pytest.mark.parametrize("key, value", [("safety.overload_z_uT", -1.0),
                                        ("safety.encoder_tolerance_mm", 0.0),
                                        ("safety.margin_mm", -0.5),
                                        ("motion.move_timeout_s", -1.0),
                                        ("rig.rod_radius_mm", -1.5),
                                        ("rig.origin_stage_mm", "12")])
def test_negative_or_mistyped_collect_values_are_refused(key, value):
    section, name = key.split(".")
    config, message = _load(collect_config.load_config, toml_text({section: {name: value}}))
    assert config is None and name in message


def test_a_nan_overload_limit_no_longer_passes():
    config, message = _load(collect_config.load_config, "[safety]\noverload_z_uT = nan\n")
    assert config is None
    assert message.endswith("config [safety] overload_z_uT = nan must be a finite number")


# -- the sensor file ---------------------------------------------------------------------------

def _sensor_overrides() -> st.SearchStrategy:
    keys = [(section, key) for section, rules in RULES.items() for key in rules]
    keys += [("magnet", ("grid", key)) for key in RULES["magnet"]["grid"]]
    keys += [(None, "sensor_id"), ("whisker", "typo")]

    def build(pairs):
        data = {"sensor_id": "fuzz-1"}
        for (section, key), value in pairs:
            if section is None:
                data[key] = value
            elif isinstance(key, tuple):
                data.setdefault(section, {}).setdefault(key[0], {})[key[1]] = value
            else:
                data.setdefault(section, {})[key] = value
        return data
    return st.lists(st.tuples(st.sampled_from(keys), VALUES), min_size=1, max_size=3).map(build)


@FUZZ
@given(st.one_of(_sensor_overrides(), VALUES))
def test_any_sensor_description_gives_a_sensor_or_is_refused(data):
    try:
        sensor = sensor_from_dict(data, "fuzz.toml")
    except UsageError as error:
        assert "\n" not in str(error)
        return
    assert all_finite(sensor_to_dict(sensor))


@FUZZ
@given(st.text(max_size=80))
def test_any_sensor_file_text_gives_a_sensor_or_is_refused(text):
    sensor, message = _load(load_sensor, text)
    _check(sensor, message)
