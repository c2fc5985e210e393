"""Rule 2, no output over an input or into a folder of another kind: a command's outputs (its folders and
files, a config's out, the cache however it is named) never go over what it reads, into a recording, a training run
or another world's suite, nor through a device or a link to nothing; one run at a time in a folder, and what a
killed run left is taken over."""

import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from steerlab.cli import main
from steerlab.errors import SteerlabError
from tests.bad_input.builders import _files, _says_what_it_is, _train, config, refused_in_one_line, trained
from tests.inputs import ch2, made, sim_log, tub


def _dagger_of_another_config(tmp_path, stack):
    """A DAgger folder that holds a run of other settings: reusing its rollouts would be silent garbage."""
    cfg = config(tmp_path, sim_log(tmp_path / "sim"))
    (tmp_path / "run" / "round0").mkdir(parents=True)
    (tmp_path / "run" / "dagger.json").write_text(json.dumps({"dagger": {"minutes": 9}}))
    return ["sim", "dagger", str(cfg)]


def _locked(tmp_path, stack):
    """`out` is held by another run (here: the lock taken by this process, on another open file)."""
    from steerlab.locks import folder_lock

    (tmp_path / "run").mkdir()
    stack.enter_context(folder_lock(tmp_path / "run", "steerlab train run"))
    return _train()(tmp_path, stack)


def _read_only_journal(tmp_path, stack):
    cfg = config(tmp_path, sim_log(tmp_path / "sim"))
    cfg.write_text(cfg.read_text() + "tune: {train.lr: {low: 1.0e-5, high: 0.1, log: true}}\n")
    journal = tmp_path / "s.journal"
    journal.write_text("")
    journal.chmod(0o444)
    stack.callback(journal.chmod, 0o644)
    if os.geteuid() == 0:  # root writes read-only files: make it immutable instead
        if subprocess.run(["chattr", "+i", str(journal)], capture_output=True).returncode:
            pytest.skip("running as root without chattr: a file root cannot write cannot be made")
        stack.callback(subprocess.run, ["chattr", "-i", str(journal)])
    return ["tune", str(cfg), "--trials", "1", "--storage", str(journal)]


def _best_without_last(tmp_path, stack):
    """A run whose last.pt was removed (to save space, say): starting again would write over its best.pt."""
    argv = _train()(tmp_path, stack)
    (tmp_path / "run").mkdir()
    made(tmp_path / "run", name="best.pt")
    return argv


def _a_file(tmp_path):
    (tmp_path / "afile").write_text("")
    return tmp_path / "afile"


# each case: a function (tmp_path, stack) -> the command's arguments, and the message's substring (builders.py)
BAD_INPUTS = {
    "sim dagger into another config's folder": (_dagger_of_another_config,
                                                "run holds a DAgger run whose dagger.json this steerlab cannot read "
                                                "(SteerlabError); choose a new out"),
    # e) a second run into the same out folder
    "train out in use": (_locked, f"run is in use by another steerlab train run (pid {os.getpid()})"),
    # d) a loss that is not finite stops training and never becomes the best checkpoint
    "train diverges": (_train("train.lr=1e30", "train.epochs=2"), "training diverged in epoch 1: the training loss is",
                       ("run/", "cache/")),
    "export to a file not .onnx": (lambda t, s: ["export", str(made(t)), "--out", str(t / "m.bin")],
                                   "m.bin: the export file must end in .onnx"),
    "ensemble to a file not .pt": (lambda t, s: ["ensemble", str(made(t, name="a.pt")), str(made(t, name="b.pt")),
                                                 "--out", str(t / "e.onnx")],
                                   "e.onnx: the ensemble is a checkpoint: its file must end in .pt"),
    "evaluate into a file as --out": (lambda t, s: ["evaluate", str(made(t)), "--data", str(sim_log(t / "sim")),
                                                    "--out", str(_a_file(t))],
                                      "a file, where an output folder (--out) is expected"),
    # p) found by a new user: each is a row here and a case of its rule's generated sweep below
    "train into the recording it reads": (lambda t, s: _train(f"out={t / 'sim'}")(t, s),
                                          "sim: the output folder (out) holds a recording ("),
    "ensemble onto one of its members": (lambda t, s: ["ensemble", str(made(t, name="a.pt")), str(made(t, name="b.pt")),
                                                       "--out", str(t / "a.pt")],
                                         "a.pt: the output file (--out) is an input of this command"),
    "tune read-only journal": (_read_only_journal, "s.journal: cannot be written ("),
    "train again into a run whose last.pt is gone": (_best_without_last, "run holds a run's best.pt but not the "
                                                     "last.pt it resumes from (removed?): training there would start "
                                                     "again and write over best.pt", ("run/.lock",)),
}


