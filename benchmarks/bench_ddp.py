"""Data-parallel training throughput: 2 DDP ranks (gloo, 1 thread each, as torchrun sets them) against one process
(2 torch threads; the baseline, measured in the same run) on this machine, same model, same global batch, same
data.

python benchmarks/bench_ddp.py [--model pilotnet] [--epochs 3] [--json PATH]
Data: a 2-minute synthetic-world recording (made once under runs/bench-ddp). Reported: training samples per
second of the epochs after the first (the epoch time of the log minus nothing: validation runs on every rank,
on 100 frames only).
"""

import csv
import os
import subprocess
import sys

import yaml
from common import ARG, ROOT, Report, arguments, machine, guarded

from steerlab.data.readers import open_recording

OUT = ROOT / "runs" / "bench-ddp"


def run(cfg: dict, name: str, nproc: int) -> float:
    out = OUT / name
    subprocess.run(["rm", "-rf", str(out)], check=True)
    path = OUT / f"{name}.yaml"
    path.write_text(yaml.safe_dump({**cfg, "out": str(out)}))
    env = {**os.environ, "OMP_NUM_THREADS": "1" if nproc > 1 else "2"}
    subprocess.run([sys.executable, "-m", "steerlab", "train", str(path), "--nproc", str(nproc)], check=True, env=env,
                   stdout=subprocess.DEVNULL)
    with open(out / "log.csv") as f:
        rows = list(csv.DictReader(f))[1:]
    return sum(float(r["seconds"]) for r in rows) / len(rows)


def main() -> None:
    ap = arguments(__doc__)
    ap.add_argument("--model", default="pilotnet")
    ap.add_argument("--epochs", type=ARG["count"], default=3)
    args = ap.parse_args()
    from steerlab.models.registry import model_class

    model_class(args.model)  # an unknown model refused before the recording
    report = Report(__file__, {"model": args.model, "epochs": args.epochs, "global_batch": 64}, args.json)
    rec = OUT / "recording"
    if not (rec / "recording.json").exists():
        subprocess.run([sys.executable, "-m", "steerlab", "sim", "record", "--seed", "5", "--minutes", "2",
                        "--out", str(rec)], check=True, stdout=subprocess.DEVNULL)
    n = len(open_recording(rec))
    cfg = {"data": str(rec), "cache": str(OUT / "cache"), "split": {"train": f"0:{n - 100}", "val": f"{n - 100}:{n}"},
           "model": {"name": args.model}, "train": {"epochs": args.epochs, "batch_size": 64, "patience": 99}}
    samples = n - 100
    print(f"machine: {machine()}; {args.model}, {samples} training frames, global batch 64, {args.epochs} epochs")
    one = run(cfg, "one", 1)
    two = run(cfg, "two", 2)
    print(f"1 process (2 threads): {samples / one:7.1f} samples/s ({one:.1f} s/epoch)")
    print(f"2 DDP ranks (1 thread each): {samples / two:7.1f} samples/s ({two:.1f} s/epoch); x{one / two:.2f}")
    report.add("data", training_frames=samples)
    report.add("1 process", samples_per_s=samples / one, seconds_per_epoch=one)
    report.add("2 DDP ranks", samples_per_s=samples / two, seconds_per_epoch=two, vs_1_process=one / two)
    report.write()


if __name__ == "__main__":
    guarded(main)
