#!/bin/sh
# make lock PYTHON=python3.X: refresh that Python's versions in constraints.txt. Installs the test set with the
# newest versions pyproject.toml allows (torch held at its pinned build, see .ci/lock.py) in a venv of its own, runs
# the suite there, and writes `pip freeze` into constraints.txt only when the suite passed. .venv is not touched.
set -eu
python=${1:?usage: .ci/lock.sh PYTHON}
cd "$(dirname "$0")/.."
version=$("$python" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "lock: Python $version, fresh venv in $work"
"$python" -m venv "$work/venv"
pip="$work/venv/bin/python -m pip"
$pip install --quiet --upgrade pip
python3=$work/venv/bin/python
$python3 .ci/lock.py hold constraints.txt > "$work/hold.txt"
$pip install --quiet --no-compile --constraint "$work/hold.txt" -e '.[test]'
PYTHONDONTWRITEBYTECODE= $python3 -m pytest -q -n 2 --dist worksteal
$pip freeze --all --exclude-editable > "$work/freeze.txt"
$python3 .ci/lock.py merge constraints.txt "$version" "$work/freeze.txt"
echo "lock: constraints.txt has Python $version's versions (git diff constraints.txt)"
