"""Hyperparameter tuning as in paper 000 V-A (`steerlab tune`): BOHB-style search with Optuna.

The search space is the `tune:` section of an ordinary training config: config keys (`train.lr`,
`model.dropout`, `preprocess.color`, ...) mapped to ranges,

    tune:
      train.lr: {low: 1.0e-6, high: 1.0e-3, log: true}     # float
      train.batch_size: {low: 4, high: 10, type: int}
      preprocess.color: [gray, yuv]                        # categorical

Optuna's multivariate TPE sampler proposes configurations and its Hyperband pruner stops unpromising trials
early, with epochs as the budget: each epoch reports the validation RMSE (together: BOHB's idea, Falkner et
al. 2018, on Optuna's parts). Objectives: validation RMSE (default), RMSE and gamma (multi-objective, Pareto
front; Optuna cannot prune multi-objective trials, so those run to completion), or the closed-loop autonomy of
the best epoch on the synthetic-world suite (the config's `closed_loop: {suite, minutes, workers}` section;
default: suite v1, 3 minutes per road). The study lives in an Optuna storage (a journal file in the output
folder by default, or `--storage URL`) that any number of workers on any number of machines can share.

Outputs in the output folder: `trials.csv`, `summary.md` (trial states, what pruning saved), `best.yaml` (a
training config `steerlab train` runs as it is), `importance.md` (fANOVA, percent), `importance.png` (predicted
validation error vs each parameter, best value marked, paper 000 Fig. 4), `history.png`, one training run per
trial under `trials/`.
"""

from __future__ import annotations

import contextlib
import copy
import csv
import inspect
import json
import math
import os
import warnings
from dataclasses import fields
from pathlib import Path

import numpy as np
import yaml
from tqdm import tqdm

from matplotlib.ticker import FuncFormatter, LogLocator, MaxNLocator, NullFormatter

from steerlab.data.preprocess import PreprocessConfig
from steerlab.errors import SteerlabError, warn
from steerlab.figures import figure
from steerlab.train.config import DEFAULTS, load_config

OBJECTIVES = {"rmse": ["minimize"], "rmse+gamma": ["minimize", "minimize"], "autonomy": ["maximize"]}
# seconds: a worker's heartbeat interval, and the silence after which its trial is failed and retried (RDB
# storages). The environment variable STEERLAB_TUNE_HEARTBEAT="INTERVAL,GRACE" (whole seconds) replaces it, e.g. "1,3"
# in the tests, so that a killed worker's trial is retried within seconds.
HEARTBEAT = (30, 90)
CONNECT_TIMEOUT = 10  # seconds to wait for a PostgreSQL or MySQL server (a URL's own connect_timeout= wins)


def _optuna():
    try:
        import optuna
    except ImportError:
        raise SteerlabError("steerlab tune needs optuna and scikit-learn: pip install optuna scikit-learn") from None
    optuna.logging.set_verbosity(optuna.logging.ERROR)  # steerlab reports trials itself
    return optuna


def _known(key: str, cfg: dict) -> bool:
    """Whether `key` (section.option) is something a training config can set."""
    section, _, option = key.partition(".")
    if section == "train":
        return option in DEFAULTS["train"]
    if section == "preprocess":
        return option in {f.name for f in fields(PreprocessConfig)} | {"preset"}
    if section == "model":
        from steerlab.models import model_class

        names = set()
        for cls in model_class(cfg["model"]["name"]).__mro__:  # follow **kw up to the base class
            params = inspect.signature(cls.__init__).parameters
            names |= {n for n, p in params.items() if p.kind != p.VAR_KEYWORD}
            if not any(p.kind == p.VAR_KEYWORD for p in params.values()):
                break
        return option in names - {"self", "in_channels", "height", "width"}
    return not option and section in DEFAULTS and section not in ("tune", "data", "out", "cache")


