"""Each collective thrust source a PX4 ULog holds, replayed on its own: the figures of
docs/autopilot-logs.md, *Versions the readers accept*.

    .venv/bin/python tools/thrust_sources.py AIRFRAME.toml LOG.ulg

AIRFRAME must have thrust.source = "collective" (e.g. `dobwind init LOG --mass KG -o AIRFRAME.toml` on a
log without ESC rpm). For every source of dobwind/io/px4layout.py's THRUST_SOURCES that the log has, the
reader is made to take that one alone and the log is replayed (with bridging, as `dobwind replay`). Printed
per source: airborne rows, the mean of thrust / (m g) over them, the RMS and largest difference of the
thrust from the first source's (in % of m g), and the mean horizontal wind over the airborne accepted rows.
"""
from __future__ import annotations

import sys

import numpy as np


def replay_with(af, log: str, source):
    """Replay with the reader restricted to ``source`` (the tuple ulog.collective_source walks)."""
    import dobwind.io.ulog as ulog
    from dobwind.replay.replay import replay_ulog

    kept = ulog.THRUST_SOURCES
    ulog.THRUST_SOURCES = (source,)
    try:
        return replay_ulog(af, log, bridge_gaps=True)
    finally:
        ulog.THRUST_SOURCES = kept


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    from dobwind.io.px4layout import THRUST_SOURCES
    from dobwind.io.ulog import _topic, open_ulog
    from dobwind.model.airframe import load_airframe
    from dobwind.model.status import accepted

    af = load_airframe(argv[0])
    ulog, _ = open_ulog(argv[1])
    present = [s for s in THRUST_SOURCES if _topic(ulog, s.topic, [s.field]) is not None]
    first = None
    for source in present:
        model, flight, traj = replay_with(af, argv[1], source)
        air = ~flight.landed & np.isfinite(flight.log.columns["thrust"])
        ratio = flight.log.columns["thrust"] / (af.mass_kg * af.gravity_mps2)
        t = flight.log.time_s + flight.t0_s  # the log's clock: each source's replay may span other instants
        first = (t[air], ratio[air]) if first is None else first
        inside = air & (t >= first[0][0]) & (t <= first[0][-1])
        diff = 100 * (ratio[inside] - np.interp(t[inside], *first))
        wind = traj.outputs[:, model.outputs.slice("wind_ned")]
        up = air & accepted(traj.status)
        print(f"{source.name}: {int(air.sum())} airborne rows, mean thrust/(m g) {np.mean(ratio[air]):.4f}, "
              f"difference from {present[0].name}: RMS {np.sqrt(np.mean(diff ** 2)):.2f} %, largest "
              f"{np.max(np.abs(diff)):.2f} % of m g; mean horizontal wind {np.mean(np.linalg.norm(wind[up, :2], axis=1)):.2f}"
              f" m/s over {int(up.sum())} accepted airborne rows")
    return 0 if present else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
