"""steerlab tune: BOHB-style search with Optuna, shared studies, reports; bad input."""

import csv
import subprocess
import sys

import pytest
import yaml

from conftest import CliProcess, drawn_pixels, image_of, legend_of
from steerlab.errors import SteerlabError
from steerlab.train.config import load_config
from tests.tune.tuning import ONE_THREAD, Hold, rows, run_tune, tune_config


@pytest.mark.figures
def test_small_study_prunes_and_writes_a_runnable_best_config(tmp_path, tiny_recording):
    out = tmp_path / "study"
    # trials far enough apart for Hyperband to stop one: validated on the recording's last frames, which the
    # trials, trained on its first 120, tell apart (after one epoch 0.13 for the trial pruned, 0.06 for the first)
    run_tune(tune_config(tmp_path, tiny_recording, out, split=("0:120", "240:300")), trials=4, seed=0, progress=False)
    trials = rows(out)
    assert len(trials) == 4 and {t["state"] for t in trials} <= {"complete", "pruned"}
    assert any(t["state"] == "pruned" for t in trials)  # Hyperband stopped an unpromising trial early
    assert sum(int(t["epochs_run"]) for t in trials) < 4 * 3
    assert all(t["state"] == "complete" for t in trials if int(t["epochs_run"]) == 3)  # nothing left to save
    summary = (out / "summary.md").read_text()
    trained = sum(int(t["epochs_run"]) for t in trials)
    assert f"trained {trained} epochs" in summary and f"would have trained {4 * 3} ({12 / trained:.2f}x)" in summary
    best = load_config(out / "best.yaml")  # a training config steerlab train runs as it is
    complete = [t for t in trials if t["state"] == "complete"]
    winner = min(complete, key=lambda t: float(t["value_0"]))
    assert best.train.lr == pytest.approx(float(winner["train.lr"]))
    assert best.model.options["dropout"] == pytest.approx(float(winner["model.dropout"]))
    assert best.tune is None
    if len(complete) >= 2:  # too few trials for fANOVA: said, no numbers
        assert (out / "importance.md").read_text().startswith(f"fANOVA importance: {len(complete)} completed trials")
        assert not (out / "importance.png").exists() and image_of(out / "slice.png").shape[:2] == (528, 704)
    assert image_of(out / "history.png").shape[:2] == (440, 715)  # what they draw: the test below


