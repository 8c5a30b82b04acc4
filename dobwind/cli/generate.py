"""`dobwind generate AIRFRAME`: the C for an airframe (and an autopilot's integration), written only
after the stability gate and, unless --no-selftest, after its compiled self-test passed."""
from __future__ import annotations

import argparse
import sys
from functools import partial
from pathlib import Path
from typing import Any

from dobwind.model.kinds import PRECISIONS, Precision
from dobwind.cli.common import AIRFRAME_HELP, Command
from dobwind.io.outputs import Target, check_replaceable, check_targets


def add(command: Command) -> None:
    p = command("generate", "emit C for an airframe")
    p.add_argument("airframe", help=AIRFRAME_HELP)
    p.add_argument("-o", "--output", help="output folder (default: generated_c/<name>/ in the working directory)")
    p.add_argument("--precision", choices=PRECISIONS, default=Precision.SINGLE,
                   help="floating-point type of the generated C: float (single) or double")
    p.add_argument("--target", choices=("px4", "ardupilot"), help="also write that autopilot's integration "
                   "beside the C: px4/ (a PX4 work-queue module, its .msg and parameter) or AP_DOBWind/ (an "
                   "ArduPilot library with its DataFlash message); single precision (default: the C only)")
    p.add_argument("--no-selftest", action="store_true",
                   help="skip the final gate: by default the generated C and its self-test are compiled with the "
                   "host compiler ($CC, default cc) and run, and C that fails its golden vectors is refused "
                   "(exit 1, nothing written); without a host compiler generate warns on stderr and still writes")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from dobwind.model.stability import require_stable
    from dobwind.codegen.generate import is_generated_name
    from dobwind.generate.emit import generate_to_dir
    from dobwind.model.airframe import load_airframe
    from dobwind.model.signals import log_signals

    if args.output is not None:
        check_targets([Target("-o", args.output, "dir")], [args.airframe])
    af = load_airframe(args.airframe)
    require_stable(af, "refusing to generate code", args.airframe)  # the same gate as `check`
    out_dir = args.output if args.output is not None else f"generated_c/{af.name}"
    target = Target("-o", out_dir, "dir")
    check_targets([target], [args.airframe])
    check_replaceable(target, is_generated_name)
    gate = None if args.no_selftest else partial(selftest_gate, af.name)
    files = generate_to_dir(af, out_dir, args.precision, source=args.airframe, integration=args.target,
                            gate=gate)
    for path in files:
        print(path)
    warn_law_scale(af, args.airframe, "generate")
    if args.target == "px4" and log_signals(af).rotor_speeds and af.thrust.rotors > PX4_ESC_REPORTS:
        sys.stderr.write(f"dobwind generate: warning: {args.airframe}: thrust.rotors = {af.thrust.rotors}, but PX4's "
                         f"esc_status holds {PX4_ESC_REPORTS} ESC reports (EscStatus.msg CONNECTED_ESC_MAX): the "
                         "module's static_assert stops its build against that message\n")
    return 0


# EscStatus.msg's CONNECTED_ESC_MAX: the ESC reports one esc_status message holds (PX4 msg/EscStatus.msg).
PX4_ESC_REPORTS = 8


def warn_law_scale(af: Any, source: str, command: str, speed: Any = None) -> None:
    """One stderr line when the force-air law reads an absurd airflow at a small force, and one when a drag
    law stops increasing inside its vehicle's envelope (model/lawscale.py):
    a warning, since the step flags such winds EXTRAPOLATED when flown; the airframe is still written.
    ``speed``: the law's reading (airflow_at_share) when the caller already has it."""
    from dobwind.model.lawscale import law_fold_problem, law_scale_problem

    for problem in (law_scale_problem(af, speed=speed), law_fold_problem(af)):
        if problem is not None:
            sys.stderr.write(f"dobwind {command}: warning: {source}: {problem}\n")


def selftest_gate(name: str, folder: Path, command: str = "generate") -> None:
    """generate's last gate (also `check`'s): the C in ``folder`` compiled and run against its golden vectors."""
    from dobwind.harness.build import system_compiler
    from dobwind.generate.selftest_gate import run_selftest

    result = run_selftest(folder, name, system_compiler())
    if not result.ran:
        sys.stderr.write(f"dobwind {command}: warning: {result.summary}\n")
