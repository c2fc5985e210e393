"""Plots people look at instead of tables."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from steerlab.figures import COLORS, MANY_COLORS, figure


def plot_steering(path: str | Path, t_s: np.ndarray, target: np.ndarray, preds: dict[str, np.ndarray],
                  title: str = "", throttle: tuple[np.ndarray, np.ndarray] | None = None) -> None:
    """Target vs prediction(s) over time, in degrees (paper 000 Fig. 7); with `throttle` (recorded, predicted)
    a second panel below shows the throttle."""
    with figure(path, rows=1 + (throttle is not None), figsize=(11, 3.6 + 2.4 * (throttle is not None)), dpi=110,
                sharex=True, squeeze=False) as (fig, axes):
        ax = axes[0, 0]
        ax.plot(t_s, np.degrees(target), color="black", lw=1.4, label="target")
        for (name, p), color in zip(preds.items(), MANY_COLORS):
            ax.plot(t_s, np.degrees(p), lw=1.0, label=name, color=color)
        ax.set_ylabel("steering [deg]")
        ax.set_title(title)
        if len(preds) > 3:  # many models: the legend goes beside the plot, not over the curves
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
        else:
            ax.legend(loc="upper right", fontsize=8)
        if throttle is not None:
            axes[1, 0].plot(t_s, throttle[0], color="black", lw=1.4, label="recorded")
            axes[1, 0].plot(t_s, throttle[1], lw=1.0, color=MANY_COLORS[0], label="predicted")
            axes[1, 0].set_ylabel("throttle")
            axes[1, 0].legend(loc="upper right", fontsize=8)
        for a in axes[:, 0]:
            a.grid(alpha=0.3)
        axes[-1, 0].set_xlabel("time [s]")


def episodes_of(labels: np.ndarray) -> list[tuple[int, int, int]]:
    """Drift-and-recover episodes as (first drift-out frame, first recover frame, end) index triples."""
    out = []
    i, n = 0, len(labels)
    while i < n:
        if labels[i] == "drift-out":
            a = i
            while i < n and labels[i] == "drift-out":
                i += 1
            b = i
            while i < n and labels[i] == "recover":
                i += 1
            if i > b:
                out.append((a, b, i))
        else:
            i += 1
    return out


def plot_recovery(path: str | Path, t_s: np.ndarray, target: np.ndarray, preds: dict[str, np.ndarray],
                  episodes: np.ndarray, max_panels: int = 6) -> int:
    """Drift-and-recover episodes in the form of paper 000 Fig. 6: the recorded steering (the driver steers
    out, then back), every model's prediction, a circle where the driver starts to correct and the correction
    dashed. Returns the number of episodes drawn."""
    found = episodes_of(episodes)[:max_panels]
    if not found:
        return 0
    cols = min(3, len(found))
    rows = -(-len(found) // cols)
    with figure(path, rows, cols, figsize=(4.6 * cols, 3.2 * rows), squeeze=False) as (fig, axes):
        for ax, (a, b, c) in zip(axes.ravel(), found):
            pad = int(round(2.0 / max(np.median(np.diff(t_s)), 1e-3)))
            w = slice(max(a - pad, 0), min(c + pad, len(t_s)))
            ax.plot(t_s[w], np.degrees(target[w]), color="black", lw=1.4, label="driver")
            ax.plot(t_s[b:c], np.degrees(target[b:c]), color="white", lw=1.0, ls="--")
            ax.plot(t_s[b], np.degrees(target[b]), "o", mfc="none", mec="black", ms=9)
            for (name, p), color in zip(preds.items(), COLORS * 3):
                ax.plot(t_s[w], np.degrees(p[w]), lw=1.0, color=color, label=name)
            ax.axvspan(t_s[a], t_s[b], color="tab:red", alpha=0.08)
            ax.set_xlabel("time [s]")
            ax.set_ylabel("steering [deg]")
            ax.grid(alpha=0.3)
        for ax in axes.ravel()[len(found):]:
            ax.axis("off")
        axes[0, 0].legend(fontsize=7)
        fig.suptitle("drift out (shaded) and back: the circle marks where the driver starts to correct, the correction "
                     "is dashed", fontsize=9)
    return len(found)


def plot_open_vs_closed(path: str | Path, tables: dict[str, list[dict]], metric: str = "rmse",
                        autonomy: str = "autonomy") -> None:
    """Each model's open-loop validation error against its closed-loop autonomy (`autonomy`: on the suite, or
    `replay_autonomy` in replay of the recording), one marker per table (e.g. before and after a training
    recipe), with an arrow from a model's first table to its last."""
    with figure(path, figsize=(8, 5.5)) as (fig, ax):
        markers = "osD^v"
        points: dict[str, list[tuple[float, float]]] = {}
        for (name, rows), marker in zip(tables.items(), markers):
            x = [float(r[f"{metric}_mean"]) for r in rows]
            y = [float(r[f"{autonomy}_mean"]) for r in rows]
            ax.scatter(x, y, marker=marker, s=40, label=name, zorder=3)
            for r, xi, yi in zip(rows, x, y):
                points.setdefault(r["label"], []).append((xi, yi))
                ax.annotate(r["label"], (xi, yi), fontsize=7, xytext=(4, 3), textcoords="offset points")
        if len(tables) > 1:
            for pts in points.values():
                if len(pts) > 1:
                    ax.annotate("", pts[-1], pts[0], arrowprops={"arrowstyle": "->", "color": "0.6", "lw": 0.8})
        ax.set_xlabel(f"open-loop validation {metric.upper()} [rad]")
        ax.set_ylabel("closed-loop autonomy, all suite roads [%]" if autonomy == "autonomy"
                      else "closed-loop replay autonomy, validation frames [%]")
        ax.set_ylim(top=101)  # autonomy is at most 100 %
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)


def rank_correlation(x, y) -> float:
    """Spearman's rank correlation: the Pearson correlation of the values' ranks, tied values sharing their mean
    rank (many models drive at 100 %). NaN for fewer than three points, when x or y takes a single value, or when
    either holds a NaN (a metric that some runs lack)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    if len(x) < 3 or not (np.ptp(x) > 0 and np.ptp(y) > 0):  # ptp is NaN with a NaN
        return float("nan")
    return float(np.corrcoef(_mean_ranks(x), _mean_ranks(y))[0, 1])


def _mean_ranks(v: np.ndarray) -> np.ndarray:
    """The ranks of `v` (1 for the smallest), tied values sharing the mean of their ranks."""
    _, value_of, count = np.unique(v, return_inverse=True, return_counts=True)
    below = np.cumsum(count) - count  # how many values are smaller than each distinct value
    return (below + (count + 1) / 2)[value_of]
