"""Suite-wide pytest hooks: the ``adversarial`` case count.

The markers (``slow``, ``install``, ``warp``, ``readme``, ``adversarial``) are declared in
``pyproject.toml`` (``[tool.pytest.ini_options] markers``); the README's "Tests" section says what
each means and which command leaves which out.

Every hostile-input test (NaN, inf, wrong types and shapes, zero, negative, huge and non-integer
values, corrupt files, bad CLI options) is marked ``@pytest.mark.adversarial``; a test that tries
many hostile calls in one item (the public-API walk of ``tests/test_adversarial_api.py``) reports
them through the ``hostile_calls`` fixture. The terminal summary says how many such cases ran and
how many passed.
"""

from __future__ import annotations

import pytest

import models  # noqa: F401  (first: it picks MuJoCo's off-screen GL backend before anything loads mujoco)

#: tests over ~2 s on 2 loaded cores (measured with --durations=0; the time of the slowest
#: parametrization), marked ``slow`` here so that files other work is editing need no change; a
#: file or test may also carry ``@pytest.mark.slow`` itself. "file::name" covers every parametrization.
SLOW = {
    "test_boundaries.py::test_the_walk_finds_planted_violations",  # 3 s (each of 5 plants walks the source)
    "test_recording.py::test_run_blueprint_views_point_at_the_recording",  # 4.5 s with its setup
    "test_adversarial_fit.py::test_a_folder_holding_another_fit_is_refused",  # 3 s
    "test_batched_planner.py::test_profiles_equal_the_generators",  # 3 s
    "test_batched_planner.py::test_profiles_of_other_generators",  # 6 s
    "test_envs.py::test_check_env_passes",  # 3 s
    "test_envs.py::test_memory_does_not_grow_over_ten_thousand_steps",  # 171 s
    "test_envs.py::test_pickle_and_copy_refuse_clearly_without_a_stray_traceback",  # 5 s
    "test_envs.py::test_vector_envs_run",  # 8 s
    "test_fovea_cortex_remap.py::test_fovea_lattice_matches_pixels_in_paper_example",  # 2 s
    "test_grid_sampling.py::test_constant_image_samples_to_constant",  # 2 s
    "test_modelfit.py::test_fit_resumes_from_its_cache_and_log",  # 16 s
    "test_modelfit.py::test_parameters_and_model_are_recovered",  # 113 s idle (446 s on loaded cores)
    "test_modelfit.py::test_ray_backend_gives_the_local_observations",  # 32 s
    "test_models_render.py::test_egl_is_the_default_backend_and_its_hint_names_the_packages",  # 3 s
    "test_models_render.py::test_ten_thousand_renders_do_not_grow_memory",  # 9 s
    "test_models_saccades.py::test_profile_table_matches_a_direct_simulation",  # 4 s
    "test_perception_mechanisms.py::test_compression_grows_with_saccade_amplitude",  # 4 s
    "test_perception_mechanisms.py::test_displacement_paradigm_blank_restores_detection",  # 9 s
    "test_perception_mechanisms.py::test_phenomena_command_writes_the_report",  # ~90 s
    "test_recovery.py::test_recovery_confusion_matrix",  # ~50 s
    "test_perception_mechanisms.py::test_rows_name_model_condition_and_paradigm",  # 19 s
    "test_psychophysics.py::test_cli_small_study_writes_outputs",  # 3 s
    "test_psychophysics.py::test_gain_zero_is_veridical_up_to_sampling_error",  # 12 s
    "test_psychophysics.py::test_killed_parallel_run_resumes",  # 19 s
    "test_psychophysics.py::test_quick_study_through_the_command_line",  # 10 s
    "test_recording.py::test_cli_writes_recording",  # 2 s
    "test_recording.py::test_every_entity_present",  # 5 s
    "test_recording.py::test_serve_on_loopback_only_and_stops_by_itself",  # 9 s
    "test_remap_pooled.py::test_field_moments_match_the_pooled_retinas_operator",  # 3 s
    "test_remap_pooled.py::test_pooled_prediction_is_never_much_worse",  # 5 s
    "test_results_integrity.py::test_a_second_run_on_the_same_folder_is_refused",  # 3 s
    "test_results_integrity.py::test_interrupted_command_stops_its_workers_and_says_how_to_resume",  # 8 s
    "test_results_integrity.py::test_kill_9_of_the_command_leaves_no_workers",  # 9 s
    "test_results_integrity.py::test_workers_use_one_thread_ignore_ctrl_c_and_know_their_parent",  # 3 s
    "test_rl.py::test_cli_bad_options_fail_clearly",  # 4 s
    "test_rl.py::test_sb3_recipe_prints_progress_and_evaluate_loads_it",  # 42 s
    "test_rl.py::test_sb3_recipe_runs",  # 2 s
    "test_rl.py::test_train_recipe_runs_a_few_hundred_steps_and_evaluates",  # PPO and SAC, 256 steps each
    "test_rl.py::test_baselines_command_trains_evaluates_aggregates_and_resumes",  # 4 quick runs
    "test_rl.py::test_training_keeps_one_torch_thread_whatever_ran_before",  # two training subprocesses
    "test_rl.py::test_wrap_conv_is_equivariant_to_sector_rolls_and_wraps",  # torch's first import
    "test_rl.py::test_iqm_and_bootstrap_match_a_direct_computation",  # scipy's first import
    "test_rl.py::test_potential_shaping_telescopes",  # two envs
    "test_rl.py::test_train_sb3_cli_refuses_bad_combinations",  # 4 s
    "test_rl.py::test_cell_head_policy_is_the_cell_map",  # SB3's first import
    "test_rl.py::test_gymnasium_wrappers_compose_with_shaping",
    "test_rl.py::test_skrl_recipe_trains_the_cortical_cell_policy_on_cpu",  # ~25 s: Warp on the CPU backend
    "test_rl.py::test_short_training_beats_random_by_a_clear_margin",  # 15 s
    "test_rl.py::test_train_and_evaluate_commands_end_to_end",  # 3 s
    # the users of module fixtures that simulate for 5-20 s (a trained policy, study tables, a recorded run)
    "test_rl.py::test_saved_policy_reloads_and_evaluates_identically",
    "test_psychophysics.py::test_errors_point_towards_the_target_near_onset",
    "test_psychophysics.py::test_compression_peaks_near_onset_and_vanishes_far_from_it",
    "test_psychophysics.py::test_eye_position_signal_shifts_flashes_along_then_against_the_saccade",
    "test_perception_mechanisms.py::test_dark_flashes_before_the_saccade_shift_in_its_direction",
    "test_perception_mechanisms.py::test_compression_near_onset_needs_references",
    "test_perception_mechanisms.py::test_nothing_beyond_the_sampling_error_far_from_the_saccade",
    "test_perception_mechanisms.py::test_every_mechanism_off_is_the_sampling_error_alone",
    "test_recording.py::test_image_shapes",
    "test_recording.py::test_time_range_and_resolution",
    "test_recording.py::test_every_timed_entity_lies_in_the_run_and_3d_shapes",
    "test_recording.py::test_saccades_visible_in_velocity",
    "test_recording.py::test_remap_difference_is_abs_of_predicted_minus_actual",
    "test_recording.py::test_dots_scene_in_the_env_recording",
}

