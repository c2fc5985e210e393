"""Plots of closed-loop drives."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from steerlab.sim.road import EDGE, LANE_CENTER  # noqa: E402


def plot_trajectory(path: str | Path, road, trajs: dict[str, np.ndarray], title: str) -> None:
    """Top-down view of closed-loop drives on one road against its lane, and their lateral offsets over time.

    trajs: label -> array with columns time_s, x, y, s, lateral_offset_m, steering, speed."""
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(13, 5), dpi=100, gridspec_kw={"width_ratios": [1, 1.4]})
    s_all = np.concatenate([t[:, 3] for t in trajs.values()])
    a, b = road.index(s_all.min() - 20), road.index(s_all.max() + 20) + 1
    for d, style in [(EDGE, "k-"), (-EDGE, "k-"), (0.0, "k--")]:
        ax.plot(road.x[a:b] - d * np.sin(road.psi[a:b]), road.y[a:b] + d * np.cos(road.psi[a:b]), style, lw=0.7)
    ax.plot(road.x[a:b] - LANE_CENTER * np.sin(road.psi[a:b]), road.y[a:b] + LANE_CENTER * np.cos(road.psi[a:b]),
            color="0.7", lw=0.7, label="lane centre")
    colors = plt.get_cmap("tab10").colors
    for (label, t), color in zip(trajs.items(), colors * 3):
        ax.plot(t[:, 1], t[:, 2], color=color, lw=1.0, label=label)
        ax2.plot(t[:, 0], t[:, 4], color=color, lw=0.8, label=label)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(fontsize=7)
    for limit in (-1.0, 1.0):
        ax2.axhline(limit, color="tab:red", ls=":", lw=0.8)
    ax2.set_xlabel("time [s]")
    ax2.set_ylabel("offset from lane centre [m] (left +)")
    ax2.grid(alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def plot_rounds(path: str | Path, rows: list[dict]) -> None:
    """DAgger: closed-loop autonomy per road type, or in replay (and the validation RMSE) against the round."""
    fig, ax = plt.subplots(figsize=(7, 4), dpi=100)
    rounds = [int(r["round"]) for r in rows]
    for key, style, label in [("autonomy_country", "o-", "country"), ("autonomy_highway", "s-", "highway"),
                              ("autonomy_twisty", "^-", "twisty"), ("autonomy_all", "k.--", "all"),
                              ("replay_autonomy", "kD-", "replay")]:
        values = [float(r[key]) if r.get(key, "") != "" else np.nan for r in rows]
        if not np.all(np.isnan(values)):
            ax.plot(rounds, values, style, label=label)
    ax.set_xlabel("DAgger round")
    ax.set_ylabel("closed-loop autonomy [%]")
    ax.set_ylim(top=101)  # autonomy is at most 100 %
    ax.set_xticks(rounds)
    ax.grid(alpha=0.3)
    ax2 = ax.twinx()
    ax2.plot(rounds, [float(r["val_rmse"]) for r in rows], color="0.6", ls=":", marker="x", label="val RMSE")
    ax2.set_ylabel("validation RMSE [rad]", color="0.4")
    lines = ax.get_legend_handles_labels()
    extra = ax2.get_legend_handles_labels()
    ax.legend(lines[0] + extra[0], lines[1] + extra[1], fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
