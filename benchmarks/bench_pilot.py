"""Streaming latency per frame on PyTorch and on ONNX Runtime, for every registered model (untrained weights:
the cost does not depend on them), over 200 real CH2 frames.

Per model and runtime: the whole pilot end to end from the JPEG bytes (decode, crop, resize, flow when the
model takes it, model, smoothing) and the model's own time (JPEG decode and preprocessing excluded), plus the
largest steering difference between the two runtimes on the same frames. The baseline of each ONNX Runtime
number is PyTorch's on the same model and frames, measured in the same run.

python benchmarks/bench_pilot.py [--json PATH]
Targets: the multimodal-lstm pilot at >= 5 x 23 = 115 frames/s (paper 000 reports 23 frames/s for its
Farneback flow alone); ONNX Runtime's model time >= 1.5x faster than torch's for pilotnet, the whole pilot
faster for every model, steering equal to 1e-4 rad.
"""

import tempfile
from pathlib import Path

import cv2
import numpy as np
import torch

from common import CH2, Report, arguments, each_ms, machine, need_ch2, guarded

from steerlab.data.readers import open_recording
from steerlab.evaluate.latency import TimedModel, untrained_checkpoint
from steerlab.export import export_onnx
from steerlab.models import list_models
from steerlab.pilot import Pilot

FRAMES, WARMUP = 200, 20


def checkpoint(folder: Path, name: str, flow: str) -> Path:
    """An untrained checkpoint of model `name` for CH2 frames, its flow computed with `flow`."""
    return untrained_checkpoint(folder, name, "ch2", flow=flow)


def run(model_file: Path, jpegs: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(whole-pilot ms, model ms, steering) per frame after the warm-up."""
    pilot = Pilot(model_file, smoothing=0.2)
    pilot.net = timed = TimedModel(pilot.net)
    # speed: used by multitask-speed only
    ms, controls = each_ms(lambda data: pilot.step(cv2.imdecode(data, cv2.IMREAD_COLOR), speed=10.0), jpegs)
    return ms[WARMUP:], np.array(timed.ms[WARMUP:]), np.array([c.steering for c in controls])


def main() -> None:
    args = arguments(__doc__).parse_args()
    need_ch2()
    report = Report(__file__, {"frames": FRAMES, "warmup": WARMUP, "smoothing": 0.2, "torch_threads": 2}, args.json)
    torch.set_num_threads(2)
    rec = open_recording(CH2, f"0:{FRAMES}", CH2 / "CH2_final_evaluation.csv")
    jpegs = [np.fromfile(p, np.uint8) for p in rec.frames["center"]]
    print(f"machine: {machine()}; {FRAMES} CH2 frames 640x480, JPEG decode included in 'pilot', smoothing a=0.2")
    print(f"{'model':<18} {'torch pilot p50/p99 ms':>22} {'frames/s':>8} {'onnx pilot p50/p99 ms':>22} "
          f"{'frames/s':>8} {'model ms torch/onnx':>20} {'x faster':>8} {'max |diff| rad':>14}")
    rows = [(n, "farneback") for n in list_models()] + [("multimodal-lstm", "dis")]
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, flow in rows:
            pt = checkpoint(Path(tmp), name, flow)
            onnx = export_onnx(pt, Path(tmp) / f"{name}-{flow}.onnx")
            (tp, tm, ts), (op, om, os_) = run(pt, jpegs), run(onnx, jpegs)
            label = name + (" (DIS)" if flow == "dis" else "")
            results[label] = (tp, op, tm, om)
            print(f"{label:<18} {np.percentile(tp, 50):10.2f} / {np.percentile(tp, 99):6.2f}     "
                  f"{1000 / tp.mean():8.1f} {np.percentile(op, 50):10.2f} / {np.percentile(op, 99):6.2f}     "
                  f"{1000 / op.mean():8.1f} {np.median(tm):9.3f} / {np.median(om):7.3f}  "
                  f"{np.median(tm) / np.median(om):8.2f} {np.abs(ts - os_).max():14.2e}")
            report.add(label, torch_pilot_p50_ms=np.percentile(tp, 50), torch_pilot_p99_ms=np.percentile(tp, 99),
                       torch_pilot_fps=1000 / tp.mean(), onnx_pilot_p50_ms=np.percentile(op, 50),
                       onnx_pilot_p99_ms=np.percentile(op, 99), onnx_pilot_fps=1000 / op.mean(),
                       onnx_pilot_vs_torch=np.median(tp) / np.median(op), torch_model_ms=np.median(tm),
                       onnx_model_ms=np.median(om), onnx_model_vs_torch=np.median(tm) / np.median(om),
                       max_steering_diff_rad=np.abs(ts - os_).max())
    tp, op, tm, om = results["pilotnet"]
    print(f"pilotnet model time: ONNX Runtime x{np.median(tm) / np.median(om):.2f} faster than torch (target x1.5)")
    slower = [k for k, (tp, op, _, _) in results.items() if np.median(op) >= np.median(tp)]
    print(f"whole pilot on ONNX Runtime faster for {len(results) - len(slower)} of {len(results)} models"
          + (f"; not for {', '.join(slower)}" if slower else ""))
    tp = results["multimodal-lstm"][0]
    print(f"multimodal-lstm (torch): x{1000 / tp.mean() / 23:.2f} the 23 frames/s of paper 000's flow alone "
          "(target x5)")
    report.add("multimodal-lstm", torch_pilot_vs_paper_flow=1000 / tp.mean() / 23)
    report.write()


if __name__ == "__main__":
    guarded(main)
