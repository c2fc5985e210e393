"""What training learns from, assembled from a config: the compiled dataset and its split, the model's
preprocessing, the usable frames, and the training sources (centre camera, side cameras and virtual views
with recovery labels, extra recordings), gathered into standardised batches by `Batches`. Experiments,
DAgger and the benchmarks build their data with the same functions as `train`."""

from __future__ import annotations

from functools import partial

import numpy as np
import torch

from steerlab.data.dataset import CompiledDataset, compile_recording
from steerlab.data.geometry import CAMERAS
from steerlab.data.inputs import (Standardizer, flip_horizontal, gather, history, no_motion, segment_starts,
                                   stack_modalities)
from steerlab.data.labels import speed_targets
from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.readers import open_recording
from steerlab.data.recording import SteeringConvention
from steerlab.errors import SteerlabError
from steerlab.models import model_class


def prepare_dataset(cfg: dict, progress: bool = True, camera: str | None = None, view: tuple | None = None,
                    data: str | None = None) -> CompiledDataset:
    """The compiled main recording of a config (or the whole recording `data`), one camera stream of it, or a
    virtual view (shift_m, yaw_deg) synthesised from its centre camera."""
    rec = (open_recording(cfg["data"], cfg.get("range"), cfg.get("labels"), cfg.get("reader")) if data is None
           else open_recording(data))
    camera = camera or cfg.get("camera", "center")
    if camera not in rec.frames:
        raise SteerlabError(f"{rec.source} has no {camera!r} camera (it has {', '.join(rec.cameras)})")
    if view is not None and rec.geometry not in CAMERAS:
        raise SteerlabError(f"viewpoint shifts need the camera geometry of the recording; {rec.source} has the "
                            f"{rec.geometry!r} preset, and geometry is known for {', '.join(CAMERAS)}")
    pre_cfg = dict(cfg.get("preprocess") or {})
    if "crop" not in pre_cfg:
        pre_cfg.setdefault("preset", rec.geometry)
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


def steering_ahead(ds: CompiledDataset, seconds: float, steering: np.ndarray | None = None) -> np.ndarray:
    """Each frame's target is the steering (`steering`, default the recorded one) `seconds` later in its
    segment (the segment's last value at its end)."""
    steering = ds.steering if steering is None else steering
    if not seconds:
        return steering
    k = int(round(seconds * ds.meta["frame_rate"]))
    seg = ds.labels["segment"]
    last = np.r_[np.flatnonzero(np.diff(seg)), len(seg) - 1]  # each segment's last frame
    return steering[np.minimum(np.arange(len(seg)) + k, last[seg])]


def teacher_steering(cfg: dict, teacher: dict, progress: bool) -> np.ndarray:
    """Distillation (`train.teacher`): the steering a trained checkpoint (an ensemble, say) predicts for every
    frame of the config's recording, streamed segment by segment as the Pilot drives; it replaces the recorded
    steering as the training target of the main recording (validation still scores against the recording)."""
    from tqdm import tqdm

    from steerlab.evaluate.offline import conventions_match, describe
    from steerlab.pilot import Pilot

    rec = open_recording(cfg["data"], cfg.get("range"), cfg.get("labels"), cfg.get("reader"))
    pilot = Pilot(teacher)
    where = f"{cfg['train']['teacher']}: train.teacher"
    if not conventions_match(pilot.convention, rec.convention):
        raise SteerlabError(f"{where} predicts {describe(pilot.convention)} steering and {rec.source} records "
                            f"{describe(rec.convention)} steering: a teacher of the recording's convention is needed")
    if pilot.geometry != rec.geometry:
        raise SteerlabError(f"{where} was trained on the {pilot.geometry!r} camera geometry and {rec.source} has "
                            f"the {rec.geometry!r} geometry")
    out = []
    with tqdm(total=len(rec), desc="teacher", unit="frame", disable=None if progress else True) as bar:
        for a, b in rec.segments():
            pilot.reset()
            speeds = None if rec.speed is None else rec.speed[a:b]
            for c in pilot.stream(range(a, b), speeds, partial(rec.load_frame, camera=cfg.get("camera", "center"))):
                out.append(c.steering)
                bar.update()
    return np.asarray(out, np.float32)


def training_sources(cfg: dict, ds: CompiledDataset, train_idx: np.ndarray, progress: bool,
                     teacher: dict | None = None):
    """The training streams and the codes of their training frames (see `Batches`): the main recording's
    training split and every usable frame of the extra recordings, each with its side cameras (`side_cameras`;
    an extra recording without them adds its centre frames only) and virtual views (`views`: [shift_m, yaw_deg] pairs) labelled with the
    recovery steering. With a `teacher` checkpoint the main recording's targets are its predictions."""
    tc = cfg["train"]
    taught = None if teacher is None else teacher_steering(cfg, teacher, progress)
    recordings = [(None, ds, train_idx, True)]
    for path in cfg.get("extra_data") or []:
        extra = prepare_dataset(cfg, progress, data=path)
        idx = usable_frames(extra, np.arange(len(extra)), f"extra recording {path}", float(tc["min_speed"]),
                            tc.get("exclude_episodes"))
        recordings.append((path, extra, idx, {"left", "right"} <= set(open_recording(path).cameras)))
    sources, codes, offset = [], [], 0
    for path, main, idx, sides in recordings:
        ahead = steering_ahead(main, float(tc["target_shift_s"]), taught if path is None else None)
        streams = [(main, ahead)]
        if tc["side_cameras"] and sides:
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
