"""A study's reports, in its output folder: `trials.csv` (Optuna's `trials_dataframe`), `summary.md` (trial
states; epochs trained against the finished trials' full budget: what pruning saved), `best.yaml` (a training
config `steerlab train` runs as it is), and Optuna's own plots: `history.png` and, over the completed trials,
`importance.md` / `importance.png` (fANOVA importance, percent, from `IMPORTANCE_TRIALS` trials on) and
`slice.png` (the objective against each parameter, paper 000 Fig. 4's view); for two objectives the Pareto front
(`pareto.md`, `pareto.png`)."""

from __future__ import annotations

import warnings
from dataclasses import replace
from pathlib import Path

import yaml

from steerlab.figures import plt
from steerlab.options import as_dict
from steerlab.train.config import TrainConfig
from steerlab.tune.space import with_params
from steerlab.tune.storage import optuna


# fANOVA's random forest over fewer completed trials (of different parameters) than this gives noise, not importance
IMPORTANCE_TRIALS = 10


def short(v) -> str:
    return f"{v:.3g}" if isinstance(v, float) else str(v)


def _save(axes, path: Path) -> None:
    """An Optuna matplotlib plot (Axes, or an array of them) written to `path` and closed. A plot with a colour
    bar (the slice plot) keeps Optuna's own layout: `tight_layout` would draw the bar over the last panel."""
    fig = (axes.flat[0] if hasattr(axes, "flat") else axes).figure
    if not any(a.get_label() == "<colorbar>" for a in fig.axes):
        fig.set_size_inches(max(6.5, fig.get_size_inches()[0]), 4)
        fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _trials_csv(study, trials: list, path: Path) -> None:
    """Optuna's trials_dataframe of the study's own trials (surplus ones left out), its columns named as the
    config keys: number, state, value_0.., epochs_run, best_epoch, seconds, then the parameters. A pruned
    trial's value is its best intermediate one."""
    frame = study.trials_dataframe(attrs=("number", "state", "value", "duration", "params", "user_attrs"))
    frame = frame[frame["number"].isin([t.number for t in trials])].copy()
    values = [c for c in frame.columns if c == "value" or c.startswith("values_")]
    for c in values:
        best = {t.number: min(t.intermediate_values.values()) for t in trials if t.intermediate_values}
        frame[c] = frame[c].fillna(frame["number"].map(best))
    frame = frame.rename(columns={**{c: f"value_{i}" for i, c in enumerate(values)},
                                  **{c: c.removeprefix("params_") for c in frame.columns if c.startswith("params_")},
                                  "user_attrs_epochs_run": "epochs_run", "user_attrs_best_epoch": "best_epoch"})
    frame["state"] = frame["state"].str.lower()
    frame["seconds"] = frame["duration"].dt.total_seconds()
    params = sorted({k for t in trials for k in t.params})
    columns = ["number", "state", *[f"value_{i}" for i in range(len(values))], "epochs_run", "best_epoch",
               "seconds", *params]
    frame.reindex(columns=columns).to_csv(path, index=False)


def _computed_evaluator(importance: dict):
    """An Optuna importance evaluator that gives `importance`, computed already."""
    class Computed(optuna().importance.BaseImportanceEvaluator):
        def evaluate(self, study, params=None, *, target=None) -> dict:
            return importance

    return Computed()


