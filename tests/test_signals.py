"""One map from the airframe to the log signals it needs (model/signals.py, issue #34): it agrees with
the step's inputs and with the columns a simulated log carries for every mode, and no other module tests
the thrust source or the acceleration input to decide what to read."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

from dobwind.model.airframe import parse_airframe
from dobwind.model.airframe_toml import dumps
from dobwind.model.signals import log_signals
from dobwind.model.step import input_layout
from tests.helpers import ROOT, all_modes

MODES = all_modes()
# Where the airframe's own keys are read or written, not what a log must hold: the parser and the dump
# (model/airframe.py, model/airframe_toml.py), and the map itself.
EXEMPT = {"model/signals.py", "model/airframe.py", "model/airframe_toml.py"}
# The step's input fields and the CSV columns that carry each (docs/formats.md), transcribed here.
COLUMNS_OF_INPUT = {"dt": ("t",), "vel_ned": ("vel_n", "vel_e", "vel_d"), "q": ("q_w", "q_x", "q_y", "q_z"),
                    "acc_ned": ("acc_n", "acc_e", "acc_d"), "specific_force": ("sf_x", "sf_y", "sf_z"),
                    "thrust": ("thrust",), "yaw_ref": ()}  # yaw_ref: from yaw_ref if logged, else the attitude


@pytest.mark.parametrize("doc", MODES, ids=[d["name"] for d in MODES])
def test_the_columns_are_the_step_inputs(doc):
    af = parse_airframe(dumps(doc), "x.toml")
    signals = log_signals(af)
    expected = ["t", "vel_n", "vel_e", "vel_d", "q_w", "q_x", "q_y", "q_z"]
    for field in input_layout(af).fields:
        if field.name == "rotor_rpm":
            expected += [f"rpm_{i + 1}" for i in range(field.size)]
        elif field.name not in ("dt", "vel_ned", "q"):
            expected += list(COLUMNS_OF_INPUT[field.name])
    assert sorted(c for c, _ in signals.columns()) == sorted(expected)
    assert signals.rotor_speeds == (doc["thrust"]["source"] == "rpm")
    assert signals.rotors == (doc["thrust"].get("rotors", 0) if signals.rotor_speeds else 0)
    assert signals.measured_acceleration == (doc["observer"]["acceleration"] != "velocity")


def signal_tests(path: Path) -> list[str]:
    """Comparisons of ``<x>.source`` with "rpm" or ``<x>.acceleration`` with an acceleration input's word."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if not isinstance(node, ast.Compare):
            continue
        sides = [node.left, *node.comparators]
        attrs = {s.attr for s in sides if isinstance(s, ast.Attribute)}
        words = {c.value for s in sides for c in ([s] if isinstance(s, ast.Constant) else getattr(s, "elts", []))
                 if isinstance(c, ast.Constant)}
        if ("source" in attrs and "rpm" in words) or \
                ("acceleration" in attrs and words & {"ned", "specific_force", "velocity"}):
            found.append(f"{path.name}:{node.lineno}")
    return found


def test_no_module_restates_which_signals_an_airframe_needs():
    files = [p for folder in ("model", "codegen", "harness", "dobwind") for p in sorted((ROOT / folder).rglob("*.py"))
             if str(p.relative_to(ROOT)) not in EXEMPT]
    assert len(files) > 100
    assert [hit for p in files for hit in signal_tests(p)] == []


@pytest.mark.parametrize("code", ['if af.thrust.source == "rpm":\n    pass\n',
                                  'ned = af.observer.acceleration == "ned"\n',
                                  'x = obs.acceleration in ("ned", "specific_force")\n'])
def test_the_check_sees_a_restated_test(tmp_path, code):
    (tmp_path / "reader.py").write_text(code)
    assert signal_tests(tmp_path / "reader.py") == ["reader.py:1"]
    (tmp_path / "reader.py").write_text("ned = log_signals(af).ned_acceleration\nsrc = af.thrust.source\n")
    assert signal_tests(tmp_path / "reader.py") == []
