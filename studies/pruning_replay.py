"""What would Hyperband have saved on a study that ran every trial to completion?

python -m studies.pruning_replay runs/tune-pruning-sim-full [--as tune-pruning-sim] [--factors 3,4,5]

Replays the learning curves of a `steerlab tune ... --no-pruning` study, in trial order, through Optuna's
Hyperband pruner with each reduction factor (same budgets and last-epoch rule as `steerlab tune`), and prints
the epochs the pruned study would have trained and the best value among the trials it would have completed.
`--as NAME` places the trials in Hyperband's brackets as a study of that name would (the bracket of a trial is
a hash of the study name and its number). The configurations stay those the unpruned study's sampler chose: a
real pruned study samples after seeing pruned trials, so run one to confirm a factor.
"""

from dataclasses import dataclass
from pathlib import Path

import optuna

from steerlab.cli import run_script, script_parser
from steerlab.errors import SteerlabError
from steerlab.options import COUNT_MAX, Options, Range, option
from studies.common import NumberList

FACTORS = NumberList(int, Range(2, COUNT_MAX))  # Hyperband's reduction factor: a bracket keeps 1 of every factor


@dataclass(frozen=True)
class PruningReplay(Options):
    factors: str = option("3,4,5", FACTORS, FACTORS.words, help="Hyperband's reduction factors replayed")


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


def parser():
    p = script_parser(__spec__.name, __doc__, PruningReplay)
    p.add_argument("study_dir", help="output folder of a study run with --no-pruning (holds study.journal)")
    p.add_argument("--as", dest="name", help="study name that decides the brackets (default: the study's own)")
    return p


def main(a, o: PruningReplay) -> None:
    journal = Path(a.study_dir) / "study.journal"
    if not journal.is_file():
        raise SteerlabError(f"{journal}: not found (run the study with --no-pruning first)")
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    storage = optuna.storages.JournalStorage(optuna.storages.journal.JournalFileBackend(str(journal)))
    names = optuna.get_all_study_names(storage)
    if not names:
        raise SteerlabError(f"{journal}: holds no study (run the study with --no-pruning first)")
    source = optuna.load_study(study_name=names[0], storage=storage)
    trials = sorted(source.get_trials(states=(optuna.trial.TrialState.COMPLETE,)), key=lambda t: t.number)
    if not trials or not all(t.intermediate_values for t in trials):
        raise SteerlabError(f"{journal}: {source.study_name} has no complete trial with its learning curve to replay")
    epochs = max(max(t.intermediate_values) for t in trials)
    curves = [t.intermediate_values for t in trials]
    if any(len(c) != epochs for c in curves):
        raise SteerlabError(f"{journal}: some trials stopped before epoch {epochs} (patience); replay needs full "
                            "curves")
    full = len(curves) * epochs
    best_full = min(t.value for t in trials)
    print(f"{source.study_name}: {len(curves)} trials x {epochs} epochs = {full}, best {best_full:.5f}")
    print("| reduction factor | complete / pruned | epochs trained | fewer | best | vs. unpruned best |")
    print("|---|---|---|---|---|---|")
    for f in FACTORS.of(o.factors):
        trained, complete, best = replay(curves, epochs, a.name or source.study_name, f)
        print(f"| {f} | {complete} / {len(curves) - complete} | {trained} | {full / trained:.2f}x | {best:.5f} | "
              f"{100 * (best / best_full - 1):+.1f} % |")


if __name__ == "__main__":
    run_script(parser(), main)
