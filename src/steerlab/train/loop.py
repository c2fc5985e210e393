"""The training loop: `train(cfg)` = `build` (the data, the model, the batches of every epoch) then `fit`
(epochs of training and validation, checkpoints).

Batches come from the memory-mapped cache through `batches.loader`; validation reads the same cache. The best
checkpoint (lowest validation RMSE, or MAE for the MAE loss) is `best.pt`; `last.pt` also holds the optimiser
and RNG state and the identity of the data, so a run that is interrupted continues where it stopped when
started again with the same config on the same data.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from steerlab.files import exponents_read, write_json
from steerlab.checkpoint import load_checkpoint, save_checkpoint
from steerlab.cpu import bf16_instructions
from steerlab.data.cache import cache_root
from steerlab.data.car import car_of
from steerlab.data.dataset import CompiledDataset
from steerlab.data.inputs import channel_stats, segment_starts
from steerlab.data.recording import SteeringConvention
from steerlab.data.splits import make_split
from steerlab.errors import SteerlabError, warn
from steerlab.evaluate.metrics import all_metrics
from steerlab.evaluate.scoring import write_predictions
from steerlab.locks import folder_lock
from steerlab.paths import check_outputs
from steerlab.models import SteeringModel, create_model
from steerlab.models.registry import predicted
from steerlab.options import as_dict
from steerlab.train.batches import (Batch, EpochSampler, FrameBatches, balance_weights, epoch_repeats, loader,
                                    recovery_repeats, sequence_windows)
from steerlab.train.config import LOSSES, TrainConfig, another_config, differences, parse_config, unreadable
from steerlab.train.distributed import Ranks, setup, wrap
from steerlab.train.host import keep_freed_memory
from steerlab.train.log import METRIC, EpochLog
from steerlab.train.sources import (check_camera, check_extra_data, check_views, main_recording, prepare_dataset,
                                    steering_ahead, throttle_learned, training_sources, usable_frames)


def _mean_error(error: torch.Tensor, loss: str) -> torch.Tensor:
    return torch.mean(error ** 2) if loss == "mse" else torch.mean(error.abs())


def objective(model, out: dict, targets: dict, loss: str = "mse", smoothness: float = 0.0,
              throttle_weight: float = 0.0, lane_weight: float = 0.0) -> torch.Tensor:
    """The model's own loss when it has one, otherwise the MSE or the MAE of its steering; with `smoothness`,
    plus that weight times the same error of the steering's change from frame to frame within each window
    (recurrent outputs (B, T): the predicted change against the recorded one); for a model that learns the
    throttle, plus `throttle_weight` times the MAE of the throttle (paper 002 weights its speed MAE so); for one
    with a lane head, plus `lane_weight` times the MAE of the lane's three values over their scales."""
    value = (model.loss(out, targets) if hasattr(model, "loss")
             else _mean_error(out["steering"] - targets["steering"], loss))
    if smoothness:
        change = torch.diff(out["steering"], dim=-1) - torch.diff(targets["steering"], dim=-1)
        value = value + smoothness * _mean_error(change, loss)
    if "throttle" in out:
        value = value + throttle_weight * torch.mean((out["throttle"] - targets["throttle"]).abs())
    if "lane" in out:
        value = value + lane_weight * torch.mean((out["lane"] - targets["lane"]).abs())
    return value


def train_one_epoch(model, opt, batches, ranks: Ranks = Ranks(), loss_name: str = "mse", smoothness: float = 0.0,
                    weights: tuple[float, float] = (0.0, 0.0), progress: bool = True, desc: str = "",
                    precision: str = "fp32") -> float:
    """One pass over `batches` (a DataLoader of this rank's share of each global batch), returning the mean
    training loss over all ranks (`weights`: the throttle's and the lane's in `objective`); with `precision` bf16
    the forward pass runs in bfloat16."""
    net = getattr(model, "module", model)  # the model itself, also inside DDP
    model.train()
    total, count = 0.0, 0
    for inputs, targets, weight in tqdm(batches, desc=desc, unit="batch", leave=False,
                                        disable=None if progress and ranks.main else True):
        inputs, targets = ({k: v.to(ranks.device, non_blocking=True) for k, v in d.items()} for d in (inputs, targets))
        n = len(targets["steering"])
        with torch.autocast(ranks.device.type, torch.bfloat16, enabled=precision == "bf16"):
            out = model(**inputs)
        loss = objective(net, out[0] if net.recurrent else out, targets, loss_name, smoothness,  # (out, state)
                         *weights)
        opt.zero_grad(set_to_none=True)
        (loss * weight if ranks.world > 1 else loss).backward()
        opt.step()
        total += float(loss.detach()) * n
        count += n
    total, count = ranks.sum(total, count)
    return total / count


