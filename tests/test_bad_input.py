"""Every bad input a user can give is refused by the real command with exit code 2 and a one-line message that
names the file, row or option and what was expected; no traceback, nothing written, nothing lost. Each case
is one entry of BAD_INPUTS, so that the list only ever grows."""

import argparse
import contextlib
import functools
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from conftest import flip_bytes
from steerlab.cli import main
from steerlab.errors import SteerlabError
from steerlab.options import WORKERS
from tests.inputs import ROWS, ch2, made, sim_log, tub, write_jpeg

def _renamed(catalog, key, other):
    """The first record of a tub catalog with `key` named `other` (as long: the manifest's line lengths hold)."""
    lines = catalog.read_text().splitlines(keepends=True)
    lines[0] = lines[0].replace(f'"{key}"', f'"{other}"')
    catalog.write_text("".join(lines))
    return catalog.parent


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


# ---------------------------------------------------------------- the cases
# each case: a function (tmp_path, stack) -> the command's arguments, after it wrote the inputs (`stack`, a
# contextlib.ExitStack, holds what must last while the command runs), and the message's substring

def _compile(data, *reader):
    return lambda tmp_path, stack: ["compile", "--data", str(data(tmp_path)), "--cache", str(tmp_path / "cache"),
                             *[a for r in reader for a in ("--reader", r)]]


def _train(*overrides):
    return lambda tmp_path, stack: ["train", str(config(tmp_path, sim_log(tmp_path / "sim"))), *overrides]


def _dagger_of_another_config(tmp_path, stack):
    """A DAgger folder that holds a run of other settings: reusing its rollouts would be silent garbage."""
    cfg = config(tmp_path, sim_log(tmp_path / "sim"))
    (tmp_path / "run" / "round0").mkdir(parents=True)
    (tmp_path / "run" / "dagger.json").write_text(json.dumps({"dagger": {"minutes": 9}}))
    return ["sim", "dagger", str(cfg)]


def _flipped(tmp_path, stack):
    best = flip_bytes(trained(tmp_path))
    return ["evaluate", str(best), "--data", str(tmp_path / "sim"), "--out", str(tmp_path / "eval")]


def _flipped_before_seals(tmp_path, stack):
    """A checkpoint of steerlab 0.1.0 (no seal; the sha256 of its weights inside) with damaged weights."""
    old = tmp_path / "old.pt"
    shutil.copy(Path(__file__).parent / "fixtures" / "run-0.1.0" / "best.pt", old)
    return ["evaluate", str(flip_bytes(old)), "--data", str(sim_log(tmp_path / "sim")), "--out", str(tmp_path / "eval")]


