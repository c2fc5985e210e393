"""Subcommands that train: train, experiment, tune, and views (what a config trains on, for another trainer)."""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import dataclass

from steerlab.cli import path_option, add_options, from_args, print_table
from steerlab.cli.data import OUTPUT_METRICS
from steerlab.errors import SteerlabError
from steerlab.options import AT_LEAST_1, CORES, Options, Range, option


@dataclass(frozen=True)
class TrainCommand(Options):
    nproc: int = option(1, Range(1, CORES), help="data-parallel ranks on this machine, at most its cores (torchrun + "
                        "DDP; train.batch_size stays the global batch)")


@dataclass(frozen=True)
class ExperimentCommand(Options):
    seeds: int = option(3, AT_LEAST_1, help="runs per model, seeds 0..N-1")


def cmd_train(a) -> None:
    from steerlab.train.config import load_config
    from steerlab.train.distributed import finish
    from steerlab.train.loop import train

    nproc = from_args(TrainCommand, a).nproc
    cfg = load_config(a.config, a.overrides)
    if cfg.dagger is not None:
        raise SteerlabError(f"{a.config} has a dagger section: run it with `steerlab sim dagger {a.config}`")
    if nproc > 1 and "WORLD_SIZE" not in os.environ:  # start the ranks with torchrun
        cmd = [sys.executable, "-m", "torch.distributed.run", "--standalone", f"--nproc-per-node={nproc}",
               "-m", "steerlab", "train", a.config, *a.overrides]
        if subprocess.run(cmd).returncode:
            raise SteerlabError(f"distributed training with {nproc} ranks failed (see the messages above): fix the "
                                "first error they name and run it again")
        return
    try:
        best = train(cfg)
    finally:
        finish()
    if os.environ.get("RANK", "0") != "0":
        return
    print(f"best checkpoint: {cfg.out}/best.pt (epoch {best.get('epoch')})")
    print_table(best, ["mse", "rmse", "mae", "mae_deg", "gamma_deg", "target_gamma_deg", *OUTPUT_METRICS])


def cmd_experiment(a) -> None:
    from steerlab.experiment import run_experiment

    table = run_experiment(a.config, a.overrides, from_args(ExperimentCommand, a).seeds)
    print(table.read_text())
    print(f"wrote {table}, {table.parent / 'table.csv'}, {table.parent / 'predictions.png'}")


def cmd_tune(a) -> None:
    from steerlab.train.config import load_config
    from steerlab.tune import TuneOptions, run_tune

    o = from_args(TuneOptions, a)
    out = run_tune(load_config(a.config, a.overrides), o)
    for name in ("summary.md", "importance.md", "pareto.md"):
        if (out / name).exists():
            print((out / name).read_text())
    print(f"wrote {out}/trials.csv, {out}/best.yaml (run it: steerlab train {out}/best.yaml)"
          + "".join(f", {out}/{f}" for f in ("importance.png", "slice.png", "history.png", "pareto.png")
                    if (out / f).exists()))


def cmd_views(a) -> None:
    from steerlab.paths import check_outputs
    from steerlab.train.config import load_config, override_key
    from steerlab.train.views_tub import write_views_tub

    if given := [o for o in a.overrides if override_key(o) == "out"]:
        raise SteerlabError(f"{given[0]}: steerlab views writes the tub --out names; a config's out (its training "
                            "run's folder) is not used here: leave it out")
    cfg = load_config(a.config, a.overrides)
    check_outputs({"output folder (--out)": a.out}, inputs=cfg.inputs(), kind="recording")
    out = write_views_tub(cfg, a.out)
    records = f"records {cfg.range} of {cfg.data}" if cfg.range else f"every record of {cfg.data}"
    print(f"wrote {out}: {len(cfg.train.views)} view(s) of {records}; train donkeycar on both: donkey train --tub "
          f"{cfg.data},{out} --type linear")


def register(sub) -> None:
    from steerlab.tune.options import TuneOptions

    q = sub.add_parser("train", help="train a model from a YAML config", epilog="example: steerlab train "
                       "configs/ch2_pilotnet.yaml train.epochs=5 out=runs/quick")
    path_option(q, "config", kind="file", help="YAML config (see configs/)")
    q.add_argument("overrides", nargs="*", help="section.key=value overrides, e.g. train.lr=3e-4")
    add_options(q, "train", TrainCommand)
    q.set_defaults(func=cmd_train)

    q = sub.add_parser("experiment", help="train several models with several seeds and tabulate them",
                       epilog="example: steerlab experiment configs/experiment_ch2.yaml --seeds 3")
    path_option(q, "config", kind="file", help="YAML config with a 'models' list (see configs/experiment_ch2.yaml)")
    q.add_argument("overrides", nargs="*", help="section.key=value overrides for every run")
    add_options(q, "experiment", ExperimentCommand)
    q.set_defaults(func=cmd_experiment)

    q = sub.add_parser("views", help="write the views a config trains on (train.views) as a donkeycar tub, for "
                       "donkeycar's own trainer", epilog="example: steerlab views configs/donkey_tub.yaml "
                       "data=path/to/my/tub reader.full_lock_deg=25 --out runs/my-tub-views")
    path_option(q, "config", kind="file", help="training config of a donkeycar tub (see configs/donkey_tub.yaml)")
    q.add_argument("overrides", nargs="*", help="section.key=value overrides, e.g. reader.full_lock_deg=25")
    path_option(q, "--out", kind="folder", makes="recording", required=True, help="the tub to write")
    q.set_defaults(func=cmd_views)

    q = sub.add_parser("tune", help="BOHB-style hyperparameter search (Optuna TPE + Hyperband) over a config's "
                       "tune: section", epilog="example: steerlab tune configs/tune_multimodal_lstm.yaml --trials 40; "
                       "more workers: run the same command elsewhere with --storage postgresql://... --study NAME")
    path_option(q, "config", kind="file", help="training config with a tune: section (config key -> range)")
    q.add_argument("overrides", nargs="*", help="section.key=value overrides, e.g. train.epochs=8")
    add_options(q, "tune", TuneOptions)
    q.set_defaults(func=cmd_tune)