def test_importance_names_the_parameter_the_objective_depends_on(tmp_path, tiny_recording, saved_figures):
    """Twelve completed trials whose objective depends on the learning rate only: fANOVA gives it most of the
    explained variance (89 %: twelve points are few for a forest); with nine the report says they are too few."""
    import numpy as np
    import optuna

    from steerlab.tune.report import IMPORTANCE_TRIALS, write_reports

    cfg = load_config(tune_config(tmp_path, tiny_recording, tmp_path / "x"))
    space = {"train.lr": optuna.distributions.FloatDistribution(1e-5, 0.1, log=True),
             "model.dropout": optuna.distributions.FloatDistribution(0.0, 0.6)}
    rng = np.random.default_rng(0)
    study = optuna.create_study()
    for k in range(12):
        lr, dropout = 10 ** rng.uniform(-5, -1), rng.uniform(0, 0.6)
        study.add_trial(optuna.trial.create_trial(params={"train.lr": lr, "model.dropout": dropout},
                                                  distributions=space, value=float(np.log10(lr)),
                                                  user_attrs={"epochs_run": 3}))
        if k + 1 == IMPORTANCE_TRIALS - 1:
            assert write_reports(study, tmp_path / "nine", cfg)
    assert "it takes at least 10" in (tmp_path / "nine" / "importance.md").read_text()
    assert write_reports(study, tmp_path / "twelve", cfg)
    table = (tmp_path / "twelve" / "importance.md").read_text()
    shares = {line.split("|")[1].strip(): float(line.split("|")[2]) for line in table.splitlines()
              if line.startswith("| ") and "hyperparameter" not in line and "---" not in line}
    assert table.startswith("fANOVA importance over 12 completed trials")
    assert shares["train.lr"] > 80 and sum(shares.values()) == pytest.approx(100.0, abs=0.15)
    # the plots, 6.5 x 4 inches at 110 dpi: the twelve objective values and the best so far, drawn and named in the
    # legend; a bar per parameter as long as its share of importance.md; the slice, a point per trial per parameter
    folder, values = tmp_path / "twelve", [t.value for t in study.trials]
    img = image_of(folder / "history.png")
    assert img.shape[:2] == (440, 715)
    history = saved_figures[str(folder / "history.png")].axes[0]
    assert legend_of(history) == ["Objective Value", "Best Value"]
    points, best = history.collections[0], history.get_lines()[0]
    np.testing.assert_allclose(points.get_offsets()[:, 1], values)
    np.testing.assert_allclose(best.get_ydata(), np.minimum.accumulate(values))
    assert drawn_pixels(img, history, points.get_facecolor()[0]) > 100
    assert drawn_pixels(img, history, best.get_color()) > 100
    img = image_of(folder / "importance.png")
    assert img.shape[:2] == (440, 715)
    bars = saved_figures[str(folder / "importance.png")].axes[0]
    assert sorted(100 * p.get_width() for p in bars.patches) == pytest.approx(sorted(shares.values()), abs=0.06)
    assert drawn_pixels(img, bars, bars.patches[0].get_facecolor()) > 1000
    assert image_of(folder / "slice.png").shape[:2] == (528, 704)
    panels = [ax for ax in saved_figures[str(folder / "slice.png")].axes if ax.get_label() != "<colorbar>"]
    assert [ax.get_xlabel() for ax in panels] == ["model.dropout", "train.lr"]
    for ax in panels:
        np.testing.assert_allclose(ax.collections[0].get_offsets()[:, 1], values)


def test_reports_leave_out_surplus_trials_and_trials_not_yet_claimed(tmp_path, tiny_recording):
    """A worker's reports, written while another worker has just created a trial (RUNNING, no "worker" yet: it may
    still turn out to be surplus), list the study's own trials only; once claimed, the trial is listed as running."""
    import optuna

    from steerlab.tune.report import write_reports

    cfg = load_config(tune_config(tmp_path, tiny_recording, tmp_path / "x"))
    space = {"train.lr": optuna.distributions.FloatDistribution(1e-5, 0.1, log=True)}
    study = optuna.create_study()
    study.add_trial(optuna.trial.create_trial(params={"train.lr": 1e-3}, distributions=space, value=0.1,
                                              user_attrs={"epochs_run": 3, "worker": {"pid": 1}}))
    surplus = study.ask()
    study.set_user_attr(f"surplus_{surplus.number}", True)
    study.tell(surplus, state=optuna.trial.TrialState.FAIL)
    unclaimed = study.ask()
    assert write_reports(study, tmp_path / "a", cfg)
    assert [r["number"] for r in rows(tmp_path / "a")] == ["0"]
    unclaimed.set_user_attr("worker", {"pid": 2})
    assert write_reports(study, tmp_path / "b", cfg)
    assert [(r["number"], r["state"]) for r in rows(tmp_path / "b")] == [("0", "complete"), ("2", "running")]


def test_rerun_reproduces_the_trials(tmp_path, tiny_recording):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    for name, board in (("a", "false"), ("b", "true")):  # TensorBoard logging changes nothing
        run_tune(tune_config(tmp_path, tiny_recording, tmp_path / name, epochs=2), [f"train.tensorboard={board}"],
                 trials=3, seed=1, progress=False)
    a, b = rows(tmp_path / "a"), rows(tmp_path / "b")
    assert [(r["train.lr"], r["model.dropout"], r["state"]) for r in a] == \
           [(r["train.lr"], r["model.dropout"], r["state"]) for r in b]
    assert [float(r["value_0"]) for r in a] == pytest.approx([float(r["value_0"]) for r in b], abs=1e-6)
    assert not (tmp_path / "a" / "tensorboard").exists()
    for r in b:  # each trial's parameters and objective in the HParams view, its curves beside its run
        run = EventAccumulator(str(tmp_path / "b" / "tensorboard" / f"{int(r['number']):04d}")).Reload()
        assert run.Scalars("objective/rmse")[0].value == pytest.approx(float(r["value_0"]), abs=1e-6)
        assert (tmp_path / "b" / "trials" / f"{int(r['number']):04d}" / "tensorboard").is_dir()


