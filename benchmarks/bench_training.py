"""Epoch time of PilotNet training from the compiled cache vs. (a) a naive loader that decodes and
preprocesses the JPEGs in every step, and (b) tensors already in memory (the floor for data loading).

python benchmarks/bench_training.py
Targets: cache >= 5x faster than naive; cache within 15% of in-memory.
"""

import tempfile
import time

import numpy as np
import torch

from _common import CH2, machine, need_ch2

from steerlab.data.dataset import compile_recording
from steerlab.data.preprocess import PreprocessConfig, preprocess
from steerlab.data.readers import open_recording
from steerlab.models import create_model
from steerlab.train.inputs import Standardizer, channel_stats
from steerlab.train.loop import Batches

N, BATCH = 1200, 100


def epoch(get_batch, order) -> float:
    torch.manual_seed(0)
    model = create_model("pilotnet", in_channels=1)
    opt = torch.optim.Adam(model.parameters(), 1e-4)
    model.train()
    t = time.perf_counter()
    for s in range(0, len(order), BATCH):
        x, y = get_batch(order[s: s + BATCH])
        loss = torch.mean((model(x) - y) ** 2)
        opt.zero_grad()
        loss.backward()
        opt.step()
    return time.perf_counter() - t


def main() -> None:
    need_ch2()
    rec = open_recording(CH2, f"0:{N}", CH2 / "CH2_final_evaluation.csv")
    cfg = PreprocessConfig.from_dict({"preset": "ch2"})
    with tempfile.TemporaryDirectory() as cache:
        ds = compile_recording(rec, cfg, cache, progress=False)
        stats = channel_stats(ds.arrays, cfg, np.arange(N))
        batches = Batches([(ds, ds.steering)], stats)
        standardize = Standardizer(stats)
        order = np.random.default_rng(0).permutation(N)
        x_all = standardize(np.asarray(ds.arrays["image"], np.float32))
        y_all = torch.from_numpy(ds.steering.astype(np.float32))

        def naive(idx):  # decode + preprocess every JPEG in every step
            x = np.stack([preprocess(rec.load_frame(int(i)), cfg)[0] for i in idx]).astype(np.float32)
            return standardize(x), torch.from_numpy(rec.steering[idx].astype(np.float32))

        epoch(batches.get, order)  # warm-up: page cache and oneDNN kernels
        t_mem = epoch(lambda idx: (x_all[idx], y_all[idx]), order)
        t_cache = epoch(batches.get, order)
        t_naive = epoch(naive, order)
    print(f"machine: {machine()}; PilotNet, {N} CH2 frames, batch {BATCH}")
    print(f"in-memory tensors : {t_mem:6.2f} s/epoch")
    print(f"compiled cache    : {t_cache:6.2f} s/epoch   ({t_cache / t_mem - 1:+.1%} vs in-memory; target within 15%)")
    print(f"naive JPEG loader : {t_naive:6.2f} s/epoch   (cache is x{t_naive / t_cache:.2f} faster; target >= 5x)")


if __name__ == "__main__":
    main()
