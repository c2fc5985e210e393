"""The install: the Python versions make and pip accept, the resolve check's pip arguments, constraints.txt's
format, and make's handling of an unsupported Python and of a broken .venv (in a copy of the Makefile: nothing is
installed)."""

import importlib.util
import os
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def load(name: str):
    spec = importlib.util.spec_from_file_location(name, ROOT / ".ci" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def pyproject() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())


def test_make_and_pip_accept_the_same_pythons():
    requires = pyproject()["project"]["requires-python"]
    minimum = re.search(r"^MIN_PYTHON := (\d+\.\d+)", (ROOT / "Makefile").read_text(), re.M).group(1)
    assert requires == f">={minimum}"
    assert sys.version_info[:2] >= tuple(map(int, minimum.split(".")))  # this suite runs on one of them


def test_resolve_check_asks_pip_for_each_python_and_platform(tmp_path):
    check = load("resolve_check")
    args = check.pip_args("3.13", "aarch64", "steerlab[tune]", tmp_path / "w", tmp_path / "c.txt", tmp_path / "r.json")
    assert args[:2] == ["install", "--dry-run"] and args[-1] == "steerlab[tune]"
    options = list(zip(args, args[1:]))
    for pair in [("--python-version", "3.13"), ("--implementation", "cp"), ("--abi", "cp313"),
                 ("--find-links", str(tmp_path / "w")), ("--constraint", str(tmp_path / "c.txt"))]:
        assert pair in options
    assert "--only-binary=:all:" in args and "--ignore-installed" in args
    platforms = [b for a, b in options if a == "--platform"]
    assert "manylinux_2_28_aarch64" in platforms and "manylinux2014_aarch64" in platforms
    assert all(p.endswith("_aarch64") for p in platforms)
    assert "--constraint" not in check.pip_args("3.11", "x86_64", "steerlab", tmp_path, None, tmp_path / "r.json")
    # every extra, the runtime and the test set on x86-64; the runtime on aarch64
    extras = set(pyproject()["project"]["optional-dependencies"])
    assert set(check.sets("x86_64")) == {"steerlab"} | {f"steerlab[{e}]" for e in extras}
    assert check.sets("x86_64")[-1] == "steerlab[test]" and check.sets("aarch64") == ["steerlab"]
    assert check.PYTHONS == ("3.11", "3.12", "3.13")


def test_the_test_set_holds_every_extra():
    """The resolve check resolves the test set alone when it passes: each extra must be part of it."""
    extras = pyproject()["project"]["optional-dependencies"]
    inner = next(r for r in extras["test"] if r.startswith("steerlab["))
    assert set(inner[len("steerlab["):-1].split(",")) == set(extras) - {"test"}


def test_lock_merges_one_python_and_marks_what_differs(tmp_path):
    lock = load("lock")
    path = tmp_path / "constraints.txt"
    (tmp_path / "f311").write_text("numpy==2.4.6\nDocOpt==0.6.2\ntorch==2.13.0+cpu\npip==26.3\nsetuptools==65.5.0\n")
    (tmp_path / "f313").write_text("numpy==2.5.5\ntorch==2.13.0\npip==26.3\n")
    lock.merge(path, "3.11", tmp_path / "f311")
    rows = [line for line in path.read_text().splitlines() if not line.startswith("#")]
    assert rows == ['docopt==0.6.2; python_version == "3.11"', 'numpy==2.4.6; python_version == "3.11"',
                    'pip==26.3; python_version == "3.11"', "torch==2.13.0"]  # 3.13 not locked yet: held to torch
    lock.merge(path, "3.13", tmp_path / "f313")
    rows = [line for line in path.read_text().splitlines() if not line.startswith("#")]
    assert rows == ['docopt==0.6.2; python_version == "3.11"', 'numpy==2.4.6; python_version == "3.11"',
                    'numpy==2.5.5; python_version == "3.13"', "pip==26.3", "torch==2.13.0"]
    assert "# pythons: 3.11 3.13" in path.read_text()
    (tmp_path / "f313b").write_text("numpy==2.4.6\ntorch==2.13.0\npip==26.3\n")  # 3.13 refreshed: the same numpy
    lock.merge(path, "3.13", tmp_path / "f313b")
    rows = [line for line in path.read_text().splitlines() if not line.startswith("#")]
    assert rows == ['docopt==0.6.2; python_version == "3.11"', "numpy==2.4.6", "pip==26.3", "torch==2.13.0"]
    assert lock.hold(path) == "torch==2.13.0\n"


