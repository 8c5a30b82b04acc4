"""`make mutants`: prove that the checks can fail. Each mutant (tools/mutant_table.py) changes one
thing; each is expected to be caught.

C mutants edit the freshly generated C of one precision in a temporary folder, which is then checked
as ``dobwind verify --c-dir`` checks it: a strict build, the generated self-test (the unmutated
vectors against the mutated step), and the comparison with the Python reference on random and limit
cases and on a flight. Model mutants patch one module's source before the tests import it and run the
targeted tests (mutant_table.MODEL_TESTS) in a subprocess: verify cannot see them, since the C and
the reference would change together.

Exit status: 0 when every mutant is caught, 1 when any survives, 2 when a mutant's anchor is missing
or the unmutated code already fails a check (then "caught" would mean nothing).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import re
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from dobwind.codegen.generate import generate_code, write_files
from dobwind.codegen.printer import CPrinter
from dobwind.model.errors import EXIT_BAD_INPUT, EXIT_CHECK_FAILED, CheckFailed
from tools.mutant_table import MODEL_TESTS, CMutant, ModelMutant, c_mutants, model_mutants
from dobwind.harness.verify import PrecisionReport, ReferenceChecks, verify_precision
from dobwind.model.airframe import load_airframe
from dobwind.model.step import StepModel, build_step

REPO = Path(__file__).resolve().parent.parent
# Plain C numbers, not part of a name or an index: 2.0f, 1e-06, -6.28318531f, 1000000.0.
_LITERAL = re.compile(r"(?<![\w.])-?\d+(?:\.\d*)?(?:e[+-]?\d+)?f?(?![\w.\]])")


class AnchorError(Exception):
    """A mutation that does not apply: the runner stops instead of counting it as caught."""


@dataclass(frozen=True)
class Outcome:
    mutant: str
    where: str
    caught_by: tuple[str, ...]

    @property
    def caught(self) -> bool:
        return bool(self.caught_by)


def region_span(text: str, region: str, prefix: str) -> tuple[int, int]:
    """Start and end of a labelled section ("/* ---- name:"), of a single-precision kernel
    ("kernel:sincos" is the function <prefix>sincos), or of the file."""
    if region in ("file", "header"):  # "header": the whole of <name>_wind.h
        return 0, len(text)
    if region.startswith("kernel:"):
        start = text.find(f" {prefix}{region.removeprefix('kernel:')}(")
        start = -1 if start < 0 or not text[text.rfind("\n", 0, start) + 1:start].startswith("static ") else start
        end = text.find("\n}\n", start) if start >= 0 else -1
    else:
        header = text.find(f"/* ---- {region}:")
        start = text.find("\n", header) if header >= 0 else -1  # not the label: its numbers are prose
        following = [i for i in (text.find("/* ----", start + 1), text.find("\n}\n", start)) if i > 0]
        end = min(following) if following else -1
    if start < 0 or end < 0:
        raise AnchorError(f"region {region!r} not found in the generated C")
    return start, end


def _mutate_literals(body: str, mutant: CMutant, printer: CPrinter) -> tuple[str, int]:
    """Every literal within 1e-6 relative of ``mutant.near``, scaled or replaced; and how many."""
    hits: list[str] = []

    def replace(match: re.Match) -> str:
        value = float(match.group(0).rstrip("f"))
        if mutant.near is None or not math.isclose(value, mutant.near, rel_tol=1e-6, abs_tol=0.0):
            return match.group(0)
        hits.append(match.group(0))
        return printer.literal(mutant.value if mutant.value is not None else value * (mutant.scale or 1.0))

    return _LITERAL.sub(replace, body), len(hits)


def apply_c_mutant(text: str, mutant: CMutant, precision: str, prefix: str) -> str:
    printer = CPrinter(precision, kernel_prefix=prefix)
    start, end = region_span(text, mutant.region, prefix)
    body = text[start:end]
    if mutant.near is not None:
        new_body, hits = _mutate_literals(body, mutant, printer)
    else:
        replacement = mutant.replacement.replace("{real}", printer.real)
        new_body, hits = re.subn(mutant.pattern, replacement, body)
    if hits != mutant.count and not (mutant.count is None and hits > 0):
        raise AnchorError(f"mutant {mutant.name!r} ({precision}): anchor matched {hits} times in region "
                          f"{mutant.region!r}, expected {mutant.count or 'at least 1'}")
    return text[:start] + new_body + text[end:]


def caught_by(report: PrecisionReport) -> tuple[str, ...]:
    checks = [f"build {label}" for label, result in report.compilers.items() if result != "ok"]
    if not report.selftest_ok:
        checks.append("self-test")
    if report.cases is None or not report.cases.passed():
        checks.append("verify cases")
    if report.flight is None or not report.flight.passed():
        checks.append("verify flight")
    return tuple(checks)


KERNEL_TESTS = ("tests/test_kernels.py::test_expm1_kernel_matches_libm_over_its_whole_range",
                "tests/test_kernels.py::test_atan2_kernel_matches_libm_in_every_octant")


def kernel_tests(folder: Path) -> tuple[str, ...]:
    """The suite's kernel-against-libm tests on the given C. They cover each kernel's whole range, where
    the step's own inputs may never reach (m300's expm1 arguments stay inside the polynomial's interval)."""
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *KERNEL_TESTS],
                          cwd=REPO, env=dict(os.environ, DOBWIND_KERNEL_C_DIR=str(folder)),
                          capture_output=True, text=True)
    if done.returncode not in (0, 1):
        raise AnchorError(f"kernel tests: pytest exit {done.returncode}:\n{done.stdout[-2000:]}")
    return ("test_kernels",) if done.returncode == 1 else ()


