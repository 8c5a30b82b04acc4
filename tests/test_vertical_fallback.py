"""The vertical-law fallback (issue #31): an airframe with force_air.vertical_law = "zero-wind" publishes
zero vertical wind and sigma_up -1 on every sample, says so in its header (VERTICAL_ESTIMATED 0), and
the same horizontal wind and status as the airframe with its fitted vertical law; through the Python reference and
the generated C."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dobwind.replay.backends import run_backend
from dobwind.core.errors import InputError
from dobwind.model.airframe import VERTICAL_FALLBACK, Uncertainty, load_airframe, parse_airframe
from dobwind.model.airframe_toml import dump_airframe
from dobwind.model.exercise import flight_inputs
from dobwind.codegen.generate import generate_code
from dobwind.model.status import REJECTED_MASK, STATUS_BITS
from dobwind.model.step import build_step
from tests.helpers import M300

BIT = {bit.name: bit.value for bit in STATUS_BITS}
UNCERTAINTY = Uncertainty((0.0, 10.0), (0.1, 0.3), (0.2, 0.4), 0.05, 0.08)


def _pair():
    fitted = dataclasses.replace(load_airframe(M300), uncertainty=UNCERTAINTY)
    return fitted, dataclasses.replace(fitted, vertical_law=VERTICAL_FALLBACK)


def test_the_header_says_whether_the_vertical_wind_is_estimated():
    """An airframe-level fact: one macro, compiled in, checked by the self-test; no status bit (one set on
    every sample would say nothing of the sample and would withdraw trust from the horizontal wind)."""
    fitted, fallback = _pair()
    assert "VERTICAL_UNIDENTIFIED" not in BIT
    for af, want in ((fitted, 1), (fallback, 0)):
        header = generate_code(af, "single").files["m300_wind.h"]
        assert f"#define M300_WIND_VERTICAL_ESTIMATED {want}\n" in header


@pytest.mark.parametrize("backend", ["python", "c"])
def test_fallback_zeroes_the_vertical_wind_and_keeps_the_status(backend):
    fitted, fallback = _pair()
    models = [build_step(af) for af in (fitted, fallback)]
    inputs = flight_inputs(models[0], 600, seed=3)      # a manoeuvring flight with some bad samples
    runs = [run_backend(m, inputs, backend, "double") for m in models]
    out = models[0].outputs
    accepted = (runs[0].status & REJECTED_MASK) == 0
    assert accepted.sum() > 500 and (~accepted).sum() > 0
    # The fitted law's vertical wind is an estimate (not zero); the fallback's is zero.
    assert np.abs(runs[0].outputs[:, out.slice("wind_ned")][:, 2]).max() > 0.05
    for key in ("wind_ned", "wind_speed_up"):
        vertical = runs[1].outputs[:, out.slice(key)][:, -1]
        assert np.all(vertical == 0.0)
    assert np.all(runs[1].outputs[:, out.slice("wind_sigma_up")] == -1.0)
    # The horizontal wind and its sigma are the fitted airframe's, bit for bit.
    for key in ("force_ned", "wind_speed_h", "wind_from_deg", "wind_sigma_h"):
        assert np.array_equal(runs[0].outputs[:, out.slice(key)], runs[1].outputs[:, out.slice(key)]), key
    horizontal = out.slice("wind_ned")
    assert np.array_equal(runs[0].outputs[:, horizontal][:, :2], runs[1].outputs[:, horizontal][:, :2])
    # The status is the fitted airframe's: the horizontal wind is as trusted as before.
    assert np.array_equal(runs[1].status, runs[0].status)


def test_the_key_round_trips_and_a_bad_value_names_it():
    _, fallback = _pair()
    text = dump_airframe(fallback)
    assert 'vertical_law = "zero-wind"' in text
    assert parse_airframe(text, "<t>").vertical_law == VERTICAL_FALLBACK
    fitted_text = dump_airframe(dataclasses.replace(fallback, vertical_law="fitted"))
    assert "vertical_law" not in fitted_text     # absent means fitted: older files read back the same
    with pytest.raises(InputError, match="force_air.vertical_law"):
        parse_airframe(text.replace('"zero-wind"', '"zero"'), "<t>")
