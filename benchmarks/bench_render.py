"""Rendered frames per second of the synthetic world at 320x160 on one core.

python benchmarks/bench_render.py     (target: >= 300 frames/s)
"""

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import time  # noqa: E402

import cv2  # noqa: E402

from steerlab.sim.road.render import Renderer  # noqa: E402
from steerlab.sim.road.road import Road  # noqa: E402

cv2.setNumThreads(1)


def main() -> None:
    for kind in ("country", "twisty"):
        road = Road(1, kind, 3000)
        r = Renderer(road, "sim")
        poses = [road.pose(10 + 0.9 * i) for i in range(1000)]
        for p in poses[:50]:
            r.render(*p, 10.0)
        t = time.perf_counter()
        for i, (x, y, psi) in enumerate(poses):
            r.render(x, y, psi, 10 + 0.9 * i)
        fps = len(poses) / (time.perf_counter() - t)
        print(f"{kind:8s} road, 320x160, one core: {fps:6.0f} frames/s  (x{fps / 300:.2f} the 300 frames/s target)")


if __name__ == "__main__":
    main()
