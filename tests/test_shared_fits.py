"""The suite's shared fits (conftest.FitMemo): a distinct call is computed once, a changed log or option is
a new call, every caller gets its own copy, and a call with a log reader is never shared. The same for the
shared wind solves (conftest.SolveMemo), keyed by the arguments' content, and for a report's analysis
figures (tests/shared_figures.py), drawn once per airframe."""
from __future__ import annotations

import os

import numpy as np

from tests.conftest import FitMemo, SolveMemo
from tests.shared_figures import FigureMemo


def _counting_fit():
    seen = []

    def fit(af, paths, terms="auto", **kwargs):
        seen.append((af, tuple(paths), terms))
        return {"af": af, "terms": terms, "points": [len(seen)]}
    return fit, seen


def test_the_same_call_is_computed_once_and_each_caller_gets_a_copy(tmp_path):
    log = tmp_path / "a.csv"
    log.write_text("t\n0\n")
    fit, seen = _counting_fit()
    memo = FitMemo(fit)
    first = memo("af", [str(log)], "auto")
    first["points"].append(99)  # a caller changing its result changes nobody else's
    second = memo("af", [str(log)], "auto")
    assert second == {"af": "af", "terms": "auto", "points": [1]} and len(seen) == 1
    assert (memo.calls, memo.computed) == (2, 1)


def test_a_changed_log_or_option_is_a_new_call(tmp_path):
    log = tmp_path / "a.csv"
    log.write_text("t\n0\n")
    fit, seen = _counting_fit()
    memo = FitMemo(fit)
    memo("af", [str(log)], "auto")
    assert memo("af", [str(log)], "airframe")["terms"] == "airframe"
    log.write_text("t\n0\n1\n")  # new size
    memo("af", [str(log)], "auto")
    stat = log.stat()
    os.utime(log, ns=(stat.st_atime_ns, stat.st_mtime_ns + 10**9))  # same size, new mtime
    memo("af", [str(log)], "auto")
    memo("other", [str(log)], "auto")
    assert len(seen) == 5 and memo.computed == 5


def test_a_call_with_a_log_reader_is_never_shared(tmp_path):
    fit, seen = _counting_fit()
    memo = FitMemo(fit)
    reader = object()
    memo("af", ["x.csv"], log_reader=reader)
    memo("af", ["x.csv"], log_reader=reader)
    assert len(seen) == 2 and memo.computed == 0


def test_the_fixture_puts_the_memo_in_place_for_the_asking_test(shared_fits):
    from dobwind.calibrate import fitfamily

    assert fitfamily.fit_airframe is shared_fits and isinstance(shared_fits, FitMemo)


def test_and_a_later_test_of_the_module_gets_the_real_fit():
    """Runs after the test above (file order): the memo's patch ended with it."""
    from dobwind.calibrate import fitfamily

    assert not isinstance(fitfamily.fit_airframe, FitMemo)


def test_a_solve_is_shared_by_content_and_a_changed_row_is_a_new_solve():
    seen = []

    def solve(af, rows, groups, verticals):
        seen.append(groups)
        return {"x": rows.copy(), "n": [len(seen)]}

    memo = SolveMemo(solve)
    rows = np.arange(6.0)
    first = memo("af", rows, 1, None)
    first["n"].append(99)  # a caller changing its result changes nobody else's
    assert memo("af", rows.copy(), 1, None)["n"] == [1] and len(seen) == 1  # equal content: shared
    changed = rows.copy()
    changed[3] += 1e-12
    memo("af", changed, 1, None)
    memo("af", rows, 2, None)
    memo("other", rows, 1, None)
    assert len(seen) == 4 and (memo.calls, memo.computed) == (5, 4)


def test_the_solve_fixture_puts_the_memo_in_place_for_the_asking_test(shared_solves):
    from dobwind.calibrate import windsolve

    assert windsolve._solve_with_thrust_scale is shared_solves


def test_and_a_later_test_gets_the_real_solve():
    from dobwind.calibrate import windsolve

    assert not isinstance(windsolve._solve_with_thrust_scale, SolveMemo)


# --- the shared analysis figures (tests/shared_figures.py) --------------------------------------------

def _counting_figures():
    """A fake analyze (its systems an object identified by identity) and write_plots (one file per call,
    its bytes numbered by the call), recording their calls."""
    seen: list[str] = []

    def analyze(af, freqs, **kwargs):
        seen.append("analyze")
        return {"airframe": af, "freqs": list(freqs)}, object()

    def write_plots(report, systems, out_dir, stage=None):
        seen.append("plot")
        out_dir.mkdir(parents=True, exist_ok=True)
        (out_dir / "bode.png").write_bytes(f"{report['airframe']} {len(seen)}".encode())
        return [out_dir / "bode.png"]
    return analyze, write_plots, seen


def test_the_figures_of_one_airframe_are_computed_and_drawn_once(tmp_path):
    analyze, write_plots, seen = _counting_figures()
    memo = FigureMemo(analyze, write_plots)
    report, systems = memo.analyze("m300", [0.1])
    report["freqs"].append(9.0)  # a caller changing its report changes nobody else's
    first = memo.write_plots(*memo.analyze("m300", [0.1]), tmp_path / "a")
    again = memo.write_plots(*memo.analyze("m300", [0.1]), tmp_path / "b")
    assert [p.read_bytes() for p in first] == [p.read_bytes() for p in again] == [b"m300 2"]
    assert again == [tmp_path / "b" / "bode.png"] and seen == ["analyze", "plot"]
    assert (memo.calls, memo.computed, memo.drawn) == (3, 1, 1)


def test_another_airframe_a_changed_report_or_a_staged_write_is_drawn_again(tmp_path):
    analyze, write_plots, seen = _counting_figures()
    memo = FigureMemo(analyze, write_plots)
    memo.write_plots(*memo.analyze("m300", [0.1]), tmp_path / "a")
    memo.write_plots(*memo.analyze("m300", [0.2]), tmp_path / "b")   # other frequencies: a new analysis
    report, systems = memo.analyze("m300", [0.1])
    report["airframe"] = "edited"
    assert memo.write_plots(report, systems, tmp_path / "c")[0].read_bytes() == b"edited 5"
    memo.write_plots(*memo.analyze("m300", [0.1]), tmp_path / "d", stage=lambda path: path)
    memo.write_plots({"airframe": "m300", "freqs": [0.1]}, object(), tmp_path / "e")  # not the memo's systems
    assert seen.count("analyze") == 2 and seen.count("plot") == 5


def test_the_figures_fixture_puts_the_memo_in_place_for_the_asking_test(shared_figures):
    from dobwind.analysis import report

    assert report.analyze == shared_figures.analyze and report.write_plots == shared_figures.write_plots


def test_and_a_later_test_gets_the_real_analysis():
    from dobwind.analysis import report

    assert not isinstance(getattr(report.analyze, "__self__", None), FigureMemo)
