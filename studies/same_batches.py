"""Does another build train on the same data? The initial weights, the random state when the first epoch starts and
the first batches of a training config, from this build and from another one (a git worktree), compared.

python -m studies.same_batches --before /tmp/base [--config configs/track_best.yaml] [--batches 3] [--seed 0]
    # git worktree add /tmp/base 808d063 first; run from the repository root, the config's data in place
"""

import os
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from steerlab.cli import run_script, script_parser
from steerlab.errors import SteerlabError
from steerlab.options import AT_LEAST_1, SEED, Options, option

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class SameBatches(Options):
    before: str = option(help="the other build's source tree (a git worktree)")
    config: str = option("configs/track_best.yaml", path="file", help="the training config")
    batches: int = option(3, AT_LEAST_1, help="batches compared")
    seed: int = option(0, SEED, help="train.seed")


def parser():
    return script_parser(__spec__.name, __doc__, SameBatches)


def main(_, a: SameBatches) -> None:
    if not (Path(a.before) / "src" / "steerlab").is_dir():
        raise SteerlabError(f"--before {a.before}: no src/steerlab there; give a source tree of steerlab (git "
                            "worktree add)")
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


if __name__ == "__main__":
    run_script(parser(), main)