def _numpy(out: dict) -> dict[str, np.ndarray]:
    """Model outputs as predictions: steering, speed, throttle, lane, and the most likely speed command."""
    pred = {k: out[k].cpu().numpy().astype(np.float64) for k in ("steering", "speed", "throttle", "lane") if k in out}
    if "command" in out:
        pred["command"] = out["command"].argmax(-1).cpu().numpy()
    return pred


@torch.inference_mode()
def predict(model, data: FrameBatches, idx: np.ndarray, batch_size: int = 256) -> dict[str, np.ndarray]:
    """Predictions for frames `idx` (in time order). Recurrent models run statefully through each contiguous
    run of frames, from a zero state at the start of the run and at every segment start, as the Pilot does."""
    model.eval()
    device = next(model.parameters(), torch.zeros(0)).device

    def inputs(frames):
        return {k: v.to(device) for k, v in data[Batch(frames)][0].items()}

    parts = []
    if not model.recurrent:
        for s in range(0, len(idx), batch_size):
            parts.append(_numpy(model(**inputs(idx[s: s + batch_size]))))
    else:
        breaks = np.flatnonzero((np.diff(idx) != 1) | (data.starts[idx[1:]] == idx[1:])) + 1
        for frames in np.split(idx, breaks):
            state = None
            for s in range(0, len(frames), batch_size):
                out, state = model(**{k: v[None] for k, v in inputs(frames[s: s + batch_size]).items()},
                                   state=state)
                parts.append(_numpy({k: v[0] for k, v in out.items()}))
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


@dataclass
class Run:
    """What `build` makes of a config and `fit` trains: the compiled main recording and its validation frames
    with their targets, the model, the batches and the epoch sampler."""

    cfg: TrainConfig
    ds: CompiledDataset
    model: SteeringModel
    model_cfg: dict
    stats: dict
    data: FrameBatches
    sampler: EpochSampler
    train_codes: np.ndarray
    val_idx: np.ndarray
    truth: dict
    convention: SteeringConvention

    def checkpoint(self, path: Path, metrics: dict, **extra) -> None:
        save_checkpoint(path, self.model, self.model_cfg, self.ds.config, self.stats, self.convention, metrics,
                        geometry=self.ds.meta["geometry"], frame_rate=self.ds.meta["frame_rate"], **extra)


def train(cfg: TrainConfig, progress: bool = True, on_epoch=None) -> dict:
    """Train one model as configured; returns the best validation metrics. Resumes from `out/last.pt`.
    `on_epoch(epoch, metrics)` is called after every epoch's checkpoint (steerlab tune reports and prunes
    there: an exception it raises ends the run, which stays resumable). The run holds a lock on `out`: a
    second run into the same folder is refused while the first one runs."""
    if not isinstance(cfg, TrainConfig):
        raise SteerlabError(f"train takes a TrainConfig (steerlab.train.config.load_config(PATH)), got {cfg!r}")
    check_outputs({"output folder (out)": cfg.out}, inputs=cfg.inputs(), kind="run")
    check_outputs({"cache folder (cache)": cache_root(cfg.cache)}, inputs=cfg.inputs(), kind="cache")
    keep_freed_memory()
    out = Path(cfg.out)
    ranks = setup(cfg.train.device)
    if cfg.train.batch_size % ranks.world:
        raise SteerlabError(f"train.batch_size {cfg.train.batch_size} is the global batch; it must divide evenly "
                            f"over {ranks.world} ranks")
    # checkpoints named by the config are read before any work: a bad one fails at once
    for key, role in (("init", "starting point"), ("teacher", "teacher")):
        path = getattr(cfg.train, key)
        if path and Path(path).suffix == ".onnx":
            raise SteerlabError(f"{path}: train.{key}: an .onnx file cannot be a {role} (it holds a graph for ONNX "
                                "Runtime, not weights to train); name the .pt checkpoint it was exported from")
    init, teacher = (_named_checkpoint(cfg.train, key) for key in ("init", "teacher"))
    rec = main_recording(cfg)
    check_camera(cfg, rec)  # before the run folder is made
    check_extra_data(cfg, rec)
    check_views(cfg, rec)
    car = car_of(rec.geometry)
    cfg = cfg.for_car(car)
    if not ranks.main:  # rank 0 holds the lock for all ranks
        return fit(build(cfg, ranks, progress, init, teacher), ranks, False, on_epoch)
    out.mkdir(parents=True, exist_ok=True)
    with folder_lock(out, "steerlab train run"):
        for tmp in out.glob("*.tmp-*"):  # left by a killed run: only the holder of the lock writes here
            tmp.unlink(missing_ok=True)
        _claim(out, cfg, car)
        return fit(build(cfg, ranks, progress, init, teacher), ranks, progress, on_epoch)


