"""Replay and fit figures (matplotlib Agg)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def save(fig, path: str | Path) -> None:
    """PNG through a temporary (removed on any failure), whatever the name's extension."""
    from dobwind.atomic import write_file_atomically

    try:
        write_file_atomically(path, lambda tmp: fig.savefig(tmp, dpi=100, format="png"))
    finally:
        plt.close(fig)


def replay_plot(t: np.ndarray, wind: np.ndarray, truth: np.ndarray | None, title: str, path: str,
                others: list[tuple[str, np.ndarray, np.ndarray]] = ()) -> None:
    """Speed, direction (from) and vertical wind (up) over time; truth and other estimates if given.
    ``others``: (label, time, wind NED) for other estimators."""
    fig, axes = plt.subplots(3, 1, sharex=True, figsize=(10, 8))
    series = [("dobwind", t, wind)] + list(others)
    if truth is not None:
        series = [("true wind", t, truth)] + series
    for label, tt, w in series:
        style = {"color": "black", "lw": 1.0} if label == "true wind" else {"lw": 1.0}
        axes[0].plot(tt, np.hypot(w[:, 0], w[:, 1]), label=label, **style)
        axes[1].plot(tt, np.degrees(np.arctan2(-w[:, 1], -w[:, 0])) % 360, ".", ms=1.5, label=label,
                     **({"color": "black"} if label == "true wind" else {}))
        axes[2].plot(tt, -w[:, 2], label=label, **style)
    axes[0].set_ylabel("horizontal speed (m/s)")
    axes[1].set_ylabel("from (deg)")
    axes[1].set_ylim(0, 360)
    axes[2].set_ylabel("vertical, up (m/s)")
    axes[2].set_xlabel("time (s)")
    axes[0].set_title(title)
    for ax in axes:
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    save(fig, path)
