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
from steerlab.data.dataset import CompiledDataset
from steerlab.data.inputs import augment, channel_stats, segment_starts
from steerlab.data.recording import SteeringConvention
from steerlab.data.splits import make_split
from steerlab.errors import SteerlabError
from steerlab.evaluate.metrics import all_metrics
from steerlab.evaluate.scoring import write_predictions
from steerlab.locks import folder_lock
from steerlab.models import create_model
from steerlab.train.config import LOSSES, check_config
from steerlab.train.distributed import Ranks, setup, wrap
from steerlab.train.sources import (Batches, balanced, model_options, model_preprocess, prepare_dataset,
                                    recovery_weighted, sequence_windows, steering_ahead, training_sources,
                                    usable_frames)


def _mean_error(error: torch.Tensor, loss: str) -> torch.Tensor:
    return torch.mean(error ** 2) if loss == "mse" else torch.mean(error.abs())


def objective(model, out: dict, targets: dict, loss: str = "mse", smoothness: float = 0.0) -> torch.Tensor:
    """The model's own loss when it has one, otherwise the MSE or the MAE of its steering; with `smoothness`,
    plus that weight times the same error of the steering's change from frame to frame within each window
    (recurrent outputs (B, T): the predicted change against the recorded one)."""
    value = (model.loss(out, targets) if hasattr(model, "loss")
             else _mean_error(out["steering"] - targets["steering"], loss))
    if smoothness:
        change = torch.diff(out["steering"], dim=-1) - torch.diff(targets["steering"], dim=-1)
        value = value + smoothness * _mean_error(change, loss)
    return value


def train_one_epoch(model, opt, batches: Batches, samples: np.ndarray, batch_size: int, flip: bool,
                    rng: np.random.Generator, transform=None, motion_dropout: float = 0.0, progress: bool = True,
                    desc: str = "", ranks: Ranks = Ranks(), loss_name: str = "mse", smoothness: float = 0.0) -> float:
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
        loss = objective(net, out[0] if net.recurrent else out, targets, loss_name, smoothness)  # (out, state)
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


class EpochLog:
    """One row per epoch in `out/log.csv` (rewritten from the history first, so that a resumed run has no
    duplicate epochs) and, with `tensorboard`, the same values as scalars in `out/tensorboard`."""

    def __init__(self, out: Path, targets: tuple, history: list[dict], tensorboard: bool = False):
        self.path = out / "log.csv"
        self.fields = (["epoch", "train_loss", "val_mse", "val_rmse", "val_mae", "val_mae_deg", "val_gamma_deg"]
                       + [f"val_{METRIC[t]}" for t in targets] + ["seconds"])
        with open(self.path, "w", newline="") as f:
            w = csv.DictWriter(f, self.fields)
            w.writeheader()
            w.writerows(history)
        self.board = None
        if tensorboard:
            try:
                from torch.utils.tensorboard import SummaryWriter
            except ImportError:
                raise SteerlabError("train.tensorboard needs the tensorboard package: pip install tensorboard") from None
            start = history[-1]["epoch"] + 1 if history else 1  # a resumed run drops later events first
            self.board = SummaryWriter(str(out / "tensorboard"), purge_step=start)

    def write(self, epoch: int, loss: float, m: dict, seconds: float) -> dict:
        row = {"epoch": epoch, "train_loss": loss, "seconds": round(seconds, 2)}
        row.update({f"val_{k}": m[k] for k in ("mse", "rmse", "mae", "mae_deg", "gamma_deg", *METRIC.values())
                    if k in m})
        with open(self.path, "a", newline="") as f:
            csv.DictWriter(f, self.fields).writerow(row)
        if self.board is not None:
            for key, value in row.items():
                if key != "epoch":  # train_loss -> train/loss, val_rmse -> val/rmse
                    self.board.add_scalar(key.replace("_", "/", 1), value, epoch)
            self.board.flush()
        return row

    def close(self) -> None:
        if self.board is not None:
            self.board.close()


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
    # checkpoints named by the config are read before any work: a bad one fails at once
    init, teacher = (load_checkpoint(cfg["train"][k]) if cfg["train"].get(k) else None for k in ("init", "teacher"))
    if not ranks.main:  # rank 0 holds the lock for all ranks
        return _train(cfg, ranks, progress, on_epoch, init, teacher)
    out.mkdir(parents=True, exist_ok=True)
    with folder_lock(out, "steerlab train run"):
        for tmp in out.glob("*.tmp-*"):  # left by a killed run: only the holder of the lock writes here
            tmp.unlink(missing_ok=True)
        return _train(cfg, ranks, progress, on_epoch, init, teacher)


