"""Replay time of a long PX4 log with slow topics (issue #36: within 1.5x of the replay before the uniform
clock). Writes a synthetic ULog (tests/ulog_writer.py) of ``--minutes`` of hover-and-cruise flight for
the m300 airframe: vehicle_attitude at 100 Hz with 3 % timing jitter, vehicle_local_position at 10 Hz,
esc_status at 4 Hz, vehicle_attitude_setpoint at 10 Hz; then times `dobwind replay` on it with this
interpreter and, with ``--before PYTHON``, another one (an earlier checkout's virtual environment),
interleaved over the rounds so the machine's load falls on both alike. Median wall seconds.

    .venv/bin/python tools/bench_slow_ulog.py --minutes 60 --before /work/main/.venv/bin/python

``--bridge`` instead times replay in this process with and without bridging short silences
(dobwind/io/bridge.py), interleaved, on the same flight with the local position silent for 0.6 s every
30 s (bridged) and for 1.5 s every 5 min (a gap beyond the bound).

    .venv/bin/python tools/bench_slow_ulog.py --minutes 60 --rounds 7 --bridge
"""
from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
AIRFRAME = ROOT / "airframes" / "m300.toml"
ESC_REPORT = {"esc_report": [("int32_t", "esc_rpm"), ("float", "esc_voltage")]}


def _stamps(rate_hz: float, seconds: float, jitter: float, rng: np.random.Generator) -> np.ndarray:
    t = np.arange(0.0, seconds, 1.0 / rate_hz)
    t = t + rng.normal(0.0, jitter / rate_hz, len(t))
    return np.unique(np.round((1.0 + np.clip(t, 0.0, None)) * 1e6).astype(np.int64))


def write_log(path: Path, minutes: float, seed: int = 1, dropouts: bool = False) -> Path:
    sys.path.insert(0, str(ROOT))
    from tests.ulog_writer import Topic, write_ulog

    rng = np.random.default_rng(seed)
    seconds = minutes * 60.0

    def motion(us: np.ndarray) -> tuple[np.ndarray, ...]:
        """North and down velocity and their derivatives (m300 reads acceleration too)."""
        w1, w2 = 2 * np.pi / 60.0, 2 * np.pi / 7.0
        t = us * 1e-6
        return 3.0 * np.sin(w1 * t), 0.2 * np.sin(w2 * t), 3.0 * w1 * np.cos(w1 * t), 0.2 * w2 * np.cos(w2 * t)

    att = _stamps(100.0, seconds, 0.03, rng)
    yaw = 0.3 * np.sin(2 * np.pi * att * 1e-6 / 90.0)
    att_rows = [{"timestamp": int(u), "q[0]": float(np.cos(y / 2)), "q[3]": float(np.sin(y / 2))} for u, y in zip(att, yaw)]
    lp = _stamps(10.0, seconds, 0.03, rng)
    if dropouts:  # silent 0.6 s every 30 s and 1.5 s every 5 min (from 15 s on, where the flight is settled)
        phase = (lp * 1e-6 - 1.0 - 15.0) % 30.0
        long_ = ((lp * 1e-6 - 1.0 - 15.0) % 300.0) < 1.5
        lp = lp[~((phase > 0.0) & (phase < 0.6)) & ~long_]
    vn, vd, an, ad = motion(lp)
    lp_rows = [{"timestamp": int(u), "vx": float(a), "vz": float(b), "ax": float(c), "az": float(d)}
               for u, a, b, c, d in zip(lp, vn, vd, an, ad)]
    esc = _stamps(4.0, seconds, 0.03, rng)
    esc_rows = [{"timestamp": int(u), "esc_count": 4, **{f"esc[{i}].esc_rpm": 4200 + 50 * np.sin(u * 1e-6) for i in range(4)}}
                for u in esc]
    sp = _stamps(10.0, seconds, 0.03, rng)
    sp_rows = [{"timestamp": int(u), "yaw_body": 0.0} for u in sp]
    topics = [
        Topic("vehicle_attitude", [("uint64_t", "timestamp"), ("float[4]", "q")], att_rows),
        Topic("vehicle_local_position", [("uint64_t", "timestamp")] + [("float", f) for f in ("vx", "vy", "vz", "ax", "ay", "az")],
              lp_rows),
        Topic("esc_status", [("uint64_t", "timestamp"), ("uint8_t", "esc_count"), ("esc_report[8]", "esc")], esc_rows),
        Topic("vehicle_attitude_setpoint", [("uint64_t", "timestamp"), ("float", "yaw_body")], sp_rows),
    ]
    return write_ulog(path, topics, None, ESC_REPORT)


def _time(python: str, log: Path) -> float:
    start = time.perf_counter()
    subprocess.run([python, "-P", "-m", "dobwind.cli", "replay", str(AIRFRAME), str(log)], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def _time_bridge(log: Path, rounds: int) -> dict[str, list[float]]:
    """In-process replay seconds with and without bridging, interleaved (the order alternating from round
    to round); also the rows bridged and SETTLING."""
    from dobwind.model.airframe import load_airframe
    from dobwind.replay.replay import replay_ulog

    af = load_airframe(AIRFRAME)
    times: dict[str, list[float]] = {"bridging": [], "no bridging": []}
    for k in range(rounds):
        for label in (list(times) if k % 2 == 0 else list(times)[::-1]):  # alternate who runs first
            start = time.perf_counter()
            _, flight, traj = replay_ulog(af, str(log), bridge_gaps=label == "bridging")
            times[label].append(time.perf_counter() - start)
            bridged = 0 if flight.bridged is None else int(flight.bridged.sum())
            settling = int(((traj.status & (1 << 6)) != 0).sum())
            print(f"{label}: rows {flight.log.rows}, bridged {bridged}, SETTLING {settling}", file=sys.stderr)
    return times


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=60.0)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--work", default="out/bench-slow-ulog")
    ap.add_argument("--before", help="another interpreter to compare with (an earlier checkout's venv)")
    ap.add_argument("--bridge", action="store_true", help="replay with and without bridging, in this process")
    args = ap.parse_args()
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    if args.bridge:
        log = work / f"slow_dropouts_{args.minutes:g}min.ulg"
        if not log.exists():
            write_log(log, args.minutes, dropouts=True)
        times = _time_bridge(log, args.rounds)
        for label, ts in times.items():
            print(f"{label}: median {statistics.median(ts):.2f} s over {len(ts)} runs ({', '.join(f'{t:.2f}' for t in ts)})")
        ratio = statistics.median(times["bridging"]) / statistics.median(times["no bridging"])
        print(f"ratio bridging/no bridging {ratio:.2f} (goal <= 1.5)")
        return 0
    log = work / f"slow_{args.minutes:g}min.ulg"
    if not log.exists():
        write_log(log, args.minutes)
    cases = {"this": sys.executable, **({"before": args.before} if args.before else {})}
    times: dict[str, list[float]] = {k: [] for k in cases}
    for _ in range(args.rounds):
        for label, python in cases.items():
            times[label].append(_time(python, log))
    for label, ts in times.items():
        print(f"{label}: median {statistics.median(ts):.2f} s over {len(ts)} runs ({', '.join(f'{t:.2f}' for t in ts)})")
    if args.before:
        ratio = statistics.median(times["this"]) / statistics.median(times["before"])
        print(f"ratio this/before {ratio:.2f} (goal <= 1.5)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
