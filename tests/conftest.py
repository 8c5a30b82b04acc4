"""Markers for the suite, so that a change can be checked by the part it touches (`make test-fast`).

- ``slow``: the tests that took over 2 s each in a full run on a loaded two-core machine (measured with
  ``pytest --durations=0``; the table below is that measurement, refreshed by hand when it drifts), and
  whole-pipeline checks (init -> fit -> replay, a fit only they read) whose packages test-fast reaches anyway;
- ``fuzz``: the seeded command-line fuzz cases (``test_cli_fuzz*.py``);
- ``needs_cc``, ``needs_arm``, ``needs_browser``: what a test module runs besides Python, read from its source
  (a compiler, the arm-none-eabi toolchain, headless chromium), so ``-m "not needs_arm"`` works on a machine
  without the cross compiler.
``make test`` runs everything; ``make test-fast`` runs ``-m "not slow and not fuzz"``.
"""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import pytest

SLOW: dict[str, tuple[str, ...]] = {
    "test_accelroute.py": (
        "test_fit_blends_the_noisy_input_and_an_unseen_still_air_flight_reads_less",
        "test_hover_noise_0_keeps_the_observer",
        "test_the_text_report_shows_both_noise_figures",
    ),
    "test_accuracy.py": (
        "test_a_failed_fit_is_a_result_not_a_crash",
        "test_rate_study_fits_each_rate_and_measures_the_spread_of_one_tunnel",
        "test_whole_benchmark_on_a_tiny_vehicle",
    ),
    "test_airframe_ranges.py": (
        "test_a_corner_of_the_ranges_checks_generates_compiling_c_and_analyses",
    ),
    "test_analysis.py": (
        "test_analyze_json_and_plots",
        "test_gain_design_round_trip",
        "test_m300_design_near_the_papers_gain",
    ),
    "test_blendnoise.py": (
        "test_the_steps_blend_leaves_the_closed_form_share_of_the_noise",
    ),
    "test_body_drag.py": (
        "test_columns_built_in_blocks_equal_one_pass",
        "test_generated_c_of_a_body_drag_airframe_matches_the_reference",
    ),
    "test_cformat.py": (
        "test_the_magnitudes_a_log_holds",
        "test_every_decade_at_random",
    ),
    "test_cli_fuzz_generated.py": (
        "test_a_generated_case_ends_cleanly_within_its_time_limit",
    ),
    "test_dataflash.py": (
        "test_fit_on_dataflash_equals_fit_on_the_equivalent_csv",
        "test_the_primary_core_is_followed_across_a_lane_switch",
    ),
    "test_docfigures.py": (  # the docs page's figures rebuilt (two airframes' analyses): make test keeps it current
        "test_figures_page_is_current",
    ),
    "test_drag_exponent.py": (
        "test_an_unusable_law_keeps_the_quadratic_one",
        "test_generated_c_of_an_exponent_law_matches_the_reference",
        "test_the_exponent_chosen_is_the_laws",
        "test_the_set_chosen_again_must_still_beat_the_quadratic_law",
    ),
    "test_fit_input.py": (
        "test_a_log_too_short_to_calibrate_beside_a_good_one_is_handled",
    ),
    "test_fit_stream.py": (
        "test_a_capped_calibration_is_thinned_evenly_and_streams_byte_for_byte",
        "test_a_fit_sampled_too_sparsely_for_its_cv_says_so",
        "test_the_log_sampler_over_blocks_is_one_pass_with_segments_and_invalid_rows",
        "test_the_self_check_over_blocks_is_one_pass",
        "test_the_streamed_fit_writes_the_whole_log_fits_airframe_byte_for_byte",
    ),
    "test_fourfold.py": (
        "test_the_fit_adds_the_harmonics_for_per_axis_drag",
        "test_the_fit_leaves_them_out_for_drag_along_the_airflow",
        "test_the_hold_level_tie_break_keeps_the_smallest_set_without_a_significant_gain",
        "test_with_the_harmonics_the_set_is_chosen_again",
    ),
    "test_harness.py": (
        "test_every_mode_matches_the_reference_in_double",
        "test_verify_command_passes_on_the_reference_airframe",
    ),
    "test_help.py": (
        "test_analyze_bandwidth_writes_the_designed_airframe_and_analyses_it",
    ),
    "test_hovernoise.py": (
        "test_fit_lowers_the_zero_airflow_cutoff_of_a_noisy_vehicle_and_still_air_reads_less",
        "test_the_text_report_says_what_the_fit_did_to_the_low_pass",
    ),
    "test_install.py": (
        "test_wheel_installs_and_runs_outside_the_checkout",
    ),
    "test_json_output.py": (
        "test_analyze_bandwidth_json",
        "test_verify_json_with_a_non_finite_figure",
    ),
    "test_isolation.py": (  # a child pytest over four modules' quick tests
        "test_representative_modules_write_nothing_into_the_checkout_and_run_from_elsewhere",
    ),
    "test_json_style.py": (
        "test_check_analyze_replay_share_one_style",
    ),
    "test_kernels.py": (
        "test_the_frozen_coefficients_are_a_near_minimax_fit",
    ),
    "test_law_increasing.py": (
        "test_linear_anisotropy_the_data_need_is_kept",
        "test_no_vertical_drag_is_refused",
        "test_quadratic_anisotropy_without_linear_drag_is_found",
    ),
    "test_model.py": (
        "test_moving_through_still_air_estimates_zero_wind",
    ),
    "test_mutants.py": (
        "test_a_c_mutant_is_caught_by_verify_and_the_self_test",
        "test_the_named_model_mutants_are_caught_by_the_suite",
    ),
    "test_outputs.py": (
        "test_a_full_disk_changes_nothing",
        "test_a_signal_mid_write_leaves_the_previous_output",
        "test_the_next_run_removes_what_a_killed_run_left_and_nothing_else",
    ),
    "test_frontback.py": (
        "test_the_fit_adds_the_pair_for_a_front_back_per_axis_body",
        "test_the_fit_leaves_the_pair_out_without_a_front_back_shape",
    ),
    "test_peraxis.py": (
        "test_the_fit_adds_the_pair_for_a_six_to_one_body",
        "test_near_equal_axes_keep_the_harmonics",
    ),
    "test_optional_groups.py": (
        "test_generated_c_with_the_group_matches_the_reference",
    ),
    "test_pipeline.py": (
        "test_accuracy_on_the_projects_simulator",  # the module's fit's last reader in test-fast (4 s)
        "test_fit_recovers_the_thrust_scale_and_a_good_model",
        "test_fit_report_json",
        "test_replay_backends_agree_and_output_has_every_row",
    ),
    "test_quality.py": (
        "test_a_gap_recovers_in_the_generated_c",
        "test_backends_agree_on_every_status_bit_at_max_dt",
        "test_quality_bits_and_sigma_agree_in_c",
        "test_sigma_with_observer_noise_agrees_in_c",
    ),
    "test_real_data.py": (  # every reader of the two real-data fits (12 s), not only the leave-one-out
        "test_neural_fly_leave_one_out_bounds_put_35wind_beyond_every_convex_law",
        "test_neural_fly_constant_wind_fit_writes_a_model_and_names_its_outlier",
        "test_neural_fly_held_out_speed",
        "test_neural_fly_split_fit_warns_that_its_vertical_law_is_not_identified",
        "test_neural_fly_leave_one_out_scores_every_run_and_judges_the_interior_ones",
        "test_neural_fly_runs_against_a_convex_law",
        "test_neural_fly_wind_direction",
    ),
    "test_report.py": (
        "test_report_is_self_contained_and_complete",
        "test_report_opens_in_headless_chromium_without_errors",
    ),
    "test_rosbag.py": (
        "test_bag_replay_equals_the_equivalent_csv",
        "test_px4_1_16_topic_names_with_v1_are_found",
        "test_px4_bag_with_vehicle_local_position_instead_of_odometry",
        "test_topic_names_are_overridable",
    ),
    "test_sampler_robust.py": (
        "test_fit_of_a_log_whose_first_rows_are_invalid",
        "test_fit_with_a_log_without_a_valid_row",
        "test_invalid_leading_rows_are_as_if_absent_whole_and_streamed",
        "test_the_streamed_fit_of_a_log_with_invalid_first_rows_is_the_whole_log_fit",
    ),
    "test_inspect.py": (  # init -> verify on its starter airframe, init -> check on each real log
        "test_init_says_the_mass_is_unchecked_and_a_wrong_one_only_scales_the_law",
        "test_rosbag_streams_airborne_esc_wind_and_init",
        "test_real_logs_init_a_starter_that_passes_check",
        "test_the_starter_airframe_passes_verify",
    ),
    "test_sitlcompare.py": (  # init -> fit -> replay on the real SITL log (a fit)
        "test_report_has_the_simulator_table_and_keeps_the_inactive_autopilot_sentence",
        "test_the_field_sitl_log_through_init_fit_replay",
    ),
    "test_selfcheck.py": (
        "test_a_good_fit_passes_and_its_replay_matches_replay",
        "test_a_log_that_contributes_nothing_fails_and_nothing_is_written",
        "test_fit_records_the_observer_noise_of_its_own_replay",
    ),
    "test_selftest.py": (
        "test_a_nan_wind_direction_fails_the_selftest",
        "test_the_unpatched_selftest_passes",
    ),
    "test_simulate_stream.py": (
        "test_blocks_join_to_the_single_pass_log",
    ),
    "test_stream.py": (
        "test_library_cache_reuses_one_build_and_survives_concurrent_misses",
        "test_streamed_replay_is_the_single_pass_bit_for_bit",
    ),
    "test_fit_schema.py": (  # the first of them fits two small simulated flights (19 s)
        "test_real_fit_reports_match_the_schema",
        "test_a_renamed_or_retyped_field_fails",
        "test_tunnel_runs_and_wind_unknown_reports_match_the_schema",  # two more fits (37 s of CPU)
    ),
    "test_structure.py": (
        "test_no_function_over_60_lines",
    ),
    "test_cvdiverge.py": (
        "test_the_drag_fusion_field_log_names_its_diverged_fold_instead_of_480_mps",  # init and a fit (8 s)
    ),
    "test_fieldcal.py": (
        "test_wind_unknown_per_segment_finds_each_segments_wind",
        "test_wind_unknown_refuses_a_flight_whose_nose_never_turns",
        "test_a_refusal_with_several_winds_says_which_were_identified",  # the two-winds solve's last quick reader
    ),
    "test_ulog.py": (
        "test_corrupt_ulogs_end_quickly_with_one_line_or_one_json_object",
        "test_report_compares_with_px4_wind_when_the_log_has_no_truth",
    ),
    "test_windunits.py": (
        "test_analyze_designs_for_a_wind_target_and_reports_it",
        "test_analyze_draws_the_wind_unit_figure_over_the_airspeeds_asked",
    ),
    "test_report_wording.py": (
        "test_a_prior_airframe_says_so_in_the_airframe_table",
        "test_an_inactive_autopilot_wind_is_not_introduced_as_a_comparison",  # zero_wind's report's last quick reader
    ),
    "test_verify_fastmath.py": (
        "test_verify_with_px4_flags_passes_and_leaves_this_process_with_subnormals",
        "test_a_nonnegative_test_by_float_comparison_fails_the_reference_comparison_under_px4",
    ),
    "test_fieldreplay.py": (
        "test_report_on_a_dataflash_log",
    ),
    "test_fieldcal_bench.py": (
        "test_end_to_end_prints_one_json_document",
    ),
    "test_verify_report.py": (
        "test_verify_checks_a_given_folder_and_catches_a_hand_edit",
    ),
    "test_analysis_goals.py": (
        "test_analyze_ramp_lag_matches_a_replayed_ramp",
    ),
}
FUZZ_FILES = ("test_cli_fuzz.py", "test_cli_fuzz_generated.py", "test_campaign_sample.py")
# What in a test module's source says it runs a tool besides Python.
NEEDS: dict[str, tuple[str, ...]] = {
    "needs_arm": ("arm-none-eabi",),
    "needs_browser": ("chromium",),
    "needs_cc": ("compile", "build_shared_library", "_compiler(", "CStep", "backend=\"c\"", "--backend\", \"c"),
}
MARKERS = {
    "slow": "over 2 s on a loaded two-core machine (skipped by make test-fast)",
    "fuzz": "a seeded command-line fuzz case (skipped by make test-fast)",
    "needs_cc": "builds C with the host compiler",
    "needs_arm": "builds C with arm-none-eabi-gcc",
    "needs_browser": "opens a page in headless chromium",
}


