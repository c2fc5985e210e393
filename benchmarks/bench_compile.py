"""Compile throughput on the real CH2 frames: 200x66 gray + optical flow, Farneback vs DIS, 2 workers vs 1.
Baselines measured in the same run: Farneback with 1 worker (for the second worker) and Farneback with 2 workers
(for DIS).

python benchmarks/bench_compile.py [--json PATH]
"""

import tempfile

from common import CH2, Report, arguments, machine, need_ch2, guarded, timed

from steerlab.data.dataset import compile_recording
from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.readers import open_recording

FRAMES = "0:1200"


def run(rec, flow: str, workers: int) -> float:
    """Frames/s of compiling `rec` into a fresh cache."""
    with tempfile.TemporaryDirectory() as cache:
        cfg = PreprocessConfig.from_dict({"preset": "ch2", "modalities": ["image", "flow"], "flow": flow})
        return len(rec) / timed(lambda: compile_recording(rec, cfg, cache, workers=workers, progress=False))


def main() -> None:
    args = arguments(__doc__).parse_args()
    need_ch2()
    report = Report(__file__, {"frames": FRAMES, "preset": "ch2", "modalities": ["image", "flow"]}, args.json)
    rec = open_recording(CH2, FRAMES, CH2 / "CH2_final_evaluation.csv")
    run(rec, "dis", 2)  # warm the page cache so every run reads the JPEGs from memory
    fb1, fb2 = run(rec, "farneback", 1), run(rec, "farneback", 2)
    dis2 = run(rec, "dis", 2)
    print(f"machine: {machine()}; {len(rec)} CH2 frames 640x480 -> 200x66 gray + flow")
    print(f"farneback, 1 worker : {fb1:7.1f} frames/s")
    print(f"farneback, 2 workers: {fb2:7.1f} frames/s   (x{fb2 / fb1:.2f} from the second core)")
    print(f"dis,       2 workers: {dis2:7.1f} frames/s   (x{dis2 / fb2:.2f} vs farneback)")
    report.add("farneback, 1 worker", fps=fb1)
    report.add("farneback, 2 workers", fps=fb2, vs_1_worker=fb2 / fb1)
    report.add("dis, 2 workers", fps=dis2, vs_farneback=dis2 / fb2)
    report.write()


if __name__ == "__main__":
    guarded(main)
