"""`generate`'s last gate: compile the freshly written C with the host compiler and run its own self-test.

The generated folder carries golden vectors (``<name>_wind_selftest.c``) computed by the Python reference.
C that compiles but disagrees with them (an airframe value for which the step cannot meet its float
tolerance, a compiler that miscompiles it) must not be reported as a success: `generate` refuses it
(exit 1) and writes nothing. When no host compiler is found the gate cannot run; `generate` then says
so on stderr and still writes, since cross-compiling for an autopilot from a machine without a host
compiler is a legitimate use (`dobwind verify` runs the same test wherever a compiler exists).
"""
from __future__ import annotations

import shlex
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

from dobwind.model.errors import CheckFailed

# A self-test compiles in well under a second and runs in milliseconds; these bounds only stop a
# compiler or a program that hangs (a wrapper script waiting on a terminal, say).
COMPILE_TIMEOUT_S = 300.0
RUN_TIMEOUT_S = 60.0


@dataclass(frozen=True)
class SelfTestResult:
    ran: bool      # False: no host compiler was found, nothing was checked
    summary: str   # the self-test's last line ("PASS: ...") or why it did not run


def host_compiler(cc: str) -> list[str] | None:
    """The compiler command as argv ($CC may hold "ccache gcc"), or None if its program is not found."""
    try:
        argv = shlex.split(cc)
    except ValueError:
        return None
    if not argv or shutil.which(argv[0]) is None:
        return None
    return argv


def _run(argv: list[str], timeout_s: float, what: str) -> subprocess.CompletedProcess:
    try:
        return subprocess.run(argv, capture_output=True, text=True, errors="replace", timeout=timeout_s)
    except subprocess.TimeoutExpired:
        raise CheckFailed(f"{what} did not finish within {timeout_s:g} s") from None
    except OSError as exc:
        raise CheckFailed(f"{what} could not be started: {exc.strerror or exc}") from None


def _last_line(text: str) -> str:
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return lines[-1][:300] if lines else ""


def run_selftest(code_dir: Path, name: str, cc: str) -> SelfTestResult:
    """Builds ``<name>_wind.c`` + ``<name>_wind_selftest.c`` from ``code_dir`` and runs it.

    Raises CheckFailed when the build fails, when the program exits non-zero, or when it exits 0
    without the PASS line the generated self-test prints (a compiler stand-in that does nothing)."""
    compiler = host_compiler(cc)
    if compiler is None:
        return SelfTestResult(False, f"no host C compiler ({cc!r} not found): the self-test was not run")
    with tempfile.TemporaryDirectory(prefix="dobwind-selftest-") as work:
        exe = Path(work) / "selftest"
        sources = [str(code_dir / f"{name}_wind.c"), str(code_dir / f"{name}_wind_selftest.c")]
        built = _run([*compiler, "-std=c99", "-O1", *sources, "-o", str(exe), "-lm"], COMPILE_TIMEOUT_S,
                     f"the host compiler {cc!r}")
        if built.returncode != 0:
            raise CheckFailed(f"the generated C does not compile with {cc!r}: {_last_line(built.stderr)}")
        if not exe.is_file():
            raise CheckFailed(f"the host compiler {cc!r} exited 0 but wrote no program")
        done = _run([str(exe)], RUN_TIMEOUT_S, "the generated self-test")
    last = _last_line(done.stdout)
    if done.returncode != 0:
        first = next((line for line in done.stdout.splitlines() if line.strip()), "")
        detail = f"{last}; first mismatch: {first.strip()[:200]}" if first.strip() != last else last
        raise CheckFailed(f"the generated C fails its own self-test ({detail or f'exit {done.returncode}'}): "
                          "the step cannot meet its tolerance for this airframe's values")
    if not last.startswith("PASS"):
        raise CheckFailed(f"the generated self-test exited 0 without its PASS line (printed {last!r})")
    return SelfTestResult(True, last)
