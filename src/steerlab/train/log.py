"""The epoch log of a training run: `out/log.csv` and, optionally, TensorBoard. Each epoch's row holds its training
loss and validation metrics, `train_seconds`, the training pass alone, and `seconds`, the whole epoch (the
validation included)."""

from __future__ import annotations

import csv
from pathlib import Path

from steerlab.errors import SteerlabError

METRIC = {"speed": "speed_mae", "command": "command_accuracy", "throttle": "throttle_mae",  # of each extra output
          "lane": "lane_mae"}


class EpochLog:
    """One row per epoch in `out/log.csv` (rewritten from the history first, so that a resumed run has no
    duplicate epochs) and, with `tensorboard`, the same values as scalars in `out/tensorboard`."""

    def __init__(self, out: Path, targets: tuple, history: list[dict], tensorboard: bool = False):
        self.path = out / "log.csv"
        self.fields = (["epoch", "train_loss", "val_mse", "val_rmse", "val_mae", "val_mae_deg", "val_gamma_deg"]
                       + [f"val_{METRIC[t]}" for t in targets] + ["train_seconds", "seconds"])
        with open(self.path, "w", newline="") as f:
            w = csv.DictWriter(f, self.fields)
            w.writeheader()
            w.writerows(history)
        self.board = None
        if tensorboard:
            try:
                from torch.utils.tensorboard import SummaryWriter
            except ImportError:
                raise SteerlabError("train.tensorboard needs the tensorboard package: pip install tensorboard") from None
            start = history[-1]["epoch"] + 1 if history else 1  # a resumed run drops later events first
            self.board = SummaryWriter(str(out / "tensorboard"), purge_step=start)

    def write(self, epoch: int, loss: float, m: dict, train_seconds: float, seconds: float) -> dict:
        row = {"epoch": epoch, "train_loss": loss, "train_seconds": round(train_seconds, 3),
               "seconds": round(seconds, 3)}
        row.update({f"val_{k}": m[k] for k in ("mse", "rmse", "mae", "mae_deg", "gamma_deg", *METRIC.values())
                    if k in m})
        with open(self.path, "a", newline="") as f:
            csv.DictWriter(f, self.fields).writerow(row)
        if self.board is not None:
            for key, value in row.items():
                if key != "epoch":  # train_loss -> train/loss, val_rmse -> val/rmse
                    self.board.add_scalar(key.replace("_", "/", 1), value, epoch)
            self.board.flush()
        return row

    def close(self) -> None:
        if self.board is not None:
            self.board.close()