def search_space(spec: dict, cfg: dict) -> dict:
    """The `tune:` section as Optuna distributions, with a one-line error for anything wrong."""
    optuna = _optuna()
    if not isinstance(spec, dict) or not spec:
        raise SteerlabError("the config has no tune: section (config key -> range) to search")
    space = {}
    for key, rng in spec.items():
        if not _known(key, cfg):
            raise SteerlabError(f"tune: {key!r} is not a config key of this config (use section.option, e.g. "
                                f"train.lr, model.dropout, preprocess.color)")
        if isinstance(rng, list):
            if len(rng) < 2:
                raise SteerlabError(f"tune: {key} needs at least two choices, got {rng}")
            space[key] = optuna.distributions.CategoricalDistribution(rng)
            continue
        if not isinstance(rng, dict) or "low" not in rng or "high" not in rng:
            raise SteerlabError(f"tune: {key} needs {{low: .., high: ..}} or a list of choices, got {rng!r}")
        kind = rng.get("type", "int" if isinstance(rng["low"], int) and isinstance(rng["high"], int) else "float")
        low, high, log = rng["low"], rng["high"], bool(rng.get("log", False))
        try:
            low, high = (int(low), int(high)) if kind == "int" else (float(low), float(high))
        except (TypeError, ValueError):
            raise SteerlabError(f"tune: {key} low/high must be numbers, got {rng['low']!r}/{rng['high']!r}") from None
        if kind not in ("int", "float"):
            raise SteerlabError(f"tune: {key} type must be int or float (lists are categorical), got {kind!r}")
        if not low < high:
            raise SteerlabError(f"tune: {key} range {low}..{high} is empty or inverted (low must be below high)")
        if log and low <= 0:
            raise SteerlabError(f"tune: {key} has a log range, so low must be positive, got {low}")
        dist = optuna.distributions.IntDistribution if kind == "int" else optuna.distributions.FloatDistribution
        space[key] = dist(low, high, log=log)
    return space


def with_params(cfg: dict, params: dict) -> dict:
    out = copy.deepcopy(cfg)
    for key, value in params.items():
        section, _, option = key.partition(".")
        if option:
            out.setdefault(section, {})[option] = value
        else:
            out[section] = value
    return out


def heartbeat() -> tuple[int, int]:
    """(interval, grace period) in seconds: HEARTBEAT, or STEERLAB_TUNE_HEARTBEAT="INTERVAL,GRACE"."""
    text = os.environ.get("STEERLAB_TUNE_HEARTBEAT", "").strip()
    if not text:
        return HEARTBEAT
    try:
        interval, grace = (int(x) for x in text.split(","))
    except ValueError:
        interval = grace = 0
    if not 0 < interval < grace:
        raise SteerlabError(f"STEERLAB_TUNE_HEARTBEAT={text!r}: expected INTERVAL,GRACE in whole seconds with "
                            "0 < INTERVAL < GRACE, e.g. 30,90")
    return interval, grace


def shown_url(url: str) -> str:
    """The storage URL as messages show it: without its password."""
    try:
        from sqlalchemy.engine import make_url

        return make_url(url).render_as_string(hide_password=True)
    except Exception:  # noqa: BLE001 - not a URL SQLAlchemy can parse: keep only what precedes the host
        scheme, sep, rest = url.partition("://")
        return f"{scheme}{sep}***@{rest.rpartition('@')[2]}" if "@" in rest else url


