"""Frames per second of a drive in the track world (render + pilot) on one core, with the share of each stage of a
tick, and of the track suite (`steerlab sim bench --world track`, its tracks two at a time on the two cores).

A tick of `sim drive --world track` is: the lane check (`intervene`: is the body off the lane?), the fisheye
render, the pilot (steerlab's donkeycar part: BGR to RGB, preprocessing, the network on PyTorch, the throttle),
the car's physics (`step`) and the loop's own bookkeeping. Each stage is timed inside one drive; the pilot's
network call is timed apart from the rest of the pilot. The checkpoint is donkeycar's linear network trained for
one epoch on the first tub of configs/track_best.yaml (what it drives like does not change what a tick costs);
`--checkpoint` times another.

python benchmarks/bench_track_drive.py [--minutes 1] [--checkpoint PATH] [--json PATH]
Baseline: the render alone (`world.render` in the same drive); the suite against one drive's rate times two.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections import defaultdict  # noqa: E402
from pathlib import Path  # noqa: E402

import cv2  # noqa: E402
from common import ROOT, Report, arguments, machine, record_race_tubs, guarded  # noqa: E402

from steerlab.errors import SteerlabError  # noqa: E402
from steerlab.options import frames_in  # noqa: E402
from steerlab.sim.core.driving import drive_loop  # noqa: E402
from steerlab.sim.core.part import donkey_pilot  # noqa: E402
from steerlab.sim.track.suite import TrackSuiteOptions, run_suite  # noqa: E402
from steerlab.sim.track.world import TrackWorld, camera_of  # noqa: E402

cv2.setNumThreads(1)
MODEL = ROOT / "runs" / "benchmarks" / "track-drive-model"


class Timed:
    """`fn` whose calls add their seconds to `spent[name]`."""

    def __init__(self, fn, name: str, spent: dict):
        self.fn, self.name, self.spent = fn, name, spent

    def __call__(self, *args, **kwargs):
        t = time.perf_counter()
        try:
            return self.fn(*args, **kwargs)
        finally:
            self.spent[self.name] += time.perf_counter() - t


class TimedNet:
    """A Pilot's model (`runtime.TorchModel`) whose calls are timed; everything else passes through."""

    def __init__(self, net, spent: dict):
        self.__dict__["net"], self.__dict__["call"] = net, Timed(net.__call__, "network", spent)

    def __call__(self, *args, **kwargs):
        return self.call(*args, **kwargs)

    def __getattr__(self, name):
        return getattr(self.net, name)


def model(checkpoint: str | None) -> Path:
    if checkpoint:
        return Path(checkpoint)
    if not (MODEL / "best.pt").exists():
        first = record_race_tubs(ROOT / "configs" / "track_best.yaml")[0]
        subprocess.run([sys.executable, "-m", "steerlab", "train", "configs/track_best.yaml", f"data={first}",
                        "extra_data=[]", "train.epochs=1", f"out={MODEL}"], check=True, cwd=ROOT,
                       stdout=subprocess.DEVNULL)
    return MODEL / "best.pt"


def one_drive(checkpoint: Path, minutes: float) -> tuple[float, dict, int]:
    """One drive on suite t1's first taped track (seed 9401) as `sim drive --world track` drives: its frames/s
    and the seconds of each stage."""
    o = TrackSuiteOptions(minutes=minutes).drive_options("taped", 9401)
    spent = defaultdict(float)
    world = TrackWorld(o.seed, o.lane_width, o.style, o.fps, camera_of(o.calibration), o.throttle)
    pilot = donkey_pilot(checkpoint, o.throttle, max_throttle=o.max_throttle)
    part = pilot.part.pilot
    part.net = TimedNet(part.net, spent)
    for name in ("intervene", "render", "step"):
        setattr(world, name, Timed(getattr(world, name), name, spent))
    pilot.step = Timed(pilot.step, "pilot", spent)
    ticks = frames_in(minutes, o.fps)
    start = time.perf_counter()
    t = drive_loop(world, pilot, ticks, o.limit_m, o.fps, progress=False)
    wall = time.perf_counter() - start
    spent["pilot"] -= spent["network"]  # the pilot's own work around its network
    spent["loop"] = wall - sum(spent.values())
    return len(t) / wall, dict(spent), len(t)


def main() -> None:
    p = arguments(__doc__)
    p.add_argument("--minutes", type=float, default=1.0,
                   help="minutes of the drive, and of each suite track (default 1)")
    p.add_argument("--checkpoint", help="the checkpoint to drive (default: one trained here, see above)")
    args = p.parse_args()
    if not 0.05 <= args.minutes <= 60:
        p.error(f"--minutes must be a number from 0.05 to 60, got {args.minutes:g}")
    if args.checkpoint and not Path(args.checkpoint).is_file():
        p.error(f"--checkpoint {args.checkpoint}: no such file (a .pt checkpoint or an exported .onnx)")
    ckpt = model(args.checkpoint)
    report = Report(__file__, {"minutes": args.minutes, "checkpoint": str(ckpt)}, args.json)
    print(f"machine: {machine()}; {ckpt}")
    try:
        one_drive(ckpt, 0.1)  # warm-up: oneDNN's kernels, the page cache
    except SteerlabError as e:  # a checkpoint that is not one, of another camera...
        sys.exit(f"--checkpoint: {e}")
    fps, spent, ticks = one_drive(ckpt, args.minutes)
    total = sum(spent.values())
    print(f"one drive, one core: {ticks} ticks at {fps:.0f} frames/s; render alone {ticks / spent['render']:.0f} "
          "frames/s")
    for name in sorted(spent, key=spent.get, reverse=True):
        print(f"  {name:10s} {1000 * spent[name] / ticks:6.2f} ms a tick  {spent[name] / total:6.1%}")
    report.add("drive", fps=fps, ticks=ticks, **{f"{k}_ms": 1000 * v / ticks for k, v in spent.items()},
               **{f"{k}_share": v / total for k, v in spent.items()})
    o = TrackSuiteOptions(minutes=args.minutes)
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        run_suite([ckpt], out, o, progress=False)
        wall = time.perf_counter() - start
    drives = len(o.drives())
    suite_ticks = drives * frames_in(args.minutes, 20.0)
    print(f"suite {o.suite}: {drives} tracks x {args.minutes:g} min (and the expert's reference laps) in {wall:.1f} s: "
          f"{suite_ticks / wall:.0f} model frames/s on {o.workers} workers (x{suite_ticks / wall / fps:.2f} one drive)")
    report.add("suite", tracks=drives, seconds=wall, fps=suite_ticks / wall, vs_one_drive=suite_ticks / wall / fps)
    report.write()


if __name__ == "__main__":
    guarded(main)
