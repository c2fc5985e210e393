"""The install: the Python versions make and pip accept, the lock and the dependency check (.ci/deps.sh, with a uv
that only logs), constraints.txt's pins, and make's handling of an unsupported Python and of a broken .venv (in a copy
of the Makefile: nothing is installed)."""

import json
import os
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from packaging.requirements import Requirement

ROOT = Path(__file__).resolve().parents[2]


def pyproject() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())


def test_make_and_pip_accept_the_same_pythons():
    requires = pyproject()["project"]["requires-python"]
    minimum = re.search(r"^MIN_PYTHON := (\d+\.\d+)", (ROOT / "Makefile").read_text(), re.M).group(1)
    assert requires == f">={minimum}"
    assert sys.version_info[:2] >= tuple(map(int, minimum.split(".")))  # this suite runs on one of them


FAKE_UV = """#!{python}
import json, os, sys
args = sys.argv[1:]
held = open(args[args.index("--constraint") + 1]).read() if "--universal" in args else None
with open(os.environ["UV_LOG"], "a") as log:
    log.write(json.dumps([args, held]) + "\\n")
out = args[args.index("--output-file") + 1]
if "--universal" in args:
    open(out, "w").write(os.environ["UV_LOCK"])
elif os.environ["UV_FAIL"] in " ".join(args):
    sys.exit("error: no wheel of torch==2.13.0 for manylinux_2_28_aarch64")
else:
    open(out, "w").write("# header\\ntorch==2.13.0\\nnumpy==2.5.5 ; python_full_version >= '3.12'\\n")
"""


