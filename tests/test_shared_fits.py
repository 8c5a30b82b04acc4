"""The suite's shared fits (conftest.FitMemo): a distinct call is computed once, a changed log or option is
a new call, every caller gets its own copy, and a call with a log reader is never shared. The same for the
shared wind solves (conftest.SolveMemo), keyed by the arguments' content."""
from __future__ import annotations

import os

import numpy as np

from tests.conftest import FitMemo, SolveMemo


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
