"""Fuzzed outline specs and point tables: every input is read or refused with one package error."""

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from whiskercal.contour.outline_spec import parse_outline
from whiskercal.contour.points import read_points
from whiskercal.errors import WhiskercalError

FUZZ = settings(max_examples=200, derandomize=True, deadline=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture])
NUMBERS = st.sampled_from(["160", "-1", "0", "nan", "inf", "1e308", "3.5", "x", "", "8"])
KEYS = st.sampled_from(["d", "w", "h", "r", "n", "side", "q", ""])
SPECS = st.builds(lambda kind, pairs: kind + ":" + ",".join(f"{k}={v}" for k, v in pairs),
                  st.sampled_from(["circle", "rounded-rect", "polygon", "teapot", ""]),
                  st.lists(st.tuples(KEYS, NUMBERS), max_size=4))


@FUZZ
@given(st.one_of(SPECS, st.text(max_size=40)))
def test_a_spec_is_an_outline_or_one_package_error(spec):
    try:
        outline = parse_outline(spec)
    except WhiskercalError:
        return
    assert outline.length_mm > 0 and outline.closed


CELLS = st.sampled_from(["1", "-2.5", "nan", "inf", "x", "", "1e3", "world_x_mm", "world_y_mm", "y"])
TABLES = st.lists(st.lists(CELLS, min_size=1, max_size=4).map(", ".join), max_size=6).map("\n".join)


@FUZZ
@given(st.one_of(TABLES, st.text(max_size=80)), st.sampled_from([None, "mm", "m", "km"]))
def test_a_table_is_points_or_one_package_error(tmp_path, text, units):
    path = tmp_path / "points.txt"
    path.write_text(text, encoding="utf-8")
    try:
        points = read_points(path, units)
    except WhiskercalError:
        return
    assert len(points.xy_mm) > 0 and points.xy_mm.shape[1] == 2
