"""Plots of closed-loop drives."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from steerlab.figures import COLORS, figure
from steerlab.sim.driving import Trajectory
from steerlab.sim.road import EDGE, LANE_CENTER


def plot_trajectory(path: str | Path, road, trajs: dict[str, Trajectory], title: str) -> None:
    """Top-down view of closed-loop drives on one road against its lane, and their lateral offsets over time."""
    with figure(path, 1, 2, figsize=(13, 5), gridspec_kw={"width_ratios": [1, 1.4]},
                margins=dict(left=0.06, right=0.99, bottom=0.1, top=0.9, wspace=0.16)) as (fig, (ax, ax2)):
        s_all = np.concatenate([t.s for t in trajs.values()])
        a, b = road.index(s_all.min() - 20), road.index(s_all.max() + 20) + 1
        for d, style in [(EDGE, "k-"), (-EDGE, "k-"), (0.0, "k--")]:
            ax.plot(road.x[a:b] - d * np.sin(road.psi[a:b]), road.y[a:b] + d * np.cos(road.psi[a:b]), style, lw=0.7)
        ax.plot(road.x[a:b] - LANE_CENTER * np.sin(road.psi[a:b]), road.y[a:b] + LANE_CENTER * np.cos(road.psi[a:b]),
                color="0.7", lw=0.7, label="lane centre")
        for (label, t), color in zip(trajs.items(), COLORS * 3):
            ax.plot(t.x, t.y, color=color, lw=1.0, label=label)
            ax2.plot(t.time_s, t.offset, color=color, lw=0.8, label=label)
        ax.set_aspect("equal")
        ax.locator_params(nbins=5)  # a map's ticks: few (matplotlib's ticks are most of a plot's drawing time)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.legend(fontsize=7)
        for limit in (-1.0, 1.0):
            ax2.axhline(limit, color="tab:red", ls=":", lw=0.8)
        ax2.set_xlabel("time [s]")
        ax2.set_ylabel("offset from lane centre [m] (left +)")
        ax2.locator_params(axis="y", nbins=5)
        ax2.grid(alpha=0.3)
        fig.suptitle(title)


def plot_track(path: str | Path, track, trajs: dict[str, Trajectory], title: str) -> None:
    """Top-down view of drives on a closed track: the lane edges (and a painted centre line), every drive's line
    (the rear axle's) with its off-track events marked where the car left the lane, and its speed over time."""
    with figure(path, 1, 2, figsize=(13, 5.5), gridspec_kw={"width_ratios": [1.2, 1]}) as (fig, (ax, ax2)):
        for d in (-track.lane_width / 2, track.lane_width / 2):
            ax.plot(*_closed(track.offset(d)), "k-", lw=0.8)
        ax.plot(*_closed(track.offset(0.0)), ls="-" if track.style == "centre" else ":", lw=0.6, color="0.5")
        x0, y0, psi0 = (float(v) for v in track.pose(0.0))
        w = track.lane_width / 2
        ax.plot([x0 + w * np.sin(psi0), x0 - w * np.sin(psi0)], [y0 - w * np.cos(psi0), y0 + w * np.cos(psi0)],
                color="tab:red", lw=2, label="start line")
        for (label, t), color in zip(trajs.items(), COLORS * 3):
            hits = t.intervention > 0
            pre = np.clip(np.flatnonzero(hits) - 1, 0, None)  # where the car was just before it was put back
            path_x, path_y = t.x.copy(), t.y.copy()
            path_x[hits], path_y[hits] = np.nan, np.nan  # no line across a put-back
            ax.plot(path_x, path_y, color=color, lw=0.8, alpha=0.8,
                    label=f"{label} ({int(hits.sum())} off track)")
            ax.plot(t.x[pre], t.y[pre], "x", color=color, ms=7)
            ax2.plot(t.time_s, t.speed, color=color, lw=0.8, label=label)
        ax.set_aspect("equal")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.legend(fontsize=7)
        ax2.set_xlabel("time [s]")
        ax2.set_ylabel("speed [m/s]")
        ax2.grid(alpha=0.3)
        fig.suptitle(title)


def _closed(xy: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """A loop's points with the first repeated at the end, so that the line closes."""
    return np.append(xy[0], xy[0][0]), np.append(xy[1], xy[1][0])


def plot_rounds(path: str | Path, rows: list[dict]) -> None:
    """DAgger: closed-loop autonomy per road type, or in replay, or the track suite's clean laps (and the
    validation RMSE) against the round; the validation RMSE alone when the rounds were not driven (`suite: null`)."""
    with figure(path, figsize=(7, 4)) as (fig, ax):
        rounds = [int(r["round"]) for r in rows]
        rmse = [float(r["val_rmse"]) for r in rows]
        if not any(r.get(k, "") != "" for r in rows for k in ("autonomy_all", "replay_autonomy", "clean_laps_pct")):
            ax.plot(rounds, rmse, "kx:")
            ax.set_xlabel("DAgger round")
            ax.set_ylabel("validation RMSE [the recording's steering unit]")
            ax.set_xticks(rounds)
            ax.grid(alpha=0.3)
            return
        for key, style, label in [("autonomy_country", "o-", "country"), ("autonomy_highway", "s-", "highway"),
                                  ("autonomy_twisty", "^-", "twisty"), ("autonomy_all", "k.--", "all"),
                                  ("replay_autonomy", "kD-", "replay"),
                                  ("clean_laps_pct", "g*-", "clean laps of the track suite")]:
            values = [float(r[key]) if r.get(key, "") != "" else np.nan for r in rows]
            if not np.all(np.isnan(values)):
                ax.plot(rounds, values, style, label=label)
        ax.set_xlabel("DAgger round")
        ax.set_ylabel("closed-loop autonomy or clean laps [%]")
        ax.set_ylim(top=101)  # at most 100 %
        ax.set_xticks(rounds)
        ax.grid(alpha=0.3)
        ax2 = ax.twinx()
        ax2.plot(rounds, rmse, color="0.6", ls=":", marker="x", label="val RMSE")
        ax2.set_ylabel("validation RMSE [steering unit]", color="0.4")
        lines = ax.get_legend_handles_labels()
        extra = ax2.get_legend_handles_labels()
        ax.legend(lines[0] + extra[0], lines[1] + extra[1], fontsize=8, loc="upper center", ncol=3,
                  bbox_to_anchor=(0.5, -0.15))  # below the axes: over none of the lines, near 100 % or near 0


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
