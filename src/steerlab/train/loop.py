"""The training loop: `train(cfg)` reads as prepare data -> train_one_epoch / evaluate -> checkpoints.

Batches are gathered from the memory-mapped cache; validation uses the same cache. The best checkpoint
(lowest validation RMSE) is `best.pt`; `last.pt` also holds the optimiser and RNG state, so a run that is
interrupted continues where it stopped when started again with the same config.
"""

from __future__ import annotations

import csv
import json
import math
import time
from functools import partial
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from steerlab.checkpoint import load_checkpoint, save_checkpoint
from steerlab.data.dataset import CompiledDataset, compile_recording
from steerlab.data.geometry import CAMERAS
from steerlab.data.labels import speed_targets
from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.readers import open_recording
from steerlab.data.recording import SteeringConvention
from steerlab.data.splits import make_split
from steerlab.errors import SteerlabError
from steerlab.evaluate.metrics import all_metrics
from steerlab.evaluate.scoring import write_predictions
from steerlab.locks import folder_lock
from steerlab.models import create_model, model_class
from steerlab.train.config import LOSSES, check_config
from steerlab.train.distributed import Ranks, setup, wrap
from steerlab.data.inputs import (Standardizer, augment, channel_stats, flip_horizontal, gather, history, no_motion,
                                   segment_starts, stack_modalities)


def prepare_dataset(cfg: dict, progress: bool = True, camera: str | None = None, view: tuple | None = None,
                    data: str | None = None) -> CompiledDataset:
    """The compiled main recording of a config (or the whole recording `data`), one camera stream of it, or a
    virtual view (shift_m, yaw_deg) synthesised from its centre camera."""
    rec = (open_recording(cfg["data"], cfg.get("range"), cfg.get("labels"), cfg.get("reader")) if data is None
           else open_recording(data))
    camera = camera or cfg.get("camera", "center")
    if camera not in rec.frames:
        raise SteerlabError(f"{rec.source} has no {camera!r} camera (it has {', '.join(rec.cameras)})")
    if view is not None and rec.preset not in CAMERAS:
        raise SteerlabError(f"viewpoint shifts need the camera geometry of the recording; {rec.source} has the "
                            f"{rec.preset!r} preset, and geometry is known for {', '.join(CAMERAS)}")
    pre_cfg = dict(cfg.get("preprocess") or {})
    if "crop" not in pre_cfg:
        pre_cfg.setdefault("preset", rec.preset)
    return compile_recording(rec, PreprocessConfig.from_dict(pre_cfg), cfg["cache"], camera, progress=progress,
                             view=view)


def model_options(model: dict, pre: PreprocessConfig) -> dict:
    """The config's model options completed with the input its preprocessing gives (channels, height, width)."""
    return {**{k: v for k, v in model.items() if k != "name"},
            "in_channels": sum(pre.channels().values()), "height": pre.height, "width": pre.width}


