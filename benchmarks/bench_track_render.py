"""Rendered frames per second of the track world through the donkeycar fisheye camera at 160x120 on one core,
against the road world's pinhole renderer with the `donkey` camera at the same size, measured in the same run.

python benchmarks/bench_track_render.py [--json PATH]     (target: >= 300 frames/s)
"""

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import cv2  # noqa: E402
import numpy as np  # noqa: E402
from common import Report, arguments, machine, per_second, guarded  # noqa: E402

from steerlab.sim.road.render import Renderer  # noqa: E402
from steerlab.sim.road.road import Road  # noqa: E402
from steerlab.sim.track.render import TrackRenderer  # noqa: E402
from steerlab.sim.track.track import Track  # noqa: E402

cv2.setNumThreads(1)
FRAMES, RUNS, TARGET = 1000, 3, 300


def rate(render, poses) -> float:
    """Frames/s of `render(*pose)` over the poses: the median of RUNS passes after one."""
    return per_second(lambda: [render(*p) for p in poses], len(poses), RUNS)


def main() -> None:
    args = arguments(__doc__).parse_args()
    report = Report(__file__, {"frames": FRAMES, "runs": RUNS, "size": "160x120", "cores": 1, "target_fps": TARGET},
                    args.json)
    print(f"machine: {machine()}; {FRAMES} frames, median of {RUNS} passes")
    road = Road(1, "twisty", 3000)
    baseline = Renderer(road, "donkey")
    poses = [(*road.pose(10 + 0.9 * i), 10 + 0.9 * i) for i in range(FRAMES)]
    base = rate(baseline.render, poses)
    print(f"road world, donkey pinhole 160x120, one core: {base:6.0f} frames/s (baseline)")
    report.add("road world, donkey pinhole", fps=base)
    for seed in (0, 1, 2, 3):
        track = Track(seed)
        r = TrackRenderer(track)
        s = np.linspace(0, 3 * track.length, FRAMES)  # three laps, the camera on the lane centre
        poses = [(*(float(v) for v in track.pose(si)), float(si)) for si in s]
        fps = rate(r.render, poses)
        print(f"track {seed} ({r.room.floor_kind:8s} {len(r.room.objects):2d} objects), fisheye 160x120, one core: "
              f"{fps:6.0f} frames/s  (x{fps / base:.2f} the baseline, x{fps / TARGET:.2f} the {TARGET} frames/s "
              "target)")
        report.add(f"track {seed}", floor=r.room.floor_kind, objects=len(r.room.objects), fps=fps,
                   vs_baseline=fps / base, vs_target=fps / TARGET)
    report.write()


if __name__ == "__main__":
    guarded(main)
