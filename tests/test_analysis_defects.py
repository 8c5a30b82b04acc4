"""The smaller defects of issue #33, each pinned by a test that failed before its fix."""
from __future__ import annotations

import dataclasses
import hashlib
import types

import pytest

from codegen.generate import generate_code
from dobwind.calibrate import fitfamily, fitreport
from dobwind.cli import demo
from dobwind.model.airframe import parse_airframe
from tests.families import FAMILIES, family_airframe


def _header(af) -> str:
    return next(text for name, text in generate_code(af).files.items() if name.endswith(".h"))


def test_demo_c_names_the_fitted_airframe_not_the_input(tmp_path, monkeypatch):
    """The demo's fitted airframe, generated from memory, carries the SHA-256 of the file the demo
    writes for it (what `generate` of that file prints), not the hash of the airframe it was fitted from."""
    start = family_airframe("polynomial")
    fitted = dataclasses.replace(start, observer=dataclasses.replace(start.observer, gains=(11.0, 12.0, 13.0)))
    report = types.SimpleNamespace(warnings=[])
    # the demo imports its pipeline's steps when it runs them: patched where they live
    monkeypatch.setattr(fitfamily, "fit_airframe", lambda af, logs, terms: (fitted, report, None))
    monkeypatch.setattr(fitreport, "fit_plot", lambda *a: None)
    monkeypatch.setattr(fitreport, "text_report", lambda r: "")
    out = demo._fit(start, {"sweep": "", "vertical": ""}, tmp_path)
    written = (tmp_path / f"{start.name}_fitted.toml").read_bytes()
    assert out.content_sha256 == hashlib.sha256(written).hexdigest() != start.content_sha256
    assert _header(out) == _header(parse_airframe(written.decode(), "fitted.toml"))


@pytest.mark.parametrize("family", FAMILIES)
def test_header_describes_the_force_air_law_of_every_family(family):
    af = family_airframe(family)
    header = _header(af)
    if af.drag is None:
        assert "horizontal speed = 0.2 + 0.05*m" in header
    else:
        assert "horizontal speed = 0 m/s" not in header
        assert f"l0 {af.drag.l0:g}, q0 {af.drag.q0:g}" in header
        assert ("body-frame airflow" in header) == (af.drag.frame == "body")


def test_verify_reports_the_diff_that_sets_the_ratio_not_the_largest_magnitude():
    """A passing single-precision run compares limit cases of 1e27 N, where 1e21 is a relative 1e-6:
    verify printed that as `max |diff| 9.03e+21`. It now prints the element that decides the ratio."""
    import numpy as np

    from codegen.tolerance import TOLERANCE
    from harness.compare import _field_errors
    from model.layout import Field, Layout

    layout = Layout((Field("force_ned", 3, "N", ""),))
    ref = np.array([[1e27, 0.0, 0.0], [10.0, 2.0, 0.0]])
    got = ref + np.array([[1e21, 0.0, 0.0], [1e-4, 0.0, 0.0]])
    (error,) = _field_errors(layout, got, ref, TOLERANCE["single"], np.ones(2, dtype=bool), None)
    ratio_small = 1e-4 / (1e-3 + 2e-5 * 10.0)
    assert error.worst_ratio == pytest.approx(ratio_small) and error.worst_row == 1
    assert error.worst_diff == pytest.approx(1e-4) and error.worst_ref == 10.0
    assert error.max_abs == pytest.approx(1e21)  # still in the JSON, for what it is


AIRFRAME_WITH_COMMENTS = '''# my vehicle: do keep this
name = "commented"
mass = 2.5  # weighed with the battery

[thrust]
source = "collective"

[observer]
sample_time = 0.02
# the gains, one per axis
gains = [
  10.0,  # x
  10.0,
  10.0,
] # tuned by hand
discretization = "paper"
acceleration = "ned"

[force_air.horizontal]
terms = ["fh^0.5"]  # F ~ v^2
coefficients = [4.0]

[force_air.vertical]
terms = ["fz"]
coefficients = [0.5]

[filter]
speeds = [0.0, 3.0]
cutoffs = [0.3, 0.5]

[limits]
max_dt = 0.1
max_tilt_deg = 45.0
'''


def _design(tmp_path, capsys, text: str):
    from dobwind.cli.app import main
    from dobwind.model.airframe import load_airframe

    src, out = tmp_path / "in.toml", tmp_path / "out.toml"
    src.write_text(text)
    assert main(["analyze", str(src), "--bandwidth", "0.7", "-o", str(out), "--json"]) == 0
    import json

    gains = json.loads(capsys.readouterr().out)["design"]["gains_kg_per_s"]
    assert load_airframe(out).observer.gains == tuple(gains) != load_airframe(src).observer.gains
    return out.read_text()


def test_design_keeps_every_comment_of_the_airframe(tmp_path, capsys):
    written = _design(tmp_path, capsys, AIRFRAME_WITH_COMMENTS)
    old = [line for line in AIRFRAME_WITH_COMMENTS.splitlines() if "#" in line and "tuned by hand" not in line]
    for line in old:
        if line.lstrip().startswith(("10.0", "gains")):
            continue  # the array's own lines are replaced
        assert line in written.splitlines()
    assert "# 0.7" not in written and "0.7 Hz bandwidth" in written  # the stale comment on the value replaced
    assert written.count("\n") == AIRFRAME_WITH_COMMENTS.count("\n") - 4  # the 5-line array is one line


def test_design_falls_back_to_the_dump_for_an_inline_table(tmp_path, capsys):
    inline = AIRFRAME_WITH_COMMENTS.replace('[observer]\nsample_time = 0.02\n', "").replace(
        '# the gains, one per axis\ngains = [\n  10.0,  # x\n  10.0,\n  10.0,\n] # tuned by hand\n'
        'discretization = "paper"\nacceleration = "ned"\n', "")
    inline = inline.replace('[thrust]', 'observer = {sample_time = 0.02, gains = [10.0, 10.0, 10.0], '
                                        'discretization = "paper", acceleration = "ned"}\n\n[thrust]')
    written = _design(tmp_path, capsys, inline)
    assert "[observer]" in written  # the full dump, still the designed airframe (checked in _design)


def test_replace_array_edits_only_its_table():
    from dobwind.io.tomledit import replace_array

    text = "[a]\ngains = [1]  # old\n[b]\ngains = [2]\n"
    assert replace_array(text, "b", "gains", "[3]") == "[a]\ngains = [1]  # old\n[b]\ngains = [3]\n"
    assert replace_array(text, "a", "gains", "[3]", "new") == "[a]\ngains = [3]  # new\n[b]\ngains = [2]\n"
    assert replace_array(text, "c", "gains", "[3]") is None


def test_a_shipped_airframe_is_named_without_its_path(tmp_path, monkeypatch, capsys):
    from dobwind.cli.app import main

    monkeypatch.chdir(tmp_path)
    assert main(["check", "m300"]) == 0
    assert main(["check", "nf_quad.toml"]) == 0
    (tmp_path / "m300").write_text("not toml [")
    assert main(["check", "m300"]) == 2  # a file of that name comes first
    capsys.readouterr()
    assert main(["check", "no_such_airframe"]) == 2
    assert "no_such_airframe: cannot read" in capsys.readouterr().err
