"""Stages of the step as labelled C sections: named locals, SSA temporaries, op counts."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import casadi as ca

from dobwind.codegen.printer import CALL_OPS, CPrinter
from dobwind.model.step import FINITE_SIGNAL, Stage, StepModel, validate_given_finite

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


@dataclass(frozen=True)
class _Instruction:
    op: int
    args: tuple[int, ...]
    res: tuple[int, ...]
    uses: tuple[tuple[int, int], ...]  # the values read: (work slot, version), since slots are reused
    defines: tuple[int, int] | None   # the value written, or None for an output


def _instructions(function: ca.Function) -> list[_Instruction]:
    version: dict[int, int] = {}
    out = []
    for k in range(function.n_instructions()):
        op = function.instruction_id(k)
        args, res = tuple(function.instruction_input(k)), tuple(function.instruction_output(k))
        uses = tuple((a, version.get(a, 0)) for a in args) if op not in (ca.OP_CONST, ca.OP_INPUT) else ()
        defines = None
        if op != ca.OP_OUTPUT:
            version[res[0]] = version.get(res[0], 0) + 1
            defines = (res[0], version[res[0]])
        out.append(_Instruction(op, args, res, uses, defines))
    return out


def _needed_by(code: list[_Instruction], output: int) -> set[int]:
    """Indices of the instructions that output number ``output`` depends on."""
    needed: set[tuple[int, int]] = set()
    marked: set[int] = set()
    for k in range(len(code) - 1, -1, -1):
        ins = code[k]
        if (ins.op == ca.OP_OUTPUT and ins.res[0] == output) or (ins.defines is not None and ins.defines in needed):
            needed.update(ins.uses)
            marked.add(k)
    return marked


def _has_normal_reciprocal(value: float | None) -> bool:
    """A constant divisor whose reciprocal is a normal float (then x / c becomes x * (1/c))."""
    return value is not None and value != 0.0 and 1.2e-38 < abs(1.0 / value) < 3.4e38


class _Writer:
    """Prints one stage's instructions as C lines (SSA temporaries t0, t1, ...)."""

    def __init__(self, printer: CPrinter, code: list[_Instruction], temp_prefix: str = "t") -> None:
        self.printer = printer
        self.temp_prefix = temp_prefix
        self.integer_status = False  # print status bits as int (integer_bits); the rejection path only
        self.ints: set[str] = set()
        self.work: dict[int, str] = {}
        self.is_bool: dict[int, bool] = {}
        self.constants: dict[int, float] = {}
        self.serial = self.ops = self.calls = 0
        self.index = 0  # the instruction being printed (constants are read from the Function by index)
        self.sincos: dict[tuple[int, int], str] = {}     # angle value -> its sincos temporary
        self.reciprocal: dict[tuple[int, int], str] = {}  # denominator value -> 1/it
        self.magnitudes: set[str] = set()  # temporaries holding an absolute value (fabs)
        # Single precision: a denominator used more than once becomes one reciprocal and products
        # (a division costs 14 cycles on a Cortex-M4F, a product 1). Double keeps every division, so
        # that it stays bit-identical to the reference.
        counts: dict[tuple[int, int], int] = {}
        for ins in code:
            if ins.op == ca.OP_DIV:
                counts[ins.uses[1]] = counts.get(ins.uses[1], 0) + 1
        self.shared_denominators = {key for key, n in counts.items() if n > 1} if printer.inline_kernels else set()

    def integer_bits(self, ins: _Instruction, lines: list[str]) -> str | None:
        """Status bits as int arithmetic (the rejection path): a bit selected by a truth value, and sums of
        such. None: another operation (printed as usual)."""
        args = [self.work[a] for a in ins.args]
        if ins.op == ca.OP_IF_ELSE_ZERO and self.is_bool[ins.args[0]]:
            bit = self.constants.get(ins.args[1])
            if bit is not None and bit.is_integer() and 0 < bit < 2 ** 30:
                name = self.temp("int", f"({args[0]} ? {int(bit)} : 0)", lines)
                self.ints.add(name)
                return name
        if ins.op == ca.OP_ADD and all(a in self.ints for a in args):
            name = self.temp("int", f"{args[0]} | {args[1]}", lines)  # distinct bits: OR is their sum
            self.ints.add(name)
            return name
        return None

    def temp(self, ctype: str, expr: str, lines: list[str], counted: bool = True) -> str:
        name = f"{self.temp_prefix}{self.serial}"
        self.serial += 1
        self.ops += counted
        lines.append(f"const {ctype} {name} = {expr};")
        return name

    def special(self, ins: _Instruction, lines: list[str]) -> str | None:
        """Single-precision rewrites: one sincos per angle, shared reciprocals, constant divisors."""
        p = self.printer
        if not p.inline_kernels:
            return None
        if ins.op in (ca.OP_SIN, ca.OP_COS):
            key = ins.uses[0]
            if key not in self.sincos:
                self.sincos[key] = self.temp(f"{p.kernel_prefix}sincos_t", f"{p.kernel_prefix}sincos({self.work[ins.args[0]]})", lines)
                self.calls += 1
            return self.temp(p.real, f"{self.sincos[key]}.{'c' if ins.op == ca.OP_COS else 's'}", lines, counted=False)
        if ins.op == ca.OP_DIV and _has_normal_reciprocal(self.constants.get(ins.args[1])):
            return self.temp(p.real, f"{self.work[ins.args[0]]} * {p.literal(1.0 / self.constants[ins.args[1]])}", lines)
        if ins.op == ca.OP_DIV and ins.uses[1] in self.shared_denominators:
            key = ins.uses[1]
            if key not in self.reciprocal:
                self.reciprocal[key] = self.temp(p.real, f"{p.one()} / {self.work[ins.args[1]]}", lines)
            return self.temp(p.real, f"{self.work[ins.args[0]]} * {self.reciprocal[key]}", lines)
        return None

    def emit(self, ins: _Instruction, function: ca.Function, stage: Stage, out_names: list[str],
             sizes: dict[str, int], lines: list[str]) -> None:
        p = self.printer
        if ins.op == ca.OP_CONST:
            value = float(function.instruction_constant(self.index))
            self.work[ins.res[0]], self.constants[ins.res[0]], self.is_bool[ins.res[0]] = p.literal(value), value, False
            return
        if ins.op == ca.OP_INPUT:
            signal = stage.inputs[ins.args[0]]
            boolean = signal == FINITE_SIGNAL  # an int 0/1 in the C (the finiteness loop's result)
            self.work[ins.res[0]], self.is_bool[ins.res[0]] = c_element(signal, ins.args[1], sizes[signal], p), boolean
            self.constants.pop(ins.res[0], None)
            return
        if ins.op == ca.OP_OUTPUT:
            signal = out_names[ins.res[0]]
            value = self.work[ins.args[0]]
            if self.is_bool[ins.args[0]]:
                value = f"({p.real}){value}"
            lines.append(f"{c_element(signal, ins.res[1], sizes[signal], p)} = {value};")
            return
        if self.integer_status:
            name = self.integer_bits(ins, lines)
            if name is not None:
                self.work[ins.res[0]], self.is_bool[ins.res[0]] = name, False
                self.constants.pop(ins.res[0], None)
                return
        name = self.special(ins, lines)
        boolean = False
        if name is None:
            expr, boolean = p.operation(ins.op, [self.work[a] for a in ins.args], [self.is_bool[a] for a in ins.args],
                                        lambda i: self.constants.get(ins.args[i]) if i < len(ins.args) else None,
                                        lambda i: self.work[ins.args[i]] in self.magnitudes)
            name = self.temp("int" if boolean else p.real, expr, lines)
            self.calls += ins.op in CALL_OPS
            if ins.op == ca.OP_FABS:
                self.magnitudes.add(name)
        self.work[ins.res[0]], self.is_bool[ins.res[0]] = name, boolean
        self.constants.pop(ins.res[0], None)