class _Code:
    """A pickled object that runs a command when unpickled without weights_only."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return os.system, (f"touch {self.marker}",)


def _code_in_checkpoint(tmp_path, stack):
    import torch

    path = tmp_path / "evil.pt"
    torch.save({"format": "steerlab-checkpoint-1", "state_dict": {}, "hook": _Code(tmp_path / "ran")}, path)
    sim_log(tmp_path / "sim")
    return ["evaluate", str(path), "--data", str(tmp_path / "sim"), "--out", str(tmp_path / "eval")]


def _truncated(path):
    """A checkpoint cut off after its first kilobyte (a copy that did not finish)."""
    path.write_bytes(path.read_bytes()[:1000])
    return path


def _locked(tmp_path, stack):
    """`out` is held by another run (here: the lock taken by this process, on another open file)."""
    from steerlab.locks import folder_lock

    (tmp_path / "run").mkdir()
    stack.enter_context(folder_lock(tmp_path / "run", "steerlab train run"))
    return _train()(tmp_path, stack)


def _evaluate_on_ch2(**convention):
    def command(tmp_path, stack):
        data = ch2(tmp_path / "ch2")
        return ["evaluate", str(made(tmp_path, **convention)), "--data", str(data), "--labels",
                str(data / "labels.csv"), "--out", str(tmp_path / "eval")]
    return command


def _serve(**convention):
    return lambda tmp_path, stack: ["serve", str(made(tmp_path, **convention)), "--port", "4599"]


def _with(*argv, command="sim bench"):
    """`command` with a checkpoint (driving_log data for replay) and the options `argv`."""
    def build(tmp_path, stack):
        ckpt = str(made(tmp_path))
        data = ["--data", str(sim_log(tmp_path / "sim"))] if command == "replay" else []
        return [*command.split(), ckpt, *data, "--out", str(tmp_path / "out"), *argv]
    return build


def _flipped_onnx(tmp_path, stack):
    from steerlab.export import export_onnx

    onnx = flip_bytes(export_onnx(made(tmp_path), tmp_path / "m.onnx"))
    return ["evaluate", str(onnx), "--data", str(sim_log(tmp_path / "sim")), "--out", str(tmp_path / "eval")]


def _exported(tmp_path):
    from steerlab.export import export_onnx

    return export_onnx(made(tmp_path), tmp_path / "m.onnx")


def _onnx_metadata(change):
    """An exported model whose metadata_props `change(props)` edits (a dict key -> value), then evaluated."""
    def command(tmp_path, stack):
        import onnx

        from steerlab.export import export_onnx

        path = export_onnx(made(tmp_path), tmp_path / "m.onnx")
        proto = onnx.load(path)
        props = {e.key: e.value for e in proto.metadata_props}
        change(props)
        del proto.metadata_props[:]
        for key, value in props.items():
            proto.metadata_props.add(key=key, value=value)
        onnx.save(proto, path)
        return ["evaluate", str(path), "--data", str(sim_log(tmp_path / "sim")), "--out", str(tmp_path / "eval")]
    return command


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


def _flat_ch2_replay(tmp_path, stack):
    """5 s of CH2-layout frames of one grey (no speed recorded, no texture to estimate it from), no --speed."""
    (tmp_path / "flat" / "center").mkdir(parents=True)
    ids = [1_000_000_000 + i * 50_000_000 for i in range(100)]
    for fid in ids:
        cv2.imwrite(str(tmp_path / "flat" / "center" / f"{fid}.jpg"), np.full((480, 640, 3), 90, np.uint8))
    (tmp_path / "flat" / "labels.csv").write_text("frame_id,steering_angle,public\n"
                                                  + "".join(f"{fid},0.0,1\n" for fid in ids))
    return ["replay", str(made(tmp_path, "steering_wheel", "left", "ch2")), "--data", str(tmp_path / "flat"),
            "--labels", str(tmp_path / "flat" / "labels.csv"), "--out", str(tmp_path / "out")]


def _corrupt_frame_replay(tmp_path, stack):
    """The flat CH2 frames with one JPEG cut off in the middle of the drive, at a given speed."""
    argv = _flat_ch2_replay(tmp_path, stack)
    frame = sorted((tmp_path / "flat" / "center").glob("*.jpg"))[50]
    frame.write_bytes(frame.read_bytes()[:300])
    return [*argv, "--speed", "10"]


def _renamed_column(tmp_path):
    """A steerlab recording whose log.csv calls its steering column 'steer'."""
    from steerlab.sim.road.run import record
    from steerlab.sim.road.world import RecordOptions

    out = record(tmp_path / "rec", RecordOptions(minutes=0.005, side_cameras=False), progress=False)
    log = out / "log.csv"
    log.write_text(log.read_text().replace(",steering,", ",steer,", 1))
    return out


def _corrupt_frame(command):
    """`steerlab COMMAND` of a config whose driving log has one frame that is no image."""
    def build(tmp_path, stack):
        cfg = config(tmp_path, sim_log(tmp_path / "sim"))
        sorted((tmp_path / "sim" / "IMG").glob("*.jpg"))[3].write_text("garbage")
        if command == "experiment":
            cfg.write_text(cfg.read_text() + "models:\n  - {model: {name: pilotnet}}\n")
        return [command, str(cfg)]
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


def _stats_changed(tmp_path, stack):
    """One stored value changed in a sealed checkpoint (the first channel's mean, as a flipped bit would): its bytes
    no longer match the sha256 sealed with them."""
    import io

    import torch

    from steerlab.checkpoint import SEAL

    best = trained(tmp_path)
    seal = best.read_bytes()[-2 - len(SEAL) - 64:]  # the zip comment: its length, the seal and the digest
    ckpt = torch.load(best, weights_only=True)
    ckpt["stats"]["mean"][0] = 4.52
    buffer = io.BytesIO()
    torch.save(ckpt, buffer)
    best.write_bytes(buffer.getvalue()[:-2] + seal)
    return ["evaluate", str(best), "--data", str(tmp_path / "sim"), "--out", str(tmp_path / "eval")]


def _stats_changed_before_seals(tmp_path, stack):
    """The same in a checkpoint as steerlab wrote it before seals: no seal, the sha256 of its contents inside."""
    import torch

    from steerlab.checkpoint import content_hash

    best = trained(tmp_path)
    ckpt = torch.load(best, weights_only=True)
    ckpt["content_sha256"] = content_hash(ckpt)
    ckpt["stats"]["mean"][0] = 4.52
    torch.save(ckpt, best)
    return ["evaluate", str(best), "--data", str(tmp_path / "sim"), "--out", str(tmp_path / "eval")]


def _fifo_labels(tmp_path, stack):
    folder = ch2(tmp_path / "ch2")
    os.mkfifo(tmp_path / "fifo.csv")
    return ["compile", "--data", str(folder), "--labels", str(tmp_path / "fifo.csv"), "--cache", str(tmp_path / "c")]


def _a_file(tmp_path):
    (tmp_path / "afile").write_text("")
    return tmp_path / "afile"


def _tub_manifest(deleted):
    """A tub whose manifest's deleted_indexes is `deleted` (strings, null, not a list...)."""
    def data(t):
        folder = tub(t / "tub")
        lines = (folder / "manifest.json").read_text().splitlines()
        catalog = json.loads(lines[4])
        catalog["deleted_indexes"] = deleted
        lines[4] = json.dumps(catalog)
        (folder / "manifest.json").write_text("\n".join(lines) + "\n")
        return folder
    return data


def _ch2_with_odd_frame(size):
    """A CH2 folder whose fourth frame is of another size than the recording's."""
    def build(tmp_path, stack):
        folder = ch2(tmp_path / "ch2")
        write_jpeg(sorted((folder / "center").glob("*.jpg"))[3], 10, size)
        return ["compile", "--data", str(folder), "--cache", str(tmp_path / "cache")]
    return build


def _two_of(command):
    """`command` with the same checkpoint named twice by absolute paths."""
    def build(tmp_path, stack):
        ckpt = made(tmp_path).resolve()
        data = ["--data", str(sim_log(tmp_path / "sim"))] if command == "replay" else []
        return [*command.split(), str(ckpt), str(tmp_path / "." / "model.pt"), *data, "--out", str(tmp_path / "out")]
    return build


def _teacher(make):
    """train.teacher naming what `make(tmp_path)` writes."""
    return lambda t, s: _train(f"train.teacher={make(t)}")(t, s)


def _pickled(tmp_path):
    import pickle

    path = tmp_path / "plain.pt"
    path.write_bytes(pickle.dumps({"weights": [1.0, 2.0]}))
    return path


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


CALIBRATION = {"image_size": [160, 120], "K": [[81.0, 0.0, 80.0], [0.0, 80.0, 61.0], [0.0, 0.0, 1.0]],
               "D": [-0.02, -0.01, 0.0, 0.005]}

BAD_INPUTS = {
    # a) recorded values outside their physical range, with file and row
    "sim steering 3.5": (_compile(lambda t: sim_log(t / "sim", {2: "3.5,0.5,0,10"})),
                         "driving_log.csv, row 3: column 'steering' is 3.5; a number in [-1, 1] is expected"),
    "sim steering -7": (_compile(lambda t: sim_log(t / "sim", {0: "-7,0.5,0,10"})),
                        "driving_log.csv, row 1: column 'steering' is -7; a number in [-1, 1]"),
    "sim speed -40": (_compile(lambda t: sim_log(t / "sim", {4: "0,0.5,0,-40"})),
                      "row 5: column 'speed' is -40; a number of at least 0 (mph) is expected"),
    "sim throttle 7": (_compile(lambda t: sim_log(t / "sim", {1: "0,7,0,10"})),
                       "row 2: column 'throttle' is 7; a number in [0, 1] is expected"),
    "tub angle 1.5": (_compile(lambda t: tub(t / "tub", {3: {"user/angle": 1.5}})),
                      "catalog_0.catalog, row 4: record 3: user/angle is 1.5; a number in [-1, 1] is expected"),
    "tub throttle 7": (_compile(lambda t: tub(t / "tub", {5: {"user/throttle": 7}})),
                       "catalog_0.catalog, row 6: record 5: user/throttle is 7; a number in [-1, 1]"),
    # b) torn lines: read past with a warning, unless the reader is strict; a bad middle line stays an error
    "tub torn line, strict": (_compile(lambda t: (tear(tub(t / "tub") / "catalog_0.catalog", 4, "\0" * 60 + "\n"),
                                                  t / "tub")[1], "strict=true"),
                              "catalog_0.catalog, row 4: a torn line"),
    "sim torn last line, strict": (_compile(lambda t: (tear(sim_log(t / "sim"), ROWS, "/elsewhere/IMG/cen"),
                                                       t / "sim")[1], "strict=true"),
                                   f"driving_log.csv, row {ROWS}: expected at least 7 columns"),
    "sim torn middle line": (_compile(lambda t: (tear(sim_log(t / "sim"), 3, "/elsewhere/IMG/cen\n"),
                                                 t / "sim")[1]),
                             "driving_log.csv, row 3: expected at least 7 columns"),
    # d) options checked for type and range when the config is read, before the dataset compiles
    **{f"train {o}": (_train(o), f"{o.split('=')[0]} must be {expected}, got {got}") for o, expected, got in [
        ("train.lr=nan", "a positive finite number", "'nan'"),
        ("train.lr=-1", "a positive finite number", "-1"),
        ("train.lr=fast", "a positive finite number", "'fast'"),
        ("train.lr=inf", "a positive finite number", "'inf'"),
        ("train.epochs=-1", "an integer of at least 1 (at most 1000000)", "-1"),
        ("train.epochs=0", "an integer of at least 1 (at most 1000000)", "0"),
        ("train.epochs=abc", "an integer of at least 1 (at most 1000000)", "'abc'"),
        ("train.epochs=1.5", "an integer of at least 1 (at most 1000000)", "1.5"),
        ("train.batch_size=0", "an integer of at least 1 (at most 1000000)", "0"),
        ("train.batch_size=ten", "an integer of at least 1 (at most 1000000)", "'ten'"),
        ("model.dropout=2", "a number in [0, 1)", "2"),
        ("train.loss=l2", "mse or mae", "'l2'"),
        ("train.keep=first", "best or last", "'first'"),
        ("train.smoothness=-0.5", "a finite number of at least 0", "-0.5"),
    ]},
    "sim dagger into another config's folder": (_dagger_of_another_config,
                                                "run holds a DAgger run whose dagger.json this steerlab cannot read "
                                                "(SteerlabError); choose a new out"),
    "sim dagger with a suite road type that does not exist": (
        lambda t, s: ["sim", "dagger", str(config(t, sim_log(t / "sim"))), "dagger.suite_roads=twisty,mountain"],
        "dagger.suite_roads must be a comma list of road types of country, highway, twisty, each once, got "
        "'twisty,mountain'"),
    "sim dagger in the track world on a road recording": (
        lambda t, s: ["sim", "dagger", str(config(t, sim_log(t / "sim"))), "dagger.world=track", "dagger.suite=t1"],
        "dagger.world: track renders the donkey camera, and"),
    "sim dagger in the track world with a road suite": (
        lambda t, s: ["sim", "dagger", str(config(t, tub(t / "tub"))), "dagger.world=track", "dagger.suite=v1"],
        "dagger.suite: v1 is a road suite; world track drives a track suite (t1, s1, t2) or none (null)"),
    "sim dagger in the track world with a track style that does not exist": (
        lambda t, s: ["sim", "dagger", str(config(t, tub(t / "tub"))), "dagger.world=track", "dagger.suite=t1",
                      "dagger.suite_styles=gravel"],
        "dagger.suite_styles must be a comma list of track styles of taped, centre, each once, got 'gravel'"),
    "sim dagger in replay on a tub without its full-lock angle": (
        lambda t, s: ["sim", "dagger", str(config(t, tub(t / "tub"))), "dagger.world=replay"],
        "tub: replay cannot turn its steering into a wheel angle: normalized steering needs the car's full-lock angle"),
    "sim dagger in the track world with zero rollout minutes": (
        lambda t, s: ["sim", "dagger", str(config(t, tub(t / "tub"))), "dagger.world=track", "dagger.suite=t1",
                      "dagger.minutes=0"],
        "dagger.minutes must be a number in (0, 1440] min, got 0"),
    "track recipe on tubs of another camera": (
        lambda t, s: ["train", str(config(t, sim_log(t / "sim"))), "preprocess.preset=donkey"],
        "holds frames of the 'sim' camera; the config's preprocess.preset donkey is for the 'donkey' camera"),
    "track recipe whose tubs were not recorded": (
        lambda t, s: ["train", str(config(t, t / "tubs" / "taped-1"))], "taped-1: recording not found"),
    "sim dagger in the track world with an option of the road world": (
        lambda t, s: ["sim", "dagger", str(config(t, tub(t / "tub"))), "dagger.world=track", "dagger.suite=t1",
                      "dagger.suite_roads=taped"],
        "dagger.suite_roads is an option of dagger.world road; dagger.world track does not take it"),
    "sim dagger in replay with a suite": (
        lambda t, s: ["sim", "dagger", str(config(t, sim_log(t / "sim"))), "dagger.world=replay", "dagger.suite=v1"],
        "dagger.suite is an option of dagger.world road and track; dagger.world replay does not take it"),
    "sim dagger on roads with a tub": (lambda t, s: ["sim", "dagger", str(config(t, tub(t / "tub")))],
                                       "holds 'donkey' frames: choose world track"),
    "an override whose value is not YAML": (_train("train.lr=,"), "override 'train.lr=,': the value is not valid YAML "
                                                               "(expected the node content, but found ','); quote "
                                                               "it: train.lr='\",\"'"),
    "sim dagger with no suite road type": (
        lambda t, s: ["sim", "dagger", str(config(t, sim_log(t / "sim"))), 'dagger.suite_roads=","'],
        "dagger.suite_roads must be a comma list of road types of country, highway, twisty, each once, got ','"),
    # smoothness in the loss needs windows of consecutive frames
    "train smoothness of a single-frame model": (_train("train.smoothness=1", "model.name=pilotnet"),
                                                 "train.smoothness needs a recurrent model"),
    # the hue turns RGB colours only
    "train hue of a gray input": (_train("train.hue_deg=90", "preprocess.color=gray"),
                                  "train.hue_deg turns the hue of RGB inputs; preprocess.color is gray"),
    # d) a loss that is not finite stops training and never becomes the best checkpoint
    "train diverges": (_train("train.lr=1e30", "train.epochs=2"), "training diverged in epoch 1: the training loss is",
                       ("run/", "cache/")),
    # pretraining (train.init): a checkpoint that is not there, or of another camera geometry
    "train init missing": (lambda t, s: _train(f"train.init={t / 'pretrained.pt'}")(t, s),
                           "pretrained.pt: checkpoint not found"),
    "train init of another geometry": (lambda t, s: _train(f"train.init={made(t, geometry='ch2')}")(t, s),
                                       "model.pt: train.init was trained on the 'ch2' camera geometry and ",
                                       ("run/", "cache/")),  # known once the data is compiled (kept for reuse)
    # distillation (train.teacher): a checkpoint that is not there, or that predicts in other units
    "train teacher missing": (lambda t, s: _train(f"train.teacher={t / 'teacher.pt'}")(t, s),
                              "teacher.pt: checkpoint not found"),
    "train teacher of another convention": (
        lambda t, s: _train(f"train.teacher={made(t, 'steering_wheel', 'left')}")(t, s),
        "model.pt: train.teacher predicts steering_wheel/left steering and ", ("run/", "cache/")),
    # ensembles: members that the Pilot would run differently
    "ensemble of mixed conventions": (lambda t, s: ["ensemble", str(made(t, name="a.pt")),
                                                    str(made(t, "normalized", "right", name="b.pt")), "--out",
                                                    str(t / "e.pt")], "a.pt differ in steering convention ("),
    "ensemble of two geometries": (lambda t, s: ["ensemble", str(made(t, name="a.pt")),
                                                 str(made(t, geometry="ch2", name="b.pt")), "--out", str(t / "e.pt")],
                                   "a.pt differ in camera geometry (ch2 and sim): an ensemble averages models of one "
                                   "camera geometry"),
    "ensemble to a file not .pt": (lambda t, s: ["ensemble", str(made(t, name="a.pt")), str(made(t, name="b.pt")),
                                                 "--out", str(t / "e.onnx")],
                                   "e.onnx: the ensemble is a checkpoint: its file must end in .pt"),
    "ensemble with a truncated member": (lambda t, s: ["ensemble", str(made(t, name="a.pt")),
                                                       str(_truncated(made(t, name="b.pt"))), "--out", str(t / "e.pt")],
                                         "b.pt: not a readable checkpoint"),
    "ensemble of one": (lambda t, s: ["ensemble", str(made(t)), "--out", str(t / "e.pt")],
                        "an ensemble needs at least two checkpoints"),
    # e) a second run into the same out folder
    "train out in use": (_locked, f"run is in use by another steerlab train run (pid {os.getpid()})"),
    # f) checkpoints: damaged, or holding code
    "checkpoint flipped bytes": (_flipped, "best.pt: the file's bytes do not match the sha256 stored with them"),
    "checkpoint of 0.1.0 flipped bytes": (_flipped_before_seals, "old.pt: the weights do not match the checkpoint's "
                                                                 "sha256: the file is damaged"),
    "checkpoint that is a text file": (lambda t, s: (t / "notes.pt").write_text("not a zip\n") and
                                       ["export", str(t / "notes.pt"), "--out", str(t / "m.onnx")],
                                       "notes.pt: not a readable checkpoint (not the zip file torch.save writes)"),
    "checkpoint with code": (_code_in_checkpoint, "evil.pt: the checkpoint holds objects other than tensors and "
                                                  "plain values (posix.system)"),
    "onnx flipped bytes": (_flipped_onnx, "m.onnx: the model does not match the sha256 in its metadata: the file "
                                          "is damaged"),
    "onnx metadata edited": (_onnx_metadata(lambda m: m.update(steerlab=m["steerlab"].replace('"sim"', '"ch2"'))),
                             "m.onnx: the model does not match the sha256 in its metadata"),
    "onnx without steerlab metadata": (_onnx_metadata(dict.clear),
                                       "m.onnx: no steerlab metadata in the model: not written by steerlab export"),
    "export to a file not .onnx": (lambda t, s: ["export", str(made(t)), "--out", str(t / "m.bin")],
                                   "m.bin: the export file must end in .onnx"),
    "export int8 without calibration data": (lambda t, s: ["export", str(made(t)), "--out", str(t / "m.onnx"),
                                                           "--int8"], "--int8 needs calibration data: --calib"),
    "export int8 calibration data missing": (lambda t, s: ["export", str(made(t)), "--out", str(t / "m.onnx"),
                                                           "--int8", "--calib", str(t / "nothere")],
                                             "nothere: recording not found"),
    "export int8 calibration range inverted": (lambda t, s: ["export", str(made(t)), "--out", str(t / "m.onnx"),
                                                             "--int8", "--calib", str(sim_log(t / "sim")),
                                                             "--calib-range", "5:2"],
                                               "driving_log.csv: frame range 5:2 is empty: START must be below STOP"),
    # g) steering conventions where a checkpoint meets data or the simulator
    "evaluate simulator checkpoint on CH2": (_evaluate_on_ch2(), "model.pt predicts road_wheel/right steering and "),
    "evaluate donkeycar checkpoint on CH2": (_evaluate_on_ch2(kind="normalized", geometry="donkey"),
                                             "records steering_wheel/left steering: the metrics would mix units; "),
    "serve donkeycar checkpoint": (_serve(kind="normalized", geometry="donkey"),
                                   "model.pt cannot drive the simulator: it predicts normalized steering without "
                                   "a full-lock angle"),
    "serve CH2-cropped checkpoint": (_serve(kind="steering_wheel", positive="left", geometry="ch2"),
                                     "model.pt cannot drive the simulator: crop (268, 0, 0, 0) removes the whole "
                                     "320x160 frame"),
    # h) options of the closed-loop commands, checked before anything drives
    "bench smoothing 5": (_with("--smoothing", "5"), "--smoothing must be a number in (0, 1], got 5"),
    "bench smoothing 0": (_with("--smoothing", "0"), "--smoothing must be a number in (0, 1], got 0"),
    "bench workers 0": (_with("--workers", "0"), f"--workers must be {WORKERS.words(int)}, got 0"),
    "bench workers -3": (_with("--workers", "-3"), f"--workers must be {WORKERS.words(int)}, got -3"),
    "bench minutes inf": (_with("--minutes", "inf"), "--minutes must be a number in (0, 1440] min, got inf"),
    "bench minutes nan": (_with("--minutes", "nan"), "--minutes must be a number in (0, 1440] min, got nan"),
    "drive smoothing 1.5": (_with("--smoothing", "1.5", command="sim drive"),
                            "--smoothing must be a number in (0, 1], got 1.5"),
    "drive minutes -inf": (_with("--minutes=-inf", command="sim drive"),
                           "--minutes must be a number in (0, 1440] min, got -inf"),
    "serve smoothing -1": (lambda t, s: ["serve", str(made(t)), "--smoothing", "-1"],
                           "--smoothing must be a number in (0, 1], got -1"),
    "replay workers 0": (_with("--workers", "0", command="replay"), f"--workers must be {WORKERS.words(int)}"),
    "replay smoothing 0": (_with("--smoothing", "0", command="replay"), "--smoothing must be a number in (0, 1], got 0"),
    "replay limit -1": (_with("--limit", "-1", command="replay"), "--limit must be a positive finite number, got -1"),
    "replay tub model without full lock": (
        lambda t, s: ["replay", str(made(t, "normalized", "right", "donkey")), "--data", str(tub(t / "tub")),
                      "--out", str(t / "out")],
        "model.pt: its steering cannot become a wheel angle: normalized steering needs the car's full-lock angle"),
    "replay max heading inf": (_with("--max-heading", "inf", command="replay"),
                               "--max-heading must be a number in (0, 90] degrees, got inf"),
    # j) closed-loop replay of a recording
    "replay too short": (_with(command="replay"), "driving_log.csv: too short to replay: no segment lasts 3 s"),
    "replay another camera": (lambda t, s: ["replay", str(made(t, "steering_wheel", "left", "ch2")), "--data",
                                            str(sim_log(t / "sim")), "--out", str(t / "out")],
                              "model.pt was trained on the 'ch2' camera geometry and"),
    "replay speed -3": (_with("--speed", "-3", command="replay"), "--speed must be a number in (0, 100] m/s, got -3"),
    "replay no speed to estimate": (_flat_ch2_replay, "cannot estimate the speed from the frames"),
    "replay corrupt frame": (_corrupt_frame_replay, ".jpg: cannot decode image (corrupt or not a JPEG/PNG)"),
    "train corrupt frame": (_corrupt_frame("train"), "_300.jpg: cannot decode image (corrupt or not a JPEG/PNG)",
                            ("run/", "cache/")),  # the run's config, written before the data is compiled
    "experiment corrupt frame": (_corrupt_frame("experiment"),
                                 "_300.jpg: cannot decode image (corrupt or not a JPEG/PNG)", ("run/", "cache/")),
    "replay missing recording": (lambda t, s: ["replay", str(made(t)), "--data", str(t / "nothere"), "--out",
                                               str(t / "out")], "nothere: recording not found"),
    # the replay of small cars (a tub: the track world's replay)
    "replay lane width 0": (_tub_replay("--lane-width", "0"), "--lane-width must be a number in (0.2, 2] m, wider than "
                                                          "the car's 0.2 m body, got 0"),
    "replay lane width narrower than the car": (_tub_replay("--lane-width", "0.15"),
                                                "--lane-width must be a number in (0.2, 2] m, wider than the "
                                                "car's 0.2 m body, got 0.15"),
    "replay tub speed nan": (_tub_replay("--speed", "nan"), "--speed must be a number in (0, 100] m/s, got nan"),
    "replay speed inf": (_with("--speed", "inf", command="replay"),
                         "--speed must be a number in (0, 100] m/s, got inf"),
    "replay calibration that does not parse": (_tub_replay(calibration="{not json"),
                                               "calib.json, row 1: not valid JSON"),
    "replay calibration of another image size": (
        _tub_replay(calibration={**CALIBRATION, "image_size": [640, 480]}),
        "calib.json: calibrated at 640x480, but the camera takes 160x120 frames"),
    "replay in an unknown world": (_tub_replay("--world", "moon"),
                                   "argument --world: invalid choice: 'moon' (choose from 'road', 'track')"),
    "replay a road recording in the track world": (_with("--world", "track", command="replay"),
                                                   "the track replay is for the donkey camera"),
    "replay a tub with a road option": (_tub_replay("--max-heading", "5"),
                                        "--max-heading is an option of the road world (--world road); the track "
                                        "world does not take it"),
    "replay a road recording with a track option": (_with("--lane-width", "0.5", command="replay"),
                                                    "--lane-width is an option of the track world (--world track)"),
    "replay the throttle of a model without one": (_tub_replay("--throttle", "model"),
                                                   "model.pt predicts no throttle: steerlab replay --throttle model "
                                                   "needs a model that learned it"),
    "replay the model's throttle at a given speed": (_tub_replay("--throttle", "model", "--speed", "2"),
                                                     "--speed and --throttle model exclude each other"),
    "replay a tub without throttle": (_tub_replay(records={i: {"user/throttle": None} for i in range(ROWS)}),
                                      "tub: records no throttle to take the speed from: give one with steerlab "
                                      "replay --speed M/S"),
    "replay a tub whose fisheye is no camera": (_tub_replay(metadata={"fisheye": {"fx": -1.0}}),
                                                "manifest.json: the fisheye camera: a fisheye camera needs an image "
                                                "of at least 2x2 px and positive focal lengths"),
    # i) a study's journal this worker cannot write
    # bad data stops the study at its first trial, naming the file and row (not "no complete trial" after many)
    "tune on a driving log with a bad row": (
        lambda t, s: _tune_space({"train.lr": {"low": 1.0e-5, "high": 0.1, "log": True}})(t, s, rows={3: "x,0.5,0,10"}),
        "driving_log.csv, row 4: ", ("run/", "cache/", "s.journal")),
    "tune read-only journal": (_read_only_journal, "s.journal: cannot be written ("),
    # k) a study's storage that cannot be opened: the URL without its password, what the server or driver said
    "tune unreachable postgres": (_tune_storage("postgresql://tuner:secret@127.0.0.1:1/steerlab"),
                                  "cannot open storage postgresql://tuner:***@127.0.0.1:1/steerlab: OperationalError: "
                                  'connection failed: connection to server at "127.0.0.1", port 1 failed: Connection '
                                  "refused"),
    "tune heartbeat 5,2": (_tune_storage("sqlite:///{tmp}/s.db", heartbeat="5,2"),
                           "STEERLAB_TUNE_HEARTBEAT='5,2': expected INTERVAL,GRACE in whole seconds with 0 < INTERVAL "
                           "< GRACE"),
    "tune join a study that does not exist": (
        lambda t, s: _tune_storage("{tmp}/s.journal")(t, s) + ["--join"],
        "s.journal: no such file, so no study to join; check steerlab tune --storage, or start the study "
        "without --join"),
    # l) latency: models, threads and checkpoints checked before anything is timed
    "latency unknown model": (lambda t, s: ["latency", "--models", "pilotnet,pilot-net", "--out", str(t / "out")],
                              "unknown model 'pilot-net'; available: cg23,"),
    "latency threads 0": (lambda t, s: ["latency", "--models", "zero", "--threads", "0", "--out", str(t / "out")],
                          "--threads must be an integer in [1, "),
    "latency threads -1": (lambda t, s: ["latency", "--models", "zero", "--threads", "-1", "--out", str(t / "out")],
                           "--threads must be an integer in [1, "),
    "latency missing checkpoint": (lambda t, s: ["latency", str(t / "gone.pt"), "--out", str(t / "out")],
                                   "gone.pt: checkpoint not found"),
    "latency onnx file on torch": (lambda t, s: ["latency", str(_exported(t)), "--runtime", "torch"],
                                   "m.onnx runs on ONNX Runtime only: time it with steerlab latency --runtime "
                                   "onnx or both"),
    # m) every option and every file field checked where it enters (no traceback)
    "tub deleted_indexes of text": (_compile(_tub_manifest(["3", "x"])),
                                    "manifest.json, row 5: deleted_indexes must be a list of record indexes"),
    "tub deleted_indexes null": (_compile(_tub_manifest([None])), "deleted_indexes must be a list of record indexes"),
    "tub deleted_indexes not a list": (_compile(_tub_manifest(5)),
                                       "deleted_indexes must be a list of record indexes (integers), got 5"),
    "tub _index of text": (_compile(lambda t: tub(t / "tub", {2: {"_index": "two"}})),
                           "catalog_0.catalog, row 3: _index is 'two'; an integer is expected"),
    "tub record with a misnamed column": (
        _compile(lambda t: _renamed(tub(t / "tub") / "catalog_0.catalog", "user/angle", "user/angel")),
        "catalog_0.catalog, row 1: a record needs the keys _index, _timestamp_ms, cam/image_array, user/angle"),
    "train model.seq_len=0": (_train("model.name=lstm", "model.seq_len=0"),
                              "model.seq_len must be an integer in [1, 1000], got 0"),
    "train model.seq_len=ten": (_train("model.name=lstm", "model.seq_len=ten"),
                                "model.seq_len must be an integer in [1, 1000], got 'ten'"),
    "train an input too small for the model": (_train("preprocess.width=20", "preprocess.height=10"),
                                               "model 'pilotnet' cannot take a 20x10 input"),
    "train preprocess.width=0": (_train("preprocess.width=0"), "preprocess.width must be an integer in [1, 4096]"),
    "compile a CH2 folder with --camera left": (
        lambda t, s: ["compile", "--data", str(ch2(t / "ch2")), "--camera", "left", "--cache", str(t / "cache")],
        "has no 'left' camera (it has center)"),
    "bench the same checkpoint twice": (_two_of("sim bench"), "is named twice"),
    "replay the same checkpoint twice": (_two_of("replay"), "is named twice"),
    # n) what cannot be right is refused, never used
    "compile a CH2 frame of 1280x960 among 640x480": (_ch2_with_odd_frame((960, 1280)),
                                                      ".jpg: the frame is 960x1280 (height x width); the "
                                                      "recording's frames are 480x640 (frame 3)", ("cache/",)),
    "compile a CH2 frame of 400x480": (_ch2_with_odd_frame((480, 400)), "the frame is 480x400 (height x width); the recording's",
                                       ("cache/",)),
    "compile a recording whose log names a column otherwise": (
        _compile(_renamed_column), "log.csv, row 1: header lacks columns ['steering']; expected frame,timestamp_ns,"),
    "compile a CH2 frame of 1x1": (_ch2_with_odd_frame((1, 1)), ".jpg: the frame is 1x1 (height x width); the recording's frames",
                                   ("cache/",)),
    "checkpoint with its statistics changed": (_stats_changed, "best.pt: the file's bytes do not match the sha256 "
                                                               "stored with them: the file is damaged"),
    "checkpoint before seals with its statistics changed": (
        _stats_changed_before_seals, "best.pt: the checkpoint's settings (statistics, preprocessing, convention, "
                                     "training state) do not match its sha256"),
    # o) messages that name the file, the option that exists and the fix
    "evaluate a CH2 checkpoint on a tub": (
        lambda t, s: ["evaluate", str(made(t, "steering_wheel", "left", "ch2")), "--data", str(tub(t / "tub")),
                      "--out", str(t / "eval")],
        "and the recording's camera geometry (donkey) is not the model's (ch2) either"),
    "export int8 of a CH2 checkpoint calibrated on a tub": (
        lambda t, s: ["export", str(made(t, "steering_wheel", "left", "ch2")), "--out", str(t / "m.onnx"), "--int8",
                      "--calib", str(tub(t / "tub"))],
        "the recording's camera geometry (donkey) is not the model's (ch2)"),
    "train with an .onnx teacher": (_teacher(_exported), "m.onnx: train.teacher: an .onnx file cannot be a teacher"),
    "train with a plain pickle as teacher": (_teacher(_pickled), "plain.pt: not a readable checkpoint (not the zip "
                                                                 "file torch.save writes)"),
    "tune a range the option does not take": (_tune_space({"model.dropout": {"low": 0.5, "high": 3.0}}),
                                              "tune: model.dropout takes a number in [0, 1), and the range or "
                                              "choices give 3.0"),
    "sim drive a tub checkpoint": (lambda t, s: ["sim", "drive", str(made(t, "normalized", "right", "donkey")),
                                                 "--out", str(t / "d")],
                                   "model.pt: model 'pilotnet' was trained on the 'donkey' camera, which the road "
                                   "world does not render"),
    "sim drive a tub checkpoint with the sim camera": (
        lambda t, s: ["sim", "drive", str(made(t, "normalized", "right", "donkey")), "--geometry", "sim", "--out",
                      str(t / "d")],
        "model.pt: model 'pilotnet' predicts normalized steering without a full-lock angle"),
    "sim drive in an unknown world": (lambda t, s: ["sim", "drive", str(made(t)), "--world", "moon"],
                                      "argument --world: invalid choice: 'moon' (choose from 'road', 'track')"),
    "track lane width 0": (_track("record", "--lane-width", "0"), "--lane-width must be a number in (0.2, 2] m, wider "
                                                                  "than the car's 0.2 m body, got 0"),
    "track lane width -0.5": (_track("drive", "--lane-width=-0.5"), "--lane-width must be a number in (0.2, 2] m"),
    "track calibration that does not parse": (_track("drive", calibration="{not json"),
                                              "calib.json, row 1: not valid JSON"),
    "track calibration of another image size": (
        _track("bench", calibration={**CALIBRATION, "image_size": [640, 480]}),
        "calib.json: calibrated at 640x480, but the camera takes 160x120 frames"),
    "track record with a road option": (_track("record", "--road", "twisty"),
                                        "--road is an option of the road world (--world road)"),
    "track record in the simulator's layout": (_track("record", "--layout", "udacity-sim"),
                                               "--layout must be tub or steerlab, got 'udacity-sim'"),
    "track record a suite track": (_track("record", "--seed", "9401"), "track seeds 9000-9999 are reserved"),
    "track drive a road checkpoint": (lambda t, s: ["sim", "drive", str(made(t)), "--world", "track"],
                                      "model.pt: model 'pilotnet' was trained on the 'sim' camera; the track world "
                                      "renders the donkeycar camera"),
    "track drive with a throttle cap above 1": (_track("drive", "--max-throttle", "1.5"),
                                                "--max-throttle must be a number in (0, 1], got 1.5"),
    "road drive with a track option": (lambda t, s: ["sim", "drive", str(made(t)), "--throttle", "0.5"],
                                       "--throttle is an option of the track world (--world track)"),
    "compile labels from a pipe": (_fifo_labels, "fifo.csv: not a regular file (a pipe or a device?), where a label "
                                                 "file is expected"),
    "evaluate into a file as --out": (lambda t, s: ["evaluate", str(made(t)), "--data", str(sim_log(t / "sim")),
                                                    "--out", str(_a_file(t))],
                                      "a file, where an output folder (--out) is expected"),
    "train with a folder as config": (lambda t, s: ["train", str(t)], ": a folder, where a config file is expected"),
    "evaluate a folder as checkpoint": (lambda t, s: ["evaluate", str(t), "--data", str(sim_log(t / "sim"))],
                                        ": a folder, where a checkpoint is expected"),
    "train the throttle with a model that cannot": (_train("model.name=two-stream-flow", "train.throttle_weight=1"),
                                                    "train.throttle_weight: model 'two-stream-flow' does not learn a "
                                                    "throttle; these do: cg23"),
    "set model.throttle by hand": (_train("model.throttle=true"), "model.throttle is not set by hand: training adds "
                                                                  "the throttle output when train.throttle_weight > 0"),
    # p) found by a new user: each is a row here and a case of its rule's generated sweep below
    "train into the recording it reads": (lambda t, s: _train(f"out={t / 'sim'}")(t, s),
                                          "sim: the output folder (out) holds a recording ("),
    "ensemble onto one of its members": (lambda t, s: ["ensemble", str(made(t, name="a.pt")), str(made(t, name="b.pt")),
                                                       "--out", str(t / "a.pt")],
                                         "a.pt: the output file (--out) is an input of this command"),
    "ensemble of one checkpoint through a symlink": (
        lambda t, s: (os.symlink(made(t, name="a.pt"), t / "link.pt"),
                      ["ensemble", str(t / "a.pt"), str(t / "link.pt"), "--out", str(t / "e.pt")])[1],
        "link.pt is named twice (as "),
    "drive minutes that hold no frame": (_with("--minutes", "1e-9", command="sim drive"),
                                         "--minutes must be at least one frame's time: 0.000833 min at 20 frames/s"),
    "a Latin-1 byte in a config": (lambda t, s: (t / "c.yaml").write_bytes(b"# caf\xe9\n")
                                   and ["train", str(t / "c.yaml")],
                                   "c.yaml, row 1: byte 0xe9 is not UTF-8 text"),
    "a key twice in a config": (lambda t, s: (config(t, sim_log(t / "sim")).open("a").write("train: {epochs: 3}\n"),
                                              ["train", str(t / "c.yaml")])[1],
                                "c.yaml: not valid YAML: key 'train' is given twice (lines 5 and 6); keep one"),
    "a reader option that is a list": (_compile(lambda t: tub(t / "tub"), "full_lock_deg=[25]"),
                                       "reader.full_lock_deg must be a number in (0, 90) degrees, got [25]"),
    "a reader option that is not a boolean": (_compile(lambda t: tub(t / "tub"), "skip_missing=maybe"),
                                              "reader.skip_missing must be true or false, got 'maybe'"),
    "latency on more threads than the machine has": (
        lambda t, s: ["latency", "--models", "zero", "--threads", "100000"], "--threads must be an integer in [1, "),
    "a label file that names a column twice": (
        _compile(lambda t: (tear(ch2(t / "ch2") / "labels.csv", 1, "frame_id,steering_angle,steering_angle\n"),
                            t / "ch2")[1]),
        "labels.csv, row 1: the header names column(s) ['steering_angle'] twice"),
    "a label file whose time goes back": (
        _compile(lambda t: (tear(ch2(t / "ch2") / "labels.csv", 4, "1020000000,0.0,0\n"), t / "ch2")[1]),
        "labels.csv, row 4: the time goes back (1020000000 ns after 1050000000 ns in the row before)"),
    "extra data that is the training recording": (lambda t, s: _train(f"extra_data=[{t / 'sim'}]")(t, s),
                                                  "is the training recording itself (data)"),
    "an episode that does not exist": (_train("train.exclude_episodes=[drift-outt]"),
                                       "train.exclude_episodes[0] must be normal, drift-out, recover or rollout"),
    "a suite road type named twice": (_with("--roads", "twisty,twisty"),
                                      "--roads must be a comma list of road types of country, highway, twisty, each "
                                      "once, got 'twisty,twisty'"),
}


def _files(folder):
    return {p: p.stat().st_mtime_ns for p in folder.rglob("*") if p.is_file()}


@pytest.mark.parametrize("case", BAD_INPUTS)
def test_bad_input_is_refused_in_one_line(case, tmp_path, capsys):
    command, message, *written = BAD_INPUTS[case]
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


# ---------------------------------------------------------------- what is read past, with a warning

def test_torn_tub_lines_are_read_past_with_one_warning(tmp_path, capsys):
    folder = tub(tmp_path / "tub")
    catalog = folder / "catalog_0.catalog"
    lines = catalog.read_text().splitlines(keepends=True)
    # power lost after record 2: NULs where records 3 and 4 were, then record 5 after them on the same line;
    # record 6 written half; 7 intact
    lines[3:7] = ["\0" * 300 + lines[5], lines[6][:50] + "\n"]
    catalog.write_text("".join(lines))
    assert main(["compile", "--data", str(folder), "--cache", str(tmp_path / "cache")]) == 0
    captured = capsys.readouterr()
    assert captured.out.startswith(f"{ROWS - 3} frames")
    warning = [line for line in captured.err.splitlines() if line.startswith("warning:")]
    assert len(warning) == 1, captured.err
    assert "read past torn catalog lines" in warning[0] and "catalog_0.catalog row(s) 4-5" in warning[0]
    assert "3 record(s) lost" in warning[0] and "strict: true" in warning[0]


def test_torn_last_line_of_a_driving_log_is_read_past(tmp_path, capsys):
    from steerlab.data.readers import open_recording

    log = sim_log(tmp_path / "sim")
    tear(log, ROWS, f"/elsewhere/IMG/center_2020_01_01_00_00_00_{100 * (ROWS - 1):03d}.jpg,,,0.1,0.")  # no line end
    rec = open_recording(log)
    assert len(rec) == ROWS - 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"driving_log.csv: row {ROWS} is torn" in err and "1 record lost" in err
    tear(log, ROWS, "\0" * 40 + "\n")  # NUL bytes, even with a line end
    assert len(open_recording(log)) == ROWS - 1
    tear(log, ROWS, f"/elsewhere/IMG/center_2020_01_01_00_00_00_{100 * (ROWS - 1):03d}.jpg,,,0.1,0.5,0,10")
    assert len(open_recording(log)) == ROWS  # a whole last line without a line end is a line


def test_convention_mismatch_allowed_converts_with_a_warning(tmp_path, capsys):
    import numpy as np

    from steerlab.pilot import Pilot

    data, ckpt = ch2(tmp_path / "ch2"), made(tmp_path)  # a simulator checkpoint (road wheel, positive right)
    assert main(["evaluate", str(ckpt), "--data", str(data), "--labels", str(data / "labels.csv"), "--out",
                 str(tmp_path / "eval"), "--allow-convention-mismatch", "--allow-other-camera"]) == 0
    err = capsys.readouterr().err
    assert "predicts road_wheel/right steering" in err and "converted to the recording's convention" in err
    predicted = np.loadtxt(tmp_path / "eval" / "predictions.csv", delimiter=",", skiprows=1, ndmin=2)[:, 1]
    pilot = Pilot(ckpt, other_camera=True)
    raw = [pilot.step(cv2.imread(str(p))).steering for p in sorted((data / "center").glob("*.jpg"))]
    # the simulator's road-wheel angle, positive right, as CH2's steering-wheel angle, positive left
    np.testing.assert_allclose(predicted, -14.8 * np.array(raw), rtol=1e-4, atol=1e-6)


# ---------------------------------------------------------------- runs, caches and checkpoints

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


def test_checkpoints_load_without_pickled_code_and_are_sealed(tmp_path):
    import hashlib

    import torch

    from steerlab.checkpoint import SEAL, load_checkpoint

    best = trained(tmp_path)
    raw = torch.load(best, weights_only=True)  # tensors and plain values only
    assert torch.load(tmp_path / "run" / "last.pt", weights_only=True)["epoch"] == 1
    data = best.read_bytes()  # the zip's comment: the seal, then the sha256 of every byte before the digest
    assert data[-64 - len(SEAL):-64] == SEAL and data[-64:] == hashlib.sha256(data[:-64]).hexdigest().encode()
    torch.save(raw, tmp_path / "plain.pt")  # written again by torch.save alone (no seal): changed by another tool
    with pytest.raises(SteerlabError, match="plain.pt: a checkpoint that steerlab sealed, without its seal: it was "
                                            "written again by another tool"):
        load_checkpoint(tmp_path / "plain.pt")
    torch.save({**raw, "format": "steerlab-checkpoint-1"}, tmp_path / "first.pt")  # as the first versions wrote it
    assert load_checkpoint(tmp_path / "first.pt")["model"] == "pilotnet"


def test_each_hash_of_a_checkpoint_is_checked_and_an_earlier_geometry_name_is_read(tmp_path):
    """The inner hashes of the versions before seals, each checked on its own (a changed weight, a changed
    statistic), a sealed file whose stored bytes changed while it still reads, a missing file named as a checkpoint,
    and the camera geometry's earlier name (`preset`) read as `geometry`."""
    import torch

    from steerlab.checkpoint import content_hash, load_checkpoint, save_payload, weights_hash

    raw = torch.load(trained(tmp_path), weights_only=True)
    raw = {k: v for k, v in raw.items() if k not in ("sha256", "content_sha256", "format")}  # save_payload sets it
    weights = {k: v.clone() for k, v in raw["state_dict"].items()}
    first = {**raw, "format": "steerlab-checkpoint-1", "sha256": weights_hash(weights)}
    for name, content in (("no-weights.pt", {"format": "steerlab-checkpoint-1"}), ("a-list.pt", [1, 2])):
        torch.save(content, tmp_path / name)
        with pytest.raises(SteerlabError, match=f"{name}: not a steerlab checkpoint"):
            load_checkpoint(tmp_path / name)
    (tmp_path / "m.onnx").write_bytes(b"an ONNX model")
    with pytest.raises(SteerlabError, match="m.onnx: an exported .onnx model, not a steerlab checkpoint"):
        load_checkpoint(tmp_path / "m.onnx")
    torch.save(first, tmp_path / "first.pt")
    assert load_checkpoint(tmp_path / "first.pt")["sha256"] == weights_hash(weights)  # intact: taken
    name = next(iter(weights))
    torch.save({**first, "state_dict": {**weights, name: weights[name] + 1}}, tmp_path / "weights.pt")
    with pytest.raises(SteerlabError, match="weights.pt: the weights do not match the checkpoint's sha256"):
        load_checkpoint(tmp_path / "weights.pt")
    earliest = {**{k: v for k, v in first.items() if k != "geometry"}, "preset": "ch2"}  # the geometry's earlier name
    torch.save(earliest, tmp_path / "earliest.pt")
    assert load_checkpoint(tmp_path / "earliest.pt")["geometry"] == "ch2" and "preset" not in load_checkpoint(
        tmp_path / "earliest.pt")

    def sealed_then_damaged(name, payload):  # the digest changed: the seal is broken, the zip still reads
        save_payload(tmp_path / name, payload)
        data = bytearray((tmp_path / name).read_bytes())
        data[-1] = ord("0") if data[-1] != ord("0") else ord("1")
        (tmp_path / name).write_bytes(bytes(data))
        return tmp_path / name

    whole = {**raw, "content_sha256": content_hash({**raw, "format": "steerlab-checkpoint-2"})}
    with pytest.raises(SteerlabError, match="sealed.pt: the file's bytes do not match the sha256 stored with them"):
        load_checkpoint(sealed_then_damaged("sealed.pt", whole))
    changed = {**whole, "stats": {**whole["stats"], "mean": [v + 1 for v in whole["stats"]["mean"]]}}
    with pytest.raises(SteerlabError, match="stats.pt: the checkpoint's settings .* do not match its sha256"):
        load_checkpoint(sealed_then_damaged("stats.pt", changed))
    with pytest.raises(SteerlabError, match="gone.pt: checkpoint not found"):
        load_checkpoint(tmp_path / "gone.pt")


# ---------------------------------------------------------------- generated sweeps: every option, every path

def _numeric_options():
    """(key, kind, check, expected) of every option whose type is a number, whatever it checks: the training config's
    (train.*, preprocess.*, every model's options) and the other config sections' (dagger, closed_loop)."""
    from steerlab.dagger import DaggerOptions, own_options, places
    from steerlab.models import list_models
    from steerlab.models.registry import OPTION_CHECKS, model_option_types
    from steerlab.options import optional, options_of
    from steerlab.sim.road.suite import SuiteOptions
    from steerlab.train.config import TrainConfig

    out = []
    owns = [(own_options(p), "dagger") for p in places()]  # the options of a dagger section that one place takes
    for cls, section in ((TrainConfig, ""), (DaggerOptions, "dagger"), *owns, (SuiteOptions, "closed_loop")):
        for o in options_of(cls, section):
            kind = optional(o.kind)[0]
            if kind in (int, float):
                out.append((o.key, kind, o.check, o.expected))
    for name in list_models():
        for option, kind in model_option_types(name).items():
            if kind in (int, float):
                out.append((f"model.{option}@{name}", kind, OPTION_CHECKS.get(option), None))
    return out


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


@pytest.mark.parametrize("key, kind, check, expected", _numeric_options(), ids=lambda v: v if isinstance(v, str)
                         else None)
def test_every_numeric_config_option_is_range_checked(key, kind, check, expected, tmp_path):
    """From the schema, no hand-picked list: out of range, of the wrong type, and at the boundary."""
    from steerlab.dagger import dagger_options, taking
    from steerlab.errors import SteerlabError
    from steerlab.sim.worlds import closed_loop
    from steerlab.train.config import load_config

    check = _a_range(key, check)
    key, _, model = key.partition("@")
    base = {"data": str(tmp_path), **({"model": {"name": model}} if model else {})}
    if key == "train.smoothness":
        base["model"] = {"name": "lstm"}
    if key == "train.hue_deg":  # the hue of RGB inputs
        base["preprocess"] = {"color": "rgb"}
    if key.startswith("preprocess."):  # a model without layers: a 4096-pixel frame builds nothing large
        base["model"] = {"name": "zero"}
    worlds = taking(key.removeprefix("dagger.")) if key.startswith("dagger.") else ("road",)
    if "road" not in worlds:  # an option of another world than the default
        base["dagger"] = {"world": worlds[0]}

    def parse(value):
        cfg = load_config(None, [f"{key}={json.dumps(value)}"], base=base)
        if key.startswith("dagger."):
            dagger_options(cfg)
        if key.startswith("closed_loop."):
            closed_loop(cfg.closed_loop)

    for value, taken in _edges(check, kind):
        if taken:
            parse(value)
        else:
            with pytest.raises(SteerlabError) as e:
                parse(value)
            assert f"{key} must be" in str(e.value) and "\n" not in str(e.value), (value, str(e.value))


def test_a_range_takes_its_bounds_as_declared_and_says_them_in_words():
    """`options.Range` by hand: closed ends take their bound, open ends refuse it and take the next float inside,
    an absent end takes any finite number that way; NaN and infinities never. Its words, as errors print them."""
    from steerlab.options import Range

    closed, open_ = Range(-1.5, 2.5), Range(0, 1, lo_open=True, hi_open=True)
    assert [closed(v) for v in (-1.5, 2.5, -1.5000001, 2.5000001, 0.0)] == [True, True, False, False, True]
    assert [open_(v) for v in (0.0, 1.0, 1e-12, 1 - 1e-12, -1e-12, 1 + 1e-12)] == [False, False, True, True, False,
                                                                                   False]
    assert [Range(2)(v) for v in (2, 1.999, 1e300)] == [True, False, True]
    assert [Range(hi=3, hi_open=True)(v) for v in (3, 2.999, -1e300)] == [False, True, True]
    assert [Range()(v) for v in (0.0, -1e300, float("nan"), float("inf"), -float("inf"))] == [True, True, False, False,
                                                                                            False]
    assert [Range(0, 1)(v) for v in (float("nan"), float("inf"))] == [False, False]
    assert Range(1, 1_000_000).words(int) == "an integer of at least 1 (at most 1000000)"
    assert Range(1, 4096).words(int) == "an integer in [1, 4096]"
    assert Range(0, 1, lo_open=True).words(float) == "a number in (0, 1]"
    assert Range(-1.5, 2.5, hi_open=True, unit="m").words(float) == "a number in [-1.5, 2.5) m"
    assert Range(0, 4294967295).words(float) == "a number in [0, 4294967295]"
    assert Range(2).words(int) == "an integer of at least 2" and Range().words(int) == "an integer"
    assert Range(0, lo_open=True, unit="m/s").words(float) == "a positive finite number m/s"
    assert Range(0.5, unit="min").words(float) == "a finite number min of at least 0.5"
    assert Range(0).words(float) == "a finite number of at least 0"
    assert Range(unit="m").words(float) == "a finite number m" and Range().words(float) == "a finite number"


def test_a_numeric_option_takes_exactly_the_values_its_range_declares():
    """Property-based (Hypothesis): for any option whose type is a number, in the config or on the command line, and
    any value a user may type (integers and floats of any size, NaN, infinities, booleans, number-like text), the
    parse takes the value exactly when it is of the option's type and inside its declared range, anywhere in it,
    not only at the ends the sweeps try."""
    from hypothesis import given, settings
    from hypothesis import strategies as st

    from steerlab.options import value_of

    options = [(key, kind, check) for key, kind, check, _ in _numeric_options()] + \
        [(f"{command} {name}", kind, check) for command, name, kind, check in _cli_numeric_options()]
    values = st.one_of(st.integers(-2**40, 2**40), st.floats(allow_nan=True, allow_infinity=True), st.booleans(),
                       st.text("0123456789.-+einfa", max_size=6))

    def takes(kind, r, value) -> bool:  # the range's own words, computed here: lo <= v <= hi, open ends excluded
        if isinstance(value, bool) or (kind is int and not isinstance(value, int)):
            return False
        try:
            v = float(value)
        except ValueError:  # text that is no number
            return False
        above = r.lo is None or (v > r.lo if r.lo_open else v >= r.lo)
        below = r.hi is None or (v < r.hi if r.hi_open else v <= r.hi)
        return v == v and abs(v) != float("inf") and above and below

    @settings(max_examples=400, deadline=None, derandomize=True, database=None)
    @given(st.sampled_from(options), values)
    def check(option, value):
        key, kind, declared = option
        try:
            value_of(kind, value, key, declared)
            taken = True
        except SteerlabError:
            taken = False
        assert taken == takes(kind, _a_range(key, declared), value), (key, value)

    check()


def _cli_numeric_options():
    from steerlab.cli import OPTIONS, build_parser
    from steerlab.options import optional, options_of

    build_parser()  # fills OPTIONS
    return [(command, o.key, optional(o.kind)[0], o.check) for command, classes in OPTIONS.items()
            for cls in classes for o in options_of(cls) if optional(o.kind)[0] in (int, float)]


def _command_args(command, tmp_path):
    """The arguments a command needs besides the option under test: real inputs, so that only the option fails."""
    ckpt = str(made(tmp_path))
    cfg = str(config(tmp_path, sim_log(tmp_path / "sim")))
    return {"latency": ["--models", "zero"], "sim record": ["--out", str(tmp_path / "rec")],
            "sim drive": [ckpt], "sim bench": [ckpt], "replay": [ckpt, "--data", str(tmp_path / "sim")],
            "serve": [ckpt], "demo": ["--out", str(tmp_path / "demo")], "train": [cfg], "experiment": [cfg],
            "tune": [cfg]}[command]


@pytest.mark.parametrize("command, name, kind, check", _cli_numeric_options(),
                         ids=lambda v: v if isinstance(v, str) else None)
def test_every_numeric_command_line_option_is_refused_out_of_range(command, name, kind, check, tmp_path, capsys):
    """From cli.OPTIONS (the options dataclasses behind every command's flags): values out of range, of the
    wrong type and at an open boundary are refused in one line naming the flag, before anything runs."""
    from steerlab.cli import flag

    check = _a_range(f"{command} {flag(name)}", check)
    argv = [*command.split(), *_command_args(command, tmp_path)]
    bad = [v for v, taken in _edges(check, kind) if not taken and not isinstance(v, (bool, list))]
    before = _files(tmp_path)
    for value in bad:
        assert main([*argv, flag(name), str(value)]) == 2, value
        err = capsys.readouterr().err
        assert err.startswith("error: ") and err.count("\n") == 1 and flag(name) in err, err
    assert _files(tmp_path) == before  # nothing written


def _command_parsers():
    """(command, its parser) of every command, `sim`'s subcommands each on its own."""
    from steerlab.cli import build_parser

    for name, parser in build_parser()._subparsers._group_actions[0].choices.items():
        yield from ([(f"{name} {n}", p) for n, p in parser._subparsers._group_actions[0].choices.items()]
                    if parser._subparsers else [(name, parser)])


def _path_arguments():
    return [(command, dest, kind) for command, p in _command_parsers()
            for dest, kind in (p.get_default("paths") or {}).items()]


@pytest.mark.parametrize("command, dest, kind", _path_arguments(), ids=lambda v: v if isinstance(v, str) else None)
def test_every_path_argument_is_checked(command, dest, kind, tmp_path, capsys):
    """Every path an argument names: a missing file, a folder where a file is expected and a file where a folder
    is expected are refused in one line naming the path, before anything runs."""
    from steerlab.cli import build_parser, flag

    parser = build_parser()
    file, folder = tmp_path / "a-file", tmp_path / "a-folder"
    file.write_text("x")
    folder.mkdir()
    for sub in command.split():
        parser = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices[sub]
    argv = [*command.split()]
    for a in parser._actions:  # every other required argument, a harmless value of its kind
        if a.required and a.dest != dest and a.option_strings:
            argv += [a.option_strings[0], str(folder if (parser.get_default("paths") or {}).get(a.dest) == "folder"
                                              else file)]
        elif not a.option_strings and a.dest not in (dest, "help") and a.nargs != "*":
            argv.append(str(file))
    dangling = tmp_path / "a-link-to-nothing"
    dangling.symlink_to(tmp_path / "nowhere")
    cases = {"file": [tmp_path / "missing.pt", folder, dangling], "folder": [file, Path("/dev/null"), dangling],
             "new-file": [folder, Path("/dev/full"), dangling]}[kind]
    positional = next(a for a in parser._actions if a.dest == dest).option_strings == []
    for path in cases:
        args = [*argv, str(path)] if positional else [*argv, flag(dest), str(path)]
        assert main(args) == 2, args
        err = capsys.readouterr().err
        assert err.startswith(f"error: {path}: ") and err.count("\n") == 1, err
        assert _says_what_it_is(path, err), err


def _single_value_flags():
    """(command, flag, an abbreviation of it, takes a value) of every option of every command that holds one value
    (not a list)."""
    out = []
    for command, p in _command_parsers():
        for a in p._actions:
            if a.option_strings and not isinstance(a, (argparse._AppendAction, argparse._HelpAction)):
                name = a.option_strings[-1]
                short = name[:-1] if [s for s in p._option_string_actions if s.startswith(name[:-1])] == [name] \
                    else name  # an abbreviation that names this option alone
                out.append((command, name, short, a.nargs != 0))
    return out


@pytest.mark.parametrize("command, name, short, valued", _single_value_flags(),
                         ids=lambda v: v if isinstance(v, str) else None)
def test_every_option_given_twice_is_refused(command, name, short, valued, capsys, tmp_path, monkeypatch):
    """Rule 1 (each option once): an option of one value given twice is refused in one line naming it, before
    anything runs, however the second is written (`--flag=value`, an abbreviation argparse takes)."""
    monkeypatch.chdir(tmp_path)  # were it not refused, what it wrote would land here
    first = [name, "1"] if valued else [name]
    for second in (first, [f"{name}=2"] if valued else [name], [short, "2"] if valued else [short]):
        assert main([*command.split(), *first, *second]) == 2, second
        err = capsys.readouterr().err
        assert err.startswith(f"error: {name} is given twice") and err.count("\n") == 1, err


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


def test_extra_data_of_another_steering_convention_is_refused(tmp_path, capsys):
    """Recordings that do not belong together are not mixed: extra_data whose steering means other angles than the
    config's data (a donkeycar tub's servo command beside the simulator's road-wheel radians) is refused before
    training, as init, teacher and ensemble refuse the same thing."""
    cfg = config(tmp_path, sim_log(tmp_path / "sim"))
    tub(tmp_path / "tub")
    cfg.write_text(cfg.read_text() + f"extra_data: [{tmp_path / 'tub'}]\n")
    assert main(["train", str(cfg)]) == 2
    assert capsys.readouterr().err == (f"error: extra_data {tmp_path / 'tub'} records normalized/right steering and "
                                       "the config's data road_wheel/right: the targets would mean different angles; "
                                       "give recordings of one car (extra_data is read with the readers' default "
                                       "options)\n")
    assert not (tmp_path / "run").exists() and not (tmp_path / "cache").exists()  # refused before any work


def test_replay_refuses_a_recording_whose_steering_means_other_angles_than_the_models(tmp_path, capsys):
    """As evaluate does: a tub read with another full-lock angle than the checkpoint was trained with."""
    ckpt = made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25)
    tub(tmp_path / "tub")
    assert main(["replay", str(ckpt), "--data", str(tmp_path / "tub"), "--reader", "full_lock_deg=30",
                 "--out", str(tmp_path / "replay")]) == 2
    assert capsys.readouterr().err == (f"error: {ckpt} predicts normalized/right (full lock 25 deg) steering and "
                                       f"{tmp_path / 'tub'} records normalized/right (full lock 30 deg) steering: "
                                       "the human's path and the model's steering would be two cars; replay it on "
                                       "recordings of its own convention (the reader options it was trained with)\n")
    assert not (tmp_path / "replay").exists()


