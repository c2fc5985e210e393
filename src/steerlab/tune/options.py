"""`steerlab tune`'s options (imported by the command line without the tuning machinery)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from steerlab.options import AT_LEAST_1, COUNT_MAX, Options, Range, SEED, option

OBJECTIVES = {"rmse": ["minimize"], "rmse+gamma": ["minimize", "minimize"], "autonomy": ["maximize"]}


@dataclass(frozen=True)
class TuneOptions(Options):
    """`steerlab tune`'s options."""

    trials: int = option(20, AT_LEAST_1, help="finished trials the study should have")
    objective: Literal[tuple(OBJECTIVES)] = option("rmse", help="validation RMSE, RMSE and gamma (Pareto front), "
                                                   "or closed-loop autonomy")
    storage: str | None = option(None, help="Optuna storage shared by workers: a journal file (*.journal) or an "
                                 "RDB URL (sqlite:///study.db, postgresql://...); default OUT/study.journal")
    study: str | None = option(None, help="study name (default: the name of the config's out folder)")
    seed: int = option(0, SEED, help="sampler seed")
    reduction_factor: int = option(3, Range(2, COUNT_MAX), "an integer of at least 2 (at most 1000000)",
                                   help="Hyperband: each rung keeps the best 1/N of the trials")
    no_pruning: bool = option(False, help="run every trial to completion (no Hyperband)")
    join: bool = option(False, help="join a study that another worker started: a study that does not exist in "
                        "the storage is an error (a mistyped --study or --storage), not a new study")

    @property
    def pruning(self) -> int | None:
        return None if self.no_pruning else self.reduction_factor