def _declarations(out_names: list[str], sizes: dict[str, int], printer: CPrinter) -> tuple[str, ...]:
    return tuple(f"{printer.real} {name};" if sizes[name] == 1 else f"{printer.real} {name}[{sizes[name]}];"
                 for name in out_names)


def build_section(stage: Stage, used: set[str], sizes: dict[str, int], printer: CPrinter) -> Section:
    keep = [i for i, name in enumerate(stage.outputs) if name in used]
    out_names = [stage.outputs[i] for i in keep]
    function = _pruned(stage, keep)
    code = _instructions(function)
    writer = _Writer(printer, code)
    lines: list[str] = []
    for k, ins in enumerate(code):
        writer.index = k
        writer.emit(ins, function, stage, out_names, sizes, lines)
    return Section(stage.name, stage.doc, _declarations(out_names, sizes, printer), tuple(lines), writer.ops,
                   writer.calls)


@dataclass(frozen=True)
class Validation:
    """The validate stage split in two: the fast path computes only the int ``accept`` (every test
    passed); the status bits are assembled in ``reject_lines``, which run only on a rejection."""
    section: Section          # lines: the fast path
    accept: str               # C int expression, nonzero when the sample passes every test
    reject_lines: tuple[str, ...]


def build_validation(stage: Stage, sizes: dict[str, int], printer: CPrinter) -> Validation:
    """The fast path computes what ``accepted`` needs, its tests printed for finite values (the
    conjunction includes the finiteness test, see CPrinter.assume_finite); the rejection path computes
    ``status`` on its own (temporaries r0, r1, ...) with the NaN-exact tests, so that each bit is the
    reference's for any input."""
    out_names = list(stage.outputs)  # ("status", "accepted")
    function = _pruned(stage, list(range(len(out_names))))
    code = _instructions(function)
    computed: dict[int, str] = {}
    fast_lines = _emit_subset(function, code, _needed_by(code, out_names.index("accepted")), stage, out_names, sizes,
                              _Writer(dataclasses.replace(printer, assume_finite=True), code), computed)
    # The rejection path reuses the fast path's arithmetic (sums of squares: the same either way) and
    # prints again only the tests and what depends on them.
    slow = _Writer(printer, code, temp_prefix="r")
    slow.integer_status = True
    slow_lines = _emit_subset(function, code, _needed_by(code, out_names.index("status")), stage, out_names, sizes, slow,
                              computed, reuse=True)
    fast_writer = fast_lines[1]
    section = Section(stage.name, stage.doc, (), tuple(fast_lines[0]), fast_writer.ops, fast_writer.calls)
    if fast_lines[2] is None:
        raise ValueError("the validate stage has no accepted output")
    return Validation(section, fast_lines[2], ("int status;", *slow_lines[0]))


