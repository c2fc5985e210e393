"""Hyperparameter tuning as in paper 000 V-A (`steerlab tune`): BOHB-style search with Optuna.

Optuna's multivariate TPE sampler proposes configurations from a config's `tune:` section (`space.py`) and its
Hyperband pruner stops unpromising trials early, with epochs as the budget: each epoch reports the validation
RMSE (together: BOHB's idea, Falkner et al. 2018, on Optuna's parts; `run.py`). Objectives: validation RMSE
(default), RMSE and gamma (multi-objective, Pareto front; Optuna cannot prune multi-objective trials, so those
run to completion), or the closed-loop autonomy of the best epoch on the synthetic-world suite (the config's
`closed_loop:` section). The study lives in an Optuna storage that any number of workers on any number of
machines can share (`storage.py`); the reports are `report.py`'s. One training run per trial under `trials/`.
"""

__all__ = ["TuneOptions", "run_tune"]


def __getattr__(name: str):
    """`TuneOptions` and `run_tune`, imported when first asked for (the command line reads the options without
    loading Optuna and torch)."""
    if name == "TuneOptions":
        from steerlab.tune.options import TuneOptions

        return TuneOptions
    if name == "run_tune":
        from steerlab.tune.run import run_tune

        return run_tune
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
