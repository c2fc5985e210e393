"""A new user's round: a few hundred inputs that the bad-input tests do not list, tried on the CLI and the Python API
of the build on PYTHONPATH; each classified as handled (refused in one line, taken, or said) or as one of five
failures: lost (an input changed or gone), traceback, silent (taken without a word where it should be refused or
said), unclear (refused, but not in one line naming what is wrong), hang.

The cases are the rows of a round's table (tests/rounds/round1.py; `--round 2`: tests/rounds/round2.py, every
command given the wrong kind of file, runs interrupted and rerun, mixed recordings, the Python API with wrong types
and units, the scripts with bad arguments), each a name, what it runs (a command line, a call of the Python API,
or a builder of the table named by the row) and the outcome expected; `cases` reads them. The fixtures are the
tiny inputs of the bad-input tests (tests/inputs.py), made in OUT_DIR/fx; every case runs in a forked process of
its own with a 45 s limit; the counts are printed, and every input not handled is written to
OUT_DIR/failures.txt.

usage: PYTHONPATH=src python -m tests.rounds.run [--round 2|3] OUT_DIR    (from the repository root; PYTHONPATH
picks the build that is tried)"""

import contextlib
import io
import json
import os
import shutil
import signal
import subprocess
import sys
import time
import traceback
from collections import Counter
from dataclasses import dataclass

from steerlab.cli import path_option, run_script, script_parser
from steerlab.errors import SteerlabError
from steerlab.options import Options, Range, option
from tests.inputs import ch2, made, sim_log, tub  # the tiny inputs of the bad-input tests
from tests.rounds import places

TIMEOUT = 45  # s a case may take (a case's own "timeout" says more)


@dataclass(frozen=True)
class RoundOptions(Options):
    round: int = option(1, Range(1, 3), help="the round: 1 (tests/rounds/round1.py), 2 (tests/rounds/round2.py) or 3 "
                        "(tests/rounds/round3/)")


def setup():
    subprocess.run(["chattr", "-i", str(places.ROOT / "ro")], capture_output=True)
    shutil.rmtree(places.FIX, ignore_errors=True)
    places.FIX.mkdir(parents=True)
    sim_log(places.FIX / "sim")
    tub(places.FIX / "tub")
    ch2(places.FIX / "ch2")
    made(places.FIX, name="a.pt")
    made(places.FIX, name="b.pt")
    made(places.FIX, "normalized", "right", "donkey", name="donkey.pt", full_lock_deg=25)
    (places.FIX / "run").mkdir()
    shutil.copy(places.FIX / "a.pt", places.FIX / "run" / "best.pt")
    shutil.copy(places.FIX / "a.pt", places.FIX / "run" / "last.pt")
    (places.FIX / "run" / "config.json").write_text("{}")
    from steerlab.sim.road.run import RecordOptions, record

    record(places.FIX / "rec", RecordOptions(seed=0, minutes=0.05, side_cameras=False), progress=False)
    (places.FIX / "c.yaml").write_text(f"data: {places.FIX / 'sim'}\ncache: {places.ROOT / 'cache'}\n"
                                       f"out: {places.WORK / 'run'}\n"
                                       "split: {train: '0:6', val: '6:8'}\ntrain: {epochs: 1, batch_size: 2}\n")
    os.symlink(places.FIX / "a.pt", places.FIX / "a-link.pt")
    os.symlink(places.FIX / "sim", places.FIX / "sim-link")


def snapshot():
    """The fixtures' files but a stale lock a command takes over (a killed run's `.lock`, emptied when it is
    released): a lock is no result nor input."""
    return {p: (p.stat().st_size, p.stat().st_mtime_ns) for p in places.FIX.rglob("*") if p.is_file()
            and p.name != ".lock"}


def run_case(fn):
    """fn() in a forked child: (code, stderr, exception text, hung, crashed)."""
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.setpgid(0, 0)
        os.close(r)
        err = io.StringIO()
        out = {"code": None, "err": "", "exc": ""}
        try:
            places.WORK.mkdir(parents=True, exist_ok=True)
            os.chdir(places.WORK)
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                try:
                    if getattr(fn, "stage", False):
                        stop_before_work()
                    out["code"] = fn()
                except SystemExit as e:
                    out["code"] = e.code
                except Reached:
                    out["code"] = 0
                except Exception as e:  # noqa: BLE001
                    from steerlab.errors import SteerlabError

                    if isinstance(e, SteerlabError):
                        out["code"] = "refused"
                        out["err"] = f"error: {e}\n"
                    else:
                        out["exc"] = traceback.format_exc()
        finally:
            out["err"] += err.getvalue()
            os.write(w, json.dumps(out, default=str).encode())
            os.close(w)
            os._exit(0)
    os.close(w)
    import select

    chunks, deadline = [], time.monotonic() + TIMEOUT
    while True:
        left = deadline - time.monotonic()
        ready = select.select([r], [], [], max(0.0, left))[0] if left > 0 else []
        if not ready:  # a hang: the case and whatever it started are ended
            try:
                os.killpg(pid, signal.SIGKILL)
            except OSError:
                os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            os.close(r)
            return None, "", "", True, False
        c = os.read(r, 65536)
        if not c:
            break
        chunks.append(c)
        if c.endswith(b"}"):
            try:
                json.loads(b"".join(chunks))
                break
            except ValueError:
                pass
    try:
        os.killpg(pid, signal.SIGKILL)  # workers the case left behind
    except OSError:
        pass
    os.waitpid(pid, 0)
    os.close(r)
    if not chunks:
        return None, "", "", False, True
    d = json.loads(b"".join(chunks))
    return d["code"], d["err"], d["exc"], False, False


