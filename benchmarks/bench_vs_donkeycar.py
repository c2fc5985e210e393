"""Training speed against donkeycar's own trainer, in one run: donkeycar's linear network on the sixteen track-world
tubs of configs/track_best.yaml, trained for N epochs by `steerlab train configs/track_best.yaml` (steerlab's shipped
recipe: batches of 128, hue, brightness and mirror) and by `donkey train --type linear` in donkeycar's own
environment (TensorFlow; its default config: batches of 128, a random 80 % of the records, no augmentation), one
after the other, each alone on the machine. The two validate on different numbers of records (steerlab on
track_best's held-out block, donkeycar on its random 20 %), so each side's training pass is timed apart from its
validation (steerlab's log.csv, train_seconds; donkeycar's from the lines Keras prints a batch) as well as its whole
epoch (log.csv's seconds; the time between the lines Keras prints at the end of each epoch); the first epoch of
each is left out (TensorFlow traces its graph there, steerlab warms its caches), and the medians of the others are
compared as training records a second. Peak memory is each trainer's peak resident set size (the kernel's count for
its process). The machine line names the CPU's instruction sets. With ../shared, PilotNet on the real CH2 frames
(configs/ch2_pilotnet.yaml) is timed the same way.

python -m benchmarks.bench_vs_donkeycar [--epochs 4] [--json PATH]
Targets: steerlab's training pass <= 1.0x donkeycar's a record (goal 0.6x); its peak memory <= donkeycar's (goal).
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
from dataclasses import dataclass
from pathlib import Path

from benchmarks.common import CH2, ROOT, Report, arguments, machine, record_race_tubs
from steerlab.cli import run_script
from steerlab.options import Options, Range, option
from studies.common.donkeycar import donkey_car, donkey_python


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
    """`steerlab train` for `epochs` epochs: the median epoch and training pass after the first (log.csv's seconds
    and train_seconds), records a second, peak RSS."""
    lines, rss = run([*STEERLAB, config, f"train.epochs={epochs}", f"train.patience={epochs}", f"out={out / 'run'}",
                      *overrides], out / "steerlab.log")
    said = next(line for _, line in lines if line.startswith("training on "))
    frames, validated = (int(n.replace(",", "")) for n in
                         re.search(r"training on ([\d,]+) frames.*validating on ([\d,]+) frames", said).groups())
    with open(out / "run" / "log.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    return timing(frames, validated, [float(r["seconds"]) for r in rows], [float(r["train_seconds"]) for r in rows],
                  rss, lines[-1][0])


def timing(records: int, validated: int, epochs: list[float], passes: list[float], rss: float,
           command_s: float) -> dict:
    """A trainer's figures from its epochs' seconds (the validation included) and its training passes' seconds:
    the medians of the epochs after the first, and records a second of each (training records over seconds)."""
    epoch, train = statistics.median(epochs[1:]), statistics.median(passes[1:])
    return {"records": records, "validation_records": validated, "epoch_s": epoch, "train_pass_s": train,
            "first_epoch_s": epochs[0], "records_per_s": records / epoch, "train_records_per_s": records / train,
            "peak_rss_mb": rss, "command_s": command_s}


def donkeycar_side(tubs: list[Path], epochs: int, out: Path) -> dict:
    """`donkey train --type linear` on `tubs` for `epochs` epochs, as steerlab_side. Keras prints a line a batch
    (`k/N [===...`) and the epoch's last one, N/N, only after the validation; so an epoch's training pass is the
    time from its `Epoch e/E` line to its batch N-1, plus the median time between its batch lines (one batch)."""
    python = donkey_python()
    car = donkey_car(python, out / "car")
    with open(car / "myconfig.py", "a") as f:
        f.write(f"\nMAX_EPOCHS = {epochs}\n")
    lines, rss = run([str(python.parent / "donkey"), "train", "--tub", ",".join(map(str, tubs)), "--model",
                      str(out / "linear.h5"), "--type", "linear", "--framework", "tensorflow"], out / "donkeycar.log",
                     cwd=car)
    records, validated = (int(next(re.search(rf"Records # {kind} (\d+)", line).group(1) for _, line in lines
                                   if f"Records # {kind}" in line)) for kind in ("Training", "Validation"))
    starts = [t for t, line in lines if re.match(r"Epoch \d+/\d+$", line.strip())]
    ends = [t for t, line in lines if re.search(r"\d+/\d+ \[=+\].* - val_loss", line)]
    if len(ends) != epochs or len(starts) != epochs:
        sys.exit(f"donkeycar trained {len(ends)} epochs of {epochs}; see {out / 'donkeycar.log'}")
    passes = []
    for start, end in zip(starts, ends):
        batches = [(t, *map(int, m.groups())) for t, line in lines if start < t < end
                   and (m := re.match(r"(\d+)/(\d+) \[", line.strip()))]
        n = batches[-1][2]
        seen = {k: t for t, k, _ in batches if k < n}  # batch k's line; N/N comes after the validation
        times = [seen[k] for k in sorted(seen)]
        if len(times) < 2 or max(seen) != n - 1:
            sys.exit(f"donkeycar's epoch printed no line for each batch; see {out / 'donkeycar.log'}")
        passes.append(seen[n - 1] - start + statistics.median(b - a for a, b in zip(times, times[1:])))
    seconds = [b - a for a, b in zip([starts[0], *ends], ends)]
    return timing(records, validated, seconds, passes, rss, lines[-1][0])


@dataclass(frozen=True)
class TrainerTiming(Options):
    epochs: int = option(4, Range(2, 100), help="epochs each trainer trains (the first is not counted)")


def parser():
    return arguments(__spec__.name, __doc__, TrainerTiming)


def main(a, args: TrainerTiming) -> None:
    config = ROOT / "configs" / "track_best.yaml"
    report = Report(__file__, {"epochs": args.epochs, "config": "configs/track_best.yaml"}, a.json)  # before any work
    tubs = record_race_tubs(config)
    report.data["settings"]["tubs"] = len(tubs)
    print(f"machine: {machine()}; donkey-linear on {len(tubs)} track tubs, {args.epochs} epochs each")
    with tempfile.TemporaryDirectory() as tmp:
        ours = steerlab_side(str(config), args.epochs, Path(tmp))
        theirs = donkeycar_side(tubs, args.epochs, Path(tmp))
    for name, r in (("steerlab", ours), ("donkeycar", theirs)):
        print(f"  {name:9s}: {r['records']:6d} records an epoch, validated on {r['validation_records']:,}: epoch "
              f"{r['epoch_s']:6.1f} s (first {r['first_epoch_s']:.1f} s), {r['records_per_s']:5.0f} records/s; "
              f"training pass {r['train_pass_s']:6.1f} s, {r['train_records_per_s']:5.0f} records/s; peak memory "
              f"{r['peak_rss_mb']:5.0f} MB")
        report.add(name, **r)
    time_ratio = theirs["records_per_s"] / ours["records_per_s"]
    pass_ratio = theirs["train_records_per_s"] / ours["train_records_per_s"]
    memory_ratio = ours["peak_rss_mb"] / theirs["peak_rss_mb"]
    print(f"  steerlab's time a training record: {pass_ratio:.2f}x donkeycar's in the training pass (target <= 1.0, "
          f"goal <= 0.6), {time_ratio:.2f}x over the whole epoch, each validation included; peak memory "
          f"{memory_ratio:.2f}x (goal <= 1.0)")
    report.add("ratio", train_pass_per_record=pass_ratio, epoch_per_record=time_ratio, peak_memory=memory_ratio)
    if (CH2 / "CH2_final_evaluation.csv").exists():
        with tempfile.TemporaryDirectory() as tmp:
            ch2 = steerlab_side("configs/ch2_pilotnet.yaml", args.epochs, Path(tmp))
        print(f"  PilotNet on CH2 (steerlab): {ch2['records']} records an epoch in {ch2['epoch_s']:.2f} s "
              f"(training pass {ch2['train_pass_s']:.2f} s): {ch2['records_per_s']:.0f} records/s; peak memory "
              f"{ch2['peak_rss_mb']:.0f} MB")
        report.add("pilotnet_ch2", **ch2)
    report.write()


if __name__ == "__main__":
    run_script(parser(), main)
