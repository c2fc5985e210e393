"""End-to-end throughput of the Pilot from JPEG bytes, frame by frame (`Pilot.step`) and pipelined
(`Pilot.stream`), for pilotnet and multimodal-lstm (Farneback flow) on PyTorch and ONNX Runtime, over 200 real
CH2 frames (640x480). Baselines measured in the same run: JPEG decode alone, and `Pilot.step` for `Pilot.stream`.

Every pass decodes, crops, resizes, computes the flow when the model takes it, runs the model and smooths
(a = 0.2); frames/s is the median over REPEATS passes after one warm-up pass. "threads" holds torch, OpenCV
and ONNX Runtime to that many threads (stream() adds its worker threads); stream() must give exactly the
controls of step().

python benchmarks/bench_stream.py [--json PATH]
Targets on 2 cores: stream() end to end >= 650 frames/s for pilotnet and >= 350 for multimodal-lstm.
"""

import os
import tempfile
from pathlib import Path

import cv2
import numpy as np
import torch
from bench_pilot import checkpoint
from common import CH2, Report, arguments, machine, need_ch2, per_second, guarded

from steerlab.data.readers import open_recording
from steerlab.export import export_onnx
from steerlab.pilot import Pilot

FRAMES, REPEATS = 200, 5
TARGETS = {"pilotnet": 650, "multimodal-lstm": 350}


def fps(run) -> float:
    """Median frames/s of `run()` (one pass over the frames) after a warm-up pass."""
    return per_second(run, FRAMES, REPEATS)


def set_threads(n: int) -> None:
    torch.set_num_threads(n)  # ONNX Runtime sessions made afterwards follow torch's count (runtime.OnnxModel)
    cv2.setNumThreads(n)


def main() -> None:
    args = arguments(__doc__).parse_args()
    need_ch2()
    report = Report(__file__, {"frames": FRAMES, "repeats": REPEATS, "smoothing": 0.2, "targets_fps": TARGETS},
                    args.json)
    rec = open_recording(CH2, f"0:{FRAMES}", CH2 / "CH2_final_evaluation.csv")
    jpegs = [np.fromfile(p, np.uint8) for p in rec.frames["center"]]
    speeds = [10.0] * FRAMES
    set_threads(2)
    print(f"machine: {machine()}; load average {os.getloadavg()[0]:.1f} at the start")
    decode = fps(lambda: [cv2.imdecode(j, cv2.IMREAD_COLOR) for j in jpegs])
    print(f"JPEG decode alone (2 OpenCV threads): {decode:.0f} frames/s")
    report.add("JPEG decode", fps=decode)
    print(f"{'model':<16} {'runtime':<7} {'threads':>7} {'step() f/s':>10} {'stream() f/s':>12} {'stream/step':>11} "
          f"{'stream/decode':>13} {'stream/target':>13}")
    best = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, target in TARGETS.items():
            pt = checkpoint(Path(tmp), name, "farneback")
            onnx = export_onnx(pt, Path(tmp) / f"{name}.onnx")
            for runtime, model_file in (("torch", pt), ("onnx", onnx)):
                for threads in (1, 2):
                    set_threads(threads)
                    pilot = Pilot(model_file, smoothing=0.2)

                    def step():
                        pilot.reset()
                        return [pilot.step(j, s) for j, s in zip(jpegs, speeds)]

                    def stream():
                        pilot.reset()
                        return list(pilot.stream(jpegs, speeds))

                    assert stream() == step(), f"{name} on {runtime}: stream() differs from step()"
                    a, b = fps(step), fps(stream)
                    best[name] = max(best.get(name, 0.0), b)
                    print(f"{name:<16} {runtime:<7} {threads:>7} {a:10.0f} {b:12.0f} {b / a:11.2f} {b / decode:13.2f} "
                          f"{b / target:13.2f}")
                    report.add(f"{name} {runtime} {threads} threads", step_fps=a, stream_fps=b, stream_vs_step=b / a,
                               stream_vs_decode=b / decode, stream_vs_target=b / target)
    set_threads(2)
    for name, target in TARGETS.items():
        print(f"{name}: stream() at best {best[name]:.0f} frames/s, x{best[name] / target:.2f} the target {target}")
        report.add(name, best_stream_fps=best[name], best_vs_target=best[name] / target)
    print(f"load average {os.getloadavg()[0]:.1f} at the end (2 cores: above 2 means other work shared them)")
    report.write()


if __name__ == "__main__":
    guarded(main)
