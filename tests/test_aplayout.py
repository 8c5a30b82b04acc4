"""aplayout.relabel on plain message dicts: what it returns and what it leaves alone."""
from __future__ import annotations

import copy

from dobwind.io.aplayout import relabel


def _old_log() -> dict[str, list[dict]]:
    """An ArduPilot 4.0-like log: each EKF3 core under its own names, ESC per motor, stamped out of order
    across the names that merge."""
    return {"XKQ1": [{"TimeUS": 20, "Q1": 1.0}, {"TimeUS": 40, "Q1": 1.0}],
            "XKQ2": [{"TimeUS": 10, "Q1": 0.5}, {"TimeUS": 30, "Q1": 0.5}],
            "ESC1": [{"TimeUS": 15, "RPM": 100.0}], "ESC2": [{"TimeUS": 5, "RPM": 200.0}],
            "IMU": [{"TimeUS": 1, "AccX": 0.0}]}


def test_relabel_leaves_its_input_as_it_was():
    msgs = _old_log()
    kept = copy.deepcopy(msgs)
    out, note = relabel(msgs)
    assert msgs == kept
    assert note is not None and "XKQ1 as XKQ C 0" in note
    # The merged names come out in time order, each row with its core or motor.
    assert [(r["TimeUS"], r["C"]) for r in out["XKQ"]] == [(10, 1), (20, 0), (30, 1), (40, 0)]
    assert [(r["TimeUS"], r["Instance"]) for r in out["ESC"]] == [(5, 1), (15, 0)]
    assert out["XKQ1"] == [] and out["ESC1"] == [] and out["IMU"] is msgs["IMU"]


def test_a_41_log_is_returned_as_it_is():
    msgs = {"XKQ": [{"TimeUS": 20, "C": 0, "Q1": 1.0}, {"TimeUS": 10, "C": 1, "Q1": 0.5}],
            "ESC": [{"TimeUS": 5, "Instance": 0, "RPM": 1.0}]}
    kept = copy.deepcopy(msgs)
    out, note = relabel(msgs)
    assert note is None and out == kept and msgs == kept
