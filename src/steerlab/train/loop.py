"""The training loop: `train(cfg)` reads as prepare data -> train_one_epoch / evaluate -> checkpoints.

Batches are gathered from the memory-mapped cache; validation uses the same cache. The best checkpoint
(lowest validation RMSE) is `best.pt`; `last.pt` also holds the optimiser and RNG state, so a run that is
interrupted continues where it stopped when started again with the same config.
"""

from __future__ import annotations

import csv
import json
import time
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from steerlab.data.dataset import CompiledDataset, compile_recording
from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.readers import open_recording
from steerlab.data.recording import SteeringConvention
from steerlab.data.splits import make_split
from steerlab.errors import SteerlabError
from steerlab.evaluate.metrics import steering_metrics
from steerlab.evaluate.scoring import write_predictions
from steerlab.models import create_model, model_class
from steerlab.train.checkpoint import save_checkpoint
from steerlab.train.inputs import (Standardizer, channel_stats, flip_horizontal, gather, segment_starts,
                                   stack_modalities)

LOG_FIELDS = ["epoch", "train_loss", "val_mse", "val_rmse", "val_mae_deg", "val_gamma_deg", "seconds"]


def prepare_dataset(cfg: dict, progress: bool = True, camera: str | None = None) -> CompiledDataset:
    rec = open_recording(cfg["data"], cfg.get("range"), cfg.get("labels"))
    camera = camera or cfg.get("camera", "center")
    if camera not in rec.frames:
        raise SteerlabError(f"{rec.source} has no {camera!r} camera (it has {', '.join(rec.cameras)})")
    pre_cfg = dict(cfg.get("preprocess") or {})
    if "crop" not in pre_cfg:
        pre_cfg.setdefault("preset", rec.preset)
    return compile_recording(rec, PreprocessConfig.from_dict(pre_cfg), cfg["cache"], camera, progress=progress)


def model_preprocess(name: str, preprocess: dict | None) -> dict:
    """The config's preprocessing completed with what the model needs (its `inputs`)."""
    pre = dict(preprocess or {})
    for key, value in getattr(model_class(name), "inputs", {}).items():
        if key in pre and pre[key] != value:
            raise SteerlabError(f"model {name!r} needs preprocess {key}={value}, the config sets {pre[key]}")
        pre[key] = value
    return pre


def training_indices(ds: CompiledDataset, idx: np.ndarray, exclude_episodes) -> np.ndarray:
    if exclude_episodes:
        if "episode" not in ds.labels:
            raise SteerlabError("exclude_episodes needs a recording with episode labels (the synthetic world's)")
        idx = idx[~np.isin(ds.labels["episode"][idx], list(exclude_episodes))]
    if len(idx) == 0:
        raise SteerlabError("the training split is empty")
    return idx


