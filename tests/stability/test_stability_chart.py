"""The stability map's PNG, drawn from a small hand-made result (no probes run)."""

import numpy as np
import pytest

from whiskercal.bench import stability_chart
from whiskercal.bench.stability_chart import draw_stability

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _result():
    z_range = {"fast": {"entries": [
        {"setting": 100.0, "status": "ok", "error_vs_truth_mm": 0.2},
        {"setting": 200.0, "status": "tip", "error_vs_truth_mm": 0.4},
        {"setting": 900.0, "status": "ZOutOfRangeError", "error_vs_truth_mm": None}]}}
    noise = {"entries": [
        {"setting": 1.0, "status": "ok", "max_error_vs_truth_mm": 0.1},
        {"setting": 10.0, "status": "ok", "max_error_vs_truth_mm": 3.0, "silent": True},
        {"setting": 100.0, "status": "ok", "max_error_vs_truth_mm": float("nan"), "silent": True,
         "documented_limit": True}]}
    kalman = [{"case": "huge noise", "status": "ok", "finite": True}]
    return {"probes": {"z_range": z_range, "noise": noise, "kalman": kalman}}


@pytest.fixture(scope="module")
def drawn(tmp_path_factory):
    """The map drawn once (a figure takes about a second): its path and the figure itself."""
    figures, real_save = [], stability_chart.save_png

    def keep(fig, path, dpi=110):
        figures.append(fig)
        return real_save(fig, path, dpi=dpi)

    folder = tmp_path_factory.mktemp("map")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(stability_chart, "save_png", keep)
        path = draw_stability(_result(), folder / "charts" / "stability.png")
    return folder, path, figures[0]


def test_writes_one_png_with_a_panel_per_probe_and_the_kalman_table(drawn):
    folder, path, fig = drawn
    assert path == folder / "charts" / "stability.png"
    assert path.read_bytes()[:8] == PNG_SIGNATURE
    axes = fig.axes
    assert len(axes) == 8
    titles = [ax.get_title() for ax in axes[:len(stability_chart.PANELS)]]
    assert titles == [panel[2] for panel in stability_chart.PANELS]
    table = "".join(text.get_text() for text in axes[-1].texts)
    assert "Kalman filter" in table and "huge noise: ok, finite=True" in table
    assert axes[3].get_xscale() == "log" and axes[6].get_xscale() == "symlog"


def test_failures_are_crossed_and_named_returned_values_plotted(drawn):
    _, _, fig = drawn
    z_panel = fig.axes[0]
    returned = [line for line in z_panel.lines if line.get_marker() == "o"]
    assert len(returned) == 1
    np.testing.assert_array_equal(returned[0].get_xdata(), [100.0, 200.0])
    np.testing.assert_array_equal(returned[0].get_ydata(), [0.2, 0.4])
    crosses = [line for line in z_panel.lines if line.get_marker() == "x"]
    assert len(crosses) == 1 and crosses[0].get_ydata()[0] == 0.0  # no number: at the bottom
    assert [text.get_text() for text in z_panel.texts] == ["ZOutOfRange"]


def test_silent_failures_and_documented_limits_are_ringed_apart(drawn):
    _, _, fig = drawn
    rings = {line.get_label(): line for line in fig.axes[3].lines if line.get_markerfacecolor() == "none"}
    assert set(rings) == {"silent failure", "documented limit (not detected)"}
    np.testing.assert_array_equal(rings["silent failure"].get_xdata(), [10.0])
    # a documented limit is never also counted silent; a NaN error is drawn at zero
    np.testing.assert_array_equal(rings["documented limit (not detected)"].get_ydata(), [0.0])
    assert not fig.axes[1].lines  # a probe missing from the result: an empty panel