def _named_checkpoint(options, key: str) -> dict | None:
    """The checkpoint `train.<key>` names (None: none), its errors naming the option."""
    path = getattr(options, key)
    try:
        return load_checkpoint(path) if path else None
    except SteerlabError as e:
        raise SteerlabError(f"train.{key}: {e}") from None


STOPPING = ("train.epochs", "train.patience")  # when a run stops: a run continues under larger ones


def run_changes(out: Path, cfg: TrainConfig, car=None, grows=()) -> list[tuple[str, object, object]]:
    """What differs between the run in the folder `out` and `cfg` (`config.differences`), but the keys of `grows`
    where the value only grew (a run of an earlier version's config, with fewer options, text for numbers or the
    car's values written out, is the same run when it parses to the same settings); [] for a run of `cfg`. `car`:
    the recording's, found when not given."""
    car = car or car_of(main_recording(cfg).geometry)
    try:
        earlier = parse_config(exponents_read(json.loads((out / "config.json").read_text()))).for_car(car).identity()
    except (OSError, ValueError, SteerlabError) as e:
        raise unreadable(out, "config.json", e) from None
    return [(key, a, b) for key, a, b in differences(earlier, cfg.for_car(car).identity())
            if not (key in grows and b > a)]


def _claim(out: Path, cfg: TrainConfig, car) -> None:
    """A folder that holds a run of another config is refused; one of the same config under more epochs or more
    patience continues (fewer is another config: what was trained already went further)."""
    if (out / "last.pt").exists() and (changes := run_changes(out, cfg, car, grows=STOPPING)):
        raise another_config(out, changes)
    if cfg.model.cls.trainable and (out / "best.pt").exists() and not (out / "last.pt").exists():
        raise SteerlabError(f"{out} holds a run's best.pt but not the last.pt it resumes from (removed?): training "
                            "there would start again and write over best.pt; choose a new out directory, or move "
                            "best.pt away")
    write_json(out / "config.json", as_dict(cfg))


def _but_throttle(model_cfg: dict) -> dict:
    return {k: v for k, v in model_cfg.items() if k != "throttle"}


def _with_throttle_row(init: dict, own: dict, where, say: bool) -> dict:
    """`init`'s weights for a model that differs from it only in the throttle (the second value of the last
    layer): a pretrained throttle row is dropped where the recording's throttle is constant, and a model that
    learns the throttle keeps its own fresh row where the pretrained one had none (said once)."""
    out, change = dict(init), None
    for key, w in init.items():
        mine = own[key]
        if w.shape != mine.shape:
            if w.shape[1:] != mine.shape[1:] or {w.shape[0], mine.shape[0]} != {1, 2}:
                raise SteerlabError(f"{where}: train.init's {key} has the shape {tuple(w.shape)}, the model's "
                                    f"{tuple(mine.shape)}: give a train.init of this model and its options")
            out[key] = w[:1] if mine.shape[0] == 1 else torch.cat([w, mine[1:]])
            change = "its throttle output dropped" if mine.shape[0] == 1 else "a new throttle output"
    if say and change:
        print(f"{where}: train.init with {change}")
    return out


