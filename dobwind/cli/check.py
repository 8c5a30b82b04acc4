"""`dobwind check AIRFRAME`: load and validate an airframe, refuse what `generate` would refuse,
and summarise its estimator (inputs, state size, step cost)."""
from __future__ import annotations

import argparse
import math
from typing import Any

from dobwind.cli.common import AIRFRAME_HELP, JSON_HELP, Command, print_json
from dobwind.model.kinds import Precision


def add(command: Command) -> None:
    p = command("check", "validate an airframe file and summarise its estimator")
    p.add_argument("airframe", help=AIRFRAME_HELP)
    p.add_argument("--json", action="store_true", help=JSON_HELP)
    p.add_argument("--no-selftest", action="store_true",
                   help="skip generate's last gate: by default the C is rendered in both precisions, compiled with "
                   "the host compiler ($CC, default cc) with its self-test and run, and an airframe whose C fails its "
                   "golden vectors is refused (exit 1), as generate would refuse it")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from dobwind.model.stability import require_stable
    from dobwind.model.airframe import load_airframe
    from dobwind.model.step import build_step
    from dobwind.cli.generate import warn_law_scale
    from dobwind.model.lawscale import airflow_at_share

    af = load_airframe(args.airframe)
    require_stable(af, "generate would refuse it", args.airframe)
    model = build_step(af)
    _refuse_what_generate_refuses(af, model, args.airframe, selftest=not args.no_selftest)
    law_speed = airflow_at_share(af)
    warn_law_scale(af, args.airframe, "check", law_speed)
    summary = {
        "name": af.name,
        "mass_kg": af.mass_kg,
        "thrust": af.thrust.source,
        "discretization": af.observer.discretization,
        "acceleration": af.observer.acceleration,
        "calibration": af.calibration,  # "prior": every accepted sample carries UNCALIBRATED
        "inputs": list(model.inputs.element_names()),
        "state_size": model.state.size,
        "step_instructions": model.step.n_instructions(),
        # model/lawscale.py: the fastest airflow the law reads at a tenth of the weight (m/s)
        "law_airflow_at_tenth_weight_mps": _finite_or_none(float(law_speed.max())),
    }
    if args.json:
        print_json(summary)
    else:
        for key, value in summary.items():
            print(f"{key:18s} {value}")
    return 0


def _finite_or_none(value: float) -> float | None:
    return round(value, 3) if math.isfinite(value) else None  # JSON has no NaN or infinity


def _refuse_what_generate_refuses(af: Any, model: Any, source: str, selftest: bool = True) -> None:
    """Renders the C in both precisions and discards it: every static refusal of `generate` (a constant
    that rounds to 0 in a float, an ill-conditioned term) then stops `check` too, with the same line.
    With ``selftest`` the rendered C also goes through generate's last gate (compiled and run against its
    golden vectors), so `check` never accepts an airframe that `generate` would then refuse."""
    import tempfile
    from pathlib import Path

    from dobwind.cli.generate import selftest_gate
    from dobwind.codegen.generate import generate_code, write_files

    for precision in (Precision.SINGLE, Precision.DOUBLE):
        code = generate_code(af, precision, model, source=source)
        if not selftest:
            continue
        with tempfile.TemporaryDirectory(prefix="dobwind-check-") as work:
            write_files(code.files, work)
            selftest_gate(af.name, Path(work), "check")
