"""constraints.txt: the exact versions the test suite last passed with, one column per Python version.

    python .ci/lock.py merge constraints.txt 3.12 freeze.txt   # replace 3.12's versions by a `pip freeze --all`
    python .ci/lock.py hold constraints.txt                      # the lines a refresh keeps (torch's build)

A package at the same version on every Python of the file gets one line without a marker; one whose versions differ
(or that only some Pythons install) gets a line per version with the Pythons it applies to, e.g.
`pandas==2.3.3; python_version == "3.11"`. While the file has one Python only, every line but torch's names it: a
Python not locked yet is not held to another's versions. `make lock PYTHON=...` (.ci/lock.sh) calls `merge` after the suite passed.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

HEADER = """\
# The exact versions the test suite last passed with, per Python version: what `make demo` and `make test` install
# (pip install --constraint constraints.txt). pyproject.toml keeps the ranges a user's `pip install steerlab` takes.
# Refresh one Python's versions with `make lock PYTHON=python3.12` (see docs/guide/install.md, "Installing"). Written by .ci/lock.py.
# torch is pinned without its local label (2.13.0, not 2.13.0+cpu): the CPU and the CUDA build of a release satisfy
# the same pin, and which one pip takes depends on the index it reads (docs/guide/install.md, "Installing").
"""
HOLD = ("torch",)  # a refresh keeps these at their versions here: the newest torch on PyPI is a CUDA build
SKIP = {"setuptools", "wheel", "distribute"}  # in some venvs by default, not installed by steerlab
LINE = re.compile(r'^([A-Za-z0-9._-]+)==([^\s;]+)\s*(?:;(.*))?$')
PYTHONS = re.compile(r'python_version\s*==\s*"(\d+\.\d+)"')


def canonical(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def read(path: Path) -> tuple[list[str], dict[str, dict[str, str]]]:
    """The file's Python versions and {package: {python: version}}."""
    pythons: list[str] = []
    pins: dict[str, dict[str, str]] = {}
    if not path.exists():
        return pythons, pins
    lines = path.read_text().splitlines()
    for line in lines:
        if line.startswith("# pythons:"):
            pythons = line.split(":", 1)[1].split()
    for line in lines:
        m = LINE.match(line.strip())
        if not m:
            continue
        name, version, marker = m.groups()
        for py in PYTHONS.findall(marker) if marker else pythons:
            pins.setdefault(name, {})[py] = version
    return pythons, pins


def frozen(text: str) -> dict[str, str]:
    """{package: version} of a `pip freeze --all`, without local labels (+cpu) and the venv's own tools."""
    out = {}
    for line in text.splitlines():
        m = LINE.match(line.strip())
        if m is None:
            if line.strip() and not line.startswith("#"):
                raise SystemExit(f"lock.py: not a pinned package in the freeze: {line!r}")
        elif canonical(m.group(1)) not in SKIP:
            out[canonical(m.group(1))] = m.group(2).split("+")[0]
    return out


def render(pythons: list[str], pins: dict[str, dict[str, str]]) -> str:
    key = lambda v: tuple(int(x) for x in v.split("."))  # noqa: E731
    pythons = sorted(pythons, key=key)
    rows = [HEADER, f"# pythons: {' '.join(pythons)}\n"]
    for name in sorted(pins):
        by_version: dict[str, list[str]] = {}
        for py in pythons:
            if py in pins[name]:
                by_version.setdefault(pins[name][py], []).append(py)
        same = len(by_version) == 1 and len(next(iter(by_version.values()))) == len(pythons)
        if same and (len(pythons) > 1 or name in HOLD):
            rows.append(f"{name}=={next(iter(by_version))}\n")
            continue
        for version, pys in by_version.items():
            marker = " or ".join(f'python_version == "{py}"' for py in pys)
            rows.append(f"{name}=={version}; {marker}\n")
    return "".join(rows)


def merge(path: Path, python: str, freeze: Path) -> None:
    pythons, pins = read(path)
    for versions in pins.values():
        versions.pop(python, None)
    for name, version in frozen(freeze.read_text()).items():
        pins.setdefault(name, {})[python] = version
    pins = {name: v for name, v in pins.items() if v}
    path.write_text(render(sorted(set(pythons) | {python}), pins))


def hold(path: Path) -> str:
    return "".join(line + "\n" for line in path.read_text().splitlines()
                   if (m := LINE.match(line.strip())) and canonical(m.group(1)) in HOLD)


if __name__ == "__main__":
    if sys.argv[1:2] == ["merge"] and len(sys.argv) == 5:
        merge(Path(sys.argv[2]), sys.argv[3], Path(sys.argv[4]))
    elif sys.argv[1:2] == ["hold"] and len(sys.argv) == 3:
        sys.stdout.write(hold(Path(sys.argv[2])))
    else:
        raise SystemExit(__doc__)
