"""Stages of the step as labelled C sections: named locals, SSA temporaries, op counts."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import casadi as ca

from dobwind.codegen import bitranges
from dobwind.codegen.printer import CALL_OPS, CPrinter, directed_float
from dobwind.model.step import FINITE_SIGNAL, Stage, StepModel, validate_given_finite

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
class _RangeTest:
    """A truth value not printed yet: ``operand``'s bit pattern lies in ``intervals`` (codegen/bitranges.py).
    Tests of one operand combine (and, or, not) into one such set before they are printed."""
    operand: str
    intervals: tuple[bitranges.Interval, ...]
    named: tuple[tuple[int, str], ...]  # the limits' patterns and their C literals, for readable bounds


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


def _has_normal_reciprocal(value: float | None) -> bool:
    """A constant divisor whose reciprocal is a normal float (then x / c becomes x * (1/c))."""
    return value is not None and value != 0.0 and 1.2e-38 < abs(1.0 / value) < 3.4e38


class _Writer:
    """Prints one stage's instructions as C lines (SSA temporaries t0, t1, ...)."""

    def __init__(self, printer: CPrinter, code: list[_Instruction], temp_prefix: str = "t") -> None:
        self.printer = printer
        self.code = code
        self.temp_prefix = temp_prefix
        self.integer_status = False  # print status bits as int (integer_bits); the rejection path only
        self.ints: set[str] = set()
        self.work: dict[int, str] = {}
        self.is_bool: dict[int, bool] = {}
        self.constants: dict[int, float] = {}
        self.serial = self.ops = self.calls = 0
        # Real-valued temporaries by their C expression: ``given`` are another section's, in scope here (the
        # quick test's, for the exact tests), reused rather than computed again; ``defined`` this one's.
        self.given: dict[str, str] = {}
        self.defined: dict[str, str] = {}
        self.index = 0  # the instruction being printed (constants are read from the Function by index)
        self.sincos: dict[tuple[int, int], str] = {}     # angle value -> its sincos temporary
        self.reciprocal: dict[tuple[int, int], str] = {}  # denominator value -> 1/it
        # Temporaries never holding a negative number (NaN of either sign aside): |x|, x*x, and sums and
        # products of such; with flush to zero too (a product flushes to +0). A comparison's set holds no
        # NaN, so for these its patterns in the negative half can go: "x*x + y*y <= c" is one interval.
        self.nonnegative: set[str] = set()
        # A test that only has to imply the exact one (the quick acceptance, model/step.py): -0 may be
        # dropped from its sets (a rotor at -0 rpm then takes the exact path), which saves a comparison.
        # Sound because such a test is an and/or of its tests, checked as it is printed (monotone).
        self.sufficient = False
        # A sufficient test's and/or, not printed yet (``junction``): its operator and its terms as C. Printed
        # as one short-circuit expression where it is assigned, the tests then run only until one fails and
        # the compiler may branch past the rest (4 x86 instructions and 56 B of M4F code less on the m300
        # than an int per test combined with & (issue #32)).
        self.junctions: dict[str, tuple[int, tuple[str, ...]]] = {}
        # The rejection tests (a printer with directed_limits): comparisons with a constant kept as bit-pattern
        # sets until something other than another test of the same operand reads them (_RangeTest).
        self.range_tests = printer.directed_limits and printer.kernel_prefix is not None
        self.tests: dict[int, _RangeTest] = {}
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
            if args[1] in self.ints:  # bits selected again: still those bits or none
                name = self.temp("int", f"({args[0]} ? {args[1]} : 0)", lines)
                self.ints.add(name)
                return name
        if ins.op == ca.OP_ADD and all(a in self.ints for a in args):
            name = self.temp("int", f"{args[0]} | {args[1]}", lines)  # distinct bits: OR is their sum
            self.ints.add(name)
            return name
        return None

    def combine_test(self, ins: _Instruction) -> bool:
        """A comparison of a value with a constant, or a not/and/or of such tests on one value: kept as a
        _RangeTest (not printed yet). False: another operation."""
        f = bitranges.fmt(self.printer.precision)
        if ins.op in (ca.OP_LT, ca.OP_LE) and len(ins.args) == 2 and not any(self.is_bool.get(a, False) for a in ins.args):
            consts = [self.constants.get(a) for a in ins.args]
            if (consts[0] is None) == (consts[1] is None):
                return False
            left = consts[0] is not None  # c < x, c <= x
            strict = ins.op == ca.OP_LT
            # The float on the safe side of the double limit (see CPrinter._compared): x <= c with the largest
            # float <= c, c <= x with the smallest float >= c; strict tests the other way.
            value = consts[0] if left else consts[1]
            limit = directed_float(value, up=left != strict) if f.bits == 32 else value
            operand = self.work[ins.args[1 if left else 0]]
            intervals = bitranges.comparison(f, left, strict, limit)
            if operand in self.nonnegative:  # only patterns below the sign bit occur (NaN aside)
                intervals = bitranges.intersection(f, intervals, ((0, f.sign - 1),))
            self.define_test(ins, _RangeTest(operand, intervals, ((f.pattern(limit), self.printer.literal(limit)),)))
            return True
        tests = [self.tests.get(a) for a in ins.args]
        if not tests or any(t is None for t in tests) or len({t.operand for t in tests}) != 1:
            return False
        if ins.op == ca.OP_NOT:
            intervals = bitranges.complement(f, tests[0].intervals)
        elif ins.op == ca.OP_AND:
            intervals = bitranges.intersection(f, tests[0].intervals, tests[1].intervals)
        elif ins.op == ca.OP_OR:
            intervals = bitranges.union(f, tests[0].intervals, tests[1].intervals)
        else:
            return False
        named = tuple(dict.fromkeys(n for t in tests for n in t.named))
        self.define_test(ins, _RangeTest(tests[0].operand, intervals, named))
        return True

    def _never_negative(self, ins: _Instruction) -> bool:
        """Whether the result is never a negative number (see ``nonnegative``): |x|, x*x, sqrt, and sums and
        products of such and of constants > 0."""
        if ins.op in (ca.OP_FABS, ca.OP_SQ) or (ins.op == ca.OP_MUL and ins.uses[0] == ins.uses[1]):
            return True
        if ins.op not in (ca.OP_ADD, ca.OP_MUL, ca.OP_SQRT):
            return False
        return all(self.work[a] in self.nonnegative or self.constants.get(a, -1.0) > 0.0 for a in ins.args)

    def define_test(self, ins: _Instruction, test: _RangeTest) -> None:
        self.tests[ins.res[0]] = test
        self.work[ins.res[0]], self.is_bool[ins.res[0]] = "", True
        self.constants.pop(ins.res[0], None)

    def materialize(self, slot: int, lines: list[str]) -> None:
        """Prints the pending test in ``slot`` as an int temporary (codegen/bitranges.py's sets as C)."""
        test = self.tests.pop(slot, None)
        if test is not None:
            f = bitranges.fmt(self.printer.precision)
            if self.sufficient and bitranges.contains(test.intervals, f.sign) and test.intervals != ((f.sign, f.sign),):
                test = dataclasses.replace(test, intervals=bitranges.intersection(
                    f, test.intervals, bitranges.complement(f, ((f.sign, f.sign),))))
            text = _test_text(self.printer, test)
            if self.sufficient:  # a term of the junction that reads it (and/or only: emit checks it)
                self.ops += 1
                self.work[slot] = text if _atomic(text) else f"({text})"
            else:
                self.work[slot] = self.temp("int", text, lines)

    def junction(self, ins: _Instruction) -> None:
        """A sufficient test's and/or of two tests as a pending junction (see ``junctions``): the terms of an
        operand of the same operator are taken in, another is one term (parenthesised when printed)."""
        terms: list[str] = []
        for slot in ins.args:
            value = self.work[slot]
            op, inner = self.junctions.get(value, (None, ()))
            terms += inner if op == ins.op else [_junction_text(self.junctions[value]) if op is not None else value]
        joined = _junction_text((ins.op, tuple(terms)))
        self.junctions[joined] = (ins.op, tuple(terms))
        self.ops += 1
        self.work[ins.res[0]], self.is_bool[ins.res[0]] = joined, True
        self.constants.pop(ins.res[0], None)

    def temp(self, ctype: str, expr: str, lines: list[str], counted: bool = True) -> str:
        if ctype == self.printer.real and expr in self.given:
            # Computed once: with -funsafe-math-optimizations (PX4) two copies of a sum may be reassociated
            # differently, and the quick test's |q|^2 could then pass where the exact test's fails.
            return self.given[expr]
        name = f"{self.temp_prefix}{self.serial}"
        self.serial += 1
        self.ops += counted
        lines.append(f"const {ctype} {name} = {expr};")
        if ctype == self.printer.real:
            self.defined[expr] = name
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

    def output(self, ins: _Instruction, out_names: list[str], sizes: dict[str, int], lines: list[str]) -> None:
        """The assignment of an output element; a junction one term per line."""
        target = c_element(out_names[ins.res[0]], ins.res[1], sizes[out_names[ins.res[0]]], self.printer)
        value = self.work[ins.args[0]]
        if value in self.junctions:
            op, terms = self.junctions[value]
            ends = [" &&" if op == ca.OP_AND else " ||"] * (len(terms) - 1) + [";"]
            lines.append(f"{target} = {terms[0]}{ends[0]}")
            lines += [f"    {term}{end}" for term, end in zip(terms[1:], ends[1:])]
            return
        if self.is_bool[ins.args[0]] and not self.integer_status:  # an int status or decision stays int
            value = f"({self.printer.real}){value}"
        lines.append(f"{target} = {value};")

    def emit(self, ins: _Instruction, function: ca.Function, stage: Stage, out_names: list[str],
             sizes: dict[str, int], lines: list[str]) -> None:
        p = self.printer
        if ins.op in (ca.OP_CONST, ca.OP_INPUT):
            self.tests.pop(ins.res[0], None)  # a reused slot: the test it held is dead
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
        if self.range_tests and self.combine_test(ins):
            return
        for slot in ins.args:
            self.materialize(slot, lines)
        if self.sufficient and ins.op not in (ca.OP_AND, ca.OP_OR, ca.OP_OUTPUT) and any(self.is_bool[a] for a in ins.args):
            raise ValueError(f"CasADi operation {ins.op} on a test in a sufficient test: only and/or keep "
                             "a dropped -0 from accepting more than the exact test")
        if ins.op != ca.OP_OUTPUT:
            self.tests.pop(ins.res[0], None)
        if self.sufficient and ins.op in (ca.OP_AND, ca.OP_OR):
            self.junction(ins)
            return
        if ins.op == ca.OP_OUTPUT:
            self.output(ins, out_names, sizes, lines)
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
                                        lambda i: self.constants.get(ins.args[i]) if i < len(ins.args) else None)
            if boolean and self.sufficient:  # a comparison of two values: a term of a junction, as a range test
                self.ops += 1
                self.work[ins.res[0]], self.is_bool[ins.res[0]] = expr if _atomic(expr) else f"({expr})", True
                self.constants.pop(ins.res[0], None)
                return
            name = self.temp("int" if boolean else p.real, expr, lines)
            self.calls += ins.op in CALL_OPS
            if self._never_negative(ins):
                self.nonnegative.add(name)
        self.work[ins.res[0]], self.is_bool[ins.res[0]] = name, boolean
        self.constants.pop(ins.res[0], None)


