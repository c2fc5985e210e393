"""Data-parallel training with PyTorch's own torch.distributed (DDP), started by torchrun.

`torchrun --nproc-per-node K -m steerlab train CONFIG` (or `steerlab train CONFIG --nproc K`) starts K ranks.
Each draws the same global batch order from the same seed and trains on its contiguous share of every global
batch (gathered from the shared memory-mapped cache: frames, or windows for recurrent models); DDP averages
the gradients, so K ranks with a global batch B take the steps one process takes with batch B. gloo on the
CPU, NCCL on CUDA. Rank 0 compiles the cache first and alone writes logs and checkpoints; every rank runs the
validation (identical weights give identical early-stopping decisions).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import torch
import torch.distributed as dist

from steerlab.errors import SteerlabError


@dataclass(frozen=True)
class Ranks:
    rank: int = 0
    world: int = 1
    device: torch.device = torch.device("cpu")

    @property
    def main(self) -> bool:
        return self.rank == 0

    def barrier(self) -> None:
        if self.world > 1:
            dist.barrier()

    def sum(self, *values: float) -> list[float]:
        """Sum numbers over the ranks."""
        if self.world == 1:
            return list(values)
        t = torch.tensor(values, dtype=torch.float64, device=self.device)
        dist.all_reduce(t)
        return t.tolist()


def device_of(option: str) -> torch.device:
    """train.device: auto (CUDA when present, else the CPU), cpu or cuda."""
    if option not in ("auto", "cpu", "cuda"):
        raise SteerlabError(f"train.device must be auto, cpu or cuda, got {option!r}")
    if option == "cuda" and not torch.cuda.is_available():
        raise SteerlabError("train.device is cuda, but torch sees no CUDA device (a CPU build or no GPU): "
                            "set train.device to cpu")
    return torch.device("cuda" if option == "cuda" or (option == "auto" and torch.cuda.is_available()) else "cpu")


def setup(option: str) -> Ranks:
    """This process's rank, the number of ranks and its device; joins the process group under torchrun."""
    device = device_of(option)
    world = int(os.environ.get("WORLD_SIZE", "1"))
    if world == 1:
        return Ranks(0, 1, device)
    rank, local = int(os.environ["RANK"]), int(os.environ.get("LOCAL_RANK", "0"))
    if device.type == "cuda":
        torch.cuda.set_device(local)
        device = torch.device("cuda", local)
    if not dist.is_initialized():
        dist.init_process_group("nccl" if device.type == "cuda" else "gloo")
    return Ranks(rank, world, device)


def wrap(model: torch.nn.Module, ranks: Ranks) -> torch.nn.Module:
    """The model as the training step sees it: on its device, in DDP with more than one rank."""
    model = model.to(ranks.device)
    if ranks.world == 1:
        return model
    from torch.nn.parallel import DistributedDataParallel

    return DistributedDataParallel(model, device_ids=[ranks.device.index] if ranks.device.type == "cuda" else None)


def finish() -> None:
    """Leave the process group (under torchrun, at the end of training)."""
    if dist.is_initialized():
        dist.destroy_process_group()
