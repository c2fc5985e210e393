"""Recurrent models (paper 000 IV-B5/6, Fig. 3): PilotNet's five convolutions, FC 1152 -> 512, an LSTM of 100
hidden units and one output.

A recurrent model takes (B, T, C, H, W) and an optional state and returns (steering (B, T), state). Training
uses windows of `seq_len` consecutive frames of one segment, each starting from a zero state (truncated
back-propagation through time); evaluation and the Pilot run it statefully over a whole range, one frame after
another, resetting at segment starts.
"""

from __future__ import annotations

import torch
import torch.nn as nn

from steerlab.models.pilotnet import pilotnet_convs
from steerlab.models.registry import register


@register("lstm")
class ConvLSTM(nn.Module):
    trainable = True
    recurrent = True
    inputs = {"modalities": ["image"], "color": "gray"}

    def __init__(self, in_channels: int = 1, height: int = 66, width: int = 200, dropout: float = 0.5,
                 hidden: int = 100, seq_len: int = 10):
        super().__init__()
        self.seq_len = seq_len
        self.features = pilotnet_convs(in_channels)
        with torch.no_grad():
            n = self.features(torch.zeros(1, in_channels, height, width)).numel()
        self.fc = nn.Sequential(nn.Linear(n, 512), nn.ReLU(inplace=True), nn.Dropout(dropout))
        self.lstm = nn.LSTM(512, hidden, batch_first=True)
        self.out = nn.Linear(hidden, 1)

    def forward(self, x: torch.Tensor, state=None):
        b, t = x.shape[:2]
        f = self.fc(self.features(x.flatten(0, 1)).flatten(1)).view(b, t, -1)
        h, state = self.lstm(f, state)
        return self.out(h).squeeze(-1), state


@register("multimodal-lstm")
class MultimodalLSTM(ConvLSTM):
    """The same network on gray + Farneback flow (paper 000 IV-B6)."""

    inputs = {"modalities": ["image", "flow"], "color": "gray"}

    def __init__(self, in_channels: int = 3, **kw):
        super().__init__(in_channels, **kw)
