"""The one cache root: compiled datasets (`dataset.py`) and the frames extracted from ROS bags (`bag.py`) live
under it. A config's `cache:`, or `--cache` on the command line, names it; otherwise the environment variable
STEERLAB_CACHE, otherwise `.steerlab-cache` in the working directory."""

from __future__ import annotations

import os
from pathlib import Path

DEFAULT = ".steerlab-cache"


def cache_root(configured: str | Path | None = None) -> Path:
    return Path(configured or os.environ.get("STEERLAB_CACHE") or DEFAULT)
