"""Turning compiled arrays into standardised network input for training; the streaming Pilot fills the same
channel layout frame by frame and shares the `Standardizer`.

torch is imported only where a tensor is made (`Standardizer`), so the Pilot on ONNX Runtime runs without it."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from steerlab.data.preprocess import PreprocessConfig

if TYPE_CHECKING:
    import torch


def stack_modalities(arrays: dict[str, np.ndarray], cfg: PreprocessConfig) -> np.ndarray:
    """(..., H, W, C_m) per modality -> (..., H, W, C) float32 in the config's modality order (one pass: each
    modality converted as it is copied)."""
    return np.concatenate([arrays[m] for m in cfg.modalities], axis=-1, dtype=np.float32)


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

    def __call__(self, x_nhwc: np.ndarray | torch.Tensor) -> torch.Tensor:
        """Standardises in place when given a contiguous float32 array or tensor: the input is consumed."""
        import torch

        x = x_nhwc if isinstance(x_nhwc, torch.Tensor) else torch.from_numpy(np.ascontiguousarray(x_nhwc, np.float32))
        b, h, w, c = x.shape
        if x.is_contiguous():  # a row's W x C values at once: torch's loop over C values a pixel is 7x slower
            x.view(b, h, w * c).sub_(self.mean.repeat(w)).div_(self.std.repeat(w))
        else:
            x.sub_(self.mean).div_(self.std)
        return x.permute(0, 3, 1, 2)