def test_constraints_pin_torch_and_what_pyproject_pins_exactly():
    """torch's CPU build for every Python; each exact pin of pyproject.toml (the simulator's python-socketio and
    python-engineio) at that version for every Python constraints.txt was locked on."""
    lock = load("lock")
    text = (ROOT / "constraints.txt").read_text()
    assert re.search(r"^torch==2\.13\.0$", text, re.M)
    pythons, pins = lock.read(ROOT / "constraints.txt")
    assert set(pythons) <= {"3.11", "3.12", "3.13"}
    project = pyproject()["project"]
    exact = [r.split(";")[0].split("==") for r in [*project["dependencies"],
                                                      *sum(project["optional-dependencies"].values(), [])] if "==" in r]
    assert ["python-socketio", "4.6.1"] in exact and ["python-engineio", "3.14.2"] in exact
    for name, version in exact:
        assert pins.get(name, {}) == {python: version for python in pythons}, name


@pytest.fixture
def project(tmp_path):
    """A folder with the Makefile and what its rules read, no .venv."""
    for name in ("Makefile", "pyproject.toml", "constraints.txt"):
        shutil.copy(ROOT / name, tmp_path / name)
    return tmp_path


def make(project, *args):
    """`make -n ARGS` as from a shell: not as a sub-make of the `make test` this suite may run under, which would
    hand down its own variables (PYTHON=...) and print the folders it enters."""
    env = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MFLAGS", "MAKELEVEL", "MAKEOVERRIDES",
                                                           "PYTHON")}
    return subprocess.run(["make", "-n", *args], cwd=project, capture_output=True, text=True, env=env)


@pytest.mark.skipif(shutil.which("make") is None, reason="make is not installed")
def test_make_refuses_an_old_or_missing_python_in_one_line(project, tmp_path):
    old = tmp_path / "python3.10"  # answers as Python 3.10.13 does to what make asks (python -c CODE)
    old.write_text(f"#!/bin/sh\nexec {sys.executable} -c \"import platform, sys; sys.version_info = (3, 10, 13); "
                   "platform.python_version = lambda: '3.10.13'; exec(sys.argv[1])\" \"$2\"\n")
    old.chmod(0o755)
    for python, what in [(str(old), "Python 3.10.13"), ("no-such-python", "not a Python that runs")]:
        run = make(project, "demo", f"PYTHON={python}")
        assert run.returncode != 0
        assert run.stderr.strip().splitlines() == [
            f"Makefile:{run.stderr.split(':')[1]}: *** steerlab needs Python 3.11 or newer (tested on 3.11, 3.12 "
            f"and 3.13); PYTHON={python} is {what}.  Stop."], run.stderr
        assert not (project / ".venv").exists()


@pytest.mark.skipif(shutil.which("make") is None, reason="make is not installed")
@pytest.mark.parametrize("state", ["interrupted", "python gone", "other python", "not made by make"])
def test_make_rebuilds_a_broken_venv_and_says_why(project, state):
    venv = project / ".venv"
    (venv / "bin").mkdir(parents=True)
    if state != "not made by make":
        (venv / ".made").touch()
    (venv / ".runtime").touch()
    python = venv / "bin" / "python"
    if state == "python gone":
        python.symlink_to(project / "removed" / "python3")
    elif state == "other python":  # a .venv of "3.99" while PYTHON is this one
        python.write_text("#!/bin/sh\necho 3.99\n")
        python.chmod(0o755)
    else:
        python.symlink_to(sys.executable)
    if state == "interrupted":
        (venv / ".installing").touch()  # make writes it before an install and removes it after the smoke test
    run = make(project, "demo", *([f"PYTHON={sys.executable}"] if state == "other python" else []))
    why = {"interrupted": "its last install did not finish", "python gone": "its python does not run",
           "other python": f"it has Python 3.99, PYTHON={sys.executable} is {sys.version_info[0]}.{sys.version_info[1]}",
           "not made by make": "it was not made by make, or its making did not finish"}[state]
    lines = run.stdout.splitlines()
    assert lines[0] == f".venv: {why}; making it anew", run.stdout + run.stderr
    python = sys.executable if state == "other python" else "python3"
    assert lines[1:6] == ["rm -rf .venv", f"{python} -m venv .venv", "touch .venv/.made", "touch .venv/.installing",
                          ".venv/bin/python -m pip install --quiet --no-compile --constraint constraints.txt "
                          "--upgrade pip"], run.stdout
    assert lines[-1] == ".venv/bin/steerlab demo --out runs/demo"
    assert (venv / ".runtime").exists()  # make -n changes nothing


@pytest.mark.skipif(shutil.which("make") is None, reason="make is not installed")
def test_make_uses_a_finished_venv_as_it_is(project):
    venv = project / ".venv"
    (venv / "bin").mkdir(parents=True)
    (venv / "bin" / "python").symlink_to(sys.executable)
    for stamp in (".made", ".runtime"):
        (venv / stamp).touch()
    run = make(project, "demo")
    assert run.stdout.splitlines() == [".venv/bin/steerlab demo --out runs/demo"], run.stdout + run.stderr