def deps(tmp_path, *args, lock="torch==2.13.0\n", fail="no such target"):
    """.ci/deps.sh ARGS in a copy of the project whose constraints.txt pins torch, with a uv that logs its arguments
    (and the torch pin a universal resolution holds), writes `lock` for a universal resolution and fails a dry run
    whose arguments hold `fail`: the run and [(uv's arguments, the held pin)]."""
    (tmp_path / ".ci").mkdir()
    shutil.copy(ROOT / ".ci" / "deps.sh", tmp_path / ".ci" / "deps.sh")
    shutil.copy(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    (tmp_path / "constraints.txt").write_text("# make lock\ntorch==2.13.0\n")
    uv = tmp_path / "uv"
    uv.write_text(FAKE_UV.format(python=sys.executable))
    uv.chmod(0o755)
    env = {**os.environ, "UV": str(uv), "UV_LOG": str(tmp_path / "log"), "UV_LOCK": lock, "UV_FAIL": fail}
    run = subprocess.run(["sh", str(tmp_path / ".ci" / "deps.sh"), *args], capture_output=True, text=True, env=env)
    calls = [json.loads(line) for line in (tmp_path / "log").read_text().splitlines()]
    return run, calls


def test_lock_is_one_universal_resolution_with_torch_held(tmp_path):
    run, calls = deps(tmp_path, "lock", "--upgrade", lock="# make lock\nnumpy==2.4.6 ; python_full_version < '3.12'\n")
    assert run.returncode == 0, run.stdout + run.stderr
    [(args, held)] = calls
    assert args[:2] == ["pip", "compile"] and args[-1] == "pyproject.toml"
    options = list(zip(args, args[1:]))
    for pair in [("--python-version", "3.11"), ("--extra", "test"), ("--output-file", "constraints.txt"),
                 ("--custom-compile-command", "make lock")]:
        assert pair in options
    assert "--universal" in args and "--upgrade" in args and held == "torch==2.13.0\n"
    assert (tmp_path / "constraints.txt").read_text() == "# make lock\nnumpy==2.4.6 ; python_full_version < '3.12'\n"
    again = tmp_path / "again"
    again.mkdir()
    _, calls = deps(again, "lock")
    assert "--upgrade" not in calls[0][0]  # without it, the pins there are kept where they fit


def test_check_resolves_each_python_and_platform_from_wheels(tmp_path):
    run, calls = deps(tmp_path, "check", lock="# make lock\ntorch==2.13.0\n")
    assert run.returncode == 0, run.stdout + run.stderr
    assert "--universal" in calls[0][0] and calls[0][1] == "torch==2.13.0\n"  # the lock, written anew: the same
    runs = {}
    for args, _ in calls[1:]:
        options = dict(zip(args, args[1:]))
        assert "--universal" not in args and "--only-binary" in args and options["--only-binary"] == ":all:"
        assert options["--no-binary"] == "docopt"  # pure Python, an sdist only
        key = (options["--python-version"], options["--python-platform"], options.get("--constraint"))
        runs[key] = options.get("--extra")
    assert set(runs) == {(python, f"{arch}-manylinux_2_28", constraints) for python in ("3.11", "3.12", "3.13")
                         for arch in ("x86_64", "aarch64") for constraints in (None, "constraints.txt")}
    assert all(extra == ("test" if platform.startswith("x86_64") else None) for (_, platform, _), extra in runs.items())
    lines = run.stdout.splitlines()
    assert lines[0].startswith("ok     constraints.txt is pyproject.toml's lock") and len(lines) == 14
    assert re.fullmatch(r"ok     Python 3\.11 x86_64  ranges          the test set: 2 packages "
                        r"\(torch==2\.13\.0 numpy==2\.5\.5\), \d+ s", lines[1]), lines[1]
    assert lines[-1].startswith("dependency check: every set resolves on Python 3.11 3.12 3.13")


def test_check_names_what_fails(tmp_path):
    run, _ = deps(tmp_path, "check", lock="# make lock\ntorch==2.14.0\n", fail="3.13 --python-platform aarch64")
    assert run.returncode == 1
    assert "FAILED constraints.txt is not pyproject.toml's lock (make lock writes it):" in run.stdout
    assert "    -torch==2.13.0" in run.stdout and "    +torch==2.14.0" in run.stdout  # the diff make lock would make
    assert "FAILED Python 3.13 aarch64 ranges          the runtime does not resolve:" in run.stdout
    assert "    error: no wheel of torch==2.13.0 for manylinux_2_28_aarch64" in run.stdout
    assert run.stderr.startswith("dependency check FAILED (")
    assert run.stderr.rstrip().endswith(
        "s): the lock; Python 3.13 aarch64 (ranges); Python 3.13 aarch64 (constraints.txt)")


def test_the_test_set_holds_every_extra():
    """The check resolves the test set alone on x86-64: each extra must be part of it."""
    extras = pyproject()["project"]["optional-dependencies"]
    inner = next(r for r in extras["test"] if r.startswith("steerlab["))
    assert set(inner[len("steerlab["):-1].split(",")) == set(extras) - {"test"}


def pins(python: str, machine: str) -> dict[str, list[str]]:
    """constraints.txt's pins that hold on CPython `python` (3.11.7) on Linux `machine`: {package: [versions]}."""
    env = {"python_version": python.rsplit(".", 1)[0], "python_full_version": python, "platform_machine": machine,
           "sys_platform": "linux", "implementation_name": "cpython", "platform_system": "Linux", "os_name": "posix"}
    found: dict[str, list[str]] = {}
    for line in (ROOT / "constraints.txt").read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            requirement = Requirement(line)
            if requirement.marker is None or requirement.marker.evaluate(env):
                found.setdefault(requirement.name, []).append(str(requirement.specifier))
    return found


@pytest.mark.parametrize("python", ["3.11.0", "3.11.7", "3.12.0", "3.13.0"])
@pytest.mark.parametrize("machine", ["x86_64", "aarch64"])
def test_constraints_pin_one_version_of_each_package_for_each_python(python, machine):
    """One pin of each package wherever it is installed; torch's release (its CPU or CUDA build by the index); each
    exact pin of pyproject.toml (the simulator's python-socketio and python-engineio) as it is there."""
    found = pins(python, machine)
    assert all(len(versions) == 1 and versions[0].startswith("==") for versions in found.values()), found
    assert found["torch"] == ["==2.13.0"]
    project = pyproject()["project"]
    exact = [r.split(";")[0].split("==") for r in [*project["dependencies"],
                                                      *sum(project["optional-dependencies"].values(), [])] if "==" in r]
    assert ["python-socketio", "4.6.1"] in exact and ["python-engineio", "3.14.2"] in exact
    for name, version in exact:
        assert found[name] == [f"=={version}"], name
    # pymdown-extensions 13 needs Python 3.11.5: the lock holds 12.3 for the 3.11 releases before it
    assert found["pymdown-extensions"] == (["==12.3"] if python == "3.11.0" else ["==13.1.2"])


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
@pytest.mark.parametrize("state", ["interrupted", "python gone", "no uv", "other python", "not made by make"])
def test_make_rebuilds_a_broken_venv_and_says_why(project, state):
    venv = project / ".venv"
    (venv / "bin").mkdir(parents=True)
    if state != "not made by make":
        (venv / ".made").touch()
    if state != "no uv":  # as a .venv made before make installed with uv
        (venv / "bin" / "uv").touch()
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
           "no uv": "it has no uv",
           "other python": f"it has Python 3.99, PYTHON={sys.executable} is {'%d.%d' % sys.version_info[:2]}",
           "not made by make": "it was not made by make, or its making did not finish"}[state]
    lines = run.stdout.splitlines()
    assert lines[0] == f".venv: {why}; making it anew", run.stdout + run.stderr
    python = sys.executable if state == "other python" else "python3"
    assert lines[1:6] == ["rm -rf .venv", f"{python} -m venv .venv",
                          ".venv/bin/python -m pip install --quiet uv==0.13.8", "touch .venv/.made",
                          "touch .venv/.installing"], run.stdout
    install = lines[6].split("; ")  # uv, told where pip is configured to look
    assert install[0].startswith('eval "$(.venv/bin/python -m pip config list | sed -n ')
    assert install[-1] == ".venv/bin/uv pip install --quiet --constraint constraints.txt -e '.'", run.stdout
    assert lines[-1] == ".venv/bin/steerlab demo --out runs/demo"
    assert (venv / ".runtime").exists()  # make -n changes nothing


@pytest.mark.skipif(shutil.which("make") is None, reason="make is not installed")
def test_make_uses_a_finished_venv_as_it_is(project):
    venv = project / ".venv"
    (venv / "bin").mkdir(parents=True)
    (venv / "bin" / "python").symlink_to(sys.executable)
    (venv / "bin" / "uv").touch()
    for stamp in (".made", ".runtime"):
        (venv / stamp).touch()
    run = make(project, "demo")
    assert run.stdout.splitlines() == [".venv/bin/steerlab demo --out runs/demo"], run.stdout + run.stderr
