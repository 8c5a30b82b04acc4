"""The profile figure: speed and direction against height with their spreads as error bars, the
vertical wind, and wind barbs of the vector-mean wind per bin (matplotlib Agg)."""
from __future__ import annotations

import numpy as np

from dobwind.io.plots import STYLES, plt, save

# Barb increments in m/s (half barb, full barb, flag): a barb shows the speed to 2.5 m/s.
BARBS_MPS = {"half": 2.5, "full": 5.0, "flag": 25.0}


def profile_plot(stats: dict[str, np.ndarray], title: str, path: str) -> None:
    h = stats["height_m"]
    has = stats["count"] > 0
    fig, axes = plt.subplots(1, 4, figsize=(13, 5.5), sharey=True, gridspec_kw={"width_ratios": [3, 3, 2, 1]})
    colour = STYLES[1][0]
    err = dict(fmt="o-", color=colour, ecolor=colour, elinewidth=1, capsize=3, markersize=4)
    axes[0].errorbar(stats["speed_mean_mps"][has], h[has], xerr=stats["speed_std_mps"][has], **err)
    axes[0].set_xlabel("horizontal wind speed, m/s (bar: spread)")
    axes[0].set_xlim(left=0)
    axes[0].set_ylabel("height above take-off, m")
    axes[1].errorbar(stats["direction_from_deg"][has], h[has], xerr=stats["direction_spread_deg"][has], **err)
    axes[1].set_xlabel("wind from, deg (vector mean; bar: spread)")
    axes[1].set_xlim(0, 360)
    axes[1].set_xticks([0, 90, 180, 270, 360])
    axes[2].errorbar(stats["up_mean_mps"][has], h[has], xerr=stats["up_std_mps"][has], **err)
    axes[2].axvline(0.0, color="0.6", linewidth=0.8)
    axes[2].set_xlabel("vertical wind, m/s (up)")
    # Barbs point into the wind, as on a weather map: u, v are the wind's own east and north components.
    axes[3].barbs(np.zeros(int(has.sum())), h[has], stats["eastward_mean_mps"][has], stats["northward_mean_mps"][has],
                  barb_increments=BARBS_MPS, length=6)
    axes[3].set_xlim(-1, 1)
    axes[3].set_xticks([])
    axes[3].set_xlabel("barbs\n(half 2.5, full 5 m/s)")
    for ax in axes:
        ax.grid(True, alpha=0.3)
    counts = stats["count"][has]
    fig.suptitle(f"{title}\n{int(counts.sum())} estimates in {int(has.sum())} bins")
    fig.tight_layout()
    save(fig, path)
