"""The training config: a YAML file plus `section.key=value` overrides from the command line, parsed once into a
frozen `TrainConfig` whose every option is typed and range-checked (`steerlab.options`).

The sections `dagger`, `tune` and `closed_loop` belong to the commands that read them (`steerlab sim dagger`,
`steerlab tune`, the closed-loop suite) and are parsed into their own types there, before any work."""

from __future__ import annotations

import copy
import re
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Literal

import yaml

from steerlab.data.car import Car
from steerlab.data.native import EPISODES
from steerlab.data.preprocess import PreprocessConfig, PreprocessOptions
from steerlab.data.splits import Split
from steerlab.data.tub import is_tub
from steerlab.data.views import EXPECTED as VIEWS_EXPECTED, View
from steerlab.errors import SteerlabError, warn_once
from steerlab.models.registry import ModelSpec, learns_lane, learns_throttle, list_models
from steerlab import files
from steerlab.paths import a_path, distinct, same_path
from steerlab.files import UniqueKeys
from steerlab.options import (AT_LEAST_0, AT_LEAST_1, COUNT_MAX, Options, POSITIVE, Range, SEED, UNIT, WORKERS,
                              as_dict, option, parse)

LOSSES = {"mse": "rmse", "mae": "mae"}  # train.loss -> the validation metric that picks the best epoch


def _folder(recording: str) -> Path:
    """A recording's folder: a driving log or a native log.csv names the folder it lies in."""
    path = Path(recording)
    return path.parent if path.suffix == ".csv" and path.is_file() else path


@dataclass(frozen=True)
class TrainOptions(Options):
    """The train: section."""

    epochs: int = option(30, AT_LEAST_1)
    batch_size: int = option(100, AT_LEAST_1)
    lr: float = option(1e-4, POSITIVE)
    patience: int = option(5, AT_LEAST_1)
    flip: bool = option(False, help="mirror each sample left-right with probability 0.5, its steering negated "
                        "(paper 002 IV-B1)")
    seed: int = option(0, SEED)
    loss: Literal[tuple(LOSSES)] = option("mse", help="mse or mae of the steering (models with a loss of their "
                                          "own keep it); the best epoch has the lowest validation RMSE or MAE")
    smoothness: float = option(0.0, AT_LEAST_0, help="recurrent models: plus this weight times the same loss on "
                               "the steering's change between consecutive frames (paper 000's outlook)")
    exclude_episodes: tuple[Literal[EPISODES], ...] = option((), expected=f"a list of episode names ({', '.join(EPISODES)})",
                                               help="e.g. [drift-out]: train on the recovery half of drift episodes")
    side_cameras: bool = option(False, help="side-camera recovery synthesis (paper 002 Eq. 3)")
    side_offset_m: float | None = option(None, Range(0, 2, lo_open=True, unit="m"),
                                         help="side cameras' offset (default: the car's)")
    recovery_s: float = option(1.0, Range(0, 10, lo_open=True, unit="s"),
                               help="seconds in which a displaced car returns to its path (a small "
                               "car's views: pursuing the point this many seconds of travel ahead on it)")
    steering_ratio: float | None = option(None, POSITIVE, help="for the recovery labels (default: the car's)")
    views: tuple[View, ...] = option(
        (), expected=VIEWS_EXPECTED,
        help="viewpoint shifts (NVIDIA PilotNet): virtual cameras warped from the centre camera, each [shift_m "
             "left, yaw_deg left], a number or a range [lo, hi] drawn for every frame; one view of every frame each")
    calibration: str | None = option(None, path="file", help="views of a donkey-camera recording: the fisheye "
                                     "calibration of its camera (JSON or YAML: image size, K, D; default: the one "
                                     "the recording carries, else a 160-degree Raspberry Pi camera)")
    recovery_distance_m: float | None = option(None, Range(0, 200, lo_open=True, unit="m"),
                                               help="return distance without a speed signal")
    min_speed: float = option(0.0, Range(0, 100, unit="m/s"),
                              help="m/s; slower frames are dropped (paper 002 V-A uses 4)")
    balance: bool = option(False, help="thin out straight driving, redrawn every epoch (paper 003)")
    rotation_deg: float = option(0.0, Range(0, 180, unit="degrees"), help="augmentation (paper 002 IV-B1)")
    brightness: float = option(0.0, Range(0, 1, hi_open=True), help="brightness scaled within 1 +- this")
    hue_deg: float = option(0.0, Range(0, 180, unit="degrees"), help="RGB inputs: the hue turned by an angle "
                            "within +- this (colours of tape, paint and floor the recordings did not show)")
    motion_dropout: float = option(0.0, UNIT, help="fraction of samples shown 'no motion seen'")
    target_shift_s: float = option(0.0, Range(0, 5, unit="s"), help="train on the steering this many seconds ahead")
    recovery_weight: int = option(1, AT_LEAST_1, help="samples in recovery episodes are drawn this many times")
    epoch_samples: int = option(0, Range(0, COUNT_MAX), help="an epoch draws every training sample as many times "
                                "over as it takes to draw at least this many (0: once each): a short drive gets the "
                                "batches an epoch of a long one")
    keep: Literal["best", "last"] = option("best", help="best.pt: the best validation epoch, or the last one")
    init: str | None = option(None, expected="a checkpoint path", help="start from this checkpoint's weights")
    teacher: str | None = option(None, expected="a checkpoint path", help="distillation: its predictions")
    device: Literal["auto", "cpu", "cuda"] = "auto"
    tensorboard: bool = False
    throttle_weight: float = option(0.0, AT_LEAST_0, help="also learn the throttle where the recording varies it "
                                    "(a donkeycar tub's user/throttle): the loss plus this weight times the MAE of "
                                    "the throttle, as paper 002 weights steering and speed")
    lane_weight: float = option(0.0, AT_LEAST_0, help="also learn the lane the car is in (a track world recording's "
                                "lateral offset, heading error and curvature) with an auxiliary head: the loss plus "
                                "this weight times the MAE of the three over their scales (data.labels.LANE)")
    workers: int = option(0, Range(0, WORKERS.hi), help="data-loading worker processes (0: in this one; the results do not "
                                                 "depend on it)")
    precision: Literal["fp32", "bf16"] = option("fp32", help="bf16: the forward pass in bfloat16 (torch.autocast; "
                                                "about 1.5x faster on CPUs with AVX512-BF16 or AMX; on others, where "
                                                "it is emulated, training says so and runs in float32); the weights "
                                                "and the loss stay float32")


