"""Training configuration: a YAML file plus `section.key=value` overrides from the command line."""

from __future__ import annotations

import copy
import math
import re
from pathlib import Path

import yaml

from steerlab.data.geometry import STEERING_RATIO
from steerlab.data.tub import is_tub
from steerlab.errors import SteerlabError

DEFAULTS = {
    "data": None,            # recording folder or driving_log.csv
    "extra_data": [],        # more recordings, used whole for training only (e.g. DAgger rollouts)
    "range": None,           # frames of the recording to use, "a:b"
    "labels": None,          # CH2: label CSV when the folder holds several
    "camera": "center",
    "reader": {},            # reader options, e.g. {full_lock_deg: 25, skip_missing: true} for donkeycar tubs
    "cache": ".steerlab-cache",
    "preprocess": {},        # PreprocessConfig fields; "preset" defaults to the recording's
    "split": {"protocol": "paper", "k": 3, "length": 1000},
    "model": {"name": "pilotnet", "dropout": 0.5},  # split, model and preprocess are replaced whole
    "train": {
        "epochs": 30, "batch_size": 100, "lr": 1e-4, "patience": 5, "flip": False, "seed": 0,
        "loss": "mse",        # mse or mae of the steering (models with a loss of their own keep it); the best
                              # epoch is the one with the lowest validation RMSE (mse) or MAE (mae)
        "smoothness": 0.0,    # recurrent models: plus this weight times the same loss on the steering's change
                              # between consecutive frames (smoothness in the cost function, paper 000's outlook)
        "exclude_episodes": [],  # e.g. [drift-out] to train on the recovery half of drift episodes only
        # side-camera recovery synthesis (paper 002 Eq. 3): left/right frames with a recovery angle added
        "side_cameras": False, "side_offset_m": 0.508, "recovery_s": 1.0, "steering_ratio": STEERING_RATIO,
        # viewpoint shifts (NVIDIA PilotNet): virtual cameras [shift_m (left +), yaw_deg (left +)] warped from
        # the centre camera, labelled like the side cameras; without speed the return distance is fixed
        "views": [], "recovery_distance_m": None,
        "min_speed": 0.0,     # m/s; frames slower are dropped from both splits (paper 002 V-A uses 4)
        "balance": False,     # thin out straight driving, redrawn every epoch (paper 003)
        "rotation_deg": 0.0,  # augmentation (paper 002 IV-B1): random rotation within +-rotation_deg,
        "brightness": 0.0,    # and brightness scaled by a random factor within 1 +- brightness
        "motion_dropout": 0.0,  # fraction of samples shown "no motion seen" (difference, flow, stacked frames)
        "target_shift_s": 0.0,  # train on the steering this many seconds ahead
        "recovery_weight": 1,   # samples in recovery episodes are drawn this many times per epoch
        "keep": "best",         # best.pt: the epoch with the best validation score (stopping after `patience`
                                # epochs without a better one), or the last epoch (validation only watched: a
                                # refit whose validation block is the held-out one)
        "init": None,           # start from the weights of this checkpoint (same model and options)
        "teacher": None,        # distillation: train on this checkpoint's predictions (an ensemble, say) instead
                                # of the recorded steering of the main recording
        "device": "auto",       # auto (CUDA when present, else the CPU), cpu or cuda
        "tensorboard": False,   # also log every epoch to out/tensorboard (tensorboard --logdir out)
    },
    "out": "runs/train",
    "dagger": None,          # DAgger rounds (steerlab sim dagger; options in dagger.py)
    "tune": None,            # search space of steerlab tune: config key -> range (tune.py)
    "closed_loop": None,     # suite for steerlab tune --objective autonomy: {suite: v1, minutes, workers}
}


