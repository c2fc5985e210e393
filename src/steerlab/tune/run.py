"""`steerlab tune`: a study's trials, worker by worker (see the package's docstring)."""

from __future__ import annotations

import json
import os
import socket
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
from tqdm import tqdm

from steerlab.errors import DataError, SteerlabError, warn
from steerlab.locks import pid_alive, waiting_lock
from steerlab.paths import check_outputs
from steerlab.options import as_dict
from steerlab.sim.worlds import closed_loop
from steerlab.train.config import TrainConfig
from steerlab.tune.options import OBJECTIVES, TuneOptions
from steerlab.tune.report import short, write_reports
from steerlab.tune.space import search_space, with_params
from steerlab.tune.storage import heartbeat, optuna as storage_optuna, shown_url, storage_of

def _retry_dead_local_trials(study, name: str, progress: bool) -> None:
    """A journal has no heartbeat. A trial left running by a worker of this machine that no longer runs (killed)
    is failed and queued again with the same parameters, as a heartbeat would on an RDB storage; one of a
    worker on another machine cannot be told from a live one, and is named."""
    optuna = storage_optuna()
    host = socket.gethostname()
    for t in study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.RUNNING,)):
        worker = t.user_attrs.get("worker") or {}
        if worker.get("host") == host and not pid_alive(int(worker.get("pid", 0))):
            study._storage.set_trial_state_values(t._trial_id, optuna.trial.TrialState.FAIL)
            study.enqueue_trial(t.params, user_attrs={"retry_of": t.number})
            warn(f"study {name}: trial {t.number} was left running by a worker that stopped (pid "
                 f"{worker.get('pid')}): failed, and queued again with the same parameters")
        elif worker.get("host") != host and progress:
            where = f"host {worker.get('host')}, pid {worker.get('pid')}" if worker else "an unknown worker"
            warn(f"study {name}: trial {t.number} runs on {where}; a journal cannot tell whether that worker still "
                 "runs (an RDB storage can: --storage sqlite:///... or postgresql://...), so it keeps its place")


def _load_study(cfg: TrainConfig, o: TuneOptions, storage, name: str, url: str | None = None):
    """Create the study, or join it if it exists with the same search space and objective (`join`: it must)."""
    optuna = storage_optuna()
    objective, pruning, seed, epochs = o.objective, o.pruning, o.seed, cfg.train.epochs
    signature = json.dumps({"tune": cfg.tune, "objective": objective, "pruning": pruning}, sort_keys=True)
    try:
        existing = optuna.load_study(study_name=name, storage=storage)
    except KeyError:
        existing = None
    if existing is None and o.join:
        names = [repr(n) for n in optuna.get_all_study_names(storage)]
        there = ", ".join(names[:10]) + (", ..." if len(names) > 10 else "") if names else "none"
        raise SteerlabError(f"study {name!r} does not exist in {shown_url(url) if url else 'the storage'} (studies "
                            f"there: {there}); check steerlab tune --study and --storage, or start "
                            "the study without --join")
    # studies created before the reduction factor was an option stored "prune": true (factor 3) or false
    older = json.dumps({"tune": cfg.tune, "objective": objective, "prune": pruning is not None},
                       sort_keys=True) if pruning in (None, 3) else None
    if existing is not None and existing.user_attrs.get("signature") not in (None, signature, older):
        raise SteerlabError(f"study {name!r} exists in this storage with a different search space, objective or "
                            "pruning; choose another steerlab tune --study name")
    # a worker that continues a study draws anew: seeded with the trials already there, so that the same --seed
    # does not propose the study's first configurations again (a new study with a seed is reproducible)
    done = len(existing.trials) if existing is not None else 0
    sampler = optuna.samplers.TPESampler(seed=int(np.random.SeedSequence([seed, done]).generate_state(1)[0]) if done
                                         else seed, multivariate=True, n_startup_trials=min(10, max(2, epochs)))
    pruner = (optuna.pruners.HyperbandPruner(min_resource=1, max_resource=epochs, reduction_factor=pruning)
              if pruning and len(OBJECTIVES[objective]) == 1 else optuna.pruners.NopPruner())
    study = optuna.create_study(study_name=name, storage=storage, sampler=sampler, pruner=pruner,
                                directions=OBJECTIVES[objective], load_if_exists=True)
    study.set_user_attr("signature", signature)
    study.set_user_attr("config", as_dict(cfg))
    return study


