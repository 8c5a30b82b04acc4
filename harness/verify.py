"""`dobwind verify`: generate into a temporary folder (or take a given folder of generated C), compile
strictly with every compiler at hand, run the self-test, and compare the C step with the Python
reference on random cases, on cases at every limit (model/boundaries.py) and on a long flight."""
from __future__ import annotations

import re
import tempfile
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from dobwind.codegen.generate import generate_code, write_files
from dobwind.codegen.tolerance import TOLERANCE
from dobwind.model.errors import CheckFailed, InputError
from dobwind.harness.build import Compiler, available_compilers, build_shared_library, run, strict_compile, system_compiler
from dobwind.harness.compare import Comparison, RowStarts, compare
from dobwind.harness.flagsets import FLAG_SETS, FlagSet, Toolchain, available_toolchains, build_selftest, compile_c
from dobwind.harness.cstep import CStep
from dobwind.harness.isolated import implies_fast_math, run_isolated
from dobwind.model import reference
from dobwind.model.airframe import Airframe
from dobwind.model.boundaries import boundary_cases
from dobwind.model.exercise import flight_inputs, random_cases
from dobwind.model.reference import Trajectory
from dobwind.model.step import StepModel, build_step
from dobwind.model.kinds import Precision

RANDOM_CASES = 5000


@dataclass
class PrecisionReport:
    precision: Precision
    compilers: dict[str, str] = field(default_factory=dict)  # label -> "ok" or the first error line
    cases: Comparison | None = None
    flight: Comparison | None = None
    selftest: str = ""
    selftest_ok: bool = False

    @property
    def passed(self) -> bool:
        return (all(v == "ok" for v in self.compilers.values()) and self.selftest_ok
                and self.cases is not None and self.cases.passed()
                and self.flight is not None and self.flight.passed())


@dataclass
class VerifyReport:
    airframe: str
    precisions: list[PrecisionReport]

    @property
    def passed(self) -> bool:
        return all(p.passed for p in self.precisions)

    def builds(self) -> list[str]:
        """The compilers that actually ran and accepted the code, in order (clang only when installed)."""
        return list(dict.fromkeys(label for p in self.precisions for label, result in p.compilers.items()
                                  if result == "ok"))

    def builds_text(self) -> str:
        return "builds: " + (", ".join(self.builds()) or "none")

    def as_dict(self) -> dict:
        return {"airframe": self.airframe, "passed": self.passed, "builds": self.builds(), "precisions": [
            {**asdict(p), "passed": p.passed} for p in self.precisions]}

    def text(self) -> str:
        lines = [f"verify {self.airframe}: {'PASS' if self.passed else 'FAIL'} ({self.builds_text()})"]
        for p in self.precisions:
            tol = TOLERANCE[p.precision]
            lines.append(f"  {p.precision} precision (tolerance rtol {tol.rtol:g}, atol {tol.atol:g}, "
                         f"angle {tol.angle_deg:g} deg): {'PASS' if p.passed else 'FAIL'}")
            for label, result in p.compilers.items():
                lines.append(f"    compile {label:14s} {result}")
            lines.append(f"    self-test: {p.selftest}")
            for title, comp in (("random and limit cases", p.cases), ("flight", p.flight)):
                if comp is None:
                    continue
                worst = sorted(comp.outputs, key=lambda e: -e.worst_ratio)[:4]
                lines.append(f"    {title}: {comp.rows} steps, {comp.status_mismatches} status mismatches, "
                             f"worst error/tolerance {comp.worst_ratio:.3g}")
                # The worst state too: a state alone can fail (issue: air_prev on the field fit's limit row).
                state = max(comp.states, key=lambda e: e.worst_ratio, default=None)
                for e, label in [(e, e.name) for e in worst] + ([(state, f"state {state.name}")] if state else []):
                    lines.append(f"      {label:14s} |diff| {e.worst_diff:.3g} at |value| {e.worst_ref:.3g} "
                                 f"(x{e.worst_ratio:.3g} of tolerance, row {e.worst_row})")
        return "\n".join(lines)


def _as_precision(array: np.ndarray, precision: Precision) -> np.ndarray:
    """What the C code holds: inputs and states rounded to float in single precision."""
    return array.astype(np.float32).astype(np.float64) if precision == Precision.SINGLE else array