# What a config that leaves them out gets on a donkeycar tub, under the user's own settings: the model and loss
# chosen on the selection blocks of both shared tubs (docs/RESULTS.md, "steerlab side by side with donkeycar").
# multimodal-lstm had the lowest mean selection MAE of the two tubs; the MAE loss suits the nearly binary
# steering of an RC car. The general defaults above (PilotNet, MSE) lose to donkeycar's linear model there.
TUB_DEFAULTS = {
    "model": {"name": "multimodal-lstm"},
    "train": {"batch_size": 32, "lr": 3.0e-4, "loss": "mae"},
}

LOSSES = {"mse": "rmse", "mae": "mae"}  # train.loss -> the validation metric that picks the best epoch


def _finite(lo: float = -math.inf, hi: float = math.inf, lo_open: bool = False, hi_open: bool = False):
    return lambda v: (math.isfinite(v) and (lo < v if lo_open else lo <= v) and (v < hi if hi_open else v <= hi))


def _views(v: list) -> bool:
    return all(isinstance(p, (list, tuple)) and len(p) == 2 and all(_is(x, float) and math.isfinite(float(x))
                                                                    for x in p) for p in v)


# The typed schema of the options: config key -> (type, check of the value, what is expected). Every config is
# checked against it when it is read, before any work; None is allowed where the default is None. Numbers may
# be written as text such as 1e-4 (YAML 1.1 reads a number without a dot as text).
SCHEMA = {
    "train.epochs": (int, lambda v: v >= 1, "an integer of at least 1"),
    "train.batch_size": (int, lambda v: v >= 1, "an integer of at least 1"),
    "train.lr": (float, _finite(0, lo_open=True), "a positive finite number"),
    "train.patience": (int, lambda v: v >= 1, "an integer of at least 1"),
    "train.seed": (int, None, "an integer"),
    "train.flip": (bool, None, "true or false"),
    "train.tensorboard": (bool, None, "true or false"),
    "train.loss": (str, lambda v: v in LOSSES, " or ".join(LOSSES)),
    "train.smoothness": (float, _finite(0), "a finite number of at least 0"),
    "train.exclude_episodes": (list, lambda v: all(isinstance(e, str) for e in v), "a list of episode names"),
    "train.side_cameras": (bool, None, "true or false"),
    "train.side_offset_m": (float, _finite(), "a finite number"),
    "train.recovery_s": (float, _finite(0, lo_open=True), "a positive finite number"),
    "train.steering_ratio": (float, _finite(0, lo_open=True), "a positive finite number"),
    "train.views": (list, _views, "a list of [shift_m, yaw_deg] pairs of numbers"),
    "train.recovery_distance_m": (float, _finite(0, lo_open=True), "a positive finite number"),
    "train.min_speed": (float, _finite(0), "a finite number of at least 0"),
    "train.balance": (bool, None, "true or false"),
    "train.rotation_deg": (float, _finite(0, 180), "a number of degrees in [0, 180]"),
    "train.brightness": (float, _finite(0, 1, hi_open=True), "a number in [0, 1)"),
    "train.motion_dropout": (float, _finite(0, 1), "a number in [0, 1]"),
    "train.target_shift_s": (float, _finite(0), "a finite number of at least 0"),
    "train.recovery_weight": (int, lambda v: v >= 1, "an integer of at least 1"),
    "train.keep": (str, lambda v: v in ("best", "last"), "best or last"),
    "train.init": (str, None, "a checkpoint path"),
    "train.teacher": (str, None, "a checkpoint path"),
    "train.device": (str, lambda v: v in ("auto", "cpu", "cuda"), "auto, cpu or cuda"),
    "model.dropout": (float, _finite(0, 1, hi_open=True), "a number in [0, 1)"),
}


def _is(value, kind) -> bool:
    if isinstance(value, bool):
        return kind is bool
    if kind is float and isinstance(value, str):
        try:
            float(value)
        except ValueError:
            return False
        return True
    return isinstance(value, (int, float) if kind is float else kind)