def pytest_configure(config: pytest.Config) -> None:
    for name, text in MARKERS.items():
        config.addinivalue_line("markers", f"{name}: {text}")


@lru_cache(maxsize=None)
def _needs(path: Path) -> tuple[str, ...]:
    text = path.read_text(encoding="utf-8")
    return tuple(marker for marker, words in NEEDS.items() if any(word in text for word in words))


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        path = Path(str(item.path))
        name = item.name.split("[", 1)[0]
        if name in SLOW.get(path.name, ()):
            item.add_marker(pytest.mark.slow)
        if path.name in FUZZ_FILES:
            item.add_marker(pytest.mark.fuzz)
        for marker in _needs(path):
            item.add_marker(getattr(pytest.mark, marker))
    items[:] = longest_first(items)


# --- module order for two workers ----------------------------------------------------------------------
# `make test` gives each pytest-xdist worker whole modules (--dist loadfile), taken from a queue in
# collection order. Two workers finish together when the long modules are handed out first and the short
# ones fill the gaps at the end, so modules are collected longest-first. The seconds below are each module's
# own time (the sum of its tests' setup, call and teardown) in a JUnit report of a full run, printed as this
# table by tools/module_seconds.py (modules under 2 s are left out: they keep collection order, at the end):
#   .venv/bin/python -m pytest -q -p no:xdist --junitxml=out/suite.xml
#   .venv/bin/python -m tools.module_seconds out/suite.xml
# Measured 2026-12-06 with -n 2 on the shared two-core machine under a load of 0.5-2.4 (other jobs running),
# with the Neural-Fly data beside the checkout (test_real_data.py skips without it). Refresh it by hand
# when a module grows or shrinks a lot; a stale table costs time, never a result. tests/test_parallel.py
# checks that every name here is an existing module. test_outputs, test_fieldcal and test_fit_schema were made
# cheaper after that run: their figures are scaled by the measured before/after ratio, not re-run; so are
# test_real_data (its fixture skips check()'s five leave-one-out fits, which one slow test runs instead:
# 58 s serial on an idle machine, about the same as before) and
# test_report_wording (one report fewer: 11 x 9.7/11.8). The modules issue #34's third round changed (shared
# analysis figures, a shared two-segment solve, tests moved to slow) were measured again alone, full (slow tests
# included), with -n 2 under a load of 1-2: test_real_data, test_pipeline, test_inspect, test_fieldcal, test_ulog,
# test_dataflash, test_sitlcompare, test_fieldreplay, test_docfigures and test_report_wording (test_report, 1.5 s,
# left out). Issue #34's fourth round (branch suitespeed3) measured a full run with -n 2 under a load of 4.5 (other
# engineers' jobs): the untouched modules' sums were 1.7 times this morning's idle ones, and the modules it made
# cheaper are given as their sum in that run divided by 1.7 (test_range_walk, test_airframe_ranges,
# test_drag_exponent, test_sampler_robust). test_real_data ran first, under the heaviest load: it is given this
# morning's 56 s less its fixture's 10 s, the two fits the leave-one-out test no longer repeats.
# Issue #34's fifth round (branch suitespeed4) gives the modules it made cheaper as their sum in the idle -n 2
# run of main eb45670 times the ratio of branch to main in interleaved serial runs of those modules (same load):
# test_cli_fuzz_generated 58 x 0.69, test_range_walk 34.5 x 0.82, test_airframe_ranges 30 x 0.77,
# test_thrustscale 18 x 0.57, test_real_data 37 less the 1.5 s of realdata.consistency() it no longer repeats.
# Measured again 2026-12-07 on main (round 17), a full run with -n 2 --dist loadfile on the shared two-core
# machine with nothing else running (483 s), the Neural-Fly data beside the checkout; every figure below is
# from that run, replacing the history above.
MODULE_SECONDS: dict[str, float] = {
    "test_cli_fuzz_generated.py": 58,
    "test_real_data.py": 47,
    "test_campaign_sample.py": 46,
    "test_logfuzz.py": 38,
    "test_accuracy.py": 35,
    "test_inspect.py": 34,
    "test_airframe_ranges.py": 31,
    "test_outputs.py": 30,
    "test_drag_exponent.py": 26,
    "test_range_walk.py": 26,
    "test_fit_stream.py": 24,
    "test_ulog.py": 23,
    "test_harness.py": 23,
    "test_pipeline.py": 20,
    "test_dataflash.py": 20,
    "test_fieldcal.py": 18,
    "test_sampler_robust.py": 16,
    "test_sitlcompare.py": 16,
    "test_cformat.py": 16,
    "test_peraxis.py": 5,
    "test_fit_schema.py": 14,
    "test_logvariants.py": 14,
    "test_frontback.py": 5,   # less its verify test, now in test_optional_groups (by hand)
    "test_optional_groups.py": 30,  # the three groups' verify tests moved there (by hand)
    "test_selfcheck.py": 12,
    "test_hardening.py": 12,
    "test_mutants.py": 12,
    "test_hovernoise.py": 11,
    "test_fourfold.py": 6,
    "test_accelroute.py": 10,
    "test_thrustscale.py": 10,
    "test_analysis.py": 9,
    "test_autopilot_flags.py": 9,
    "test_windunits.py": 9,
    "test_rosbag.py": 8,
    "test_model.py": 8,
    "test_install.py": 8,
    "test_isolation.py": 8,
    "test_body_drag.py": 8,
    "test_autopilot_targets.py": 8,
    "test_directionshape.py": 8,
    "test_fieldcal_bench.py": 8,
    "test_verify_fastmath.py": 7,
    "test_quickaccept_c.py": 7,
    "test_cli_fuzz.py": 7,
    "test_autopilot_run.py": 6,
    "test_fieldreplay.py": 6,
    "test_verify_report.py": 5,
    "test_cparse.py": 5,
    "test_json_output.py": 5,
    "test_report_warnings.py": 5,
    "test_stream.py": 5,
    "test_atmos_netcdf.py": 4,
    "test_analysis_defects.py": 4,
    "test_atmos_profile.py": 4,
    "test_analysis_goals.py": 4,
    "test_calibration_run.py": 4,
    "test_bridge.py": 4,
    "test_codegen.py": 3,
    "test_tracked_airflow.py": 3,
    "test_law_increasing.py": 3,
    "test_structure.py": 3,
    "test_report_wording.py": 3,
    "test_cli_checks.py": 3,
    "test_casadi_lib.py": 3,
    "test_quality.py": 2,
    "test_escrpm.py": 2,
    "test_kernels.py": 2,
    "test_px4sim.py": 2,
    "test_blendnoise.py": 2,
    "test_report.py": 2,
    "test_docfigures.py": 2,
    "test_analysis_families.py": 2,
}


