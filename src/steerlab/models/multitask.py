"""Paper 002's models: the base steering CNN (III-A), the speed command network (III-B) and the multi-modal
multi-task network (III-C), with the community model cg23 that paper 002 Table I compares them with.

Paper 002 gives the structure but not the layer sizes; the sizes here are ours and chosen to keep training
practical on a CPU:

- base CNN: five convolutions in the style of AlexNet with large early kernels (24@11x11 stride 2, 48@7x7,
  64@5x5, 64@3x3, 64@3x3, max-pooling after the 1st, 2nd and 5th) on a 1:1 input of 96x96, then four fully
  connected layers 1024 -> 256 -> 64 -> 16 -> 1.
- The steering loss of every paper-002 model is the weighted MAE (`weighted_mae`).
- `speed-command`: the base convolutions, FC 1024 -> 256, an LSTM of 64 units over the image sequence, and two
  heads: steering and three speed-command logits; loss = weighted MAE + `command_weight` x cross entropy.
- `multitask-speed`: visual encoder = the base network up to its 64 features, steering from those; speed
  encoder = FC 11 -> 32 -> 32 over the 10 most recent speeds (as differences to the current speed, plus the
  current speed / 10 m/s); the next frame's speed = current speed + FC(visual 64 + speed 32 -> 32 -> 1);
  loss = weighted MAE of steering + `speed_weight` x MAE of speed (m/s).
- `cg23`: three convolutions (16, 32, 64 @ 3x3, each followed by 2x2 max-pooling) and two fully connected
  layers (-> 256 -> 1), on the configured input (200x66 by default); MSE loss.
"""

from __future__ import annotations

import torch
import torch.nn as nn
import torch.nn.functional as F

from steerlab.models.dropout import Dropout
from steerlab.models.registry import SteeringModel, register

SQUARE = {"width": 96, "height": 96}  # paper 002: the input squeezed to an aspect ratio of 1:1


def weighted_mae(pred: torch.Tensor, y: torch.Tensor, gain: float = 1.0) -> torch.Tensor:
    """Paper 002 III-A: MAE with per-sample weights that grow with |steering| against straight-driving bias.
    w = 1 + gain * |y| / mean(|y|) over the batch (a frame turning as hard as the average counts double at
    gain 1); loss = sum(w * |pred - y|) / sum(w)."""
    a = y.abs()
    w = 1 + gain * a / (a.mean() + 1e-8)
    return (w * (pred - y).abs()).sum() / w.sum()


def base_convs(in_channels: int) -> nn.Sequential:
    return nn.Sequential(
        nn.Conv2d(in_channels, 24, 11, 2), nn.ReLU(inplace=True), nn.MaxPool2d(3, 2),
        nn.Conv2d(24, 48, 7, padding=3), nn.ReLU(inplace=True), nn.MaxPool2d(3, 2),
        nn.Conv2d(48, 64, 5, padding=2), nn.ReLU(inplace=True),
        nn.Conv2d(64, 64, 3, padding=1), nn.ReLU(inplace=True),
        nn.Conv2d(64, 64, 3, padding=1), nn.ReLU(inplace=True), nn.MaxPool2d(3, 2))


def dense(sizes: list[int | None], dropout: float) -> nn.Sequential:
    """Fully connected layers with ReLU and dropout between them; a first size of None takes however many
    features come in (sized by the first input)."""
    layers = []
    for a, b in zip(sizes[:-1], sizes[1:]):
        layers += [nn.Linear(a, b) if a else nn.LazyLinear(b), nn.ReLU(inplace=True), Dropout(dropout)]
    return nn.Sequential(*layers)


class _VisualEncoder(nn.Module):
    """The base CNN's convolutions and its first fully connected layers: (B, C, H, W) -> (B, sizes[-1])."""

    def __init__(self, in_channels: int, dropout: float, sizes: list[int]):
        super().__init__()
        self.convs = base_convs(in_channels)
        self.fc = dense([None] + sizes, dropout)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.fc(self.convs(x).flatten(1))


