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
    for name, p in preds.items():
        ax.plot(t_s, np.degrees(p), lw=1.0, label=name)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("steering [deg]")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