def test_continuing_a_study_with_the_same_seed_proposes_new_configurations(tmp_path, tiny_recording):
    cfg = tune_config(tmp_path, tiny_recording, tmp_path / "c", epochs=1)
    journal = str(tmp_path / "c.journal")
    run_tune(cfg, trials=1, storage=journal, study_name="c", seed=0, progress=False)
    run_tune(cfg, trials=2, storage=journal, study_name="c", seed=0, progress=False)  # one more, same seed
    params = [(r["train.lr"], r["model.dropout"]) for r in rows(tmp_path / "c")]
    assert len(params) == 2 and len(set(params)) == 2  # still drawing at random: not the first one again


def test_two_workers_share_one_journal(tmp_path, tiny_recording):
    import optuna

    cfg = tune_config(tmp_path, tiny_recording, tmp_path / "shared", epochs=1)
    journal = tmp_path / "study.journal"
    argv = ["tune", str(cfg), "--trials", "4", "--storage", str(journal), "--study", "s"]
    workers = [CliProcess(argv + ["--seed", str(i)], tmp_path / f"worker{i}.err", ONE_THREAD) for i in range(2)]
    for w in workers:
        assert w.wait(timeout=300) == 0, w.errors()
    study = optuna.load_study(study_name="s", storage=optuna.storages.JournalStorage(
        optuna.storages.journal.JournalFileBackend(str(journal))))
    done = [t for t in study.trials if t.state in (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.PRUNED)]
    assert len(done) == 4
    assert len({(t.params["train.lr"], t.params["model.dropout"]) for t in done}) == 4
    assert len(rows(tmp_path / "shared")) == 4
    assert load_config(tmp_path / "shared" / "best.yaml").model.name == "pilotnet"


@pytest.mark.parametrize("tune, message", [
    ({"train.learning_rate": {"low": 0.1, "high": 1.0}}, "'train.learning_rate' is not a config key"),
    ({"model.hidden": {"low": 64, "high": 512}}, "'model.hidden' is not a config key"),  # pilotnet has none
    ({"train.lr": {"low": 1.0e-3, "high": 1.0e-5}}, "range 0.001..1e-05 is empty or inverted"),
    ({"train.lr": {"low": 0.0, "high": 1.0, "log": True}}, "log range, so low must be positive"),
    ({"preprocess.color": ["gray"]}, "needs at least two choices"),
])
def test_bad_search_spaces(tmp_path, tiny_recording, tune, message):
    with pytest.raises(SteerlabError, match=message):
        run_tune(tune_config(tmp_path, tiny_recording, tmp_path / "x", tune), trials=1, progress=False)
    assert not (tmp_path / "x").exists()  # nothing written


def test_bad_storage_and_changed_space(tmp_path, tiny_recording):
    cfg = tune_config(tmp_path, tiny_recording, tmp_path / "y", epochs=1)
    with pytest.raises(SteerlabError, match="unknown storage 'redis://x'"):
        run_tune(cfg, trials=1, storage="redis://x", progress=False)
    assert not (tmp_path / "y").exists()
    journal = str(tmp_path / "s.journal")
    run_tune(cfg, trials=1, storage=journal, study_name="s", progress=False)
    other = tune_config(tmp_path, tiny_recording, tmp_path / "z", {"train.lr": {"low": 1e-5, "high": 1e-3}})
    with pytest.raises(SteerlabError, match="study 's' exists in this storage with a different search space"):
        run_tune(other, trials=1, storage=journal, study_name="s", progress=False)
    assert not (tmp_path / "z").exists()
    with pytest.raises(SteerlabError, match="different search space, objective or pruning"):
        run_tune(cfg, trials=1, storage=journal, study_name="s", pruning=4, progress=False)  # workers must agree
    with pytest.raises(SteerlabError, match=r"--reduction-factor must be an integer of at least 2 \(at most "
                                            r"1000000\), got 1"):
        run_tune(tune_config(tmp_path, tiny_recording, tmp_path / "w"), trials=1, pruning=1, progress=False)
    assert not (tmp_path / "w").exists()