def _atomic(text: str) -> bool:
    """Whether a test's C needs no parentheses as a term of && or || (no operator of lower precedence)."""
    return "||" not in text and "&&" not in text and "?" not in text


def _junction_text(junction: tuple[int, tuple[str, ...]]) -> str:
    op, terms = junction
    return "(" + (" && " if op == ca.OP_AND else " || ").join(terms) + ")"


def _pattern_text(printer: CPrinter, f: bitranges.Format, pattern: int, named: tuple[tuple[int, str], ...]) -> str:
    """A bound of a bit-pattern interval in C: the limit's own literal through bits() where it is one
    (or one pattern beside it, for a strict test), the special patterns in hexadecimal."""
    k = printer.kernel_prefix
    for limit, literal in named:
        for offset, suffix in ((0, ""), (1, " + 1u"), (-1, " - 1u")):
            if pattern == limit + offset and not (limit + offset) & ~f.top:
                return f"({k}bits({literal}){suffix})" if suffix else f"{k}bits({literal})"
    return f"0x{pattern:08x}u" if f.bits == 32 else f"UINT64_C(0x{pattern:016x})"


def _interval_text(printer: CPrinter, f: bitranges.Format, u: str, interval: bitranges.Interval,
                   named: tuple[tuple[int, str], ...]) -> str:
    lo, hi = interval
    text = lambda pattern: _pattern_text(printer, f, pattern, named)  # noqa: E731
    if lo == hi:
        return f"{u} == {text(lo)}"
    if lo == 0:
        return f"{u} <= {text(hi)}"
    if hi == f.top:
        return f"{u} >= {text(lo)}"
    return f"{printer.kernel_prefix}within({u}, {text(lo)}, {text(hi)})"  # lo > hi: wraps around


