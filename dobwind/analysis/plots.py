"""PNG figures for `dobwind analyze -o DIR` (matplotlib, Agg: no display needed)."""
from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from dobwind.analysis.figures import bandwidth_hz, response  # noqa: E402
from dobwind.analysis.ramp import RampResult  # noqa: E402
from dobwind.io.atomic import write_file_atomically  # noqa: E402

PAPER_BANDWIDTH_HZ = 0.5
# Colour AND dash per line: euler and zoh nearly coincide, and only the dash tells them apart.
LINE_STYLES = (("#0072B2", "-"), ("#D55E00", "--"), ("#009E73", ":"), ("#CC79A7", "-."), ("#E69F00", (0, (5, 2, 1, 2))),
               ("#56B4E9", (0, (1, 1))), ("black", (0, (8, 3))))


def _save(fig, path: Path) -> Path:
    try:
        write_file_atomically(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))
    finally:
        plt.close(fig)
    return path


def bode(systems: list[tuple[str, object]], title: str, path: Path) -> Path:
    """Magnitude (dB) and phase (deg) against frequency (Hz), -3 dB points marked, 0.5 Hz line."""
    fig, (mag_ax, ph_ax) = plt.subplots(2, 1, sharex=True, figsize=(8.5, 7))
    nyquist = min(0.5 / sys.dt for _, sys in systems if sys.isdtime())
    freq = np.geomspace(0.005, nyquist * 0.999, 800)
    for i, (label, sys) in enumerate(systems):
        h = response(sys, freq)
        colour, dash = LINE_STYLES[i % len(LINE_STYLES)]
        width = 2.2 - 0.25 * min(i, 4)  # earlier lines wider, so a later one that coincides stays visible on top
        line, = mag_ax.semilogx(freq, 20 * np.log10(np.abs(h)), label=label, color=colour, ls=dash, lw=width)
        ph_ax.semilogx(freq, np.degrees(np.unwrap(np.angle(h))), color=colour, ls=dash, lw=width)
        bw = bandwidth_hz(sys)
        if math.isfinite(bw):
            mag_ax.plot([bw], [20 * math.log10(abs(response(sys, np.array([bw]))[0]))], "o", color=line.get_color())
    mag_ax.axhline(-3.0, color="grey", lw=0.8, ls=":")
    mag_ax.text(freq[0] * 1.1, -2.5, "-3 dB", color="grey", fontsize=8)
    for ax in (mag_ax, ph_ax):
        ax.axvline(PAPER_BANDWIDTH_HZ, color="black", lw=0.8, ls="--")
        ax.grid(True, which="both", alpha=0.3)
    mag_ax.text(PAPER_BANDWIDTH_HZ * 1.05, -38, "0.5 Hz (paper)", fontsize=8)
    mag_ax.set_ylim(-40, 5)
    mag_ax.set_ylabel("gain (dB)")
    ph_ax.set_ylabel("phase (deg)")
    ph_ax.set_xlabel("frequency (Hz)")
    mag_ax.set_xlabel("frequency (Hz)")
    mag_ax.tick_params(labelbottom=True)  # sharex hides the upper panel's tick labels; each panel names its axis
    mag_ax.set_title(title + "  (dots: -3 dB points)")
    mag_ax.legend(fontsize=8, loc="lower left")
    fig.tight_layout()
    return _save(fig, path)


def ramp(result: RampResult, path: Path, airframe: str = "") -> Path:
    fig, ax = plt.subplots(figsize=(8.5, 4.5))
    ax.plot(result.time_s, result.truth_mps, "k", lw=1.2, label="true wind")
    ax.plot(result.time_s, result.scheduled_mps, color="#0072B2", lw=1.6,
            label=f"scheduled low-pass (lag {result.scheduled_lag_s:.2f} s)")
    ax.plot(result.time_s, result.fixed_mps, color="#D55E00", ls="--", lw=1.6,
            label=f"fixed {result.fixed_cutoff_hz:g} Hz low-pass (lag {result.fixed_lag_s:.2f} s)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("horizontal wind speed (m/s)")
    prefix = f"{airframe}: " if airframe else ""
    ax.set_title(f"{prefix}wind ramp to 10 m/s; the scheduled cutoff cuts the lag by {result.lag_reduction_s:.2f} s")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="lower right")
    fig.tight_layout()
    return _save(fig, path)


def wind_units(block: dict, path: Path, airframe: str = "") -> Path:
    """The wind-unit view over airspeed: the law's slope, the wind noise along and across the airflow,
    and the ramp lag, each at the airspeeds asked (breakpoints marked)."""
    points = sorted(block["airspeeds"], key=lambda p: p["airspeed_mps"])
    speed = np.array([p["airspeed_mps"] for p in points])
    fig, (slope_ax, noise_ax, lag_ax) = plt.subplots(3, 1, sharex=True, figsize=(8.5, 8))
    slope_ax.semilogy(speed, [p["slope_along_mps_per_n"] for p in points], color="#0072B2", marker="o")
    slope_ax.set_ylabel("slope (m/s per N)")
    if points and points[0]["wind_noise_along_mps"] is not None:
        noise_ax.plot(speed, [p["wind_noise_along_mps"] for p in points], color="#0072B2", marker="o", label="along")
        noise_ax.plot(speed, [p["wind_noise_across_mps"] for p in points], color="#D55E00", ls="--", marker="s",
                      label="across")
        noise_ax.legend(loc="upper right")
    noise_ax.set_ylabel("wind noise, 1 sigma (m/s)")
    lag_ax.plot(speed, [p["ramp_lag_s"] for p in points], color="#009E73", marker="o")
    lag_ax.set_ylabel("ramp lag (s)")
    lag_ax.set_xlabel("airspeed (m/s)")
    for ax in (slope_ax, noise_ax, lag_ax):
        ax.grid(True, alpha=0.3)
        for b in block["breakpoints"]:
            ax.axvline(b["airspeed_mps"], color="grey", lw=0.8, ls=":")
    prefix = f"{airframe}: " if airframe else ""
    slope_ax.set_title(f"{prefix}in wind units (dotted: schedule breakpoints; noise from {block['noise_source']})",
                       fontsize=9)
    fig.tight_layout()
    return _save(fig, path)
