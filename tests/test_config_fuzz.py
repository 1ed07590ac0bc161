"""The TOML configs under arbitrary input: a valid config or one UsageError line, nothing else.

Covers the collect, study, shaft study and follow configs and the sensor file. A NaN compares
false with everything, so a non-finite number would silently switch off a limit (the overload
and encoder guards): every numeric key refuses NaN and inf, naming the key. Every key refuses a
value of the wrong type (a bool or a string for a number, a float for an integer) naming the
file, the table and the key, and a value that loads is the one the file gave. Short
derandomized runs.
"""

import math
import tempfile
from itertools import groupby
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from toml_values import (VALUES, all_finite, deep_array, kept_as_given, overrides, toml_text,
                         toml_value, wrong_values)

from whiskercal.collect import config as collect_config
from whiskercal.errors import UsageError
from whiskercal.follow import FollowConfig, load_follow_config
from whiskercal.shaftstudy import config as shaft_config
from whiskercal.study import config as study_config
from whiskercal.tomlconfig import read_toml
from whiskercal.twin.params import DEFAULT_SENSOR
from whiskercal.twin.sensor_file import RULES, load_sensor, sensor_from_dict, sensor_to_dict

FUZZ = settings(max_examples=300, derandomize=True, deadline=None,
                suppress_health_check=[HealthCheck.too_slow])
COLLECT_DEFAULTS = read_toml(collect_config.DEFAULT_CONFIG_PATH)
STUDY_DEFAULTS = study_config.default_config()
SHAFT_DEFAULTS = shaft_config.DEFAULTS
FOLLOW_DEFAULTS = {"follow": FollowConfig().to_dict()}
SENSOR_DEFAULTS = {key: value for key, value in sensor_to_dict(DEFAULT_SENSOR).items()
                   if key != "sensor_id"}

# each config file as nested dicts: what its loader makes of a file, and its documented defaults
LOADERS = {
    "collect": (lambda path: collect_config.load_config(path).to_dict(), COLLECT_DEFAULTS),
    "study": (study_config.load_config, STUDY_DEFAULTS),
    "shaft": (shaft_config.load_config, SHAFT_DEFAULTS),
    "follow": (lambda path: {"follow": load_follow_config(path).to_dict()}, FOLLOW_DEFAULTS),
    "sensor": (lambda path: sensor_to_dict(load_sensor(path)), SENSOR_DEFAULTS),
}


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
    assert config is None and f"config.toml [{section}] {name}: must be" in message


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("key", _numeric_keys(STUDY_DEFAULTS))
def test_every_numeric_study_key_refuses_non_finite_numbers(key, bad):
    section, name = key.split(".")
    value = [1.0, bad] if isinstance(STUDY_DEFAULTS[section][name], list) else bad
    config, message = _load(study_config.load_config, toml_text({section: {name: value}}))
    assert config is None and f"config.toml [{section}] {name}: must be" in message


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
    assert message.endswith("config.toml [safety] overload_z_uT: must be a finite number, not nan")


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


# -- every config: types, unknown keys, bytes that are not TOML ------------------------------

def _keys(defaults: dict) -> list[tuple[str, str, object]]:
    """(table, key, default) for every key of every table, nested tables as ``magnet.grid``."""
    keys = []
    for section, table in defaults.items():
        for key, value in table.items():
            if isinstance(value, dict):
                keys += [(f"{section}.{key}", inner, default) for inner, default in value.items()]
            else:
                keys.append((section, key, value))
    return keys


def _file_text(kind: str, table: str, body: str) -> str:
    """A config file of ``kind`` holding one ``[table]`` with ``body`` (a sensor file names its
    build first)."""
    head = 'sensor_id = "fuzz-1"\n' if kind == "sensor" else ""
    return f"{head}[{table}]\n{body}\n"


_WRONG = [(kind, table, key, bad) for kind, (_, defaults) in LOADERS.items()
          for table, key, default in _keys(defaults) for bad in wrong_values(default)]


@pytest.mark.parametrize("kind, table, key, bad", _WRONG,
                         ids=[f"{k}-{t}.{n}-{type(b).__name__}" for k, t, n, b in _WRONG])
def test_a_value_of_the_wrong_type_is_one_line_naming_file_table_and_key(kind, table, key, bad):
    result, message = _load(LOADERS[kind][0], _file_text(kind, table, f"{key} = {toml_value(bad)}"))
    assert result is None, f"{kind} [{table}] {key} = {bad!r} loaded"
    assert "\n" not in message
    assert f"config.toml [{table}] {key}: must be " in message
    assert message.endswith(f", not {toml_value(bad)}") or message.endswith("...")


@pytest.mark.parametrize("kind", LOADERS)
def test_the_documented_example_message_for_a_bool(kind):
    table, key, _ = next(entry for entry in _keys(LOADERS[kind][1]) if type(entry[2]) is float)
    _, message = _load(LOADERS[kind][0], _file_text(kind, table, f"{key} = true"))
    assert message.endswith(f"config.toml [{table}] {key}: must be {_says(kind, table, key)}, not true")


def _says(kind: str, table: str, key: str) -> str:
    """What the key must be, in the words the message uses (the sensor file's RULES)."""
    if kind != "sensor":
        return "a number" if key in ("angle_deg", "whisker_angle_deg", "slide_start_mm") \
            else "a number > 0"
    rules = RULES
    for part in table.split("."):
        rules = rules[part]
    return rules[key]


