"""Hyperparameter tuning as in paper 000 V-A (`steerlab tune`): BOHB-style search with Optuna.

Optuna's multivariate TPE sampler proposes configurations from a config's `tune:` section (`space.py`) and its
Hyperband pruner stops unpromising trials early, with epochs as the budget: each epoch reports the validation
RMSE (together: BOHB's idea, Falkner et al. 2018, on Optuna's parts; `run.py`). Objectives: validation RMSE
(default), RMSE and gamma (multi-objective, Pareto front; Optuna cannot prune multi-objective trials, so those
run to completion), or the closed-loop autonomy of the best epoch on the synthetic-world suite (the config's
`closed_loop:` section). The study lives in an Optuna storage that any number of workers on any number of
machines can share (`storage.py`); the reports are `report.py`'s. One training run per trial under `trials/`.
"""

from steerlab.tune.run import TuneOptions, run_tune

__all__ = ["TuneOptions", "run_tune"]
