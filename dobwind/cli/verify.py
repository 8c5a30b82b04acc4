"""`dobwind verify AIRFRAME`: generate, compile strictly and compare the C with the Python reference;
exit 1 when they disagree."""
from __future__ import annotations

import argparse
from pathlib import Path

from dobwind.cli.common import AIRFRAME_HELP, JSON_HELP, Command, print_json
from dobwind.core import options as opt
from dobwind.core.errors import EXIT_CHECK_FAILED, InputError
from dobwind.model.kinds import PRECISIONS, Precision


def add(command: Command) -> None:
    p = command("verify", "generate, compile strictly, compare with the Python reference")
    p.add_argument("airframe", help=AIRFRAME_HELP)
    p.add_argument("--precision", choices=(*PRECISIONS, "both"), default="both",
                   help="which generated C to build and compare")
    p.add_argument("--steps", type=opt.VERIFY_STEPS, default=20000,
                   help=f"length of the simulated flight compared step by step ({opt.VERIFY_STEPS.text()})")
    p.add_argument("--seed", type=opt.SEED, default=1, help=f"random seed of the flight and of the random cases "
                   f"({opt.SEED.text()})")
    p.add_argument("--c-dir", help="verify the generated C in this folder as it is (e.g. generated_c/m300) "
                   "instead of freshly generated C; its precision is read from its header (default: none)")
    p.add_argument("--flags", choices=("px4", "ardupilot"), help="also build with that autopilot's own compile "
                   "flags (gcc, clang, arm-none-eabi-gcc; C and C++, -Werror), and build the self-test and the "
                   "library compared with the reference with them; ardupilot: single precision only "
                   "(default: none)")
    p.add_argument("--json", action="store_true", help=JSON_HELP)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from dobwind.codegen.generate import refuse_ill_conditioned_terms
    from dobwind.harness.verify import verify_airframe
    from dobwind.model.airframe import load_airframe

    af = load_airframe(args.airframe)
    if args.c_dir is None and args.precision in (Precision.SINGLE, "both"):
        refuse_ill_conditioned_terms(af, args.airframe)  # generate refuses them: nothing to verify
    try:
        report = verify_airframe(af, args.precision, steps=args.steps, seed=args.seed,
                                 c_dir=None if args.c_dir is None else Path(args.c_dir), flags=args.flags)
    except InputError as exc:
        if exc.source != af.name:
            raise
        raise InputError(args.airframe, exc.where, exc.message) from None  # name the file, not the airframe
    if args.json:
        print_json(report.as_dict())
    else:
        print(report.text())
    return 0 if report.passed else EXIT_CHECK_FAILED