def test_follow_settings_of_the_wrong_type_are_refused():
    _, message = _load(load_follow_config, "[follow]\nkp_mm_s_per_uT = true\n")
    assert message.endswith("config.toml [follow] kp_mm_s_per_uT: must be a number >= 0, not true")
    _, message = _load(load_follow_config, "[follow]\nkey_points = 6.0\n")
    assert message.endswith("config.toml [follow] key_points: must be an integer >= 4, not 6.0")


@pytest.mark.parametrize("kind", LOADERS)
def test_an_unknown_key_or_table_is_one_line_naming_it(kind):
    table = _keys(LOADERS[kind][1])[0][0]
    _, message = _load(LOADERS[kind][0], _file_text(kind, table, "typo_key = 1.0"))
    assert f"config.toml [{table}] typo_key: unknown key (known: " in message and "\n" not in message
    _, message = _load(LOADERS[kind][0], _file_text(kind, "typo_table", "a = 1"))
    assert "config.toml [typo_table]: unknown table (known: " in message and "\n" not in message


@pytest.mark.parametrize("kind", LOADERS)
@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_a_non_finite_number_is_refused_for_every_config(kind, bad):
    table, key, _ = next(entry for entry in _keys(LOADERS[kind][1]) if type(entry[2]) is float)
    _, message = _load(LOADERS[kind][0], _file_text(kind, table, f"{key} = {toml_value(bad)}"))
    assert message.endswith(f"config.toml [{table}] {key}: must be a finite number, not {toml_value(bad)}")


def _load_bytes(loader, data: bytes):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "config.toml"
        path.write_bytes(data)
        try:
            return loader(path), None
        except UsageError as error:
            return None, str(error)


@pytest.mark.parametrize("kind", LOADERS)
@pytest.mark.parametrize("data, says", [
    ('[a]\nb = "caf\xe9"\n'.encode("latin-1"), "not valid TOML (not UTF-8 text"),
    ("\ufeff[a]\n".encode("utf-16"), "not valid TOML (not UTF-8 text"),
    (f"a = {deep_array(3000)}\n".encode(), "not valid TOML (arrays or tables nested too deep)"),
    (f"a = {{ b = {'{ b = ' * 3000}1{' }' * 3000} }}\n".encode(), "not valid TOML"),
], ids=["latin-1", "utf-16", "array-3000-deep", "table-3000-deep"])
def test_bytes_that_are_not_toml_are_one_line(kind, data, says):
    result, message = _load_bytes(LOADERS[kind][0], data)
    assert result is None and "config.toml: " + says in message and "\n" not in message


@pytest.mark.parametrize("kind", LOADERS)
def test_a_deep_but_parsable_array_is_one_line_naming_the_key(kind):
    table, key, _ = _keys(LOADERS[kind][1])[0]
    _, message = _load(LOADERS[kind][0], _file_text(kind, table, f"{key} = {deep_array(400)}"))
    assert f"config.toml [{table}] {key}: must be " in message and len(message) < 400


@pytest.mark.parametrize("kind", LOADERS)
def test_the_defaults_written_out_load_back_to_the_same_values(kind):
    loader, defaults = LOADERS[kind]
    head = 'sensor_id = "fuzz-1"\n' if kind == "sensor" else ""
    body = "\n".join(f"[{table}]\n" + "\n".join(f"{key} = {toml_value(value)}" for _, key, value in keys)
                     for table, keys in groupby(_keys(defaults), key=lambda entry: entry[0]))
    loaded, message = _load(loader, head + body + "\n")
    assert message is None
    assert {table: loaded[table] for table in defaults} == defaults


@pytest.mark.parametrize("kind", ["collect", "study", "shaft", "follow"])
def test_the_defaults_are_the_documented_ones_with_their_types(kind):
    loader, defaults = LOADERS[kind]
    loaded, message = _load(loader, "")
    assert message is None and kept_as_given(defaults, loaded, defaults)


@FUZZ
@given(st.one_of(overrides(SHAFT_DEFAULTS).map(toml_text), st.text(max_size=60)))
def test_any_shaft_study_config_file_loads_finite_or_is_refused(text):
    config = _check(*_load(shaft_config.load_config, text))
    if config is not None:
        assert all_finite(config) and config["trials"]["safe_y_mm"] > config["rig"]["rod_radius_mm"]


@FUZZ
@given(st.one_of(overrides(FOLLOW_DEFAULTS).map(toml_text), st.text(max_size=60)))
def test_any_follow_config_file_loads_finite_or_is_refused(text):
    config = _check(*_load(load_follow_config, text))
    if config is not None:
        assert all_finite(config.to_dict()) and config.key_points >= 4


@FUZZ
@given(st.sampled_from(["collect", "study", "shaft", "follow"]), st.data())
def test_a_config_that_loads_holds_the_values_the_file_gave(kind, data):
    loader, defaults = LOADERS[kind]
    given_tables = data.draw(overrides(defaults))
    loaded, message = _load(loader, toml_text(given_tables))
    if loaded is None:
        assert message and "\n" not in message
        return
    assert kept_as_given(given_tables, loaded, defaults)


@pytest.mark.parametrize("kind, table, key", [("collect", "rig", "trace_length_mm"),
                                              ("study", "geometry", "tip_reach_mm")])
@pytest.mark.parametrize("reach", [1.7e308, 1e6])
def test_a_reach_the_defaults_would_scale_to_beyond_any_build_is_one_line(kind, table, key, reach):
    result, message = _load(LOADERS[kind][0], f"[{table}]\n{key} = {reach!r}\n")
    assert result is None and f"config.toml [{table}] {key}: must be a number > 0 and <= " in message