def reference_cases(model: StepModel, states: np.ndarray, inputs: np.ndarray) -> Trajectory:
    mapped = model.step.map(inputs.shape[0])
    xs, ys, st = mapped(states.T, inputs.T)
    return Trajectory(np.asarray(xs).T, np.asarray(ys).T, np.asarray(st).ravel().astype(np.int64))


def folder_precision(c_dir: Path, name: str) -> str:
    """The precision a generated folder was written in, from its header's first comment line."""
    header = c_dir / f"{name}_wind.h"
    if not c_dir.is_dir():
        raise InputError(str(c_dir), None, "no such folder" if not c_dir.exists() else "not a folder")
    for needed in (header, c_dir / f"{name}_wind.c", c_dir / f"{name}_wind_selftest.c"):
        if not needed.is_file():
            raise InputError(str(c_dir), None, f"no {needed.name}: not generated C for the airframe {name!r}")
    try:
        first = header.read_text(errors="replace").splitlines()[1:2]
    except OSError as exc:
        raise InputError(str(header), None, f"cannot read: {exc.strerror}") from None
    found = re.search(r"\((single|double) precision\)", first[0] if first else "")
    if found is None:
        raise InputError(str(header), "line 2", "no '(single precision)' or '(double precision)': not written by generate")
    return found.group(1)


def _selftest_build(code_dir: Path, name: str, work: Path, flags: FlagSet | None) -> Path:
    if flags is not None:
        return build_selftest(Toolchain("cc", system_compiler(), system_compiler()), flags, code_dir, name, work)
    exe = work / "selftest"
    run([system_compiler(), "-std=c99", "-O2", str(code_dir / f"{name}_wind.c"), str(code_dir / f"{name}_wind_selftest.c"),
         "-o", str(exe), "-lm"])
    return exe


def _flag_set_builds(report: PrecisionReport, flags: FlagSet, code_dir: Path, name: str, work: Path) -> None:
    """Every toolchain at hand, C and the C file as C++, with the autopilot's set (-Werror in it)."""
    sources = [code_dir / f"{name}_wind.c", code_dir / f"{name}_wind_selftest.c"]
    for toolchain in available_toolchains():
        for cxx in (False, True):
            label = f"{toolchain.label} {flags.name} {'C++' if cxx else 'C'}"
            try:
                compile_c(toolchain, flags, sources, work, cxx)
                report.compilers[label] = "ok"
            except CheckFailed as exc:
                report.compilers[label] = _first_error(str(exc))


def _first_error(text: str) -> str:
    lines = [line for line in text.splitlines() if "error" in line] or text.splitlines()[-1:]
    return lines[0][:200]


def verify_precision(model: StepModel, precision: Precision, steps: int, seed: int, work: Path,
                     c_dir: Path | None = None, compilers: list[Compiler] | None = None,
                     references: ReferenceChecks | None = None, flags: FlagSet | None = None) -> PrecisionReport:
    """With ``c_dir`` the C in that folder is checked as it is (a hand edit shows); otherwise fresh C.
    With ``flags`` (an autopilot's set, harness/flagsets.py) the C is also compiled with it by every
    toolchain, and the self-test and the library compared with the reference are built with it."""
    # The references first, before any library is loaded into this process (see _run_c), and in IEEE
    # arithmetic: a process a fast-math library was loaded into would compute them with subnormals flushed.
    if _flushes_subnormals():
        raise CheckFailed("this process flushes subnormals to zero (a fast-math library was loaded into it): "
                          "the reference and the limit cases would be wrong")
    checks = references if references is not None else ReferenceChecks.build(model, precision, steps, seed)
    report = PrecisionReport(precision)
    if c_dir is None:
        write_files(generate_code(model.airframe, precision, model).files, work)
    code_dir = work if c_dir is None else c_dir
    name = model.airframe.name
    for compiler in compilers if compilers is not None else available_compilers():
        try:
            for source in (f"{name}_wind.c", f"{name}_wind_selftest.c"):
                strict_compile(compiler, code_dir / source, work)
            report.compilers[compiler.label] = "ok"
        except CheckFailed as exc:
            report.compilers[compiler.label] = str(exc).splitlines()[-1][:200]
    if flags is not None:
        _flag_set_builds(report, flags, code_dir, name, work)
    try:
        done = run([str(_selftest_build(code_dir, name, work, flags))])
        last = (done.stdout.strip().splitlines() or [""])[-1]
        report.selftest, report.selftest_ok = last or "no output", last.startswith("PASS")
    except CheckFailed as exc:
        report.selftest = str(exc).strip().splitlines()[-1]
    extra = () if flags is None else tuple(f for f in flags.c if f not in ("-Werror", "-Wfatal-errors"))
    cases, flight = _run_c(model, precision, build_shared_library(model, precision, code_dir, work, extra), extra, checks)
    report.cases = compare(model, cases, checks.cases, TOLERANCE[precision], RowStarts.cases(checks.states, checks.inputs))
    report.flight = compare(model, flight, checks.flight, TOLERANCE[precision],
                            RowStarts.flight(model, checks.flight_inputs, flight, checks.flight))
    return report


