"""Outline specs: the three shapes are the twin's own objects; polylines from files; bad specs."""

import math

import numpy as np
import pytest
import shapely

from whiskercal.contour.outline_spec import parse_outline
from whiskercal.errors import UsageError
from whiskercal.twin.outlines import outline


@pytest.mark.parametrize("spec, twin", [("circle:d=160", "cylinder"),
                                        ("rounded-rect:w=160,h=160,r=40", "rounded-rect"),
                                        ("polygon:n=8,side=70,r=30", "octagon")])
def test_the_papers_objects_are_the_twins_outlines(spec, twin):
    ours, theirs = parse_outline(spec), outline(twin)
    assert ours.closed
    # the same continuous outline: every vertex of each within a chord's sag of the other
    assert shapely.hausdorff_distance(ours.geometry, shapely.LinearRing(theirs.points())) < 0.01
    assert ours.length_mm == pytest.approx(theirs.perimeter_mm, abs=0.01)


def test_a_circles_length_is_pi_d_and_a_sharp_rectangles_its_perimeter():
    assert parse_outline("circle:d=160").length_mm == pytest.approx(math.pi * 160, abs=1e-3)
    assert parse_outline("rounded-rect:w=100,h=40").length_mm == pytest.approx(280.0, abs=1e-9)


def test_a_polygon_has_one_side_at_the_bottom():
    vertices = parse_outline("polygon:n=6,side=50").vertices_mm
    apothem = 50 / (2 * math.tan(math.pi / 6))
    assert vertices[:, 1].min() == pytest.approx(-apothem, abs=1e-9)
    assert np.sum(np.isclose(vertices[:-1, 1], -apothem)) >= 2  # a whole side lies there


def test_a_polyline_closes_when_it_ends_where_it_starts(tmp_path):
    square = tmp_path / "square.txt"
    square.write_text("# x y, mm\n0 0\n10, 0\n10 10\n0 10\n0 0\n")
    ring = parse_outline(f"polyline:{square}")
    assert ring.closed and ring.length_mm == pytest.approx(40.0)
    (tmp_path / "open.txt").write_text("0 0\n10 0\n10 10\n")
    line = parse_outline(f"polyline:{tmp_path / 'open.txt'}")
    assert not line.closed and line.length_mm == pytest.approx(20.0)


@pytest.mark.parametrize("spec, words", [
    ("teapot:d=1", "use circle:d=D"),
    ("circle", "use circle:d=D"),
    ("circle:r=80", "'r=80' is not one of d="),
    ("circle:d=160,d=150", "each once"),
    ("circle:d=-1", "d must be a finite number > 0"),
    ("circle:d=nan", "d must be a finite number > 0"),
    ("rounded-rect:w=160", "needs h="),
    ("rounded-rect:w=160,h=160,r=80", "r must be less than half"),
    ("polygon:n=2,side=70", "n must be an integer >= 3"),
    ("polygon:n=8.5,side=70", "n must be an integer"),
    ("polygon:n=8,side=70,r=90", "less than the polygon's apothem"),
    ("polyline:/nonexistent/outline.txt", "cannot read it"),
])
def test_a_bad_spec_is_one_usage_error(spec, words):
    with pytest.raises(UsageError, match=None) as error:
        parse_outline(spec)
    assert words in str(error.value)


def test_a_bad_polyline_file_names_its_line(tmp_path):
    (tmp_path / "three.txt").write_text("0 0\n1 2 3\n")
    with pytest.raises(UsageError, match="line 2 has 3 fields"):
        parse_outline(f"polyline:{tmp_path / 'three.txt'}")
    (tmp_path / "one.txt").write_text("5 5\n5 5\n")
    with pytest.raises(UsageError, match="two distinct points"):
        parse_outline(f"polyline:{tmp_path / 'one.txt'}")