def storage_of(url: str | None, out: Path, join: bool = False):
    """An Optuna storage: a journal file (default `<out>/study.journal`, or a path / journal:PATH), or an RDB URL
    (sqlite:///, postgresql://, mysql://) with heartbeats, so a killed worker's trial is failed and retried.
    `postgresql://` uses the psycopg (3) driver; connecting gives up after CONNECT_TIMEOUT seconds. `join`: the
    storage must exist (a journal or SQLite file is not created)."""
    _optuna()
    from optuna.storages import JournalStorage, RDBStorage, RetryHeartbeatStaleTrialCallback
    from optuna.storages.journal import JournalFileBackend

    url = url or str(out / "study.journal")
    scheme = url.split(":", 1)[0]
    local = url[len("sqlite:///"):] if scheme == "sqlite" else None if "://" in url else url.removeprefix("journal:")
    if join and local is not None and not Path(local).is_file():
        raise SteerlabError(f"{local}: no such file, so no study to join; check --storage, or start the study "
                            "without --join")
    if scheme.split("+", 1)[0] in ("sqlite", "postgresql", "mysql"):  # postgresql+psycopg2://...
        interval, grace = heartbeat()
        engine = url
        if scheme == "postgresql":  # the driver requirements.txt installs, whatever SQLAlchemy's default
            engine = "postgresql+psycopg" + url[len(scheme):]
        kwargs = {}
        if scheme != "sqlite" and "connect_timeout=" not in url:
            kwargs["connect_args"] = {"connect_timeout": CONNECT_TIMEOUT}
        try:
            with warnings.catch_warnings(), _schema_lock(engine, kwargs):  # heartbeats: experimental in Optuna
                warnings.simplefilter("ignore")
                return RDBStorage(engine, engine_kwargs=kwargs, heartbeat_interval=interval, grace_period=grace,
                                  heartbeat_stale_trial_callback=RetryHeartbeatStaleTrialCallback(max_retry=2))
        except ModuleNotFoundError as e:
            raise SteerlabError(f"cannot open storage {shown_url(url)}: its database driver is not installed "
                                f"(no module {e.name!r}; for PostgreSQL: pip install 'psycopg[binary]')") from None
        except Exception as e:  # noqa: BLE001 - SQLAlchemy raises many types for a bad URL or server
            raise SteerlabError(f"cannot open storage {shown_url(url)}: {_first_line(e)}") from None
    path = url.removeprefix("journal:")
    if "://" in path or not path.endswith((".journal", ".log")):
        raise SteerlabError(f"unknown storage {url!r}: use a journal file (*.journal, *.log, journal:PATH) or "
                            "an RDB URL (sqlite:///study.db, postgresql://user:pass@host/db)")
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        _check_journal_access(path)
        _repair_journal(path)
        return JournalStorage(JournalFileBackend(str(path)))
    except ValueError as e:  # Optuna's reader: a damaged line before the last one
        raise SteerlabError(f"{path}: a line before the last one is damaged ({e.__class__.__name__}); only a torn "
                            "last line can be skipped") from None
    except PermissionError as e:
        raise SteerlabError(f"{e.filename or path}: permission denied (the study's journal needs to be readable "
                            "and writable, with its folder writable for the lock file)") from None


@contextlib.contextmanager
def _schema_lock(url: str, kwargs: dict):
    """On PostgreSQL, one worker at a time opens the storage: workers started together on an empty database
    would otherwise create Optuna's tables together, and all but one fail (a unique violation in PostgreSQL's
    catalog). A session-level advisory lock, released when its connection closes, also if the worker dies."""
    if not url.startswith("postgresql"):
        yield
        return
    import sqlalchemy

    engine = sqlalchemy.create_engine(url, poolclass=sqlalchemy.pool.NullPool, **kwargs)
    try:
        with engine.connect() as conn:
            conn.execute(sqlalchemy.text("SELECT pg_advisory_lock(7355608)"))  # any fixed key: steerlab's
            try:
                yield
            finally:
                conn.execute(sqlalchemy.text("SELECT pg_advisory_unlock(7355608)"))
    finally:
        engine.dispose()


def _first_line(e: Exception) -> str:
    """An exception as one line: a database driver's message without SQLAlchemy's wrapping and links."""
    orig = getattr(e, "orig", None) or e  # sqlalchemy.exc.DBAPIError wraps the driver's exception
    lines = [line.strip() for line in str(orig).splitlines() if line.strip()]
    text = "; ".join(lines[:2]) if lines else ""
    return f"{orig.__class__.__name__}: {text}" if text else orig.__class__.__name__


def _check_journal_access(path: Path) -> None:
    """A journal that this worker cannot write (or whose folder cannot take Optuna's lock file) is refused
    before anything runs, naming the file."""
    if path.is_dir():
        raise SteerlabError(f"{path}: a folder, not a journal file")
    if path.exists() and not os.access(path, os.R_OK | os.W_OK):
        raise SteerlabError(f"{path}: the journal file is not writable (permission denied); the study needs "
                            "to append to it: make it writable or choose another --storage")
    if not os.access(path.parent, os.W_OK | os.X_OK):
        raise SteerlabError(f"{path.parent}: the journal's folder is not writable (permission denied); the "
                            f"study needs it for {path.name} and its lock file")


