"""Recurrent models: a convolutional encoder per frame, an LSTM over time, a steering output per frame.

- `lstm` (paper 000 IV-B5, Fig. 3): PilotNet's five convolutions, FC 1152 -> 512, an LSTM of 100 hidden units
  and one output; gray image.
- `multimodal-lstm` (paper 000 IV-B6): the same network on gray + Farneback flow.
- `flow-lstm` (paper 003, CNN+OptF+LSTM): the two-stream encoder of `two-stream-flow` (one PilotNet
  convolution stack on the image, one on the flow), features concatenated, FC -> 512, LSTM 100, one output;
  MSE loss (paper 003's loss_lstm).

A recurrent model takes (B, T, C, H, W) and an optional state and returns ({"steering": (B, T)}, state)
(and "throttle" (B, T) when built with `throttle=True`).
Training uses windows of `seq_len` consecutive frames of one segment, each starting from a zero state
(truncated back-propagation through time); evaluation and the Pilot run it statefully over a whole range, one
frame after another, resetting at segment starts.
"""

from __future__ import annotations

import torch
import torch.nn as nn

from steerlab.models.dropout import Dropout
from steerlab.models.pilotnet import pilotnet_convs
from steerlab.models.registry import SteeringModel, register


@register("lstm")
class ConvLSTM(SteeringModel):
    recurrent = True
    inputs = {"modalities": ["image"], "color": "gray"}

    def __init__(self, in_channels: int = 1, dropout: float = 0.5, hidden: int = 100, seq_len: int = 10,
                 throttle: bool = False):
        super().__init__()
        self.seq_len, self.learns_throttle = seq_len, throttle
        self.features = pilotnet_convs(in_channels)
        self.fc = nn.Sequential(nn.LazyLinear(512), nn.ReLU(inplace=True), Dropout(dropout))
        self.lstm = nn.LSTM(512, hidden, batch_first=True)
        self.out = nn.Linear(hidden, 1 + throttle)

    def encode(self, frames: torch.Tensor) -> torch.Tensor:
        """(N, C, H, W) -> (N, 512)"""
        return self.fc(self.features(frames).flatten(1))

    def forward(self, x: torch.Tensor, state=None):
        b, t = x.shape[:2]
        h, state = self.lstm(self.encode(x.flatten(0, 1)).view(b, t, -1), state)
        return self.named(self.out(h)), state


@register("multimodal-lstm")
class MultimodalLSTM(ConvLSTM):
    """The same network on gray + Farneback flow (paper 000 IV-B6)."""

    inputs = {"modalities": ["image", "flow"], "color": "gray"}

    def __init__(self, in_channels: int = 3, **kw):
        super().__init__(in_channels, **kw)


@register("flow-lstm")
class FlowLSTM(ConvLSTM):
    """Paper 003's CNN+OptF+LSTM: image and flow through separate PilotNet convolution stacks."""

    inputs = {"modalities": ["image", "flow"]}

    def __init__(self, in_channels: int = 3, dropout: float = 0.5, hidden: int = 100, seq_len: int = 10,
                 throttle: bool = False):
        super().__init__(in_channels - 2, dropout, hidden, seq_len, throttle)  # self.features: the image
        self.image_channels = in_channels - 2
        self.flow_features = pilotnet_convs(2)

    def encode(self, frames: torch.Tensor) -> torch.Tensor:
        c = self.image_channels
        f = torch.cat([self.features(frames[:, :c]).flatten(1), self.flow_features(frames[:, c:]).flatten(1)], 1)
        return self.fc(f)
