"""Plots of drives in the track world: the driven line on the track, off-track events marked, and the speed (`sim
drive --world track`, and every checkpoint's line on each track of the suite: `sim bench`'s tracks/*.png)."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from steerlab.figures import COLORS, figure
from steerlab.sim.core.driving import Trajectory
from steerlab.sim.track.track import Track


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


def plot_tracks(out: Path, drives: list, lane_width: float, expert: str) -> None:
    """One figure per track of a suite (`out/tracks/<style>-<seed>.png`): the line of the expert (its drives in
    `out/<expert>`) and of every checkpoint (the suite's rows `drives`), off-track events marked."""
    (out / "tracks").mkdir(exist_ok=True)
    for style, seed in dict.fromkeys((d.style, d.seed) for d in drives):
        name = f"{style}-{seed}"
        trajs = {expert: Trajectory.read(out / expert / name / "trajectory.csv")}
        for d in drives:
            if (d.style, d.seed) == (style, seed):
                trajs[f"{d.label}: {d.clean_laps}/{d.laps} clean laps"] = Trajectory.read(
                    out / d.label / name / "trajectory.csv")
        plot_track(out / "tracks" / f"{name}.png", Track(seed, lane_width, style), trajs, f"{style} track {seed}")


def plot_drives(out: Path, suites: dict[str, Path], o) -> None:
    """An experiment's figure per track of the suite (`out/tracks/<style>-<seed>.png`): the expert's line and the
    drive of every entry's seed-0 run (`suites`: the entry's label -> its run's suite folder), labelled with the
    entry and its clean laps."""
    (out / "tracks").mkdir(parents=True, exist_ok=True)
    rows = {}
    for label, suite in suites.items():
        with open(suite / "suite.csv") as f:
            rows[label] = list(csv.DictReader(f))
    first = next(iter(suites.values()))
    for style, seed in o.drives():
        name = f"{style}-{seed}"
        trajs = {"expert": Trajectory.read(first / o.expert_folder() / name / "trajectory.csv")}
        for label, suite in suites.items():
            for d in rows[label]:
                if (d["style"], int(d["seed"])) == (style, seed):
                    trajs[f"{label}: {d['clean_laps']}/{d['laps']} clean laps"] = Trajectory.read(
                        suite / d["label"] / name / "trajectory.csv")
        plot_track(out / "tracks" / f"{name}.png", Track(seed, o.drive_options(style, seed).lane_width, style), trajs,
                   f"{style} track {seed}")
