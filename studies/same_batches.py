"""Does another build train on the same data? The initial weights, the random state when the first epoch starts and
the first batches of a training config, from this build and from another one (a git worktree), compared.

python studies/same_batches.py --before /tmp/base [--config configs/track_best.yaml] [--batches 3] [--seed 0]
    # git worktree add /tmp/base 808d063 first; run from the repository root, the config's data in place
"""

import argparse
import hashlib
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def dump(out: str, config: str, seed: int, batches: int) -> None:
    """In a process of one build: train until the first epoch begins, then write what it starts from to `out`."""
    import torch

    import steerlab.train.loop as loop
    from steerlab.train.config import load_config

    def first(model, opt, loader, *args, **kwargs):
        state = getattr(model, "module", model).state_dict()
        weights = hashlib.sha1(b"".join(k.encode() + v.detach().float().numpy().tobytes() for k, v in state.items()))
        found = {"weights": np.array(weights.hexdigest()),
                 "random_state": np.array(hashlib.sha1(torch.get_rng_state().numpy().tobytes()).hexdigest())}
        for i, (inputs, targets, _) in zip(range(batches), loader):
            found.update({f"{i}.{k}": v.numpy() for k, v in {**inputs, **targets}.items()})
        np.savez(out, **found)
        raise SystemExit(0)

    loop.train_one_epoch = first
    with tempfile.TemporaryDirectory() as run:
        loop.train(load_config(config, [f"train.seed={seed}", f"out={run}/run"]), progress=False)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--before", required=True, help="the other build's source tree (a git worktree)")
    p.add_argument("--config", default="configs/track_best.yaml", help="the training config (default %(default)s)")
    p.add_argument("--batches", type=int, default=3, help="batches compared (default %(default)s)")
    p.add_argument("--seed", type=int, default=0, help="train.seed (default %(default)s)")
    a = p.parse_args()
    if not (ROOT / a.config).is_file():
        p.error(f"--config {a.config}: no such file")
    if not (Path(a.before) / "src" / "steerlab").is_dir():
        p.error(f"--before {a.before}: no src/steerlab there; give a source tree of steerlab (git worktree add)")
    if a.batches < 1:
        p.error(f"--batches must be at least 1, got {a.batches}")
    with tempfile.TemporaryDirectory() as tmp:
        found = {}
        for name, src in (("this build", ROOT / "src"), ("before", Path(a.before).resolve() / "src")):
            out = f"{tmp}/{len(found)}.npz"
            code = f"import sys; sys.path.insert(0, {str(src)!r}); from same_batches import dump; " \
                   f"dump({out!r}, {a.config!r}, {a.seed}, {a.batches})"
            env = {**os.environ, "PYTHONPATH": f"{src}{os.pathsep}{Path(__file__).parent}"}
            subprocess.run([sys.executable, "-c", code], check=True, env=env, cwd=ROOT)
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
