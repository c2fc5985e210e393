"""The plots of a replay: every checkpoint's lateral offset from the human's path along the route (`plot_offsets`),
and the human's path as replay rebuilt it, seen from above, with where each checkpoint was put back (`plot_paths`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from steerlab.data.path import HumanPath
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


def path_summary(path: HumanPath) -> dict:
    """A rebuilt path in numbers: its length (m), how far it turned in all (degrees, left +) and the box it lies
    in (m): a track driven lap after lap turns 360 degrees a lap within the track's own box."""
    return {"m": float(path.s[-1]), "turned_deg": float(np.degrees(path.psi[-1] - path.psi[0])),
            "box_m": [float(np.ptp(path.x)), float(np.ptp(path.y))]}


GAP_M = 2.0  # between two segments' paths, side by side


def plot_paths(path: Path, paths: list[HumanPath], trajs: dict[str, Trajectory], title: str) -> None:
    """The human's path of every replayed segment as replay rebuilt it from the recorded steering and speed, seen
    from above (each segment from its own start, side by side, left to right), and where each checkpoint's car
    was when it was put back (its trajectory's pose before the intervention)."""
    with figure(path, figsize=(8, 6)) as (fig, ax):
        shifts, shift = [], 0.0
        for n, p in enumerate(paths):
            shifts.append(shift - p.x.min())
            one = path_summary(p)
            ax.plot(p.x + shifts[-1], p.y, color="0.3", lw=0.6, label=f"segment {n}: {one['m']:.0f} m, turned "
                    f"{one['turned_deg']:+.0f} deg, {one['box_m'][0]:.1f} x {one['box_m'][1]:.1f} m")
            ax.plot(p.x[0] + shifts[-1], p.y[0], "o", color="0.3", ms=4)
            ax.annotate(str(n), (p.x[0] + shifts[-1], p.y[0]), xytext=(4, 4), textcoords="offset points", fontsize=8)
            shift += np.ptp(p.x) + GAP_M
        for (label, t), color in zip(trajs.items(), COLORS * 5):
            pre = np.clip(np.flatnonzero(t.intervention > 0) - 1, 0, None)  # where the car was just before
            ax.plot(t.x[pre] + np.asarray(shifts)[t.segment[pre]], t.y[pre], "x", color=color, ms=6,
                    label=f"{label}: put back")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x [m] (each segment from its start, the dot with its number)")
        ax.set_ylabel("y [m]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
        ax.set_title(f"{title}: the human's path, rebuilt from the recorded steering and speed")