def _repair_journal(path: Path) -> None:
    """A worker killed while appending leaves a torn last line, after which Optuna can never read the journal
    again. Skip it: with a warning naming the file, its bytes move to `<journal>.torn` (appended, so nothing
    is ever lost) and the journal ends after its last whole line. A last line that is whole JSON without its
    line end gets the line end. Done under Optuna's own journal lock, so no worker is writing meanwhile."""
    from optuna.storages.journal import JournalFileSymlinkLock

    if not path.is_file() or path.stat().st_size == 0:
        return
    lock = JournalFileSymlinkLock(str(path))
    lock.acquire()
    try:
        with open(path, "rb+") as f:
            size = end = f.seek(0, os.SEEK_END)
            tail = b""
            while True:  # read back to the line end before the last line
                start = max(0, end - (1 << 16))
                f.seek(start)
                tail = f.read(end - start) + tail
                end = start
                cut = tail.rfind(b"\n", 0, len(tail) - 1)
                if cut >= 0 or start == 0:
                    break
            last = tail[cut + 1:]
            try:
                whole = isinstance(json.loads(last), dict)
            except ValueError:  # not JSON, NUL bytes, half a UTF-8 character
                whole = False
            if whole:
                if not last.endswith(b"\n"):
                    f.seek(0, os.SEEK_END)
                    f.write(b"\n")
                return
            with open(path.with_name(path.name + ".torn"), "ab") as backup:
                backup.write(last)
            f.truncate(size - len(last))
        warn(f"{path}: its last line is torn ({len(last)} bytes that are not a whole JSON record, left by a "
             f"worker that stopped while writing); skipped it and kept its bytes in {path.name}.torn")
    finally:
        lock.release()


def _load_study(cfg_text: dict, objective: str, storage, name: str, seed: int, epochs: int,
                pruning: int | None, join: bool = False, url: str | None = None):
    """Create the study, or join it if it exists with the same search space and objective (`join`: it must)."""
    optuna = _optuna()
    signature = json.dumps({"tune": cfg_text["tune"], "objective": objective, "pruning": pruning}, sort_keys=True)
    try:
        existing = optuna.load_study(study_name=name, storage=storage)
    except KeyError:
        existing = None
    if existing is None and join:
        names = [repr(n) for n in optuna.get_all_study_names(storage)]
        there = ", ".join(names[:10]) + (", ..." if len(names) > 10 else "") if names else "none"
        raise SteerlabError(f"study {name!r} does not exist in {shown_url(url) if url else 'the storage'} (studies "
                            f"there: {there}); check --study and --storage, or start the study without --join")
    # studies created before the reduction factor was an option stored "prune": true (factor 3) or false
    older = json.dumps({"tune": cfg_text["tune"], "objective": objective, "prune": pruning is not None},
                       sort_keys=True) if pruning in (None, 3) else None
    if existing is not None and existing.user_attrs.get("signature") not in (None, signature, older):
        raise SteerlabError(f"study {name!r} exists in this storage with a different search space, objective or "
                            "pruning; choose another --study name")
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
    study.set_user_attr("config", cfg_text)
    return study


