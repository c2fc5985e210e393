"""Models that see motion: explicitly (frame difference, optical flow) or implicitly (stacked frames).

- `pilotnet-diff` (paper 000 IV-B3): PilotNet on gray + frame difference, 2 channels.
- `pilotnet-flow` (paper 000 IV-B4): PilotNet on gray + Farneback flow, 3 channels; every channel is
  standardised on its own with training statistics.
- `cnn3d` (paper 000 IV-B2): PilotNet with 3-D kernels of temporal depth 3 on 3 stacked gray frames.
- `two-stream-flow` (paper 003): one PilotNet on the image, one on the optical flow, trained with the combined
  loss mean((y_img - y)^2 + (y_flow - y)^2); the prediction is the mean of the two heads.

`inputs` declares the preprocessing a model needs; training fills it in (and refuses a config that asks for
something else).
"""

from __future__ import annotations

import torch
import torch.nn as nn

from steerlab.models.pilotnet import PilotNet, pilotnet_head
from steerlab.models.registry import SteeringModel, register


@register("pilotnet-diff")
class PilotNetDiff(PilotNet):
    inputs = {"modalities": ["image", "diff"], "color": "gray"}


@register("pilotnet-flow")
class PilotNetFlow(PilotNet):
    inputs = {"modalities": ["image", "flow"], "color": "gray"}


@register("cnn3d")
class CNN3D(SteeringModel):
    """PilotNet's five layers with kernels of temporal depth 3 over 3 stacked frames.

    Temporal size: every layer pads one frame on each side in time (and none in space), so the temporal size
    stays 3 through the network while the spatial sizes follow PilotNet (66x200 -> 1x18). The flattened
    features are 64 x 3 x 1 x 18 = 3456, followed by PilotNet's fully connected layers."""

    inputs = {"stack": 3, "modalities": ["image"], "color": "gray"}

    def __init__(self, in_channels: int = 3, dropout: float = 0.5, throttle: bool = False):
        super().__init__()
        self.learns_throttle = throttle
        layers, c = [], 1
        for out, k, s in [(24, 5, 2), (36, 5, 2), (48, 5, 2), (64, 3, 1), (64, 3, 1)]:
            layers += [nn.Conv3d(c, out, (3, k, k), (1, s, s), padding=(1, 0, 0)), nn.ReLU(inplace=True)]
            c = out
        self.features = nn.Sequential(*layers)
        self.frames = in_channels
        self.head = pilotnet_head(dropout, 1 + throttle)

    def forward(self, x: torch.Tensor) -> dict[str, torch.Tensor]:
        return self.named(self.head(self.features(x.unsqueeze(1)).flatten(1)))  # channels = time


@register("two-stream-flow")
class TwoStreamFlow(SteeringModel):
    inputs = {"modalities": ["image", "flow"]}

    def __init__(self, in_channels: int = 3, dropout: float = 0.5):
        super().__init__()
        self.image_channels = in_channels - 2  # the flow's (dx, dy) come last
        self.image = PilotNet(self.image_channels, dropout)
        self.flow = PilotNet(2, dropout)

    def forward(self, x: torch.Tensor) -> dict[str, torch.Tensor]:
        y_img = self.image(x[:, : self.image_channels])["steering"]
        y_flow = self.flow(x[:, self.image_channels:])["steering"]
        return {"steering": (y_img + y_flow) / 2, "steering_image": y_img, "steering_flow": y_flow}

    def loss(self, out: dict, targets: dict) -> torch.Tensor:
        """Paper 003: mean over the batch of (y_img - y)^2 + (y_flow - y)^2."""
        y = targets["steering"]
        return torch.mean((out["steering_image"] - y) ** 2 + (out["steering_flow"] - y) ** 2)