@dataclass(frozen=True)
class TrainConfig(Options):
    """A training run: the recording and what to take from it, the model, and how to train it."""

    data: str | None = option(None, expected="a recording's path")
    extra_data: tuple[str, ...] = option((), expected="a list of recordings", help="used whole, for training")
    range: str | None = option(None, expected='a frame range like "0:1800"')
    labels: str | None = None
    camera: str = "center"
    reader: dict = option({}, help="reader options, e.g. {full_lock_deg: 25, skip_missing: true}")
    cache: str | None = option(None, help="the cache root (data/cache.py)")
    preprocess: PreprocessOptions = field(default_factory=PreprocessOptions)
    split: Split = field(default_factory=Split)
    model: ModelSpec = field(default_factory=ModelSpec)
    train: TrainOptions = field(default_factory=TrainOptions)
    out: str = "runs/train"
    dagger: dict | None = None       # steerlab sim dagger (dagger.DaggerOptions)
    tune: dict | None = None         # steerlab tune's search space (tune/space.py)
    closed_loop: dict | None = None  # the closed-loop suite of a world (sim/worlds.closed_loop)

    def __post_init__(self):
        super().__post_init__()
        if not self.data:
            raise SteerlabError("the config names no data (set data: PATH or pass data=PATH)")
        for i, extra in enumerate(self.extra_data):  # every frame of an extra recording trains
            if same_path(_folder(extra), _folder(self.data)):
                raise SteerlabError(f"extra_data[{i}] {extra} is the training recording itself (data): its "
                                    "validation frames would be trained on; remove it from extra_data")
        distinct(self.extra_data, "recording of extra_data")
        t, cls = self.train, self.model.cls
        if t.smoothness > 0 and not cls.recurrent:
            raise SteerlabError(f"train.smoothness needs a recurrent model (it trains on windows of consecutive "
                                f"frames); {self.model.name!r} sees single frames in shuffled batches")
        if t.smoothness > 0 and self.model.options.get("seq_len", 2) < 2:
            raise SteerlabError(f"train.smoothness needs windows of at least 2 frames; model.seq_len is "
                                f"{self.model.options['seq_len']}")
        if t.balance and cls.recurrent:
            raise SteerlabError("balanced sampling picks single frames; recurrent models train on sequences "
                                "(paper 003 does not balance its LSTM either): set train.balance to false")
        if self.split.random is not None and cls.recurrent:
            raise SteerlabError(f"split.random draws single frames; model {self.model.name!r} trains on sequences "
                                "of consecutive frames: split by blocks (split.train and split.val)")
        if hasattr(cls, "loss") and t.loss != "mse":
            raise SteerlabError(f"model {self.model.name!r} trains on a loss of its own; train.loss={t.loss} does "
                                "not apply: remove it")
        if t.throttle_weight > 0 and not learns_throttle(self.model.name):
            able = ", ".join(m for m in list_models() if learns_throttle(m))
            raise SteerlabError(f"train.throttle_weight: model {self.model.name!r} does not learn a throttle; "
                                f"these do: {able}; choose one of them, or set train.throttle_weight to 0")
        if t.lane_weight > 0 and not learns_lane(self.model.name):
            able = ", ".join(m for m in list_models() if learns_lane(m))
            raise SteerlabError(f"train.lane_weight: model {self.model.name!r} has no lane head; these do: {able}; "
                                "choose one of them, or set train.lane_weight to 0")
        if t.lane_weight > 0 and (t.side_cameras or t.views):
            raise SteerlabError("train.lane_weight: the lane values are the centre camera's, not those of side "
                                "cameras or virtual views: set train.side_cameras and train.views off, or "
                                "train.lane_weight to 0")
        if not all(isinstance(v, View) for v in t.views):  # made in Python: each through the config's parse
            object.__setattr__(t, "views", tuple(View.parse_option(v, f"train.views[{i}]")
                                                 for i, v in enumerate(t.views)))
        fixed = [v.as_dict() for v in t.views if v.shift_m[0] == v.shift_m[1] and v.yaw_deg[0] == v.yaw_deg[1]]
        again = next((v for i, v in enumerate(fixed) if v in fixed[:i]), None)
        if again is not None:  # the same frames twice; a range given twice is two draws, two views
            raise SteerlabError(f"train.views names the fixed view {again} twice: give each fixed view once (a range "
                                "given N times gives N views of every frame)")
        if t.calibration is not None and not t.views:
            raise SteerlabError("train.calibration is the lens that train.views are warped through: set train.views "
                                "too, or leave the calibration out")
        inputs = self.preprocessing()
        if t.hue_deg and inputs.color != "rgb":
            raise SteerlabError(f"train.hue_deg turns the hue of RGB inputs; preprocess.color is {inputs.color}: "
                                "set preprocess.color: rgb or train.hue_deg: 0")
        self.model.check(inputs)  # the input fits the model's layers

    def inputs(self) -> list[str]:
        """Every path the run reads: recordings, a label file or video log, checkpoints. No output may be one."""
        return [p for p in (self.data, *self.extra_data, self.labels, self.reader.get("log"), self.train.init,
                            self.train.teacher, self.train.calibration) if isinstance(p, str)]

    def preprocessing(self, geometry: str | None = None) -> PreprocessConfig:
        """The preprocessing of this config's model on a recording of the camera `geometry`."""
        return self.model.preprocess(self.preprocess).resolve(geometry)

    def for_car(self, car: Car) -> TrainConfig:
        """The config with the car's values where it leaves them to the car (the side cameras' offset and the
        steering ratio of the recovery labels), as a run records it."""
        t = self.train
        return replace(self, train=replace(t, side_offset_m=car.side_camera_offset_m if t.side_offset_m is None
                                           else t.side_offset_m,
                                           steering_ratio=t.steering_ratio or car.steering_ratio))

    def identity(self) -> dict:
        """What a run's results depend on, as plain values: not where it is written or its cache is kept, not
        TensorBoard's logging or the data-loading workers, not a search space, and the side cameras' offset and the
        steering ratio only where recovery labels use them."""
        d = as_dict(self)
        for key in ("out", "cache", "tune"):
            del d[key]
        t = d["train"]
        del t["workers"], t["tensorboard"]
        if not t["side_cameras"]:
            del t["side_offset_m"]
        if not (t["side_cameras"] or t["views"]):
            del t["steering_ratio"]
        for key in ("throttle_weight", "lane_weight", "epoch_samples", "calibration"):  # runs from before these
            if not t[key]:
                del t[key]
        return d


