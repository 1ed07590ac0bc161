"""The field benchmark runs and reports errors that agree with the field's own checks."""

from whiskercal.bench import field_speed


def test_field_speed_benchmark_reports_times_and_errors():
    result = field_speed.run(n_single=50, n_batch=500)
    errors = result["max_error_uT"]
    assert max(errors["interpolated_vs_exact_working_range"]) < 0.5
    assert max(errors["interpolated_vs_exact_whole_grid"]) < 0.5
    # Next to the magnet the dipole is far off: the reason the twin uses the exact field.
    assert max(errors["dipole_vs_exact_working_range"]) > 100.0
    assert result["table_nodes"] > 0 and result["table_build_s"] > 0
    assert all(value > 0 for value in result["batch_per_pose_us"].values())
    assert result["study_real_time_s"] == 72.0
