"""The training loop: `train(cfg)` reads as prepare data -> train_one_epoch / evaluate -> checkpoints.

Batches are gathered from the memory-mapped cache; validation uses the same cache. The best checkpoint
(lowest validation RMSE) is `best.pt`; `last.pt` also holds the optimiser and RNG state, so a run that is
interrupted continues where it stopped when started again with the same config.
"""

from __future__ import annotations

import csv
import json
import time
from functools import partial
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from steerlab.data.dataset import CompiledDataset, compile_recording
from steerlab.data.labels import speed_targets
from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.readers import open_recording
from steerlab.data.recording import SteeringConvention
from steerlab.data.splits import make_split
from steerlab.errors import SteerlabError
from steerlab.evaluate.metrics import all_metrics
from steerlab.evaluate.scoring import write_predictions
from steerlab.models import create_model, model_class
from steerlab.train.checkpoint import save_checkpoint
from steerlab.train.inputs import (Standardizer, augment, channel_stats, flip_horizontal, gather, history,
                                   segment_starts, stack_modalities)


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


def usable_frames(ds: CompiledDataset, idx: np.ndarray, name: str, min_speed: float = 0.0,
                  exclude_episodes=()) -> np.ndarray:
    """The frames of a split that training may use: optionally only those at `min_speed` m/s or faster
    (paper 002 V-A drops frames slower than 4 m/s) and outside the excluded episodes."""
    if min_speed:
        if "speed" not in ds.labels:
            raise SteerlabError(f"min_speed needs a recording with speed; {ds.meta['source']} has none")
        idx = idx[ds.labels["speed"][idx] >= float(min_speed)]
    if exclude_episodes:
        if "episode" not in ds.labels:
            raise SteerlabError("exclude_episodes needs a recording with episode labels (the synthetic world's)")
        idx = idx[~np.isin(ds.labels["episode"][idx], list(exclude_episodes))]
    if len(idx) == 0:
        raise SteerlabError(f"the {name} split is empty" + (f" once frames slower than {min_speed} m/s are dropped"
                                                             if min_speed else ""))
    return idx


