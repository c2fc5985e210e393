"""donkeycar's linear model and steerlab's tub default, trained on the same track-world tubs, raced on the track
suite.

The tubs: the racing expert on tracks 1-4 for 3 minutes each (`steerlab sim record --world track`; recorded here
where they are missing). steerlab's tub default is trained on them with `configs/track_default.yaml` (or give
`--checkpoint`); donkeycar's linear model with donkeycar's own trainer (`donkey train --type linear`, its default
config: a random 80/20 split, early stopping), in donkeycar's own environment ($DONKEY_VENV, made on first use:
`common.donkey_python`). Both race the track suite (`steerlab sim bench --world track`: 8 unseen tracks)
through a donkeycar part: steerlab's own `SteerlabPilot`, and donkeycar's `KerasLinear` run in its environment
behind a pipe (`_donkey_part.py`). Both drive with their learned throttle, capped at `--max-throttle` (1: uncapped,
as donkeycar drives its pilot with `AI_THROTTLE_MULT` 1; 0.5: `SteerlabPilot`'s default on a real car). The
tables (suite-max<cap>/both.md) and plots (suite-max<cap>/tracks/*.png): laps, clean laps, lap time against the
expert's, off-track events.

python studies/donkeycar_on_track.py [--checkpoint runs/track/default/best.pt] [--max-throttle 1] [--minutes 2]
    [--workers 1]
Finished drives are kept in runs/donkeycar-track/suite-max<cap> and reused.
"""

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from common import ROOT, donkey_car, donkey_python, track_tubs  # noqa: E402

from steerlab.data.car import CARS  # noqa: E402
from steerlab.sim.core.part import PartPilot  # noqa: E402
from steerlab.sim.core.suite import from_json, labels_for, write_csv  # noqa: E402
from steerlab.sim.track.plots import plot_tracks  # noqa: E402
from steerlab.sim.track.run import TrackDrive, drive  # noqa: E402
from steerlab.sim.track.suite import (EXPERT, TRACK_SUITES, TrackSuiteOptions, drive_row, markdown,  # noqa: E402
                                      run_suite, summarize)
from steerlab.train.config import load_config  # noqa: E402
from steerlab.train.loop import train  # noqa: E402

OUT = ROOT / "runs" / "donkeycar-track"
LABEL = "donkeycar-linear"


class DonkeycarPart:
    """donkeycar's own pilot part for `model`, run in donkeycar's environment: `run(img_arr)` sends the frame
    down a pipe and returns the part's (angle, throttle)."""

    def __init__(self, python: Path, car: Path, model: Path, log: Path, max_throttle: float):
        self.log, self.max_throttle = log, max_throttle
        self.process = subprocess.Popen([str(python), str(Path(__file__).with_name("_donkey_part.py")),
                                         str(car / "config.py"), str(model), "linear"], cwd=car,
                                        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=open(log, "wb"))
        if self.process.stdout.readline() != b"ready\n":
            raise RuntimeError(f"donkeycar's part did not start; see {log}")

    def run(self, img_arr: np.ndarray):
        self.process.stdin.write(np.ascontiguousarray(img_arr, np.uint8).tobytes())
        self.process.stdin.flush()
        answer = self.process.stdout.read(16)
        if len(answer) != 16:
            raise RuntimeError(f"donkeycar's part stopped; see {self.log}")
        angle, throttle = (float(v) for v in np.frombuffer(answer, np.float64))
        return angle, float(np.clip(throttle, -self.max_throttle, self.max_throttle))

    def close(self) -> None:
        self.process.stdin.close()
        self.process.wait()


def read_drive(folder: Path) -> TrackDrive:
    """A finished drive's result from its drive.json."""
    return from_json(TrackDrive, json.loads((folder / "drive.json").read_text()))


def donkey_model(python: Path, tubs: list[Path]) -> tuple[Path, Path]:
    """donkeycar's linear model trained by `donkey train` on `tubs` (once); its car folder and model file."""
    car, model = donkey_car(python, OUT / "car"), OUT / "linear.h5"
    if not model.exists():
        print("training donkeycar's linear model (donkey train)", flush=True)
        with open(OUT / "train-linear.log", "w") as log:
            subprocess.run([str(python.parent / "donkey"), "train", "--tub", ",".join(map(str, tubs)), "--model",
                            str(model), "--type", "linear", "--framework", "tensorflow"], cwd=car, check=True,
                           stdout=log, stderr=subprocess.STDOUT)
    return car, model


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--checkpoint", help="steerlab's model (default: configs/track_default.yaml trained into "
                    "runs/track/default)")
    ap.add_argument("--minutes", type=float, default=None, help="minutes per track (default: the suite's, 2)")
    ap.add_argument("--workers", type=int, default=1, help="tracks steerlab drives in parallel")
    ap.add_argument("--max-throttle", type=float, default=1.0, help="the cap of both models' learned throttle")
    args = ap.parse_args()
    if args.checkpoint and not Path(args.checkpoint).is_file():
        sys.exit(f"error: {args.checkpoint}: checkpoint not found")
    tubs = track_tubs()
    python = donkey_python()
    OUT.mkdir(parents=True, exist_ok=True)
    car, model = donkey_model(python, tubs)
    checkpoint = Path(args.checkpoint or ROOT / "runs" / "track" / "default" / "best.pt")
    if not checkpoint.exists():  # the default: trained once
        train(load_config(ROOT / "configs" / "track_default.yaml", [f"out={checkpoint.parent}"]), progress=False)
    o = TrackSuiteOptions(minutes=args.minutes, workers=args.workers, max_throttle=args.max_throttle)
    suite = OUT / f"suite-max{args.max_throttle:g}"
    run_suite([checkpoint], suite, o, plots=False)  # steerlab's drives and the expert's
    label = labels_for([checkpoint])[0]
    full_lock = CARS["donkey"].full_lock_deg
    drives = []
    for style, seed in o.drives():
        folder = suite / LABEL / f"{style}-{seed}"
        if not (folder / "drive.json").exists():
            part = DonkeycarPart(python, car, model, OUT / "part.log", args.max_throttle)
            try:
                drive(PartPilot(part, full_lock, name=LABEL, source=str(model)), folder, o.drive_options(style, seed),
                      progress=False)
            finally:
                part.close()
            print(f"  {LABEL} drove {style}-{seed}", flush=True)
        expert = read_drive(suite / EXPERT / f"{style}-{seed}")
        for name, ckpt in ((label, checkpoint), (LABEL, model)):
            drives.append(drive_row(read_drive(suite / name / f"{style}-{seed}"), expert, name, str(ckpt), style, seed))
    drives.sort(key=lambda d: d.label != label)
    summary = summarize(drives)
    write_csv(suite / "both.csv", drives)
    write_csv(suite / "both-summary.csv", summary)
    table = markdown(summary, drives, o)
    (suite / "both.md").write_text(table)
    plot_tracks(suite, drives, TRACK_SUITES[o.suite]["lane_width"], EXPERT)  # tracks/<style>-<seed>.png: both lines
    print(table)


if __name__ == "__main__":
    main()
