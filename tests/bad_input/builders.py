"""What the bad-input tests of tests/bad_input/ share: the tiny config and the checkpoint trained on it, the
builders of the cases their BAD_INPUTS tables hold and the check each case passes (`refused_in_one_line`), the
files of a folder, the edges of a declared range, every command's parser, a damaged file's variants."""

import contextlib
import json
import os
from pathlib import Path

from steerlab.cli import main
from tests.inputs import made, sim_log, tub


def tear(path, line, text):
    """Replace line `line` (1-based) of a text file by `text` (no line end added when it is the last line)."""
    lines = path.read_text().splitlines(keepends=True)
    lines[line - 1] = text
    path.write_text("".join(lines))


def config(tmp_path, data, **train):
    cfg = tmp_path / "c.yaml"
    cfg.write_text(f"data: {data}\ncache: {tmp_path / 'cache'}\nout: {tmp_path / 'run'}\n"
                   f"split: {{train: '0:6', val: '6:8'}}\n"
                   f"train: {json.dumps({'epochs': 1, 'batch_size': 2, **train})}\n")
    return cfg


def trained(tmp_path):
    """A real checkpoint, trained for an epoch on the tiny driving log."""
    log = sim_log(tmp_path / "sim")
    assert main(["train", str(config(tmp_path, log))]) == 0
    return tmp_path / "run" / "best.pt"


def _files(folder):
    return {p: p.stat().st_mtime_ns for p in folder.rglob("*") if p.is_file()}


# ---------------------------------------------------------------- the cases
# each case of a BAD_INPUTS table (the rule files of tests/bad_input/): a function (tmp_path, stack) -> the command's
# arguments, after it wrote the inputs (`stack`, a contextlib.ExitStack, holds what must last while the command
# runs), and the message's substring; a third item names the folders a refused command may still write to

def refused_in_one_line(case, tmp_path, capsys):
    """A case of a BAD_INPUTS table, run by the real command: refused with exit code 2 and a one-line message that
    holds the case's, no traceback, nothing lost, nothing written."""
    command, message, *written = case
    with contextlib.ExitStack() as stack:
        argv = command(tmp_path, stack)
        capsys.readouterr()
        before = _files(tmp_path)
        code = main(argv)
        after = _files(tmp_path)
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.startswith("error: ") and err.count("\n") == 1 and "Traceback" not in err, err
    assert message in err, err
    # nothing lost: every file is there, unchanged; nothing written (a diverged run: its log, no checkpoint)
    assert {p: t for p, t in after.items() if p in before} == before
    new = {p.relative_to(tmp_path).as_posix() for p in set(after) - set(before)}
    assert not {p for p in new if not p.startswith(tuple(written[0] if written else ()))}, new
    assert not {p for p in new if p.endswith(".pt") or ".tmp-" in p}, new
    assert not (tmp_path / "ran").exists()  # no code ran from a checkpoint


def _compile(data, *reader):
    return lambda tmp_path, stack: ["compile", "--data", str(data(tmp_path)), "--cache", str(tmp_path / "cache"),
                             *[a for r in reader for a in ("--reader", r)]]


def _train(*overrides):
    return lambda tmp_path, stack: ["train", str(config(tmp_path, sim_log(tmp_path / "sim"))), *overrides]


def _with(*argv, command="sim bench"):
    """`command` with a checkpoint (driving_log data for replay) and the options `argv`."""
    def build(tmp_path, stack):
        ckpt = str(made(tmp_path))
        data = ["--data", str(sim_log(tmp_path / "sim"))] if command == "replay" else []
        return [*command.split(), ckpt, *data, "--out", str(tmp_path / "out"), *argv]
    return build


def _tune_storage(storage, heartbeat=None):
    """`steerlab tune` of a one-parameter space into `storage` (a URL), with STEERLAB_TUNE_HEARTBEAT set if given."""
    def build(tmp_path, stack):
        cfg = config(tmp_path, sim_log(tmp_path / "sim"))
        cfg.write_text(cfg.read_text() + "tune: {train.lr: {low: 1.0e-5, high: 0.1, log: true}}\n")
        if heartbeat is not None:
            old = os.environ.get("STEERLAB_TUNE_HEARTBEAT")
            os.environ["STEERLAB_TUNE_HEARTBEAT"] = heartbeat
            stack.callback(lambda: os.environ.pop("STEERLAB_TUNE_HEARTBEAT") if old is None
                           else os.environ.update(STEERLAB_TUNE_HEARTBEAT=old))
        return ["tune", str(cfg), "--trials", "1", "--study", "s", "--storage", storage.format(tmp=tmp_path)]
    return build