def run_tune(cfg: TrainConfig, o: TuneOptions, progress: bool = True) -> Path:
    """Run trials of the study until it has `o.trials` finished ones; write the reports. Returns the folder.
    Raises when the study has no complete trial to report (all failed or still running)."""
    from steerlab.train.loop import train

    optuna = storage_optuna()
    space = search_space(cfg.tune, cfg)
    world, closed = closed_loop(cfg.closed_loop) if o.objective == "autonomy" else (None, None)
    url = o.storage or ""
    local = (url[len("sqlite:///"):] if url.startswith("sqlite:///") else None if "://" in url
             else url.removeprefix("journal:") or None)  # a storage file of this machine: an output too
    check_outputs({"output folder (out)": cfg.out}, {"study's storage (--storage)": local}, cfg.inputs(), "study")
    out = Path(cfg.out)
    name = o.study or out.name
    epochs, trials, objective = cfg.train.epochs, o.trials, o.objective
    store = storage_of(o.storage, out, o.join)
    study = _load_study(cfg, o, store, name, o.storage or str(out / "study.journal"))
    if isinstance(store, optuna.storages.JournalStorage):
        _retry_dead_local_trials(study, name, progress)
    surplus, failures = [], []

    def objective_fn(trial):
        if _ahead(study, trial.number) >= trials:  # other workers have started the last trials already
            study.set_user_attr(f"surplus_{trial.number}", True)
            surplus.append(trial.number)
            raise _Surplus()
        trial.set_user_attr("worker", {"host": socket.gethostname(), "pid": os.getpid()})
        run_cfg = replace(with_params(cfg, {k: _suggest(trial, k, d) for k, d in space.items()}),
                          out=str(out / "trials" / f"{trial.number:04d}"))
        single = len(OBJECTIVES[objective]) == 1

        def on_epoch(epoch: int, m: dict) -> None:
            trial.set_user_attr("epochs_run", epoch)
            if single and objective == "rmse":
                trial.report(m["rmse"], epoch)
                if epoch < epochs and trial.should_prune():  # a trial that trained all its epochs is complete
                    raise optuna.TrialPruned()

        try:
            best = train(run_cfg, progress=False, on_epoch=on_epoch)
        except DataError:  # bad data is bad for every trial: the study stops, saying where (the trial: failed)
            raise
        except SteerlabError as e:  # the trial's training failed (diverged, say): a failed trial, the study goes on
            trial.set_user_attr("error", str(e))
            failures.append(trial.number)
            raise _Failed() from None
        trial.set_user_attr("best_epoch", best.get("epoch"))
        if objective == "rmse":
            return best["rmse"]
        if objective == "rmse+gamma":
            return best["rmse"], best["gamma_deg"]
        # a trial's suite keeps its tables; figures for every trial of a study would go unseen
        return world.report.metrics(Path(run_cfg.out) / "best.pt", closed, False, plots=False)["autonomy"]

    done_states = (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.PRUNED)
    finished = len(study.get_trials(deepcopy=False, states=done_states))
    bar = tqdm(total=trials, initial=min(finished, trials), desc=f"study {name}", unit="trial",
               disable=not progress or None)

    board = _Board(out, objective) if cfg.train.tensorboard else None

    def report(study, trial):
        if study.user_attrs.get(f"surplus_{trial.number}"):
            return
        bar.update(1)
        if board:
            board.add(trial)
        if progress:
            value = trial.values if trial.values is not None else trial.intermediate_values
            state = "pruned" if trial.state == optuna.trial.TrialState.PRUNED else trial.state.name.lower()
            if "error" in trial.user_attrs:
                state = f"failed ({trial.user_attrs['error']})"
            shown = (", ".join(f"{v:.4f}" for v in value) if isinstance(value, list)
                     else f"{min(value.values()):.4f} after {len(value)} epoch(s)" if value else "-")
            bar.write(f"trial {trial.number}: {state}, {shown}; "
                      + ", ".join(f"{k}={short(v)}" for k, v in trial.params.items()))

    # study.optimize runs Optuna's heartbeat (RDB storages) and fails stale trials of dead workers; one trial
    # at a time, so that the count can be checked between trials
    while len(study.get_trials(deepcopy=False, states=done_states)) < trials:
        surplus.clear()
        try:
            study.optimize(objective_fn, n_trials=1, catch=(_Surplus, _Failed), callbacks=[report])
        except (optuna.exceptions.UpdateFinishedTrialError, ValueError) as e:
            if isinstance(e, ValueError) and not str(e).startswith("Cannot tell a FAIL trial"):
                raise
            # our trial was failed by another worker's heartbeat check: Optuna refuses its result
            warn(f"study {name}: another worker failed this worker's trial after no heartbeat for {heartbeat()[1]} s "
                 "(this worker was stalled or cut off from the storage); the trial is retried, this worker goes on")
            continue
        if surplus and not _wait_for_others(study, trials):
            break
        if len(failures) >= trials:  # every trial of this worker failed: not a matter of parameters
            break
    bar.close()
    if board:
        board.close()
    out.mkdir(parents=True, exist_ok=True)
    with waiting_lock(out / ".reports.lock"):  # workers sharing an out folder write the reports in turn
        complete = write_reports(study, out, cfg)
    if not complete:
        raise SteerlabError(f"study {name} has no complete trial ({(out / 'summary.md').read_text().strip()}), so "
                            f"there is no best configuration; run the command again to run more trials")
    return out