def longest_first(items: list[pytest.Item]) -> list[pytest.Item]:
    """The items regrouped by module, the modules by MODULE_SECONDS descending (ties and unlisted modules in
    collection order), each module's tests in their own order: the order is the same in every worker,
    as xdist requires, and a module stays contiguous."""
    first_seen: dict[str, int] = {}
    for item in items:
        first_seen.setdefault(Path(str(item.path)).name, len(first_seen))

    def rank(item: pytest.Item) -> tuple[float, int]:
        name = Path(str(item.path)).name
        return (-MODULE_SECONDS.get(name, 0.0), first_seen[name])

    return sorted(items, key=rank)  # sorted is stable: a module's tests keep their order


# --- shared fits -------------------------------------------------------------------------------------
# `dobwind fit` is the suite's most expensive step (30-140 s each on a loaded two-core machine), and some
# modules run the same fit twice only to read it two ways (--json and the text report). The fit is a pure
# function of the airframe, the log files and the options, so a test may ask for ``shared_fits``: the
# command line runs whole each time (parsing, writing, printing, exit status), and fitfamily.fit_airframe
# computes each distinct call once per module. A changed log (size or mtime) or option is a new call.

def _fit_key(args: tuple, kwargs: dict) -> str:
    af, paths, *rest = args
    files = [(str(p), Path(p).stat().st_size, Path(p).stat().st_mtime_ns) if Path(p).is_file() else (str(p),)
             for p in paths]
    return repr((af, files, rest, sorted(kwargs.items())))