def _emit_subset(function: ca.Function, code: list[_Instruction], subset: set[int], stage: Stage,
                 out_names: list[str], sizes: dict[str, int], writer: "_Writer", computed: dict[int, str],
                 reuse: bool = False) -> tuple[list[str], "_Writer", str | None]:
    """The instructions of ``subset`` printed by ``writer``: (lines, writer, the accepted expression).
    The ``accepted`` output is not assigned but returned: the template tests it. ``computed``: instruction
    -> the temporary holding its floating-point value; filled, or (``reuse``) read instead of printing."""
    lines: list[str] = []
    accept = None
    for k, ins in enumerate(code):
        if k not in subset:
            continue
        writer.index = k
        if ins.op == ca.OP_OUTPUT and out_names[ins.res[0]] == "accepted":
            accept = writer.work[ins.args[0]]
            continue
        if reuse and k in computed:
            writer.work[ins.res[0]], writer.is_bool[ins.res[0]] = computed[k], False
            writer.constants.pop(ins.res[0], None)
            continue
        writer.emit(ins, function, stage, out_names, sizes, lines)
        if not reuse and ins.op not in _NOT_OPS and not writer.is_bool[ins.res[0]]:
            computed[k] = writer.work[ins.res[0]]
    return lines, writer, accept


def build_sections(model: StepModel, printer: CPrinter) -> tuple[Validation, tuple[Section, ...], Section]:
    """(validate, the computing stages, the result check)."""
    sizes = signal_sizes(model)
    used = used_signals(model) | {"status", "result_status", "quality_status"}
    limits = dataclasses.replace(printer, directed_limits=True)  # the rejection tests
    # Validation with the finiteness test as an input: the template computes it as one loop over the inputs.
    validate = build_validation(validate_given_finite(model.airframe, model.inputs), {**sizes, FINITE_SIGNAL: 1}, limits)
    check = build_section(model.check_result, used, sizes, limits)
    return validate, tuple(build_section(stage, used, sizes, printer) for stage in model.stages), check