def test_killed_worker_trial_is_failed_and_retried(tmp_path, tiny_recording, monkeypatch):
    """Against an RDB storage (sqlite here, PostgreSQL across machines) a worker killed mid-trial has its trial
    failed by the next worker's heartbeat check and retried with the same parameters."""
    import signal
    import time
    import warnings

    import optuna

    cfg = tune_config(tmp_path, tiny_recording, tmp_path / "k", epochs=2)
    url = f"sqlite:///{tmp_path / 'study.db'}"
    storage = optuna.storages.RDBStorage(url)  # the database made before the worker opens it too
    hold = Hold(tmp_path)
    worker = CliProcess(["tune", str(cfg), "--trials", "2", "--storage", url, "--study", "s", "--no-pruning"],
                        tmp_path / "worker.err", ONE_THREAD,
                        prelude=hold.prelude + "import steerlab.tune.storage as t\nt.HEARTBEAT = (1, 2)\n")
    try:
        hold.wait(worker)  # until the first trial has finished an epoch (and holds), however busy
    finally:
        worker.send_signal(signal.SIGKILL)
        worker.wait()
    assert worker.returncode == -signal.SIGKILL, f"the worker ended before it was killed: {worker.errors()}"
    study = optuna.load_study(study_name="s", storage=storage)
    killed = study.trials[0]
    assert killed.state == optuna.trial.TrialState.RUNNING and killed.user_attrs["epochs_run"] == 1
    with warnings.catch_warnings():  # heartbeats are experimental in Optuna
        warnings.simplefilter("ignore")
        watch = optuna.storages.RDBStorage(url, heartbeat_interval=1, grace_period=2)
    deadline = time.monotonic() + 120
    while killed._trial_id not in watch._get_stale_trial_ids(study._study_id):  # silent past the grace period
        assert time.monotonic() < deadline, "the killed worker's trial never went stale"
        time.sleep(0.1)
    monkeypatch.setattr("steerlab.tune.storage.HEARTBEAT", (1, 2))
    run_tune(cfg, trials=2, storage=url, study_name="s", pruning=None, progress=False)
    trials = optuna.load_study(study_name="s", storage=storage).trials
    assert trials[0].state == optuna.trial.TrialState.FAIL
    done = [t for t in trials if t.state == optuna.trial.TrialState.COMPLETE]
    assert len(done) == 2
    assert any(t.params == killed.params for t in done)  # the killed trial was retried


