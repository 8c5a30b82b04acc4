"""`dobwind verify`: generate into a temporary folder, compile strictly with every compiler at hand,
and compare the C step with the Python reference on random cases and on a long flight."""
from __future__ import annotations

import tempfile
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from dobwind.codegen.generate import generate_code, write_files
from dobwind.codegen.tolerance import TOLERANCE
from dobwind.model.errors import CheckFailed
from dobwind.harness.build import available_compilers, build_shared_library, run, strict_compile, system_compiler
from dobwind.harness.compare import Comparison, compare
from dobwind.harness.cstep import CStep
from dobwind.model import reference
from dobwind.model.airframe import Airframe
from dobwind.model.exercise import flight_inputs, random_cases
from dobwind.model.reference import Trajectory
from dobwind.model.step import StepModel, build_step

RANDOM_CASES = 5000


@dataclass
class PrecisionReport:
    precision: str
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
            for title, comp in (("random cases", p.cases), ("flight", p.flight)):
                if comp is None:
                    continue
                worst = sorted(comp.outputs, key=lambda e: -e.worst_ratio)[:4]
                lines.append(f"    {title}: {comp.rows} steps, {comp.status_mismatches} status mismatches, "
                             f"worst error/tolerance {comp.worst_ratio:.3g}")
                for e in worst:
                    lines.append(f"      {e.name:14s} max |diff| {e.max_abs:.3g} (x{e.worst_ratio:.3g} of tolerance, row {e.worst_row})")
        return "\n".join(lines)


def _as_precision(array: np.ndarray, precision: str) -> np.ndarray:
    """What the C code holds: inputs and states rounded to float in single precision."""
    return array.astype(np.float32).astype(np.float64) if precision == "single" else array


def reference_cases(model: StepModel, states: np.ndarray, inputs: np.ndarray) -> Trajectory:
    mapped = model.step.map(inputs.shape[0])
    xs, ys, st = mapped(states.T, inputs.T)
    return Trajectory(np.asarray(xs).T, np.asarray(ys).T, np.asarray(st).ravel().astype(np.int64))


def verify_precision(model: StepModel, precision: str, steps: int, seed: int, work: Path) -> PrecisionReport:
    report = PrecisionReport(precision)
    code = generate_code(model.airframe, precision, model)
    write_files(code.files, work)
    name = model.airframe.name
    for compiler in available_compilers():
        try:
            for source in (f"{name}_wind.c", f"{name}_wind_selftest.c"):
                strict_compile(compiler, work / source, work)
            report.compilers[compiler.label] = "ok"
        except CheckFailed as exc:
            report.compilers[compiler.label] = str(exc).splitlines()[-1][:200]
    try:
        exe = work / "selftest"
        run([system_compiler(), "-std=c99", "-O2", str(work / f"{name}_wind.c"), str(work / f"{name}_wind_selftest.c"),
             "-o", str(exe), "-lm"])
        done = run([str(exe)])
        report.selftest, report.selftest_ok = done.stdout.strip().splitlines()[-1], True
    except CheckFailed as exc:
        report.selftest = str(exc).strip().splitlines()[-1]
    cstep = CStep(model, build_shared_library(model, precision, work, work))

    states, inputs = random_cases(model, RANDOM_CASES, seed, boundaries=precision == "double")
    states, inputs = _as_precision(states, precision), _as_precision(inputs, precision)
    report.cases = compare(model, cstep.cases(states, inputs), reference_cases(model, states, inputs),
                           TOLERANCE[precision])
    flight = _as_precision(flight_inputs(model, steps, seed), precision)
    report.flight = compare(model, cstep.run(flight), reference.run(model, flight), TOLERANCE[precision])
    return report


def verify_airframe(af: Airframe, precision: str = "both", steps: int = 20000, seed: int = 1) -> VerifyReport:
    model = build_step(af)
    precisions = ("double", "single") if precision == "both" else (precision,)
    reports = []
    for p in precisions:
        with tempfile.TemporaryDirectory(prefix=f"dobwind-verify-{p}-") as tmp:
            reports.append(verify_precision(model, p, steps, seed, Path(tmp)))
    return VerifyReport(af.name, reports)
