"""Turning compiled arrays into standardised network input for training; the streaming Pilot fills the same
channel layout frame by frame and shares the `Standardizer`.

torch is imported only where a tensor is made (`Standardizer`), so the Pilot on ONNX Runtime runs without it."""

from __future__ import annotations

from typing import TYPE_CHECKING

import cv2
import numpy as np

from steerlab.data.preprocess import PreprocessConfig

if TYPE_CHECKING:
    import torch


def stack_modalities(arrays: dict[str, np.ndarray], cfg: PreprocessConfig) -> np.ndarray:
    """(..., H, W, C_m) per modality -> (..., H, W, C) float32 in the config's modality order."""
    return np.concatenate([np.asarray(arrays[m], dtype=np.float32) for m in cfg.modalities], axis=-1)


def segment_starts(segment_ids: np.ndarray) -> np.ndarray:
    """For every frame, the index of the first frame of its segment."""
    first = np.flatnonzero(np.diff(segment_ids, prepend=-1))
    return first[np.searchsorted(first, np.arange(len(segment_ids)), side="right") - 1]


def history(idx: np.ndarray, starts: np.ndarray, n: int) -> np.ndarray:
    """(B, n) indices of the n frames ending at each index, oldest first; before the start of a segment the
    segment's first frame is repeated (as the Pilot does at a segment's first frame)."""
    return np.maximum(idx[:, None] + np.arange(1 - n, 1), starts[idx][:, None])


def gather(arrays: dict[str, np.ndarray], cfg: PreprocessConfig, idx: np.ndarray, starts: np.ndarray) -> dict:
    """The modalities of frames `idx` from compiled arrays. With `stack` = N the image is the N frames ending
    at each index, oldest first (see `history`)."""
    out = {m: arrays[m][idx] for m in cfg.modalities if m != "image"}
    if cfg.stack == 1:
        out["image"] = arrays["image"][idx]
        return out
    imgs = np.asarray(arrays["image"][history(idx, starts, cfg.stack).ravel()])
    b, (h, w, c) = len(idx), imgs.shape[1:]
    out["image"] = imgs.reshape(b, cfg.stack, h, w, c).transpose(0, 2, 3, 1, 4).reshape(b, h, w, cfg.stack * c)
    return out


def channel_stats(arrays: dict[str, np.ndarray], cfg: PreprocessConfig, indices: np.ndarray, starts: np.ndarray,
                  chunk: int = 512) -> dict[str, list[float]]:
    """Per-channel mean and std over the given frames (the training split only), computed in chunks."""
    total = sq = None
    count = 0
    for i in range(0, len(indices), chunk):
        idx = np.sort(indices[i: i + chunk])
        x = stack_modalities(gather(arrays, cfg, idx, starts), cfg).astype(np.float64)
        s, q = x.sum(axis=(0, 1, 2)), (x ** 2).sum(axis=(0, 1, 2))
        total, sq = (s, q) if total is None else (total + s, sq + q)
        count += x.shape[0] * x.shape[1] * x.shape[2]
    mean = total / count
    std = np.sqrt(np.maximum(sq / count - mean ** 2, 0.0))
    return {"mean": mean.tolist(), "std": np.maximum(std, 1e-3).tolist()}


class Standardizer:
    """x -> (x - mean) / std per channel, and NHWC -> NCHW shape in channels-last memory layout (no copy;
    oneDNN convolutions on the CPU run about a quarter faster on it)."""

    def __init__(self, stats: dict[str, list[float]]):
        import torch

        self.mean = torch.tensor(stats["mean"], dtype=torch.float32)
        self.std = torch.tensor(stats["std"], dtype=torch.float32)

    def __call__(self, x_nhwc: np.ndarray) -> torch.Tensor:
        """Standardises in place when given a contiguous float32 array: the array is consumed."""
        import torch

        x = torch.from_numpy(np.ascontiguousarray(x_nhwc, dtype=np.float32))
        return x.sub_(self.mean).div_(self.std).permute(0, 3, 1, 2)