def test_autonomy_objective_drives_the_suite_of_the_config(tmp_path, tiny_recording):
    cfg = tune_config(tmp_path, tiny_recording, tmp_path / "drive", epochs=1)
    text = yaml.safe_load(cfg.read_text())
    # the roads driven one after the other in this process: no worker processes to start for a second of driving;
    # two of the suite's three road types (its 3 highways and 3 twisty roads), so that "all" sums over road types
    cfg.write_text(yaml.safe_dump({**text, "closed_loop": {"suite": "v1", "minutes": 0.02, "workers": 1,
                                                           "roads": "highway,twisty"}}))
    for bad in ({"suite": "v9"}, {"minutes": -1}, {"minutes": 0}):
        broken = tmp_path / "broken.yaml"
        broken.write_text(yaml.safe_dump({**text, "out": str(tmp_path / "broken"), "closed_loop": bad}))
        with pytest.raises(SteerlabError, match=r"closed_loop.(suite must be v1, got 'v9'|minutes must be a number "
                                                r"in \(0, 1440\] min, got (-1|0))"):
            run_tune(broken, trials=1, objective="autonomy", progress=False)
        assert not (tmp_path / "broken").exists()  # nothing trained, nothing written
    run_tune(cfg, trials=2, objective="autonomy", seed=0, progress=False)
    trials = rows(tmp_path / "drive")
    assert [t["state"] for t in trials] == ["complete", "complete"]
    for t in trials:  # the trial's value is the autonomy over all roads of the suite it drove
        with open(tmp_path / "drive" / "trials" / f"{int(t['number']):04d}" / "suite" / "summary.csv") as f:
            overall = next(r for r in csv.DictReader(f) if r["road_type"] == "all")
        assert float(t["value_0"]) == pytest.approx(float(overall["autonomy"]))
        assert float(overall["minutes"]) == pytest.approx(6 * 0.02, rel=0.05)  # 6 roads, 1.2 s each
        assert not (tmp_path / "drive" / "trials" / f"{int(t['number']):04d}" / "suite" / "roads").exists()  # no figures
    best = max(trials, key=lambda t: float(t["value_0"]))  # autonomy is maximised
    assert yaml.safe_load((tmp_path / "drive" / "best.yaml").read_text().split("\n", 1)[1])["model"]["dropout"] \
        == pytest.approx(float(best["model.dropout"]))


@pytest.mark.parametrize("command", ["tune", "train", "experiment", "sim dagger"])
def test_options_and_overrides_in_any_order(command):
    from steerlab.cli import parse_args as parse

    option = {"tune": ["--trials", "3"], "train": ["--nproc", "1"], "experiment": ["--seeds", "2"],
              "sim dagger": []}[command]
    for argv in (["c.yaml", *option, "train.epochs=2", "model.dropout=0"],
                 ["c.yaml", "train.epochs=2", *option, "model.dropout=0"],
                 ["c.yaml", "train.epochs=2", "model.dropout=0", *option]):
        args = parse([*command.split(), *argv])
        assert args.config == "c.yaml" and args.overrides == ["train.epochs=2", "model.dropout=0"], argv
    with pytest.raises(SystemExit):  # what is neither an option nor an override stays an error
        parse([*command.split(), "c.yaml", *option, "--bogus"])


def test_tune_with_options_before_overrides(tmp_path, tiny_recording, capsys):
    from steerlab.cli import main

    cfg = tune_config(tmp_path, tiny_recording, tmp_path / "order", epochs=3)
    assert main(["tune", str(cfg), "--trials", "2", "--no-pruning", "train.epochs=1"]) == 0
    trials = rows(tmp_path / "order")
    assert len(trials) == 2 and {t["epochs_run"] for t in trials} == {"1"}  # the override reached the trials


def test_torn_last_journal_line_is_skipped_with_a_warning(tmp_path, tiny_recording, capsys):
    import optuna

    from steerlab.tune.storage import storage_of

    cfg = tune_config(tmp_path, tiny_recording, tmp_path / "torn", epochs=1)
    journal = tmp_path / "s.journal"
    run_tune(cfg, trials=1, storage=str(journal), progress=False)
    whole = journal.read_bytes()
    torn = b'{"op_code":4,"worker_id":"dead-worker","trial_id":1,"param_na'  # the worker died mid-write
    journal.write_bytes(whole + torn)
    capsys.readouterr()
    run_tune(cfg, trials=2, storage=str(journal), seed=1, progress=False)  # another seed: another sample
    err = capsys.readouterr().err
    assert f"{journal}: its last line is torn ({len(torn)} bytes" in err and "s.journal.torn" in err
    assert (tmp_path / "s.journal.torn").read_bytes() == torn  # the removed bytes are kept
    assert journal.read_bytes().startswith(whole)  # no whole line lost
    assert [t["state"] for t in rows(tmp_path / "torn")] == ["complete", "complete"]
    storage = storage_of(str(journal), tmp_path / "torn")  # it opens again (as every worker does), without a word
    assert "torn" not in capsys.readouterr().err
    assert [t.state.name for t in optuna.load_study(study_name="torn", storage=storage).trials] == ["COMPLETE"] * 2


