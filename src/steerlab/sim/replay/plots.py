"""The plot of a replay: every checkpoint's lateral offset from the human's path along the route."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from steerlab.figures import COLORS, figure
from steerlab.sim.core.driving import Trajectory


def plot_offsets(path: Path, trajs: dict[str, Trajectory], limit_m: float, title: str,
                 limit_label: str = "intervention limit") -> None:
    """The lateral offset of every checkpoint along the route (km driven), interventions marked, and the offset
    limit (+-`limit_m`, named in the legend by `limit_label`)."""
    with figure(path, figsize=(12, 4)) as (fig, ax):
        for (label, t), color in zip(trajs.items(), COLORS * 5):
            dt = np.diff(t.time_s, prepend=t.time_s[0])
            km = np.cumsum(np.where(dt > 0, dt, 0) * t.speed) / 1000
            hits = t.intervention > 0
            ax.plot(km, t.offset, color=color, lw=0.8, label=f"{label} ({int(hits.sum())} interventions)")
            pre = np.flatnonzero(hits) - 1  # where the car was just before it was put back
            ax.plot(km[hits], t.offset[np.clip(pre, 0, None)], "x", color=color, ms=7)
        for d in (-limit_m, limit_m):
            label = f"{limit_label} (+-{limit_m:.2g} m)" if d > 0 else None
            ax.axhline(d, color="tab:red", ls=":", lw=0.8, label=label)
        ax.set_xlabel("distance along the route [km]")
        ax.set_ylabel("offset from the human's path [m] (left +)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        ax.set_title(title)