class Batches:
    """Gathers standardised batches from the cache.

    Each source is a compiled camera stream with its own steering labels (the centre camera, and with
    side-camera synthesis the left and right ones); a sample is coded as source * N + frame. Samples come back
    in the order asked for; each source is read in sorted order so that the memory-mapped reads run forward."""

    def __init__(self, sources: list[tuple[CompiledDataset, np.ndarray]], stats: dict):
        self.sources, self.cfg, self.standardize = sources, sources[0][0].config, Standardizer(stats)
        self.n = len(sources[0][0])
        self.starts = segment_starts(sources[0][0].labels["segment"])  # all sources share the timeline

    def get(self, codes: np.ndarray, flip: np.ndarray | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        order = np.argsort(codes, kind="stable")
        x = y = None
        for k, (ds, steering) in enumerate(self.sources):
            pos = order[(codes[order] // self.n) == k]
            if len(pos):
                idx = codes[pos] % self.n
                part = stack_modalities(gather(ds.arrays, self.cfg, idx, self.starts), self.cfg)
                if x is None:
                    x, y = np.empty((len(codes),) + part.shape[1:], np.float32), np.empty(len(codes), np.float32)
                x[pos], y[pos] = part, steering[idx]
        if flip is not None and flip.any():
            x[flip] = flip_horizontal(x[flip], self.cfg)
            y[flip] *= -1
        return self.standardize(x), torch.from_numpy(y)


def side_camera_labels(ds: CompiledDataset, offset_m: float, recovery_s: float, ratio: float) -> np.ndarray:
    """Paper 002 Eq. 3: a camera d_y metres to the LEFT sees the view of a car that must steer back right:
    theta_f = theta_r - arctan(d_y / (speed * t_r)) as a road-wheel angle (positive left); converted back to
    the recording's convention (steering-wheel recordings use the vehicle's steering ratio)."""
    if "speed" not in ds.labels:
        raise SteerlabError("side-camera synthesis needs the speed signal (paper 002 Eq. 3)")
    conv = SteeringConvention(**ds.meta["convention"])
    speed = np.maximum(ds.labels["speed"], 1.0)
    correction = -np.arctan(offset_m / (speed * recovery_s))
    return ds.steering + conv.from_road_wheel_left(correction, ratio)


def sequence_windows(codes: np.ndarray, n: int, starts: np.ndarray, length: int) -> np.ndarray:
    """Windows (M, length) of consecutive frames that lie inside the sample set and inside one segment,
    starting every `length` frames, so an epoch sees each frame about once."""
    all_codes = np.sort(codes)
    codes = all_codes[(all_codes % n) % length == 0]
    w = codes[:, None] + np.arange(length)
    inside = np.isin(w, all_codes).all(axis=1)
    frame = w % n
    same = (w // n == w[:, :1] // n).all(axis=1) & (starts[frame] == starts[frame[:, :1]]).all(axis=1)
    return w[inside & same]


def objective(model, x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    """The model's own loss when it has one, otherwise the MSE of its steering."""
    if hasattr(model, "loss"):
        return model.loss(x, y)
    pred = model(x)
    pred = pred[0] if isinstance(pred, tuple) else pred  # recurrent models also return their state
    return torch.mean((pred - y) ** 2)


def train_one_epoch(model, opt, batches: Batches, samples: np.ndarray, batch_size: int, flip: bool,
                    rng: np.random.Generator, progress: bool = True, desc: str = "") -> float:
    """One pass over `samples`: frame codes (M,), or windows (M, T) of frame codes for recurrent models."""
    model.train()
    order = rng.permutation(len(samples))
    total, count = 0.0, 0
    steps = range(0, len(order), batch_size)
    for s in tqdm(steps, desc=desc, unit="batch", leave=False, disable=None if progress else True):
        b = samples[order[s: s + batch_size]]
        flips = np.repeat(rng.random(len(b)) < 0.5, b[0].size) if flip else None
        x, y = batches.get(b.ravel(), flips)
        if b.ndim == 2:  # windows: (B*T, C, H, W) -> (B, T, C, H, W)
            x, y = x.view(len(b), b.shape[1], *x.shape[1:]), y.view(len(b), b.shape[1])
        loss = objective(model, x, y)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        total += float(loss.detach()) * len(b)
        count += len(b)
    return total / count


@torch.inference_mode()
def predict(model, batches: Batches, idx: np.ndarray, batch_size: int = 256) -> np.ndarray:
    """Predictions for frames `idx` (in time order). Recurrent models run statefully through each contiguous
    run of frames, from a zero state at the start of the run and at every segment start, as the Pilot does."""
    model.eval()
    if not getattr(model, "recurrent", False):
        out = [model(batches.get(idx[s: s + batch_size])[0]).numpy() for s in range(0, len(idx), batch_size)]
        return np.concatenate(out).astype(np.float64)
    out = []
    breaks = np.flatnonzero((np.diff(idx) != 1) | (batches.starts[idx[1:]] == idx[1:])) + 1
    for run in np.split(idx, breaks):
        state = None
        for s in range(0, len(run), batch_size):
            x = batches.get(run[s: s + batch_size])[0]
            y, state = model(x[None], state)
            out.append(y[0].numpy())
    return np.concatenate(out).astype(np.float64)


def train(cfg: dict, progress: bool = True) -> dict:
    """Train one model as configured; returns the best validation metrics. Resumes from `out/last.pt`."""
    out = Path(cfg["out"])
    out.mkdir(parents=True, exist_ok=True)
    tc = cfg["train"]
    cfg_file = out / "config.json"
    if (out / "last.pt").exists():
        if not cfg_file.exists() or json.loads(cfg_file.read_text()) != json.loads(json.dumps(cfg)):
            raise SteerlabError(f"{out} holds a run with another config; choose a new out directory or delete it")
    cfg_file.write_text(json.dumps(cfg, indent=1))

    cfg = {**cfg, "preprocess": model_preprocess(cfg["model"]["name"], cfg.get("preprocess"))}
    ds = prepare_dataset(cfg, progress)
    train_idx, val_idx = make_split(cfg["split"], len(ds))
    train_idx = training_indices(ds, train_idx, tc.get("exclude_episodes"))
    stats = channel_stats(ds.arrays, ds.config, train_idx, segment_starts(ds.labels["segment"]))
    sources = [(ds, ds.steering)]
    if tc.get("side_cameras"):
        for cam, sign in (("left", 1.0), ("right", -1.0)):
            side = prepare_dataset(cfg, progress, camera=cam)
            sources.append((side, side_camera_labels(side, sign * float(tc["side_offset_m"]),
                                                     float(tc["recovery_s"]), float(tc["steering_ratio"]))))
        train_idx = np.concatenate([train_idx + k * len(ds) for k in range(3)])
    batches = Batches(sources, stats)
    torch.manual_seed(int(tc["seed"]))
    samples = train_idx
    model_cfg = {k: v for k, v in cfg["model"].items() if k != "name"}
    model_cfg.update(in_channels=sum(ds.config.channels().values()), height=ds.config.height, width=ds.config.width)
    model = create_model(cfg["model"]["name"], **model_cfg)
    if getattr(model, "recurrent", False):
        samples = sequence_windows(train_idx, len(ds), batches.starts, model.seq_len)
        if len(samples) == 0:
            raise SteerlabError(f"no training window of {model.seq_len} consecutive frames in one segment")
    if all(p.dim() != 5 for p in model.parameters()):  # channels-last exists for 2-D convolutions only
        model = model.to(memory_format=torch.channels_last)
    convention = SteeringConvention(**ds.meta["convention"])
    y_val = ds.steering[val_idx]

    def checkpoint(path, metrics, **extra):
        save_checkpoint(path, model, model_cfg, ds.config, stats, convention, metrics,
                        preset=ds.meta["preset"], frame_rate=ds.meta["frame_rate"], **extra)

    if not getattr(model, "trainable", True):
        model.fit(np.concatenate([labels for _, labels in sources])[train_idx])
        pred = predict(model, batches, val_idx)
        metrics = {**steering_metrics(pred, y_val), "epoch": 0}
        checkpoint(out / "best.pt", metrics)
        write_predictions(out / "val_predictions.csv", ds.labels["frame_ids"][val_idx], pred)
        return metrics

    opt = torch.optim.Adam(model.parameters(), lr=float(tc["lr"]))
    start, best, since_best, history = 1, None, 0, []
    if (out / "last.pt").exists():
        state = torch.load(out / "last.pt", map_location="cpu", weights_only=False)
        model.load_state_dict(state["state_dict"])
        opt.load_state_dict(state["optimizer"])
        start, best, since_best, history = state["epoch"] + 1, state["best"], state["since_best"], state["history"]
        torch.set_rng_state(state["torch_rng"])
        print(f"resuming {out} after epoch {state['epoch']}")
    log_path = out / "log.csv"
    with open(log_path, "w", newline="") as f:  # rewritten from history so a resumed log has no duplicates
        w = csv.DictWriter(f, LOG_FIELDS)
        w.writeheader()
        w.writerows(history)

    for epoch in range(start, int(tc["epochs"]) + 1):
        if since_best >= int(tc["patience"]):
            break
        t0 = time.time()
        rng = np.random.default_rng([int(tc["seed"]), epoch])
        loss = train_one_epoch(model, opt, batches, samples, int(tc["batch_size"]), bool(tc["flip"]), rng,
                               progress, desc=f"epoch {epoch}")
        pred = predict(model, batches, val_idx)
        m = steering_metrics(pred, y_val)
        row = {"epoch": epoch, "train_loss": loss, "val_mse": m["mse"], "val_rmse": m["rmse"],
               "val_mae_deg": m["mae_deg"], "val_gamma_deg": m["gamma_deg"], "seconds": round(time.time() - t0, 2)}
        history.append(row)
        with open(log_path, "a", newline="") as f:
            csv.DictWriter(f, LOG_FIELDS).writerow(row)
        if progress:
            print(f"epoch {epoch}: train mse {loss:.5f}  val rmse {m['rmse']:.4f}  mae {m['mae_deg']:.2f} deg  "
                  f"gamma {m['gamma_deg']:.3f} (target {m['target_gamma_deg']:.3f})")
        if best is None or m["rmse"] < best["rmse"]:
            best, since_best = {**m, "epoch": epoch}, 0
            checkpoint(out / "best.pt", best)
            write_predictions(out / "val_predictions.csv", ds.labels["frame_ids"][val_idx], pred)
        else:
            since_best += 1
        checkpoint(out / "last.pt", best, optimizer=opt.state_dict(), epoch=epoch, best=best,
                   since_best=since_best, history=history, torch_rng=torch.get_rng_state())
    return best
