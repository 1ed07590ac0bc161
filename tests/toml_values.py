"""Hypothesis strategies for TOML values and a tiny writer, shared by the config fuzz tests."""

import math

from hypothesis import strategies as st

_SCALARS = st.one_of(st.floats(), st.integers(-2**63, 2**63 - 1), st.integers(-3, 400),
                     st.booleans(), st.text(max_size=6), st.sampled_from([0, 0.0, -0.0, 1, -1]))
VALUES = st.recursive(_SCALARS, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                        st.dictionaries(st.sampled_from("ab"),
                                                                        inner, max_size=2)),
                      max_leaves=6)


def overrides(defaults: dict) -> st.SearchStrategy:
    """Override tables: a few known keys of ``defaults`` (sometimes an unknown one) set to any
    TOML value, often a near-miss of the default (its negative, NaN, inf, the wrong type)."""
    keys = [(section, key) for section, table in defaults.items() for key in table]
    keys.append(("trials" if "trials" in defaults else "rig", "typo_key"))
    pick = st.lists(st.tuples(st.sampled_from(keys), VALUES), min_size=1, max_size=3)

    def build(pairs):
        table = {}
        for (section, key), value in pairs:
            table.setdefault(section, {})[key] = value
        return table
    return pick.map(build)


def toml_value(value) -> str:
    """``value`` as TOML (floats keep nan, inf and their sign)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return '"' + "".join(c if c.isalnum() else f"\\u{ord(c):04x}" for c in value
                             if ord(c) < 0x10000 and not 0xD800 <= ord(c) < 0xE000) + '"'
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return "{" + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + "}"


def toml_text(tables: dict) -> str:
    """Top-level tables of key = value lines."""
    lines = []
    for section, table in tables.items():
        lines.append(f"[{section}]")
        lines += [f"{key} = {toml_value(value)}" for key, value in table.items()]
    return "\n".join(lines) + "\n"


def all_finite(value) -> bool:
    """True when every number in nested dicts/lists/tuples is finite."""
    if isinstance(value, dict):
        return all(all_finite(v) for v in value.values())
    if isinstance(value, (list, tuple)):
        return all(all_finite(v) for v in value)
    if isinstance(value, float):
        return math.isfinite(value)
    return True


def wrong_values(default) -> list:
    """Values of the wrong type for a key whose documented default is ``default``: a bool or a
    string for a number, a float for an integer, a number for a bool or a string, and for a list
    a bool inside it or a string in its place."""
    if isinstance(default, bool):
        return [1, "true"]
    if isinstance(default, int):
        return [float(default) + 0.0, True, "1"]
    if isinstance(default, float):
        return [True, "15", [default]]
    if isinstance(default, str):
        return [5, False]
    if isinstance(default, list):
        return [[True] * len(default), "12", [[[1.0]]]]
    return []


def deep_array(depth: int) -> str:
    """A TOML array nested ``depth`` deep."""
    return "[" * depth + "]" * depth


def kept_as_given(given, loaded, default) -> bool:
    """True when a value that loaded is the value the file gave, of the default's own type: no
    bool taken as a number, no float as an integer, no string as a number (ints may stand for
    floats, and then load as the same float)."""
    if isinstance(default, dict):
        return isinstance(given, dict) and all(kept_as_given(value, loaded[key], default[key])
                                               for key, value in given.items())
    if isinstance(default, list):
        return (isinstance(given, list) and len(given) == len(loaded)
                and all(kept_as_given(g, v, 0.0) for g, v in zip(given, loaded)))
    if isinstance(default, float):
        return type(given) in (int, float) and type(loaded) is float and loaded == given
    return type(given) is type(default) and type(loaded) is type(default) and loaded == given