class Memo:
    """A pure function computed once per distinct key; every caller gets its own deep copy (the caller may
    change what it is given). ``calls`` and ``computed`` let a test see the sharing happen. A subclass says
    what the key is (None: this call is never shared)."""

    def __init__(self, function):
        self.function, self.results, self.calls, self.computed = function, {}, 0, 0

    def key(self, args: tuple, kwargs: dict) -> str | None:
        raise NotImplementedError

    def __call__(self, *args, **kwargs):
        import copy

        self.calls += 1
        key = self.key(args, kwargs)
        if key is None:
            return self.function(*args, **kwargs)
        if key not in self.results:
            self.computed += 1
            self.results[key] = self.function(*args, **kwargs)
        return copy.deepcopy(self.results[key])


class FitMemo(Memo):
    """fit_airframe, keyed by the airframe, the log files' names, sizes and mtimes, and the options."""

    def key(self, args: tuple, kwargs: dict) -> str | None:
        if kwargs.get("log_reader") is not None:  # a reader object has no content key: never shared
            return None
        return _fit_key(args, kwargs)


@pytest.fixture(scope="module")
def _fit_memo() -> FitMemo:
    from dobwind.calibrate import fitfamily

    return FitMemo(fitfamily.fit_airframe)


@pytest.fixture
def shared_fits(_fit_memo: FitMemo, monkeypatch: pytest.MonkeyPatch) -> FitMemo:
    """The module's memo in place of fit_airframe, for the requesting test only (the results outlive it,
    the patch does not: a later test of the module that patches the fit's internals gets the real one)."""
    from dobwind.calibrate import fitfamily

    monkeypatch.setattr(fitfamily, "fit_airframe", _fit_memo)
    return _fit_memo