def run_tune(config: str | Path, overrides: list[str] = (), trials: int = 20, objective: str = "rmse",
             storage: str | None = None, study_name: str | None = None, seed: int = 0, pruning: int | None = 3,
             progress: bool = True, join: bool = False) -> Path:
    """Run trials of the study until it has `trials` finished ones; write the reports. Returns the folder.
    `pruning`: Hyperband's reduction factor (a rung keeps the best 1/pruning of the trials; None: no pruning).
    `join`: the study must exist already (a worker joining a study that another one started: a mistyped
    study name or storage is an error rather than a new study)."""
    from steerlab.train.loop import train

    optuna = _optuna()
    if objective not in OBJECTIVES:
        raise SteerlabError(f"unknown objective {objective!r}; choose one of {', '.join(OBJECTIVES)}")
    if trials < 1:
        raise SteerlabError(f"--trials must be at least 1, got {trials}")
    if pruning is not None and pruning < 2:
        raise SteerlabError(f"--reduction-factor must be at least 2, got {pruning}")
    cfg = load_config(config, list(overrides))
    space = search_space(cfg.get("tune"), cfg)
    closed = cfg.get("closed_loop") or {}
    if objective == "autonomy":
        from steerlab.sim.bench import suite_minutes

        suite_minutes(closed.get("suite", "v1"), closed.get("minutes"), f"{config}: closed_loop: ")
    out = Path(cfg["out"])
    name = study_name or out.name
    epochs = int(cfg["train"]["epochs"])
    store = storage_of(storage, out, join)
    study = _load_study(cfg, objective, store, name, seed, epochs, pruning, join, storage or str(out / "study.journal"))
    base = {k: v for k, v in cfg.items() if k != "tune"}
    surplus = []

    def objective_fn(trial):
        if _ahead(study, trial.number) >= trials:  # other workers have started the last trials already
            study.set_user_attr(f"surplus_{trial.number}", True)
            surplus.append(trial.number)
            raise _Surplus()
        run_cfg = with_params(base, {k: _suggest(trial, k, d) for k, d in space.items()})
        run_cfg["out"] = str(out / "trials" / f"{trial.number:04d}")
        single = len(OBJECTIVES[objective]) == 1

        def on_epoch(epoch: int, m: dict) -> None:
            trial.set_user_attr("epochs_run", epoch)
            if single and objective == "rmse":
                trial.report(m["rmse"], epoch)
                if epoch < epochs and trial.should_prune():  # a trial that trained all its epochs is complete
                    raise optuna.TrialPruned()

        best = train(run_cfg, progress=False, on_epoch=on_epoch)
        trial.set_user_attr("best_epoch", best.get("epoch"))
        if objective == "rmse":
            return best["rmse"]
        if objective == "rmse+gamma":
            return best["rmse"], best["gamma_deg"]
        from steerlab.sim.bench import closed_loop_metrics

        # a trial's suite keeps its tables; road figures for every trial of a study would go unseen
        return closed_loop_metrics(Path(run_cfg["out"]) / "best.pt", closed, False, plots=False)["autonomy"]

    done_states = (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.PRUNED)
    finished = len(study.get_trials(deepcopy=False, states=done_states))
    bar = tqdm(total=trials, initial=min(finished, trials), desc=f"study {name}", unit="trial",
               disable=not progress or None)

    board = _Board(out, objective) if cfg["train"]["tensorboard"] else None

    def report(study, trial):
        if study.user_attrs.get(f"surplus_{trial.number}"):
            return
        bar.update(1)
        if board:
            board.add(trial)
        if progress:
            value = trial.values if trial.values is not None else trial.intermediate_values
            state = "pruned" if trial.state == optuna.trial.TrialState.PRUNED else trial.state.name.lower()
            shown = (", ".join(f"{v:.4f}" for v in value) if isinstance(value, list)
                     else f"{min(value.values()):.4f} after {len(value)} epoch(s)" if value else "-")
            bar.write(f"trial {trial.number}: {state}, {shown}; "
                      + ", ".join(f"{k}={_short(v)}" for k, v in trial.params.items()))

    # study.optimize runs Optuna's heartbeat (RDB storages) and fails stale trials of dead workers; one trial
    # at a time, so that the count can be checked between trials
    while len(study.get_trials(deepcopy=False, states=done_states)) < trials:
        surplus.clear()
        try:
            study.optimize(objective_fn, n_trials=1, catch=(_Surplus,), callbacks=[report])
        except (optuna.exceptions.UpdateFinishedTrialError, ValueError) as e:
            if isinstance(e, ValueError) and not str(e).startswith("Cannot tell a FAIL trial"):
                raise
            # our trial was failed by another worker's heartbeat check: Optuna refuses its result
            warn(f"study {name}: another worker failed this worker's trial after no heartbeat for {heartbeat()[1]} s "
                 "(this worker was stalled or cut off from the storage); the trial is retried, this worker goes on")
            continue
        if surplus and not _wait_for_others(study, trials):
            break
    bar.close()
    if board:
        board.close()
    from steerlab.locks import waiting_lock

    out.mkdir(parents=True, exist_ok=True)
    with waiting_lock(out / ".reports.lock"):  # workers sharing an out folder write the reports in turn
        write_reports(study, out, base)
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


class _Surplus(Exception):
    """A trial beyond the study's total: marked failed, left out of every report."""


