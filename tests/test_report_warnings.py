"""`report` says what the log reader warns of, on the page and on stderr, as `replay` does: a log that never
flew gives a page of figures with no estimate, and without the warning nothing on it says why."""
from __future__ import annotations

import pytest

from dobwind.cli.app import main
from tests import atmos_logs
from tests.helpers import M300

pytest.importorskip("pymavlink")


def test_a_log_that_never_flew_is_said_on_the_page_and_on_stderr(tmp_path, capsys):
    _, cols = atmos_logs.flight(hold_s=1.0)
    log = atmos_logs.write_log(tmp_path / "ground.bin", cols, airborne=False)
    page = tmp_path / "r.html"
    assert main(["report", str(M300), str(log), "-o", str(page)]) == 0
    err = capsys.readouterr().err
    assert f"dobwind report: warning: {log}: never airborne" in err
    assert "warning: " + str(log) + ": never airborne" in page.read_text()


def test_a_flight_has_no_such_warning(tmp_path, capsys):
    _, cols = atmos_logs.flight(hold_s=1.0)
    log = atmos_logs.write_log(tmp_path / "flight.bin", cols)
    assert main(["report", str(M300), str(log), "-o", str(tmp_path / "r.html")]) == 0
    assert "never airborne" not in capsys.readouterr().err
