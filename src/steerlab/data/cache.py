"""The one cache root: compiled datasets (`dataset.py`) and the frames extracted from ROS bags (`bag.py`) live
under it. A config's `cache:`, or `--cache` on the command line, names it; otherwise the environment variable
STEERLAB_CACHE, otherwise `.steerlab-cache` in the working directory. However it is named, it goes through the
outputs' one check (`paths.check_outputs`): a cache is never written into a recording, a run or another kind of
folder (the default, steerlab's own folder, is taken wherever the command runs)."""

from __future__ import annotations

import os
from pathlib import Path

from steerlab.paths import check_outputs

DEFAULT = ".steerlab-cache"


def cache_root(configured: str | Path | None = None) -> Path:
    env = os.environ.get("STEERLAB_CACHE")
    if configured or env:  # a named one; the default is steerlab's own folder in the working directory
        check_outputs({"cache folder" if configured else "cache folder (STEERLAB_CACHE)": configured or env},
                      kind="cache")
    return Path(configured or env or DEFAULT)