class Batches:
    """Gathers standardised batches from the cache: `get(codes)` -> (inputs, targets), both dicts of tensors.

    Each source is a compiled camera stream with its own steering labels (the centre camera, and with
    side-camera synthesis the left and right ones); a sample is coded as source * N + frame. Samples come back
    in the order asked for; each source is read in sorted order so that the memory-mapped reads run forward.
    inputs: "x" (B, C, H, W), and "speeds" (B, K) for models with a speed history; targets: "steering", and
    where the recording has speed, "speed" (the next frame's) and "command" (paper 002 IV-B2)."""

    def __init__(self, sources: list[tuple[CompiledDataset, np.ndarray]], stats: dict, speed_history: int = 0):
        self.sources, self.cfg, self.standardize = sources, sources[0][0].config, Standardizer(stats)
        labels = sources[0][0].labels
        self.n = len(sources[0][0])
        self.starts = segment_starts(labels["segment"])  # all sources share the timeline and the speed
        self.speed = labels.get("speed")
        self.targets = speed_targets(self.speed, labels["timestamps_ns"], labels["segment"]) if self.speed is not None else {}
        self.speed_history = speed_history
        self._steering = np.concatenate([s for _, s in sources])

    def steering(self, codes: np.ndarray) -> np.ndarray:
        return self._steering[codes]

    def get(self, codes: np.ndarray, flip: np.ndarray | None = None, transform=None) -> tuple[dict, dict]:
        """`flip` marks samples to mirror (steering negated); `transform(x)` alters raw inputs (augmentation)."""
        order = np.argsort(codes, kind="stable")
        x = None
        for k, (ds, _) in enumerate(self.sources):
            pos = order[(codes[order] // self.n) == k]
            if len(pos):
                part = stack_modalities(gather(ds.arrays, self.cfg, codes[pos] % self.n, self.starts), self.cfg)
                if x is None:
                    x = np.empty((len(codes),) + part.shape[1:], np.float32)
                x[pos] = part
        y = self.steering(codes).astype(np.float32)
        if flip is not None and flip.any():
            x[flip] = flip_horizontal(x[flip], self.cfg)
            y[flip] *= -1
        if transform is not None:
            x = transform(x)
        frames = codes % self.n
        inputs = {"x": self.standardize(x)}
        if self.speed_history:
            inputs["speeds"] = torch.from_numpy(self.speed[history(frames, self.starts, self.speed_history)].astype(np.float32))
        targets = {"steering": torch.from_numpy(y)}
        targets.update({k: torch.from_numpy(v[frames].astype(np.float32 if k == "speed" else np.int64))
                        for k, v in self.targets.items()})
        return inputs, targets


def balanced(codes: np.ndarray, steering: np.ndarray, rng: np.random.Generator, bins: int = 25) -> np.ndarray:
    """Paper 003's balanced subset, drawn anew every epoch: the steering range is cut into `bins` equal bins and
    a bin with more samples than the mean of the non-empty bins keeps a random subset of about that size, which
    thins out driving straight ahead."""
    edges = np.linspace(steering.min(), steering.max(), bins + 1)[1:-1]
    b = np.digitize(steering, edges)
    counts = np.bincount(b, minlength=bins)
    cap = counts[counts > 0].mean()
    return codes[rng.random(len(codes)) < np.minimum(1.0, cap / counts[b])]


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


def objective(model, out: dict, targets: dict) -> torch.Tensor:
    """The model's own loss when it has one, otherwise the MSE of its steering."""
    if hasattr(model, "loss"):
        return model.loss(out, targets)
    return torch.mean((out["steering"] - targets["steering"]) ** 2)


def train_one_epoch(model, opt, batches: Batches, samples: np.ndarray, batch_size: int, flip: bool,
                    rng: np.random.Generator, transform=None, progress: bool = True, desc: str = "") -> float:
    """One pass over `samples`: frame codes (M,), or windows (M, T) of frame codes for recurrent models."""
    model.train()
    order = rng.permutation(len(samples))
    total, count = 0.0, 0
    steps = range(0, len(order), batch_size)
    for s in tqdm(steps, desc=desc, unit="batch", leave=False, disable=None if progress else True):
        b = samples[order[s: s + batch_size]]
        flips = np.repeat(rng.random(len(b)) < 0.5, b[0].size) if flip else None
        inputs, targets = batches.get(b.ravel(), flips, transform)
        if b.ndim == 2:  # windows: (B*T, ...) -> (B, T, ...)
            inputs, targets = ({k: v.view(len(b), b.shape[1], *v.shape[1:]) for k, v in d.items()}
                               for d in (inputs, targets))
        out = model(**inputs)
        loss = objective(model, out[0] if getattr(model, "recurrent", False) else out, targets)  # (out, state)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        total += float(loss.detach()) * len(b)
        count += len(b)
    return total / count


def _numpy(out: dict) -> dict[str, np.ndarray]:
    """Model outputs as predictions: steering, speed, and the most likely speed command."""
    pred = {k: out[k].numpy().astype(np.float64) for k in ("steering", "speed") if k in out}
    if "command" in out:
        pred["command"] = out["command"].argmax(-1).numpy()
    return pred


@torch.inference_mode()
def predict(model, batches: Batches, idx: np.ndarray, batch_size: int = 256) -> dict[str, np.ndarray]:
    """Predictions for frames `idx` (in time order). Recurrent models run statefully through each contiguous
    run of frames, from a zero state at the start of the run and at every segment start, as the Pilot does."""
    model.eval()
    parts = []
    if not getattr(model, "recurrent", False):
        for s in range(0, len(idx), batch_size):
            parts.append(_numpy(model(**batches.get(idx[s: s + batch_size])[0])))
    else:
        breaks = np.flatnonzero((np.diff(idx) != 1) | (batches.starts[idx[1:]] == idx[1:])) + 1
        for frames in np.split(idx, breaks):
            state = None
            for s in range(0, len(frames), batch_size):
                inputs = {k: v[None] for k, v in batches.get(frames[s: s + batch_size])[0].items()}
                out, state = model(**inputs, state=state)
                parts.append(_numpy({k: v[0] for k, v in out.items()}))
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


METRIC = {"speed": "speed_mae", "command": "command_accuracy"}  # the metric of each extra target


def _log_row(epoch: int, loss: float, m: dict, seconds: float) -> dict:
    row = {"epoch": epoch, "train_loss": loss, "seconds": round(seconds, 2)}
    row.update({f"val_{k}": m[k] for k in ("mse", "rmse", "mae_deg", "gamma_deg", *METRIC.values()) if k in m})
    return row


def _write_predictions(path: Path, ds: CompiledDataset, idx: np.ndarray, pred: dict) -> None:
    extra = {k: pred[k] for k in ("speed", "command") if k in pred}
    write_predictions(path, ds.labels["frame_ids"][idx], pred["steering"], extra)


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

    name = cfg["model"]["name"]
    cfg = {**cfg, "preprocess": model_preprocess(name, cfg.get("preprocess"))}
    ds = prepare_dataset(cfg, progress)
    train_idx, val_idx = make_split(cfg["split"], len(ds))
    min_speed = float(tc["min_speed"])
    train_idx = usable_frames(ds, train_idx, "training", min_speed, tc.get("exclude_episodes"))
    val_idx = usable_frames(ds, val_idx, "validation", min_speed)
    stats = channel_stats(ds.arrays, ds.config, train_idx, segment_starts(ds.labels["segment"]))
    sources = [(ds, ds.steering)]
    if tc.get("side_cameras"):
        for cam, sign in (("left", 1.0), ("right", -1.0)):
            side = prepare_dataset(cfg, progress, camera=cam)
            sources.append((side, side_camera_labels(side, sign * float(tc["side_offset_m"]),
                                                     float(tc["recovery_s"]), float(tc["steering_ratio"]))))
        train_idx = np.concatenate([train_idx + k * len(ds) for k in range(3)])
    torch.manual_seed(int(tc["seed"]))
    model_cfg = {k: v for k, v in cfg["model"].items() if k != "name"}
    model_cfg.update(in_channels=sum(ds.config.channels().values()), height=ds.config.height, width=ds.config.width)
    model = create_model(name, **model_cfg)
    if (getattr(model, "targets", ()) or getattr(model, "speed_history", 0)) and "speed" not in ds.labels:
        raise SteerlabError(f"model {name!r} needs a recording with speed; {ds.meta['source']} has none")
    batches = Batches(sources, stats, getattr(model, "speed_history", 0))
    samples = train_idx
    if getattr(model, "recurrent", False):
        if tc["balance"]:
            raise SteerlabError("balanced sampling picks single frames; recurrent models train on sequences "
                                "(paper 003 does not balance its LSTM either)")
        samples = sequence_windows(train_idx, len(ds), batches.starts, model.seq_len)
        if len(samples) == 0:
            raise SteerlabError(f"no training window of {model.seq_len} consecutive frames in one segment")
    if all(p.dim() != 5 for p in model.parameters()):  # channels-last exists for 2-D convolutions only
        model = model.to(memory_format=torch.channels_last)
    convention = SteeringConvention(**ds.meta["convention"])
    truth = {"steering": ds.steering[val_idx], **{k: v[val_idx] for k, v in batches.targets.items()}}

    def checkpoint(path, metrics, **extra):
        save_checkpoint(path, model, model_cfg, ds.config, stats, convention, metrics,
                        preset=ds.meta["preset"], frame_rate=ds.meta["frame_rate"], **extra)

    if not getattr(model, "trainable", True):
        model.fit(batches.steering(train_idx))
        pred = predict(model, batches, val_idx)
        metrics = {**all_metrics(pred, truth), "epoch": 0}
        checkpoint(out / "best.pt", metrics)
        _write_predictions(out / "val_predictions.csv", ds, val_idx, pred)
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
    log_fields = (["epoch", "train_loss", "val_mse", "val_rmse", "val_mae_deg", "val_gamma_deg"]
                  + [f"val_{METRIC[t]}" for t in getattr(model, "targets", ())] + ["seconds"])
    log_path = out / "log.csv"
    with open(log_path, "w", newline="") as f:  # rewritten from history so a resumed log has no duplicates
        w = csv.DictWriter(f, log_fields)
        w.writeheader()
        w.writerows(history)

    rotation, brightness = float(tc["rotation_deg"]), float(tc["brightness"])
    for epoch in range(start, int(tc["epochs"]) + 1):
        if since_best >= int(tc["patience"]):
            break
        t0 = time.time()
        rng = np.random.default_rng([int(tc["seed"]), epoch])
        transform = (partial(augment, cfg=ds.config, rng=rng, rotation_deg=rotation, brightness=brightness)
                     if rotation or brightness else None)
        epoch_samples = balanced(samples, batches.steering(samples), rng) if tc["balance"] else samples
        loss = train_one_epoch(model, opt, batches, epoch_samples, int(tc["batch_size"]), bool(tc["flip"]), rng,
                               transform, progress, desc=f"epoch {epoch}")
        pred = predict(model, batches, val_idx)
        m = all_metrics(pred, truth)
        row = _log_row(epoch, loss, m, time.time() - t0)
        history.append(row)
        with open(log_path, "a", newline="") as f:
            csv.DictWriter(f, log_fields).writerow(row)
        if progress:
            extra = "".join(f"  {k} {m[k]:.3f}" for k in ("speed_mae", "command_accuracy") if k in m)
            print(f"epoch {epoch}: train loss {loss:.5f}  val rmse {m['rmse']:.4f}  mae {m['mae_deg']:.2f} deg  "
                  f"gamma {m['gamma_deg']:.3f} (target {m['target_gamma_deg']:.3f}){extra}")
        if best is None or m["rmse"] < best["rmse"]:
            best, since_best = {**m, "epoch": epoch}, 0
            checkpoint(out / "best.pt", best)
            _write_predictions(out / "val_predictions.csv", ds, val_idx, pred)
        else:
            since_best += 1
        checkpoint(out / "last.pt", best, optimizer=opt.state_dict(), epoch=epoch, best=best,
                   since_best=since_best, history=history, torch_rng=torch.get_rng_state())
    return best
