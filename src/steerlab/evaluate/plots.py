"""Plots people look at instead of tables."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def plot_steering(path: str | Path, t_s: np.ndarray, target: np.ndarray, preds: dict[str, np.ndarray],
                  title: str = "") -> None:
    """Target vs prediction(s) over time, in degrees (paper 000 Fig. 7)."""
    fig, ax = plt.subplots(figsize=(11, 3.6), dpi=110)
    ax.plot(t_s, np.degrees(target), color="black", lw=1.4, label="target")
    colors = plt.get_cmap("tab20").colors  # distinct colours for up to 20 models
    for (name, p), color in zip(preds.items(), colors[::2] + colors[1::2]):
        ax.plot(t_s, np.degrees(p), lw=1.0, label=name, color=color)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("steering [deg]")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    if len(preds) > 3:  # many models: the legend goes beside the plot, not over the curves
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    else:
        ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def plot_trajectory(path: str | Path, road, traj: np.ndarray, result: dict) -> None:
    """Top-down view of a closed-loop run against the lane, and the lateral offset over time.

    traj columns: time_s, x, y, s, lateral_offset_m, steering, speed."""
    from steerlab.sim.road import EDGE, LANE_CENTER

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 5), dpi=100, gridspec_kw={"width_ratios": [1, 1.4]})
    a, b = road.index(traj[:, 3].min() - 20), road.index(traj[:, 3].max() + 20) + 1
    for d, style in [(EDGE, "k-"), (-EDGE, "k-"), (0.0, "k--")]:
        ax.plot(road.x[a:b] - d * np.sin(road.psi[a:b]), road.y[a:b] + d * np.cos(road.psi[a:b]), style, lw=0.7)
    ax.plot(road.x[a:b] - LANE_CENTER * np.sin(road.psi[a:b]), road.y[a:b] + LANE_CENTER * np.cos(road.psi[a:b]),
            color="0.7", lw=0.7, label="lane centre")
    ax.plot(traj[:, 1], traj[:, 2], color="tab:red", lw=1.0, label="car")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(fontsize=8)
    ax.set_title(f"{result['label']} on {result['road']} road, seed {result['seed']}")
    ax2.plot(traj[:, 0], traj[:, 4], lw=0.8)
    ax2.axhline(1.0, color="tab:red", ls=":", lw=0.8)
    ax2.axhline(-1.0, color="tab:red", ls=":", lw=0.8)
    ax2.set_xlabel("time [s]")
    ax2.set_ylabel("offset from lane centre [m]")
    ax2.set_title(f"autonomy {result['autonomy']:.1f}%, {result['interventions']} interventions, "
                  f"mean |offset| {result['mean_abs_offset_m']:.2f} m")
    ax2.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