class Reached(Exception):
    """The command got past every check of its input: the work would start here."""


def stop_before_work():
    """Every command's work replaced by Reached, so that a value a command takes costs nothing: what is tried is
    whether the value is refused before the work starts."""
    import dataclasses

    import steerlab.demo
    import steerlab.evaluate.latency
    import steerlab.experiment
    import steerlab.serve
    import steerlab.sim.replay.run
    import steerlab.sim.worlds
    import steerlab.train.loop
    import steerlab.tune

    def stop(*a, **k):
        raise Reached

    def stopped(part):  # a world's record, drive or suite: an entry with its `run` (a function in earlier builds)
        return dataclasses.replace(part, run=stop) if dataclasses.is_dataclass(part) else stop

    for name, entry in list(steerlab.sim.worlds.WORLDS.items()):
        steerlab.sim.worlds.WORLDS[name] = dataclasses.replace(
            entry, **{part: stopped(getattr(entry, part)) for part in ("record", "drive", "suite")})
    for module, attr in ((steerlab.sim.replay.run, "run_replay"), (steerlab.serve, "serve"),
                         (steerlab.demo, "run_demo"), (steerlab.evaluate.latency, "run_latency"),
                         (steerlab.train.loop, "train"), (steerlab.experiment, "run_experiment"),
                         (steerlab.tune, "run_tune")):
        setattr(module, attr, stop)


def classify(case, result, before, after):
    code, err, exc, hung, crashed = result
    expect, hint = case["expect"], case.get("hint")
    if hung:
        return "hang"
    if {p: t for p, t in after.items() if p in before} != before:
        return "lost"
    if crashed or exc or "Traceback" in err or code not in (0, 2, None, "refused"):
        return "traceback"
    refused = code in (2, "refused")
    lines = [line for line in err.splitlines() if line.strip()]
    warned = any(line.startswith("warning:") for line in lines)
    if expect == "refuse":
        if not refused:
            return "silent"
        last = [line for line in lines if line.startswith("error:")]
        if len(last) != 1 or (hint and not any(h.lower() in last[0].lower() for h in hint)):
            return "unclear"
        return "handled"
    if expect == "warn":
        if refused:
            last = [line for line in lines if line.startswith("error:")]
            return "handled" if len(last) == 1 and (not hint or any(h.lower() in last[0].lower() for h in hint)) \
                else "unclear"
        return "handled" if warned else "silent"
    # expect ok
    return "handled" if not refused else ("handled" if case.get("refuse_ok") else "silent-refusal")


def preload():
    """What the commands import, imported once here: each case's process is forked from this one."""
    import importlib

    for name in ("steerlab.demo", "steerlab.evaluate.latency", "steerlab.experiment", "steerlab.serve",
                 "steerlab.sim.replay.run", "steerlab.sim.worlds", "steerlab.train.loop", "steerlab.tune",
                 "steerlab.tune.run", "steerlab.dagger", "steerlab.evaluate.offline", "steerlab.export",
                 "steerlab.pilot", "steerlab.data.readers", "steerlab.sim.road.suite", "steerlab.sim.track.suite",
                 "steerlab.sim.road.run", "steerlab.sim.track.run", "optuna", "matplotlib.pyplot"):
        try:
            importlib.import_module(name)
        except ImportError:
            pass


def parser():
    p = script_parser(__spec__.name, __doc__, RoundOptions)
    path_option(p, "out_dir", kind="folder", metavar="OUT_DIR", help="the round's folder (a new one, or an earlier "
                "round's)")
    return p


