"""What training does to a batch before the model sees it, on the whole batch at once: a float32 tensor (B, H, W, C)
of unstandardised inputs in the config's channel layout (`data.inputs.stack_modalities`), changed by torch's
operations on every sample together (two threads, no loop over samples in Python).

- `mirror`: left-right, the flow's horizontal component negated (the caller negates the steering);
- `no_motion`: the inputs as at a segment's first frame (motion dropout);
- `augment`: paper 002 IV-B1's rotation and brightness, and the hue of other rooms, drawn per sample."""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F

from steerlab.data.preprocess import PreprocessConfig

LUMA = {"gray": (0, 1), "rgb": (0, 3), "yuv": (0, 1), "hsv": (2, 3)}  # the channels that carry brightness


def first_channel(cfg: PreprocessConfig, modality: str) -> int:
    """The first channel of `modality` in the stacked input."""
    c = 0
    for m, n in cfg.channels().items():
        if m == modality:
            return c
        c += n
    raise KeyError(modality)


def mirror(x: torch.Tensor, cfg: PreprocessConfig) -> torch.Tensor:
    """The samples mirrored left-right (a new tensor); the flow's horizontal component changes sign with them."""
    x = x.flip(2)
    if "flow" in cfg.modalities:
        x[..., first_channel(cfg, "flow")] *= -1  # the flow's dx channel
    return x


def no_motion(x: torch.Tensor, cfg: PreprocessConfig) -> torch.Tensor:
    """The inputs as if no motion had been seen (as at a segment's first frame), a new tensor: difference 128, flow
    0, and every frame of a stack replaced by the newest."""
    x = x.clone()
    if cfg.stack > 1:
        c, first = cfg.image_channels, first_channel(cfg, "image")
        newest = x[..., first + (cfg.stack - 1) * c: first + cfg.stack * c]
        x[..., first: first + cfg.stack * c] = newest.repeat(1, 1, 1, cfg.stack)
    if "diff" in cfg.modalities:
        c = first_channel(cfg, "diff")
        x[..., c: c + cfg.image_channels] = 128.0
    if "flow" in cfg.modalities:
        c = first_channel(cfg, "flow")
        x[..., c: c + 2] = 0.0
    return x


def hue_turns(deg: np.ndarray) -> np.ndarray:
    """(N, 3, 3) matrices that turn RGB colours by `deg` (N,) about the gray axis k = (1, 1, 1) / sqrt(3)
    (Rodrigues: cos a I + (1 - cos a) k k^T + sin a [k]x): grays stay, saturation and brightness stay, the hue
    turns (120 degrees: red -> green -> blue -> red)."""
    a = np.radians(np.asarray(deg, np.float64))[:, None, None]
    cross = np.array([[0, -1, 1], [1, 0, -1], [-1, 1, 0]]) / np.sqrt(3)
    return (np.cos(a) * np.eye(3) + (1 - np.cos(a)) / 3 + np.sin(a) * cross).astype(np.float32)


def _rotate(x: torch.Tensor, deg: np.ndarray, flow: int | None) -> torch.Tensor:
    """Every sample turned about the image centre by its angle (degrees, counter-clockwise as seen), bilinear, the
    border pixels repeated outwards; flow vectors are turned by the same angle."""
    b, h, w, c = x.shape
    a = torch.from_numpy(np.radians(deg).astype(np.float32))
    cos, sin = a.cos(), a.sin()
    # the inverse rotation in grid_sample's coordinates (-1..1 across each axis, so the aspect enters)
    theta = torch.zeros(b, 2, 3)
    theta[:, 0, 0], theta[:, 0, 1], theta[:, 1, 0], theta[:, 1, 1] = cos, -sin * h / w, sin * w / h, cos
    grid = F.affine_grid(theta, [b, c, h, w], align_corners=False)
    out = F.grid_sample(x.permute(0, 3, 1, 2), grid, mode="bilinear", padding_mode="border",
                        align_corners=False).permute(0, 2, 3, 1)
    if flow is not None:  # (dx, dy) in image coordinates (y down): dx' = cos dx + sin dy, dy' = -sin dx + cos dy
        dx, dy = out[..., flow].clone(), out[..., flow + 1].clone()
        cos, sin = cos.view(-1, 1, 1), sin.view(-1, 1, 1)
        out[..., flow], out[..., flow + 1] = cos * dx + sin * dy, cos * dy - sin * dx
    return out.contiguous()


def augment(x: torch.Tensor, cfg: PreprocessConfig, rng: np.random.Generator, rotation_deg: float,
            brightness: float, hue_deg: float = 0.0) -> torch.Tensor:
    """Training augmentation of paper 002 IV-B1 on a batch (B, H, W, C) of unstandardised inputs, every sample's
    draws from `rng` one sample after the other (its hue angle, rotation and brightness factor, those that are on),
    so that a seed gives each sample the draws it gets when the samples are augmented one at a time:

    - hue (RGB inputs): the colours of every frame of the sample turned about the gray axis by an angle drawn
      from +-hue_deg (`hue_turns`), clipped to 0..255: tape, paint and floors of colours the recordings lack;
    - rotation: every sample is turned about the image centre by an angle drawn from +-rotation_deg (camera
      vibration); every channel turns with it, and flow vectors are turned by the same angle;
    - brightness: the brightness channels of the image (gray, RGB, Y of YUV, V of HSV) are scaled by a factor
      drawn from 1 +- brightness, clipped to 0..255.
    Returns the augmented batch (`x` itself, changed in place, unless it was rotated)."""
    b = len(x)
    on = sum(1 for span in (hue_deg, rotation_deg, brightness) if span)
    draws = iter(rng.random((b, on)).T)  # a row per sample, in turn; a column per augmentation that is on

    def within(lo: float, hi: float) -> np.ndarray:  # as rng.uniform(lo, hi) scales its draw
        return lo + (hi - lo) * next(draws)

    if hue_deg:
        turns = torch.from_numpy(hue_turns(within(-hue_deg, hue_deg))).transpose(1, 2).contiguous()
        for f in range(cfg.stack):  # the image's channels come first
            rgb = x[..., 3 * f: 3 * f + 3]
            rgb.copy_(torch.bmm(rgb.reshape(b, -1, 3), turns).view(rgb.shape).clamp_(0, 255))
    if rotation_deg:
        flow = first_channel(cfg, "flow") if "flow" in cfg.modalities else None
        x = _rotate(x, within(-rotation_deg, rotation_deg), flow)
    if brightness:
        factor = torch.from_numpy(within(1 - brightness, 1 + brightness).astype(np.float32)).view(-1, 1, 1, 1)
        lo, hi = LUMA[cfg.color]
        for f in range(cfg.stack):
            c = f * cfg.image_channels
            x[..., c + lo: c + hi].mul_(factor).clamp_(0, 255)
    return x
