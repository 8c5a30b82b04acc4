"""The smaller defects of issue #33, each pinned by a test that failed before its fix."""
from __future__ import annotations

import dataclasses
import hashlib
import types

import pytest

from codegen.generate import generate_code
from dobwind import demo
from dobwind.model.airframe import parse_airframe
from dobwind.model.airframe_toml import dump_airframe
from tests.families import FAMILIES, family_airframe


def _header(af) -> str:
    return next(text for name, text in generate_code(af).files.items() if name.endswith(".h"))


def test_demo_c_names_the_fitted_airframe_not_the_input(tmp_path, monkeypatch):
    """The demo's fitted airframe, generated from memory, carries the SHA-256 of the file the demo
    writes for it (what `generate` of that file prints), not the hash of the airframe it was fitted from."""
    start = family_airframe("polynomial")
    fitted = dataclasses.replace(start, observer=dataclasses.replace(start.observer, gains=(11.0, 12.0, 13.0)))
    report = types.SimpleNamespace(warnings=[])
    monkeypatch.setattr(demo, "fit_airframe", lambda af, logs, terms: (fitted, report, None))
    monkeypatch.setattr(demo, "fit_plot", lambda *a: None)
    monkeypatch.setattr(demo, "text_report", lambda r: "")
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
