"""`inspect` says where replay's NetCDF and profile would take position and UTC from, so the campaign
learns it from the first log (docs/inspect-init.md)."""
from __future__ import annotations

import json

import pytest

from dobwind.cli.app import main
from tests import atmos_logs

pytest.importorskip("pymavlink")


def test_a_log_with_position_and_gps_time(tmp_path, capsys):
    _, cols = atmos_logs.flight(hold_s=1.0)
    log = atmos_logs.write_log(tmp_path / "f.bin", cols)
    assert main(["inspect", str(log)]) == 0
    out = capsys.readouterr().out
    assert "position and UTC (replay -o .nc, profile): position POS; UTC from GPS.GWk/GMS (" in out
    assert main(["inspect", str(log), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)["position"]
    assert got["position"] == "POS" and got["utc"] is True


def test_a_log_without_them_says_what_is_missing(tmp_path, capsys):
    _, cols = atmos_logs.flight(hold_s=1.0)
    log = atmos_logs.write_log(tmp_path / "f.bin", cols, position=False, gps_time=False)
    assert main(["inspect", str(log), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)["position"]
    assert got["position"] == "none (heights from XKF1.PD (EKF core 0))" and got["utc"] is False
    assert got["time_source"].startswith("no GPS time in the log")