def test_an_experiment_refuses_a_seed_override(tmp_path):
    """`steerlab experiment CONFIG --seeds 3 train.seed=5` would train every 'seed' with seed 5."""
    from steerlab.experiment import load_experiment

    cfg = config(tmp_path, sim_log(tmp_path / "sim"))
    cfg.write_text(cfg.read_text() + "models:\n  - {model: {name: zero}}\n")
    with pytest.raises(SteerlabError, match=r"override train.seed: an experiment's runs take the seeds 0..N-1 of "
                                            r"steerlab experiment --seeds; leave it out"):
        load_experiment(cfg, ["train.seed=5"])
    assert load_experiment(cfg, ["train.epochs=2"]).overrides == ("train.epochs=2",)


def test_options_that_may_repeat_are_not_refused():
    """What the each-once rule leaves alone: two options one of whose names begins the other's, an option that
    collects a list, a value after `--`; the same option twice is refused (SystemExit, after its one line)."""
    parsers = dict(_command_parsers())
    parsers["sim bench"]._once(["--throttle", "1", "--throttle-scale", "2"])
    parsers["evaluate"]._once(["--reader", "a=1", "--reader", "b=2"])
    parsers["sim bench"]._once(["--minutes", "1", "--", "--minutes"])
    with pytest.raises(SystemExit):
        parsers["sim bench"]._once(["--minutes", "1", "--minutes", "2"])


