"""The run file records the controller's phase per sample and each change of phase with its rule;
the report draws them."""

import numpy as np
from tests_follow_artifact import calibration_path

from whiskercal.artifacts.contour_run import read_contour_run
from whiskercal.contour import contour_to_file
from whiskercal.follow import RULES, Phase
from whiskercal.report.contour import write_report


def test_a_wall_run_records_every_change_of_phase_with_an_allowed_rule(tmp_path):
    path = tmp_path / "wall.h5"
    contour_to_file("wall", calibration_path(), path, duration_s=6.0, seed=1)
    run = read_contour_run(path)
    phases, changes = run.columns["phase"], run.transitions
    assert set(phases) <= {phase.value for phase in Phase}
    assert list(changes["rule"][:2]) == ["touched", "target reached"]
    for source, target, rule in zip(changes["source"], changes["target"], changes["rule"]):
        assert Phase(source) in RULES[rule].sources and RULES[rule].target in (None, Phase(target))
    # each change of the phase a sample was handled in is logged at that sample or the one
    # before it (a rule that fires while a sample is handled takes effect from the next)
    logged = set(changes["sample"]) | {index + 1 for index in changes["sample"]}
    changed = np.flatnonzero(phases[1:] != phases[:-1]) + 1
    assert changed.size and set(changed) <= logged
    summary = write_report(run, tmp_path / "report")
    assert summary["rules_fired"]["touched"] >= 1
    assert (tmp_path / "report" / "phases.png").stat().st_size > 0
    assert "target reached" in (tmp_path / "report" / "contour.html").read_text(encoding="utf-8")