class _Unset:
    def __repr__(self) -> str:
        return "(unset)"


UNSET = _Unset()  # a key one of two configs lacks


def differences(earlier: dict, now: dict, prefix: str = "") -> list[tuple[str, object, object]]:
    """(dotted key, earlier value, value now) of every key whose value differs between two nested mappings."""
    out = []
    for key in sorted(set(earlier) | set(now), key=str):
        a, b = earlier.get(key, UNSET), now.get(key, UNSET)
        if isinstance(a, dict) and isinstance(b, dict):
            out += differences(a, b, f"{prefix}{key}.")
        elif a != b:
            out.append((f"{prefix}{key}", a, b))
    return out


def another_config(out: Path, changes: list[tuple[str, object, object]], what: str = "a run") -> SteerlabError:
    """The error for a folder that holds `what` of another config, naming what differs (`differences`)."""
    shown = "; ".join(f"{key}: {a!r} -> {b!r}" for key, a, b in changes[:3])
    more = f"; and {len(changes) - 3} more" if len(changes) > 3 else ""
    return SteerlabError(f"{out} holds {what} of another config ({shown}{more}); choose a new out directory or "
                         "delete it")


def unreadable(out: Path, name: str, e: Exception, what: str = "a run") -> SteerlabError:
    """The error for a folder whose stored config (`name`) this version cannot read."""
    return SteerlabError(f"{out} holds {what} whose {name} this steerlab cannot read ({e.__class__.__name__}); "
                         "choose a new out directory or delete it")


