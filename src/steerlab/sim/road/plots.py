"""Plots of drives in the road world: a drive's path on its road and its lateral offset (`sim drive`), and every
checkpoint's drive on each road of the suite (`sim bench`'s roads/*.png)."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from steerlab.figures import COLORS, figure
from steerlab.sim.core.driving import Trajectory
from steerlab.sim.road.road import EDGE, LANE_CENTER


def plot_trajectory(path: str | Path, road, trajs: dict[str, Trajectory], title: str, limit_m: float = 1.0) -> None:
    """Top-down view of closed-loop drives on one road against its lane, and their lateral offsets over time with
    the intervention limit (`limit_m` off the lane centre) drawn on both sides."""
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
        for limit in (-limit_m, limit_m):
            ax2.axhline(limit, color="tab:red", ls=":", lw=0.8)
        ax2.set_xlabel("time [s]")
        ax2.set_ylabel("offset from lane centre [m] (left +)")
        ax2.locator_params(axis="y", nbins=5)
        ax2.grid(alpha=0.3)
        fig.suptitle(title)


def plot_roads(out: Path, drives: list[dict], minutes: float) -> None:
    """One figure per road in `out`: the path and lateral offset over time of every drive on it (a suite's rows,
    each with the `folder` of its trajectory.csv), labelled with the drive's label and autonomy."""
    from steerlab.sim.road.world import make_road

    out.mkdir(parents=True, exist_ok=True)
    for road, seed in dict.fromkeys((d["road_type"], int(d["seed"])) for d in drives):
        trajs = {f"{d['label']} ({float(d['autonomy']):.0f} %)": Trajectory.read(Path(d["folder"]) / "trajectory.csv")
                 for d in drives if (d["road_type"], int(d["seed"])) == (road, seed)}
        plot_trajectory(out / f"{road}-{seed}.png", make_road(seed, road, minutes * 60), trajs, f"{road} road {seed}")


def plot_drives(out: Path, suites: dict[str, Path], o) -> None:
    """An experiment's figure per road of the suite (`out/roads/<type>-<seed>.png`): the drive of every entry's
    seed-0 run on it (`suites`: the entry's label -> its run's suite folder), labelled with the entry."""
    drives = []
    for label, suite in suites.items():
        with open(suite / "suite.csv") as f:
            drives += [{**d, "label": label, "folder": suite / d["label"] / f"{d['road_type']}-{d['seed']}"}
                       for d in csv.DictReader(f)]
    plot_roads(out / "roads", drives, o.place_minutes)