def write_reports(study, out: Path, cfg: TrainConfig) -> bool:
    """Every report of the study; returns whether it has a complete trial (otherwise there is no best one, and
    only trials.csv and summary.md are written)."""
    TrialState = optuna().trial.TrialState
    vis = optuna().visualization.matplotlib
    out.mkdir(parents=True, exist_ok=True)
    # the study's own trials: not the surplus ones, nor one that another worker has just created and not yet
    # claimed (it has no "worker" yet), which may still turn out to be surplus. The attributes are read after the
    # trials: a worker marks a trial surplus before it fails it.
    trials = study.get_trials(deepcopy=False)
    surplus = {k for k in study.user_attrs if k.startswith("surplus_")}
    trials = [t for t in trials if f"surplus_{t.number}" not in surplus
              and (t.state != TrialState.RUNNING or "worker" in t.user_attrs)]
    _trials_csv(study, trials, out / "trials.csv")
    complete = [t for t in trials if t.state == TrialState.COMPLETE]
    finished = [t for t in trials if t.state in (TrialState.COMPLETE, TrialState.PRUNED)]
    trained = sum(t.user_attrs.get("epochs_run", 0) for t in finished)
    full = len(finished) * cfg.train.epochs
    (out / "summary.md").write_text(
        f"{len(trials)} trials: {len(complete)} complete, {len(finished) - len(complete)} pruned, "
        f"{len(trials) - len(finished)} failed or running. The finished trials trained {trained} epochs; run to "
        f"their last epoch they would have trained {full}" + (f" ({full / trained:.2f}x)" if trained else "") + ".\n")
    for stale in ("best.yaml", "importance.md", "importance.png", "slice.png", "history.png", "pareto.md", "pareto.png"):
        (out / stale).unlink(missing_ok=True)
    if not complete:
        return False
    params = sorted({k for t in trials for k in t.params})
    with warnings.catch_warnings():  # Optuna's matplotlib plots are marked experimental
        warnings.simplefilter("ignore")
        if len(study.directions) > 1:
            front = study.best_trials
            lines = ["| trial | validation RMSE | gamma [deg] | " + " | ".join(params) + " |",
                     "|---" * (3 + len(params)) + "|"]
            lines += [f"| {t.number} | {t.values[0]:.4f} | {t.values[1]:.3f} | "
                      + " | ".join(short(t.params.get(k, "")) for k in params) + " |" for t in front]
            (out / "pareto.md").write_text("Pareto front (validation RMSE vs gamma):\n\n" + "\n".join(lines) + "\n")
            _save(vis.plot_pareto_front(study, target_names=["validation RMSE", "gamma [deg]"]), out / "pareto.png")
            best = min(front, key=lambda t: t.values[0])
        else:
            best = study.best_trial
            _save(vis.plot_optimization_history(study), out / "history.png")
            distinct = len({repr(t.params) for t in complete})  # a rerun with the same --seed repeats them
            if params and distinct > 1 and len({t.values[0] for t in complete}) > 1:
                _save(vis.plot_slice(study), out / "slice.png")
                if distinct < IMPORTANCE_TRIALS:
                    (out / "importance.md").write_text(
                        f"fANOVA importance: {distinct} completed trials of different parameters; it takes at least "
                        f"{IMPORTANCE_TRIALS} for the importance to be more than noise, so none is given.\n")
                else:
                    fanova = optuna().importance.FanovaImportanceEvaluator(seed=0)
                    importance = optuna().importance.get_param_importances(study, evaluator=fanova, normalize=True)
                    total = sum(importance.values()) or 1.0
                    rows = [f"| {k} | {100 * v / total:.1f} |" for k, v in importance.items()]
                    (out / "importance.md").write_text(
                        f"fANOVA importance over {len(complete)} completed trials (percent of the explained "
                        "variance of the objective):\n\n| hyperparameter | importance [%] |\n|---|---|\n"
                        + "\n".join(rows) + "\n")
                    # the plot of these importances: fANOVA's forest is not fitted a second time (seconds for a
                    # study of hundreds of trials)
                    _save(vis.plot_param_importances(study, evaluator=_computed_evaluator(importance)),
                          out / "importance.png")
    best_cfg = replace(with_params(cfg, best.params), out=str(out / "best"))
    (out / "best.yaml").write_text(
        f"# best trial {best.number} of study {study.study_name}: {', '.join(f'{v:.5g}' for v in best.values)}\n"
        + yaml.safe_dump(as_dict(best_cfg), sort_keys=False))
    return True