def test_journal_repair_keeps_every_whole_line(tmp_path, capsys):
    from steerlab.tune.storage import _repair_journal

    journal = tmp_path / "s.journal"
    lines = b'{"op_code":0,"worker_id":"a"}\n{"op_code":1,"worker_id":"a"}\n'
    for tail, kept, removed in [(b"", lines, None),                          # nothing to do
                                (b'{"op_code":2}', lines + b'{"op_code":2}\n', None),  # whole, line end lost
                                (b"\0" * 40 + b"\n", lines, b"\0" * 40 + b"\n"),  # NUL bytes of a lost write
                                (b'{"op_code":2,"x":"\xc3', lines, b'{"op_code":2,"x":"\xc3')]:  # half a character
        journal.write_bytes(lines + tail)
        (tmp_path / "s.journal.torn").unlink(missing_ok=True)
        _repair_journal(journal)
        assert journal.read_bytes() == kept
        assert (tmp_path / "s.journal.torn").exists() == (removed is not None)
        if removed:
            assert (tmp_path / "s.journal.torn").read_bytes() == removed
            assert "its last line is torn" in capsys.readouterr().err
    assert not list(tmp_path.glob("*.lock"))  # Optuna's journal lock is released


def test_a_trial_left_running_by_a_dead_worker_on_a_journal_is_retried(tmp_path, tiny_recording, capsys):
    """A worker killed mid-trial on a journal (no heartbeat) leaves its trial running; the next worker of the same
    machine sees that its process is gone, fails it and runs it again with the same parameters."""
    import socket

    import optuna

    from steerlab.tune.storage import storage_of

    cfg = tune_config(tmp_path, tiny_recording, tmp_path / "j", epochs=1)
    journal = tmp_path / "j.journal"
    run_tune(cfg, trials=1, storage=str(journal), study_name="j", seed=0)
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    study = optuna.load_study(study_name="j", storage=storage_of(str(journal), tmp_path))
    killed = study.ask({"train.lr": optuna.distributions.FloatDistribution(1e-5, 0.1, log=True),
                        "model.dropout": optuna.distributions.FloatDistribution(0.0, 0.6)})
    killed.set_user_attr("worker", {"host": socket.gethostname(), "pid": dead.pid})
    capsys.readouterr()
    run_tune(cfg, trials=2, storage=str(journal), study_name="j", seed=0)
    assert f"trial {killed.number} was left running by a worker that stopped (pid {dead.pid})" in capsys.readouterr().err
    trials = optuna.load_study(study_name="j", storage=storage_of(str(journal), tmp_path)).trials
    assert trials[killed.number].state == optuna.trial.TrialState.FAIL
    retried = [t for t in trials if t.user_attrs.get("retry_of") == killed.number]
    assert len(retried) == 1 and retried[0].state == optuna.trial.TrialState.COMPLETE
    assert retried[0].params == killed.params


def test_a_study_without_a_complete_trial_claims_nothing(tmp_path, tiny_recording, monkeypatch):
    """Every trial failed: the reports say so, no best.yaml is claimed, and the command ends with an error."""
    def broken(cfg, progress=False, on_epoch=None):
        raise SteerlabError("training diverged in epoch 1")

    monkeypatch.setattr("steerlab.train.loop.train", broken)
    with pytest.raises(SteerlabError, match="has no complete trial \\(1 trials: 0 complete, 0 pruned, 1 failed"):
        run_tune(tune_config(tmp_path, tiny_recording, tmp_path / "f", epochs=1), trials=1, seed=0)
    assert (tmp_path / "f" / "summary.md").exists() and not (tmp_path / "f" / "best.yaml").exists()
