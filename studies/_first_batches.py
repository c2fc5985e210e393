"""What a training config starts from in one build (`studies/same_batches.py` runs it once with each build's source
on PYTHONPATH): train until the first epoch begins, then write the initial weights' hash, the random state's hash
and the first batches to an .npz file.

python -m studies._first_batches OUT.npz CONFIG SEED BATCHES
"""

import hashlib
import sys
import tempfile

import numpy as np


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


if __name__ == "__main__":
    dump(sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]))
