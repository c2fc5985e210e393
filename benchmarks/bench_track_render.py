"""Rendered frames per second of the track world through the donkeycar fisheye camera at 160x120 on one core,
against the road world's pinhole renderer with the `donkey` camera at the same size, measured in the same run;
each track in its own room and in the varied one of `sim record --vary` (`Look.draw` of its seed).

python -m benchmarks.bench_track_render [--json PATH]     (target: >= 300 frames/s)
"""

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import cv2  # noqa: E402
import numpy as np  # noqa: E402
from benchmarks.common import Report, arguments, machine, per_second  # noqa: E402

from steerlab.cli import run_script  # noqa: E402
from steerlab.data.fisheye import DONKEY_FISHEYE  # noqa: E402
from steerlab.sim.road.render import Renderer  # noqa: E402
from steerlab.sim.road.road import Road  # noqa: E402
from steerlab.sim.track.look import LOOK, Look  # noqa: E402
from steerlab.sim.track.render import TrackRenderer  # noqa: E402
from steerlab.sim.track.track import Track  # noqa: E402

cv2.setNumThreads(1)
FRAMES, RUNS, TARGET = 1000, 3, 300


def rate(render, poses) -> float:
    """Frames/s of `render(*pose)` over the poses: the median of RUNS passes after one."""
    return per_second(lambda: [render(*p) for p in poses], len(poses), RUNS)


def parser():
    return arguments(__spec__.name, __doc__)


def main(args) -> None:
    report = Report(__file__, {"frames": FRAMES, "runs": RUNS, "size": "160x120", "cores": 1, "target_fps": TARGET},
                    args.json)
    print(f"machine: {machine()}; {FRAMES} frames, median of {RUNS} passes")
    road = Road(1, "twisty", 3000)
    baseline = Renderer(road, "donkey")
    poses = [(*road.pose(10 + 0.9 * i), 10 + 0.9 * i) for i in range(FRAMES)]
    base = rate(baseline.render, poses)
    print(f"road world, donkey pinhole 160x120, one core: {base:6.0f} frames/s (baseline)")
    report.add("road world, donkey pinhole", fps=base)
    for seed, varied in ((seed, varied) for seed in (0, 1, 2, 3) for varied in (False, True)):
        track = Track(seed)
        look = Look.draw(seed) if varied else LOOK
        r = TrackRenderer(track, look.mount(DONKEY_FISHEYE), look=look)
        s = np.linspace(0, 3 * track.length, FRAMES)  # three laps, the camera on the lane centre
        poses = [(*(float(v) for v in track.pose(si)), float(si)) for si in s]
        fps = rate(r.render, poses)
        name = f"track {seed}" + (" varied" if varied else "")
        print(f"{name:14s} ({r.room.floor_kind:8s} {len(r.room.objects):2d} objects), fisheye 160x120, one core: "
              f"{fps:6.0f} frames/s  (x{fps / base:.2f} the baseline, x{fps / TARGET:.2f} the {TARGET} frames/s "
              "target)")
        report.add(name, floor=r.room.floor_kind, objects=len(r.room.objects), fps=fps,
                   vs_baseline=fps / base, vs_target=fps / TARGET)
    report.write()


if __name__ == "__main__":
    run_script(parser(), main)