def _test_text(printer: CPrinter, test: _RangeTest) -> str:
    """The test as C: the set or the negation of its complement, whichever prints fewer comparisons (then
    fewer wrapped intervals: ``!within(dt, lo, hi)`` rather than the wrapped interval beyond it)."""
    f = bitranges.fmt(printer.precision)
    u = f"{printer.kernel_prefix}bits({test.operand})"
    options = []
    for negated, intervals in ((False, test.intervals), (True, bitranges.complement(f, test.intervals))):
        printed = bitranges.wrapped(f, intervals)
        cost = (len(printed), sum(lo > hi for lo, hi in printed), negated)
        options.append((cost, negated, printed))
    _, negated, printed = min(options)
    if not printed:
        return "1" if negated else "0"
    parts = [_interval_text(printer, f, u, interval, test.named) for interval in printed]
    text = parts[0] if len(parts) == 1 else " || ".join(f"({part})" for part in parts)
    return f"!({text})" if negated else text


def _declarations(out_names: list[str], sizes: dict[str, int], printer: CPrinter) -> tuple[str, ...]:
    return tuple(f"{printer.real} {name};" if sizes[name] == 1 else f"{printer.real} {name}[{sizes[name]}];"
                 for name in out_names)


def build_section(stage: Stage, used: set[str], sizes: dict[str, int], printer: CPrinter,
                  integer_status: bool = False) -> Section:
    """``integer_status``: the stage's outputs are status bits, printed and declared as int."""
    keep = [i for i, name in enumerate(stage.outputs) if name in used]
    out_names = [stage.outputs[i] for i in keep]
    function = _pruned(stage, keep)
    writer = _Writer(printer, _instructions(function))
    writer.integer_status = integer_status
    declarations = tuple(f"int {name};" for name in out_names) if integer_status else \
        _declarations(out_names, sizes, printer)
    return _written(writer, function, stage, out_names, sizes, declarations)


