"""``whiskercal report``: one self-contained HTML file per calibration."""

import json
import re
import shutil
import subprocess
import tempfile

import pytest
from click.testing import CliRunner

from whiskercal.bench.pareto import draw_pareto
from whiskercal.bench.runner import write_json
from whiskercal.cli import cli

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--no-first-run"]
# Appended to a copy of the report only: records each image's natural width once the page loaded.
PROBE = ("<script>window.addEventListener('load',()=>{document.body.setAttribute("
         "'data-img-widths',Array.from(document.images).map(i=>i.complete?i.naturalWidth:-1)"
         ".join(','));});</script></body>")


@pytest.fixture(scope="module")
def bench_dir(tmp_path_factory):
    """A minimal bench directory: one comparison with one chart."""
    folder = tmp_path_factory.mktemp("bench")
    rows = [{"method": "a", "t": 1e-3, "e": 0.1, "default": True}, {"method": "a", "t": 1e-2, "e": 0.01}]
    draw_pareto(rows, {"x": "t", "y": "e", "series": ["method"]}, folder / "demo.png")
    write_json(folder / "bench.json", {"created": "2026-01-01T00:00:00+00:00", "quick": True,
                                       "machine": {"processor": "x86_64", "cpu_count": 2},
                                       "comparisons": {"demo": {"status": "ok", "charts": ["demo.png"],
                                                                "supports": {"degree": 5}}}})
    return folder


@pytest.fixture(scope="module")
def report_html(twin_files, study_file, bench_dir, tmp_path_factory):
    raw, cal = twin_files
    out = tmp_path_factory.mktemp("html") / "report.html"
    result = CliRunner().invoke(cli, ["report", str(cal), "--raw", str(raw), "--study", str(study_file),
                                      "--bench", str(bench_dir), "--out", str(out), "--json"],
                                catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert json.loads(result.output)["bytes"] == out.stat().st_size
    return out


@pytest.mark.slow
def test_report_is_self_contained(report_html):
    page = report_html.read_text(encoding="utf-8")
    sources = re.findall(r'(?:src|href)="([^"#]*)"', page)
    assert sources and all(s.startswith("data:image/png;base64,") for s in sources)
    assert "http://" not in page and "https://" not in page
    assert "<script" not in page


def test_report_has_every_section_and_the_truth(report_html, twin_files, study_file):
    page = report_html.read_text(encoding="utf-8")
    for title in ("Summary", "Grid and fit residuals", "Level sets and traced tips", "Lookup z → tip",
                  "Flat-plane study", "Speed against accuracy", "Provenance"):
        assert f"<h2>{title}</h2>" in page
    assert "Against the twin&#x27;s true tips" in page
    from whiskercal.artifacts.h5io import sha256_file

    for path in (*twin_files, study_file):
        assert sha256_file(path) in page
    # residuals, level sets, lookup, the study's three figures, the bench's one chart
    assert page.count("<img ") == 7
    study_rows = re.findall(r"<tr><td>(10|30)</td>", page)
    assert study_rows == ["10", "30"]

def test_residual_map_reproduces_the_artifacts_fit(report_html, twin_files):
    from whiskercal.artifacts.calibration import read_calibration

    page = report_html.read_text(encoding="utf-8")
    shown = float(re.search(r"Residual RMS ([0-9.]+) µT", page).group(1))
    assert shown == pytest.approx(read_calibration(twin_files[1]).metrics["rmse_uT"], abs=1e-3)


def test_without_raw_the_grid_is_explained_not_drawn(twin_files, tmp_path):
    _, cal = twin_files
    out = tmp_path / "bare.html"
    result = CliRunner().invoke(cli, ["report", str(cal), "--out", str(out)], catch_exceptions=False)
    assert result.exit_code == 0
    page = out.read_text(encoding="utf-8")
    assert "No raw grid given" in page
    assert "Speed against accuracy" not in page


def test_a_missing_calibration_is_one_line_and_nonzero(tmp_path):
    result = CliRunner().invoke(cli, ["report", str(tmp_path / "none.h5"), "--out",
                                      str(tmp_path / "r.html")])
    assert result.exit_code != 0
    assert result.output.count("\n") == 1 and result.output.startswith("error:")


def test_a_bench_directory_without_bench_json_is_refused(twin_files, tmp_path):
    _, cal = twin_files
    result = CliRunner().invoke(cli, ["report", str(cal), "--bench", str(tmp_path), "--out",
                                      str(tmp_path / "r.html")])
    assert result.exit_code == 2
    assert "no bench.json" in result.output


@pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed (apt-get install chromium)")
def test_every_figure_loads_in_headless_chromium(report_html, tmp_path):
    page = report_html.read_text(encoding="utf-8")
    probe = tmp_path / "probe.html"
    probe.write_text(page.replace("</body>", PROBE), encoding="utf-8")
    with tempfile.TemporaryDirectory() as profile:
        dom = subprocess.run([CHROMIUM, *CHROMIUM_FLAGS, f"--user-data-dir={profile}",
                              "--virtual-time-budget=10000", "--dump-dom", probe.as_uri()],
                             capture_output=True, text=True, timeout=120, check=True).stdout
    widths = re.search(r'data-img-widths="([^"]*)"', dom)
    assert widths is not None, "the page did not finish loading"
    values = [int(w) for w in widths.group(1).split(",")]
    assert len(values) == page.count("<img ")
    assert all(w > 0 for w in values), values


def test_the_report_says_when_the_grid_was_collected_open_loop():
    from types import SimpleNamespace

    from whiskercal.report.build import _positions_note

    assert "Open loop" in _positions_note(SimpleNamespace(encoders="none"))
    assert "measured by the stage's encoders" in _positions_note(SimpleNamespace(encoders="measured"))
