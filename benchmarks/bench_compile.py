"""Compile throughput on the real CH2 frames: 200x66 gray + optical flow, Farneback vs DIS, 2 workers vs 1.

python benchmarks/bench_compile.py
"""

import tempfile
import time

from _common import CH2, machine, need_ch2

from steerlab.data.dataset import compile_recording
from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.readers import open_recording


def run(rec, flow: str, workers: int) -> float:
    with tempfile.TemporaryDirectory() as cache:
        cfg = PreprocessConfig.from_dict({"preset": "ch2", "modalities": ["image", "flow"], "flow": flow})
        t = time.perf_counter()
        compile_recording(rec, cfg, cache, workers=workers, progress=False)
        return len(rec) / (time.perf_counter() - t)


def main() -> None:
    need_ch2()
    rec = open_recording(CH2, "0:1200", CH2 / "CH2_final_evaluation.csv")
    run(rec, "dis", 2)  # warm the page cache so every run reads the JPEGs from memory
    fb1, fb2 = run(rec, "farneback", 1), run(rec, "farneback", 2)
    dis2 = run(rec, "dis", 2)
    print(f"machine: {machine()}; {len(rec)} CH2 frames 640x480 -> 200x66 gray + flow")
    print(f"farneback, 1 worker : {fb1:7.1f} frames/s")
    print(f"farneback, 2 workers: {fb2:7.1f} frames/s   (x{fb2 / fb1:.2f} from the second core)")
    print(f"dis,       2 workers: {dis2:7.1f} frames/s   (x{dis2 / fb2:.2f} vs farneback)")


if __name__ == "__main__":
    main()
