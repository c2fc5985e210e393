"""Rendered frames per second of the road world at 320x160 on one core, against the baseline measured in the same
run: decoding the same frames from JPEG (as `steerlab sim record` writes them, quality 92) on one core, which is
what reading them back from a recording costs. Above x1, rendering a frame is cheaper than reading one.

python benchmarks/bench_render.py [--json PATH]     (target: >= 300 frames/s)
"""

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import cv2  # noqa: E402
from common import Report, arguments, machine, per_second, guarded  # noqa: E402

from steerlab.data.writer import JPEG  # noqa: E402
from steerlab.sim.road.render import Renderer  # noqa: E402
from steerlab.sim.road.road import Road  # noqa: E402

cv2.setNumThreads(1)
FRAMES, RUNS, TARGET = 1000, 3, 300


def main() -> None:
    args = arguments(__doc__).parse_args()
    report = Report(__file__, {"frames": FRAMES, "runs": RUNS, "size": "320x160", "cores": 1, "target_fps": TARGET},
                    args.json)
    print(f"machine: {machine()}; {FRAMES} frames, median of {RUNS} passes")
    for kind in ("country", "twisty"):
        road = Road(1, kind, 3000)
        r = Renderer(road, "sim")
        poses = [(*road.pose(10 + 0.9 * i), 10 + 0.9 * i) for i in range(FRAMES)]
        jpegs = [cv2.imencode(".jpg", r.render(*p), JPEG)[1] for p in poses]
        render = per_second(lambda: [r.render(*p) for p in poses], FRAMES, RUNS)
        decode = per_second(lambda: [cv2.imdecode(j, cv2.IMREAD_COLOR) for j in jpegs], FRAMES, RUNS)
        print(f"{kind:8s} road, 320x160, one core: {render:6.0f} frames/s  (JPEG decode of the same frames "
              f"{decode:6.0f} frames/s: x{render / decode:.2f}; x{render / TARGET:.2f} the {TARGET} frames/s target)")
        report.add(kind, render_fps=render, jpeg_decode_fps=decode, render_vs_decode=render / decode,
                   render_vs_target=render / TARGET)
    report.write()


if __name__ == "__main__":
    guarded(main)
