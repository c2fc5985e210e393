"""Training throughput per model from the compiled cache, so users can plan: frames per second of one
training epoch (forward, backward, Adam step, batches gathered from the cache), on 640 frames of the real
Udacity simulator recording (it has speed, so every model trains). Frame models use batches of 64 frames,
recurrent models batches of 8 windows of 10 frames.

python benchmarks/bench_throughput.py
Ratio printed: every model against PilotNet, measured in the same run.
"""

import tempfile
import time

import numpy as np
import torch

from _common import SHARED, machine

from steerlab.data.dataset import compile_recording
from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.readers import open_recording
from steerlab.models import create_model, list_models, model_class
from steerlab.data.inputs import channel_stats
from steerlab.train.loop import train_one_epoch
from steerlab.train.sources import Batches, model_preprocess, sequence_windows

SIM = SHARED / "udacity-sim-track1"
N = 640


def throughput(name: str, rec, cache: str) -> float:
    cfg = PreprocessConfig.from_dict(model_preprocess(name, {"preset": "sim"}))
    ds = compile_recording(rec, cfg, cache, progress=False)
    idx = np.arange(N)
    stats = channel_stats(ds.arrays, cfg, idx, np.zeros(len(ds), int))
    torch.manual_seed(0)
    model = create_model(name, in_channels=sum(cfg.channels().values()), height=cfg.height, width=cfg.width)
    batches = Batches([(ds, ds.steering)], stats, getattr(model, "speed_history", 0))
    recurrent = getattr(model, "recurrent", False)
    samples = sequence_windows(idx, batches.starts, model.seq_len) if recurrent else idx
    batch = 8 if recurrent else 64
    if all(p.dim() != 5 for p in model.parameters()):
        model = model.to(memory_format=torch.channels_last)
    opt = torch.optim.Adam(model.parameters(), 1e-4)
    rng = np.random.default_rng(0)
    train_one_epoch(model, opt, batches, samples[: 2 * batch], batch, False, rng, progress=False)  # warm-up
    t = time.perf_counter()
    train_one_epoch(model, opt, batches, samples, batch, False, rng, progress=False)
    return samples.size / (time.perf_counter() - t)


def main() -> None:
    if not (SIM / "driving_log.csv").exists():
        print(f"skipped: {SIM} not found (the benchmark uses the real simulator recording)")
        return
    rec = open_recording(SIM, f"0:{N}")
    print(f"machine: {machine()}; {N} simulator frames, one training epoch per model")
    print(f"{'model':<18} {'input':>10} {'frames/s':>9} {'vs pilotnet':>12}")
    with tempfile.TemporaryDirectory() as cache:
        results = {name: throughput(name, rec, cache) for name in list_models() if model_class(name).trainable}
    for name, fps in results.items():
        cfg = PreprocessConfig.from_dict(model_preprocess(name, {}))
        shape = f"{sum(cfg.channels().values())}@{cfg.width}x{cfg.height}"
        print(f"{name:<18} {shape:>10} {fps:9.0f} {fps / results['pilotnet']:11.2f}x")


if __name__ == "__main__":
    main()