def _run_c(model: StepModel, precision: Precision, library: Path, flags: tuple[str, ...],
           checks: "ReferenceChecks") -> tuple[Trajectory, Trajectory]:
    """The C's answers to the checks. A library built with fast-math flags sets flush-to-zero for the
    process that loads it (gcc's crtfastmath): it runs in a child, fed in its own type, so that neither
    this process's arithmetic nor the subnormal limit rows are flushed (harness/isolated.py)."""
    if implies_fast_math(flags):
        return run_isolated(library, precision, (model.state.size, model.outputs.size), checks.states,
                            checks.inputs, checks.flight_inputs)
    cstep = CStep(model, library)
    return cstep.cases(checks.states, checks.inputs), cstep.run(checks.flight_inputs)


def _flushes_subnormals() -> bool:
    """Whether this process's arithmetic flushes subnormals (compared by bits: denormals-are-zero would
    make a float comparison see the smallest subnormal as 0 too)."""
    return int((np.array([5e-324]) * 1.0).view(np.uint64)[0]) != 1


@dataclass(frozen=True)
class ReferenceChecks:
    """The comparison's inputs and the reference's answers; the mutation suite reuses one per precision."""
    states: np.ndarray
    inputs: np.ndarray
    cases: Trajectory
    flight_inputs: np.ndarray
    flight: Trajectory

    @staticmethod
    def build(model: StepModel, precision: Precision, steps: int, seed: int) -> "ReferenceChecks":
        states, inputs = random_cases(model, RANDOM_CASES, seed)
        limits = boundary_cases(model, precision)  # already in the precision's numbers
        states = np.vstack([_as_precision(states, precision), limits.states])
        inputs = np.vstack([_as_precision(inputs, precision), limits.inputs])
        flight = _as_precision(flight_inputs(model, steps, seed), precision)
        return ReferenceChecks(states, inputs, reference_cases(model, states, inputs), flight,
                               reference.run(model, flight))


def verify_airframe(af: Airframe, precision: str = "both", steps: int = 20000, seed: int = 1,
                    c_dir: Path | None = None, model: StepModel | None = None,
                    flags: str | None = None) -> VerifyReport:
    """``c_dir``: verify that folder's C (its own precision; ``precision`` must be it or "both").
    ``flags``: "px4" or "ardupilot", build with that autopilot's compile flags too."""
    model = model or build_step(af)
    if c_dir is not None:
        found = folder_precision(Path(c_dir), af.name)
        if precision not in ("both", found):
            raise InputError(str(c_dir), None, f"holds {found}-precision C, not {precision}")
        precision = found
    flag_set = None if flags is None else FLAG_SETS[flags]
    precisions = (Precision.DOUBLE, Precision.SINGLE) if precision == "both" else (precision,)
    if flag_set is not None and not flag_set.double_ok:
        if precisions == (Precision.DOUBLE,):
            raise InputError(af.name, "--flags", f"{flags}'s -fsingle-precision-constant makes every double literal "
                             "a float: its builds are single precision (use --precision single)")
        precisions = (Precision.SINGLE,)
    reports = []
    for p in precisions:
        with tempfile.TemporaryDirectory(prefix=f"dobwind-verify-{p}-") as tmp:
            reports.append(verify_precision(model, p, steps, seed, Path(tmp), None if c_dir is None else Path(c_dir),
                                            flags=flag_set))
    return VerifyReport(af.name, reports)
