"""NVIDIA PilotNet as specified in paper 000 IV-B1 (and paper 003's "NVIDIA" model).

Five convolutions: 24, 36, 48 channels with 5x5 kernels and stride 2, then 64, 64 with 3x3 kernels and
stride 1; fully connected 1164, 100, 50, 10, 1 (with `lane`, a lane head on the 10 features). Dropout on every
fully connected layer (paper 000 IV-D).
For a 66x200 input the flattened convolution output has 64 x 1 x 18 = 1152 features.
"""

from __future__ import annotations

import torch
import torch.nn as nn

from steerlab.models.dropout import Dropout
from steerlab.models.registry import SteeringModel, register


def pilotnet_convs(in_channels: int) -> nn.Sequential:
    layers, c = [], in_channels
    for out, k, s in [(24, 5, 2), (36, 5, 2), (48, 5, 2), (64, 3, 1), (64, 3, 1)]:
        layers += [nn.Conv2d(c, out, k, s), nn.ReLU(inplace=True)]
        c = out
    return nn.Sequential(*layers)


def pilotnet_head(dropout: float, outputs: int = 1) -> nn.Sequential:
    """Fully connected 1164, 100, 50, 10, `outputs` with ReLU and dropout after each hidden layer; the first
    layer takes however many features the convolutions give (sized by the first input, `registry.create_model`)."""
    layers = []
    for b in (1164, 100, 50, 10):
        layers += [nn.LazyLinear(b), nn.ReLU(inplace=True), Dropout(dropout)]
    return nn.Sequential(*layers, nn.Linear(10, outputs))


@register("pilotnet")
class PilotNet(SteeringModel):
    inputs: dict = {}  # any colour space and modalities

    def __init__(self, in_channels: int = 1, dropout: float = 0.5, throttle: bool = False, lane: bool = False):
        super().__init__()
        self.learns_throttle, self.learns_lane = throttle, lane
        self.features = pilotnet_convs(in_channels)
        self.head = pilotnet_head(dropout, 1 + throttle)
        if lane:
            self.lane = nn.Linear(10, 3)

    def forward(self, x: torch.Tensor) -> dict[str, torch.Tensor]:
        return self.heads(self.head, self.features(x).flatten(1))


@register("donkey-linear")
class DonkeyLinear(SteeringModel):
    """donkeycar's linear model (`KerasLinear`, `default_n_linear` in donkeycar's parts/keras.py), written here with
    its published layout: five convolutions of 24, 32, 64, 64, 64 filters with kernels 5, 5, 5, 3, 3 and strides
    2, 2, 2, 1, 1, ReLU, dropout after each; fully connected 100 and 50 with ReLU and dropout; a linear steering
    output and, with `throttle`, a linear throttle output (with `lane`, the lane head on the 50 features).
    donkeycar feeds it the whole 160x120 RGB frame (for that input the flattened features are 64 x 8 x 13 = 6656)
    and drops 0.2 everywhere."""

    inputs: dict = {}  # any colour space and size the convolutions fit

    def __init__(self, in_channels: int = 3, dropout: float = 0.2, throttle: bool = False, lane: bool = False):
        super().__init__()
        self.learns_throttle, self.learns_lane = throttle, lane
        layers, c = [], in_channels
        for out, k, s in [(24, 5, 2), (32, 5, 2), (64, 5, 2), (64, 3, 1), (64, 3, 1)]:
            layers += [nn.Conv2d(c, out, k, s), nn.ReLU(inplace=True), Dropout(dropout)]
            c = out
        self.features = nn.Sequential(*layers)
        self.head = nn.Sequential(nn.LazyLinear(100), nn.ReLU(inplace=True), Dropout(dropout),
                                  nn.Linear(100, 50), nn.ReLU(inplace=True), Dropout(dropout),
                                  nn.Linear(50, 1 + throttle))
        if lane:
            self.lane = nn.Linear(50, 3)

    def forward(self, x: torch.Tensor) -> dict[str, torch.Tensor]:
        return self.heads(self.head, self.features(x).flatten(1))