def build(cfg: TrainConfig, ranks: Ranks, progress: bool, init: dict | None, teacher: dict | None) -> Run:
    """Compile the data (rank 0 first, the other ranks then read the cache), pick the usable frames of the
    split, gather the training sources and make the model and the epoch sampler."""
    t = cfg.train
    progress = progress and ranks.main
    if not ranks.main:
        ranks.barrier()
    ds = prepare_dataset(cfg, progress)
    if ranks.main:
        ranks.barrier()
    model_cfg = cfg.model.arguments(ds.config)
    if throttle_learned(cfg, ds, ranks.main):
        model_cfg["throttle"] = True
    if t.lane_weight:
        model_cfg["lane"] = True
    if init:  # before the other streams compile
        if init.get("geometry", ds.meta["geometry"]) != ds.meta["geometry"]:  # older checkpoints record none
            raise SteerlabError(f"{t.init}: train.init was trained on the {init['geometry']!r} camera geometry "
                                f"and {ds.meta['source']} has the {ds.meta['geometry']!r} geometry: pretrain on "
                                "recordings of the same camera (steerlab sim record --geometry)")
        if init["model"] != cfg.model.name or _but_throttle(init["model_cfg"]) != _but_throttle(model_cfg):
            raise SteerlabError(f"{t.init}: train.init must be a checkpoint of the same model and options "
                                f"({cfg.model.name}, {model_cfg}); it holds {init['model']}, {init['model_cfg']}")
    train_idx, val_idx = make_split(cfg.split, len(ds), ds.labels.get("session"))
    train_idx = usable_frames(ds, train_idx, "training", t.min_speed, t.exclude_episodes)
    val_idx = usable_frames(ds, val_idx, "validation", t.min_speed)
    stats = channel_stats(ds.arrays, ds.config, train_idx, segment_starts(ds.labels["segment"]))
    sources, train_codes = training_sources(cfg, ds, train_idx, progress, teacher)
    torch.manual_seed(t.seed)
    model = create_model(cfg.model.name, **model_cfg)
    if init:
        model.load_state_dict(_with_throttle_row(init["state_dict"], model.state_dict(), t.init, ranks.main))
    if (model.targets or model.speed_history) and "speed" not in ds.labels:
        raise SteerlabError(f"model {cfg.model.name!r} needs a recording with speed; {ds.meta['source']} has none")
    data = FrameBatches(sources, stats, model.speed_history, t.rotation_deg, t.brightness, model.learns_throttle,
                        t.hue_deg, model.learns_lane)
    samples = train_codes
    if model.recurrent:
        samples = sequence_windows(train_codes, data.starts, model.seq_len)
        if len(samples) == 0:
            raise SteerlabError(f"{ds.meta['source']}: no training window of {model.seq_len} consecutive frames in "
                                f"one segment of the training frames (split.train): train on more frames, or set "
                                f"model.seq_len below {model.seq_len}")
    repeats = None
    if t.recovery_weight > 1:
        episodes = data.episodes()
        if not np.isin(episodes, "recover").any():
            raise SteerlabError("recovery_weight needs recordings with recovery episodes (the road and track worlds')")
        repeats = recovery_repeats(samples, episodes, t.recovery_weight)
    repeats = epoch_repeats(len(samples), repeats, t.epoch_samples)
    weights = balance_weights(data.steering(samples)) if t.balance else None
    sampler = EpochSampler(samples, t.batch_size, t.seed, t.flip, t.motion_dropout, weights, repeats, ranks.rank,
                           ranks.world)
    if all(p.dim() != 5 for p in model.parameters()):  # channels-last exists for 2-D convolutions only
        model = model.to(memory_format=torch.channels_last)
    recorded = steering_ahead(ds, t.target_shift_s)  # the recording's, also under a teacher
    truth = {"steering": recorded[val_idx], **{k: v[val_idx] for k, v in data.targets.items()}}
    return Run(cfg, ds, model, model_cfg, stats, data, sampler, train_codes, val_idx, truth,
               SteeringConvention(**ds.meta["convention"]))


