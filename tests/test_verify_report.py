"""`verify` and the demo claim only the builds that actually ran."""
from __future__ import annotations

import shutil

import pytest

from dobwind.harness import build
from dobwind.harness.verify import verify_airframe
from dobwind.model.airframe import load_airframe
from tests.helpers import M300


def test_clang_missing_is_not_claimed(monkeypatch):
    real_which = shutil.which
    monkeypatch.setattr(build.shutil, "which", lambda cmd, *a, **k: None if cmd == "clang" else real_which(cmd, *a, **k))
    report = verify_airframe(load_airframe(M300), "double", steps=200)
    assert report.passed, report.text()
    assert "clang" not in report.builds_text() and "clang" not in report.text()
    assert report.builds() == ["cc (C99)", "c++ (C++11)"]
    assert report.as_dict()["builds"] == report.builds()


@pytest.mark.skipif(shutil.which("clang") is None, reason="clang is not installed (.ci/run installs it)")
def test_clang_present_is_claimed_once_it_ran():
    report = verify_airframe(load_airframe(M300), "double", steps=200)
    assert "clang (C99)" in report.builds()
    assert report.text().splitlines()[0].endswith("(builds: cc (C99), c++ (C++11), clang (C99))")


def test_verify_checks_a_given_folder_and_catches_a_hand_edit(tmp_path, capsys):
    from dobwind.cli.app import main
    from tests.helpers import ROOT

    checked_in = ROOT / "generated_c" / "m300"
    assert main(["verify", str(M300), "--c-dir", str(checked_in), "--steps", "200"]) == 0
    assert "single precision" in capsys.readouterr().out
    edited = tmp_path / "m300"
    shutil.copytree(checked_in, edited)
    source = edited / "m300_wind.c"
    text = source.read_text()
    # The dt bounds are one interval of IEEE bit patterns (flag-safe, codegen/bitranges.py), in the quick
    # test and in the exact one: end both one pattern lower, so that a step of exactly max_dt is rejected.
    anchor = "m300_wind_bits(in->dt), m300_wind_bits(1.00000007e-05f), m300_wind_bits(0.100009993f))"
    assert text.count(anchor) == 2
    text = text.replace(anchor, anchor[:-1] + " - 1u)")
    source.write_text(text)
    assert main(["verify", str(M300), "--c-dir", str(edited), "--steps", "200"]) == 1
    out = capsys.readouterr().out
    assert "FAIL" in out.splitlines()[0] and "status mismatches" in out


def test_verify_refuses_a_folder_without_the_airframes_c(tmp_path, capsys):
    from dobwind.cli.app import main

    assert main(["verify", str(M300), "--c-dir", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(tmp_path) in err and "m300_wind.h" in err
    assert main(["verify", str(M300), "--c-dir", str(tmp_path / "x"), "--precision", "double"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{tmp_path / 'x'}: no such folder" in err
    (tmp_path / "f").write_text("")
    assert main(["verify", str(M300), "--c-dir", str(tmp_path / "f")]) == 2
    assert f"{tmp_path / 'f'}: not a folder" in capsys.readouterr().err
