"""Figures of merit for SISO discrete systems: bandwidth, gain and phase, settling, delay, noise.

python-control's bandwidth() raises on first-order discrete low-passes (0.10.2), so the -3 dB point
is found here directly: a scan of |H(e^{j w dt})| on a log grid, refined by Brent's method.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import control as ct
import numpy as np
import scipy.linalg
import scipy.signal
import scipy.optimize


def response(sys: ct.LTI, freq_hz: np.ndarray) -> np.ndarray:
    """Complex frequency response at the given frequencies (Hz)."""
    freq_hz = np.atleast_1d(np.asarray(freq_hz, dtype=float))
    s = 2j * np.pi * freq_hz
    z = np.exp(s * sys.dt) if sys.isdtime() else s
    if isinstance(sys, ct.StateSpace) and sys.nstates > 1 and sys.ninputs == 1 and sys.noutputs == 1:
        try:
            return _state_space_response(sys, z)
        except np.linalg.LinAlgError:
            pass  # a frequency on a pole: python-control's own evaluation says how (inf or nan)
    return np.atleast_1d(np.squeeze(np.asarray(sys(z), dtype=complex)))


def _state_space_response(sys: ct.StateSpace, z: np.ndarray) -> np.ndarray:
    """C (zI - A)^-1 B + D at every z in one stacked solve: python-control 0.10 solves frequency by
    frequency in Python (without Slycot), and the bandwidth scans' 2,000-point grids made that most of
    `analyze` and of `init`'s gain design. The same operations per frequency, so the same values."""
    n = sys.nstates
    shifted = z[:, None, None] * np.eye(n) - sys.A
    solved = np.linalg.solve(shifted, np.broadcast_to(np.asarray(sys.B, dtype=complex), (len(z), n, 1)))
    return (sys.C @ solved + sys.D)[:, 0, 0]


def dc_gain(sys: ct.LTI) -> float:
    return float(np.real(np.squeeze(sys.dcgain())))


def bandwidth_hz(sys: ct.LTI) -> float:
    """First frequency where |H| falls to |H(0)| / sqrt(2); inf if it never does (below Nyquist)."""
    target = abs(dc_gain(sys)) / math.sqrt(2)
    top = 0.5 / sys.dt if sys.isdtime() else 1e4
    grid = np.geomspace(top * 1e-7, top * (1 - 1e-9), 2000)
    mags = np.abs(response(sys, grid))
    below = np.flatnonzero(mags < target)
    if below.size == 0:
        return math.inf
    i = below[0]
    if i == 0:
        return float(grid[0])
    return float(scipy.optimize.brentq(lambda f: abs(response(sys, np.array([f]))[0]) - target,
                                       grid[i - 1], grid[i], xtol=1e-12, rtol=1e-12))


def gain_phase(sys: ct.LTI, freq_hz: float) -> tuple[float, float]:
    """(gain in dB, phase in degrees) at one frequency."""
    h = response(sys, np.array([freq_hz]))[0]
    return 20 * math.log10(abs(h)), math.degrees(math.atan2(h.imag, h.real))


def group_delay_s(sys: ct.LTI, freq_hz: float | None = None) -> float:
    """-d(phase)/d(omega) near zero frequency (default: 1e-4 of Nyquist)."""
    f0 = freq_hz if freq_hz is not None else (0.5 / sys.dt) * 1e-4 if sys.isdtime() else 1e-4
    h = response(sys, np.array([f0 * 0.5, f0 * 1.5]))
    phase = np.unwrap(np.angle(h))
    return float(-(phase[1] - phase[0]) / (2 * math.pi * f0))


# Longest step response simulated for a settling time: a design slower than this (17 min at 100 Hz)
# is not flown, and its figure is then a lower bound (as in model/settling.py).
MAX_SETTLING_SAMPLES = 100_000