def test_overrides_and_reader_options_given_twice_are_refused(tmp_path, capsys):
    """The same key twice among `section.key=value` overrides or `--reader key=value` options is refused."""
    from steerlab.train.config import load_config

    cfg = config(tmp_path, sim_log(tmp_path / "sim"))
    assert main(["train", str(cfg), f"out={tmp_path / 'a'}", "train.epochs=1", f"out={tmp_path / 'b'}"]) == 2
    assert capsys.readouterr().err.startswith("error: override out= is given twice")
    with pytest.raises(SteerlabError, match=r"override train.epochs= is given twice \('train.epochs=1' and "):
        load_config(cfg, ["train.epochs=1", " train.epochs =2"])
    assert main(["compile", "--data", str(tmp_path / "sim"), "--reader", "camera=center", "--reader",
                 "camera=left"]) == 2
    assert capsys.readouterr().err == "error: --reader camera= is given twice; give each reader option once\n"
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


# ---------------------------------------------------------------- damaged files: every stored byte covered

def _damaged(data: bytes):
    """One byte flipped at several offsets, and the file cut off at several lengths."""
    n = len(data)
    for offset in (0, 7, n // 7, n // 3, n // 2, 2 * n // 3, n - 90, n - 30, n - 1):
        flipped = bytearray(data)
        flipped[offset] ^= 0xFF
        yield f"byte {offset} flipped", bytes(flipped)
    for length in (0, 20, n // 2, n - 64, n - 1):
        yield f"cut at {length}", data[:length]


def test_damaged_checkpoints_and_exports_are_refused_naming_the_file(tmp_path):
    from steerlab.checkpoint import load_checkpoint
    from steerlab.errors import SteerlabError
    from steerlab.export import export_onnx
    from steerlab.pilot import Pilot

    best = trained(tmp_path)
    onnx = export_onnx(best, tmp_path / "m.onnx")
    for good, load in ((best, load_checkpoint), (tmp_path / "run" / "last.pt", load_checkpoint), (onnx, Pilot)):
        data = good.read_bytes()
        for what, bad in _damaged(data):
            path = tmp_path / f"damaged{good.suffix}"
            path.write_bytes(bad)
            with pytest.raises(SteerlabError, match=f"^{path}: "):
                load(path)
            assert what  # every case refused
        good.write_bytes(data)
        load(good)  # the undamaged file still loads


def test_a_damaged_cache_entry_is_said_and_compiled_again(tmp_path, capsys):
    from steerlab.data.dataset import compile_recording
    from steerlab.data.preprocess import PreprocessConfig
    from steerlab.data.readers import open_recording

    rec, cfg = open_recording(sim_log(tmp_path / "sim")), PreprocessConfig.from_dict({"preset": "sim"})
    ds = compile_recording(rec, cfg, tmp_path / "cache", progress=False)
    image = np.array(ds.arrays["image"])
    for name in ("image.npy", "labels.npz", "meta.json"):
        data = (ds.path / name).read_bytes()
        for what, bad in list(_damaged(data))[::3]:
            (ds.path / name).write_bytes(bad)
            capsys.readouterr()
            again = compile_recording(rec, cfg, tmp_path / "cache", progress=False)
            err = capsys.readouterr().err
            assert "is damaged" in err and "compiling it again" in err, (name, what, err)
            np.testing.assert_array_equal(again.arrays["image"], image)
    compile_recording(rec, cfg, tmp_path / "cache", progress=False)
    assert "damaged" not in capsys.readouterr().err


def test_a_damaged_tub_catalog_is_read_past_with_the_loss_said(tmp_path, capsys):
    from steerlab.data.readers import open_recording

    folder = tub(tmp_path / "tub")
    catalog = folder / "catalog_0.catalog"
    data = catalog.read_bytes()
    for what, bad in _damaged(data):
        catalog.write_bytes(bad)
        capsys.readouterr()
        try:
            rec = open_recording(folder)
        except SteerlabError as e:  # nothing left to read, or a record a flip made wrong: said in one line
            assert str(e).startswith(str(folder)) and "\n" not in str(e), (what, str(e))
            continue
        err = capsys.readouterr().err
        assert len(rec) == ROWS or ("record(s) lost" in err or "read past torn" in err), (what, err)


# ---------------------------------------------------------------- the Python API: one rule with the command line

def test_the_pilot_and_the_donkeycar_part_refuse_what_is_not_a_frame_or_a_speed(tmp_path):
    """What cannot be a camera frame of the model's camera, or a measured speed, is a SteerlabError that names
    what is expected, from the Pilot and from the donkeycar part alike; `other_camera` takes any size."""
    from steerlab.donkey import SteerlabPilot
    from steerlab.pilot import Pilot

    ckpt = made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25)
    pilot, part = Pilot(ckpt), SteerlabPilot(ckpt)
    rgb = np.zeros((120, 160, 3), np.uint8)
    for frame in (b"", None, "abc", bytearray(b"xyz"), rgb.astype(np.float64), rgb[..., 0],
                  np.zeros((480, 640, 3), np.uint8)):
        with pytest.raises(SteerlabError, match=r"120x160x3 uint8|trained on the 'donkey' camera \(120x160\)"):
            pilot.step(frame)
    with pytest.raises(SteerlabError, match="the measured speed must be a finite number of m/s, at least 0, got "
                                            "'fast'"):
        part.run(rgb, speed="fast")
    with pytest.raises(SteerlabError, match="got nan"):
        pilot.step(rgb, float("nan"))
    with pytest.raises(SteerlabError, match="expects 120x160x3 uint8 RGB frames"):
        part.run(np.zeros((480, 640, 3), np.uint8))
    assert np.isfinite(Pilot(ckpt, other_camera=True).step(np.zeros((480, 640, 3), np.uint8)).steering)
    assert np.isfinite(pilot.step(cv2.imencode(".jpg", rgb)[1].tobytes()).steering)  # the bytes of a JPEG


def test_the_donkeycar_part_refuses_options_it_cannot_use(tmp_path):
    """A throttle forced on a model that learned one, and options of the wrong type or range: one clear error
    when the part is made."""
    from steerlab.donkey import SteerlabPilot

    learned = made(tmp_path, "normalized", "right", "donkey", name="throttle.pt", throttle=True)
    with pytest.raises(SteerlabError, match=r"throttle.pt learned the throttle; throttle=0.3 would override it: pass "
                                            r"learned_throttle=False to drive at a constant throttle"):
        SteerlabPilot(learned, 0.3)
    assert SteerlabPilot(learned, 0.3, learned_throttle=False).run(np.zeros((120, 160, 3), np.uint8))[1] == 0.3
    for options, message in [({"learned_throttle": "no"}, "learned_throttle must be True or False, got 'no'"),
                             ({"threads": 0}, r"threads must be an integer in \[1, \d+\] \(this machine's cores\), "
                                              r"got 0"),
                             ({"threads": 1.5}, r"threads must be an integer in \[1, \d+\] \(this machine's cores\), "
                                                r"got 1.5"),
                             ({"throttle_scale": 0}, r"throttle_scale must be a number in \(0, 10\], got 0"),
                             ({"throttle_floor": -0.1}, r"throttle_floor must be a number in \[0, 1\], got -0.1"),
                             ({"max_throttle": 0}, r"max_throttle must be a number in \(0, 1\], got 0"),
                             ({"clock": 5}, r"clock must be a function that returns seconds \(time.monotonic\), "
                                            r"got 5")]:
        with pytest.raises(SteerlabError, match=message):
            SteerlabPilot(learned, **options)


def test_the_pilot_refuses_what_is_not_a_checkpoint_and_speeds_that_do_not_pair_with_its_frames(tmp_path):
    from steerlab.pilot import Pilot

    for bad in (42, None, "", [1]):
        with pytest.raises(SteerlabError, match=r"checkpoint must be the path of a .pt checkpoint or an .onnx file "
                                                rf"\(or a loaded checkpoint\), got {re.escape(repr(bad))}"):
            Pilot(bad)
    with pytest.raises(SteerlabError, match="the checkpoint given as a dict is not a steerlab checkpoint"):
        Pilot({"a": 1})
    pilot = Pilot(made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25))
    frames = [np.zeros((120, 160, 3), np.uint8)] * 3
    with pytest.raises(SteerlabError, match=r"Pilot.stream: more frames than speeds \(2 speeds\): give one speed a "
                                            "frame"):
        list(pilot.stream(frames, speeds=[1.0, 1.0]))
    with pytest.raises(SteerlabError, match=r"Pilot.stream: more speeds than frames \(3 frames\): give one speed a "
                                            "frame"):
        list(pilot.stream(frames, speeds=[1.0] * 4))
    assert len(list(pilot.stream(frames, speeds=[1.0] * 3))) == 3


