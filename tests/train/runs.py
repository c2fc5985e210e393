"""What the tests of training share: a run's config on the tiny recording (PilotNet on 64x64 frames, the
compiled frames in one cache per worker process) and its log."""

import csv

from steerlab.train.config import load_config


def _raw(rec, tmp_path, model=None, split=None, preprocess=None, extra=(), **train):
    """A run's config: PilotNet on 64x64 frames (a third of 200x66's pixels, the same paths) unless `model` or
    `preprocess` say otherwise. The compiled frames are kept in one cache for all tests of a worker process (its
    entries are named by the recording's content and the preprocessing, so each is compiled once)."""
    return {"data": str(rec), "cache": str(tmp_path.parent / "train-cache"), "out": str(tmp_path / "run"),
            "split": split or {"train": "0:240", "val": "240:300"}, "extra_data": list(extra),
            "model": model or {"name": "pilotnet", "dropout": 0.0},
            "preprocess": {"width": 64, "height": 64} if preprocess is None and model is None else preprocess or {},
            "train": {"epochs": 4, "lr": 1e-3, "batch_size": 32, "patience": 10, **train}}


def _cfg(rec, tmp_path, **options):
    return load_config(None, base=_raw(rec, tmp_path, **options))


def _log(tmp_path):
    with open(tmp_path / "run" / "log.csv") as f:
        return list(csv.DictReader(f))
