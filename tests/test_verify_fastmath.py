"""verify under PX4's flags: -funsafe-math-optimizations links crtfastmath into a shared library, and
loading it sets flush-to-zero / denormals-are-zero for the whole process. The comparison with the
reference must still see the subnormal limit rows (model/boundaries.py), and the process running verify
must keep IEEE subnormals (its own references and every later computation depend on them)."""
from __future__ import annotations

import numpy as np

from dobwind.codegen.generate import generate_code, write_files
from dobwind.harness.flagsets import FLAG_SETS
from dobwind.harness.verify import verify_airframe, verify_precision
from dobwind.model.airframe import load_airframe
from dobwind.model.kinds import Precision
from dobwind.model.step import build_step
from tests.helpers import M300

SMALLEST_DOUBLE = 5e-324  # the smallest positive subnormal double


def _keeps_subnormals() -> bool:
    """Compared by bits: under denormals-are-zero a float comparison would itself see 5e-324 as 0."""
    return int((np.array([SMALLEST_DOUBLE]) * 1.0).view(np.uint64)[0]) == 1


def test_verify_with_px4_flags_passes_and_leaves_this_process_with_subnormals():
    assert _keeps_subnormals()  # the premise: nothing before this test changed the mode
    report = verify_airframe(load_airframe(M300), precision="single", steps=300, flags="px4")
    assert report.passed, report.text()
    assert _keeps_subnormals()


def test_a_nonnegative_test_by_float_comparison_fails_the_reference_comparison_under_px4(tmp_path):
    """The mutant `x >= 0.0f` passes -1.4e-45 rpm under flush-to-zero (it compares as -0); the generated
    test reads the bit pattern. Only the limit rows tell them apart, so they must reach the C unflushed."""
    model = build_step(load_airframe(M300))
    folder = tmp_path / "c"
    folder.mkdir()
    write_files(generate_code(model.airframe, Precision.SINGLE, model).files, folder)
    source = folder / "m300_wind.c"
    text = source.read_text()
    for i in range(4):  # 0 <= rpm on the patterns: +0 up to +inf, or -0 (codegen/bitranges.py)
        rpm = f"m300_wind_bits(in->rotor_rpm[{i}])"
        original = f"({rpm} <= 0x7f800000u) || ({rpm} == 0x80000000u)"
        assert text.count(original) == 1
        text = text.replace(original, f"in->rotor_rpm[{i}] >= 0.0f")
    source.write_text(text)
    work = tmp_path / "work"
    work.mkdir()
    report = verify_precision(model, Precision.SINGLE, 300, 1, work, c_dir=folder, compilers=[],
                              flags=FLAG_SETS["px4"])
    assert report.cases is not None and report.cases.status_mismatches > 0, report.cases
    assert _keeps_subnormals()
