"""C literals: negative zero survives negation, and no constant silently becomes inf or 0 in C."""
from __future__ import annotations

import subprocess

import casadi as ca
import pytest

from dobwind.cli.app import main
from dobwind.codegen.printer import CPrinter, LiteralError
from dobwind.harness.build import STRICT_FLAGS, system_compiler
from dobwind.model.airframe_toml import dumps
from tests.helpers import airframe_dict


@pytest.mark.parametrize("precision", ["single", "double"])
def test_negated_negative_zero_is_valid_c_and_keeps_its_sign(precision, tmp_path):
    printer = CPrinter(precision)
    zero = printer.literal(-0.0)
    assert zero.startswith("(") and zero.endswith(")")
    negated, _ = printer.operation(ca.OP_NEG, [zero], [False], lambda i: -0.0)
    assert "--" not in negated
    source = tmp_path / "neg.c"
    # 1/x tells the two zeros apart: -(-0.0) is +0.0, so 1/x is +inf.
    source.write_text(f"#include <math.h>\n#include <stdio.h>\nint main(void) {{ {printer.real} x = {negated}; "
                      f"printf(\"%d\\n\", (int)(isinf(1 / x) && 1 / x > 0)); return 0; }}\n")
    exe = tmp_path / "neg"
    subprocess.run([system_compiler(), "-std=c99", *STRICT_FLAGS, str(source), "-o", str(exe), "-lm"], check=True)
    assert subprocess.run([str(exe)], capture_output=True, text=True).stdout.strip() == "1"


@pytest.mark.parametrize("value", [float("nan"), float("inf"), -float("inf"), 3.5e38, -1e39, 1e-46, -1e-300])
def test_single_precision_refuses_constants_outside_float_range(value):
    with pytest.raises(LiteralError):
        CPrinter("single").literal(value)


@pytest.mark.parametrize("value", [3.4028234e38, -3.4028234e38, 1.5e-45, 0.0, -0.0, 1e-38])
def test_single_precision_accepts_the_edges_of_float_range(value):
    assert CPrinter("single").literal(value).rstrip(")").endswith("f")


def test_double_precision_takes_what_float_refuses():
    assert CPrinter("double").literal(1e39) == "1e+39"
    with pytest.raises(LiteralError):
        CPrinter("double").literal(float("nan"))


def test_generate_reports_an_unprintable_constant_as_bad_input(tmp_path, capsys):
    # Since issue #16 the loader's ranges refuse such a value first, naming its key, in both precisions;
    # the printer's own check (above) stays as the last guard for constants the model computes.
    path = tmp_path / "huge.toml"
    path.write_text(dumps(airframe_dict(**{"force_air.vertical.coefficients": [0.6, 1e39]})))
    out = tmp_path / "out"
    for precision in ("single", "double"):
        assert main(["generate", str(path), "-o", str(out), "--precision", precision]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"{path}: force_air.vertical.coefficients:" in err
        assert not out.exists()
