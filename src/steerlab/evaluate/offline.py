"""Open-loop evaluation of a checkpoint on a recording, frame by frame through the Pilot."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from tqdm import tqdm

from steerlab.data.readers import open_recording
from steerlab.evaluate.metrics import exponential_smoothing, steering_metrics
from steerlab.evaluate.plots import plot_steering
from steerlab.evaluate.scoring import write_predictions
from steerlab.pilot import Pilot


def evaluate(checkpoint: str | Path, data: str | Path, frame_range: str | None, out: str | Path,
             labels: str | Path | None = None, camera: str = "center", progress: bool = True) -> dict:
    """Run the Pilot over every frame (resetting at segment starts); write metrics, predictions and a plot."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rec = open_recording(data, frame_range, labels)
    pilot = Pilot(checkpoint)
    seg = rec.segment_ids()
    pred = np.empty(len(rec))
    for i in tqdm(range(len(rec)), desc="evaluate", unit="frame", disable=None if progress else True):
        if i > 0 and seg[i] != seg[i - 1]:
            pilot.reset()
        pred[i] = pilot.step(rec.load_frame(i, camera))
    metrics = steering_metrics(pred, rec.steering)
    smooth = np.concatenate([exponential_smoothing(pred[a:b], 0.2) for a, b in rec.segments()])
    metrics["smoothed_a0.2"] = steering_metrics(smooth, rec.steering)
    write_predictions(out / "predictions.csv", rec.frame_ids, pred)
    t = (rec.timestamps_ns - rec.timestamps_ns[0]) / 1e9
    plot_steering(out / "steering.png", t, rec.steering, {pilot.name: pred},
                  title=f"{rec.name} {frame_range or ''}: RMSE {metrics['rmse']:.4f} rad, "
                        f"gamma {metrics['gamma_deg']:.3f} vs target {metrics['target_gamma_deg']:.3f} deg")
    (out / "metrics.json").write_text(json.dumps(metrics, indent=1))
    return metrics