def fit(run: Run, ranks: Ranks, progress: bool, on_epoch=None) -> dict:
    """Train `run` epoch by epoch (continuing from `out/last.pt` when it holds the same data), validating after
    each, until `train.epochs` or `train.patience` epochs without a better validation score; returns the
    best validation metrics."""
    cfg, t, model = run.cfg, run.cfg.train, run.model
    out, score = Path(cfg.out), LOSSES[t.loss]
    deg = run.convention.degrees_per_unit

    def save(path, metrics, **extra):
        if ranks.main:
            run.checkpoint(path, metrics, **extra)

    def keep_predictions(pred):
        if ranks.main:
            write_predictions(out / "val_predictions.csv", run.ds.labels["frame_ids"][run.val_idx], pred["steering"],
                              {k: v for k, v in pred.items() if k not in ("steering", "lane")})

    if not model.trainable:
        model.fit(run.data.steering(run.train_codes))
        pred = predict(model, run.data, run.val_idx)
        metrics = {**all_metrics(pred, run.truth, deg), "epoch": 0}
        save(out / "best.pt", metrics)
        keep_predictions(pred)
        return metrics

    step_model = wrap(model, ranks)  # on the device; in DDP with several ranks
    # fused: one kernel for all parameters; the per-tensor updates were a sixth of PilotNet's step on a CPU
    opt = torch.optim.Adam(model.parameters(), lr=t.lr, fused=True)
    data_id = run.ds.path.name  # the compiled cache entry: its name holds the hash of the source and its labels
    start, best, since_best, history = 1, None, 0, []
    if (out / "last.pt").exists():
        state = load_checkpoint(out / "last.pt")
        if state.get("data", data_id) != data_id:
            raise SteerlabError(f"{out} holds a run trained on other data ({state['data']}, now {data_id}: the "
                                "recording or its labels changed); choose a new out directory or delete it")
        model.load_state_dict(state["state_dict"])
        opt.load_state_dict(state["optimizer"])
        start, best, since_best, history = state["epoch"] + 1, state["best"], state["since_best"], state["history"]
        torch.set_rng_state(state["torch_rng"])
        if ranks.main:
            print(f"resuming {out} after epoch {state['epoch']}")
    precision = t.precision
    if precision == "bf16" and ranks.device.type == "cpu" and bf16_instructions() is False:
        precision = "fp32"  # emulated, bfloat16 is 9x slower than float32 (docs/results/speed.md)
        if ranks.main:
            warn("train.precision bf16: this CPU has no bfloat16 instructions (avx512_bf16, amx_bf16; or "
                 "ONEDNN_MAX_CPU_ISA keeps torch from them), where bfloat16 is emulated and slower: training in "
                 "float32")
    log = EpochLog(out, predicted(model), history, t.tensorboard) if ranks.main else None
    batches = loader(run.data, run.sampler, t.workers, ranks.device)
    if progress and start <= t.epochs:
        print(f"training on {len(run.train_codes):,} frames of {len(run.data.sources)} camera stream(s), "
              f"{len(batches)} batches of {t.batch_size} an epoch; validating on {len(run.val_idx):,} frames")
    for epoch in range(start, t.epochs + 1):
        if since_best >= t.patience and t.keep == "best":
            break
        t0 = time.time()
        run.sampler.set_epoch(epoch)
        loss = train_one_epoch(step_model, opt, batches, ranks, t.loss, t.smoothness, (t.throttle_weight,
                               t.lane_weight), progress, f"epoch {epoch}", precision)
        trained = time.time() - t0
        pred = predict(model, run.data, run.val_idx)
        m = all_metrics(pred, run.truth, deg)
        for what, value in (("training loss", loss), (f"validation {score}", m[score])):
            if not math.isfinite(value):  # stop before a diverged model can become the best one
                kept = "no checkpoint was saved" if best is None else f"best.pt keeps epoch {best['epoch']}"
                raise SteerlabError(f"training diverged in epoch {epoch}: the {what} is {value} (train.lr "
                                    f"{t.lr:g} may be too high: lower it); {kept}")
        if log is not None:
            history.append(log.write(epoch, loss, m, trained, time.time() - t0))
        if progress:
            extra = "".join(f"  {k} {m[k]:.3f}" for k in METRIC.values() if k in m)
            angles = (f"mae {m['mae_deg']:.2f} deg  gamma {m['gamma_deg']:.3f} (target {m['target_gamma_deg']:.3f})"
                      if np.isfinite(m["mae_deg"]) else
                      f"mae {m['mae']:.4f} ({run.convention.unit}; degrees n/a: no full-lock angle)")
            print(f"epoch {epoch}: train loss {loss:.5f}  val rmse {m['rmse']:.4f}  {angles}{extra}")
        if t.keep == "last" or best is None or m[score] < best[score]:
            best, since_best = {**m, "epoch": epoch}, 0
            save(out / "best.pt", best)
            keep_predictions(pred)
        else:
            since_best += 1
        save(out / "last.pt", best, optimizer=opt.state_dict(), epoch=epoch, best=best, since_best=since_best,
             history=history, torch_rng=torch.get_rng_state(), data=data_id)
        if on_epoch is not None:
            on_epoch(epoch, m)
    if log is not None:
        log.close()
    return best
