"""Does another build train on the same data? The initial weights, the random state when the first epoch starts and
the first batches of a training config, from this build and from another one (a git worktree), compared.

python -m studies.same_batches --before /tmp/base [--config configs/track_best.yaml] [--batches 3] [--seed 0]
    # git worktree add /tmp/base 808d063 first; run from the repository root, the config's data in place
"""

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--before", required=True, help="the other build's source tree (a git worktree)")
    p.add_argument("--config", default="configs/track_best.yaml", help="the training config (default %(default)s)")
    p.add_argument("--batches", type=int, default=3, help="batches compared (default %(default)s)")
    p.add_argument("--seed", type=int, default=0, help="train.seed (default %(default)s)")
    a = p.parse_args()
    if not (Path(a.before) / "src" / "steerlab").is_dir():
        p.error(f"--before {a.before}: no src/steerlab there; give a source tree of steerlab (git worktree add)")
    if a.batches < 1:
        p.error(f"--batches must be at least 1, got {a.batches}")
    with tempfile.TemporaryDirectory() as tmp:
        found = {}
        for name, src in (("this build", ROOT / "src"), ("before", Path(a.before).resolve() / "src")):
            out = f"{tmp}/{len(found)}.npz"
            subprocess.run([sys.executable, "-m", "studies._first_batches", out, a.config, str(a.seed), str(a.batches)],
                           check=True, env={**os.environ, "PYTHONPATH": str(src)}, cwd=ROOT)
            found[name] = dict(np.load(out))
        now, before = found["this build"], found["before"]
        for key in ("weights", "random_state"):
            print(f"{key}: {'the same' if now[key] == before[key] else 'DIFFERENT'}")
        for key in sorted(k for k in now if k[0].isdigit()):
            gap = float(np.abs(now[key].astype(np.float64) - before[key]).max())
            print(f"batch {key}: largest difference {gap:.3g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
