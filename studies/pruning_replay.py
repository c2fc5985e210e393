"""What would Hyperband have saved on a study that ran every trial to completion?

python studies/pruning_replay.py runs/tune-pruning-sim-full [--as tune-pruning-sim] [--factors 3 4 5]

Replays the learning curves of a `steerlab tune ... --no-pruning` study, in trial order, through Optuna's
Hyperband pruner with each reduction factor (same budgets and last-epoch rule as `steerlab tune`), and prints
the epochs the pruned study would have trained and the best value among the trials it would have completed.
`--as NAME` places the trials in Hyperband's brackets as a study of that name would (the bracket of a trial is
a hash of the study name and its number). The configurations stay those the unpruned study's sampler chose: a
real pruned study samples after seeing pruned trials, so run one to confirm a factor.
"""

import argparse
import sys
from pathlib import Path

import optuna


def replay(curves: list[dict], epochs: int, name: str, factor: int) -> tuple[int, int, float]:
    study = optuna.create_study(study_name=name,
                                pruner=optuna.pruners.HyperbandPruner(1, epochs, reduction_factor=factor))
    trained, complete, best = 0, 0, float("inf")
    for curve in curves:
        trial = study.ask()
        for epoch in range(1, epochs + 1):
            trial.report(curve[epoch], epoch)
            trained += 1
            if epoch < epochs and trial.should_prune():
                study.tell(trial, state=optuna.trial.TrialState.PRUNED)
                break
        else:
            value = min(curve.values())
            study.tell(trial, value)
            complete, best = complete + 1, min(best, value)
    return trained, complete, best


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("study_dir", help="output folder of a study run with --no-pruning (holds study.journal)")
    p.add_argument("--as", dest="name", help="study name that decides the brackets (default: the study's own)")
    p.add_argument("--factors", type=int, nargs="+", default=[3, 4, 5], help="reduction factors (at least 2)")
    a = p.parse_args()
    journal = Path(a.study_dir) / "study.journal"
    if not journal.is_file():
        sys.exit(f"error: {journal}: not found (run the study with --no-pruning first)")
    if min(a.factors) < 2:
        sys.exit(f"error: --factors must be integers of at least 2 (a reduction factor), got {min(a.factors)}")
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    storage = optuna.storages.JournalStorage(optuna.storages.journal.JournalFileBackend(str(journal)))
    source = optuna.load_study(study_name=optuna.get_all_study_names(storage)[0], storage=storage)
    trials = sorted(source.get_trials(states=(optuna.trial.TrialState.COMPLETE,)), key=lambda t: t.number)
    epochs = max(max(t.intermediate_values) for t in trials)
    curves = [t.intermediate_values for t in trials]
    if any(len(c) != epochs for c in curves):
        sys.exit(f"error: {journal}: some trials stopped before epoch {epochs} (patience); replay needs full curves")
    full = len(curves) * epochs
    best_full = min(t.value for t in trials)
    print(f"{source.study_name}: {len(curves)} trials x {epochs} epochs = {full}, best {best_full:.5f}")
    print("| reduction factor | complete / pruned | epochs trained | fewer | best | vs. unpruned best |")
    print("|---|---|---|---|---|---|")
    for f in a.factors:
        trained, complete, best = replay(curves, epochs, a.name or source.study_name, f)
        print(f"| {f} | {complete} / {len(curves) - complete} | {trained} | {full / trained:.2f}x | {best:.5f} | "
              f"{100 * (best / best_full - 1):+.1f} % |")


if __name__ == "__main__":
    main()
