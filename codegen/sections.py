"""Stages of the step as labelled C sections: named locals, SSA temporaries, op counts."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import casadi as ca

from dobwind.codegen.printer import CALL_OPS, CPrinter
from dobwind.model.step import Stage, StepModel

_NOT_OPS = {ca.OP_CONST, ca.OP_INPUT, ca.OP_OUTPUT}


@dataclass(frozen=True)
class Section:
    name: str
    doc: str
    declarations: tuple[str, ...]  # locals this section defines, declared before its block
    lines: tuple[str, ...]         # statements inside the block
    ops: int                        # arithmetic operations
    calls: int                      # of which math-library calls


def signal_sizes(model: StepModel) -> dict[str, int]:
    sizes = {f"in.{f.name}": f.size for f in model.inputs.fields}
    sizes.update({f"state.{f.name}": f.size for f in model.state.fields})
    for stage in (model.validate, *model.stages, model.check_result):
        for name, size in zip(stage.outputs, (stage.function.size1_out(i) for i in range(stage.function.n_out()))):
            sizes[name] = size
    sizes["const.one"] = 1
    return sizes


def c_element(signal: str, index: int, size: int, printer: CPrinter) -> str:
    """C lvalue/rvalue of one element of a signal."""
    if signal == "const.one":
        return printer.one()
    if signal.startswith("in."):
        base = f"in->{signal[3:]}"
    elif signal.startswith("state."):
        base = f"state->{signal[6:]}"
    else:
        base = signal
    return base if size == 1 else f"{base}[{index}]"


def used_signals(model: StepModel) -> set[str]:
    used = {sig for _, sig in model.next_state}
    for stage in (*model.stages, model.check_result):
        used.update(stage.inputs)
    return used


def _pruned(stage: Stage, keep: list[int]) -> ca.Function:
    """The stage restricted to the outputs that something consumes (no dead code in C)."""
    symbols = stage.function.sx_in()
    outputs = stage.function.call(symbols)
    return ca.Function(stage.name, symbols, [outputs[i] for i in keep], {"cse": True})


def build_section(stage: Stage, used: set[str], sizes: dict[str, int], printer: CPrinter) -> Section:
    keep = [i for i, name in enumerate(stage.outputs) if name in used]
    out_names = [stage.outputs[i] for i in keep]
    function = _pruned(stage, keep)
    work: dict[int, str] = {}
    is_bool: dict[int, bool] = {}
    constants: dict[int, float] = {}
    lines: list[str] = []
    ops = calls = 0
    for k in range(function.n_instructions()):
        op = function.instruction_id(k)
        args = function.instruction_input(k)
        res = function.instruction_output(k)
        if op == ca.OP_CONST:
            value = float(function.instruction_constant(k))
            work[res[0]], constants[res[0]], is_bool[res[0]] = printer.literal(value), value, False
        elif op == ca.OP_INPUT:
            signal = stage.inputs[args[0]]
            work[res[0]], is_bool[res[0]] = c_element(signal, args[1], sizes[signal], printer), False
            constants.pop(res[0], None)
        elif op == ca.OP_OUTPUT:
            signal = out_names[res[0]]
            value = work[args[0]]
            if is_bool[args[0]]:
                value = f"({printer.real}){value}"
            lines.append(f"{c_element(signal, res[1], sizes[signal], printer)} = {value};")
        else:
            expr, boolean = printer.operation(op, [work[a] for a in args], [is_bool[a] for a in args],
                                              lambda i: constants.get(args[i]) if i < len(args) else None)
            name = f"t{ops}"
            lines.append(f"const {'int' if boolean else printer.real} {name} = {expr};")
            work[res[0]], is_bool[res[0]] = name, boolean
            constants.pop(res[0], None)
            ops += 1
            calls += op in CALL_OPS
    declarations = tuple(
        f"{printer.real} {name};" if sizes[name] == 1 else f"{printer.real} {name}[{sizes[name]}];" for name in out_names
    )
    return Section(stage.name, stage.doc, declarations, tuple(lines), ops, calls)


def build_sections(model: StepModel, printer: CPrinter) -> tuple[Section, tuple[Section, ...], Section]:
    """(validate, the computing stages, the result check)."""
    sizes = signal_sizes(model)
    used = used_signals(model) | {"status", "result_status", "quality_status"}
    limits = dataclasses.replace(printer, directed_limits=True)  # the rejection tests
    validate = build_section(model.validate, used, sizes, limits)
    check = build_section(model.check_result, used, sizes, limits)
    return validate, tuple(build_section(stage, used, sizes, printer) for stage in model.stages), check
