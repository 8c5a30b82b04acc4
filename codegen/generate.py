"""Airframe -> C files: the step's stages printed through Jinja templates.

Output is deterministic (no timestamps, no paths): generating twice gives identical bytes.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import jinja2
import numpy as np

from dobwind.codegen.printer import CPrinter, LiteralError, directed_float
from dobwind.codegen.kernels import kernel_literals
from dobwind.codegen.sections import build_sections, c_element, signal_sizes
from dobwind.codegen.single_terms import refuse_ill_conditioned_terms  # noqa: F401 (re-exported)
from dobwind.codegen.targets import TARGET_FOLDERS, render_target
from dobwind.codegen.tolerance import MIN_SPEED_FOR_DIRECTION, SELFTEST_TOLERANCE
from dobwind.model import reference
from dobwind.model.airframe import Airframe
from dobwind.model.errors import InputError
from dobwind.model.boundaries import boundary_cases
from dobwind.model.exercise import flight_inputs
from dobwind.model.status import INPUT_MAGNITUDE_LIMIT, REJECTED_MASK, STATUS_BITS
from dobwind.model.stability import require_stable
from dobwind.model.step import StepModel, build_step
from dobwind.model.version import VERSION
from dobwind.model.kinds import DragFrame, Precision

SELFTEST_ROWS = 120
# The types of the bit-pattern tests of validation and the result check (codegen/bitranges.py, source.c.j2).
IEEE_TYPES = {
    Precision.SINGLE: {"bits": "uint32_t", "abs_mask": "0x7fffffffu", "sign_shift": 31},
    Precision.DOUBLE: {"bits": "uint64_t", "abs_mask": "(~(uint64_t)0 >> 1)", "sign_shift": 63},
}

_ENV = jinja2.Environment(
    loader=jinja2.PackageLoader("dobwind.codegen", "templates"),
    undefined=jinja2.StrictUndefined,
    trim_blocks=True,
    lstrip_blocks=True,
    keep_trailing_newline=True,
    autoescape=False,
)


@dataclass(frozen=True)
class GeneratedCode:
    name: str
    precision: Precision
    files: dict[str, str]  # file name -> text
    total_ops: int


def _polynomial_text(model) -> str:
    parts = [f"{c:g}*{t.text}" if t.text != "1" else f"{c:g}" for t, c in zip(model.terms, model.coefficients)]
    return " + ".join(parts) or "0"


def _force_air_lines(af: Airframe) -> list[str]:
    """The header's description of the force-air law, one comment line each (issue #33: a drag airframe
    was described by its empty polynomial tables, "horizontal speed = 0 m/s")."""
    if af.drag is None:
        return [f"horizontal speed = {_polynomial_text(af.horizontal)} m/s",
                f"vertical (down)  = {_polynomial_text(af.vertical)} m/s"]
    law = af.drag
    coefficients = ", ".join(f"{k} {v:g}" for k, v in law.as_dict().items() if isinstance(v, float) and k != "exponent")
    frame = "body-frame airflow at the measured attitude" if law.frame == DragFrame.BODY else "level heading-frame airflow"
    return [f"drag law of the {frame}, inverted in the step (docs/model.md),",
            f"exponent {law.exponent:g}, coefficients {coefficients}"]


def _state_decls(model: StepModel, printer: CPrinter, prefix: str) -> list[dict[str, str]]:
    decls, seen_last = [], False
    for f in model.state.fields:
        if f.name.startswith("last."):
            if not seen_last:
                decls.append({"decl": f"{prefix}output_t last;", "unit": "-", "doc": "last valid output"})
                seen_last = True
            continue
        size = f"[{f.size}]" if f.size > 1 else ""
        decls.append({"decl": f"{printer.real} {f.name}{size};", "unit": f.unit, "doc": f.doc})
    return decls


def _commit_lines(model: StepModel, printer: CPrinter) -> list[str]:
    sizes = signal_sizes(model)
    lines = []
    for field, signal in model.next_state:
        size = model.state.field(field).size
        lines += [f"{c_element('state.' + field, i, size, printer)} = {c_element(signal, i, sizes[signal], printer)};"
                  for i in range(size)]
    # The output is a copy of the new last valid output, after its stores (measured on the m300: 64 B of M4F
    # flash and 5 x86 instructions per step fewer than storing every value to both; storing to *out and
    # copying it back to state->last instead costs 44 instructions more, the reloads of what was just stored).
    lines.append("*out = state->last;")
    return lines


def _init_lines(model: StepModel, printer: CPrinter) -> list[str]:
    """The initial state's non-zero elements (StepModel.initial_state), stored after the init's memset."""
    initial = model.initial_state()
    lines = []
    for f in model.state.fields:
        values = initial[model.state.slice(f.name)]
        lines += [f"{c_element('state.' + f.name, i, f.size, printer)} = {printer.literal(float(v))};"
                  for i, v in enumerate(values) if v != 0.0]
    return lines


def _advance_lines(model: StepModel, printer: CPrinter) -> list[str]:
    """The state a validated but rejected sample still writes (model/biasgate.py's check)."""
    sizes = signal_sizes(model)
    lines = []
    for field, signal in model.advance_on_check:
        size = model.state.field(field).size
        lines += [f"{c_element('state.' + field, i, size, printer)} = {c_element(signal, i, sizes[signal], printer)};"
                  for i in range(size)]
    return lines


def _fmt(value: float, precision: Precision, printer: CPrinter) -> str:
    """A test-vector literal; NaN and infinities (rejected inputs) through <math.h>'s macros."""
    if not np.isfinite(value):
        macro = "NAN" if np.isnan(value) else ("INFINITY" if value > 0 else "-INFINITY")
        return macro if precision == Precision.SINGLE else f"(double){macro}"
    if precision == Precision.SINGLE:
        return printer.literal(float(np.float32(value)))
    return printer.literal(float(value))


def _fmt_rows(rows: np.ndarray, precision: Precision, printer: CPrinter) -> list[str]:
    """[", ".join(_fmt(v, precision, printer) for v in row) for row in rows], each distinct value printed
    once: a render prints about 14,000 numbers, 3,000 of them distinct (m300 in single precision), at 3.6 us
    each. Keyed by the value; zeros by their sign too (0.0 and -0.0 are one dict key but print apart),
    NaN as one key (every NaN prints as NAN). Values are printed in the same order, so the first that
    has no literal raises as before."""
    printed: dict[object, str] = {}
    out = []
    for row in np.asarray(rows, dtype=float).tolist():
        texts = []
        for v in row:
            key = ("zero", math.copysign(1.0, v)) if v == 0.0 else ("nan",) if v != v else v
            text = printed.get(key)
            if text is None:
                text = printed[key] = _fmt(v, precision, printer)
            texts.append(text)
        out.append(", ".join(texts))
    return out


def _selftest_context(model: StepModel, printer: CPrinter, precision: Precision) -> dict:
    inputs = flight_inputs(model, SELFTEST_ROWS, seed=2024, bad_every=23)
    if precision == Precision.SINGLE:
        inputs = inputs.astype(np.float32).astype(np.float64)  # exactly what the C program will hold
    traj = reference.run(model, inputs)
    # Rounded to 7 decimals so that last-bit libm differences between machines cannot change the text.
    expected = np.round(traj.outputs, 7) + 0.0
    tol = SELFTEST_TOLERANCE[precision]
    unpack = [f"in->{name} = u[{column}];" for column, name in enumerate(model.inputs.element_names())]
    outputs = model.outputs.element_names()
    from_col, speed_col = outputs.index("wind_from_deg"), outputs.index("wind_speed_h")
    checks = [{"got": f"out->{label}", "want": f"y[{column}]", "label": label}
              for column, label in enumerate(outputs) if column != from_col]
    return {
        "rows": SELFTEST_ROWS,
        "n_in": model.inputs.size,
        "n_out": model.outputs.size,
        "input_rows": _fmt_rows(inputs, precision, printer),
        "output_rows": _fmt_rows(expected, precision, printer),
        "statuses": ", ".join(str(int(s)) for s in traj.status),
        **_limit_context(model, printer, precision),
        "unpack": unpack,
        "checks": checks,
        "from_want": f"y[{from_col}]",
        "speed_want": f"y[{speed_col}]",
        "rtol": repr(tol.rtol),
        "atol": repr(tol.atol),
        "angle_tol": repr(tol.angle_deg),
        "min_speed": repr(MIN_SPEED_FOR_DIRECTION),
        "macros": _macro_checks(model, f"{model.airframe.name}_wind_".upper()),
    }


def _macro_checks(model: StepModel, prefix: str) -> list[dict[str, str]]:
    """The header macros the self-test compares with the model's values (status bits, mask, vertical, settling)."""
    checks = [{"name": f"{prefix}STATUS_{bit.name}", "want": f"0x{bit.value:02X}",
               "test": f"{prefix}STATUS_{bit.name} == 0x{bit.value:02X}u"} for bit in STATUS_BITS]
    checks.append({"name": f"{prefix}REJECTED_MASK", "want": f"0x{REJECTED_MASK:02X}",
                   "test": f"{prefix}REJECTED_MASK == 0x{REJECTED_MASK:02X}u"})
    estimated = int(model.airframe.vertical_law == "fitted")
    checks.append({"name": f"{prefix}VERTICAL_ESTIMATED", "want": str(estimated),
                   "test": f"{prefix}VERTICAL_ESTIMATED == {estimated}"})
    settle = model.settling_time_s  # a float already (model/step.py): printed in full, compared to 1e-6
    checks.append({"name": f"{prefix}SETTLING_TIME_S", "want": f"{settle:.9g}",
                   "test": f"fabs((double){prefix}SETTLING_TIME_S - (double){settle!r}) <= (double){settle!r} * (double)1e-6"})
    return checks


def _limit_context(model: StepModel, printer: CPrinter, precision: Precision) -> dict:
    """The limit cases (model/boundaries.py): one step each from its own state."""
    cases = boundary_cases(model, precision)
    mapped = model.step.map(len(cases.labels))
    _, ys, st = mapped(cases.states.T, cases.inputs.T)
    expected = np.round(np.asarray(ys).T, 7) + 0.0
    return {
        "limit_rows": len(cases.labels),
        "n_state": model.state.size,
        "limit_state_rows": _fmt_rows(cases.states, precision, printer),
        "limit_input_rows": _fmt_rows(cases.inputs, precision, printer),
        "limit_output_rows": _fmt_rows(expected, precision, printer),
        "limit_statuses": ", ".join(str(int(s)) for s in np.asarray(st).ravel()),
        "load_state": [f"state->{name} = x[{column}];" for column, name in enumerate(model.state.element_names())],
    }


def generate_code(af: Airframe, precision: Precision = Precision.SINGLE, model: StepModel | None = None,
                  source: str | None = None, target: str | None = None) -> GeneratedCode:
    """``source`` names the airframe file in errors (default: the airframe's name). ``target`` ("px4",
    "ardupilot") adds that autopilot's module or library folder (codegen/targets.py); single precision."""
    model = model or build_step(af)
    _refuse_unstable(af)
    if target is not None and precision != Precision.SINGLE:
        raise InputError(source or af.name, "--target", f"{target} integrations are single precision "
                         "(the autopilots' estimators run in float): drop --precision double")
    if precision == Precision.SINGLE:
        refuse_ill_conditioned_terms(af, source or af.name)
    try:
        return _render(af, precision, model, target)
    except LiteralError as exc:
        raise InputError(source or af.name, None, f"cannot print the C in {precision} precision: {exc} "
                         "(check the airframe's values)") from None


def _render(af: Airframe, precision: Precision, model: StepModel, target: str | None = None) -> GeneratedCode:
    prefix = f"{af.name}_wind_"
    printer = CPrinter(precision, kernel_prefix=prefix)
    validate, sections, check = build_sections(model, printer)
    every_line = [line for s in (validate.quick, validate.section, *sections, check) for line in s.lines]
    kernels = {k: any(f"{prefix}{k}(" in line for line in every_line) for k in ("sincos", "expm1", "atan2")}
    kernels["ieee_within"] = any(f"{prefix}within(" in line for line in every_line)
    kernels["ieee"] = any(f"{prefix}bits(" in line for line in every_line)
    common = {
        "name": af.name,
        "prefix": prefix,
        "precision": precision,
        "version": VERSION,
        "sha256": af.content_sha256,
        "real": printer.real,
        "zero": printer.zero(),
    }
    total_ops = validate.quick.ops + sum(s.ops for s in sections) + check.ops  # an accepted sample's path
    header = _ENV.get_template("header.h.j2").render(
        **common, af=af, guard=f"{af.name.upper()}_WIND_H", status_bits=STATUS_BITS, rejected_mask=REJECTED_MASK,
        settling_time=printer.literal(model.settling_time_s),
        outputs=model.outputs.fields, inputs=model.inputs.fields, state=_state_decls(model, printer, prefix),
        force_air=_force_air_lines(af),
    )
    source = _ENV.get_template("source.c.j2").render(
        **common, validate=validate, sections=sections, check=check, commit=_commit_lines(model, printer),
        reset=[f"state->{field} = {printer.literal(value)};" for field, value in model.reset_on_reject],
        advance=_advance_lines(model, printer), init=_init_lines(model, printer),
        total_ops=total_ops, total_calls=validate.quick.calls + sum(s.calls for s in sections) + check.calls,
        kernels=kernels, coefficients=kernel_literals(printer), ieee=IEEE_TYPES[precision],
        finite=_finite_loop(model, printer),
        state_fields=[f for f in model.state.fields],
    )
    selftest = _ENV.get_template("selftest.c.j2").render(**common, **_selftest_context(model, printer, precision))
    cmake = _ENV.get_template("CMakeLists.txt.j2").render(**common)
    files = {
        f"{af.name}_wind.h": header,
        f"{af.name}_wind.c": source,
        f"{af.name}_wind_selftest.c": selftest,
        "CMakeLists.txt": cmake,
    }
    if target is not None:
        files.update(render_target(target, _ENV, model, common, files))
    return GeneratedCode(af.name, precision, files, total_ops)


def _finite_loop(model: StepModel, printer: CPrinter) -> dict[str, str | int]:
    """The finiteness loop of the template: element count and the limit's bits (the float at or below
    INPUT_MAGNITUDE_LIMIT, so that the test never accepts more than the reference's |x| <= limit)."""
    if printer.precision == Precision.SINGLE:
        limit = directed_float(INPUT_MAGNITUDE_LIMIT, up=False)
        bits = f"0x{int(np.array(limit, dtype=np.float32).view(np.uint32)):08x}u"
    else:
        limit = INPUT_MAGNITUDE_LIMIT
        bits = f"UINT64_C(0x{int(np.array(limit, dtype=np.float64).view(np.uint64)):016x})"
    return {"count": model.inputs.size, "limit_bits": bits, "limit_text": f"{INPUT_MAGNITUDE_LIMIT:g}"}


def _refuse_unstable(af: Airframe) -> None:
    require_stable(af, "refusing to generate code")


# What generate writes for any airframe: the only names a folder it replaces may hold.
GENERATED_NAME = re.compile(r"[a-z][a-z0-9_]*_wind(_selftest)?\.[ch]|CMakeLists\.txt|"
                            + "|".join(TARGET_FOLDERS.values()))


def is_generated_name(name: str) -> bool:
    return GENERATED_NAME.fullmatch(name) is not None


def write_files(files: dict[str, str], out_dir: str | Path) -> list[Path]:
    """Writes into a folder the caller owns (a build or staging folder); atomic replacement of a user's
    folder is the applications' job (``dobwind.generate.emit``)."""
    paths = []
    for name, text in files.items():
        path = Path(out_dir) / name
        path.parent.mkdir(parents=True, exist_ok=True)  # a target's folder
        path.write_text(text, encoding="utf-8")
        paths.append(path)
    return paths