def begin(out_dir) -> None:
    """The round's folders under `out_dir` (a new one or an earlier round's), emptied, and its fixtures made."""
    import torch

    places.place(out_dir)
    torch.set_num_threads(1)  # no OpenMP thread team in this process: a forked child using one would hang
    if places.ROOT.exists() and not (places.ROOT / "fx").is_dir():
        raise SteerlabError(f"{places.ROOT} exists and is not an earlier round's folder (it has no fx/): name a new "
                            "one")
    preload()
    subprocess.run(["chattr", "-i", str(places.ROOT / "ro")], capture_output=True)
    shutil.rmtree(places.ROOT, ignore_errors=True)
    setup()


TABLES = {1: "tests.rounds.round1", 2: "tests.rounds.round2", 3: "tests.rounds.round3"}  # each round's table of cases


def _call(spec: str, table):
    """A row's callable: `module:name` of the build tried, or a builder of the table (`name`)."""
    import importlib

    if ":" in spec:
        module, name = spec.split(":")
        return getattr(importlib.import_module(module), name)
    return getattr(table, spec)


def case_of(row: dict, table) -> dict:
    """The case of a row of `table`: {name, group, fn, expect, hint, after, ...}, its paths filled (places.fill).
    A row runs one of: `cli` (a command line, through steerlab.cli.main), `api` (a call of the Python API or a
    builder, with `args` and `kwargs`, whose return value is no exit code), `build` (a builder of the table, with
    `kwargs`, that returns the command's exit code); `expect` is refuse (the default), ok or warn, `hint` what the
    one line must name; `stage`, `timeout`, `refuse_ok` and `after` as `run_case`, `main` and `classify` read them."""
    extra = {k: v for k, v in row.items() if k in ("timeout", "refuse_ok")}
    if "cli" in row:
        argv = [str(a) for a in places.fill(row["cli"])]

        def fn(a=argv):
            from steerlab.cli import main as m
            return m(a)
        name = row.get("name", " ".join(argv))
    else:
        call = _call(row.get("api") or row["build"], table)
        args, kwargs = places.fill(tuple(row.get("args", ()))), places.fill(row.get("kwargs", {}))
        fn = (lambda: (call(*args, **kwargs), 0)[1]) if "api" in row else (lambda: call(*args, **kwargs))
        name = row["name"]
    fn.stage = row.get("stage", False)
    after = row.get("after")
    return {"name": places.fill(name), **({"group": row["group"]} if "group" in row else {}), "fn": fn,
            "expect": row.get("expect", "refuse"), "hint": places.fill(row.get("hint")),
            "after": after and _call(after, table), **extra}


def cases(table) -> list[dict]:
    """Every case of a round's table: its rows in order, a row `{"sweep": NAME}` standing for the rows its builder
    `NAME()` makes (a sweep of the build's own options)."""
    out = []
    for row in table.CASES:
        rows = _call(row["sweep"], table)() if "sweep" in row else [row]
        out += [case_of(r, table) for r in rows]
    return out


def prepare(round: int, out_dir):
    """The round's folders and fixtures made (`begin`, then the table's own `setup`), and its cases."""
    import importlib

    begin(out_dir)
    table = importlib.import_module(TABLES[round])
    if hasattr(table, "setup"):
        table.setup()
    return table, cases(table)


def main(a, o: RoundOptions):
    global TIMEOUT
    table, cases = prepare(o.round, a.out_dir)
    counts, bad, start = Counter(), [], time.monotonic()
    for n, case in enumerate(cases):
        if n % 50 == 0:
            print(f"{n}/{len(cases)} ({time.monotonic() - start:.0f} s)", file=sys.stderr, flush=True)
        before = snapshot()
        TIMEOUT = case.get("timeout", 45)  # an interrupted run and its rerun: two commands' start-up
        result = run_case(case["fn"])
        after = snapshot()
        cls = classify(case, result, before, after)
        if cls == "silent-refusal":
            cls = "handled"  # refused though acceptable: a stricter build; counted as handled
        if cls == "handled" and case.get("after"):
            cls = case["after"]() or cls  # what the case checks on disk afterwards (an output it must keep)
        counts[cls] += 1
        if cls != "handled":
            code, err, exc, *_ = result
            said = (exc.strip().splitlines() or [""])[-1][:300] if exc else err.strip()[-300:]
            bad.append(f"{cls:<10} [{case.get('group', '-')}] {case['name'][:200]}\n           {said}")
        if cls == "lost":  # put the fixtures back for the next case
            shutil.rmtree(places.FIX)
            setup()
            if hasattr(table, "setup"):
                table.setup()
    groups = Counter(case.get("group", "-") for case in cases)
    print(f"{len(cases)} inputs ({', '.join(f'{g} {k}' for g, k in groups.items())}) in "
          f"{time.monotonic() - start:.0f} s: " + ", ".join(f"{k} {v}" for k, v in counts.most_common()))
    (places.ROOT / "failures.txt").write_text("\n".join(bad) + "\n")
    print("\n".join(bad))


if __name__ == "__main__":
    run_script(parser(), main)