def test_a_full_lock_angle_in_radians_is_said(tmp_path, capsys):
    """Rule 4: a full-lock angle below 5 degrees (0.44: radians typed for degrees) is said, by the donkeycar part
    and by the readers that take one; a plausible one is not."""
    from steerlab.data.readers import open_recording
    from steerlab.donkey import SteerlabPilot

    ckpt = made(tmp_path, "road_wheel", "left", "donkey")
    SteerlabPilot(ckpt, full_lock_deg=0.44)
    assert capsys.readouterr().err == ("warning: SteerlabPilot: full_lock_deg=0.44: a car's wheels turn 5 degrees or "
                                       "more at full lock; radians where degrees are expected? (math.degrees "
                                       "converts)\n")
    tub(tmp_path / "tub")
    open_recording(tmp_path / "tub", options={"full_lock_deg": 0.44})
    open_recording(tmp_path / "tub", options={"full_lock_deg": 0.44})  # opened again in the same command: said once
    assert capsys.readouterr().err.count("reader option: full_lock_deg=0.44: a car's wheels turn 5 degrees") == 1
    SteerlabPilot(ckpt, full_lock_deg=25)
    open_recording(tmp_path / "tub", options={"full_lock_deg": 25})
    assert capsys.readouterr().err == ""


# ---------------------------------------------------------------- the rules, each a sweep generated from the code
# Rule 1: every value checked where it enters (options, reader options, other worlds' options); rule 2: no output
# over an input or into a folder of another kind, and one line when it cannot be written; rule 3: files as people
# save them; rule 4: implausible values said; rule 5: only earlier versions' checkpoints taken as earlier versions.
# Each generator lists its inputs and whether each is refused or said, so that `python tests/test_bad_input.py`
# counts them (docs/results/bad-input.md, "Bad input").