class _Board:
    """With `train.tensorboard: true`: every trial's curves are in `trials/NNNN/tensorboard` (the training run's
    own log), and each finished trial's parameters and objective(s) go to TensorBoard's HParams view under
    `tensorboard/` (a pruned trial with its last epoch's value), so `tensorboard --logdir OUT` shows the study."""

    def __init__(self, out: Path, objective: str):
        from torch.utils.tensorboard import SummaryWriter

        self.writer = SummaryWriter(str(out / "tensorboard"))
        self.names = objective.split("+")

    def add(self, trial) -> None:
        values = trial.values or list(trial.intermediate_values.values())[-1:]
        if not values:  # failed before its first epoch
            return
        self.writer.add_hparams(dict(trial.params), {f"objective/{n}": v for n, v in zip(self.names, values)},
                                run_name=f"{trial.number:04d}")
        self.writer.flush()

    def close(self) -> None:
        self.writer.close()


class _Failed(Exception):
    """A trial whose training failed with a SteerlabError (said in its report line)."""


class _Surplus(Exception):
    """A trial beyond the study's total: marked failed, left out of every report."""


def _suggest(trial, key: str, dist):
    optuna = storage_optuna()
    if isinstance(dist, optuna.distributions.CategoricalDistribution):
        return trial.suggest_categorical(key, dist.choices)
    if isinstance(dist, optuna.distributions.IntDistribution):
        return trial.suggest_int(key, dist.low, dist.high, log=dist.log)
    return trial.suggest_float(key, dist.low, dist.high, log=dist.log)


def _ahead(study, number: int) -> int:
    """Trials numbered below `number` that are finished, running or queued (a dead worker's trial, re-queued by
    the heartbeat check): everything but failed ones (a crash, a killed worker, a surplus trial), which do not
    count against the total."""
    import optuna

    return sum(1 for t in study.get_trials(deepcopy=False)
               if t.number < number and t.state != optuna.trial.TrialState.FAIL)


def _wait_for_others(study, trials: int) -> bool:
    """This worker found the study's last trials started by others. With heartbeats (RDB storages), wait while
    they run: a trial whose worker dies meanwhile is failed after the grace period and queued again (Optuna's
    retry callback), and then this worker runs it. True: run another trial; False: the study is done, or
    nothing is watched (a journal: no heartbeats, so this worker stops here)."""
    import time

    import optuna
    from optuna.trial import TrialState

    interval = getattr(study._storage, "get_heartbeat_interval", lambda: None)()  # RDB storages only
    if not interval:
        return False
    interval = min(interval, 5)
    while True:
        with warnings.catch_warnings():  # experimental in Optuna
            warnings.simplefilter("ignore")
            optuna.storages.fail_stale_trials(study)
        states = [t.state for t in study.get_trials(deepcopy=False)]
        if sum(s in (TrialState.COMPLETE, TrialState.PRUNED) for s in states) >= trials:
            return False
        if TrialState.WAITING in states or TrialState.RUNNING not in states:
            return True  # a queued trial, or room for a new one (another worker's trial failed)
        time.sleep(interval)