def _first_channel(cfg: PreprocessConfig, modality: str) -> int:
    c = 0
    for m, n in cfg.channels().items():
        if m == modality:
            return c
        c += n
    raise KeyError(modality)


def flip_horizontal(x_nhwc: np.ndarray, cfg: PreprocessConfig) -> np.ndarray:
    """Mirror left-right. The flow's horizontal component changes sign with the mirror."""
    x = x_nhwc[:, :, ::-1, :].copy()
    if "flow" in cfg.modalities:
        x[..., _first_channel(cfg, "flow")] *= -1  # the flow's dx channel
    return x


def no_motion(x_nhwc: np.ndarray, cfg: PreprocessConfig) -> np.ndarray:
    """The inputs as if no motion had been seen (as at a segment's first frame): difference 128, flow 0, and
    every frame of a stack replaced by the newest."""
    x = x_nhwc.copy()
    if cfg.stack > 1:
        c, first = cfg.image_channels, _first_channel(cfg, "image")
        newest = x[..., first + (cfg.stack - 1) * c: first + cfg.stack * c]
        x[..., first: first + cfg.stack * c] = np.tile(newest, cfg.stack)
    if "diff" in cfg.modalities:
        c = _first_channel(cfg, "diff")
        x[..., c: c + cfg.image_channels] = 128.0
    if "flow" in cfg.modalities:
        c = _first_channel(cfg, "flow")
        x[..., c: c + 2] = 0.0
    return x


LUMA = {"gray": [0], "rgb": [0, 1, 2], "yuv": [0], "hsv": [2]}  # the channels that carry brightness


def hue_turn(deg: float) -> np.ndarray:
    """The 3x3 matrix that turns RGB colours by `deg` about the gray axis (1, 1, 1): grays stay, saturation and
    brightness stay, the hue turns (120 degrees: red -> green -> blue -> red)."""
    return cv2.Rodrigues(np.full(3, np.radians(deg) / np.sqrt(3)))[0].astype(np.float32)


def augment(x_nhwc: np.ndarray, cfg: PreprocessConfig, rng: np.random.Generator, rotation_deg: float,
            brightness: float, hue_deg: float = 0.0) -> np.ndarray:
    """Training augmentation of paper 002 IV-B1, in place on unstandardised inputs:

    - rotation: every sample is turned about the image centre by an angle drawn from +-rotation_deg (camera
      vibration); every channel turns with it, and flow vectors are turned by the same angle;
    - brightness: the brightness channels of the image (gray, RGB, Y of YUV, V of HSV) are scaled by a factor
      drawn from 1 +- brightness, clipped to 0..255;
    - hue (RGB inputs): the colours of every frame of the sample turned about the gray axis by an angle drawn
      from +-hue_deg (`hue_turn`), clipped to 0..255: tape, paint and floors of colours the recordings lack."""
    h, w = x_nhwc.shape[1:3]
    flow = _first_channel(cfg, "flow") if "flow" in cfg.modalities else None
    luma = [f * cfg.image_channels + c for f in range(cfg.stack) for c in LUMA[cfg.color]]
    for i in range(len(x_nhwc)):
        if hue_deg:
            turn = hue_turn(rng.uniform(-hue_deg, hue_deg)).T
            for f in range(cfg.stack):  # the image's channels come first
                rgb = x_nhwc[i, ..., 3 * f: 3 * f + 3]
                rgb[...] = np.clip(rgb @ turn, 0, 255)
        if rotation_deg:
            m = cv2.getRotationMatrix2D((w / 2, h / 2), rng.uniform(-rotation_deg, rotation_deg), 1.0)
            turned = cv2.warpAffine(x_nhwc[i], m, (w, h), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
            x_nhwc[i] = turned.reshape(x_nhwc[i].shape)
            if flow is not None:
                x_nhwc[i, ..., flow: flow + 2] = x_nhwc[i, ..., flow: flow + 2] @ m[:, :2].T.astype(np.float32)
        if brightness:
            x_nhwc[i, ..., luma] = np.clip(x_nhwc[i, ..., luma] * rng.uniform(1 - brightness, 1 + brightness), 0, 255)
    return x_nhwc
