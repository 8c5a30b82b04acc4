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
