"""What `dobwind report` says about the autopilot's wind and the airframe (issue #36, a new user's pass):
an inactive autopilot wind was introduced as "compared with the autopilot's own estimate" above a table
saying `active False`; active, the table dumped 16-digit floats with the units only in the JSON keys; and
a page from an uncalibrated prior did not say so where the airframe is described."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from dobwind.cli.app import main
from dobwind.report.report import comparison_rows
from tests.helpers import M300
from tests.shared_figures import use_shared_figures

pytest.importorskip("pyulog")


def test_comparison_rows_name_units_and_round():
    rows = comparison_rows({"topic": "wind", "active": True, "active_share": 0.25, "overlap_rows": 880,
                            "mean_vector_difference_mps": 8.347086953436918, "mean_wind_ours_ne_mps": [0.79433, -0.1936],
                            "variance_north_m2s2": 0.07387405464138562})
    assert rows == [("rows where both estimate", "overlap_rows", "880", "rows"),
                    ("share of the autopilot's samples that are active", "active_share", "25.0", "%"),
                    ("mean of |ours - theirs|, row by row", "mean_vector_difference_mps", "8.347", "m/s"),
                    ("our mean wind (north, east)", "mean_wind_ours_ne_mps", "+0.794, -0.194", "m/s"),
                    ("the autopilot's own variance, north", "variance_north_m2s2", "0.074", "m²/s²")]


def _errors_section(page: str) -> str:
    return re.search(r"<h2>Errors</h2>(.*?)<h2>", page, re.S).group(1)


@pytest.fixture(scope="module")
def zero_wind(tmp_path_factory) -> tuple[Path, str]:
    """A log whose autopilot wind is all zero and M300's page on it: read by two tests, built once (each
    `report` takes 2.5-5 s, most of it the analysis figures)."""
    from tests.test_fieldreplay import _flight, _slow_ulog

    folder = tmp_path_factory.mktemp("zero_wind")
    _, cols = _flight()
    log = _slow_ulog(folder / "z.ulg", cols, wind="zero")
    with pytest.MonkeyPatch.context() as patch:
        use_shared_figures(patch)
        assert main(["report", str(M300), str(log), "-o", str(folder / "r.html")]) == 0
    return log, (folder / "r.html").read_text()


def _airframe_table(page: str) -> str:
    return re.search(r"<h2>Airframe</h2>(.*?)</table>", page, re.S).group(1)


def test_an_inactive_autopilot_wind_is_not_introduced_as_a_comparison(zero_wind):
    errors = _errors_section(zero_wind[1])
    assert "compared with" not in errors and "nothing to compare with" in errors and "False" not in errors


def test_an_active_autopilot_wind_is_a_table_with_units(tmp_path, shared_figures):
    from tests.test_fieldreplay import _flight, _slow_ulog

    _, cols = _flight()
    log = _slow_ulog(tmp_path / "w.ulg", cols, wind="late")
    assert main(["report", str(M300), str(log), "-o", str(tmp_path / "r.html")]) == 0
    errors = _errors_section((tmp_path / "r.html").read_text())
    assert "compared with the autopilot" in errors and "mean_vector_difference_mps" in errors
    row = re.search(r"<tr><td>mean of \|ours - theirs\|.*?</tr>", errors, re.S).group(0)
    assert "m/s" in row and re.search(r'class="num">\d+\.\d{3}<', row)
    assert not re.search(r"\d\.\d{7,}", errors)  # no raw float


def test_a_prior_airframe_says_so_in_the_airframe_table(tmp_path, zero_wind, shared_figures):
    log, calibrated_page = zero_wind
    prior = tmp_path / "prior.toml"
    prior.write_text(M300.read_text() + '\n[calibration]\nstatus = "prior"\n')
    assert main(["report", str(prior), str(log), "-o", str(tmp_path / "r.html")]) == 0
    assert "uncalibrated prior" in _airframe_table((tmp_path / "r.html").read_text())
    assert "uncalibrated prior" not in _airframe_table(calibrated_page)