def _renamed_column(tmp_path):
    """A steerlab recording whose log.csv calls its steering column 'steer'."""
    from steerlab.sim.road.run import record
    from steerlab.sim.road.world import RecordOptions

    out = record(tmp_path / "rec", RecordOptions(minutes=0.005, side_cameras=False), progress=False)
    log = out / "log.csv"
    log.write_text(log.read_text().replace(",steering,", ",steer,", 1))
    return out


def _tune_space(space):
    def build(tmp_path, stack, rows=None):
        cfg = config(tmp_path, sim_log(tmp_path / "sim", rows))
        cfg.write_text(cfg.read_text() + f"tune: {json.dumps(space)}\n")
        return ["tune", str(cfg), "--trials", "1", "--storage", str(tmp_path / "s.journal")]
    return build


def _calibration(tmp_path, calibration) -> list[str]:
    """`--calibration calib.json` with the content `calibration` (text, or a mapping as JSON); none for None."""
    if calibration is None:
        return []
    path = tmp_path / "calib.json"
    path.write_text(calibration if isinstance(calibration, str) else json.dumps(calibration))
    return ["--calibration", str(path)]


def _track(command, *argv, calibration=None):
    """`sim COMMAND --world track` with an untrained donkeycar checkpoint (drive, bench) or none (record), the
    options `argv` and, given its content, a calibration file `calib.json`."""
    def build(tmp_path, stack):
        args = [] if command == "record" else [str(made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25))]
        args += _calibration(tmp_path, calibration)
        return ["sim", command, *args, "--world", "track", "--out", str(tmp_path / "out"), *argv]
    return build


def _tub_replay(*argv, calibration=None, records=None, metadata=None):
    """`replay` of an untrained donkeycar checkpoint on the tiny tub (its `records` changed, and its manifest's
    metadata replaced by `metadata`), with the options `argv` and, given its content, a calibration file."""
    def build(tmp_path, stack):
        folder = tub(tmp_path / "tub", records)
        if metadata is not None:
            tear(folder / "manifest.json", 3, json.dumps(metadata) + "\n")
        ckpt = made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25)
        return ["replay", str(ckpt), "--data", str(folder), "--reader", "full_lock_deg=25", "--out",
                str(tmp_path / "out"), *_calibration(tmp_path, calibration), *argv]
    return build


def _a_range(key: str, check):
    """A number's option declares its range (`options.Range`): the sweeps take their cases from it, so an option
    without one, or whose range is deleted, fails here rather than going untested."""
    from steerlab.options import Range

    assert isinstance(check, Range), f"{key} is a number and declares no range (options.Range) to be checked against"
    return check


def _edges(check, kind):
    """Values just outside a range (refused), its ends (taken when closed), a wrong type, and non-finite ones."""
    lo, hi = check.lo, check.hi
    step = 1 if kind is int else 1e-6
    values = [("abc", False), (True, False), ([1], False)]
    if kind is float:
        values += [("nan", False), ("inf", False)]
    if lo is not None:
        values += [(lo - step, False), (kind(lo), not check.lo_open)]
    if hi is not None:
        values += [(hi + step, False), (kind(hi), not check.hi_open)]
    if kind is int:
        values.append((1.5, False))
    return values


def _command_parsers():
    """(command, its parser) of every command, `sim`'s subcommands each on its own."""
    from steerlab.cli import build_parser

    for name, parser in build_parser()._subparsers._group_actions[0].choices.items():
        yield from ([(f"{name} {n}", p) for n, p in parser._subparsers._group_actions[0].choices.items()]
                    if parser._subparsers else [(name, parser)])


def _says_what_it_is(path: Path, err: str) -> bool:
    """Whether a refusal of a device or a link to nothing says what the path is (not "file exists", "is a file"),
    or the name a file of the output's kind must have."""
    if "must end in" in err:
        return True
    if path.is_symlink() and not path.exists():
        return "a symbolic link to " in err
    return "a device" in err if str(path).startswith("/dev/") else True


def _damaged(data: bytes):
    """One byte flipped at several offsets, and the file cut off at several lengths."""
    n = len(data)
    for offset in (0, 7, n // 7, n // 3, n // 2, 2 * n // 3, n - 90, n - 30, n - 1):
        flipped = bytearray(data)
        flipped[offset] ^= 0xFF
        yield f"byte {offset} flipped", bytes(flipped)
    for length in (0, 20, n // 2, n - 64, n - 1):
        yield f"cut at {length}", data[:length]
