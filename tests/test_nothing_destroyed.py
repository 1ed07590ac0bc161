"""No file is ever destroyed: an input is never an output (same name, symbolic or hard link),
paths named by data files stay inside their folder, and files are replaced atomically."""

import json
import os
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from whiskercal import atomic
from whiskercal.cli import cli
from whiskercal.errors import UsageError

ROOT = Path(__file__).resolve().parents[1]
SHORT = ROOT / "data" / "twin-short-60mm"
CALIBRATION = ROOT / "tests" / "fixtures" / "calibration-1.0.0.h5"
LINKS = ("same", "hard", "symbolic")


def _run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def _alias(original: Path, how: str, directory: Path) -> Path:
    """Another name for ``original``: itself, a hard link or a symbolic link in ``directory``."""
    if how == "same":
        return original
    alias = directory / f"{how}-alias{original.suffix}"
    (os.link if how == "hard" else os.symlink)(original, alias)
    return alias


def _assert_refused(result, original: Path, before: bytes) -> None:
    assert result.exit_code == 2, result.output
    assert result.stderr.count("\n") == 1 and "is the input" in result.stderr, result.stderr
    assert original.read_bytes() == before  # the input is untouched


@pytest.fixture
def files(tmp_path):
    """Copies of a raw grid, a study, a calibration artifact and a TOML config to write over."""
    for name in ("raw_grid.h5", "plane_study.h5", "study.toml", "collect.toml"):
        shutil.copy(SHORT / name, tmp_path / name)
    shutil.copy(CALIBRATION, tmp_path / "cal.h5")
    return tmp_path


@pytest.mark.parametrize("how", LINKS)
def test_fit_refuses_to_write_over_its_raw_grid(files, how):
    raw = files / "raw_grid.h5"
    before = raw.read_bytes()
    _assert_refused(_run("fit", raw, "--out", _alias(raw, how, files)), raw, before)


@pytest.mark.parametrize("how", LINKS)
@pytest.mark.parametrize("option, name", [(None, "cal.h5"), ("--raw", "raw_grid.h5"),
                                          ("--study", "plane_study.h5")])
def test_report_refuses_to_write_over_a_file_it_reads(files, how, option, name):
    target = files / name
    before = target.read_bytes()
    extra = [option, target] if option else []
    result = _run("report", files / "cal.h5", *extra, "--out", _alias(target, how, files))
    _assert_refused(result, target, before)


def test_report_refuses_to_write_over_the_bench_results_it_embeds(files):
    bench = files / "bench"
    bench.mkdir()
    (bench / "bench.json").write_text(json.dumps({"comparisons": {}}), encoding="utf-8")
    (bench / "degree.png").write_bytes(b"\x89PNG chart")
    for target in (bench / "bench.json", bench / "degree.png"):
        before = target.read_bytes()
        _assert_refused(_run("report", files / "cal.h5", "--bench", bench, "--out", target),
                        target, before)


@pytest.mark.parametrize("how", LINKS)
@pytest.mark.parametrize("name", ["cal.h5", "plane_study.h5"])
def test_optimal_depth_report_refuses_out_artifact_over_an_input(files, how, name):
    target = files / name
    before = target.read_bytes()
    result = _run("optimal-depth", "report", files / "plane_study.h5", "--artifact",
                  files / "cal.h5", "--out-artifact", _alias(target, how, files))
    _assert_refused(result, target, before)


def test_optimal_depth_report_refuses_figures_over_an_input(files):
    study = files / "errors.png"  # a study file given the name of a figure the report draws
    shutil.move(files / "plane_study.h5", study)
    before = study.read_bytes()
    result = _run("optimal-depth", "report", study, "--artifact", files / "cal.h5",
                  "--out-artifact", files / "new.h5")
    _assert_refused(result, study, before)


