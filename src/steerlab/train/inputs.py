"""Turning compiled arrays into standardised network input: shared by training and the streaming Pilot."""

from __future__ import annotations

import numpy as np
import torch

from steerlab.data.preprocess import PreprocessConfig


def stack_modalities(arrays: dict[str, np.ndarray], cfg: PreprocessConfig) -> np.ndarray:
    """(..., H, W, C_m) per modality -> (..., H, W, C) float32 in the config's modality order."""
    return np.concatenate([np.asarray(arrays[m], dtype=np.float32) for m in cfg.modalities], axis=-1)


def segment_starts(segment_ids: np.ndarray) -> np.ndarray:
    """For every frame, the index of the first frame of its segment."""
    first = np.flatnonzero(np.diff(segment_ids, prepend=-1))
    return first[np.searchsorted(first, np.arange(len(segment_ids)), side="right") - 1]


def gather(arrays: dict[str, np.ndarray], cfg: PreprocessConfig, idx: np.ndarray, starts: np.ndarray) -> dict:
    """The modalities of frames `idx` from compiled arrays. With `stack` = N the image is the N frames ending
    at each index, oldest first; before the start of a segment the segment's first frame is repeated."""
    out = {m: arrays[m][idx] for m in cfg.modalities if m != "image"}
    if cfg.stack == 1:
        out["image"] = arrays["image"][idx]
        return out
    hist = np.maximum(idx[:, None] + np.arange(1 - cfg.stack, 1), starts[idx][:, None])
    imgs = np.asarray(arrays["image"][hist.ravel()])
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
        self.mean = torch.tensor(stats["mean"], dtype=torch.float32)
        self.std = torch.tensor(stats["std"], dtype=torch.float32)

    def __call__(self, x_nhwc: np.ndarray) -> torch.Tensor:
        x = torch.from_numpy(np.ascontiguousarray(x_nhwc, dtype=np.float32))
        return ((x - self.mean) / self.std).permute(0, 3, 1, 2)


def flip_horizontal(x_nhwc: np.ndarray, cfg: PreprocessConfig) -> np.ndarray:
    """Mirror left-right. The flow's horizontal component changes sign with the mirror."""
    x = x_nhwc[:, :, ::-1, :].copy()
    if "flow" in cfg.modalities:
        c = 0
        for m, n in cfg.channels().items():
            if m == "flow":
                break
            c += n
        x[..., c] *= -1  # the flow's dx channel
    return x