def model_preprocess(name: str, preprocess: dict | None) -> dict:
    """The config's preprocessing completed with what the model needs (its `inputs`)."""
    pre = dict(preprocess or {})
    for key, value in model_class(name).inputs.items():
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

    A source is a compiled camera stream with its own steering labels: the main recording's centre camera
    (source 0, whose frames are the validation frames too), its side cameras and virtual views, and the streams
    of extra training recordings. Sample codes number the frames of all sources one after another (source k's
    frame i is offsets[k] + i). Samples come back in the order asked for; each source is read in sorted order so
    that the memory-mapped reads run forward.
    inputs: "x" (B, C, H, W), and "speeds" (B, K) for models with a speed history; targets: "steering", and
    where the recordings have speed, "speed" (the next frame's) and "command" (paper 002 IV-B2)."""

    def __init__(self, sources: list[tuple[CompiledDataset, np.ndarray]], stats: dict, speed_history: int = 0):
        self.sources, self.cfg, self.standardize = sources, sources[0][0].config, Standardizer(stats)
        self.offsets = np.cumsum([0] + [len(ds) for ds, _ in sources])
        self.local_starts = [segment_starts(ds.labels["segment"]) for ds, _ in sources]
        self.starts = np.concatenate([st + off for st, off in zip(self.local_starts, self.offsets)])  # per code
        self._steering = np.concatenate([y for _, y in sources])
        with_speed = all("speed" in ds.labels for ds, _ in sources)
        self.speed = np.concatenate([ds.labels["speed"] for ds, _ in sources]) if with_speed else None
        self.targets = {}
        if with_speed:
            parts = [speed_targets(ds.labels["speed"], ds.labels["timestamps_ns"], ds.labels["segment"])
                     for ds, _ in sources]
            self.targets = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
        self.speed_history = speed_history

    def steering(self, codes: np.ndarray) -> np.ndarray:
        return self._steering[codes]

    def get(self, codes: np.ndarray, flip: np.ndarray | None = None, still: np.ndarray | None = None,
            transform=None) -> tuple[dict, dict]:
        """`flip` marks samples to mirror (steering negated); `still` marks samples whose motion inputs
        (difference, flow) are replaced by "no motion seen"; `transform(x)` alters raw inputs (augmentation)."""
        order = np.argsort(codes, kind="stable")
        source = np.searchsorted(self.offsets, codes, side="right") - 1
        x = None
        for k, (ds, _) in enumerate(self.sources):
            pos = order[source[order] == k]
            if len(pos):
                frames = codes[pos] - self.offsets[k]
                part = stack_modalities(gather(ds.arrays, self.cfg, frames, self.local_starts[k]), self.cfg)
                if x is None:
                    x = np.empty((len(codes),) + part.shape[1:], np.float32)
                x[pos] = part
        y = self.steering(codes).astype(np.float32)
        if still is not None and still.any():
            x[still] = no_motion(x[still], self.cfg)
        if flip is not None and flip.any():
            x[flip] = flip_horizontal(x[flip], self.cfg)
            y[flip] *= -1
        if transform is not None:
            x = transform(x)
        inputs = {"x": self.standardize(x)}
        if self.speed_history:
            inputs["speeds"] = torch.from_numpy(self.speed[history(codes, self.starts, self.speed_history)].astype(np.float32))
        targets = {"steering": torch.from_numpy(y)}
        targets.update({k: torch.from_numpy(v[codes].astype(np.float32 if k == "speed" else np.int64))
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


def recovery_labels(ds: CompiledDataset, steering: np.ndarray, shift_m: float, yaw_deg: float, tc: dict) -> np.ndarray:
    """The steering that brings a car `shift_m` left of where the recording was made, turned `yaw_deg` to the
    left, back to the recorded path (paper 002 Eq. 3, with the turn added): theta_f = theta_r +
    arctan(-d_y / L) - yaw as a road-wheel angle (positive left), where L = speed * t_r is the distance in which
    the car returns (t_r = `recovery_s`; `recovery_distance_m` when the recording has no speed). Converted back
    to the recording's convention (steering-wheel recordings use the vehicle's steering ratio)."""
    if "speed" in ds.labels:
        distance = np.maximum(ds.labels["speed"], 1.0) * float(tc["recovery_s"])
    elif tc.get("recovery_distance_m"):
        distance = float(tc["recovery_distance_m"])
    else:
        raise SteerlabError(f"{ds.meta['source']} has no speed: set train.recovery_distance_m, the distance in "
                            "which a displaced car returns to its path, for side cameras or viewpoint shifts")
    conv = SteeringConvention(**ds.meta["convention"])
    correction = np.arctan(-shift_m / distance) - np.radians(yaw_deg)
    return steering + conv.from_road_wheel_left(correction, float(tc["steering_ratio"]))


def steering_ahead(ds: CompiledDataset, seconds: float) -> np.ndarray:
    """Each frame's target is the steering `seconds` later in its segment (the segment's last value at its end)."""
    if not seconds:
        return ds.steering
    k = int(round(seconds * ds.meta["frame_rate"]))
    seg = ds.labels["segment"]
    last = np.r_[np.flatnonzero(np.diff(seg)), len(seg) - 1]  # each segment's last frame
    return ds.steering[np.minimum(np.arange(len(seg)) + k, last[seg])]


def training_sources(cfg: dict, ds: CompiledDataset, train_idx: np.ndarray, progress: bool):
    """The training streams and the codes of their training frames (see `Batches`): the main recording's
    training split and every usable frame of the extra recordings, each with its side cameras (`side_cameras`)
    and virtual views (`views`: [shift_m, yaw_deg] pairs) labelled with the recovery steering."""
    tc = cfg["train"]
    recordings = [(None, ds, train_idx)]
    for path in cfg.get("extra_data") or []:
        extra = prepare_dataset(cfg, progress, data=path)
        idx = usable_frames(extra, np.arange(len(extra)), f"extra recording {path}", float(tc["min_speed"]),
                            tc.get("exclude_episodes"))
        recordings.append((path, extra, idx))
    sources, codes, offset = [], [], 0
    for path, main, idx in recordings:
        ahead = steering_ahead(main, float(tc["target_shift_s"]))
        streams = [(main, ahead)]
        if tc["side_cameras"]:
            for cam, sign in (("left", 1.0), ("right", -1.0)):
                side = prepare_dataset(cfg, progress, camera=cam, data=path)
                streams.append((side, recovery_labels(side, ahead, sign * float(tc["side_offset_m"]), 0.0, tc)))
        for shift, yaw in tc["views"]:
            view = prepare_dataset(cfg, progress, view=(float(shift), float(yaw)), data=path)
            streams.append((view, recovery_labels(view, ahead, float(shift), float(yaw), tc)))
        for stream in streams:
            sources.append(stream)
            codes.append(idx + offset)
            offset += len(main)
    return sources, np.concatenate(codes)


def sequence_windows(codes: np.ndarray, starts: np.ndarray, length: int) -> np.ndarray:
    """Windows (M, length) of consecutive sample codes that lie inside the sample set and inside one segment
    (`starts`: the first code of each code's segment), starting every `length` frames from the segment's start,
    so an epoch sees each frame about once."""
    all_codes = np.sort(codes)
    w = all_codes[(all_codes - starts[all_codes]) % length == 0][:, None] + np.arange(length)
    inside = np.isin(w, all_codes).all(axis=1)
    w = w[inside]
    return w[(starts[w] == starts[w[:, :1]]).all(axis=1)]


def recovery_weighted(samples: np.ndarray, episodes: np.ndarray, weight: int) -> np.ndarray:
    """Samples (codes, or windows of codes) that touch a recovery episode appear `weight` times."""
    touch = np.isin(episodes[samples], "recover")
    touch = touch.any(axis=1) if samples.ndim == 2 else touch
    return np.concatenate([samples] + [samples[touch]] * (weight - 1))


def objective(model, out: dict, targets: dict, loss: str = "mse") -> torch.Tensor:
    """The model's own loss when it has one, otherwise the MSE or the MAE of its steering."""
    if hasattr(model, "loss"):
        return model.loss(out, targets)
    error = out["steering"] - targets["steering"]
    return torch.mean(error ** 2) if loss == "mse" else torch.mean(error.abs())


def train_one_epoch(model, opt, batches: Batches, samples: np.ndarray, batch_size: int, flip: bool,
                    rng: np.random.Generator, transform=None, motion_dropout: float = 0.0, progress: bool = True,
                    desc: str = "", ranks: Ranks = Ranks(), loss_name: str = "mse") -> float:
    """One pass over `samples`: frame codes (M,), or windows (M, T) of frame codes for recurrent models.
    Flips and motion dropout are drawn per sample (per window: a window is mirrored or still as a whole).
    With several ranks every rank draws the same global batches and trains on its contiguous share of each."""
    net = getattr(model, "module", model)  # the model itself, also inside DDP
    model.train()
    order = rng.permutation(len(samples))
    total, count = 0.0, 0
    steps = range(0, len(order), batch_size)
    for s in tqdm(steps, desc=desc, unit="batch", leave=False, disable=None if progress and ranks.main else True):
        b = samples[order[s: s + batch_size]]
        flips = np.repeat(rng.random(len(b)) < 0.5, b[0].size) if flip else None
        still = np.repeat(rng.random(len(b)) < motion_dropout, b[0].size) if motion_dropout else None
        if len(b) < ranks.world:  # a last batch too small to share
            continue
        lo, hi = ranks.rank * len(b) // ranks.world, (ranks.rank + 1) * len(b) // ranks.world
        share = ranks.world * (hi - lo) / len(b)  # DDP averages over ranks: weight by the share of the batch
        b, k = b[lo:hi], b[0].size
        flips, still = (None if a is None else a[lo * k: hi * k] for a in (flips, still))
        inputs, targets = batches.get(b.ravel(), flips, still, transform)
        if b.ndim == 2:  # windows: (B*T, ...) -> (B, T, ...)
            inputs, targets = ({k: v.view(len(b), b.shape[1], *v.shape[1:]) for k, v in d.items()}
                               for d in (inputs, targets))
        inputs, targets = ({k: v.to(ranks.device) for k, v in d.items()} for d in (inputs, targets))
        out = model(**inputs)
        loss = objective(net, out[0] if net.recurrent else out, targets, loss_name)  # (out, state)
        opt.zero_grad(set_to_none=True)
        (loss * share if ranks.world > 1 else loss).backward()
        opt.step()
        total += float(loss.detach()) * len(b)
        count += len(b)
    total, count = ranks.sum(total, count)
    return total / count


def _numpy(out: dict) -> dict[str, np.ndarray]:
    """Model outputs as predictions: steering, speed, and the most likely speed command."""
    pred = {k: out[k].cpu().numpy().astype(np.float64) for k in ("steering", "speed") if k in out}
    if "command" in out:
        pred["command"] = out["command"].argmax(-1).cpu().numpy()
    return pred


@torch.inference_mode()
def predict(model, batches: Batches, idx: np.ndarray, batch_size: int = 256) -> dict[str, np.ndarray]:
    """Predictions for frames `idx` (in time order). Recurrent models run statefully through each contiguous
    run of frames, from a zero state at the start of the run and at every segment start, as the Pilot does."""
    model.eval()
    device = next(model.parameters(), torch.zeros(0)).device

    def inputs(frames):
        return {k: v.to(device) for k, v in batches.get(frames)[0].items()}

    parts = []
    if not model.recurrent:
        for s in range(0, len(idx), batch_size):
            parts.append(_numpy(model(**inputs(idx[s: s + batch_size]))))
    else:
        breaks = np.flatnonzero((np.diff(idx) != 1) | (batches.starts[idx[1:]] == idx[1:])) + 1
        for frames in np.split(idx, breaks):
            state = None
            for s in range(0, len(frames), batch_size):
                out, state = model(**{k: v[None] for k, v in inputs(frames[s: s + batch_size]).items()},
                                   state=state)
                parts.append(_numpy({k: v[0] for k, v in out.items()}))
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


METRIC = {"speed": "speed_mae", "command": "command_accuracy"}  # the metric of each extra target


def _log_row(epoch: int, loss: float, m: dict, seconds: float) -> dict:
    row = {"epoch": epoch, "train_loss": loss, "seconds": round(seconds, 2)}
    row.update({f"val_{k}": m[k] for k in ("mse", "rmse", "mae", "mae_deg", "gamma_deg", *METRIC.values()) if k in m})
    return row


def _write_predictions(path: Path, ds: CompiledDataset, idx: np.ndarray, pred: dict) -> None:
    extra = {k: pred[k] for k in ("speed", "command") if k in pred}
    write_predictions(path, ds.labels["frame_ids"][idx], pred["steering"], extra)


def train(cfg: dict, progress: bool = True, on_epoch=None) -> dict:
    """Train one model as configured; returns the best validation metrics. Resumes from `out/last.pt`.
    `on_epoch(epoch, metrics)` is called after every epoch's checkpoint (steerlab tune reports and prunes
    there: an exception it raises ends the run, which stays resumable). The run holds a lock on `out`: a
    second run into the same folder is refused while the first one runs."""
    check_config(cfg)
    out = Path(cfg["out"])
    ranks = setup(str(cfg["train"]["device"]))
    if int(cfg["train"]["batch_size"]) % ranks.world:
        raise SteerlabError(f"train.batch_size {cfg['train']['batch_size']} is the global batch; it must divide "
                            f"evenly over {ranks.world} ranks")
    if not ranks.main:  # rank 0 holds the lock for all ranks
        return _train(cfg, ranks, progress, on_epoch)
    out.mkdir(parents=True, exist_ok=True)
    with folder_lock(out, "steerlab train run"):
        for tmp in out.glob("*.tmp-*"):  # left by a killed run: only the holder of the lock writes here
            tmp.unlink(missing_ok=True)
        return _train(cfg, ranks, progress, on_epoch)


def _train(cfg: dict, ranks: Ranks, progress: bool, on_epoch) -> dict:
    out = Path(cfg["out"])
    tc = cfg["train"]
    score = LOSSES[tc["loss"]]
    progress = progress and ranks.main
    cfg_file = out / "config.json"
    if (out / "last.pt").exists():
        if not cfg_file.exists() or json.loads(cfg_file.read_text()) != json.loads(json.dumps(cfg)):
            raise SteerlabError(f"{out} holds a run with another config; choose a new out directory or delete it")
    if ranks.main:
        out.mkdir(parents=True, exist_ok=True)
        cfg_file.write_text(json.dumps(cfg, indent=1))

    name = cfg["model"]["name"]
    cfg = {**cfg, "preprocess": model_preprocess(name, cfg.get("preprocess"))}
    if not ranks.main:
        ranks.barrier()  # rank 0 compiles the cache first; the others then read it
    ds = prepare_dataset(cfg, progress)
    if ranks.main:
        ranks.barrier()
    train_idx, val_idx = make_split(cfg["split"], len(ds), ds.labels.get("session"))
    min_speed = float(tc["min_speed"])
    train_idx = usable_frames(ds, train_idx, "training", min_speed, tc.get("exclude_episodes"))
    val_idx = usable_frames(ds, val_idx, "validation", min_speed)
    stats = channel_stats(ds.arrays, ds.config, train_idx, segment_starts(ds.labels["segment"]))
    sources, train_codes = training_sources(cfg, ds, train_idx, progress)
    torch.manual_seed(int(tc["seed"]))
    model_cfg = model_options(cfg["model"], ds.config)
    model = create_model(name, **model_cfg)
    if tc.get("init"):
        init = load_checkpoint(tc["init"])
        if init["model"] != name or init["model_cfg"] != model_cfg:
            raise SteerlabError(f"{tc['init']}: train.init must be a checkpoint of the same model and options "
                                f"({name}, {model_cfg}); it holds {init['model']}, {init['model_cfg']}")
        model.load_state_dict(init["state_dict"])
    if hasattr(model, "loss") and tc["loss"] != "mse":
        raise SteerlabError(f"model {name!r} trains on a loss of its own; train.loss={tc['loss']} does not apply")
    if (model.targets or model.speed_history) and "speed" not in ds.labels:
        raise SteerlabError(f"model {name!r} needs a recording with speed; {ds.meta['source']} has none")
    batches = Batches(sources, stats, model.speed_history)
    samples = train_codes
    if model.recurrent:
        if tc["balance"]:
            raise SteerlabError("balanced sampling picks single frames; recurrent models train on sequences "
                                "(paper 003 does not balance its LSTM either)")
        samples = sequence_windows(train_codes, batches.starts, model.seq_len)
        if len(samples) == 0:
            raise SteerlabError(f"no training window of {model.seq_len} consecutive frames in one segment")
    if int(tc["recovery_weight"]) > 1:
        episodes = np.concatenate([d.labels.get("episode", np.full(len(d), "")) for d, _ in sources])
        if not np.isin(episodes, "recover").any():
            raise SteerlabError("recovery_weight needs recordings with recovery episodes (the synthetic world's)")
        samples = recovery_weighted(samples, episodes, int(tc["recovery_weight"]))
    if all(p.dim() != 5 for p in model.parameters()):  # channels-last exists for 2-D convolutions only
        model = model.to(memory_format=torch.channels_last)
    convention = SteeringConvention(**ds.meta["convention"])
    truth = {"steering": sources[0][1][val_idx], **{k: v[val_idx] for k, v in batches.targets.items()}}

    def checkpoint(path, metrics, **extra):
        if ranks.main:
            save_checkpoint(path, model, model_cfg, ds.config, stats, convention, metrics,
                            preset=ds.meta["preset"], frame_rate=ds.meta["frame_rate"], **extra)

    if not model.trainable:
        model.fit(batches.steering(train_codes))
        pred = predict(model, batches, val_idx)
        metrics = {**all_metrics(pred, truth, convention.degrees_per_unit), "epoch": 0}
        checkpoint(out / "best.pt", metrics)
        if ranks.main:
            _write_predictions(out / "val_predictions.csv", ds, val_idx, pred)
        return metrics

    step_model = wrap(model, ranks)  # on the device; in DDP with several ranks
    opt = torch.optim.Adam(model.parameters(), lr=float(tc["lr"]))
    start, best, since_best, history = 1, None, 0, []
    if (out / "last.pt").exists():
        state = load_checkpoint(out / "last.pt")
        model.load_state_dict(state["state_dict"])
        opt.load_state_dict(state["optimizer"])
        start, best, since_best, history = state["epoch"] + 1, state["best"], state["since_best"], state["history"]
        torch.set_rng_state(state["torch_rng"])
        if ranks.main:
            print(f"resuming {out} after epoch {state['epoch']}")
    log_fields = (["epoch", "train_loss", "val_mse", "val_rmse", "val_mae", "val_mae_deg", "val_gamma_deg"]
                  + [f"val_{METRIC[t]}" for t in model.targets] + ["seconds"])
    log_path = out / "log.csv"
    if ranks.main:
        with open(log_path, "w", newline="") as f:  # rewritten from history so a resumed log has no duplicates
            w = csv.DictWriter(f, log_fields)
            w.writeheader()
            w.writerows(history)

    rotation, brightness = float(tc["rotation_deg"]), float(tc["brightness"])
    for epoch in range(start, int(tc["epochs"]) + 1):
        if since_best >= int(tc["patience"]):
            break
        t0 = time.time()
        rng = np.random.default_rng([int(tc["seed"]), epoch])  # the same on every rank: the same global batches
        augment_rng = np.random.default_rng([int(tc["seed"]), epoch, 1 + ranks.rank])  # per sample, per rank
        transform = (partial(augment, cfg=ds.config, rng=augment_rng, rotation_deg=rotation, brightness=brightness)
                     if rotation or brightness else None)
        epoch_samples = balanced(samples, batches.steering(samples), rng) if tc["balance"] else samples
        loss = train_one_epoch(step_model, opt, batches, epoch_samples, int(tc["batch_size"]), bool(tc["flip"]),
                               rng, transform, float(tc["motion_dropout"]), progress, desc=f"epoch {epoch}",
                               ranks=ranks, loss_name=tc["loss"])
        pred = predict(model, batches, val_idx)
        m = all_metrics(pred, truth, convention.degrees_per_unit)
        for what, value in (("training loss", loss), (f"validation {score}", m[score])):
            if not math.isfinite(value):  # stop before a diverged model can become the best one
                kept = "no checkpoint was saved" if best is None else f"best.pt keeps epoch {best['epoch']}"
                raise SteerlabError(f"training diverged in epoch {epoch}: the {what} is {value} (train.lr "
                                    f"{tc['lr']} may be too high); {kept}")
        row = _log_row(epoch, loss, m, time.time() - t0)
        history.append(row)
        if ranks.main:
            with open(log_path, "a", newline="") as f:
                csv.DictWriter(f, log_fields).writerow(row)
        if progress:
            extra = "".join(f"  {k} {m[k]:.3f}" for k in ("speed_mae", "command_accuracy") if k in m)
            angles = (f"mae {m['mae_deg']:.2f} deg  gamma {m['gamma_deg']:.3f} (target {m['target_gamma_deg']:.3f})"
                      if np.isfinite(m["mae_deg"]) else f"mae {m['mae']:.4f} ({convention.unit})")
            print(f"epoch {epoch}: train loss {loss:.5f}  val rmse {m['rmse']:.4f}  {angles}{extra}")
        if best is None or m[score] < best[score]:
            best, since_best = {**m, "epoch": epoch}, 0
            checkpoint(out / "best.pt", best)
            if ranks.main:
                _write_predictions(out / "val_predictions.csv", ds, val_idx, pred)
        else:
            since_best += 1
        checkpoint(out / "last.pt", best, optimizer=opt.state_dict(), epoch=epoch, best=best,
                   since_best=since_best, history=history, torch_rng=torch.get_rng_state())
        if on_epoch is not None:
            on_epoch(epoch, m)
    return best
