"""Training speed against donkeycar's own trainer, in one run: donkeycar's linear network on the sixteen track-world
tubs of configs/track_best.yaml, trained for N epochs by `steerlab train configs/track_best.yaml` (steerlab's shipped
recipe: batches of 128, hue, brightness and mirror) and by `donkey train --type linear` in donkeycar's own
environment (TensorFlow; its default config: batches of 128, a random 80 % of the records, no augmentation), one
after the other, each alone on the machine. Each side's epoch is its training pass plus its validation (steerlab's
log.csv; the time between the lines Keras prints at the end of each epoch); the first epoch of each is left out
(TensorFlow traces its graph there, steerlab warms its caches), and the median of the others is compared as
training records a second. Peak memory is each trainer's peak resident set size (the kernel's count for its
process). With ../shared, PilotNet on the real CH2 frames (configs/ch2_pilotnet.yaml) is timed the same way.

python benchmarks/bench_vs_donkeycar.py [--epochs 4] [--json PATH]
Targets: steerlab's epoch <= 1.0x donkeycar's a record (goal 0.6x); its peak memory <= donkeycar's (goal).
"""

from __future__ import annotations

import csv
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import CH2, ROOT, Report, arguments, donkey_car, donkey_python, machine, record_race_tubs, guarded


STEERLAB = [sys.executable, "-m", "steerlab", "train"]


def run(cmd: list[str], log: Path, cwd: Path | None = None) -> tuple[list[tuple[float, str]], float]:
    """Run `cmd` alone, its output into `log`; returns its lines with the seconds at which each arrived, and its
    peak resident set size in MB."""
    lines, start = [], time.perf_counter()
    with open(log, "w") as f:
        p = subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                             env={**os.environ, "PYTHONUNBUFFERED": "1"})
        for line in p.stdout:
            lines.append((time.perf_counter() - start, line))
            f.write(line)
        _, status, usage = os.wait4(p.pid, 0)
    if status:
        sys.exit(f"{' '.join(map(str, cmd[:4]))} ... failed; see {log}")
    return lines, usage.ru_maxrss / 1024


def steerlab_side(config: str, epochs: int, out: Path, overrides: list[str] = ()) -> dict:
    """`steerlab train` for `epochs` epochs: records a second over the epochs after the first, peak RSS."""
    lines, rss = run([*STEERLAB, config, f"train.epochs={epochs}", f"train.patience={epochs}", f"out={out / 'run'}",
                      *overrides], out / "steerlab.log")
    said = next(line for _, line in lines if line.startswith("training on "))
    frames = int(re.search(r"training on ([\d,]+) frames", said).group(1).replace(",", ""))
    with open(out / "run" / "log.csv", newline="") as f:
        seconds = [float(r["seconds"]) for r in csv.DictReader(f)]
    return {"records": frames, "epoch_s": statistics.median(seconds[1:]), "first_epoch_s": seconds[0],
            "records_per_s": frames / statistics.median(seconds[1:]), "peak_rss_mb": rss,
            "command_s": lines[-1][0]}


def donkeycar_side(tubs: list[Path], epochs: int, out: Path) -> dict:
    """`donkey train --type linear` on `tubs` for `epochs` epochs, as steerlab_side."""
    python = donkey_python()
    car = donkey_car(python, out / "car")
    with open(car / "myconfig.py", "a") as f:
        f.write(f"\nMAX_EPOCHS = {epochs}\n")
    lines, rss = run([str(python.parent / "donkey"), "train", "--tub", ",".join(map(str, tubs)), "--model",
                      str(out / "linear.h5"), "--type", "linear", "--framework", "tensorflow"], out / "donkeycar.log",
                     cwd=car)
    records = int(next(re.search(r"Records # Training (\d+)", line).group(1) for _, line in lines
                       if "Records # Training" in line))
    starts = [t for t, line in lines if re.match(r"Epoch 1/\d+", line)][:1]
    ends = [t for t, line in lines if re.search(r"\d+/\d+ \[=+\].* - val_loss", line)]
    if len(ends) != epochs or not starts:
        sys.exit(f"donkeycar trained {len(ends)} epochs of {epochs}; see {out / 'donkeycar.log'}")
    seconds = [b - a for a, b in zip(starts + ends, ends)]
    return {"records": records, "epoch_s": statistics.median(seconds[1:]), "first_epoch_s": seconds[0],
            "records_per_s": records / statistics.median(seconds[1:]), "peak_rss_mb": rss,
            "command_s": lines[-1][0]}


def main() -> None:
    p = arguments(__doc__)
    p.add_argument("--epochs", type=int, default=4, metavar="N",
                   help="epochs each trainer trains (2-100; the first is not counted; default 4)")
    args = p.parse_args()
    if not 2 <= args.epochs <= 100:
        p.error(f"--epochs must be an integer from 2 to 100 (the first epoch is not counted), got {args.epochs}")
    config = ROOT / "configs" / "track_best.yaml"
    tubs = record_race_tubs(config)
    report = Report(__file__, {"epochs": args.epochs, "tubs": len(tubs), "config": "configs/track_best.yaml"},
                    args.json)
    print(f"machine: {machine()}; donkey-linear on {len(tubs)} track tubs, {args.epochs} epochs each")
    with tempfile.TemporaryDirectory() as tmp:
        ours = steerlab_side(str(config), args.epochs, Path(tmp))
        theirs = donkeycar_side(tubs, args.epochs, Path(tmp))
    for name, r in (("steerlab", ours), ("donkeycar", theirs)):
        print(f"  {name:9s}: {r['records']:6d} records an epoch in {r['epoch_s']:6.1f} s (first "
              f"{r['first_epoch_s']:.1f} s): {r['records_per_s']:5.0f} records/s; "
              f"peak memory {r['peak_rss_mb']:5.0f} MB")
        report.add(name, **r)
    time_ratio = theirs["records_per_s"] / ours["records_per_s"]
    memory_ratio = ours["peak_rss_mb"] / theirs["peak_rss_mb"]
    print(f"  steerlab's epoch a record: {time_ratio:.2f}x donkeycar's (target <= 1.0, goal <= 0.6); "
          f"peak memory {memory_ratio:.2f}x (goal <= 1.0)")
    report.add("ratio", epoch_per_record=time_ratio, peak_memory=memory_ratio)
    if (CH2 / "CH2_final_evaluation.csv").exists():
        with tempfile.TemporaryDirectory() as tmp:
            ch2 = steerlab_side("configs/ch2_pilotnet.yaml", args.epochs, Path(tmp))
        print(f"  PilotNet on CH2 (steerlab): {ch2['records']} records an epoch in {ch2['epoch_s']:.2f} s: "
              f"{ch2['records_per_s']:.0f} records/s; peak memory {ch2['peak_rss_mb']:.0f} MB")
        report.add("pilotnet_ch2", **ch2)
    report.write()


if __name__ == "__main__":
    guarded(main)