@register("yang-base")
class YangBase(SteeringModel):
    inputs = SQUARE

    def __init__(self, in_channels: int = 3, dropout: float = 0.5, weight_gain: float = 1.0):
        super().__init__()
        self.weight_gain = weight_gain
        self.encoder = _VisualEncoder(in_channels, dropout, [256, 64, 16])
        self.out = nn.Linear(16, 1)

    def forward(self, x: torch.Tensor) -> dict[str, torch.Tensor]:
        return {"steering": self.out(self.encoder(x)).squeeze(1)}

    def loss(self, out: dict, targets: dict) -> torch.Tensor:
        return weighted_mae(out["steering"], targets["steering"], self.weight_gain)


@register("speed-command")
class SpeedCommand(SteeringModel):
    recurrent = True
    inputs = SQUARE
    targets = ("command",)

    def __init__(self, in_channels: int = 3, dropout: float = 0.5, hidden: int = 64, seq_len: int = 10,
                 weight_gain: float = 1.0, command_weight: float = 0.1):
        super().__init__()
        self.seq_len, self.weight_gain, self.command_weight = seq_len, weight_gain, command_weight
        self.encoder = _VisualEncoder(in_channels, dropout, [256])
        self.lstm = nn.LSTM(256, hidden, batch_first=True)
        self.steer = nn.Linear(hidden, 1)
        self.command = nn.Linear(hidden, 3)

    def forward(self, x: torch.Tensor, state=None):
        b, t = x.shape[:2]
        h, state = self.lstm(self.encoder(x.flatten(0, 1)).view(b, t, -1), state)
        return {"steering": self.steer(h).squeeze(-1), "command": self.command(h)}, state

    def loss(self, out: dict, targets: dict) -> torch.Tensor:
        ce = F.cross_entropy(out["command"].flatten(0, -2), targets["command"].flatten())
        return weighted_mae(out["steering"], targets["steering"], self.weight_gain) + self.command_weight * ce


@register("multitask-speed")
class MultitaskSpeed(SteeringModel):
    inputs = SQUARE
    targets = ("speed",)
    speed_history = 10  # the most recent speeds the model is given (paper 002 III-C: 10)

    def __init__(self, in_channels: int = 3, dropout: float = 0.5, speed_history: int = 10, weight_gain: float = 1.0,
                 speed_weight: float = 0.1):
        super().__init__()
        self.speed_history, self.weight_gain, self.speed_weight = speed_history, weight_gain, speed_weight
        self.visual = _VisualEncoder(in_channels, dropout, [256, 64])
        self.steer = nn.Sequential(nn.Linear(64, 16), nn.ReLU(inplace=True), nn.Linear(16, 1))
        self.speed_encoder = dense([speed_history + 1, 32, 32], 0.0)
        self.speed_head = nn.Sequential(nn.Linear(64 + 32, 32), nn.ReLU(inplace=True), nn.Linear(32, 1))

    def forward(self, x: torch.Tensor, speeds: torch.Tensor) -> dict[str, torch.Tensor]:
        v = self.visual(x)
        current = speeds[:, -1:]
        s = self.speed_encoder(torch.cat([speeds - current, current / 10.0], 1))
        speed = current.squeeze(1) + self.speed_head(torch.cat([v, s], 1)).squeeze(1)
        return {"steering": self.steer(v).squeeze(1), "speed": speed}

    def loss(self, out: dict, targets: dict) -> torch.Tensor:
        speed_mae = (out["speed"] - targets["speed"]).abs().mean()
        return weighted_mae(out["steering"], targets["steering"], self.weight_gain) + self.speed_weight * speed_mae


@register("cg23")
class CG23(SteeringModel):
    inputs: dict = {}

    def __init__(self, in_channels: int = 1, dropout: float = 0.5, throttle: bool = False):
        super().__init__()
        self.learns_throttle = throttle
        layers, c = [], in_channels
        for out in (16, 32, 64):
            layers += [nn.Conv2d(c, out, 3, padding=1), nn.ReLU(inplace=True), nn.MaxPool2d(2)]
            c = out
        self.features = nn.Sequential(*layers)
        self.head = nn.Sequential(*dense([None, 256], dropout), nn.Linear(256, 1 + throttle))

    def forward(self, x: torch.Tensor) -> dict[str, torch.Tensor]:
        return self.named(self.head(self.features(x).flatten(1)))