@pytest.mark.parametrize("case", BAD_INPUTS)
def test_bad_input_is_refused_in_one_line(case, tmp_path, capsys):
    refused_in_one_line(BAD_INPUTS[case], tmp_path, capsys)


# ---------------------------------------------------------------- what a killed run or compile left, taken over

def test_stale_lock_and_leftovers_of_a_killed_run_are_taken_over(tmp_path, capsys):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    run = tmp_path / "run"
    run.mkdir()
    (run / ".lock").write_text(f"{dead.pid}\n")
    (run / f"best.pt.tmp-{dead.pid}-0123abcd").write_bytes(b"half a checkpoint")
    best = trained(tmp_path)
    assert best.exists() and not list(run.glob("*.tmp-*"))
    assert (run / ".lock").read_text() == ""  # released


def test_compile_removes_leftovers_of_killed_compiles_and_compiles_an_entry_once(tmp_path, monkeypatch):
    from steerlab.data import dataset
    from steerlab.data.preprocess import PreprocessConfig
    from steerlab.data.readers import open_recording

    cache = tmp_path / "cache"
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    left = cache / f".rec-center-0123-abcd.tmp-{dead.pid}"
    alive = cache / f".other-center-0123-abcd.tmp-{os.getpid()}"  # a compile that still runs
    for folder in (left, alive):
        folder.mkdir(parents=True)
        (folder / "image.npy").write_bytes(b"\0" * 1000)
    rec = open_recording(sim_log(tmp_path / "sim"))
    builds, real = [], dataset._build

    def slow_build(*a, **k):
        builds.append(1)
        time.sleep(0.5)  # the other thread arrives while this one compiles
        real(*a, **k)

    monkeypatch.setattr(dataset, "_build", slow_build)
    results = []
    threads = [threading.Thread(target=lambda: results.append(dataset.compile_recording(
        rec, PreprocessConfig.from_dict({"preset": "sim"}), cache, progress=False))) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(builds) == 1 and len(results) == 2 and results[0].path == results[1].path
    assert not left.exists() and alive.exists()


def test_a_cache_entry_without_its_meta_json_is_compiled_again_and_said(tmp_path, capsys):
    """An entry folder whose meta.json is gone (half removed by hand, a disk that filled) holds no checksums to
    trust: it is compiled again, with a warning naming it, where the rename into place used to fail."""
    from steerlab.data import dataset
    from steerlab.data.preprocess import PreprocessConfig
    from steerlab.data.readers import open_recording

    rec, cfg = open_recording(sim_log(tmp_path / "sim")), PreprocessConfig.from_dict({"preset": "sim"})
    first = dataset.compile_recording(rec, cfg, tmp_path / "cache", progress=False)
    (first.path / "meta.json").unlink()
    capsys.readouterr()
    again = dataset.compile_recording(rec, cfg, tmp_path / "cache", progress=False)
    assert f"warning: {first.path / 'meta.json'}: the compiled cache entry is damaged" in capsys.readouterr().err
    assert again.path == first.path and (again.path / "meta.json").is_file() and len(again) == len(rec)


def test_a_cache_named_by_the_environment_is_checked_as_an_output(tmp_path, monkeypatch, capsys):
    """Rule 2 for the cache however it is named: STEERLAB_CACHE at a recording or a run folder is refused before
    anything is written there, from the command line and from the Python API."""
    from steerlab.data.dataset import compile_recording
    from steerlab.data.preprocess import PreprocessConfig
    from steerlab.data.readers import open_recording

    tub(tmp_path / "tub")
    run = tmp_path / "run"
    run.mkdir()
    made(run, name="last.pt")  # what marks a training run's folder
    for folder, held in ((tmp_path / "tub", "a recording"), (run, "a training run")):
        monkeypatch.setenv("STEERLAB_CACHE", str(folder))
        before = _files(folder)
        assert main(["compile", "--data", str(tmp_path / "tub")]) == 2
        assert capsys.readouterr().err.startswith(f"error: {folder}: the cache folder (STEERLAB_CACHE) holds {held} (")
        with pytest.raises(SteerlabError, match=f"the cache folder \\(STEERLAB_CACHE\\) holds {held}"):
            compile_recording(open_recording(tmp_path / "tub"), PreprocessConfig(), progress=False)
        assert _files(folder) == before


def test_a_suite_of_one_world_is_not_written_over_by_another_worlds(tmp_path, capsys):
    """Rule 2: a road-world suite's folder refuses a track-world bench and the other way round (both are suites
    to the outputs' check), before any drive; its tables stay as they were."""
    road, track = made(tmp_path), made(tmp_path, "normalized", "right", "donkey", name="tub.pt", full_lock_deg=25)
    for world, ckpt, other, column in (("track", track, "road", "road_type"), ("road", road, "track", "style")):
        out = tmp_path / f"{world}-into-other"
        out.mkdir()
        (out / "suite.csv").write_text(f"label,checkpoint,{column},seed\r\n")  # as csv.DictWriter ends its lines
        (out / "suite.md").write_text("a table\n")
        before = _files(out)
        assert main(["sim", "bench", str(ckpt), "--world", world, "--out", str(out), "--minutes", "0.01"]) == 2
        assert capsys.readouterr().err == (f"error: {out}: the output folder holds a {other}-world suite "
                                           f"({out / 'suite.csv'} has its {column} column); a {world}-world suite "
                                           "goes into a new folder or one of its own\n")
        assert _files(out) == before


def _commands():
    """(command words, its parser) of every subcommand."""
    from steerlab.cli import build_parser

    out = []
    for name, parser in build_parser()._subparsers._group_actions[0].choices.items():
        subs = [(f"{name} {n}", p) for n, p in parser._subparsers._group_actions[0].choices.items()] \
            if parser._subparsers else [(name, parser)]
        out += subs
    return out


def rule2_cases():
    """(command, output argument, collision): every output argument of every command (its folders and files to
    write, and `out` of the commands that take a config) against the ways an output can destroy or mix into what
    is not its own."""
    out = []
    for command, parser in _commands():
        paths = parser.get_default("paths") or {}
        for dest, kind in paths.items():
            if kind == "folder":
                out += [(command, dest, c) for c in ("a recording", "a CH2 folder", "a training run", "unwritable",
                                                     "long name", "inside a recording", *NOT_WRITABLE)]
            elif kind == "new-file":
                out += [(command, dest, c) for c in ("an input", "an input through a symlink",
                                                     "an input, relative", "a run's checkpoint", "long name",
                                                     *NOT_WRITABLE)]
        if paths.get("config") == "file" and command != "views":  # views writes --out only (refuses out=)
            out += [(command, "out=", c) for c in ("a recording", "the recording it reads", "a training run",
                                                   "long name", "unwritable", *NOT_WRITABLE)]
    return [c for c in out if not (c[0] == "train" and c[2] == "a training run")]  # a run continues its own


NOT_WRITABLE = ("/dev/null", "/dev/full", "a symbolic link to nothing")  # neither a file nor a folder


def _collision(tmp_path, what, file_input):
    """The path of a collision: a folder or file that the output must not be."""
    rec = sim_log(tmp_path / "rec").parent
    run = tmp_path / "run-of-another"
    run.mkdir(exist_ok=True)
    for name in ("best.pt", "last.pt"):
        (run / name).write_bytes(b"a checkpoint")
    if what == "unwritable":
        ro = tmp_path / "ro"
        ro.mkdir(exist_ok=True)
        ro.chmod(0o555)
        if os.geteuid() == 0 and subprocess.run(["chattr", "+i", str(ro)], capture_output=True).returncode:
            pytest.skip("running as root without chattr: a folder root cannot write cannot be made")  # root writes
        return ro / "out"  # into read-only folders: an immutable one it cannot
    if (tmp_path / "a-link").exists() is False:
        os.symlink(file_input, tmp_path / "a-link")
    if what == "a symbolic link to nothing":
        os.symlink(tmp_path / "nowhere", tmp_path / "a-dangling-link")
        return tmp_path / "a-dangling-link"
    if what.startswith("/dev/"):
        return Path(what)
    return {"a recording": rec, "a CH2 folder": ch2(tmp_path / "ch2-other"), "the recording it reads": rec,
            "a training run": run,
            "inside a recording": rec / "IMG", "long name": tmp_path / ("x" * 300), "an input": file_input,
            "an input through a symlink": tmp_path / "a-link",
            "an input, relative": Path(os.path.relpath(file_input)), "a run's checkpoint": run / "best.pt"}[what]


@pytest.mark.parametrize("command, dest, what", rule2_cases(), ids=str)
def test_rule2_no_output_over_an_input_or_into_another_kind_of_folder(command, dest, what, tmp_path, capsys):
    from steerlab.cli import flag

    parser = dict(_commands())[command]
    file = tmp_path / "a-file.pt"
    file.write_bytes(b"refused before it is read")
    folder = tmp_path / "a-folder"
    folder.mkdir()
    target = _collision(tmp_path, what, file)
    argv = [*command.split()]
    for a in parser._actions:  # every other required argument, an existing input of its kind
        if a.required and a.dest != dest and a.option_strings:
            argv += [a.option_strings[0], str(sim_log(tmp_path / "sim").parent if a.dest == "data" else file)]
        elif not a.option_strings and a.dest not in ("help", "overrides") and a.nargs != "*":
            argv.append(str(_config_of(command, tmp_path) if a.dest == "config" else file))
    if dest == "out=":
        argv.append(f"out={target}")
    else:
        argv += [flag(dest), str(target)]
    before = _files(tmp_path)
    try:
        assert main(argv) == 2, argv
    finally:
        if (tmp_path / "ro").exists():
            subprocess.run(["chattr", "-i", str(tmp_path / "ro")], capture_output=True)
            (tmp_path / "ro").chmod(0o755)
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1, err
    shown = str(target if what != "long name" else tmp_path)
    assert shown in err or str(target.resolve()) in err or str(file) in err, err
    assert {p: t for p, t in _files(tmp_path).items() if p in before} == before  # nothing lost
    assert not (tmp_path / "nowhere").exists()  # nothing made through a link to nothing
    assert what not in NOT_WRITABLE or _says_what_it_is(target, err), err


def _config_of(command, tmp_path):
    """A config that `command` takes: a training config, with a models list for an experiment and a search space
    for a study."""
    cfg = config(tmp_path, tmp_path / "rec")
    extra = {"experiment": "models:\n  - {model: {name: zero}}\n",
             "tune": "tune: {train.lr: {low: 1.0e-5, high: 0.1, log: true}}\n"}
    cfg.write_text(cfg.read_text() + extra.get(command, ""))
    return cfg


def test_an_experiment_writes_its_table_where_its_runs_train(tmp_path):
    """`out=NEW` moves the whole experiment: its runs train below NEW and its table is written there, not over the
    config's earlier experiment; two entries of one name would share a run folder and a row, and are refused."""
    from steerlab.experiment import load_experiment

    cfg = config(tmp_path, sim_log(tmp_path / "sim"))
    cfg.write_text(cfg.read_text() + "models:\n  - {model: {name: zero}}\n  - {model: {name: train-mean}}\n")
    exp = load_experiment(cfg, [f"out={tmp_path / 'new'}"])
    assert exp.out == tmp_path / "new"
    assert Path(exp.run_config(exp.entries[1], 2).out) == tmp_path / "new" / "train-mean" / "seed2"
    cfg.write_text(cfg.read_text() + "  - {model: {name: zero}, train: {lr: 0.01}}\n")
    with pytest.raises(SteerlabError, match="models entries 1 and 3 are both named 'zero'; give one a label"):
        load_experiment(cfg)
