"""`steerlab experiment`: train several models, several seeds each, on identical splits, and tabulate them in
the form of paper 000 Table I (model, input, input shape, MSE mean +- std, gamma, target gamma)."""

from __future__ import annotations

import copy
import csv
import json
from pathlib import Path

import numpy as np
import yaml

from steerlab.data.preprocess import PreprocessConfig
from steerlab.errors import SteerlabError
from steerlab.evaluate.metrics import exponential_smoothing, steering_metrics
from steerlab.evaluate.plots import plot_steering
from steerlab.evaluate.scoring import read_steering_csv
from steerlab.train.config import load_config
from steerlab.train.loop import model_preprocess, prepare_dataset, train

FIELDS = ["label", "model", "input", "shape", "seeds", "mse_mean", "mse_std", "rmse_mean", "mae_deg_mean",
          "gamma_deg_mean", "target_gamma_deg", "smoothed_rmse_mean", "smoothed_gamma_deg_mean", "epochs_mean",
          "train_s_mean"]
ALPHA = 0.2  # exponential smoothing of paper 002 Eq. 2, reported beside the raw predictions


def run_experiment(path: str | Path, overrides=(), seeds: int = 3, progress: bool = True) -> Path:
    """Every entry of the config's `models` list is a training config fragment (`model`, and optionally
    `label`, `preprocess`, `train`) applied on top of the shared config. Finished runs are reused."""
    raw = yaml.safe_load(Path(path).read_text()) if Path(path).is_file() else None
    if not isinstance(raw, dict) or not isinstance(raw.get("models"), list) or not raw["models"]:
        raise SteerlabError(f"{path}: an experiment config needs a non-empty 'models' list")
    entries = raw.pop("models")
    out = Path(raw.get("out", "runs/experiment"))
    rows, preds = [], {}
    labels = None
    for entry in entries:
        label = entry.get("label", entry["model"]["name"])
        runs = []
        for seed in range(seeds):
            base = copy.deepcopy(raw)
            base["model"] = entry["model"]
            base["preprocess"] = {**raw.get("preprocess", {}), **entry.get("preprocess", {})}
            base["train"] = {**raw.get("train", {}), **entry.get("train", {}), "seed": seed}
            base["out"] = str(out / label / f"seed{seed}")
            cfg = load_config(None, list(overrides), base=base)
            done = Path(cfg["out"]) / "metrics.json"
            if not done.exists():
                if progress:
                    print(f"== {label}, seed {seed}")
                metrics = train(cfg, progress=progress)
                log = Path(cfg["out"]) / "log.csv"
                metrics["train_s"] = sum(float(r["seconds"]) for r in csv.DictReader(open(log))) if log.exists() else 0.0
                done.write_text(json.dumps(metrics, indent=1))
            if labels is None:
                labels = prepare_dataset(cfg, progress=False).labels
            runs.append({**json.loads(done.read_text()), **_smoothed(Path(cfg["out"]), labels)})
        pre = PreprocessConfig.from_dict(model_preprocess(entry["model"]["name"], base["preprocess"]))
        mse = np.array([r["mse"] for r in runs])
        rows.append({
            "label": label, "model": entry["model"]["name"],
            "input": "+".join(pre.modalities) + (f" x{pre.stack} frames" if pre.stack > 1 else "") + f" ({pre.color})",
            "shape": f"{sum(pre.channels().values())}@{pre.width}x{pre.height}", "seeds": seeds,
            "mse_mean": mse.mean(), "mse_std": mse.std(), "rmse_mean": np.mean([r["rmse"] for r in runs]),
            "mae_deg_mean": np.mean([r["mae_deg"] for r in runs]),
            "gamma_deg_mean": np.mean([r["gamma_deg"] for r in runs]), "target_gamma_deg": runs[0]["target_gamma_deg"],
            "smoothed_rmse_mean": np.mean([r["smoothed_rmse"] for r in runs]),
            "smoothed_gamma_deg_mean": np.mean([r["smoothed_gamma_deg"] for r in runs]),
            "epochs_mean": np.mean([r["epoch"] for r in runs]), "train_s_mean": np.mean([r["train_s"] for r in runs]),
        })
        preds[label] = read_steering_csv(out / label / "seed0" / "val_predictions.csv")
    _write(out, rows, preds, cfg)
    return out / "table.md"


def _smoothed(run: Path, labels: dict) -> dict:
    """RMSE and gamma of the run's validation predictions after exponential smoothing, restarted at every
    break in the validation frames (a gap in the split or a new segment)."""
    ids, pred, _ = read_steering_csv(run / "val_predictions.csv")
    pos = {int(f): i for i, f in enumerate(labels["frame_ids"])}
    idx = np.array([pos[int(f)] for f in ids])
    breaks = np.flatnonzero((np.diff(idx) != 1) | (np.diff(labels["segment"][idx]) != 0)) + 1
    smooth = np.concatenate([exponential_smoothing(p, ALPHA) for p in np.split(pred, breaks)])
    m = steering_metrics(smooth, labels["steering"][idx])
    return {"smoothed_rmse": m["rmse"], "smoothed_gamma_deg": m["gamma_deg"]}


def _write(out: Path, rows: list[dict], preds: dict, cfg: dict) -> None:
    with open(out / "table.csv", "w", newline="") as f:
        w = csv.DictWriter(f, FIELDS)
        w.writeheader()
        w.writerows(rows)
    lines = ["| model | input | input shape | MSE (mean +- std) | RMSE | MAE [deg] | gamma [deg] | target gamma [deg] "
             f"| RMSE smoothed a={ALPHA} | gamma smoothed [deg] | best epoch | train time [s] |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['label']} | {r['input']} | {r['shape']} | {r['mse_mean']:.6f} +- {r['mse_std']:.6f} | "
                     f"{r['rmse_mean']:.4f} | {r['mae_deg_mean']:.2f} | {r['gamma_deg_mean']:.3f} | "
                     f"{r['target_gamma_deg']:.3f} | {r['smoothed_rmse_mean']:.4f} | {r['smoothed_gamma_deg_mean']:.3f} | "
                     f"{r['epochs_mean']:.1f} | {r['train_s_mean']:.0f} |")
    lines.append(f"\n{rows[0]['seeds']} seed(s) per model; validation split {cfg['split']}; plot: predictions.png (seed 0)\n")
    (out / "table.md").write_text("\n".join(lines))
    ds = prepare_dataset(cfg, progress=False)
    ids = next(iter(preds.values()))[0]
    pos = {int(f): i for i, f in enumerate(ds.labels["frame_ids"])}
    idx = np.array([pos[int(f)] for f in ids])
    t = (ds.labels["timestamps_ns"][idx] - ds.labels["timestamps_ns"][idx[0]]) / 1e9
    plot_steering(out / "predictions.png", t, ds.steering[idx], {k: v[1] for k, v in preds.items()},
                  title="validation predictions, seed 0")
