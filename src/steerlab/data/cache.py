"""The one cache root: compiled datasets (`dataset.py`) and the frames extracted from ROS bags (`bag.py`) live
under it. A config's `cache:`, or `--cache` on the command line, names it; otherwise the environment variable
STEERLAB_CACHE, otherwise `.steerlab-cache` in the working directory. However it is named, it goes through the
outputs' one check (`paths.check_outputs`): a cache is never written into a recording, a run or another kind of
folder."""

from __future__ import annotations

import os
from pathlib import Path

from steerlab.paths import check_outputs

DEFAULT = ".steerlab-cache"


def cache_root(configured: str | Path | None = None) -> Path:
    env = os.environ.get("STEERLAB_CACHE")
    root = Path(configured or env or DEFAULT)
    check_outputs({"cache folder" if configured or not env else "cache folder (STEERLAB_CACHE)": root}, kind="cache")
    return root