def check_c(model: StepModel, files: dict[str, str], precision: str, steps: int, root: Path, label: str,
            references: ReferenceChecks | None = None, kernels: bool = False) -> tuple[str, ...]:
    folder = root / label / "c"
    folder.mkdir(parents=True)
    write_files(files, folder)
    work = root / label / "work"  # a fresh library path: ctypes would reuse an already loaded one
    work.mkdir()
    try:
        # No separate strict compiles: the shared library is built with the same strict flags.
        report = verify_precision(model, precision, steps, seed=1, work=work, c_dir=folder, compilers=[],
                                  references=references or ReferenceChecks.build(model, precision, steps, 1))
    except CheckFailed as exc:  # the shared library did not build
        return (f"build: {str(exc).splitlines()[-1][:60]}",)
    return caught_by(report) + (kernel_tests(folder) if kernels else ())


def run_c_mutants(model: StepModel, steps: int, root: Path, only: str | None) -> list[Outcome]:
    af = model.airframe
    prefix = f"{af.name}_wind_"
    source = f"{af.name}_wind.c"
    outcomes = []
    for precision in ("single", "double"):
        files = generate_code(af, precision, model).files
        references = ReferenceChecks.build(model, precision, steps, seed=1)
        baseline = check_c(model, files, precision, steps, root, f"baseline-{precision}", references)
        if baseline:
            raise AnchorError(f"the unmutated {precision}-precision C already fails: {', '.join(baseline)}")
        for k, mutant in enumerate(m for m in c_mutants(af) if precision in m.precisions):
            if only and only not in mutant.name:
                continue
            target = f"{af.name}_wind.h" if mutant.region == "header" else source
            mutated = dict(files, **{target: apply_c_mutant(files[target], mutant, precision, prefix)})
            found = check_c(model, mutated, precision, steps, root, f"{precision}-{k}", references,
                            kernels=mutant.region.startswith("kernel:") and af.name == "m300")  # the tests probe m300
            outcomes.append(Outcome(mutant.name, f"C {precision}: {mutant.region}", found))
            print(f"  {outcomes[-1].where:28s} {mutant.name:45s} {', '.join(found) or 'SURVIVED'}", flush=True)
    return outcomes


def run_model_mutant(mutant: ModelMutant, root: Path, tests: tuple[str, ...]) -> Outcome:
    source = Path(__import__(mutant.module, fromlist=["_"]).__file__).read_text()
    if source.count(mutant.old) != 1:
        raise AnchorError(f"model mutant {mutant.name!r}: {mutant.old!r} found {source.count(mutant.old)} times "
                          f"in {mutant.module}")
    marker = root / f"applied-{abs(hash(mutant.name))}"
    env = dict(os.environ, DOBWIND_MUTANT=json.dumps({"module": mutant.module, "old": mutant.old, "new": mutant.new}),
               DOBWIND_MUTANT_APPLIED=str(marker))
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider",
                           "-p", "tools.mutant_plugin", *tests], cwd=REPO, env=env,
                          capture_output=True, text=True)
    if not marker.exists():
        raise AnchorError(f"model mutant {mutant.name!r} was not applied:\n{done.stdout[-2000:]}{done.stderr[-2000:]}")
    failed = re.findall(r"^FAILED (\S+)", done.stdout, re.MULTILINE)
    # pytest exits 1 when tests failed; anything else (usage, collection, internal error) is no verdict.
    where = f"model: {mutant.module.rsplit('.', 1)[-1]}"
    if done.returncode == 1 and failed:
        # The first failing test, without its parameters (-x stops there).
        return Outcome(mutant.name, where, tuple(f"test {f.split('::')[-1].split('[')[0]}" for f in failed))
    if done.returncode == 0:
        return Outcome(mutant.name, where, ())
    raise AnchorError(f"model mutant {mutant.name!r}: pytest exit {done.returncode}:\n{done.stdout[-2000:]}")


def table(outcomes: list[Outcome]) -> str:
    lines = [f"{'mutant':46s} {'where':28s} caught by", "-" * 110]
    lines += [f"{o.mutant:46s} {o.where:28s} {', '.join(o.caught_by) or 'SURVIVED'}" for o in outcomes]
    caught = sum(o.caught for o in outcomes)
    lines.append(f"caught {caught}/{len(outcomes)}" + ("" if caught == len(outcomes) else
                                                        f": {len(outcomes) - caught} survived (a missing test)"))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools.mutants", description=__doc__.split("\n\n")[0])
    parser.add_argument("airframe", nargs="?", default=str(REPO / "airframes" / "m300.toml"))
    parser.add_argument("--steps", type=int, default=5000, help="flight steps compared per C mutant")
    parser.add_argument("--only", help="run only the mutants whose name contains this text")
    parser.add_argument("--skip-model", action="store_true", help="C mutants only")
    args = parser.parse_args(argv)
    model = build_step(load_airframe(args.airframe))
    try:
        with tempfile.TemporaryDirectory(prefix="dobwind-mutants-") as tmp:
            outcomes = run_c_mutants(model, args.steps, Path(tmp), args.only)
            if not args.skip_model:
                for mutant in model_mutants():
                    if args.only and args.only not in mutant.name:
                        continue
                    outcomes.append(run_model_mutant(mutant, Path(tmp), MODEL_TESTS))
                    print(f"  {outcomes[-1].where:28s} {mutant.name:45s} "
                          f"{', '.join(outcomes[-1].caught_by) or 'SURVIVED'}", flush=True)
    except AnchorError as exc:
        print(f"mutants: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    print(table(outcomes))
    return 0 if all(o.caught for o in outcomes) else EXIT_CHECK_FAILED


if __name__ == "__main__":
    sys.exit(main())