def settling_time_s(sys: ct.LTI, threshold: float = 0.02) -> float:
    if not sys.isdtime():
        return float(ct.step_info(sys, SettlingTimeThreshold=threshold)["SettlingTime"])
    # python-control picks the horizon from the poles' time constants and, for a pole within ~1e-5
    # of 1, stops before the response reaches 10 %: its rise-time search then raises IndexError.
    # Twenty of the slowest time constant is past any 2 % crossing of these low-order systems.
    slowest = max((abs(complex(p)) for p in sys.poles()), default=0.0)
    if slowest >= 1.0:
        return math.inf
    n = min(int(math.ceil(20.0 / max(1.0 - slowest, 1e-12))) + 2, MAX_SETTLING_SAMPLES)
    times = np.arange(n) * sys.dt
    try:
        # The step response by lfilter, not python-control's per-sample Python loop (30 s of
        # `analyze m300` went there: issue #33's figures); the same settling times.
        return float(ct.step_info(_step_response(sys, n), T=times, SettlingTimeThreshold=threshold,
                                  yfinal=dc_gain(sys))["SettlingTime"])
    except IndexError:  # not even at 10 % within the cap: settling takes longer than the horizon
        return float(times[-1])


def _step_response(sys: ct.LTI, n: int) -> np.ndarray:
    """y(k), k < n, of the discrete SISO state-space system to a unit step from rest (x(0) = 0), as
    python-control's step_response gives it: the transfer function's difference equation (lfilter, in
    C). These systems have a few states, poles well apart, so the polynomial form is well conditioned."""
    num, den = scipy.signal.ss2tf(*(np.asarray(m, dtype=float) for m in (sys.A, sys.B, sys.C, sys.D)))
    return scipy.signal.lfilter(num[0], den, np.ones(n))


def _reachable(a: np.ndarray, b: np.ndarray) -> list[int]:
    """Indices of the states an input reaches, directly or through A (graph closure on the nonzeros)."""
    reached = set(np.flatnonzero(np.any(b != 0, axis=1)).tolist())
    frontier = list(reached)
    while frontier:
        i = frontier.pop()
        for j in np.flatnonzero(a[:, i] != 0).tolist():
            if j not in reached:
                reached.add(j)
                frontier.append(j)
    return sorted(reached)


def noise_gain(sys: ct.LTI) -> float:
    """RMS of the output per unit RMS of white input noise (one independent sample per step)."""
    a, b, c, d = (np.asarray(m, dtype=float) for m in (sys.A, sys.B, sys.C, sys.D))
    # Only the states the noise reaches carry its variance. An unreached one (a held previous sample,
    # zero in the linearization) can couple with a gain like 2e6 into the rest and make the Lyapunov
    # system ill-conditioned (scipy's LinAlgWarning) without changing the result, so it is dropped.
    keep = _reachable(a, b)
    a, b, c = a[np.ix_(keep, keep)], b[keep], c[:, keep]
    if a.size == 0:
        return float(abs(d[0, 0]))
    p = scipy.linalg.solve_discrete_lyapunov(a, b @ b.T)
    return float(math.sqrt(float((c @ p @ c.T + d @ d.T)[0, 0])))


def poles(sys: ct.LTI) -> np.ndarray:
    return np.asarray(sys.poles())


@dataclass(frozen=True)
class Figures:
    poles: tuple[complex, ...]
    stable: bool
    bandwidth_hz: float
    gain_phase: tuple[tuple[float, float, float], ...]  # (Hz, dB, deg)
    settling_time_s: float
    group_delay_s: float

    def as_dict(self) -> dict:
        return {
            "poles": [[p.real, p.imag] if abs(p.imag) > 0 else p.real for p in self.poles],
            "stable": self.stable,
            "bandwidth_hz": None if math.isinf(self.bandwidth_hz) else self.bandwidth_hz,
            "gain_phase": [{"freq_hz": f, "gain_db": g, "phase_deg": p} for f, g, p in self.gain_phase],
            "settling_time_s": self.settling_time_s,
            "group_delay_s": self.group_delay_s,
        }


def figures(sys: ct.LTI, freqs_hz: list[float]) -> Figures:
    ps = poles(sys)
    stable = bool(np.all(np.abs(ps) < 1.0)) if sys.isdtime() else bool(np.all(np.real(ps) < 0))
    return Figures(
        poles=tuple(complex(p) for p in ps),
        stable=stable,
        bandwidth_hz=bandwidth_hz(sys) if stable else math.nan,
        gain_phase=tuple((f, *gain_phase(sys, f)) for f in freqs_hz),
        settling_time_s=settling_time_s(sys) if stable else math.inf,
        group_delay_s=group_delay_s(sys) if stable else math.nan,
    )
