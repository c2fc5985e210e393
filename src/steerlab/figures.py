"""Figures: matplotlib without a display, one way to make, save and close a figure, and the colours."""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

COLORS = plt.get_cmap("tab10").colors
MANY_COLORS = plt.get_cmap("tab20").colors[::2] + plt.get_cmap("tab20").colors[1::2]  # up to 20 distinct lines


@contextmanager
def figure(path: str | Path, rows: int = 1, cols: int = 1, figsize=(8, 5), dpi: int = 100,
           margins: dict | None = None, **kw):
    """`with figure(path, ...) as (fig, axes):` draw; on leaving, the figure is laid out, written to `path` and
    closed (also when drawing fails). `kw` goes to `plt.subplots`. The layout is `tight_layout`'s, which draws
    the figure once to measure its text, or, for figures drawn often (one per road of a suite), the fixed
    `margins` of `subplots_adjust`, so that the figure is drawn only when it is saved."""
    fig, axes = plt.subplots(rows, cols, figsize=figsize, dpi=dpi, **kw)
    try:
        yield fig, axes
        if margins:
            fig.subplots_adjust(**margins)
        else:
            fig.tight_layout()
            fig.set_layout_engine(None)  # laid out: savefig draws once
        fig.savefig(path, pil_kwargs={"compress_level": 1})  # quick to write; files about a third larger
    finally:
        plt.close(fig)
