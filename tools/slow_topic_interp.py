"""Which interpolant of a 10 Hz velocity gives the observer the force it would get from 50 Hz velocity
(docs/field-logs.md, slow topics). `.venv/bin/python tools/slow_topic_interp.py` (from the checkout):
the wind of nf_quad over two simulated outdoor flights with velocity decimated to 10 Hz and interpolated back to 50 Hz, against the
same flight at 50 Hz (RMS and mean difference) and against the true wind."""
from __future__ import annotations

import numpy as np
from scipy.interpolate import PchipInterpolator, CubicSpline, Akima1DInterpolator
from dobwind.model.airframe import load_airframe
from dobwind.simulate.simulate import simulate
from dobwind.model.step import build_step
from dobwind.replay.backends import run_backend
from dobwind.io.logs import FlightLog, step_inputs


def main() -> None:
    af = load_airframe("airframes/nf_quad.toml")
    model = build_step(af)
    for seed in (1, 2):
        cols = simulate(af, "outdoor", seed=seed, hold_s=8.0, rate_hz=50.0)
        t = cols["t"]
        def run(c):
            traj = run_backend(model, step_inputs(model, FlightLog("x", c)), "python", "double")
            return traj.outputs[:, model.outputs.slice("wind_ned")]
        ref = run(cols)
        truth = np.column_stack([cols[k] for k in ("wind_n", "wind_e", "wind_d")])
        ts = t[::5]  # 10 Hz velocity
        for name, f in (("linear", lambda x, y: np.interp(t, x, y)), ("pchip", lambda x, y: PchipInterpolator(x, y)(t)),
                        ("cubic", lambda x, y: CubicSpline(x, y)(t)), ("akima", lambda x, y: Akima1DInterpolator(x, y)(t)),
                        ("hold", lambda x, y: y[np.clip(np.searchsorted(x, t, side="right") - 1, 0, None)])):
            c = dict(cols)
            for k in ("vel_n", "vel_e", "vel_d"):
                c[k] = f(ts, cols[k][::5])
            w = run(c)
            s = slice(500, None)
            d = w[s] - ref[s]
            e = w[s] - truth[s]
            print(seed, f"{name:7s} vs 50Hz rms h {np.sqrt(np.mean(d[:, :2]**2)):.3f} v {np.sqrt(np.mean(d[:, 2]**2)):.3f} mean {np.abs(d.mean(0)).round(3)}  vs truth rms h {np.sqrt(np.mean(e[:, :2]**2)):.3f}")
        e = ref[500:] - truth[500:]
        print(seed, f"50Hz    vs truth rms h {np.sqrt(np.mean(e[:, :2]**2)):.3f}")


if __name__ == "__main__":
    main()
