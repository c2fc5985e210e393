"""Streaming latency per frame, end to end from the JPEG bytes of a real CH2 frame (decode, crop, resize,
flow when the model takes it, model, smoothing), for every registered model (untrained weights: the cost
does not depend on them).

python benchmarks/bench_pilot.py
Target: the multimodal-lstm pilot at >= 5 x 23 = 115 frames/s (paper 000 reports 23 frames/s for its
Farneback flow alone).
"""

import time

import cv2
import numpy as np
import torch

from _common import CH2, machine, need_ch2

from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.readers import open_recording
from steerlab.data.recording import SteeringConvention
from steerlab.models import create_model, list_models
from steerlab.pilot import Pilot
from steerlab.train.loop import model_preprocess

FRAMES = 300


def checkpoint(name: str, flow: str) -> dict:
    cfg = PreprocessConfig.from_dict(model_preprocess(name, {"preset": "ch2", "flow": flow}))
    c = sum(cfg.channels().values())
    model_cfg = {"in_channels": c, "height": cfg.height, "width": cfg.width}
    model = create_model(name, **model_cfg)
    return {"format": "steerlab-checkpoint-1", "model": name, "model_cfg": model_cfg,
            "state_dict": model.state_dict(), "preprocess": cfg.as_dict(),
            "stats": {"mean": [0.0] * c, "std": [1.0] * c}, "convention": SteeringConvention().as_dict()}


def run(name: str, jpegs: list[np.ndarray], flow: str = "farneback") -> np.ndarray:
    pilot = Pilot(checkpoint(name, flow), smoothing=0.2)
    times = []
    for data in jpegs:
        t = time.perf_counter()
        pilot.step(cv2.imdecode(data, cv2.IMREAD_COLOR), speed=10.0)  # speed: used by multitask-speed only
        times.append(time.perf_counter() - t)
    return np.array(times[20:]) * 1000  # skip warm-up


def main() -> None:
    need_ch2()
    torch.set_num_threads(2)
    rec = open_recording(CH2, f"0:{FRAMES}", CH2 / "CH2_final_evaluation.csv")
    jpegs = [np.fromfile(p, np.uint8) for p in rec.frames["center"]]
    print(f"machine: {machine()}; {FRAMES} CH2 frames 640x480, JPEG decode included, smoothing a=0.2")
    print(f"{'model':<18} {'p50 ms':>7} {'p99 ms':>7} {'frames/s':>9}")
    rows = [(n, "farneback") for n in list_models()] + [("multimodal-lstm", "dis")]
    for name, flow in rows:
        ms = run(name, jpegs, flow)
        label = name + (" (DIS)" if flow == "dis" else "")
        print(f"{label:<18} {np.percentile(ms, 50):7.2f} {np.percentile(ms, 99):7.2f} {1000 / ms.mean():9.1f}")
    ms = run("multimodal-lstm", jpegs)
    print(f"multimodal-lstm: x{1000 / ms.mean() / 23:.2f} the 23 frames/s of paper 000's flow alone (target x5)")


if __name__ == "__main__":
    main()