# What a config that leaves them out gets on a donkeycar tub, under the user's own settings: the recipe chosen on the
# selection blocks of the three shared tubs (docs/results/donkeycar.md, "The tub defaults: linear-views"):
# donkeycar linear's layout (donkey-linear) on the whole 160x120 RGB frame as donkeycar feeds it, the MAE loss
# (it suits the nearly binary steering of an RC car), batch 32, Adam 3e-4, the throttle learned beside the steering
# with weight 0.5, and every frame also seen from a car moved up to 15 cm and turned up to 15 degrees, labelled with
# the steering back to the path in 0.3 s (TUB_VIEWS: they need the car's full-lock angle). A config with a model
# section of its own keeps its input and gets no views: the training settings only (`tub_defaults`).
TUB_VIEWS = {"views": [[[-0.15, 0.15], [-15, 15]]], "recovery_s": 0.3}
TUB_DEFAULTS = {"preprocess": {"crop": [0, 0, 0, 0], "width": 160, "height": 120, "color": "rgb"},
                "model": {"name": "donkey-linear"},
                "train": {"batch_size": 32, "lr": 3.0e-4, "loss": "mae", "throttle_weight": 0.5, **TUB_VIEWS}}
SECTIONS = [f.name for f in fields(TrainConfig)]


def override_key(text: str) -> str:
    """The dotted key a `section.key=value` override sets."""
    return text.split("=", 1)[0].strip()


def apply_override(cfg: dict, text: str) -> None:
    """`section.key=value` into a raw config; the value is read as YAML."""
    if "=" not in text:
        raise SteerlabError(f"override {text!r} must look like section.key=value, e.g. train.epochs=5")
    key, value = text.split("=", 1)
    parts = key.strip().split(".")
    node = cfg
    for p in parts[:-1]:
        node = node.setdefault(p, {})
        if not isinstance(node, dict):
            raise SteerlabError(f"override {text!r}: {p!r} is not a section; give the key of a value, "
                                "e.g. train.epochs=2")
    # a frame range such as 0:1800 stays text (YAML 1.1 would read it as a base-60 number)
    if re.fullmatch(r"\s*\d*:\d*\s*", value):
        node[parts[-1]] = value
        return
    try:
        node[parts[-1]] = yaml.load(value, Loader=UniqueKeys)
    except yaml.YAMLError as e:
        raise SteerlabError(f"override {text!r}: the value is not valid YAML ({getattr(e, 'problem', None) or e}); "
                            f"quote it: {key}='\"{value}\"'") from None


def read_yaml(path: str | Path, what: str = "sections (data, split, model, train, ...)") -> dict:
    """A YAML config file as a mapping, with one-line errors."""
    path = Path(path)
    data = files.read_yaml(path, "config file") or {}
    if not isinstance(data, dict):
        raise SteerlabError(f"{path}: expected a mapping of {what}")
    return data