def _train(cfg: dict, ranks: Ranks, progress: bool, on_epoch, init: dict | None, teacher: dict | None) -> dict:
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
    model_cfg = model_options(cfg["model"], ds.config)
    if init:  # before the other streams compile
        if init.get("geometry", ds.meta["geometry"]) != ds.meta["geometry"]:  # older checkpoints record none
            raise SteerlabError(f"{tc['init']}: train.init was trained on the {init['geometry']!r} camera "
                                f"geometry and {ds.meta['source']} has the {ds.meta['geometry']!r} geometry: "
                                "pretrain on recordings of the same camera (steerlab sim record --geometry)")
        if init["model"] != name or init["model_cfg"] != model_cfg:
            raise SteerlabError(f"{tc['init']}: train.init must be a checkpoint of the same model and options "
                                f"({name}, {model_cfg}); it holds {init['model']}, {init['model_cfg']}")
    train_idx, val_idx = make_split(cfg["split"], len(ds), ds.labels.get("session"))
    min_speed = float(tc["min_speed"])
    train_idx = usable_frames(ds, train_idx, "training", min_speed, tc.get("exclude_episodes"))
    val_idx = usable_frames(ds, val_idx, "validation", min_speed)
    stats = channel_stats(ds.arrays, ds.config, train_idx, segment_starts(ds.labels["segment"]))
    sources, train_codes = training_sources(cfg, ds, train_idx, progress, teacher)
    torch.manual_seed(int(tc["seed"]))
    model = create_model(name, **model_cfg)
    if init:
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
    recorded = steering_ahead(ds, float(tc["target_shift_s"]))  # the recording's, also under a teacher
    truth = {"steering": recorded[val_idx], **{k: v[val_idx] for k, v in batches.targets.items()}}

    def checkpoint(path, metrics, **extra):
        if ranks.main:
            save_checkpoint(path, model, model_cfg, ds.config, stats, convention, metrics,
                            geometry=ds.meta["geometry"], frame_rate=ds.meta["frame_rate"], **extra)

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
    log = EpochLog(out, model.targets, history, bool(tc["tensorboard"])) if ranks.main else None

    rotation, brightness = float(tc["rotation_deg"]), float(tc["brightness"])
    for epoch in range(start, int(tc["epochs"]) + 1):
        if since_best >= int(tc["patience"]) and tc["keep"] == "best":
            break
        t0 = time.time()
        rng = np.random.default_rng([int(tc["seed"]), epoch])  # the same on every rank: the same global batches
        augment_rng = np.random.default_rng([int(tc["seed"]), epoch, 1 + ranks.rank])  # per sample, per rank
        transform = (partial(augment, cfg=ds.config, rng=augment_rng, rotation_deg=rotation, brightness=brightness)
                     if rotation or brightness else None)
        epoch_samples = balanced(samples, batches.steering(samples), rng) if tc["balance"] else samples
        loss = train_one_epoch(step_model, opt, batches, epoch_samples, int(tc["batch_size"]), bool(tc["flip"]),
                               rng, transform, float(tc["motion_dropout"]), progress, desc=f"epoch {epoch}",
                               ranks=ranks, loss_name=tc["loss"], smoothness=float(tc["smoothness"]))
        pred = predict(model, batches, val_idx)
        m = all_metrics(pred, truth, convention.degrees_per_unit)
        for what, value in (("training loss", loss), (f"validation {score}", m[score])):
            if not math.isfinite(value):  # stop before a diverged model can become the best one
                kept = "no checkpoint was saved" if best is None else f"best.pt keeps epoch {best['epoch']}"
                raise SteerlabError(f"training diverged in epoch {epoch}: the {what} is {value} (train.lr "
                                    f"{tc['lr']} may be too high); {kept}")
        if log is not None:
            history.append(log.write(epoch, loss, m, time.time() - t0))
        if progress:
            extra = "".join(f"  {k} {m[k]:.3f}" for k in ("speed_mae", "command_accuracy") if k in m)
            angles = (f"mae {m['mae_deg']:.2f} deg  gamma {m['gamma_deg']:.3f} (target {m['target_gamma_deg']:.3f})"
                      if np.isfinite(m["mae_deg"]) else f"mae {m['mae']:.4f} ({convention.unit})")
            print(f"epoch {epoch}: train loss {loss:.5f}  val rmse {m['rmse']:.4f}  {angles}{extra}")
        if tc["keep"] == "last" or best is None or m[score] < best[score]:
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
    if log is not None:
        log.close()
    return best