def _suggest(trial, key: str, dist):
    import optuna

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


def _short(v) -> str:
    return f"{v:.3g}" if isinstance(v, float) else str(v)


def write_reports(study, out: Path, base: dict) -> None:
    """trials.csv, summary.md (trial states; epochs trained against the finished trials' full budget),
    best.yaml, and for single-objective studies importance.md/.png and history.png; for rmse+gamma the Pareto
    front (pareto.md, pareto.png)."""
    import optuna
    from optuna.trial import TrialState

    out.mkdir(parents=True, exist_ok=True)
    trials = [t for t in study.get_trials(deepcopy=False) if not study.user_attrs.get(f"surplus_{t.number}")]
    params = sorted({k for t in trials for k in t.params})
    with open(out / "trials.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["number", "state", *[f"value_{i}" for i in range(len(study.directions))], "epochs_run",
                    "best_epoch", "seconds", *params])
        for t in trials:
            values = t.values or [min(t.intermediate_values.values()) if t.intermediate_values else ""] * len(
                study.directions)
            seconds = (t.datetime_complete - t.datetime_start).total_seconds() if t.datetime_complete else ""
            w.writerow([t.number, t.state.name.lower(), *values, t.user_attrs.get("epochs_run", ""),
                        t.user_attrs.get("best_epoch", ""), seconds, *[t.params.get(k, "") for k in params]])
    complete = [t for t in trials if t.state == TrialState.COMPLETE]
    finished = [t for t in trials if t.state in (TrialState.COMPLETE, TrialState.PRUNED)]
    trained = sum(t.user_attrs.get("epochs_run", 0) for t in finished)
    full = len(finished) * int(base["train"]["epochs"])
    (out / "summary.md").write_text(
        f"{len(trials)} trials: {len(complete)} complete, {len(finished) - len(complete)} pruned, "
        f"{len(trials) - len(finished)} failed or running. The finished trials trained {trained} epochs; run to "
        f"their last epoch they would have trained {full}" + (f" ({full / trained:.2f}x)" if trained else "") + ".\n")
    if not complete:
        return
    if len(study.directions) > 1:
        front = study.best_trials
        lines = ["| trial | validation RMSE | gamma [deg] | " + " | ".join(params) + " |",
                 "|---" * (3 + len(params)) + "|"]
        lines += [f"| {t.number} | {t.values[0]:.4f} | {t.values[1]:.3f} | "
                  + " | ".join(_short(t.params.get(k, "")) for k in params) + " |" for t in front]
        (out / "pareto.md").write_text("Pareto front (validation RMSE vs gamma):\n\n" + "\n".join(lines) + "\n")
        _plot_pareto(out / "pareto.png", complete, front)
        best = min(front, key=lambda t: t.values[0])
    else:
        best = study.best_trial
        _plot_history(out / "history.png", trials, study.directions[0] == optuna.study.StudyDirection.MINIMIZE)
        varied = len({t.values[0] for t in complete}) > 1 and len({repr(t.params) for t in complete}) > 1
        if varied and params:  # fANOVA needs trials that differ (a rerun with the same --seed repeats them)
            importance = optuna.importance.get_param_importances(
                study, evaluator=optuna.importance.FanovaImportanceEvaluator(seed=0), normalize=True)
            total = sum(importance.values()) or 1.0
            rows = [f"| {k} | {100 * v / total:.1f} |" for k, v in importance.items()]
            (out / "importance.md").write_text(
                f"fANOVA importance over {len(complete)} completed trials (percent of the explained variance "
                "of the objective):\n\n| hyperparameter | importance [%] |\n|---|---|\n" + "\n".join(rows) + "\n")
            _plot_marginals(out / "importance.png", study, complete, best)
    best_cfg = with_params(base, best.params)
    best_cfg["out"] = str(out / "best")
    (out / "best.yaml").write_text(
        f"# best trial {best.number} of study {study.study_name}: {', '.join(f'{v:.5g}' for v in best.values)}\n"
        + yaml.safe_dump(json.loads(json.dumps(best_cfg)), sort_keys=False))


