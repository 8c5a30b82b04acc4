"""`dobwind simulate SCENARIO -o LOG.csv`: a synthetic flight log with a known wind."""
from __future__ import annotations

import argparse

from dobwind.cli.common import Command
from dobwind.core import options as opt
from dobwind.io.outputs import CSV_TABLE, OutputFiles, Target, check_targets


def add(command: Command) -> None:
    p = command("simulate", "synthesize a flight log with known wind")
    p.add_argument("scenario", help="sweep (the paper's calibration) | vertical (climbs and descents) | tunnel "
                   "(60 deg, 3-10 m/s) | still-air (manoeuvres) | outdoor (turbulent) | box (legs along 4 tracks, out and "
                   "back, in a steady wind: for fit --wind unknown) | one-heading (the same legs along one track, the "
                   "nose never turning)")
    p.add_argument("--airframe", help="airframe TOML (default: the shipped reference airframe m300)")
    p.add_argument("-o", "--output", required=True, help="the flight-log CSV to write (required)")
    p.add_argument("--seed", type=opt.SEED, default=0, help=f"turbulence and timing noise ({opt.SEED.text()})")
    p.add_argument("--hold", type=opt.SIMULATE_HOLD,
                   help=f"seconds per hold ({opt.SIMULATE_HOLD.text()}; default: the scenario's own)")
    p.add_argument("--rate", type=opt.SIMULATE_RATE, help=f"sample rate, Hz ({opt.SIMULATE_RATE.text()}; default: "
                   f"the vehicle file's rate, else 1 / the airframe's observer.sample_time); at most "
                   f"{opt.SIMULATE_MAX_ROWS:,} rows in all")
    p.add_argument("--vehicle", help="the true vehicle's physics and sensors (TOML; default: a vehicle of the "
                   "airframe's size with built-in drag)")
    p.add_argument("--wind", metavar="SPEED@FROM[,UP]", help="the mean wind of a box, one-heading or outdoor flight "
                   "(m/s, degrees it blows from, optional updraft m/s; default: drawn from the seed, which still "
                   "sets the manoeuvres and noise, so one seed at two winds differs in the wind alone)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from dobwind.model.airframe import load_airframe
    from dobwind.simulate.simulate import write_log
    from dobwind.simulate.vehicle import load_vehicle

    target = Target("-o", args.output, refused=CSV_TABLE)
    wind_ned = _wind_ned(args.wind) if args.wind is not None else None
    check_targets([target], [args.airframe] if args.airframe else [])
    af = load_airframe(args.airframe or _default_airframe())
    vehicle = load_vehicle(args.vehicle) if args.vehicle else None
    # The log's rate: --rate, else the vehicle file's sensors, else the rate the airframe's observer expects.
    rate = args.rate or (vehicle.rate_hz if vehicle else 1.0 / af.observer.sample_time_s)
    with OutputFiles([target]) as out:
        rows = write_log(out.stage(args.output), af, args.scenario, args.seed, args.hold, rate, vehicle,
                         args.vehicle, wind_ned=wind_ned)
    print(f"{args.output}: {rows} rows, {rows / rate:.1f} s of '{args.scenario}' at {rate:g} Hz")
    return 0


def _wind_ned(text: str) -> tuple[float, float, float]:
    """`--wind` as `fit` reads a known wind (the same syntax and ranges; 'unknown' is fit's alone), as the
    NED vector the simulator blows."""
    from dobwind.calibrate.fieldtruth import parse_wind

    n, e, d = (float(x) for x in parse_wind(text, unknown_allowed=False).vector())
    return n, e, d


def _default_airframe() -> str:
    from dobwind.core.resources import shipped_airframe

    return str(shipped_airframe())
