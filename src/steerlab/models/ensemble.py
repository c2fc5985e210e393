"""An ensemble: the mean of the outputs of several trained models that read the same inputs (seeds of one
model, or models with the same preprocessing and outputs), built by `steerlab ensemble` (`checkpoint.save_ensemble`).

It takes the frame as the Pilot prepares it before standardisation (its checkpoint's statistics are the
identity), and each member standardises it with its own training statistics. Recurrent members' states are
concatenated along the hidden axis, so a recurrent ensemble carries one (h, c) pair like a single recurrent
model, and exports to ONNX the same way. Speed-command logits are averaged too (the command is their
argmax). It is not in the model registry: nothing trains it.
"""

from __future__ import annotations

import torch
import torch.nn as nn

from steerlab.models.registry import SteeringModel, create_model


class Ensemble(SteeringModel):
    registry_name = "ensemble"
    trainable = False

    def __init__(self, members: list[dict]):
        """`members`: one dict per model, {"model": name, "model_cfg": options, "stats": {"mean", "std"}}."""
        super().__init__()
        self.nets = nn.ModuleList(create_model(m["model"], **m["model_cfg"]) for m in members)
        for k, m in enumerate(members):
            shape = (1, -1, 1, 1)
            self.register_buffer(f"mean{k}", torch.tensor(m["stats"]["mean"]).view(shape), persistent=False)
            self.register_buffer(f"std{k}", torch.tensor(m["stats"]["std"]).view(shape), persistent=False)
        first = self.nets[0]
        self.recurrent, self.speed_history, self.targets = first.recurrent, first.speed_history, first.targets
        self.learns_throttle = first.learns_throttle
        self.hidden = [net.lstm.hidden_size for net in self.nets] if self.recurrent else []

    def forward(self, x: torch.Tensor, speeds: torch.Tensor | None = None, state=None):
        kwargs = {} if speeds is None else {"speeds": speeds}
        outs, states = [], []
        if state is not None:  # one (h, c) pair: the members' states side by side on the hidden axis
            state = list(zip(*(torch.split(s, self.hidden, dim=-1) for s in state)))
        for k, net in enumerate(self.nets):
            mean, std = getattr(self, f"mean{k}"), getattr(self, f"std{k}")
            if self.recurrent:
                own = None if state is None else tuple(s.contiguous() for s in state[k])
                out, s = net((x - mean.unsqueeze(1)) / std.unsqueeze(1), state=own, **kwargs)
                states.append(s)
            else:
                out = net((x - mean) / std, **kwargs)
            outs.append(out)
        mean_out = {key: torch.stack([o[key] for o in outs]).mean(0) for key in outs[0]}
        if not self.recurrent:
            return mean_out
        return mean_out, tuple(torch.cat([s[i] for s in states], dim=-1) for i in (0, 1))
