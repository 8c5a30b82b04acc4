"""What the drag law's three optional groups share (the four-fold harmonics q4c/q4s, the per-axis pair
qax/qay, its front/back pair qax1c/qay1c): a law without the group writes no key, so existing airframe
files stay as they are; with it the keys round-trip through the file; and the generated C matches the
reference on every code path the group touches. Each group's own physics is in its module
(tests/test_fourfold.py, tests/test_peraxis.py, tests/test_frontback.py), whose laws these are."""
from __future__ import annotations

import dataclasses

import pytest

from dobwind.model.airframe import load_airframe, parse_airframe
from dobwind.model.airframe_toml import dump_airframe
from tests.helpers import M300
from tests.test_fourfold import LAW as FOURFOLD_LAW
from tests.test_frontback import LAW as FRONT_BACK_LAW
from tests.test_peraxis import LAW as PER_AXIS_LAW

# (law, the group's keys, how the file writes them, whether the heading-frame law is verified too)
GROUPS = {
    "fourfold": (FOURFOLD_LAW, ("q4c", "q4s"), ("q4c = 0.012", "q4s = -0.02"), False),
    "peraxis": (PER_AXIS_LAW, ("qax", "qay"), ("qax = -0.01", "qay = 0.09"), True),
    "frontback": (FRONT_BACK_LAW, ("qax1c", "qay1c"), ("qax1c = -0.004", "qay1c = -0.02"), True),
}


@pytest.mark.parametrize("group", GROUPS)
def test_airframe_file_keys(group):
    law, keys, written, _ = GROUPS[group]
    af = dataclasses.replace(load_airframe(M300), drag=dataclasses.replace(law, **{k: 0.0 for k in keys}))
    assert not any(k in dump_airframe(af) for k in keys)  # files without them unchanged
    other = dataclasses.replace(af, drag=law)
    text = dump_airframe(other)
    assert all(w in text for w in written)
    assert parse_airframe(text, "x.toml").drag == other.drag


@pytest.mark.parametrize("group", GROUPS)
def test_generated_c_with_the_group_matches_the_reference(group):
    """verify (strict compile, self-test, random and limit cases, a flight; both precisions) on a
    body-frame law with the group and an exponent, and for the pairs on the quadratic heading-frame one."""
    from dobwind.harness.verify import verify_airframe
    law, _, _, heading_too = GROUPS[group]
    af = load_airframe(M300)
    for each in (dataclasses.replace(law, frame="body", lr=0.15, exponent=1.8),) + ((law,) if heading_too else ()):
        assert verify_airframe(dataclasses.replace(af, drag=each), "both", steps=300).passed