@pytest.mark.parametrize("how", LINKS)
def test_runs_refuse_to_write_their_dataset_over_the_config(files, how):
    for command, config in ((["collect", "--stage", "sim://x/stage", "--sensor", "sim://x/sensor"],
                             files / "collect.toml"),
                            (["optimal-depth", "run", "--stage", "sim://x/stage", "--sensor",
                              "sim://x/sensor"], files / "study.toml")):
        before = config.read_bytes()
        alias = _alias(config, how, files)
        _assert_refused(_run(*command, "--config", config, "--out", alias), config, before)
        if alias != config:
            alias.unlink()


@pytest.fixture
def dataset(tmp_path):
    shutil.copytree(SHORT, tmp_path / "data" / SHORT.name)
    return tmp_path / "data" / SHORT.name


@pytest.mark.parametrize("how", ["hard", "symbolic"])
def test_regress_update_refuses_a_golden_file_that_is_a_recorded_file(dataset, how):
    raw = dataset / "raw_grid.h5"
    before = raw.read_bytes()
    (dataset / "golden.json").unlink()
    (os.link if how == "hard" else os.symlink)(raw, dataset / "golden.json")
    _assert_refused(_run("regress", dataset, "--update"), raw, before)


def test_regress_update_refuses_a_golden_file_that_leads_outside_the_dataset(dataset):
    outside = dataset.parents[1] / "elsewhere.json"
    shutil.move(dataset / "golden.json", outside)
    before = outside.read_bytes()
    os.symlink(Path("..") / ".." / outside.name, dataset / "golden.json")
    result = _run("regress", dataset, "--update")
    assert result.exit_code == 2, result.output
    assert "leads outside" in result.stderr and result.stderr.count("\n") == 1
    assert outside.read_bytes() == before


def test_a_chart_named_by_bench_json_outside_its_folder_is_refused(files):
    secret = files / "secret.png"
    secret.write_bytes(b"\x89PNG not to be embedded")
    bench = files / "runs" / "bench"
    bench.mkdir(parents=True)
    entry = {"status": "ok", "charts": ["../../secret.png"], "supports": {}}
    (bench / "bench.json").write_text(json.dumps({"comparisons": {"degree": entry}}),
                                      encoding="utf-8")
    result = _run("report", files / "cal.h5", "--bench", bench, "--out", files / "r.html")
    assert result.exit_code == 2, result.output
    assert "leads outside" in result.stderr and "../../secret.png" in result.stderr
    assert not (files / "r.html").exists()


@pytest.mark.parametrize("name", ["../x", "/etc/passwd", "a/../../x"])
def test_inside_refuses_names_that_leave_the_folder(tmp_path, name):
    with pytest.raises(UsageError, match="leads outside"):
        atomic.inside(tmp_path, name)
    assert atomic.inside(tmp_path, "a/../b.png") == tmp_path.resolve() / "b.png"


def test_an_interrupted_write_leaves_the_old_file_and_no_scratch(tmp_path):
    target = atomic.write_text(tmp_path / "out.json", "old")
    with pytest.raises(RuntimeError):
        with atomic.atomic_open(target) as handle:
            handle.write("half of the new")
            raise RuntimeError("interrupted")
    assert target.read_text() == "old"
    assert os.listdir(tmp_path) == ["out.json"]


def test_a_replaced_file_keeps_its_mode_and_a_new_one_follows_the_umask(tmp_path):
    kept = atomic.write_text(tmp_path / "kept.txt", "a")
    os.chmod(kept, 0o640)
    atomic.write_text(kept, "b")
    assert kept.stat().st_mode & 0o777 == 0o640
    umask = os.umask(0o022)
    try:
        fresh = atomic.write_bytes(tmp_path / "fresh.bin", b"x")
    finally:
        os.umask(umask)
    assert fresh.stat().st_mode & 0o777 == 0o644


def test_a_hard_link_to_a_replaced_file_keeps_the_old_content(tmp_path):
    target = atomic.write_text(tmp_path / "a.txt", "old")
    os.link(target, tmp_path / "b.txt")
    atomic.write_text(target, "new")
    assert (tmp_path / "b.txt").read_text() == "old" and target.read_text() == "new"