def _encode(dist, value) -> float:
    import optuna

    if isinstance(dist, optuna.distributions.CategoricalDistribution):
        return float(dist.choices.index(value))
    return math.log(value) if dist.log else float(value)


def _plot_marginals(path: Path, study, complete: list, best) -> None:
    """Paper 000 Fig. 4: the objective a random forest fitted to the trials predicts for each value of one
    hyperparameter, averaged over the other hyperparameters of the trials (partial dependence); dots are the
    trials, the dashed line the best trial's value."""
    import optuna
    from sklearn.ensemble import RandomForestRegressor

    dists = {k: d for t in complete for k, d in t.distributions.items()}
    names = sorted(dists)
    x = np.array([[_encode(dists[k], t.params[k]) for k in names] for t in complete])
    y = np.array([t.values[0] for t in complete])
    forest = RandomForestRegressor(n_estimators=64, min_samples_leaf=1, random_state=0).fit(x, y)
    with figure(path, 1, len(names), figsize=(3.6 * len(names), 3.2), squeeze=False, dpi=110) as (fig, axes):
        for j, (k, ax) in enumerate(zip(names, axes[0])):
            d = dists[k]
            categorical = isinstance(d, optuna.distributions.CategoricalDistribution)
            grid = (np.arange(len(d.choices), dtype=float) if categorical
                    else np.linspace(_encode(d, d.low), _encode(d, d.high), 40))
            pd_ = []
            for g in grid:
                xg = x.copy()
                xg[:, j] = g
                pd_.append(forest.predict(xg).mean())
            shown = grid if categorical or not d.log else np.exp(grid)
            ax.plot(shown, pd_, color="tab:blue", lw=2, label="predicted",  # no line between unordered choices
                    **({"ls": "", "marker": "_", "ms": 24, "mew": 2} if categorical else {}))
            ax.scatter(x[:, j] if categorical or not d.log else np.exp(x[:, j]), y, s=12, color="gray", label="trials")
            b = _encode(d, best.params[k])
            ax.axvline(b if categorical or not d.log else math.exp(b), color="tab:red", ls="--", label="best")
            if categorical:
                ax.set_xticks(grid, [str(c) for c in d.choices])
                ax.set_xlim(-0.5, len(d.choices) - 0.5)
            elif d.log:
                ax.set_xscale("log")
                ax.xaxis.set_minor_formatter(NullFormatter())
                if d.high / d.low < 30:  # a decade or so: label 1, 2 and 5 of it, not overlapping minor ticks
                    ax.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
                    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
            ax.set_xlabel(k)
            ax.set_ylabel("validation error" if j == 0 else "")
        axes[0][0].legend(fontsize=7)


def _plot_history(path: Path, trials: list, minimize: bool) -> None:
    from optuna.trial import TrialState

    with figure(path, figsize=(6.5, 3.5), dpi=110) as (fig, ax):
        done = [t for t in trials if t.state == TrialState.COMPLETE]
        pruned = [t for t in trials if t.state == TrialState.PRUNED and t.intermediate_values]
        ax.scatter([t.number for t in done], [t.values[0] for t in done], s=18, label="complete")
        ax.scatter([t.number for t in pruned], [list(t.intermediate_values.values())[-1] for t in pruned], marker="x",
                   color="gray", s=18, label="pruned (last epoch)")
        if done:
            pick = np.minimum.accumulate if minimize else np.maximum.accumulate
            order = sorted(done, key=lambda t: t.number)
            ax.step([t.number for t in order], pick([t.values[0] for t in order]), where="post", color="tab:red",
                    label="best so far")
        ax.set_xlabel("trial")
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        ax.set_ylabel("objective")
        ax.legend(fontsize=8)


def _plot_pareto(path: Path, complete: list, front: list) -> None:
    with figure(path, figsize=(5, 4), dpi=110) as (fig, ax):
        ax.scatter([t.values[0] for t in complete], [t.values[1] for t in complete], s=14, color="gray", label="trials")
        front = sorted(front, key=lambda t: t.values[0])
        ax.plot([t.values[0] for t in front], [t.values[1] for t in front], "o-", color="tab:red", label="Pareto front")
        ax.set_xlabel("validation RMSE")
        ax.set_ylabel("gamma [deg]")
        ax.legend(fontsize=8)
