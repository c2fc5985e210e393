"""Epoch time of PilotNet training from the compiled cache vs. two baselines measured in the same run: (a) a naive
loader that decodes and preprocesses the JPEGs (and computes the optical flow, when the model takes it) in every
step, and (b) tensors already in memory (the floor for data loading). Two inputs: gray (paper 000 "spatial") and
gray + Farneback flow (paper 000 "spatial + optical flow").

python benchmarks/bench_training.py [--json PATH]
Targets: cache >= 5x faster than naive; cache within 15% of in-memory.
"""

import tempfile

import numpy as np
import torch
from common import CH2, Report, arguments, machine, need_ch2, guarded, timed

from steerlab.data.dataset import compile_recording
from steerlab.data.modalities import optical_flow
from steerlab.data.preprocess import PreprocessConfig, preprocess
from steerlab.data.readers import open_recording
from steerlab.models import create_model
from steerlab.data.inputs import Standardizer, channel_stats, stack_modalities
from steerlab.train.batches import Batch, FrameBatches

N, BATCH = 1200, 100


def epoch(get_batch, order, channels: int) -> float:
    torch.manual_seed(0)
    model = create_model("pilotnet", in_channels=channels).to(memory_format=torch.channels_last)
    opt = torch.optim.Adam(model.parameters(), 1e-4)
    model.train()

    def run():
        for s in range(0, len(order), BATCH):
            x, y = get_batch(order[s: s + BATCH])
            loss = torch.mean((model(x)["steering"] - y) ** 2)
            opt.zero_grad()
            loss.backward()
            opt.step()

    return timed(run)


def bench(rec, modalities: list[str], cache: str, report: Report) -> None:
    cfg = PreprocessConfig.from_dict({"preset": "ch2", "modalities": modalities})
    channels = sum(cfg.channels().values())
    ds = compile_recording(rec, cfg, cache, progress=False)
    stats = channel_stats(ds.arrays, cfg, np.arange(N), np.zeros(N, int))
    batches = FrameBatches([(ds, ds.steering)], stats)

    def cached(idx):
        inputs, targets, _ = batches[Batch(idx)]
        return inputs["x"], targets["steering"]
    standardize = Standardizer(stats)
    order = np.random.default_rng(0).permutation(N)
    x_all = standardize(stack_modalities({m: ds.arrays[m][:] for m in modalities}, cfg)).contiguous(
        memory_format=torch.channels_last)
    y_all = torch.from_numpy(ds.steering.astype(np.float32))

    def naive(idx):  # decode + preprocess (+ flow against the previous frame) for every sample of every step
        xs = []
        for i in idx:
            img, gray = preprocess(rec.load_frame(int(i)), cfg)
            arrays = {"image": img}
            if "flow" in modalities:
                _, prev = preprocess(rec.load_frame(max(int(i) - 1, 0)), cfg)
                arrays["flow"] = optical_flow(prev, gray)
            xs.append(stack_modalities(arrays, cfg))
        return standardize(np.stack(xs)), torch.from_numpy(rec.steering[idx].astype(np.float32))

    epoch(cached, order, channels)  # warm-up: page cache and oneDNN kernels
    t_mem = epoch(lambda idx: (x_all[idx], y_all[idx]), order, channels)
    t_cache = epoch(cached, order, channels)
    t_naive = epoch(naive, order, channels)
    print(f"input {'+'.join(modalities)} ({channels} channels)")
    print(f"  in-memory tensors : {t_mem:6.2f} s/epoch")
    print(f"  compiled cache    : {t_cache:6.2f} s/epoch   ({t_cache / t_mem - 1:+.1%} vs in-memory; target within 15%)")
    print(f"  naive JPEG loader : {t_naive:6.2f} s/epoch   (cache is x{t_naive / t_cache:.2f} faster; target >= 5x)")
    report.add("+".join(modalities), channels=channels, in_memory_s=t_mem, cache_s=t_cache, naive_s=t_naive,
               cache_vs_in_memory=t_cache / t_mem, naive_vs_cache=t_naive / t_cache)


def main() -> None:
    args = arguments(__doc__).parse_args()
    need_ch2()
    report = Report(__file__, {"model": "pilotnet", "frames": N, "batch": BATCH}, args.json)
    rec = open_recording(CH2, f"0:{N}", CH2 / "CH2_final_evaluation.csv")
    print(f"machine: {machine()}; PilotNet, {N} CH2 frames, batch {BATCH}")
    with tempfile.TemporaryDirectory() as cache:
        bench(rec, ["image"], cache, report)
        bench(rec, ["image", "flow"], cache, report)
    report.write()


if __name__ == "__main__":
    guarded(main)
