"""Every range of model/ranges.py walked to both its edges through `check` and `generate` (issue #37,
class 1: `generate` reported success for C that failed its own self-test, on 20 airframes `check` had
accepted, most of them at the edge of a range).

At each edge point the two commands must agree: both accept (and the C generate wrote passed its self-test,
which generate runs before it reports success) or both refuse with the same exit code. The walk sets one
value at a time on a plausible airframe (tests/helpers.py BASE, or a drag-law family for the drag keys);
where the edge makes the airframe impossible for another reason (a 5 g vehicle whose rotors lift 80 kg
cannot hover), both refuse it, which the walk counts as agreement too.
"""
from __future__ import annotations

import os
import shutil
from typing import Any

import pytest

from dobwind.cli.app import main
from dobwind.model.airframe_toml import dumps
from dobwind.model.ranges import RANGES, Range
from tests.families import family_doc
from tests.helpers import airframe_dict
from tests.render_cache import _render_memo, shared_renders  # noqa: F401  (each edge's C rendered once per precision)

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(shutil.which(os.environ.get("CC", "cc")) is None, reason="no host C compiler")]

ENVELOPE = {"force_h_max": 20.0, "force_z": [-5.0, 5.0], "airflow_h_max": 12.0}
UNCERTAINTY = {"speeds": [0.0, 5.0, 10.0], "sigma_h": [0.3, 0.4, 0.6], "sigma_up": [0.2, 0.3, 0.4]}


def _edges(key: str, bounds: Range) -> list[float]:
    """The two edges, each just inside when the range leaves it out; and 0 where 0 means "off"."""
    low = bounds.low * (1 + 1e-9) if bounds.low_open else bounds.low
    high = bounds.high * (1 - 1e-9) if bounds.high_open else bounds.high
    return [low, high] + ([0.0] if bounds.zero_allowed else [])


def _document(key: str, value: float) -> dict[str, Any]:
    """BASE (or a drag family) with ``value`` put where ``key`` applies."""
    simple = {"mass", "gravity", "thrust.scale", "thrust.max_rpm", "observer.sample_time",
              "observer.acceleration_bias_time", "limits.max_dt", "limits.max_tilt_deg"}
    if key in simple:
        return airframe_dict(**{key: value})
    if key == "thrust.coefficients":
        return airframe_dict(**{key: [0.0, 1.5, value]})
    if key in ("observer.gains", "filter.cutoffs"):
        return airframe_dict(**{key: [value] * 3})
    if key == "observer.force_offset":
        return airframe_dict(**{key: [value, 0.0, 0.0]})
    if key == "filter.speeds":
        return airframe_dict(**{key: [0.0, 4.0, max(value, 4.1)] if value > 4.0 else [value, 4.0, 12.0]})
    if key == "force_air.coefficients":
        return airframe_dict(**{"force_air.horizontal.coefficients": [value, 0.05, -0.03, 0.08, 0.06, 0.9]})
    if key == "force_air.drag":
        doc = family_doc("drag-heading")
        doc["force_air"]["drag"]["q0"] = value
        return doc
    doc = airframe_dict()
    if key.startswith("envelope."):
        leaf = key.split(".")[1]
        doc["envelope"] = {**ENVELOPE, leaf: [-value, value] if leaf == "force_z" else value}
    else:
        leaf = key.split(".")[1]
        table = dict(UNCERTAINTY)
        if leaf == "speeds":
            table["speeds"] = [0.0, 5.0, max(value, 5.1)]
        else:
            table["sigma_h"] = [value] * 3
        doc["uncertainty"] = table
    return doc


POINTS = [(key, value) for key, bounds in RANGES.items() for value in _edges(key, bounds)]


@pytest.mark.parametrize("key, value", POINTS, ids=[f"{k}={v:g}" for k, v in POINTS])
def test_check_and_generate_agree_at_every_edge_of_every_range(key, value, tmp_path, capsys, shared_renders):
    path = tmp_path / "edge.toml"
    path.write_text(dumps(_document(key, value)))
    checked = main(["check", str(path)])
    check_err = capsys.readouterr().err
    out = tmp_path / "c"
    generated = main(["generate", str(path), "-o", str(out)])
    generate_err = capsys.readouterr().err
    assert checked == generated, f"check {checked} ({check_err.strip()}), generate {generated} ({generate_err.strip()})"
    assert generated in (0, 1, 2)
    assert out.exists() == (generated == 0)  # a refusal writes nothing
    for err in (check_err, generate_err):
        assert "Traceback" not in err and len(err.strip().splitlines()) <= 1


def test_the_walk_reaches_every_range_and_mostly_generates():
    """The walk is not vacuous: every key is visited, and most edge airframes are real vehicles whose C
    passes its self-test (counted by the test above; here, that the documents parse)."""
    from dobwind.model.airframe import parse_airframe
    from dobwind.core.errors import InputError

    assert {key for key, _ in POINTS} == set(RANGES)
    parsed = 0
    for key, value in POINTS:
        try:
            parse_airframe(dumps(_document(key, value)), "<edge>")
            parsed += 1
        except InputError:
            pass
    assert parsed >= 0.7 * len(POINTS)