# --- shared wind solves ------------------------------------------------------------------------------
# `--wind unknown`'s joint solve (windsolve._solve_with_thrust_scale: nine bounded least-squares runs) takes
# 10-45 s on a loaded machine, and test_fieldcal.py asks it the same question several times only to see
# the decision taken after it under another limit (MAX_WIND_SIGMA_MPS is read after the solve, never in
# it). The solve is a pure function of its arguments, so ``shared_solves`` computes each distinct call
# once per module: the key is the pickled arguments (airframe, rows, groups, vertical rows), so a change
# in any input is a new solve; the identification, coverage and refusal after it always run.

class SolveMemo(Memo):
    """_solve_with_thrust_scale, keyed by the content of its arguments (pickled, hashed)."""

    def key(self, args: tuple, kwargs: dict) -> str | None:
        import hashlib
        import pickle

        return hashlib.sha256(pickle.dumps((args, sorted(kwargs.items())))).hexdigest()


@pytest.fixture(scope="module")
def _solve_memo() -> SolveMemo:
    from dobwind.calibrate import windsolve

    return SolveMemo(windsolve._solve_with_thrust_scale)


@pytest.fixture
def shared_solves(_solve_memo: SolveMemo, monkeypatch: pytest.MonkeyPatch) -> SolveMemo:
    """The module's memo in place of the joint solve, for the requesting test only."""
    from dobwind.calibrate import windsolve

    monkeypatch.setattr(windsolve, "_solve_with_thrust_scale", _solve_memo)
    return _solve_memo


from tests.shared_figures import shared_figures  # noqa: E402,F401  (a report's analysis figures, once per process)
from tests.compile_cache import shared_selftest_builds  # noqa: E402,F401  (self-test builds, once per source)
