"""Dropout with torch's semantics (`nn.Dropout`: in training each element is kept with probability 1 - p and
scaled by 1 / (1 - p), in evaluation the identity), its masks drawn in bulk.

On the CPU, `nn.Dropout` draws its mask with `bernoulli_`, one draw at a time: on donkeycar's linear model
(dropout after every convolution) that was a third of a training step on two cores. Here the mask comes from 64
random bits at a time (NumPy's PCG64, seeded from torch's generator, so `torch.manual_seed` and a saved RNG state
still decide every mask), as four 16-bit words, each compared with a threshold (a keep probability exact to
1/65536), and is stored scaled, so the backward pass is one product."""

from __future__ import annotations

import numpy as np
import torch
import torch.nn as nn

WORDS = 4  # 16-bit words in one 64-bit draw


def keep_mask(like: torch.Tensor, p: float) -> torch.Tensor:
    """A tensor of the shape, strides and dtype of `like` whose every element is 1 / (1 - p) with probability
    1 - p (to within 1/65536) and 0 otherwise, independently."""
    n = like.numel()
    seed = int(torch.empty((), dtype=torch.int64).random_())  # from torch's generator: manual_seed decides it
    bits = np.random.PCG64(seed).random_raw(-(-n // WORDS)).view(np.int16)[:n]
    threshold = 32768 - round((1 - p) * 65536)  # a uniform int16 is >= this with probability 1 - p
    words = torch.from_numpy(bits)
    if like.is_contiguous() or like.is_contiguous(memory_format=torch.channels_last):
        words = words.as_strided(like.shape, like.stride())  # the memory layout of `like`: no strided copy after
    else:
        words = words.view(like.shape)
    return (words >= threshold).to(like.dtype).mul_(1 / (1 - p))


class _Drop(torch.autograd.Function):
    @staticmethod
    def forward(ctx, x: torch.Tensor, p: float) -> torch.Tensor:
        mask = keep_mask(x, p)
        ctx.save_for_backward(mask)
        return x * mask

    @staticmethod
    def backward(ctx, grad: torch.Tensor):
        mask, = ctx.saved_tensors
        return grad * mask, None


class Dropout(nn.Dropout):
    """`nn.Dropout(p)` with masks drawn in bulk (`keep_mask`); the same module in a checkpoint and an export."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if not self.training or self.p == 0:
            return x
        return _Drop.apply(x, self.p)
