"""The profile against a known wind law (issue #35's SITL goal): each bin's mean speed and vector-mean
direction against a power law u(h) = U (min(h, H) / H)^p from a fixed direction, above a minimum height.

    .venv/bin/python -m benchmarks.profilecheck AIRFRAME LOG... [--speed 10] [--height 60]
        [--exponent 0.5] [--from-deg 180] [--min-height 10] [--bin 5] [--min-seconds 10] [--allow FLAG]

The defaults are ArduPilot SITL's wind as the field log arducopter_sitl_wind10_from180.bin was flown
(SIM_WIND_SPD 10, SIM_WIND_DIR 180, SIM_WIND_T 0 with SIM_WIND_T_ALT 60: 10 sqrt(h/60) m/s below 60 m).
Exit 0 when every bin above --min-height is within --max-speed-error and --max-direction-error, else 1.
A bin with less data than --min-seconds has no mean in `dobwind profile` (the same default), so none here:
it is listed and left out of the verdict.
"""
from __future__ import annotations

import argparse
import sys

import numpy as np


def law(height_m: np.ndarray, speed: float, ref_height: float, exponent: float) -> np.ndarray:
    return speed * (np.clip(height_m, 0.0, ref_height) / ref_height) ** exponent


def main(argv: list[str] | None = None) -> int:
    from dobwind.cli.campaign import expand_logs
    from dobwind.atmos.profile import DEFAULT_MIN_SECONDS, allowed_mask, combine, flight_sums, table

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("airframe")
    p.add_argument("logs", nargs="+")
    p.add_argument("--speed", type=float, default=10.0)
    p.add_argument("--height", type=float, default=60.0)
    p.add_argument("--exponent", type=float, default=0.5)
    p.add_argument("--from-deg", type=float, default=180.0)
    p.add_argument("--min-height", type=float, default=10.0)
    p.add_argument("--bin", type=float, default=5.0)
    p.add_argument("--min-seconds", type=float, default=DEFAULT_MIN_SECONDS)
    p.add_argument("--allow", action="append", default=[])
    p.add_argument("--max-speed-error", type=float, default=0.5)
    p.add_argument("--max-direction-error", type=float, default=5.0)
    args = p.parse_args(argv)
    allow = allowed_mask(args.allow)
    parts = [flight_sums(args.airframe, log, args.bin, "python", "single", None, allow)
             for log in expand_logs(args.logs)]
    stats = table(combine([part[0] for part in parts]), args.bin, args.min_seconds)
    if not stats:
        sys.stderr.write("no trusted estimate with a height (see --allow)\n")
        return 1
    above = (stats["height_bottom_m"] >= args.min_height) & ~stats["below_minimum"]
    expected = law(stats["height_m"], args.speed, args.height, args.exponent)
    speed_error = stats["speed_mean_mps"] - expected
    direction_error = (stats["direction_from_deg"] - args.from_deg + 180.0) % 360.0 - 180.0
    print("height m    n  time s  speed  SE     law    error  from deg  error")
    for k in np.flatnonzero(stats["count"] > 0):
        mark = "" if above[k] else ("  (under --min-seconds: no mean)" if stats["below_minimum"][k]
                                    else "  (below --min-height)")
        print(f"{stats['height_m'][k]:6.1f}  {stats['count'][k]:5d}  {stats['seconds'][k]:6.1f}  "
              f"{stats['speed_mean_mps'][k]:5.2f}  {stats['speed_se_mps'][k]:5.2f}  "
              f"{expected[k]:5.2f}  {speed_error[k]:+5.2f}  {stats['direction_from_deg'][k]:8.1f}  "
              f"{direction_error[k]:+5.1f}{mark}")
    worst_speed = float(np.max(np.abs(speed_error[above]))) if above.any() else float("nan")
    worst_direction = float(np.max(np.abs(direction_error[above]))) if above.any() else float("nan")
    passed = above.any() and worst_speed <= args.max_speed_error and worst_direction <= args.max_direction_error
    print(f"bins above {args.min_height:g} m: worst speed error {worst_speed:.2f} m/s (goal {args.max_speed_error:g}), "
          f"worst direction error {worst_direction:.1f} deg (goal {args.max_direction_error:g}): "
          f"{'PASS' if passed else 'FAIL'}")
    return 0 if passed else 1


if __name__ == "__main__":
    raise SystemExit(main())