def _option_classes():
    """Every options dataclass a user's values enter through: the commands' (cli.OPTIONS), the config's sections,
    the readers' option tables."""
    from steerlab.cli import OPTIONS, build_parser
    from steerlab.dagger import DaggerOptions, own_options, places
    from steerlab.data.readers import READERS
    from steerlab.train.config import TrainOptions

    build_parser()
    classes = {cls for group in OPTIONS.values() for cls in group}
    owns = {own_options(p) for p in places()}  # the options of a dagger section that one place takes
    readers = {r.options for r in READERS if r.options}  # every registered reader's option table
    return sorted(classes | owns | readers | {DaggerOptions, TrainOptions}, key=lambda c: c.__name__)


def _wrong_values(o):
    """Values of the wrong kind for the option `o`: what no option of its type takes."""
    from typing import Literal, get_origin

    from steerlab.options import optional

    kind = optional(o.kind)[0]
    if kind is bool:
        return ["maybe", 1, 0, "true", [True], None if not optional(o.kind)[1] else "no"]
    if kind in (int, float):
        return [[1], {"a": 1}, "abc", True, *(["nan", "inf"] if kind is float else [1.5, "2"])]
    if get_origin(kind) is Literal:
        return ["no-such-choice", 7, [kind.__args__[0]]]
    if kind in (dict,):
        return [5, "text", [1]]
    if kind is str:
        return [5, [1], {"a": 1}]
    if get_origin(kind) is tuple:
        return ["text", 5, {"a": 1}]
    return []


