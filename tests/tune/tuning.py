"""What the tests of `steerlab tune` share (here and in tests/sim/test_worlds.py): a study run through the Python
API with its options named as flags, a tuning config, the environment of a worker on one thread, a worker held
mid-trial, and a study's trials.csv."""

import csv
import os

import yaml

from steerlab.cli import flag
from steerlab.options import parse
from steerlab.train.config import load_config
from steerlab.tune import TuneOptions, run_tune as run


def run_tune(config, overrides=(), progress=False, study_name=None, pruning=3, **options):
    """`steerlab tune CONFIG [overrides] --option ...` through the Python API, options named as flags."""
    o = parse(TuneOptions, {**options, "study": study_name, "reduction_factor": pruning or 3,
                            "no_pruning": pruning is None}, name=flag)
    return run(load_config(config, list(overrides)), o, progress)


def tune_config(path, recording, out, tune=None, epochs=3, split=("0:120", "120:160")):
    """A tuning config in `path` (a test's tmp_path). The compiled cache is one for all the tests of a process (the
    folder above their tmp_paths): every one of them compiles the same recording at the same size, so the first
    compiles it and the others read it; workers that start together wait for one compile (the cache's lock)."""
    cfg = {"data": str(recording), "cache": str(path.parent / "tune-cache"), "out": str(out),
           "split": {"train": split[0], "val": split[1]}, "model": {"name": "pilotnet"},
           "preprocess": {"width": 64, "height": 64},  # small frames (PilotNet's layers need 61 or more): quick trials
           "train": {"epochs": epochs, "batch_size": 32, "patience": 10},
           "tune": tune or {"train.lr": {"low": 1.0e-5, "high": 0.1, "log": True},
                            "model.dropout": {"low": 0.0, "high": 0.6}}}
    file = path / f"{out.name}.yaml"
    file.write_text(yaml.safe_dump(cfg))
    return file


# Worker processes train on one thread, as the tests do: threads of several processes that share the cores
# only get in each other's way.
ONE_THREAD = {**os.environ, "OMP_NUM_THREADS": "1"}


class Hold:
    """`prelude`: that of a worker (conftest.CliProcess) whose trial stops after its first epoch until the worker is
    killed, so that it is killed mid-trial however fast or busy the machine is. It says that it holds in a FIFO in
    `folder`, which `wait` waits on (no polling)."""

    def __init__(self, folder):
        fifo = folder / "held"
        os.mkfifo(fifo)
        # open before the worker is started: its open for writing waits for this reader, never the other way round
        self.fd = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
        self.prelude = f"""import time
import steerlab.train.loop as loop
_train = loop.train
def _held(cfg, progress=False, on_epoch=None):
    def epoch_done(epoch, metrics):
        on_epoch(epoch, metrics)
        if epoch == 1:
            with open({str(fifo)!r}, "wb") as f:
                f.write(b"held")
            while True:
                time.sleep(60)
    return _train(cfg, progress, on_epoch=epoch_done)
loop.train = _held
"""

    def wait(self, worker) -> bool:
        """Until `worker` holds (True) or has ended (False), however long that takes."""
        from multiprocessing.connection import wait

        try:
            wait([self.fd, worker.process.sentinel])
            return os.read(self.fd, 4) == b"held"
        finally:
            os.close(self.fd)


def rows(out):
    with open(out / "trials.csv") as f:
        return list(csv.DictReader(f))
