"""The levers of a training step on two cores, each measured against the step steerlab ships, in the same run: one
step of donkeycar's linear network (`donkey-linear`, the track recipe's) on a batch of 128 RGB 160x120 frames, the
batch made as training makes it (gathered from a uint8 cache, half mirrored, hue and brightness drawn per sample,
standardised) and the model's forward, backward and Adam step. Each variant runs in a process of its own (the
allocator's setting and the thread count hold for a whole process): the median of 20 steps after 5.

- shipped: `models.dropout.Dropout` (masks drawn in bulk), `train.host.keep_freed_memory` (glibc keeps freed
  blocks), channels-last convolutions, torch's two threads, float32, batches made in this process (`train.workers`
  0) with torch's operations on the whole batch;
- torch-dropout: `nn.Dropout` (a `bernoulli_` draw per element);
- default-malloc: glibc's default (blocks of tens of MB mapped afresh every step);
- nchw: convolutions on NCHW tensors;
- 1-thread: torch on one thread;
- pinned-threads: torch's two OpenMP threads each bound to a core (`OMP_PROC_BIND=close OMP_PLACES=cores`);
- 1-worker: the batches made by one DataLoader worker process while the model trains (torch on two threads);
- compile: `torch.compile` of the model (its compile time apart);
- bf16: `train.precision: bf16`, the forward pass in bfloat16 (on CPUs with AVX512-BF16 or AMX);
- before: the same step with the source of an earlier commit (`--before`, by default 808d063, before these
  levers: torch's dropout and malloc's default, the batch changed sample by sample in NumPy).

python -m benchmarks.bench_train_step [--before COMMIT] [--json PATH]
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from benchmarks.common import ROOT, Report, arguments, machine

from steerlab.cli import run_script
from steerlab.errors import SteerlabError
from steerlab.options import Options, option

B, H, W, FRAMES, STEPS, WARMUP = 128, 120, 160, 2048, 20, 5
VARIANTS = ["shipped", "torch-dropout", "default-malloc", "nchw", "1-thread", "pinned-threads", "1-worker", "compile",
            "bf16"]
PINNED = {"OMP_PROC_BIND": "close", "OMP_PLACES": "cores"}  # each of torch's OpenMP threads bound to a core


def batches(workers: int):
    """The track recipe's batches (flip, hue 180, brightness 0.25) from a synthetic uint8 cache, as `steerlab train`
    makes them."""
    from steerlab.data.dataset import CompiledDataset
    from steerlab.data.preprocess import PreprocessConfig
    from steerlab.train.batches import EpochSampler, FrameBatches, loader

    cfg = PreprocessConfig(width=W, height=H, color="rgb", crop=(0, 0, 0, 0))
    rng = np.random.default_rng(0)
    folder = Path(tempfile.mkdtemp())  # a cache entry's image.npy, which a worker process maps again
    np.save(folder / "image.npy", rng.integers(0, 256, (FRAMES, H, W, 3), np.uint8))
    images = np.load(folder / "image.npy", mmap_mode="r")
    labels = {"steering": rng.uniform(-1, 1, FRAMES), "throttle": rng.uniform(0, 1, FRAMES),
              "segment": np.zeros(FRAMES, int), "timestamps_ns": np.arange(FRAMES) * 50_000_000,
              "frame_ids": np.arange(FRAMES)}
    ds = CompiledDataset(folder, cfg, {"image": images}, labels, {"source": "synthetic"})
    data = FrameBatches([(ds, labels["steering"])], {"mean": [100.0] * 3, "std": [50.0] * 3}, throttle=True,
                        brightness=0.25, hue_deg=180)
    sampler = EpochSampler(np.arange(FRAMES), B, seed=0, flip=True)
    batches = loader(data, sampler, workers, torch.device("cpu"))
    epoch = 0
    while True:
        epoch += 1
        sampler.set_epoch(epoch)
        yield from batches


def one(variant: str) -> dict:
    """Milliseconds of a training step under `variant` (run in a process of its own), and of making its batch."""
    from steerlab.models import create_model
    from steerlab.train.loop import objective

    if variant not in ("default-malloc", "before"):  # "before": the earlier source has no such setting
        from steerlab.train.host import keep_freed_memory

        keep_freed_memory()
    torch.set_num_threads(1 if variant == "1-thread" else 2)
    torch.manual_seed(0)
    model = create_model("donkey-linear", in_channels=3, height=H, width=W, throttle=True)
    if variant == "torch-dropout":
        for module in model.modules():
            for name, child in module.named_children():
                if type(child).__name__ == "Dropout":
                    setattr(module, name, torch.nn.Dropout(child.p))
    if variant != "nchw":
        model = model.to(memory_format=torch.channels_last)
    opt = torch.optim.Adam(model.parameters(), 1e-3, fused=True)
    step_model = torch.compile(model) if variant == "compile" else model
    source = batches(1 if variant == "1-worker" else 0)
    steps, made = [], []
    for _ in range(WARMUP + STEPS):
        t = time.perf_counter()
        inputs, targets, _ = next(source)
        made.append(time.perf_counter() - t)
        if variant == "nchw":
            inputs["x"] = inputs["x"].contiguous()
        with torch.autocast("cpu", torch.bfloat16, enabled=variant == "bf16"):
            out = step_model(**inputs)
        loss = objective(model, out, targets, "mae", throttle_weight=1.0)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        steps.append(time.perf_counter() - t)
    return {"step_ms": 1000 * statistics.median(steps[WARMUP:]), "batch_ms": 1000 * statistics.median(made[WARMUP:]),
            "first_step_s": steps[0]}


def measure(variant: str, source: Path | None = None) -> dict:
    """`one(variant)` in a process of its own, with steerlab imported from `source` (a checkout's src/) if given."""
    env = {**os.environ, **(PINNED if variant == "pinned-threads" else {})}
    if source is not None:
        env["PYTHONPATH"] = str(source)
    done = subprocess.run([sys.executable, "-m", "benchmarks.bench_train_step", "--one", variant], capture_output=True,
                          text=True, env=env, cwd=ROOT)
    if done.returncode:  # the variant's process died (torch.compile's AVX-512 code corrupts the heap on some CPUs)
        said = (done.stderr.strip().splitlines() or [f"exit status {done.returncode}"])[-1]
        return {"failed": said}
    return json.loads(done.stdout.strip().splitlines()[-1])


@dataclass(frozen=True)
class StepTiming(Options):
    before: str = option("808d063", help="the earlier source to time as 'before' (a commit, checked out in a git "
                         "worktree; 808d063: the source before these levers; '' to skip)")


def parser():
    return arguments(__spec__.name, __doc__, StepTiming)


def main(a, args: StepTiming) -> None:
    report = Report(__file__, {"model": "donkey-linear", "batch": B, "input": f"{W}x{H} rgb", "steps": STEPS,
                               "before": args.before}, a.json)
    print(f"machine: {machine()}; donkey-linear, batches of {B} RGB {W}x{H}, median of {STEPS} steps after {WARMUP}")
    base = measure("shipped")
    if "failed" in base:
        sys.exit(f"the shipped step failed: {base['failed']}")
    results = {"shipped": base}
    if args.before:
        with tempfile.TemporaryDirectory() as tmp:
            added = subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", tmp, args.before],
                                   capture_output=True, text=True)
            if added.returncode:
                raise SteerlabError(f"--before {args.before}: not a commit of {ROOT} "
                                    f"({added.stderr.strip().splitlines()[-1]})")
            try:
                results[f"before ({args.before})"] = measure("before", Path(tmp) / "src")
            finally:
                subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", tmp], check=True)
    for variant in VARIANTS[1:]:
        results[variant] = measure(variant)
    for name, r in results.items():
        if "failed" in r:
            print(f"  {name:18s} failed: {r['failed']}")
            report.add(name, failed=r["failed"])
            continue
        print(f"  {name:18s} {r['step_ms']:6.1f} ms a step (its batch {r['batch_ms']:5.1f} ms)  "
              f"x{r['step_ms'] / base['step_ms']:.2f} the shipped step  ({B / r['step_ms'] * 1000:4.0f} samples/s; "
              f"first step {r['first_step_s']:.1f} s)")
        report.add(name, **r, vs_shipped=r["step_ms"] / base["step_ms"])
    report.write()


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--one":  # one variant, in the process that `measure` starts
        print(json.dumps(one(sys.argv[2])))
    else:
        run_script(parser(), main)
