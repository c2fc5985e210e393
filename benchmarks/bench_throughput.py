"""Training throughput per model, so users can plan, and the data path against its own needs: frames per second of
one training epoch (forward, backward, Adam step, batches from the compiled cache through torch's DataLoader)
on 640 frames of the real Udacity simulator recording (it has speed, so every model trains). Frame models use
batches of 64 frames, recurrent models batches of 8 windows of 10 frames.

Measured in the same run:
- the training loop before the DataLoader (the hand-made batches of commit BASELINE, run from a git worktree of
  it, in a subprocess with the same Python): no model may train slower now;
- the loader alone (the model replaced by a no-op): it must deliver at least 3x the model's own training
  throughput, so that a faster device (a GPU) is fed;
- `train.workers` 0 and 1 (data loading in this process, or one worker process preparing the next batches).

python benchmarks/bench_throughput.py [--models pilotnet,lstm] [--no-baseline] [--json PATH]
"""

import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np
import torch
from common import ROOT, Report, SHARED, arguments, machine, guarded, timed

from steerlab.data.dataset import compile_recording
from steerlab.data.inputs import channel_stats, segment_starts
from steerlab.data.preprocess import PreprocessOptions
from steerlab.data.readers import open_recording
from steerlab.models import list_models, model_class
from steerlab.models.registry import ModelSpec
from steerlab.train.batches import EpochSampler, FrameBatches, loader, sequence_windows
from steerlab.train.loop import train_one_epoch

SIM = SHARED / "udacity-sim-track1"
N = 640
BASELINE = "4e71608"  # the last commit whose training gathered its batches by hand


def setup(name: str, rec, cache: str, workers: int):
    spec = ModelSpec(name, {})
    pre = spec.preprocess(PreprocessOptions(preset="sim")).resolve()
    ds = compile_recording(rec, pre, cache, progress=False)
    idx = np.arange(N)
    stats = channel_stats(ds.arrays, pre, idx, segment_starts(ds.labels["segment"]))
    torch.manual_seed(0)
    model = spec.build(pre)
    data = FrameBatches([(ds, ds.steering)], stats, model.speed_history)
    samples = sequence_windows(idx, data.starts, model.seq_len) if model.recurrent else idx
    sampler = EpochSampler(samples, 8 if model.recurrent else 64, seed=0)
    if all(p.dim() != 5 for p in model.parameters()):
        model = model.to(memory_format=torch.channels_last)
    return model, loader(data, sampler, workers, torch.device("cpu")), samples.size


def training(name: str, rec, cache: str, workers: int) -> float:
    model, batches, frames = setup(name, rec, cache, workers)
    opt = torch.optim.Adam(model.parameters(), 1e-4)
    batches.sampler.set_epoch(1)
    train_one_epoch(model, opt, batches, progress=False)  # warm-up: oneDNN kernels, page cache, workers
    batches.sampler.set_epoch(2)
    return frames / timed(lambda: train_one_epoch(model, opt, batches, progress=False))


def loading(name: str, rec, cache: str, workers: int) -> float:
    _, batches, frames = setup(name, rec, cache, workers)

    def epoch(n: int) -> None:
        batches.sampler.set_epoch(n)
        for _ in batches:
            pass

    epoch(1)  # warms up
    return frames / timed(lambda: epoch(2))


def baseline(models: list[str]) -> dict[str, float]:
    """The frames/s of commit BASELINE's own bench_throughput.py, run from a worktree beside this repository (so
    that it finds ../shared/data as this one does)."""
    folder = ROOT.parent / f".steerlab-baseline-{os.getpid()}"
    subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "--quiet", str(folder), BASELINE],
                   check=True)
    try:
        env = {**os.environ, "PYTHONPATH": str(folder / "src")}
        out = subprocess.run([sys.executable, str(folder / "benchmarks" / "bench_throughput.py")], env=env, check=True,
                             capture_output=True, text=True).stdout
    finally:
        subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(folder)], check=True)
        shutil.rmtree(folder, ignore_errors=True)
    rows = [line.split() for line in out.splitlines() if line.split() and line.split()[0] in models]
    return {r[0]: float(r[2]) for r in rows}


def main() -> None:
    p = arguments(__doc__)
    p.add_argument("--models", help="comma list (default: every trainable model)")
    p.add_argument("--no-baseline", action="store_true", help=f"skip the measurement of commit {BASELINE}")
    a = p.parse_args()
    if not (SIM / "driving_log.csv").exists():
        print(f"skipped: {SIM} not found (the benchmark uses the real simulator recording)")
        return
    models = a.models.split(",") if a.models else [n for n in list_models() if model_class(n).trainable]
    for name in models:
        model_class(name)  # an unknown name refused before any work
    report = Report(__file__, {"frames": N, "models": models, "baseline_commit": None if a.no_baseline else BASELINE},
                    a.json)
    rec = open_recording(SIM, f"0:{N}")
    print(f"machine: {machine()}; {N} simulator frames, one training epoch per model, frames/s")
    before = {} if a.no_baseline else baseline(models)
    print(f"{'model':<16} {'before':>8} {'workers 0':>10} {'workers 1':>10} {'now/before':>11} {'loader alone':>13} "
          f"{'loader/train':>13}")
    with tempfile.TemporaryDirectory() as cache:
        for name in models:
            w0, w1 = training(name, rec, cache, 0), training(name, rec, cache, 1)
            feed = loading(name, rec, cache, 1)
            old = before.get(name, float("nan"))
            print(f"{name:<16} {old:8.0f} {w0:10.0f} {w1:10.0f} {max(w0, w1) / old:10.2f}x {feed:13.0f} "
                  f"{feed / max(w0, w1):12.1f}x", flush=True)
            report.add(name, before_fps=old, workers_0_fps=w0, workers_1_fps=w1, now_vs_before=max(w0, w1) / old,
                       loader_alone_fps=feed, loader_vs_training=feed / max(w0, w1))
    print("targets: now/before >= 1.00x for every model (2 cores); loader alone >= 3x the training throughput")
    report.write()


if __name__ == "__main__":
    guarded(main)