def check_config(cfg: dict) -> None:
    """Check every option of the schema for type and range, and that the model can take what the options ask
    of it: a one-line error naming the first bad one."""
    for key, (kind, check, expected) in SCHEMA.items():
        section, name = key.split(".")
        node = cfg.get(section)
        if not isinstance(node, dict) or name not in node:
            continue
        value = node[name]
        if value is None and DEFAULTS.get(section, {}).get(name, 0) is None:
            continue
        if not _is(value, kind) or (check is not None and not check(float(value) if kind is float else value)):
            raise SteerlabError(f"{key} must be {expected}, got {value!r}")
    smoothness = (cfg.get("train") or {}).get("smoothness")
    if smoothness and float(smoothness) > 0:  # the change between consecutive frames of a training window
        model = cfg.get("model") or {}
        cls = _model_class(model.get("name"))
        if cls is not None and not cls.recurrent:
            raise SteerlabError(f"train.smoothness needs a recurrent model (it trains on windows of consecutive "
                                f"frames); {model['name']!r} sees single frames in shuffled batches")
        if cls is not None and isinstance(model.get("seq_len"), int) and model["seq_len"] < 2:
            raise SteerlabError(f"train.smoothness needs windows of at least 2 frames; model.seq_len is "
                                f"{model['seq_len']}")


def _merge(base: dict, new: dict) -> dict:
    out = copy.deepcopy(base)
    for k, v in (new or {}).items():
        if isinstance(v, dict) and isinstance(out.get(k), dict) and k == "train":
            out[k] = _merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def apply_override(cfg: dict, text: str) -> None:
    if "=" not in text:
        raise SteerlabError(f"override {text!r} must look like section.key=value, e.g. train.epochs=5")
    key, value = text.split("=", 1)
    parts = key.strip().split(".")
    node = cfg
    for p in parts[:-1]:
        node = node.setdefault(p, {})
        if not isinstance(node, dict):
            raise SteerlabError(f"override {text!r}: {p!r} is not a section")
    # a frame range such as 0:1800 stays text (YAML 1.1 would read it as a base-60 number)
    node[parts[-1]] = value if re.fullmatch(r"\s*\d*:\d*\s*", value) else yaml.safe_load(value)


def _model_class(name):
    from steerlab.models import list_models, model_class

    return model_class(name) if name in list_models() else None


def _layered(layers: list[dict | None], overrides: list[str]) -> dict:
    cfg = {}
    for layer in layers:
        cfg = _merge(cfg, layer)
    for o in overrides:
        apply_override(cfg, o)
    return cfg


def load_config(path: str | Path | None = None, overrides: list[str] = (), base: dict | None = None) -> dict:
    """Defaults <- (on a donkeycar tub) TUB_DEFAULTS <- `base` <- YAML file <- overrides. Relative data paths
    are taken relative to the working directory."""
    user = {}
    if path is not None:
        path = Path(path)
        if not path.is_file():
            raise SteerlabError(f"{path}: config file not found")
        try:
            user = yaml.safe_load(path.read_text()) or {}
        except yaml.YAMLError as e:
            raise SteerlabError(f"{path}: not valid YAML: {e}") from None
        if not isinstance(user, dict):
            raise SteerlabError(f"{path}: expected a mapping of sections (data, split, model, train, ...)")
    cfg = _layered([DEFAULTS, base, user], overrides)
    if isinstance(cfg["data"], str) and is_tub(Path(cfg["data"])):
        plain, cfg = cfg, _layered([DEFAULTS, TUB_DEFAULTS, base, user], overrides)
        if hasattr(_model_class(cfg["model"].get("name")), "loss"):  # a model that trains on a loss of its own
            cfg["train"]["loss"] = plain["train"]["loss"]
    unknown = set(cfg) - set(DEFAULTS)
    if unknown:
        raise SteerlabError(f"unknown config sections {sorted(unknown)}; known: {sorted(DEFAULTS)}")
    unknown = set(cfg["train"]) - set(DEFAULTS["train"])
    if unknown:
        raise SteerlabError(f"unknown train options {sorted(unknown)}; known: {sorted(DEFAULTS['train'])}")
    if not cfg["data"]:
        raise SteerlabError("the config names no data (set data: PATH or pass data=PATH)")
    check_config(cfg)
    return cfg