def rule1_cases():
    """(class, option, value): every option of every options class, each value of a wrong kind, and each minutes that
    hold no frame; all refused by `parse` naming the option."""
    from steerlab.options import MINUTES, options_of

    cases = []
    for cls in _option_classes():
        for o in options_of(cls):
            if o.path:
                continue
            cases += [(cls, o.key, v) for v in _wrong_values(o)]
            if o.check is MINUTES:
                cases.append((cls, o.key, 1e-7))  # no frame at any frame rate
    return cases


@pytest.mark.parametrize("cls, key, value", rule1_cases(), ids=lambda v: getattr(v, "__name__", str(v))[:30])
def test_rule1_every_option_refuses_a_value_it_cannot_mean(cls, key, value):
    from steerlab.options import parse

    with pytest.raises(SteerlabError) as e:
        parse(cls, {key: value}, "x")
    assert f"x.{key}" in str(e.value) and "\n" not in str(e.value), str(e.value)


def _of_its_type(kind, value) -> bool:
    """Whether `value` is of the option type `kind` (None aside), in the test's own words: what a YAML config or a
    Python caller could mean by it."""
    from typing import Literal, get_origin

    if get_origin(kind) is Literal:
        return value in kind.__args__ and not isinstance(value, bool)
    if kind is float:  # a number, or text that is one (the command line gives text)
        try:
            number = float(value) if isinstance(value, (int, float, str)) and not isinstance(value, bool) else None
        except ValueError:
            number = None
        return number is not None and abs(number) != float("inf") and number == number
    return {bool: bool, str: str, dict: dict}.get(kind) is not None and isinstance(value, kind) or (
        kind is int and isinstance(value, int) and not isinstance(value, bool))


def test_rule1_any_value_not_of_an_options_type_is_refused_naming_it():
    """Rule 1 as a property: for every option of every options class whose type is a plain one (bool, int, float,
    text, a choice, a mapping), any value not of that type (drawn from numbers, text, lists, mappings, None) is
    refused naming the option, so an option is covered because of its type, whatever checks it has."""
    from typing import Literal, get_origin

    from hypothesis import given, settings
    from hypothesis import strategies as st

    from steerlab.options import optional, options_of, parse

    options = [(cls, o.key, *optional(o.kind)) for cls in _option_classes() for o in options_of(cls)
               if not o.path and "." not in o.key and (optional(o.kind)[0] in (bool, int, float, str, dict)
                                                       or get_origin(optional(o.kind)[0]) is Literal)]
    scalars = st.one_of(st.none(), st.booleans(), st.integers(-10**6, 10**6), st.floats(), st.text(max_size=8),
                        st.text("0123456789.-+einfa", max_size=5))
    values = st.one_of(scalars, st.lists(scalars, max_size=3), st.dictionaries(st.text(max_size=3), scalars,
                                                                                max_size=2))

    @settings(max_examples=600, deadline=None, derandomize=True, database=None)
    @given(st.sampled_from(options), values)
    def check(option, value):
        cls, key, kind, nullable = option
        if (value is None and nullable) or _of_its_type(kind, value):
            return
        try:
            parse(cls, {key: value}, "x")
        except SteerlabError as e:
            assert f"x.{key}" in str(e) and "\n" not in str(e), str(e)
        else:
            raise AssertionError(f"{cls.__name__}.{key} took {value!r}")

    check()


def _valid_value(o):
    """A value the option `o` takes (its default, or a number in its range), as the command line writes it."""
    from dataclasses import MISSING
    from typing import Literal, get_origin

    from steerlab.options import optional

    kind = optional(o.kind)[0]
    if o.default not in (None, MISSING) and kind is not bool:
        return str(o.default)
    if get_origin(kind) is Literal:
        return str(kind.__args__[0])
    if kind in (int, float):
        lo, hi = getattr(o.check, "lo", None) or 0, getattr(o.check, "hi", None)
        return str(kind(lo + 1 if hi is None or lo + 1 <= hi else (lo + hi) / 2))  # inside the option's range
    return None if kind is bool else "x"


def rule1_world_cases():
    """(command, world, flag, value): every flag of every world's options, given in another world that lacks it."""
    from steerlab.cli import flag
    from steerlab.options import optional, options_of
    from steerlab.sim.worlds import WORLDS

    cases = []
    for command, sub in (("record", "sim record"), ("drive", "sim drive"), ("suite", "sim bench"),
                         ("replay", "replay")):
        for world in WORLDS.values():
            own = {o.key for o in options_of(getattr(world, command).options)}
            for other in WORLDS.values():
                for o in options_of(getattr(other, command).options):
                    if o.key in own or o.path:
                        continue
                    kind = optional(o.kind)[0]
                    name = flag(f"no_{o.key}" if kind is bool and o.default is True else o.key)
                    cases.append((sub, world.name, name, _valid_value(o)))
    return sorted(set(cases))


@pytest.mark.parametrize("command, world, name, value", rule1_world_cases(), ids=str)
def test_rule1_an_option_of_another_world_is_refused(command, world, name, value, tmp_path, capsys):
    (tmp_path / "model.pt").write_bytes(b"refused before it is read")
    ckpt = [] if command == "sim record" else [str(tmp_path / "model.pt")]
    data = ["--data", str(sim_log(tmp_path / "sim") if world == "road" else tub(tmp_path / "tub"))] \
        if command == "replay" else []
    argv = [*command.split(), *ckpt, *data, "--world", world, "--out", str(tmp_path / "out"), name,
            *([] if value is None else [value])]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{name} is an option of the" in err, err
    assert not (tmp_path / "out").exists()


def rule1_reader_cases():
    """(layout, option, value): a wrong value of every option of the readers of a driving log and a tub, through
    `--reader` on the command line (the option tables of the other readers are swept by rule1_cases)."""
    from steerlab.data import tub as tubs
    from steerlab.data.simlog import SIM_OPTIONS
    from steerlab.options import options_of

    out = []
    for layout, cls in (("sim", SIM_OPTIONS), ("tub", tubs.OPTIONS)):
        for o in options_of(cls):
            out += [(layout, o.key, v) for v in ("maybe", "[25]", "{a: 1}", "-1", "1e400") if v != "-1" or
                    getattr(o.check, "lo", None) is not None]
    return out


