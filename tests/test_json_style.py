"""One JSON style across commands (issue #15): indent 2, and the error figures carry their unit in the
key name (the short names the demo reads stay beside them, with the same values)."""
from __future__ import annotations

import json

from dobwind.cli.app import main
from dobwind.replay.replay import UNIT_KEYS
from tests.helpers import M300


def _json(capsys, argv: list[str]) -> dict:
    capsys.readouterr()
    assert main(argv) == 0
    text = capsys.readouterr().out
    obj = json.loads(text)
    assert text == json.dumps(obj, indent=2) + "\n", f"{argv[0]}: not the common style (indent 2)"
    return obj


def test_check_analyze_replay_share_one_style(tmp_path, capsys):
    _json(capsys, ["check", str(M300), "--json"])
    analysis = _json(capsys, ["analyze", str(M300), "--json", "--freq", "0.5"])
    assert analysis["gains_kg_per_s"] == analysis["gains"]
    log = tmp_path / "tunnel.csv"
    assert main(["simulate", "tunnel", "--hold", "6", "--rate", "25", "-o", str(log)]) == 0
    replay = _json(capsys, ["replay", str(M300), str(log), "--json"])
    for block in ("per_sample", "per_segment"):
        for short, named in UNIT_KEYS.items():
            if short in replay[block]:
                assert named.endswith(("_mps", "_deg")) and replay[block][named] == replay[block][short]
    assert replay["per_sample"]["speed_error_mean_mps"] > 0
    assert replay["per_segment"]["table"][0]["true_speed_mps"] > 2.0  # the tunnel's first hold is 3 m/s