def _written(writer: _Writer, function: ca.Function, stage: Stage, out_names: list[str], sizes: dict[str, int],
             declarations: tuple[str, ...]) -> Section:
    """The section ``writer`` prints from ``function``'s instructions (those it was made with)."""
    lines: list[str] = []
    for k, ins in enumerate(writer.code):
        writer.index = k
        writer.emit(ins, function, stage, out_names, sizes, lines)
    return Section(stage.name, stage.doc, declarations, tuple(lines), writer.ops, writer.calls)


@dataclass(frozen=True)
class Validation:
    """The validate stage in two parts. ``quick`` computes the int ``quick_accept``: a cheaper test that
    implies acceptance (model/step.py), each of its tests one bit-pattern interval, none over every input.
    ``section`` computes the int ``status`` (0: accepted) for a sample the quick test does not accept, every
    test an exact integer test of bit patterns (codegen/bitranges.py), so that one computation gives both
    the decision and each status bit as the reference's for any input, NaN included."""
    section: Section
    quick: Section


def _integer_section(stage: Stage, output: str, sizes: dict[str, int], printer: CPrinter, prefix: str,
                     sufficient: bool, given: dict[str, str] | None = None,
                     defined: dict[str, str] | None = None) -> Section:
    """One int output of the validate stage as C lines, with temporaries named ``prefix``0, 1, ...
    ``given``: real-valued temporaries in scope by expression, reused; ``defined`` receives this one's."""
    function = _pruned(stage, [list(stage.outputs).index(output)])
    writer = _Writer(printer, _instructions(function), prefix)
    writer.integer_status, writer.sufficient = True, sufficient
    writer.given = dict(given or {})
    writer.defined = defined if defined is not None else {}
    return _written(writer, function, stage, [output], sizes, ())


def build_validation(stage: Stage, sizes: dict[str, int], printer: CPrinter) -> Validation:
    # The quick test's temporaries are named a0, a1, ...: the status's t0, ... are in a block inside its
    # scope, and the same names would shadow them (-Wshadow). The exact tests read the quick test's
    # values (|q|^2, the tilt's terms, |v|^2, ...) rather than computing them again: one value, so that
    # the quick test implies them whatever the compiler does to a computation (sections.py, temp).
    values: dict[str, str] = {}
    quick = _integer_section(stage, "quick_accept", sizes, printer, "a", True, defined=values)
    return Validation(_integer_section(stage, "status", sizes, printer, "t", False, given=values), quick)


def build_sections(model: StepModel, printer: CPrinter) -> tuple[Validation, tuple[Section, ...], Section]:
    """(validate, the computing stages, the result check)."""
    sizes = signal_sizes(model)
    used = used_signals(model) | {"status", "result_status", "quality_status"}
    limits = dataclasses.replace(printer, directed_limits=True)  # the rejection tests
    # Validation with the finiteness test as an input: the template computes it as one loop over the inputs.
    validate = build_validation(validate_given_finite(model.airframe, model.inputs), {**sizes, FINITE_SIGNAL: 1}, limits)
    check = build_section(model.check_result, used, sizes, limits, integer_status=True)
    return validate, tuple(build_section(stage, used, sizes, printer) for stage in model.stages), check