@pytest.mark.parametrize("layout, key, value", rule1_reader_cases(), ids=str)
def test_rule1_reader_options_are_typed(layout, key, value, tmp_path, capsys):
    data = sim_log(tmp_path / "sim") if layout == "sim" else tub(tmp_path / "tub")
    assert main(["compile", "--data", str(data), "--reader", f"{key}={value}", "--cache", str(tmp_path / "c")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"reader.{key} must be" in err, err
    assert not (tmp_path / "c").exists()


def rule1_named_set_cases():
    """(class, option, value): a comma list of a fixed set's names with a name twice, an unknown one, or none."""
    from steerlab.sim.road.suite import SUITES, SuiteOptions
    from steerlab.sim.track.suite import TRACK_SUITES, TrackSuiteOptions

    out = []
    for cls, key, suites, part in ((SuiteOptions, "roads", SUITES, "roads"),
                                   (TrackSuiteOptions, "styles", TRACK_SUITES, "tracks")):
        for suite, spec in suites.items():
            for name in spec[part]:
                out += [(cls, suite, key, f"{name},{name}"), (cls, suite, key, f"{name},{name}x"),
                        (cls, suite, key, ",")]
    return out


def rule1_road_list_cases():
    """(class, value): a road list naming one road type twice and nothing else, unknown types, or none."""
    from steerlab.sim.road.road import ROAD_TYPES
    from steerlab.sim.road.world import DriveOptions, RecordOptions

    return [(cls, value) for cls in (RecordOptions, DriveOptions) for name in ROAD_TYPES
            for value in (f"{name},{name}", f"{name},{name},{name}", f"{name},{name}x", ",")]


@pytest.mark.parametrize("cls, value", rule1_road_list_cases(), ids=str)
def test_rule1_a_road_list_whose_repeat_means_nothing_is_refused(cls, value):
    from steerlab.options import parse

    with pytest.raises(SteerlabError, match=r"^--road must be .* \(not one name alone, repeated\)"):
        parse(cls, {"road": value}, name=lambda f: f"--{f}")
    assert parse(cls, {"road": "country,twisty,twisty"}).road == "country,twisty,twisty"  # a repeat that means more


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
        if paths.get("config") == "file":
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
        if subprocess.run(["chattr", "+i", str(ro)], capture_output=True).returncode:
            pytest.skip("chattr is not available: no folder this test cannot write")
        return ro / "out"
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
        subprocess.run(["chattr", "-i", str(tmp_path / "ro")], capture_output=True)
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1, err
    shown = str(target if what != "long name" else tmp_path)
    assert shown in err or str(target.resolve()) in err or str(file) in err, err
    assert {p: t for p, t in _files(tmp_path).items() if p in before} == before  # nothing lost
    assert not (tmp_path / "nowhere").exists()  # nothing made through a link to nothing
    assert what not in NOT_WRITABLE or _says_what_it_is(target, err), err


def _says_what_it_is(path: Path, err: str) -> bool:
    """Whether a refusal of a device or a link to nothing says what the path is (not "file exists", "is a file"),
    or the name a file of the output's kind must have."""
    if "must end in" in err:
        return True
    if path.is_symlink() and not path.exists():
        return "a symbolic link to " in err
    return "a device" in err if str(path).startswith("/dev/") else True


def _config_of(command, tmp_path):
    """A config that `command` takes: a training config, with a models list for an experiment and a search space
    for a study."""
    cfg = config(tmp_path, tmp_path / "rec")
    extra = {"experiment": "models:\n  - {model: {name: zero}}\n",
             "tune": "tune: {train.lr: {low: 1.0e-5, high: 0.1, log: true}}\n"}
    cfg.write_text(cfg.read_text() + extra.get(command, ""))
    return cfg


def _resaved(path):
    """A copy of the file's bytes in another form: with a byte-order mark, CRLF, trailing blank lines; or in UTF-16,
    with a Latin-1 byte, with its first column named twice, with NUL bytes; or another file altogether (a
    checkpoint, an image)."""
    data = path.read_bytes()
    return {"bom": b"\xef\xbb\xbf" + data, "crlf": data.replace(b"\n", b"\r\n"),
            "bom+crlf": b"\xef\xbb\xbf" + data.replace(b"\n", b"\r\n"), "blank lines": data + b"\n\n\n",
            "utf-16": data.decode().encode("utf-16"), "latin-1": data.replace(b"\n", b" \xe9\n", 2),
            "column twice": data.replace(b",", b"," + data.split(b",")[0] + b",", 1),
            "NUL bytes": data.replace(b"\n", b"\0\n", 2), "a checkpoint": made(path.parent, name=".x.pt").read_bytes(),
            "a JPEG image": _jpeg_bytes(path.parent / ".x.jpg")}


def _jpeg_bytes(path: Path) -> bytes:
    write_jpeg(path, 100, (32, 32))
    return path.read_bytes()


def rule3_cases():
    """(file, variant, taken): every text file a user gives (the readers' CSV files, the score's, a config, a
    calibration), saved the ways people save them (taken) or otherwise (refused naming the file)."""
    taken = ("bom", "crlf", "bom+crlf", "blank lines")
    out = []
    for file in ("ch2 labels", "driving log", "native log", "answer file", "config", "calibration"):
        for variant in (*taken, "utf-16", "latin-1", "column twice", "NUL bytes", "a checkpoint", "a JPEG image"):
            if variant == "column twice" and file in ("driving log", "config", "calibration"):
                continue
            out.append((file, variant, variant in taken))
    return out + [("config", "key twice", False), ("calibration", "key twice", False),
                  ("calibration", "NaN", False)]


def _rule3_input(tmp_path, file):
    """(the file, what reads it) for a file of rule3_cases."""
    from steerlab.data.fisheye import load_calibration
    from steerlab.data.readers import open_recording
    from steerlab.evaluate.scoring import score
    from steerlab.train.config import load_config

    if file == "ch2 labels":
        d = ch2(tmp_path / "ch2")
        return d / "labels.csv", lambda: len(open_recording(d, labels=d / "labels.csv"))
    if file == "driving log":
        log = sim_log(tmp_path / "sim")
        return log, lambda: len(open_recording(log))
    if file == "native log":
        d = _renamed_column(tmp_path)
        (d / "log.csv").write_text((d / "log.csv").read_text().replace(",steer,", ",steering,", 1))
        return d / "log.csv", lambda: len(open_recording(d))
    if file == "answer file":
        d = ch2(tmp_path / "ch2")
        return d / "labels.csv", lambda: score(d / "labels.csv", d / "labels.csv")["frames"]
    if file == "config":
        cfg = config(tmp_path, sim_log(tmp_path / "sim"))
        return cfg, lambda: load_config(cfg).train.epochs
    path = tmp_path / "calib.yaml"
    path.write_text("image_size: [160, 120]\nK: [[81.0, 0.0, 80.0], [0.0, 80.0, 61.0], [0.0, 0.0, 1.0]]\n"
                    "D: [-0.02, -0.01, 0.0, 0.005]\n")
    return path, lambda: load_calibration(path).fx


@pytest.mark.parametrize("file, variant, taken", rule3_cases(), ids=str)
def test_rule3_files_as_people_save_them(file, variant, taken, tmp_path):
    path, read = _rule3_input(tmp_path, file)
    original = read()
    if variant == "key twice":
        path.write_text(path.read_text() + ("train: {epochs: 2}\n" if file == "config" else "D: [0, 0, 0, 0]\n"))
    elif variant == "NaN":  # a calibration in JSON, with a number JSON does not have
        from steerlab.data.fisheye import load_calibration

        path = tmp_path / "calib.json"
        path.write_text('{"image_size": [160, 120], "K": [[81, 0, 80], [0, 80, 61], [0, 0, 1]], "D": [NaN, 0, 0, 0]}')
        read = lambda: load_calibration(path)  # noqa: E731
    else:
        path.write_bytes(_resaved(path)[variant])
    if taken:
        assert read() == original
        return
    with pytest.raises(SteerlabError) as e:
        read()
    assert str(path) in str(e.value) and "\n" not in str(e.value), str(e.value)
    said = {"a checkpoint": "a steerlab checkpoint, where the", "a JPEG image":
            "a JPEG image, where the"}.get(variant, "")
    assert said in str(e.value), str(e.value)


def test_rule3_what_steerlab_writes_is_valid_json(tmp_path):
    """A metric that is not a number (one frame has no gamma) is null in metrics.json, never NaN."""
    assert main(["evaluate", str(made(tmp_path)), "--data", str(sim_log(tmp_path / "sim")), "--range", "0:1",
                 "--out", str(tmp_path / "eval")]) == 0
    text = (tmp_path / "eval" / "metrics.json").read_text()
    metrics = json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} in metrics.json"))
    assert metrics["gamma_deg"] is None


def rule4_cases():
    """(what, value, outcome): values implausible for their unit. The measured speed of every car: negative
    refused, beyond twice its top speed said; a calibration's focal length: too long to see anything refused;
    predictions in degrees where radians are expected said; answers (and predictions with them) beyond a steering
    wheel's two turns each way said."""
    from steerlab.data.car import CARS

    out = []
    for geometry, car in CARS.items():
        top = car.speeds[1]
        out += [("speed", (geometry, -1.0), "refused"), ("speed", (geometry, -1e-3), "refused"),
                ("speed", (geometry, 3 * top), "said"), ("speed", (geometry, 100 * top), "said"),
                ("speed", (geometry, top), "taken")]
    out += [("focal length", fx, "refused" if fx > 1000 else "taken") for fx in (80, 200, 400, 8000, 80000)]
    out += [("spread", factor, "said" if factor > 10 else "taken") for factor in (1, 3, 57.3, 180 / 3.1416 * 10)]
    out += [("answers", most, "said" if most > 4 * 3.1416 else "taken") for most in (0.5, 8.0, 12.5, 28.6, 458.0)]
    return out


@functools.cache
def _checkpoint_of(geometry: str) -> dict:
    """An untrained checkpoint of the camera `geometry`, loaded (made once per test process)."""
    from steerlab.checkpoint import load_checkpoint

    folder = Path(tempfile.mkdtemp(prefix="steerlab-rule4-"))
    try:
        return load_checkpoint(made(folder, *(("normalized", "right") if geometry == "donkey" else ()),
                                    geometry=geometry))
    finally:
        shutil.rmtree(folder)


@pytest.mark.parametrize("what, value, outcome", rule4_cases(), ids=str)
def test_rule4_implausible_values_are_said(what, value, outcome, tmp_path, capsys):
    if what == "speed":
        from steerlab.data.geometry import CAMERAS
        from steerlab.pilot import Pilot

        geometry, speed = value
        cam = CAMERAS[geometry]
        act = lambda: Pilot(_checkpoint_of(geometry)).step(np.zeros((cam.height, cam.width, 3), np.uint8),  # noqa
                                                           speed)
    elif what == "focal length":
        from steerlab.data.fisheye import load_calibration

        path = tmp_path / "calib.json"
        path.write_text(json.dumps({"image_size": [160, 120], "K": [[value, 0, 80], [0, value, 60], [0, 0, 1]],
                                    "D": [0, 0, 0, 0]}))
        act = lambda: load_calibration(path)  # noqa: E731
    else:
        from steerlab.evaluate.scoring import score

        folder = ch2(tmp_path / "ch2")
        rows = (folder / "labels.csv").read_text().splitlines()[1:]
        pred = tmp_path / "pred.csv"
        pred.write_text("frame_id,steering_angle\n" + "".join(
            f"{r.split(',')[0]},{float(r.split(',')[1]) * value + 0.001 * (i % 2)}\n" for i, r in enumerate(rows)))
        if what == "answers":  # answers and predictions alike up to `value`: the spread says nothing
            lines = [line.split(",") for line in rows]
            top = max(abs(float(r[1])) for r in lines)
            (folder / "labels.csv").write_text("frame_id,steering_angle,public\n" + "".join(
                f"{r[0]},{float(r[1]) * value / top},{r[2]}\n" for r in lines))
            pred.write_text("frame_id,steering_angle\n" + "".join(
                f"{r[0]},{float(r[1]) * value / top * 0.9}\n" for r in lines))
        act = lambda: score(folder / "labels.csv", pred)  # noqa: E731
    if outcome == "refused":
        with pytest.raises(SteerlabError):
            act()
        return
    capsys.readouterr()
    act()
    said = capsys.readouterr().err
    assert (said.count("warning:") == 1) == (outcome == "said"), said


def rule5_cases():
    """(how the file was written, taken): a checkpoint as each steerlab version wrote it, and as another tool wrote
    a sealed one again."""
    return [("sealed", True), ("0.1.0", True), ("first versions", True), ("torch.save of a sealed one", False),
            ("torch.save of one with an inner hash", False), ("torch.save of an earlier version's, format changed",
                                                               False)]


@pytest.mark.parametrize("how, taken", rule5_cases(), ids=str)
def test_rule5_only_earlier_versions_are_taken_as_earlier_versions(how, taken, tmp_path):
    import torch

    from steerlab.checkpoint import FORMAT, content_hash, load_checkpoint

    path = made(tmp_path)
    raw = torch.load(path, weights_only=True)
    if how == "0.1.0":
        path = Path(__file__).parent / "fixtures" / "run-0.1.0" / "best.pt"
    elif how == "first versions":
        torch.save({**raw, "format": "steerlab-checkpoint-1"}, path)
    elif how == "torch.save of a sealed one":
        torch.save(raw, path)
    elif how == "torch.save of one with an inner hash":
        earlier = {**raw, "format": "steerlab-checkpoint-1"}
        torch.save({**earlier, "content_sha256": content_hash(earlier)}, path)
    elif how != "sealed":
        torch.save({**raw, "format": FORMAT}, path)
    if taken:
        assert load_checkpoint(path)["model"] in ("pilotnet", "cg23")  # 0.1.0's run trained cg23
        return
    with pytest.raises(SteerlabError, match=f"^{path}: a checkpoint that steerlab sealed, without its seal"):
        load_checkpoint(path)


def rule_counts() -> list[tuple[str, int, int, int]]:
    """(rule, inputs generated, refused, said) of the generated sweeps above."""
    r1 = len(rule1_cases()) + len(rule1_world_cases()) + len(rule1_reader_cases()) + len(rule1_named_set_cases())
    edges = [_edges(check, kind) for _, kind, check, _ in _numeric_options()]
    cli = [_edges(check, kind) for _, _, kind, check in _cli_numeric_options()]
    taken = sum(t for e in edges for _, t in e)
    r1 += sum(map(len, edges)) + sum(1 for e in cli for v, t in e if not t and not isinstance(v, (bool, list)))
    r1 += 3 * len(_single_value_flags())  # each given twice: as it was, as --flag=value, abbreviated
    r3 = rule3_cases()
    r4 = rule4_cases()
    return [("1 every value checked where it enters", r1, r1 - taken, 0),
            ("2 no output over an input or into another's folder", len(rule2_cases()), len(rule2_cases()), 0),
            ("3 files as people save them", len(r3) + 1, sum(not t for _, _, t in r3), 0),
            ("4 implausible values said", len(r4), sum(o == "refused" for *_, o in r4),
             sum(o == "said" for *_, o in r4)),
            ("5 only earlier versions as earlier versions", len(rule5_cases()), sum(not t for _, t in rule5_cases()),
             0)]


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


if __name__ == "__main__":  # the table of docs/results/bad-input.md, "Bad input"
    print("| rule | inputs generated | refused | said |\n|---|---|---|---|")
    for rule, n, refused, said in rule_counts():
        print(f"| {rule} | {n} | {refused} | {said} |")
