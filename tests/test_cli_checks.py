"""Command-line contracts of issue #10: commands agree with each other and fail with one line."""
from __future__ import annotations

import pytest

from dobwind.cli import main
from dobwind.model.airframe_toml import dumps
from tests.helpers import airframe_dict


def _one_line(err: str) -> str:
    assert err.count("\n") == 1 and err.endswith("\n") and "Traceback" not in err, err
    return err


def test_check_and_generate_agree_on_unstable_gains(tmp_path, capsys):
    # Paper form: pole 1 - dt*gain/(2m) = 1 - 0.02*600/5 = -1.4 on axis y: outside the unit circle.
    bad = tmp_path / "bad.toml"
    bad.write_text(dumps(airframe_dict(**{"observer.gains": [20.0, 600.0, 30.0]})))
    assert main(["check", str(bad)]) == 2
    check_err = _one_line(capsys.readouterr().err)
    assert main(["generate", str(bad), "-o", str(tmp_path / "out")]) == 2
    generate_err = _one_line(capsys.readouterr().err)
    for err in (check_err, generate_err):
        assert str(bad) in err and "observer.gains" in err and "-1.4" in err and "axis y" in err
    assert not (tmp_path / "out").exists()


def test_check_refuses_gains_unstable_only_at_max_dt(tmp_path, capsys):
    # 1 - 0.02*120/5 = 0.52 at the sample time, but 1 - 0.1*120/5 = -1.4 at limits.max_dt = 0.1 s.
    bad = tmp_path / "late.toml"
    bad.write_text(dumps(airframe_dict(**{"observer.gains": [20.0, 25.0, 120.0]})))
    assert main(["check", str(bad)]) == 2
    err = _one_line(capsys.readouterr().err)
    assert "limits.max_dt" in err and "axis z" in err


def test_check_and_generate_agree_on_stable_gains(tmp_path, capsys):
    # Worst pole 1 - 0.1*30/5 = 0.4 at limits.max_dt: inside.
    good = tmp_path / "good.toml"
    good.write_text(dumps(airframe_dict(**{"observer.gains": [20.0, 25.0, 30.0]})))
    assert main(["check", str(good)]) == 0
    assert main(["generate", str(good), "-o", str(tmp_path / "out")]) == 0


@pytest.mark.parametrize("typo, right, where", [
    ("masss", "mass", ""), ("gainz", "gains", "observer."), ("speed", "speeds", "filter."),
    ("max_rpms", "max_rpm", "thrust."),
])
def test_a_misspelt_key_is_named_before_the_missing_one(tmp_path, capsys, typo, right, where):
    doc = airframe_dict()
    table = doc
    for part in where.rstrip(".").split(".") if where else []:
        table = table[part]
    table[typo] = table.pop(right)
    path = tmp_path / "typo.toml"
    path.write_text(dumps(doc))
    assert main(["check", str(path)]) == 2
    err = _one_line(capsys.readouterr().err)
    assert f"{path}: {where}{typo}: unknown key; did you mean '{right}'?" in err
    assert "missing" not in err


def test_compile_step_leaves_no_temporary_folder_and_still_runs(tmp_path, monkeypatch):
    import tempfile

    import numpy as np

    from dobwind.harness.cstep import compile_step
    from dobwind.model import reference
    from dobwind.model.airframe import parse_airframe
    from dobwind.model.exercise import flight_inputs
    from dobwind.model.step import build_step

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))  # every temporary folder lands here
    model = build_step(parse_airframe(dumps(airframe_dict()), "<test>"))
    cstep = compile_step(model, "double")
    assert list(tmp_path.iterdir()) == []
    rows = flight_inputs(model, 200, seed=1)
    got, ref = cstep.run(rows), reference.run(model, rows)  # the loaded library outlives its file
    assert np.array_equal(got.status, ref.status) and np.allclose(got.outputs, ref.outputs, rtol=1e-9, atol=1e-9)