_ADVERSARIAL = {"passed": 0, "failed": 0, "skipped": 0}
_CALLS = {"tried": 0, "refused": 0}


class HostileCalls:
    """Counts the hostile calls one test item makes (``add(tried, refused)``)."""

    def add(self, tried: int, refused: int) -> None:
        _CALLS["tried"] += tried
        _CALLS["refused"] += refused


@pytest.fixture
def hostile_calls() -> HostileCalls:
    return HostileCalls()


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        if f"{item.path.name}::{item.originalname}" in SLOW:
            item.add_marker(pytest.mark.slow)


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    if "adversarial" not in report.keywords:
        return
    if report.when == "call" or (report.when == "setup" and report.outcome != "passed"):
        _ADVERSARIAL[report.outcome] = _ADVERSARIAL.get(report.outcome, 0) + 1


def pytest_terminal_summary(terminalreporter, exitstatus, config) -> None:
    n = sum(_ADVERSARIAL.values())
    if n:
        terminalreporter.write_line(
            f"adversarial inputs: {n} cases tried, {_ADVERSARIAL['passed']} passed, "
            f"{_ADVERSARIAL['failed']} failed, {_ADVERSARIAL['skipped']} skipped")
    if _CALLS["tried"]:
        terminalreporter.write_line(
            f"public-API walk: {_CALLS['tried']} hostile calls, {_CALLS['refused']} refused with a clear error")