def layered(*layers: dict | None, overrides=()) -> dict:
    """Raw config layers merged in order (the train section key by key, every other section whole), then the
    overrides, each key once (of two, which one counts would be a guess)."""
    cfg: dict = {}
    for layer in layers:
        for k, v in (layer or {}).items():
            if k == "train" and isinstance(v, dict) and isinstance(cfg.get(k), dict):
                cfg[k] = {**cfg[k], **copy.deepcopy(v)}
            else:
                cfg[k] = copy.deepcopy(v)
    given: dict[str, str] = {}
    for o in overrides:
        key = override_key(o)
        if key in given and "=" in o:
            raise SteerlabError(f"override {key}= is given twice ({given[key]!r} and {o!r}); give each key once")
        given[key] = o
        apply_override(cfg, o)
    return cfg


def tub_defaults(given: dict) -> dict:
    """TUB_DEFAULTS as they lie under `given`, a tub's config as the user wrote it (its layers merged): a config with
    a model section of its own keeps its input and trains without the views; so does one that chooses its own
    recovery (train.views, side_cameras) or learns the lane (lane_weight: the lane is the recorded camera's), and one
    whose reader gives no full-lock angle (the views' labels are steering angles; `say_without_views` says so)."""
    train = given.get("train") if isinstance(given.get("train"), dict) else {}
    reader = given.get("reader") if isinstance(given.get("reader"), dict) else {}
    own = "model" in given
    defaults = {k: v for k, v in TUB_DEFAULTS.items() if not (own and k in ("preprocess", "model"))}
    if own or any(k in train for k in ("views", "side_cameras", "lane_weight")) or reader.get("full_lock_deg") is None:
        return {**defaults, "train": {k: v for k, v in defaults["train"].items() if k not in TUB_VIEWS}}
    return defaults


def say_without_views(cfg: TrainConfig, full_lock: bool) -> None:
    """A tub trained on the tub defaults' model without views, its reader giving no full-lock angle (`full_lock`),
    is told what it misses, once a process."""
    data = cfg.data or ""
    if (not full_lock and not cfg.train.views and cfg.model.name == TUB_DEFAULTS["model"]["name"]
            and is_tub(Path(data))):
        warn_once(f"{data}: trains without the tub defaults' views (a car moved and turned, labelled with the steering "
             "back to its path): they need the car's full-lock angle, e.g. reader option full_lock_deg=25")


def parse_config(*layers: dict | None, overrides=(), source: Path | None = None) -> TrainConfig:
    """Raw config layers (plain values, merged by `layered`) and overrides as a TrainConfig. Under them lie the
    default model and, when the data is a donkeycar tub, TUB_DEFAULTS as `tub_defaults` lays them (a model with a
    loss of its own keeps it, a model that cannot learn the throttle learns none). `source`: the config file, named
    in errors about the whole config."""
    plain = layered({"model": as_dict(ModelSpec())}, *layers, overrides=overrides)
    raw = plain
    if isinstance(plain.get("data"), str) and is_tub(Path(plain["data"])):
        raw = layered(tub_defaults(layered(*layers, overrides=overrides)), *layers, overrides=overrides)
        model, own = raw.get("model"), plain.get("train") if isinstance(plain.get("train"), dict) else {}
        if isinstance(model, dict) and hasattr(ModelSpec.parse_option(model, "model").cls, "loss"):
            raw["train"]["loss"] = own.get("loss", "mse")
        if isinstance(model, dict) and not learns_throttle(ModelSpec.parse_option(model, "model").name):
            raw["train"]["throttle_weight"] = own.get("throttle_weight", 0.0)
    unknown, where = sorted(set(raw) - set(SECTIONS)), f"{source}: " if source else ""  # the file, when one
    if unknown:
        raise SteerlabError(f"{where}unknown config sections {unknown}; known: {sorted(SECTIONS)}: is it a config?")
    if not raw.get("data"):
        raise SteerlabError(f"{where}the config names no data (set data: PATH or pass data=PATH)")
    return parse(TrainConfig, raw)


def load_config(path: str | Path | None = None, overrides=(), base: dict | None = None) -> TrainConfig:
    """`base` <- the YAML file <- overrides, parsed. Relative data paths are taken relative to the working
    directory."""
    if base is not None and not isinstance(base, dict):
        raise SteerlabError(f"load_config: base must be a dict of config sections, got {base!r}")
    if isinstance(overrides, str) or not isinstance(overrides, (list, tuple)):
        raise SteerlabError(f"load_config: overrides must be a list of section.key=value texts, got {overrides!r}")
    path = None if path is None else a_path(path, "load_config: path")
    return parse_config(base, None if path is None else read_yaml(path), overrides=overrides, source=path)
