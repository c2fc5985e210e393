"""The third round's inputs (`python -m tests.rounds.run --round 3`), each a row as in round1.py, with its group:
the commands of the README's pages (docs/guide/commands.md, which the README links as its commands) with their
arguments misspelled, mistyped, swapped, missing, repeated or pointed at the wrong kind of file (A); the features
added since the second round: `train.views`, `train.calibration`, `train.recovery_s`, `cameras.register_camera`,
the studies `tub_replay` and `view_truth`, `train.lane_weight` and `--steer-by lane`, `--throttle-floor` and
`--throttle-scale`, the real tub wood-tape (B); real-world data mistakes: tubs, driving logs, label files and
calibrations edited or saved by hand in plausible wrong ways, values in other units (C); interrupted workflows and
outputs left half written, and the Python API with wrong types and units (D). The fixtures are the first round's
(OUT_DIR/fx) and a few more made by `setup`: an ONNX export, a calibration, predictions, a checkpoint with a lane
head, a track-world tub, configs of the tub fixtures."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

from tests.inputs import made
from tests.rounds import places, round2

F, W, S = "{fx}", "{work}", "{shared}"
CK, SIM, TUB, CH2, REC = f"{F}/a.pt", f"{F}/sim", f"{F}/tub", f"{F}/ch2", f"{F}/rec"
DK, LANE, TRK = f"{F}/donkey.pt", f"{F}/lane.pt", f"{F}/trk"  # a donkey model, one with a lane head, a track tub
CONFIG, TUBCFG, TRKCFG = f"{F}/c.yaml", f"{F}/tub.yaml", f"{F}/trk.yaml"
WOOD, HALL, TAPED = f"{S}/donkeycar/wood-tape", f"{S}/donkeycar/hall", f"{S}/donkeycar/taped-track"
REAL_CH2, REAL_SIM = f"{S}/udacity-ch2", f"{S}/udacity-sim-track1"
CAL = f"{F}/cal.json"
CALIBRATION = {"image_size": [160, 120], "K": [[81.0, 0.0, 80.0], [0.0, 80.0, 61.0], [0.0, 0.0, 1.0]],
               "D": [-0.02, -0.01, 0.0, 0.005]}
HERE = __name__


def _g(rows, group):
    for r in rows:
        r["group"] = group
    return rows


# A. the commands of the guide, each as a new user gets it wrong: a row is (argv, hint) refused, or
# (argv, hint, expect)
A = [
    # compile
    (["compil", "--data", SIM], ["compil"]),
    (["Compile", "--data", SIM], ["Compile"]),
    (["compile", "--data"], ["--data"]),
    (["compile", "--data", SIM, "--range", "2400:0", "--cache", f"{W}/c"], ["range", "2400:0"]),
    (["compile", "--data", SIM, "--range", "0-6", "--cache", f"{W}/c"], ["range", "0-6"]),
    (["compile", "--data", SIM, "--range", "0:6:2", "--cache", f"{W}/c"], ["range", "0:6:2"]),
    (["compile", "--data", SIM, "--range", "0:2400", "--cache", f"{W}/c"], ["2400", "range"]),
    (["compile", "--data", SIM, "--range", ":", "--cache", f"{W}/c"], ["range"], "ok"),  # all: a slice's ':'"
    (["compile", "--data", SIM, "--range", "0..6", "--cache", f"{W}/c"], ["range", "0..6"]),
    (["compile", "--data", SIM, "--range", "0:6", "--range", "0:4", "--cache", f"{W}/c"], ["--range"]),
    (["compile", "--data", SIM, "--modalities", "image,flo", "--cache", f"{W}/c"], ["flo"]),
    (["compile", "--data", SIM, "--modalities", "image,image", "--cache", f"{W}/c"], ["image"]),
    (["compile", "--data", SIM, "--modalities", "image flow", "--cache", f"{W}/c"], ["image flow", "modalities"]),
    (["compile", "--data", SIM, "--modalities", "", "--cache", f"{W}/c"], ["modalities"]),
    (["compile", "--data", SIM, "--modalities", "Image", "--cache", f"{W}/c"], ["Image"]),
    (["compile", "--data", SIM, "--flow", "DIS", "--modalities", "image,flow", "--cache", f"{W}/c"], ["DIS"]),
    (["compile", "--data", SIM, "--flow", "farneback", "--cache", f"{W}/c"], ["--flow", "flow"], "ok"),  # default
    (["compile", "--data", SIM, "--color", "grey", "--cache", f"{W}/c"], ["grey"]),
    (["compile", "--data", SIM, "--color", "RGB", "--cache", f"{W}/c"], ["RGB"]),
    (["compile", "--data", SIM, "--camera", "centre", "--cache", f"{W}/c"], ["centre"]),
    (["compile", "--data", SIM, "--camera", "Center", "--cache", f"{W}/c"], ["Center"]),
    (["compile", "--data", TUB, "--camera", "left", "--cache", f"{W}/c"], ["left"]),
    (["compile", "--data", SIM, "--preset", "donkeycar", "--cache", f"{W}/c"], ["donkeycar"]),
    (["compile", "--data", SIM, "--labels", f"{SIM}/driving_log.csv", "--cache", f"{W}/c"], ["--labels", "labels"]),
    (["compile", "--data", CH2, "--labels", f"{CH2}/labels.csv", "--labels", f"{CH2}/labels.csv", "--cache",
      f"{W}/c"], ["--labels"]),
    (["compile", "--data", CH2, "--labels", CAL, "--cache", f"{W}/c"], ["cal.json"]),
    (["compile", "--data", TUB, "--reader", "skip_missing=ture", "--cache", f"{W}/c"], ["skip_missing", "ture"]),
    (["compile", "--data", TUB, "--reader", "skipmissing=true", "--cache", f"{W}/c"], ["skipmissing"]),
    (["compile", "--data", TUB, "--reader", "skip_missing", "--cache", f"{W}/c"], ["skip_missing", "KEY=VALUE"]),
    (["compile", "--data", TUB, "--reader", "skip_missing:true", "--cache", f"{W}/c"], ["skip_missing"]),
    (["compile", "--data", TUB, "--reader", "skip_missing=true,full_lock_deg=25", "--cache", f"{W}/c"],
     ["skip_missing", "reader"]),
    (["compile", "--data", TUB, "--reader", "skip_missing=true", "--reader", "skip_missing=false", "--cache",
      f"{W}/c"], ["skip_missing"]),
    (["compile", "--data", TUB, "--reader", "full_lock_deg=25", "--reader", "full_lock_deg=30", "--cache", f"{W}/c"],
     ["full_lock_deg"]),
    (["compile", "--data", TUB, "--reader", "full_lock_deg=25°", "--cache", f"{W}/c"], ["full_lock_deg"]),
    (["compile", "--data", SIM, "--reader", "skip_missing=true", "--cache", f"{W}/c"], ["skip_missing"]),
    (["compile", SIM, "--cache", f"{W}/c"], ["unrecognized", "sim", "--data"]),
    (["compile", "--data", SIM, "--cache"], ["--cache"]),
    (["compile", "--data", SIM, "--cache", CK], ["a.pt"]),
    (["compile", "--data", SIM, "--cache", CONFIG], ["c.yaml"]),
    # train
    (["train", "configs/ch2_pilotnet.yml"], ["ch2_pilotnet.yml"]),
    (["train", "{repo}/configs/ch2_pilotnet.yml"], ["ch2_pilotnet.yml"]),
    (["train", CONFIG, "trian.epochs=5", f"out={W}/t"], ["trian"]),
    (["train", CONFIG, "train.epochs=five", f"out={W}/t"], ["train.epochs", "five"]),
    (["train", CONFIG, "train.epochs=5.5", f"out={W}/t"], ["train.epochs", "5.5"]),
    (["train", CONFIG, "train.epochs==5", f"out={W}/t"], ["train.epochs"]),
    (["train", CONFIG, "--train.epochs=5", f"out={W}/t"], ["--train.epochs"]),
    (["train", CONFIG, "train.epochs=5", "train.epochs=6", f"out={W}/t"], ["train.epochs"]),
    (["train", CONFIG, f"out={W}/t", f"out={W}/t2"], ["out"]),
    (["train", CONFIG, "train.epochs=", f"out={W}/t"], ["train.epochs"]),
    (["train", CONFIG, "train=5", f"out={W}/t"], ["train"]),
    (["train", CONFIG, "model.name=pilot-net", f"out={W}/t"], ["pilot-net"]),
    (["train", CONFIG, "model.name=PilotNet", f"out={W}/t"], ["PilotNet"]),
    (["train", CONFIG, "model=pilotnet", f"out={W}/t"], ["model"]),
    (["train", CONFIG, "train.tensorboard=yes", f"out={W}/t"], ["tensorboard", "yes"], "ok"),  # YAML's yes: true
    (["train", CONFIG, "train.lr=1e-4.", f"out={W}/t"], ["train.lr"]),
    (["train", CONFIG, "train.lr=0,001", f"out={W}/t"], ["train.lr", "0,001"]),
    (["train", CONFIG, "train.teacher=runs/x-ensemble.pt", f"out={W}/t"], ["train.teacher", "x-ensemble.pt"]),
    (["train", CONFIG, "out="], ["out"]),
    (["train", CONFIG, "--nproc", "0", f"out={W}/t"], ["--nproc"]),
    (["train", CONFIG, "--nproc", "two", f"out={W}/t"], ["--nproc", "two"]),
    (["train", CONFIG, "--nproc", "1000", f"out={W}/t"], ["--nproc"]),
    (["train", f"out={W}/t", CONFIG], ["out="]),
    (["train", CONFIG, CONFIG, f"out={W}/t"], ["c.yaml"]),
    (["train"], ["config"]),
    (["train", f"{F}/sim"], ["sim"]),
    # evaluate
    (["evaluate", SIM, "--data", CK, "--out", f"{W}/ev"], ["sim", "a.pt"]),
    (["evaluate", "--data", SIM, "--out", f"{W}/ev"], ["checkpoint", "required"]),
    (["evaluate", CK, "--out", f"{W}/ev"], ["--data"]),
    (["evaluate", CK, "--data", SIM, "--range", "1800:2400", "--out", f"{W}/ev"], ["range", "1800"]),
    (["evaluate", CK, "--data", SIM, "--video", "eval.avi", "--out", f"{W}/ev"], ["eval.avi", ".mp4"]),
    (["evaluate", CK, "--data", SIM, "--video", "--out", f"{W}/ev"], ["--video"]),
    (["evaluate", CK, "--data", SIM, "--labels", f"{CH2}/labels.csv", "--out", f"{W}/ev"], ["--labels", "labels"]),
    (["evaluate", CK, "--data", SIM, "--allow-convention-mismatch=yes", "--out", f"{W}/ev"],
     ["allow-convention-mismatch"]),
    (["evaluate", CK, "--data", SIM, "--allow-other-cameras", "--out", f"{W}/ev"], ["allow-other-cameras"]),
    (["evaluate", CK, "--data", SIM, "--out", f"{W}/ev", "--out", f"{W}/ev2"], ["--out"]),
    (["evaluate", f"{F}/run", "--data", SIM, "--range", "0:6", "--out", f"{W}/ev"], ["run", "best.pt"], "ok"),
    (["evaluate", "best.pt", "--data", SIM, "--out", f"{W}/ev"], ["best.pt"]),
    # score
    (["score", "--truth", f"{F}/pred.csv", "--pred", f"{CH2}/labels.csv"], ["pred.csv", "public"]),
    (["score", "--truth", f"{CH2}/labels.csv"], ["--pred"]),
    (["score", "--pred", f"{F}/pred.csv"], ["--truth"]),
    (["score", f"{CH2}/labels.csv", f"{F}/pred.csv"], ["--truth", "unrecognized"]),
    (["score", "--truth", "CH2_final_evaluation.csv", "--pred", "predictions.csv"], ["CH2_final_evaluation.csv"]),
    (["score", "--truth", f"{CH2}/labels.csv", "--pred", f"{SIM}/driving_log.csv"], ["driving_log.csv"]),
    (["score", "--truth", f"{CH2}/labels.csv", "--pred", f"{F}/pred.csv", "--pred", f"{F}/pred.csv"], ["--pred"]),
    (["score", "--truth", f"{CH2}/labels.csv", "--pred", CH2], ["ch2"]),
    # experiment and tune
    (["experiment", CONFIG, "--seeds", "0"], ["--seeds"]),
    (["experiment", CONFIG, "--seeds", "3.5"], ["--seeds", "3.5"]),
    (["experiment", CONFIG, "--seeds", "0,1,2"], ["--seeds", "0,1,2"]),
    (["experiment", "configs/experiment_ch2.yml", "--seeds", "3"], ["experiment_ch2.yml"]),
    (["tune", CONFIG, "--trials", "0"], ["--trials"]),
    (["tune", CONFIG, "--trials", "73.5"], ["--trials", "73.5"]),
    (["tune", CONFIG, "--trials", "3"], ["tune"]),
    (["tune", CONFIG, "--trial", "3"], ["tune"]),
    # sim record
    (["sim", "recrod", "--out", f"{W}/r"], ["recrod"]),
    (["sim", "record", "--seed", "3", "--minutes", "6", "--road", "mixd", "--out", f"{W}/r"], ["mixd"]),
    (["sim", "record", "--road", "Mixed", "--minutes", "0.01", "--out", f"{W}/r"], ["Mixed"]),
    (["sim", "record", "--road", "twisty,highway", "--minutes", "0.01", "--out", f"{W}/r"], ["twisty,highway"],
     "ok"),  # a list of roads: recorded as roads [twisty, highway]
    (["sim", "record", "--layout", "udacity", "--minutes", "0.01", "--out", f"{W}/r"], ["udacity"]),
    (["sim", "record", "--layout", "tub", "--minutes", "0.01", "--out", f"{W}/r"], ["layout", "tub"]),
    (["sim", "record", "--world", "tracks", "--out", f"{W}/r"], ["tracks"]),
    (["sim", "record", "--vary", "--minutes", "0.01", "--out", f"{W}/r"], ["vary"]),
    (["sim", "record", "--poses", "--minutes", "0.01", "--out", f"{W}/r"], ["poses"]),
    (["sim", "record", "--world", "track", "--poses", "--layout", "steerlab", "--minutes", "0.01", "--out",
      f"{W}/r"], ["layout", "poses"]),
    (["sim", "record", "--world", "track", "--pose-offset", "1", "--minutes", "0.01", "--out", f"{W}/r"],
     ["pose_offset", "pose-offset", "poses"]),
    (["sim", "record", "--world", "track", "--style", "tape", "--minutes", "0.01", "--out", f"{W}/r"], ["tape"]),
    (["sim", "record", "--world", "track", "--seed", "9001", "--minutes", "0.01", "--out", f"{W}/r"], ["9001",
                                                                                                     "seed"]),
    (["sim", "record", "--seed", "9500", "--minutes", "0.01", "--out", f"{W}/r"], ["9500", "seed"]),
    (["sim", "record", "--minutes", "0.01", "--seed", "3", "--seed", "4", "--out", f"{W}/r"], ["--seed"]),
    (["sim", "record", "--minutes", "0.01"], ["--out"], "ok"),  # the default runs/... folder is allowed: refuse_ok
    (["sim", "record", "--minutes", "6min", "--out", f"{W}/r"], ["--minutes", "6min"]),
    (["sim", "record", "--minutes", "1:30", "--out", f"{W}/r"], ["--minutes", "1:30"]),
    # sim drive and bench
    (["sim", "drive", CK, "--road", "twisty", "--world", "track", "--minutes", "0.01", "--out", f"{W}/d"],
     ["road", "track"]),
    (["sim", "drive", CK, "--video", "drive.mov", "--minutes", "0.01", "--out", f"{W}/d"], ["drive.mov", ".mp4"]),
    (["sim", "drive", "--seed", "101", "--minutes", "2", "--out", f"{W}/d"], ["checkpoint", "required"]),
    (["sim", "drive", CK, f"{F}/b.pt", "--minutes", "0.01", "--out", f"{W}/d"], ["b.pt", "unrecognized"]),
    (["sim", "drive", DK, "--world", "track", "--light", "55", "--minutes", "0.01", "--out", f"{W}/d"], ["--light"]),
    (["sim", "drive", DK, "--world", "track", "--light", "0", "--minutes", "0.01", "--out", f"{W}/d"], ["--light"]),
    (["sim", "drive", CK, "--light", "0.55", "--minutes", "0.01", "--out", f"{W}/d"], ["light"]),
    (["sim", "drive", CK, "--geometry", "donkey", "--minutes", "0.01", "--out", f"{W}/d"], ["donkey"]),
    (["sim", "bench", CK, "--suite", "v2", "--out", f"{W}/b"], ["v2"]),
    (["sim", "bench", CK, "--roads", "twisty,twisty", "--out", f"{W}/b"], ["twisty"]),
    (["sim", "bench", CK, "--roads", "twisted", "--out", f"{W}/b"], ["twisted"]),
    (["sim", "bench", DK, "--world", "track", "--styles", "tape", "--out", f"{W}/b"], ["tape"]),
    (["sim", "bench", DK, "--world", "track", "--suite", "v1", "--out", f"{W}/b"], ["v1"]),
    (["sim", "bench", DK, "--world", "track", "--max-throttle", "2", "--out", f"{W}/b"], ["--max-throttle"]),
    (["sim", "bench", DK, "--world", "track", "--styles", "taped", "--roads", "twisty", "--out", f"{W}/b"],
     ["roads"]),
    (["sim", "bench", "--out", f"{W}/b"], ["checkpoint", "required"]),
    (["sim", "dagger", CONFIG, "dagger.rounds=0"], ["rounds"]),
    (["sim", "dagger", CONFIG, "dagger.round=1"], ["round"]),
    # replay
    (["replay", CK, "--data", SIM, "--world", "trak", "--out", f"{W}/rp"], ["trak"]),
    (["replay", CK, "--data", SIM, "--video", "replay.avi", "--out", f"{W}/rp"], ["replay.avi", ".mp4"]),
    (["replay", CK, "--data", SIM, "--world", "track", "--out", f"{W}/rp"], ["donkey", "sim"]),
    (["replay", DK, "--data", TUB, "--world", "track", "--max-heading", "20", "--out", f"{W}/rp"],
     ["max-heading", "max_heading"]),
    (["replay", DK, "--data", TUB, "--world", "track", "--fov", "90", "--out", f"{W}/rp"], ["fov"]),
    (["replay", CK, "--data", SIM, "--speed", "15mph", "--out", f"{W}/rp"], ["--speed", "15mph"]),
    (["replay", CK, "--data", SIM, "--workers", "0", "--out", f"{W}/rp"], ["--workers"]),
    (["replay", "--data", SIM, "--out", f"{W}/rp"], ["checkpoint", "required"]),
    # export, ensemble
    (["export", CK, f"{W}/model.onnx"], ["--out"]),
    (["export", CK, "--out", f"{W}/m.pt"], ["m.pt", ".onnx"]),
    (["export", CK, "--out", f"{W}/m.ONNX"], ["m.ONNX", ".onnx"], "ok"),
    (["export", CK, "--out", f"{W}/m.onnx", "--int8"], ["--calib"]),
    (["export", CK, "--out", f"{W}/m.onnx", "--calib", SIM], ["--int8", "--calib"]),
    (["export", CK, "--out", f"{W}/m.onnx", "--int8", "--calib", SIM, "--calib-range", "0:3840"], ["3840"]),
    (["export", CK, "--out", f"{W}/m.onnx", "--int8", "--calib", SIM, "--calib-range", "0"], ["--calib-range"]),
    (["export", CK, "--out", f"{W}/m.onnx", "--calib-range", "0:6"], ["--calib-range", "--int8"]),
    (["export", CK, "--out", f"{W}/m.onnx"], ["m.onnx"], "ok"),  # an export written again: taken
    (["ensemble", CK, "--out", f"{W}/e.pt"], ["two", "ensemble"]),
    (["ensemble", CK, f"{F}/b.pt"], ["--out"]),
    (["ensemble", CK, f"{F}/b.pt", "--out", f"{W}/e.onnx"], ["e.onnx", ".pt"]),
    (["ensemble", CK, f"{F}/m.onnx", "--out", f"{W}/e.pt"], ["m.onnx"]),
    (["ensemble", CK, f"{F}/b.pt", "--out", f"{W}/e"], [".pt", "e"]),
    (["ensemble", CK, CK, "--out", f"{W}/e.pt"], ["a.pt"]),
    # serve, latency, demo, models
    (["serve", CK, "--port", "99999"], ["--port"]),
    (["serve", CK, "--port", "http"], ["--port", "http"]),
    (["serve", CK, "--set-speed", "30mph"], ["--set-speed"]),
    (["serve", CK, "--set-speed", "-4"], ["--set-speed"]),
    (["serve", CK, "--record"], ["--record"]),
    (["serve", CK, "--record", f"{F}/c.yaml"], ["c.yaml"]),
    (["latency", "--threads", "0", "--models", "zero"], ["--threads"]),
    (["latency", "--threads", "1000", "--models", "zero"], ["--threads"]),
    (["latency", "--runtime", "tensorrt", "--models", "zero"], ["tensorrt"]),
    (["latency", "--runtime", "ONNX", "--models", "zero"], ["ONNX"]),
    (["latency", "--models", "al"], ["al"]),
    (["latency", "--models", "zero,zero", "--frames", "5"], ["zero"]),
    (["latency", "--models", "zero", "--geometry", "donkeys"], ["donkeys"]),
    (["latency", "--models", "zero", "--frames", "0"], ["--frames"]),
    (["latency", "--models", "zero", "--data", HALL, "--range", "0:10000", "--frames", "5"], ["10000", "range"]),
    (["latency", CK, "--models", "zero", "--frames", "5"], ["--models", "a.pt"]),
    (["demo", "--out", CONFIG], ["c.yaml"]),
    (["demo", "--minutes", "0"], ["--minutes"]),
    (["models", "extra"], ["extra", "unrecognized"]),
    (["models", "--json"], ["--json", "unrecognized"]),
    ([], ["command", "steerlab"]),
    (["--version"], ["version"], "ok"),
    (["help"], ["help"]),
]


def _a_rows():
    rows = []
    for argv, hint, *expect in A:
        row = {"cli": argv, "hint": hint, "group": "A"}
        if expect:
            row["expect"] = expect[0]
            if expect[0] == "ok":
                row["refuse_ok"] = True  # taken or refused: what is tried is that it ends in one line, no traceback
        row["timeout"] = 120 if argv[:1] == ["tune"] else 90
        if argv[:1] in (["experiment"], ["serve"], ["demo"]) or argv[:2] in (["sim", "bench"], ["sim", "dagger"]):
            row["stage"] = True  # a value taken costs nothing: the work is stopped where it would start (the others
            # run: their checks of the data, done where the work starts, are what is tried)
        rows.append(row)
    return rows


# B. the features added recently
VIEWS = [  # train.views=VALUE on the config of the driving log (a pinhole camera) or the tub: refused unless "ok"
    ("[[0.5, 10]]", CONFIG, "ok"), ("[[3, 0]]", CONFIG, ["views", "2"]), ("[[0, 60]]", CONFIG, ["views", "45"]),
    ("[[[0.5, -0.5], 0]]", CONFIG, ["views", "lo"]), ("[[0.5, 10, 3]]", CONFIG, ["views"]),
    ("[0.5, 10]", CONFIG, ["views"]), ("[['0.5', '10']]", CONFIG, ["views", "0.5"]),
    ("[[.nan, 0]]", CONFIG, ["views"]), ("[[1e400, 0]]", CONFIG, ["views"]), ("[[true, 0]]", CONFIG, ["views"]),
    ("[[0.5, 10], [0.5, 10]]", CONFIG, ["views", "twice", "[0.5, 10]"], "warn"),
    ("{shift_m: 0.5, yaw_deg: 10}", CONFIG, ["views"]), ("'[[0.5, 10]]'", CONFIG, ["views"]),
    ("[]", CONFIG, "ok"), ("[[-0.15, 0.15], [-15, 15]]", TUBCFG, ["views[1]", "-15"]),
    ("[[[-0.15, 0.15]], [-15, 15]]]", TUBCFG, ["views"]), ("[[[-0.15, 0.15], [-15, 15]]]", TUBCFG, "ok"),
    ("[[15, 0]]", TUBCFG, ["views", "15"]), ("[[0, 0.26]]", TUBCFG, "ok"), ("[[0, 0]]", TUBCFG, ["views", "0"],
                                                                            "warn"),
    ("[[0.1]]", TUBCFG, ["views"]), ("[[0.1, [1]]]", TUBCFG, ["views", "yaw_deg"]),
    ("[[0.1, [1, 2, 3]]]", TUBCFG, ["views", "yaw_deg"]), ("[[[0.2, 0.1], 0]]", TUBCFG, ["views", "shift_m"]),
    ("[[0.1, 10deg]]", TUBCFG, ["views", "10deg"]), ("[[-2.5, 0]]", TUBCFG, ["views", "2"]),
    ("[[0.1, -46]]", TUBCFG, ["views", "45"]), ("[[null, 0]]", TUBCFG, ["views"]),
    ("[[[0, 0], [0, 0]]]", TUBCFG, ["views"], "warn"),
    ("0.5", TUBCFG, ["views"]), ("[[0.1, 5]] ", TUBCFG, "ok"),
]
TRAIN_KEYS = [  # (config, overrides, hint or "ok"/"warn" with its hint)
    (TUBCFG, ["train.views=[[0.1, 5]]", f"train.calibration={CAL}"], "ok"),
    (TUBCFG, [f"train.calibration={CAL}"], ["train.calibration", "views"]),
    (CONFIG, ["train.views=[[0.1, 5]]", f"train.calibration={CAL}"], ["cal.json", "donkey", "sim"]),
    (TUBCFG, ["train.views=[[0.1, 5]]", f"train.calibration={W}/nothere.json"], ["train.calibration",
                                                                                   "nothere.json"]),
    (TUBCFG, ["train.views=[[0.1, 5]]", f"train.calibration={CK}"], ["a.pt", "calibration"]),
    (TUBCFG, ["train.views=[[0.1, 5]]", f"train.calibration={TUB}"], ["calibration", "tub"]),
    (TUBCFG, ["train.views=[[0.1, 5]]", f"train.calibration={CONFIG}"], ["c.yaml"]),
    (TUBCFG, ["train.views=[[0.1, 5]]", f"train.calibration={F}/empty.json"], ["empty.json"]),
    (TUBCFG, ["train.views=[[0.1, 5]]", "train.calibration=[1, 2]"], ["train.calibration"]),
    (TUBCFG, ["train.views=[[0.1, 5]]", "train.recovery_s=0"], ["recovery_s"]),
    (TUBCFG, ["train.views=[[0.1, 5]]", "train.recovery_s=-0.3"], ["recovery_s"]),
    (TUBCFG, ["train.views=[[0.1, 5]]", "train.recovery_s=300"], ["recovery_s", "300"], "warn"),  # ms for s
    (TUBCFG, ["train.views=[[0.1, 5]]", "train.recovery_s=0.3s"], ["recovery_s", "0.3s"]),
    (TUBCFG, ["train.views=[[0.1, 5]]", "train.recovery_s=.inf"], ["recovery_s"]),
    (TUBCFG, ["train.views=[[0.1, 5]]", "train.recovery_s=0.3"], "ok"),
    (CONFIG, ["train.views=[[0.1, 5]]", "train.side_cameras=true"], "ok"),
    (TUBCFG, ["train.views=[[0.1, 5]]", "train.steering_ratio=15"], ["steering_ratio"], "ok"),  # a ratio: no rule
    # lane_weight and what it needs
    (CONFIG, ["train.lane_weight=0.5"], ["lane"]),
    (TRKCFG, ["train.lane_weight=0.5", "model.name=zero"], ["lane_weight", "zero"]),
    (TRKCFG, ["train.lane_weight=-1"], ["lane_weight"]),
    (TRKCFG, ["train.lane_weight=half"], ["lane_weight", "half"]),
    (TRKCFG, ["train.lane_weight=0.5", "train.views=[[0.1, 0]]"], ["lane_weight", "views"]),
    (TRKCFG, ["train.lane_weight=0.5", "train.side_cameras=true"], ["lane_weight", "side"]),
    (TRKCFG, ["train.lane_weight=0.5"], "ok"),
    (TRKCFG, ["train.lane_weight=1e6"], ["lane_weight"], "ok"),  # a weight: no rule bounds it
    (TUBCFG, ["train.lane_weight=0.5"], ["lane", "tub"]),
    (TUBCFG, [f"data={WOOD}", "train.lane_weight=0.5", "split.train=0:60", "split.val=60:80"],
     ["lane", "wood-tape"]),
    (TRKCFG, ["train.lane_weight=0.5", "model.name=donkey-linear"], "ok"),
    (TRKCFG, ["train.lane_weight=0.5", "model.name=multimodal-lstm"], ["lane_weight", "multimodal-lstm"]),
    # the real tub wood-tape
    (TUBCFG, [f"data={WOOD}", "split.train=0:6000", "split.val=6000:7000"], "ok"),
    (TUBCFG, [f"data={WOOD}", "split.train=0:9000", "split.val=60:80"], ["split.train", "8000"]),
    (TUBCFG, [f"data={WOOD}", "split.train=0:60", "split.val=50:80"], ["split", "overlap", "50"]),
    (TUBCFG, [f"data={WOOD}", "split.train=0:60", "split.val=60:80", "reader.full_lock_deg=0.44"],
     ["full_lock_deg", "radians"], "warn"),
    (TUBCFG, [f"data={WOOD}", "split.train=0:6000", "split.val=6000:7000", f"extra_data=[{WOOD}]"],
     ["extra_data", "wood-tape"]),
    (TUBCFG, [f"data={WOOD}", "split.train=0:6000", "split.val=6000:7000", f"extra_data=[{WOOD}/]"],
     ["extra_data", "wood-tape"]),
    (TUBCFG, [f"data={WOOD}", "split.train=0:6000", "split.val=6000:7000", f"extra_data=[{HALL}]"], "ok"),
    (TUBCFG, [f"data={WOOD}", "split.train=0:60", "split.val=60:80", f"extra_data=[{SIM}]"],
     ["sim", "wood-tape", "donkey"]),
    (TUBCFG, [f"data={WOOD}", "split.train=0:6000", "split.val=6000:7000", "train.views=[[[-0.15, 0.15], "
              "[-15, 15]]]", "train.recovery_s=0.3"], "ok"),
    (TUBCFG, [f"data={WOOD}", "range=0:20000", "split.train=0:60", "split.val=60:70"], ["range", "20000"]),
    (TUBCFG, [f"data={WOOD}/catalog_3.catalog", "split.train=0:6", "split.val=6:8"], ["catalog_3.catalog"]),
]
DRIVES = [  # --throttle-floor, --throttle-scale, --steer-by: (argv, hint or "ok")
    (["sim", "drive", DK, "--world", "track", "--throttle-floor", "20"], ["--throttle-floor"]),
    (["sim", "drive", DK, "--world", "track", "--throttle-floor", "-0.1"], ["--throttle-floor"]),
    (["sim", "drive", DK, "--world", "track", "--throttle-floor", "0.2"], "ok"),
    (["sim", "drive", DK, "--world", "track", "--throttle-floor", "0.6", "--max-throttle", "0.5"],
     ["throttle-floor", "throttle_floor", "max"]),
    (["sim", "drive", DK, "--world", "track", "--throttle-floor", "1.5"], ["--throttle-floor"]),
    (["sim", "drive", DK, "--world", "track", "--throttle-floor", "20%"], ["--throttle-floor", "20%"]),
    (["sim", "drive", DK, "--world", "track", "--throttle-scale", "0"], ["--throttle-scale"]),
    (["sim", "drive", DK, "--world", "track", "--throttle-scale", "-1.2"], ["--throttle-scale"]),
    (["sim", "drive", DK, "--world", "track", "--throttle-scale", "120"], ["--throttle-scale"]),
    (["sim", "drive", DK, "--world", "track", "--throttle-scale", "1.2x"], ["--throttle-scale"]),
    (["sim", "drive", DK, "--world", "track", "--throttle-scale", "nan"], ["--throttle-scale"]),
    (["sim", "drive", DK, "--world", "track", "--throttle-scale", "1.2", "--throttle", "0.3"],
     ["throttle-scale", "throttle_scale", "throttle"], "warn"),
    (["sim", "drive", CK, "--throttle-floor", "0.2"], ["throttle"]),
    (["sim", "drive", CK, "--throttle-scale", "1.2"], ["throttle"]),
    (["sim", "drive", CK, "--steer-by", "lane"], ["steer"]),
    (["sim", "drive", DK, "--world", "track", "--steer-by", "lanes"], ["lanes"]),
    (["sim", "drive", DK, "--world", "track", "--steer-by", "Lane"], ["Lane"]),
    (["sim", "drive", DK, "--world", "track", "--steer-by", "lane"], ["donkey.pt", "lane"]),
    (["sim", "drive", LANE, "--world", "track", "--steer-by", "lane"], "ok"),
    (["sim", "drive", LANE, "--world", "track", "--steer-by", "lane", "--steer-by", "steering"], ["--steer-by"]),
    (["sim", "drive", f"{F}/m.onnx", "--world", "track", "--steer-by", "lane"], ["m.onnx", "lane"]),
    (["sim", "drive", CK, "--world", "track", "--steer-by", "lane"], ["a.pt"]),
    (["sim", "bench", DK, "--world", "track", "--steer-by", "lane"], ["donkey.pt", "lane"]),
    (["sim", "bench", LANE, "--world", "track", "--steer-by", "lane"], "ok"),
    (["sim", "bench", LANE, DK, "--world", "track", "--steer-by", "lane"], ["donkey.pt", "lane"]),
    (["sim", "bench", DK, "--world", "track", "--throttle-floor", "2"], ["--throttle-floor"]),
    (["sim", "bench", DK, "--world", "track", "--throttle-scale", "0"], ["--throttle-scale"]),
    (["sim", "bench", CK, "--throttle-scale", "1.2"], ["throttle"]),
    (["sim", "bench", DK, "--world", "track", "--throttle-floor", "0.2", "--throttle-scale", "1.2",
      "--max-throttle", "1"], "ok"),
    (["replay", DK, "--data", TUB, "--throttle-floor", "0.2"], ["throttle-floor", "unrecognized"]),
    (["replay", DK, "--data", TUB, "--steer-by", "lane"], ["steer-by", "unrecognized"]),
    # the real tub wood-tape through the commands
    (["compile", "--data", WOOD, "--range", "0:50", "--cache", f"{W}/c"], "ok"),
    (["compile", "--data", WOOD, "--range", "0:9000", "--cache", f"{W}/c"], ["9000", "8000"]),
    (["compile", "--data", WOOD, "--range", "7990:8010", "--cache", f"{W}/c"], ["8010", "8000"]),
    (["compile", "--data", WOOD, "--camera", "left", "--cache", f"{W}/c"], ["left"]),
    (["compile", "--data", WOOD, "--preset", "ch2", "--range", "0:50", "--cache", f"{W}/c"], ["ch2", "crop"]),
    (["compile", "--data", WOOD, "--labels", f"{CH2}/labels.csv", "--cache", f"{W}/c"], ["--labels", "labels"]),
    (["compile", "--data", f"{WOOD}/images", "--cache", f"{W}/c"], ["images"]),
    (["compile", "--data", f"{WOOD}/manifest.json", "--cache", f"{W}/c"], ["manifest.json"]),
    (["compile", "--data", f"{WOOD}/catalog_0.catalog", "--cache", f"{W}/c"], ["catalog_0.catalog"]),
    (["compile", "--data", f"{WOOD}/catalog_0.catalog_manifest", "--cache", f"{W}/c"],
     ["catalog_0.catalog_manifest"]),
    (["compile", "--data", f"{S}/donkeycar/wood_tape", "--cache", f"{W}/c"], ["wood_tape"]),
    (["compile", "--data", WOOD, "--range", "0:50", "--reader", "full_lock_deg=0.44", "--cache", f"{W}/c"],
     ["full_lock_deg"], "warn"),
    (["evaluate", DK, "--data", WOOD, "--range", "0:20", "--out", f"{W}/ev-wood"], "ok"),
    (["evaluate", CK, "--data", WOOD, "--range", "0:20", "--out", f"{W}/ev-wood2"], ["a.pt", "wood-tape"]),
    (["evaluate", DK, "--data", WOOD, "--range", "0:20", "--out", WOOD], ["wood-tape"]),
    (["evaluate", DK, "--data", WOOD, "--range", "0:20", "--out", f"{WOOD}/eval"], ["wood-tape"]),
    (["evaluate", DK, "--data", WOOD, "--range", "0:20", "--reader", "full_lock_deg=30", "--out", f"{W}/ev-w30"],
     ["full_lock", "25", "30"], "warn"),
    (["replay", DK, "--data", WOOD, "--reader", "full_lock_deg=25", "--range", "0:100", "--speed", "60", "--out", f"{W}/rp-w"], ["--speed", "60"],
     "warn"),  # said as the road replay's --speed 60 is (round 2)
    (["replay", DK, "--data", WOOD, "--reader", "full_lock_deg=25", "--range", "0:100", "--world", "track", "--out", f"{W}/rp-w"], "ok"),
    (["replay", DK, "--data", WOOD, "--reader", "full_lock_deg=25", "--range", "0:100", "--world", "track", "--calibration", f"{F}/cal640.json",
      "--out", f"{W}/rp-w"], ["cal640.json", "640"]),
    (["replay", DK, "--data", WOOD, "--reader", "full_lock_deg=25", "--range", "0:100", "--world", "track", "--mount-height", "15", "--out",
      f"{W}/rp-w"], ["--mount-height"]),
    (["replay", DK, "--data", WOOD, "--reader", "full_lock_deg=25", "--range", "0:100", "--world", "track", "--pitch", "70", "--out", f"{W}/rp-w"],
     ["--pitch"]),
    (["latency", "--models", "zero", "--data", WOOD, "--range", "0:100", "--frames", "5", "--out", f"{W}/lat-w"],
     "ok"),
    (["export", DK, "--out", f"{W}/w8.onnx", "--int8", "--calib", WOOD, "--calib-range", "0:9000"], ["9000"]),
    (["sim", "record", "--world", "track", "--minutes", "0.01", "--out", WOOD], ["wood-tape"]),
    (["sim", "record", "--world", "track", "--minutes", "0.01", "--out", f"{WOOD}/images"], ["images",
                                                                                             "wood-tape"]),
    (["serve", DK, "--record", WOOD], ["wood-tape"]),
]
STUDIES = [  # python -m studies.X ARGV: refused in one line before any work (a run still going after 25 s: taken)
    ("studies/tub_replay.py", ["--tubs", "woodtape"], ["woodtape"]),
    ("studies/tub_replay.py", ["--tubs", "wood_tape"], ["wood_tape"]),
    ("studies/tub_replay.py", ["--tubs", "Wood-Tape"], ["Wood-Tape"]),
    ("studies/tub_replay.py", ["--tubs", ""], ["--tubs"]),
    ("studies/tub_replay.py", ["--tubs", "hall,"], ["--tubs"], "ok"),  # the empty name left out: taken
    ("studies/tub_replay.py", ["--tubs", "hall, wood-tape"], [" wood-tape", "--tubs"], "ok"),  # spaces stripped
    ("studies/tub_replay.py", ["--tubs", WOOD], ["--tubs", "wood-tape"]),
    ("studies/tub_replay.py", ["--tubs", "taped"], ["taped"]),
    ("studies/tub_replay.py", ["--epochs", "0"], ["--epochs"]),
    ("studies/tub_replay.py", ["--epochs", "1.5"], ["--epochs", "1.5"]),
    ("studies/tub_replay.py", ["--epochs", "1e9"], ["--epochs"]),
    ("studies/tub_replay.py", ["--seeds", "-1"], ["--seeds"]),
    ("studies/tub_replay.py", ["--seeds", "two"], ["--seeds", "two"]),
    ("studies/tub_replay.py", ["--seeds", "0,1"], ["--seeds", "0,1"]),
    ("studies/tub_replay.py", ["--out", f"{W}/tr"], ["--out", "unrecognized"]),
    ("studies/tub_replay.py", ["hall"], ["hall", "unrecognized"]),
    ("studies/tub_replay.py", ["--tubs", "hall", "--tubs", "wood-tape"], ["--tubs"]),
    ("studies/tub_replay.py", ["--folds", "last"], ["--folds", "unrecognized"]),
    ("studies/view_truth.py", ["--tracks", "21,3,x"], ["--tracks", "x"]),
    ("studies/view_truth.py", ["--tracks", "-1"], ["--tracks", "-1"]),
    ("studies/view_truth.py", ["--tracks", "21,21"], ["--tracks", "21"]),
    ("studies/view_truth.py", ["--tracks", ""], ["--tracks"]),
    ("studies/view_truth.py", ["--tracks", "21.5"], ["--tracks", "21.5"]),
    ("studies/view_truth.py", ["--tracks", "99999999999"], ["--tracks"]),
    ("studies/view_truth.py", ["--tracks", "21;3"], ["--tracks", "21;3"]),
    ("studies/view_truth.py", ["--out", SIM], ["sim"]),
    ("studies/view_truth.py", ["--out", CK], ["a.pt"]),
    ("studies/view_truth.py", ["--out", TUB], ["tub"]),
    ("studies/view_truth.py", ["--out", WOOD], ["wood-tape"]),
    ("studies/view_truth.py", ["--out", f"{F}/run"], ["run"]),
    ("studies/view_truth.py", ["--out"], ["--out"]),
    ("studies/view_truth.py", ["--moves", "0.1,0"], ["--moves", "unrecognized"]),
    ("studies/view_truth.py", ["--tracks", "21", "--tracks", "3"], ["--tracks"]),
]


def _camera(**kw):
    """The fields of a Camera (geometry.Camera) of a 160x120 frame, with `kw` in place."""
    return {"width": 160, "height": 120, "focal": 80.0, "cy": 60.0, "mount_height": 0.15, "pitch_deg": 15.0, **kw}


def _car(**kw):
    return {"wheelbase": 0.18, "steering_ratio": 1.0, "full_lock_deg": 25.0, "side_camera_offset_m": None,
            "lane_limit_m": 0.3, "speeds": (0.5, 5.0), **kw}


CAMERAS = [  # register_camera(name, Camera(**camera), crop, Car(**car)) through `register`: (label, kwargs, hint)
    ("a name with a space", {"name": "my cam"}, ["my cam"]),
    ("the name of a known camera", {"name": "sim"}, ["sim", "registered"]),
    ("the name 'donkey'", {"name": "donkey"}, ["donkey", "registered"]),
    ("a name of digits given as an int", {"name": 123}, ["123", "name"]),
    ("an empty name", {"name": ""}, ["name"]),
    ("a name with a slash", {"name": "cams/wide"}, ["cams/wide"]),
    ("camera as a dict", {"camera": "dict"}, ["camera", "Camera"]),
    ("car as a dict", {"car": "dict"}, ["car", "Car"]),
    ("camera and car swapped", {"swap": True}, ["camera", "car"]),
    ("crop of floats", {"crop": (0.5, 0, 0, 0)}, ["crop"]),
    ("crop negative", {"crop": (-10, 0, 0, 0)}, ["crop"]),
    ("crop taking the whole height", {"crop": (60, 60, 0, 0)}, ["crop", "120"]),
    ("crop of three values", {"crop": (0, 0, 0)}, ["crop"]),
    ("crop as a text", {"crop": "0,0,0,0"}, ["crop"]),
    ("crop None", {"crop": None}, ["crop"]),
    ("crop an int", {"crop": 5}, ["crop"]),
    ("crop of numpy ints", {"crop": tuple(np.int64(v) for v in (10, 0, 0, 0))}, ["crop"], "ok"),
    ("crop of bools", {"crop": (True, False, False, False)}, ["crop"]),
    ("camera width 0", {"cam": {"width": 0}}, ["width", "camera"]),
    ("camera width as a text", {"cam": {"width": "160"}}, ["width", "camera"]),
    ("camera width a float", {"cam": {"width": 160.0}}, ["width", "camera"]),
    ("camera focal negative", {"cam": {"focal": -80.0}}, ["focal"]),
    ("camera focal nan", {"cam": {"focal": float("nan")}}, ["focal"]),
    ("camera height in cm", {"cam": {"mount_height": 150.0}}, ["mount_height"], "warn"),
    ("camera pitch in radians", {"cam": {"pitch_deg": 0.26}}, ["pitch"], "ok"),
    ("camera pitch 120 degrees", {"cam": {"pitch_deg": 120.0}}, ["pitch"]),
    ("camera cy outside the frame", {"cam": {"cy": 500.0}}, ["cy"]),
    ("car full lock in radians", {"car_kw": {"full_lock_deg": 0.44}}, ["full_lock_deg", "radians"], "warn"),
    ("car wheelbase negative", {"car_kw": {"wheelbase": -0.18}}, ["wheelbase"]),
    ("car speeds reversed", {"car_kw": {"speeds": (5.0, 0.5)}}, ["speeds"]),
    ("registered twice", {"twice": True}, ["registered"]),
    ("registered, then used by latency --geometry", {"then": ["latency", "--models", "zero", "--geometry", "wide",
                                                               "--frames", "5", "--out", f"{W}/lat-wide"]}, [], "ok"),
    ("registered, then a case variant used", {"then": ["latency", "--models", "zero", "--geometry", "Wide",
                                                        "--frames", "5", "--out", f"{W}/lat-wide"]}, ["Wide"]),
]


def _b_rows():
    rows = []
    for value, cfg, hint, *expect in VIEWS:
        row = {"cli": ["train", cfg, f"train.views={value}", f"out={W}/tv"], "stage": True}
        if hint == "ok":
            row.update(expect="ok")
        else:
            row.update(hint=hint, **({"expect": expect[0]} if expect else {}))
        rows.append(row)
    for cfg, overrides, hint, *expect in TRAIN_KEYS:
        row = {"cli": ["train", cfg, *overrides, f"out={W}/tk"], "stage": hint == "ok", "timeout": 90}
        row.update({"expect": "ok"} if hint == "ok" else {"hint": hint, **({"expect": expect[0]} if expect else {})})
        rows.append(row)
    for argv, hint, *expect in DRIVES:
        if argv[:2] in (["sim", "drive"], ["sim", "bench"]) and "--out" not in argv:
            argv = [*argv, "--minutes", "0.01", "--out", f"{W}/dv"]
        row = {"cli": argv, "stage": hint == "ok" and argv[:2] == ["sim", "bench"], "timeout": 120}
        row.update({"expect": "ok"} if hint == "ok" else {"hint": hint, **({"expect": expect[0]} if expect else {})})
        rows.append(row)
    rows += [{"name": f"{path} " + " ".join(argv), "build": "tests.rounds.round2_scripts:script",
              "kwargs": {"path": path, "argv": argv}, "hint": hint, "timeout": 60,
              **({"expect": expect[0], "refuse_ok": True} if expect else {})} for path, argv, hint, *expect in STUDIES]
    rows += [{"name": f"register_camera: {label}", "api": f"{HERE}:register", "kwargs": kw, "hint": hint,
              **({"expect": expect[0]} if expect else {})} for label, kw, hint, *expect in CAMERAS]
    return _g(rows, "B")


def register(name="wide", crop=(0, 0, 0, 0), cam=None, car="Car", camera="Camera", car_kw=None, swap=False,
             twice=False, then=None):
    """`cameras.register_camera` with a camera and car made from `cam` and `car_kw` (or given as dicts), then
    `then` (a command line) run."""
    from steerlab.data.cameras import register_camera
    from steerlab.data.car import Car
    from steerlab.data.geometry import Camera

    c = Camera(**_camera(**(cam or {}))) if camera == "Camera" else _camera(**(cam or {}))
    k = Car(**_car(**(car_kw or {}))) if car == "Car" else _car(**(car_kw or {}))
    if swap:
        c, k = k, c
    register_camera(name, c, crop, k)
    if twice:
        register_camera(name, c, crop, k)
    if then:
        from steerlab.cli import main

        code = main([places.fill(a) for a in then])
        if code:
            raise SystemExit(code)


# C. real-world data mistakes: a copy of a fixture edited by `edit`, then a command on it ({copy})
def _records(d):
    return [json.loads(line) for line in (d / "catalog_0.catalog").read_text().splitlines() if line.strip()]


def _write_records(d, recs, keep_manifest=False):
    lines = [json.dumps(r) for r in recs]
    (d / "catalog_0.catalog").write_text("\n".join(lines) + "\n")
    if not keep_manifest:
        m = json.loads((d / "catalog_0.catalog_manifest").read_text())
        m["line_lengths"] = [len(line) + 1 for line in lines]
        (d / "catalog_0.catalog_manifest").write_text(json.dumps(m) + "\n")


def _record(i, **kw):
    def f(d):
        recs = _records(d)
        for k, v in kw.items():
            k = k.replace("__", "/")
            if v is _DROP:
                recs[i].pop(k, None)
            else:
                recs[i][k] = v
        _write_records(d, recs)
    return f


_DROP = object()


def _manifest(line, **kw):
    def f(d):
        lines = (d / "manifest.json").read_text().splitlines()
        m = json.loads(lines[line])
        m.update(kw)
        lines[line] = json.dumps(m)
        (d / "manifest.json").write_text("\n".join(lines) + "\n")
    return f


def _manifest_text(change):
    def f(d):
        (d / "manifest.json").write_text(change((d / "manifest.json").read_text()))
    return f


def _bytes(name, change):
    def f(d):
        p = d / name
        p.write_bytes(change(p.read_bytes()))
    return f


def _images(size, pattern, which=None, gray=False):
    import cv2

    def f(d):
        frames = sorted(d.rglob(pattern))
        for fr in frames if which is None else [frames[which]]:
            img = np.full((*size, 3), 90, np.uint8)
            cv2.imwrite(str(fr), cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) if gray else img)
    return f


def _lines(name, change):
    """The lines of the file `name` in the copy changed by `change(lines) -> lines` (text)."""
    def f(d):
        p = d / name
        p.write_text("\n".join(change(p.read_text().splitlines())) + "\n")
    return f


def _log(change):
    """The driving log's lines changed by `change(lines) -> lines` (text)."""
    return _lines("driving_log.csv", change)


def _cols(fn):
    return _log(lambda lines: [",".join(fn(line.split(","), i)) for i, line in enumerate(lines)])


def _set(col, value, rows=None):
    return _cols(lambda c, i: c[:col] + [value if callable(value) is False else value(c[col])] + c[col + 1:]
                 if rows is None or i in rows else c)


def _labels(change):
    return _lines("labels.csv", change)


def _png_as_jpg(d):
    import cv2

    fr = sorted((d / "images").glob("*.jpg"))[2]
    cv2.imwrite(str(fr.with_suffix(".png")), np.full((120, 160, 3), 90, np.uint8))
    fr.with_suffix(".png").replace(fr)


def _empty_image(d):
    sorted((d / "images").glob("*.jpg"))[2].write_bytes(b"")


def _half_image(d):
    p = sorted((d / "images").glob("*.jpg"))[2]
    p.write_bytes(p.read_bytes()[: len(p.read_bytes()) // 2])


def _blank_line(d):
    recs = (d / "catalog_0.catalog").read_text().splitlines()
    (d / "catalog_0.catalog").write_text("\n".join(recs[:4] + [""] + recs[4:]) + "\n")


def _edit_catalog_by_hand(d):  # a value changed in an editor: the line's length no longer the manifest's
    text = (d / "catalog_0.catalog").read_text().replace('"user/angle": 0.1', '"user/angle": 0.15', 1)
    (d / "catalog_0.catalog").write_text(text)


def _renamed_key(d):
    recs = _records(d)
    for r in recs:
        r["angle"] = r.pop("user/angle")
    _write_records(d, recs)


def _seconds(d):
    recs = _records(d)
    for r in recs:
        r["_timestamp_ms"] = r["_timestamp_ms"] / 1000.0
    _write_records(d, recs)


def _images_renamed(d):
    for p in (d / "images").glob("*.jpg"):
        p.rename(p.with_name(p.name.replace("_cam_image_array_", "")))


def _catalog_removed(d):
    (d / "catalog_0.catalog").unlink()
    (d / "catalog_0.catalog_manifest").unlink()


def _two_catalogs_one_listed(d):  # a second catalog on disk that the manifest does not list
    shutil.copy(d / "catalog_0.catalog", d / "catalog_1.catalog")


def _tub_v1(d):  # donkeycar's old tub v1 layout: record_N.json files, meta.json
    for i, r in enumerate(_records(d)):
        (d / f"record_{i}.json").write_text(json.dumps({"cam/image_array": r["cam/image_array"],
                                                        "user/angle": r["user/angle"],
                                                        "user/throttle": r["user/throttle"]}))
    for name in ("catalog_0.catalog", "catalog_0.catalog_manifest", "manifest.json"):
        (d / name).unlink()
    (d / "meta.json").write_text(json.dumps({"inputs": ["cam/image_array", "user/angle", "user/throttle"],
                                             "types": ["image_array", "float", "float"]}))


def _wood_cut(d, update=False):
    """The real wood-tape tub cut by hand to its first catalog (its first 1000 records): the manifest updated
    or, as a hurried owner does, not."""
    if update:
        _manifest(4, paths=["catalog_0.catalog"], current_index=1000)(d)


def _windows_paths(lines):
    out = []
    for line in lines:
        c = line.split(",")
        c[0] = "C:\\Users\\me\\Desktop\\data\\IMG\\" + c[0].split("/")[-1]
        out.append(",".join(c))
    return out


def _cr_only(d):
    p = d / "driving_log.csv"
    p.write_bytes(p.read_bytes().replace(b"\n", b"\r"))


def _mixed_endings(d):
    p = d / "driving_log.csv"
    lines = p.read_bytes().split(b"\n")
    p.write_bytes(b"\r\n".join(lines[:4]) + b"\n" + b"\n".join(lines[4:]))


def _bom_header(d):
    p = d / "driving_log.csv"
    p.write_bytes(b"\xef\xbb\xbfcenter,left,right,steering,throttle,brake,speed\r\n"
                  + p.read_bytes().replace(b"\n", b"\r\n"))


def _utf16_bom_labels(d):
    p = d / "labels.csv"
    p.write_bytes(p.read_text().encode("utf-16-le").join([b"\xff\xfe", b""]))


def _excel_labels(lines):  # saved by a European Excel: semicolons, decimal commas
    return [lines[0].replace(",", ";")] + [";".join(v.replace(".", ",") for v in line.split(",")) for line in lines[1:]]


def _scientific_ids(lines):  # frame ids as Excel shows them
    return [lines[0]] + [",".join([f"{int(line.split(',')[0]):.4E}", *line.split(",")[1:]]) for line in lines[1:]]


def _degrees_labels(lines):
    return [lines[0]] + [",".join([c[0], f"{float(c[1]) * 57.3 + 5 * i:.2f}", c[2]])
                         for i, c in enumerate(line.split(",") for line in lines[1:])]


EDITS = {  # name: (fixture copied, the edit, the command on the copy, hint, expect)
    # tubs: catalog and manifest edited by hand
    "tub: an angle in degrees": (TUB, _record(3, user__angle=12.5), "compile", ["catalog_0.catalog", "user/angle"]),
    "tub: an angle as a text": (TUB, _record(3, user__angle="0.1"), "compile", ["catalog_0.catalog", "user/angle"]),
    "tub: an angle null": (TUB, _record(3, user__angle=None), "compile", ["catalog_0.catalog", "user/angle"]),
    "tub: an angle NaN": (TUB, _bytes("catalog_0.catalog", lambda b: b.replace(b'"user/angle": 0.1', b'"user/angle":'
                                                                                 b' NaN', 1)), "compile",
                          ["catalog_0.catalog", "user/angle", "NaN"]),
    "tub: a throttle in percent": (TUB, _record(2, user__throttle=30), "compile", ["catalog_0.catalog",
                                                                                   "user/throttle"]),
    "tub: a record without its throttle": (TUB, _record(2, user__throttle=_DROP), "compile",
                                           ["catalog_0.catalog", "user/throttle"], "ok"),  # compile reads none
    "tub: a record without its image key": (TUB, _record(2, cam__image_array=_DROP), "compile",
                                            ["catalog_0.catalog", "cam/image_array"]),
    "tub: user/angle renamed angle in every record": (TUB, _renamed_key, "compile", ["user/angle"]),
    "tub: an _index twice": (TUB, _record(4, _index=3), "compile", ["catalog_0.catalog", "_index", "3"]),
    "tub: an _index as a text": (TUB, _record(4, _index="4"), "compile", ["catalog_0.catalog", "_index"]),
    "tub: a timestamp going back": (TUB, _record(5, _timestamp_ms=900), "compile",
                                    ["timestamps", "frame 5"], "warn"),
    "tub: timestamps in seconds": (TUB, _seconds, "compile", ["_timestamp_ms", "catalog_0.catalog"], "warn"),
    "tub: an image named .png": (TUB, _record(3, cam__image_array="3_cam_image_array_.png"), "compile",
                                 ["3_cam_image_array_.png"]),
    "tub: an image named by its path": (TUB, _record(3, cam__image_array="images/3_cam_image_array_.jpg"),
                                        "compile", ["images/3_cam_image_array_.jpg"], "ok"),
    "tub: the images renamed": (TUB, _images_renamed, "compile", ["0_cam_image_array_.jpg", "images"]),
    "tub: a PNG saved as .jpg": (TUB, _png_as_jpg, "compile", ["2_cam_image_array_.jpg"], "ok"),
    "tub: an empty image": (TUB, _empty_image, "compile", ["2_cam_image_array_.jpg"]),
    "tub: half an image": (TUB, _half_image, "compile", ["2_cam_image_array_.jpg"]),
    "tub: a gray JPEG among colour ones": (TUB, _images((120, 160), "*.jpg", 3, gray=True), "compile",
                                           ["3_cam_image_array_.jpg"], "ok"),
    "tub: every image 320x240": (TUB, _images((240, 320), "*.jpg"), "evaluate", ["320x240", "donkey", "160x120"]),
    "tub: one image 320x240": (TUB, _images((240, 320), "*.jpg", 3), "compile", ["3_cam_image_array_.jpg"]),
    "tub: every image 224x224": (TUB, _images((224, 224), "*.jpg"), "evaluate", ["224x224", "160x120"]),
    "tub: manifest paths a missing catalog": (TUB, _manifest(4, paths=["catalog_0.catalog", "catalog_1.catalog"]),
                                              "compile", ["catalog_1.catalog"]),
    "tub: manifest paths empty": (TUB, _manifest(4, paths=[]), "compile", ["manifest.json", "paths"]),
    "tub: manifest paths a text": (TUB, _manifest(4, paths="catalog_0.catalog"), "compile",
                                   ["manifest.json", "paths"]),
    "tub: manifest deleted_indexes as texts": (TUB, _manifest(4, deleted_indexes=["2"]), "compile",
                                               ["manifest.json", "deleted_indexes"]),
    "tub: manifest deleted_indexes all": (TUB, _manifest(4, deleted_indexes=list(range(8))), "compile",
                                          ["deleted", "tub"]),
    "tub: manifest deleted_indexes a range text": (TUB, _manifest(4, deleted_indexes="2-4"), "compile",
                                                   ["manifest.json", "deleted_indexes"]),
    "tub: manifest current_index short": (TUB, _manifest(4, current_index=3), "compile", ["current_index"], "ok"),
    "tub: manifest of four lines": (TUB, _manifest_text(lambda t: "\n".join(t.splitlines()[:4]) + "\n"), "compile",
                                    ["manifest.json"]),
    "tub: manifest with a trailing comma": (TUB, _manifest_text(lambda t: t.replace("]}", "],}", 1)), "compile",
                                            ["manifest.json"]),
    "tub: manifest as one JSON document": (TUB, _manifest_text(lambda t: "[" + ",".join(t.splitlines()) + "]\n"),
                                           "compile", ["manifest.json"]),
    "tub: manifest CRLF": (TUB, _manifest_text(lambda t: t.replace("\n", "\r\n")), "compile", ["manifest.json"],
                           "ok"),
    "tub: manifest with a BOM": (TUB, _manifest_text(lambda t: "\ufeff" + t), "compile", ["manifest.json"], "ok"),
    "tub: manifest removed": (TUB, lambda d: (d / "manifest.json").unlink(), "compile", ["manifest.json"]),
    "tub: catalogs removed": (TUB, _catalog_removed, "compile", ["catalog_0.catalog"]),
    "tub: a catalog on disk not in the manifest": (TUB, _two_catalogs_one_listed, "compile", ["catalog_1.catalog"],
                                                   "ok"),  # as donkeycar reads a tub: its manifest's catalogs
    "tub: catalog CRLF": (TUB, _bytes("catalog_0.catalog", lambda b: b.replace(b"\n", b"\r\n")), "compile",
                          ["catalog_0.catalog"], "ok"),
    "tub: catalog with a BOM": (TUB, _bytes("catalog_0.catalog", lambda b: b"\xef\xbb\xbf" + b), "compile",
                                ["catalog_0.catalog"], "ok"),
    "tub: a blank line in the catalog": (TUB, _blank_line, "compile", ["catalog_0.catalog"], "ok"),
    "tub: a value edited by hand (line lengths off)": (TUB, _edit_catalog_by_hand, "compile",
                                                       ["catalog_0.catalog"], "ok"),
    "tub: catalog_manifest removed": (TUB, lambda d: (d / "catalog_0.catalog_manifest").unlink(), "compile",
                                      ["catalog_0.catalog_manifest"], "ok"),
    "tub: a catalog record with single quotes": (TUB, _bytes("catalog_0.catalog", lambda b: b.replace(b'"user/mode": '
                                                 b'"user"', b"'user/mode': 'user'", 1)), "compile",
                                                 ["catalog_0.catalog"], "warn"),
    "tub: donkeycar's old v1 layout": (TUB, _tub_v1, "compile", ["tub", "v1", "record_"]),
    "tub: pilot-mode records": (TUB, _record(3, user__mode="local"), "compile", ["user/mode"], "ok"),
    # driving logs
    "log: Windows paths": (SIM, _log(_windows_paths), "compile", ["driving_log.csv"], "ok"),
    "log: a header row": (SIM, _log(lambda ls: ["center,left,right,steering,throttle,brake,speed", *ls]), "compile",
                          ["driving_log.csv"], "ok"),
    "log: a header row with a BOM, CRLF": (SIM, _bom_header, "compile", ["driving_log.csv"], "ok"),
    "log: semicolons": (SIM, _log(lambda ls: [line.replace(",", ";") for line in ls]), "compile",
                        ["driving_log.csv"]),
    "log: European Excel (semicolons, decimal commas)": (SIM, _log(lambda ls: [";".join(c.replace(".", ",")
                                                                                        if "/" not in c else c
                                                                                        for c in line.split(","))
                                                                               for line in ls]), "compile",
                                                         ["driving_log.csv"]),
    "log: tabs": (SIM, _log(lambda ls: [line.replace(",", "\t") for line in ls]), "compile", ["driving_log.csv"]),
    "log: spaces after commas": (SIM, _log(lambda ls: [line.replace(",", ", ") for line in ls]), "compile",
                                 ["driving_log.csv"], "ok"),
    "log: quoted fields": (SIM, _log(lambda ls: [",".join(f'"{c}"' for c in line.split(",")) for line in ls]),
                           "compile", ["driving_log.csv"], "ok"),
    "log: relative paths": (SIM, _cols(lambda c, i: ["IMG/" + c[0].split("/")[-1], *c[1:]]), "compile",
                            ["driving_log.csv"], "ok"),
    "log: steering in degrees": (SIM, _set(3, "12.5", {2}), "compile", ["driving_log.csv", "steering", "3"]),
    "log: throttle in percent": (SIM, _set(4, "50", {2}), "compile", ["driving_log.csv", "throttle"]),
    "log: speed in km/h": (SIM, _set(6, "110"), "compile", ["driving_log.csv", "speed"], "warn"),
    "log: speed negative": (SIM, _set(6, "-3", {1}), "compile", ["driving_log.csv", "speed"]),
    "log: steering a text": (SIM, _set(3, "left", {1}), "compile", ["driving_log.csv", "left"]),
    "log: steering empty": (SIM, _set(3, "", {1}), "compile", ["driving_log.csv", "steering"]),
    "log: six columns (no speed)": (SIM, _cols(lambda c, i: c[:6]), "compile", ["driving_log.csv", "7"]),
    "log: a row of six columns": (SIM, _cols(lambda c, i: c[:6] if i == 3 else c), "compile",
                                  ["driving_log.csv", "4"]),
    "log: an image that is not there": (SIM, _cols(lambda c, i: [c[0].replace("000.jpg", "050.jpg"), *c[1:]]),
                                        "compile", ["center_2020_01_01_00_00_00_050.jpg"]),
    "log: the same row twice": (SIM, _log(lambda ls: ls[:3] + ls[2:]), "compile", ["driving_log.csv", "twice",
                                                                                   "center_"], "warn"),
    "log: rows out of time order": (SIM, _log(lambda ls: [ls[0], ls[2], ls[1], *ls[3:]]), "compile",
                                    ["driving_log.csv", "order", "center_"], "warn"),
    "log: CR line endings (old Mac)": (SIM, _cr_only, "compile", ["driving_log.csv"], "ok"),
    "log: mixed line endings": (SIM, _mixed_endings, "compile", ["driving_log.csv"], "ok"),
    "log: renamed driving-log.csv": (SIM, lambda d: (d / "driving_log.csv").rename(d / "driving-log.csv"), "compile",
                                     ["driving_log.csv", "driving-log.csv", "sim"]),
    "log: IMG renamed img": (SIM, lambda d: (d / "IMG").rename(d / "img"), "compile", ["IMG", "center_"]),
    "log: IMG zipped away (IMG.zip)": (SIM, lambda d: (shutil.make_archive(str(d / "IMG"), "zip", d / "IMG"),
                                                       shutil.rmtree(d / "IMG")), "compile", ["IMG", "center_"]),
    # label files
    "labels: a French header": (CH2, _labels(lambda ls: ["frame_id,angle_de_braquage,public", *ls[1:]]), "compile",
                                ["labels.csv", "steering_angle"]),
    "labels: a German header": (CH2, _labels(lambda ls: ["bild_id,lenkwinkel,öffentlich", *ls[1:]]), "compile",
                                ["labels.csv", "frame_id"]),
    "labels: a Chinese header": (CH2, _labels(lambda ls: ["帧编号,转向角,公开", *ls[1:]]), "compile",
                                 ["labels.csv", "frame_id"]),
    "labels: a capitalised header": (CH2, _labels(lambda ls: ["Frame_ID,Steering_Angle,Public", *ls[1:]]), "compile",
                                     ["labels.csv", "frame_id"], "ok"),
    "labels: no header": (CH2, _labels(lambda ls: ls[1:]), "compile", ["labels.csv", "frame_id"]),
    "labels: in degrees": (CH2, _labels(_degrees_labels), "compile", ["labels.csv", "degrees"], "warn"),
    "labels: European Excel": (CH2, _labels(_excel_labels), "compile", ["labels.csv"]),
    "labels: frame ids in scientific notation": (CH2, _labels(_scientific_ids), "compile", ["labels.csv"]),
    "labels: frame ids as floats": (CH2, _labels(lambda ls: [ls[0]] + [line.replace(",", ".0,", 1) for line in ls[1:]]),
                                    "compile", ["labels.csv"], "ok"),
    "labels: no public column": (CH2, _labels(lambda ls: [line.rsplit(",", 1)[0] for line in ls]), "compile",
                                 ["labels.csv"], "ok"),
    "labels: UTF-16 with a BOM (Excel's Unicode text)": (CH2, _utf16_bom_labels, "compile", ["labels.csv"]),
    "labels: a frame id no image has": (CH2, _labels(lambda ls: ls[:3] + ["1234,0.0,1"] + ls[3:]), "compile",
                                        ["1234", "labels.csv"]),
    "labels: angle columns swapped with public": (CH2, _labels(lambda ls: ["frame_id,public,steering_angle"] +
                                                               ls[1:]), "compile", ["labels.csv"], "ok"),
    # the real tub cut by hand
    "wood-tape cut to one catalog, manifest left as it was": ("wood", _wood_cut, "compile", ["catalog_1.catalog"]),
    "wood-tape cut to one catalog, manifest updated": ("wood", lambda d: _wood_cut(d, True), "compile1000", [],
                                                       "ok"),
}
CALIBS = [  # (name, content, hint, expect): train.calibration of the tub with views, and sim record --calibration
    ("another image size", {**CALIBRATION, "image_size": [640, 480]}, ["640", "160x120"], "refuse"),
    ("image size as height, width", {**CALIBRATION, "image_size": [120, 160]}, ["120x160", "160x120"], "refuse"),
    ("K flat", {**CALIBRATION, "K": [81.0, 0, 80.0, 0, 80.0, 61.0, 0, 0, 1]}, [], "ok"),
    ("D of five (a pinhole calibration)", {**CALIBRATION, "D": [-0.02, -0.01, 0.0, 0.005, 0.001]}, ["D", "four"],
     "refuse"),
    ("D missing", {k: v for k, v in CALIBRATION.items() if k != "D"}, ["D"], "refuse"),
    ("K missing", {k: v for k, v in CALIBRATION.items() if k != "K"}, ["K"], "refuse"),
    ("fx negative", {**CALIBRATION, "K": [[-81.0, 0, 80.0], [0, 80.0, 61.0], [0, 0, 1]]}, ["fx", "K"], "refuse"),
    ("K of a 640x480 calibration at 160x120", {**CALIBRATION, "K": [[320.0, 0, 320.0], [0, 320.0, 240.0],
                                                                   [0, 0, 1]]}, ["320", "K", "cx"], "refuse"),
    ("K transposed", {**CALIBRATION, "K": [[81.0, 0, 0], [0, 80.0, 0], [80.0, 61.0, 1]]}, ["K"], "refuse"),
    ("D in degrees?", {**CALIBRATION, "D": [-2.0, -1.0, 0.0, 0.5]}, ["D"], "warn"),
    ("a text, not JSON", "image_size: 160x120", ["cal-"], "refuse"),
    ("JSON with comments", '{"image_size": [160, 120], // the Pi camera\n "K": [[81, 0, 80], [0, 80, 61], [0, 0, 1]],'
                           ' "D": [0, 0, 0, 0]}', ["cal-"], "refuse"),
    ("OpenCV FileStorage YAML", "%YAML:1.0\n---\nimage_width: 160\nimage_height: 120\nK: !!opencv-matrix\n   rows: 3\n"
                                "   cols: 3\n   dt: d\n   data: [81., 0., 80., 0., 80., 61., 0., 0., 1.]\nD: !!opencv-"
                                "matrix\n   rows: 4\n   cols: 1\n   dt: d\n   data: [-0.02, -0.01, 0., 0.005]\n",
     [], "ok"),
    ("ROS camera_info YAML", "image_width: 160\nimage_height: 120\ncamera_matrix:\n  rows: 3\n  cols: 3\n  data: [81, "
                             "0, 80, 0, 80, 61, 0, 0, 1]\ndistortion_model: equidistant\ndistortion_coefficients:\n"
                             "  rows: 1\n  cols: 4\n  data: [-0.02, -0.01, 0.0, 0.005]\n", [], "ok"),
    ("ROS camera_info of a plumb_bob model", "image_width: 160\nimage_height: 120\ncamera_matrix:\n  rows: 3\n  cols: "
                                             "3\n  data: [81, 0, 80, 0, 80, 61, 0, 0, 1]\ndistortion_model: plumb_bob"
                                             "\ndistortion_coefficients:\n  rows: 1\n  cols: 5\n  data: [-0.02, -0.01,"
                                             " 0.0, 0.005, 0.0]\n", ["distortion", "plumb_bob", "D", "four"],
     "refuse"),
    ("DIM instead of image_size", {"DIM": [160, 120], "K": CALIBRATION["K"], "D": CALIBRATION["D"]}, [], "ok"),
    ("D nested [[k1], [k2], [k3], [k4]]", {**CALIBRATION, "D": [[-0.02], [-0.01], [0.0], [0.005]]}, [], "ok"),
    ("numbers as texts", {**CALIBRATION, "D": ["-0.02", "-0.01", "0.0", "0.005"]}, ["D"], "refuse"),
    ("an empty JSON object", {}, ["image_size", "cal-"], "refuse"),
]


def _c_rows():
    rows = []
    for name, (src, edit, cmd, hint, *expect) in EDITS.items():
        row = {"name": f"{cmd} of a copy: {name}", "build": "edited", "kwargs": {"src": src, "name": name,
                                                                                  "cmd": cmd}, "hint": hint,
               "timeout": 120 if src == "wood" else 45}
        if expect:
            row["expect"] = expect[0]
            if expect[0] == "ok":
                row["refuse_ok"] = True  # what is tried: one line or taken, never a traceback
        rows.append(row)
    for name, content, hint, expect in CALIBS:
        for how in ("train", "record"):
            rows.append({"name": f"{how} with a calibration: {name}", "build": "with_calibration",
                         "kwargs": {"name": name, "content": content, "how": how}, "hint": hint or ["cal-"],
                         "expect": expect})
    units = [  # values in other units than the option's, on the command line
        (["replay", CK, "--data", SIM, "--fov", "1.2", "--out", f"{W}/rp-u"], ["--fov"], "refuse"),
        (["replay", CK, "--data", REAL_SIM, "--range", "0:100", "--max-heading", "0.17", "--out", f"{W}/rp-u"],
         ["--max-heading"], "warn"),
        (["replay", CK, "--data", REAL_SIM, "--range", "0:100", "--pitch", "0.1", "--out", f"{W}/rp-u"], ["--pitch"],
         "ok"),
        (["replay", CK, "--data", SIM, "--mount-height", "140", "--out", f"{W}/rp-u"], ["--mount-height"], "warn"),
        (["replay", CK, "--data", REAL_SIM, "--range", "0:100", "--limit", "100", "--out", f"{W}/rp-u"], ["--limit"],
         "warn"),
        (["replay", DK, "--data", TUB, "--world", "track", "--lane-width", "90", "--out", f"{W}/rp-u"],
         ["--lane-width", "lane_width"], "warn"),
        (["replay", DK, "--data", WOOD, "--reader", "full_lock_deg=25", "--range", "0:100", "--world", "track",
          "--speed", "30", "--out", f"{W}/rp-u"], ["--speed"], "warn"),  # beyond twice the small car's 8 m/s
        (["sim", "record", "--world", "track", "--mount-height", "15", "--minutes", "0.01", "--out", f"{W}/r-u"],
         ["--mount-height"], "refuse"),
        (["sim", "record", "--world", "track", "--pitch", "0.35", "--minutes", "0.01", "--out", f"{W}/r-u"],
         ["--pitch"], "ok"),
        (["sim", "record", "--world", "track", "--lane-width", "60", "--minutes", "0.01", "--out", f"{W}/r-u"],
         ["--lane-width", "lane_width"], "warn"),
        (["sim", "drive", DK, "--world", "track", "--latency", "50", "--minutes", "0.01", "--out", f"{W}/d-u"],
         ["--latency"], "refuse"),
        (["sim", "drive", DK, "--world", "track", "--latency", "0.05", "--minutes", "0.01", "--out", f"{W}/d-u"],
         ["--latency", "0.05"], "refuse"),
        (["sim", "drive", CK, "--limit-m", "100", "--minutes", "0.01", "--out", f"{W}/d-u"], ["--limit-m"], "warn"),
        (["sim", "drive", DK, "--world", "track", "--throttle", "30", "--minutes", "0.01", "--out", f"{W}/d-u"],
         ["--throttle"], "refuse"),
        (["sim", "record", "--fps", "0.05", "--minutes", "1", "--out", f"{W}/r-u"], ["--fps"], "warn"),
        (["train", CONFIG, "train.rotation_deg=0.2", f"out={W}/tu"], ["rotation_deg"], "ok"),
        (["train", CONFIG, "train.side_offset_m=20", f"out={W}/tu"], ["side_offset_m"], "warn"),
        (["train", CONFIG, "train.target_shift_s=100", f"out={W}/tu"], ["target_shift_s"], "warn"),
        (["train", CONFIG, "train.min_speed=15", f"out={W}/tu"], ["min_speed"], "warn"),
        (["train", CONFIG, "train.hue_deg=3.14", "preprocess.color=rgb", f"out={W}/tu"], ["hue_deg"], "ok"),
        (["train", CONFIG, "train.lr=3", f"out={W}/tu"], ["train.lr"], "warn"),
        (["train", CONFIG, "train.brightness=25", f"out={W}/tu"], ["brightness"], "refuse"),
        (["train", CONFIG, "train.recovery_distance_m=1500", f"out={W}/tu"], ["recovery_distance_m"], "warn"),
        (["compile", "--data", TUB, "--reader", "full_lock_deg=0.44", "--cache", f"{W}/c"], ["full_lock_deg"],
         "warn"),
        (["compile", "--data", TUB, "--reader", "full_lock_deg=250", "--cache", f"{W}/c"], ["full_lock_deg"],
         "refuse"),
    ]
    for argv, hint, expect in units:
        row = {"cli": argv, "hint": hint, "expect": expect, "timeout": 90}
        if expect == "ok":
            row["refuse_ok"] = True
        rows.append(row)
    return _g(rows, "C")


def edited(src, name, cmd):
    """`cmd` (compile, or evaluate of donkey.pt) on a copy of `src` edited as EDITS[name] says."""
    from steerlab.cli import main

    slug = "".join(ch if ch.isalnum() else "-" for ch in name)[:60]
    d = places.WORK / "edited" / slug
    shutil.rmtree(d, ignore_errors=True)
    d.parent.mkdir(parents=True, exist_ok=True)
    if src == "wood":
        wood = Path(places.fill(WOOD))
        d.mkdir()
        (d / "images").mkdir()
        for f in ("manifest.json", "catalog_0.catalog", "catalog_0.catalog_manifest"):
            shutil.copy(wood / f, d / f)
        for i in range(1000):
            p = wood / "images" / f"{i}_cam_image_array_.jpg"
            if p.exists():
                shutil.copy(p, d / "images" / p.name)
    else:
        shutil.copytree(places.fill(src), d, symlinks=True)
    EDITS[name][1](d)
    labels = ["--labels", str(d / "labels.csv")] if src == CH2 and (d / "labels.csv").exists() else []
    if cmd == "evaluate":
        return main(["evaluate", str(places.FIX / "donkey.pt"), "--data", str(d), "--out",
                     str(places.WORK / "ev-edited" / slug)])
    rng = ["--range", "0:1000"] if cmd == "compile1000" else []
    return main(["compile", "--data", str(d), *labels, *rng, "--cache", str(places.WORK / "cache")])


def with_calibration(name, content, how):
    """train of the tub with a view and `train.calibration` of `content`, or `sim record --world track
    --calibration`."""
    from steerlab.cli import main

    slug = "".join(ch if ch.isalnum() else "-" for ch in name)[:50]
    suffix = ".yaml" if isinstance(content, str) and ("YAML" in name or "ROS" in name) else ".json"
    p = places.WORK / f"cal-{slug}{suffix}"
    p.write_text(content if isinstance(content, str) else json.dumps(content))
    if how == "train":
        return main(["train", str(places.FIX / "tub.yaml"), "train.views=[[0.1, 5]]", f"train.calibration={p}",
                     f"out={places.WORK / f'tc-{slug}'}"])  # a run of its own: a shared one is another config's
    return main(["sim", "record", "--world", "track", "--minutes", "0.01", "--calibration", str(p), "--out",
                 str(places.WORK / f"trk-{slug}")])


# D. interrupted workflows and outputs left half written; the Python API with wrong types and units
def _run_copy(name):
    return round2._copy_of(places.FIX / "run", name)


def left_half_written(what):
    """What a stopped command left, then the command again (or the next one) on it."""
    from steerlab.cli import main

    F, W = places.FIX, places.WORK
    if what == "evaluate again into its half-written folder":
        out = W / "ev-half"
        shutil.rmtree(out, ignore_errors=True)
        main(["evaluate", str(F / "a.pt"), "--data", str(F / "sim"), "--out", str(out)])
        pred = next(p for p in out.iterdir() if p.suffix == ".csv")
        pred.write_bytes(pred.read_bytes()[: pred.stat().st_size // 2])
        (out / "metrics.json").unlink(missing_ok=True)
        return main(["evaluate", str(F / "a.pt"), "--data", str(F / "sim"), "--out", str(out)])
    if what == "export over its own half-written .onnx":
        p = W / "half.onnx"
        p.write_bytes((F / "m.onnx").read_bytes()[:1000])
        return main(["export", str(F / "a.pt"), "--out", str(p)])
    if what == "ensemble over its own half-written .pt":
        p = W / "half-e.pt"
        p.write_bytes((F / "a.pt").read_bytes()[:1000])
        return main(["ensemble", str(F / "a.pt"), str(F / "b.pt"), "--out", str(p)])
    if what == "evaluate a best.pt cut while it was saved":
        d = _run_copy("run-cutbest")
        (d / "best.pt").write_bytes((d / "best.pt").read_bytes()[:5000])
        return main(["evaluate", str(d / "best.pt"), "--data", str(F / "sim"), "--out", str(W / "ev-cutbest")])
    if what == "evaluate a run folder whose best.pt is cut":
        d = _run_copy("run-cutbest2")
        (d / "best.pt").write_bytes((d / "best.pt").read_bytes()[:5000])
        return main(["evaluate", str(d), "--data", str(F / "sim"), "--out", str(W / "ev-cutbest2")])
    if what == "evaluate a best.pt of zero bytes":
        d = _run_copy("run-zero")
        (d / "best.pt").write_bytes(b"")
        return main(["evaluate", str(d / "best.pt"), "--data", str(F / "sim"), "--out", str(W / "ev-zero")])
    if what == "ensemble with a member cut":
        d = _run_copy("run-cutmember")
        (d / "last.pt").write_bytes((d / "last.pt").read_bytes()[:5000])
        return main(["ensemble", str(F / "a.pt"), str(d / "last.pt"), "--out", str(W / "e-cut.pt")])
    if what == "sim drive a .part checkpoint":
        p = W / "best.pt.part"
        p.write_bytes((F / "a.pt").read_bytes()[:3000])
        return main(["sim", "drive", str(p), "--minutes", "0.01", "--out", str(W / "dr-part")])
    if what == "train again into a run whose config.json is cut":
        return _train_left(lambda d: (d / "config.json").write_text('{"data": "'), "run-cfgcut")
    if what == "train again into a run whose config.json was edited by hand":
        return _train_left(_edit_config, "run-cfgedit")
    if what == "train again into a run whose last.pt is cut":
        return _train_left(lambda d: (d / "last.pt").write_bytes((d / "last.pt").read_bytes()[:4000]), "run-lastcut")
    if what == "train again into a run whose last.pt is gone, best.pt kept":
        return _train_left(lambda d: (d / "last.pt").unlink(), "run-lastgone")
    if what == "train again into a run with a .lock of garbage":
        return _train_left(lambda d: (d / ".lock").write_text("not a pid\n"), "run-lockjunk")
    if what == "train again into a run locked by a live process":
        return _train_left(_held_lock, "run-locklive")
    if what == "train again into a run with a .lock of a pid over 2**32":
        return _train_left(lambda d: (d / ".lock").write_text("99999999999\n"), "run-lockhuge")
    if what == "compile again over a cache entry whose image.npy is cut":
        return _cache_left(lambda e: (e / "image.npy").write_bytes((e / "image.npy").read_bytes()[:200]))
    if what == "compile again over a cache entry without meta.json":
        return _cache_left(lambda e: (e / "meta.json").unlink())
    if what == "compile again over a cache entry whose labels.npz is empty":
        return _cache_left(lambda e: (e / "labels.npz").write_bytes(b""))
    if what == "compile again over a cache entry with a stray .tmp":
        return _cache_left(lambda e: (e / "image.npy.tmp").write_bytes(b"\0" * 100))
    if what == "train on a cache entry whose image.npy is cut":
        cache = W / "cache-train-cut"
        shutil.rmtree(cache, ignore_errors=True)
        main(["compile", "--data", str(F / "sim"), "--cache", str(cache)])
        for e in cache.rglob("image.npy"):
            e.write_bytes(e.read_bytes()[:200])
        return main(["train", str(F / "c.yaml"), f"cache={cache}", f"out={W / 'run-cc'}"])
    if what == "sim record again into a .part folder of another world":
        part = W / ".rec-other.part"
        shutil.rmtree(part, ignore_errors=True)
        shutil.copytree(places.FIX / "rec", part)
        return main(["sim", "record", "--world", "track", "--minutes", "0.01", "--out", str(W / "rec-other")])
    if what == "train data= a recording whose last frame file is cut":
        d = round2._copy_of(places.FIX / "sim", "sim-lastcut")
        last = sorted((d / "IMG").glob("*.jpg"))[-1]
        last.write_bytes(last.read_bytes()[:100])
        return main(["train", str(F / "c.yaml"), f"data={d}", f"out={W / 'run-lc'}"])
    raise ValueError(what)


_HELD = []


def _held_lock(d):
    """The run's .lock held (flock) by this process, as a run still going holds it."""
    import fcntl

    fd = os.open(d / ".lock", os.O_RDWR | os.O_CREAT)
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
    _HELD.append(fd)


def _edit_config(d):
    cfg = json.loads((d / "config.json").read_text() or "{}")
    cfg["train"] = {**cfg.get("train", {}), "epochs": "3"}
    (d / "config.json").write_text(json.dumps(cfg))


def _train_left(change, name):
    """A real finished run of c.yaml in WORK/name, `change`d, then train again into it with one epoch more."""
    from steerlab.cli import main

    out = places.WORK / name
    shutil.rmtree(out, ignore_errors=True)
    code = main(["train", str(places.FIX / "c.yaml"), f"out={out}"])
    if code:
        raise RuntimeError(f"the first training ended in {code}")
    change(out)
    return main(["train", str(places.FIX / "c.yaml"), "train.epochs=2", f"out={out}"])


def _cache_left(change):
    from steerlab.cli import main

    cache = places.WORK / "cache-left"
    shutil.rmtree(cache, ignore_errors=True)
    main(["compile", "--data", str(places.FIX / "sim"), "--cache", str(cache)])
    for meta in list(cache.rglob("meta.json")):
        change(meta.parent)
    return main(["compile", "--data", str(places.FIX / "sim"), "--cache", str(cache)])


HALF = [  # (what, expect, hint)
    ("evaluate again into its half-written folder", "ok", []),
    ("export over its own half-written .onnx", "ok", ["half.onnx"]),
    ("ensemble over its own half-written .pt", "ok", ["half-e.pt"]),
    ("evaluate a best.pt cut while it was saved", "refuse", ["best.pt"]),
    ("evaluate a run folder whose best.pt is cut", "refuse", ["run-cutbest2", "folder"]),
    ("evaluate a best.pt of zero bytes", "refuse", ["best.pt"]),
    ("ensemble with a member cut", "refuse", ["last.pt"]),
    ("sim drive a .part checkpoint", "refuse", ["best.pt.part"]),
    ("train again into a run whose config.json is cut", "refuse", ["config.json"]),
    ("train again into a run whose config.json was edited by hand", "refuse", ["config.json", "epochs"]),
    ("train again into a run whose last.pt is cut", "refuse", ["last.pt"]),
    ("train again into a run whose last.pt is gone, best.pt kept", "warn", ["last.pt"]),
    ("train again into a run with a .lock of garbage", "ok", [".lock"]),
    ("train again into a run locked by a live process", "refuse", [".lock", "running", "run-locklive"]),
    ("train again into a run with a .lock of a pid over 2**32", "ok", [".lock"]),
    ("compile again over a cache entry whose image.npy is cut", "warn", ["image.npy", "cache"]),
    ("compile again over a cache entry without meta.json", "warn", ["meta.json"]),  # a damaged entry: said
    ("compile again over a cache entry whose labels.npz is empty", "warn", ["labels.npz", "cache"]),
    ("compile again over a cache entry with a stray .tmp", "ok", [".tmp"]),
    ("train on a cache entry whose image.npy is cut", "warn", ["image.npy", "cache"]),
    ("sim record again into a .part folder of another world", "ok", [".rec-other.part"]),
    ("train data= a recording whose last frame file is cut", "refuse", ["center_2020_01_01_00_00_00_700.jpg"]),
]
TRK_LONG = f"{W}/trk-long.yaml"
INTERRUPTED = [  # as round 2's: name, argv, its output, when (ready), the command run then, the signal
    ("sim record --world track", ["sim", "record", "--world", "track", "--minutes", "5", "--out", f"{W}/trk-int"],
     f"{W}/trk-int", "grows", ["sim", "record", "--world", "track", "--minutes", "0.01", "--out", f"{W}/trk-int"],
     "SIGINT"),
    ("sim record --world track, killed", ["sim", "record", "--world", "track", "--minutes", "5", "--out",
                                          f"{W}/trk-kill"], f"{W}/trk-kill", "grows",
     ["compile", "--data", f"{W}/trk-kill", "--cache", f"{W}/cache"], "SIGKILL"),
    ("compile of wood-tape", ["compile", "--data", WOOD, "--cache", f"{W}/cache-wood"], f"{W}/cache-wood", "started",
     ["compile", "--data", WOOD, "--range", "0:50", "--cache", f"{W}/cache-wood"], "SIGINT"),
    ("compile of wood-tape, killed", ["compile", "--data", WOOD, "--cache", f"{W}/cache-wood2"], f"{W}/cache-wood2",
     "started", ["compile", "--data", WOOD, "--range", "0:50", "--cache", f"{W}/cache-wood2"], "SIGKILL"),
    ("replay --world track on wood-tape", ["replay", DK, "--data", WOOD, "--reader", "full_lock_deg=25", "--world", "track", "--out",
                                           f"{W}/rp-wint"], f"{W}/rp-wint", "started",
     ["replay", DK, "--data", WOOD, "--reader", "full_lock_deg=25", "--range", "0:100", "--world", "track", "--out", f"{W}/rp-wint"], "SIGINT"),
    ("evaluate on wood-tape", ["evaluate", DK, "--data", WOOD, "--out", f"{W}/ev-wint"], f"{W}/ev-wint", "started",
     ["evaluate", DK, "--data", WOOD, "--range", "0:20", "--out", f"{W}/ev-wint"], "SIGINT"),
    ("sim drive --world track --steer-by lane", ["sim", "drive", LANE, "--world", "track", "--steer-by", "lane",
                                                 "--minutes", "3", "--out", f"{W}/dr-lint"], f"{W}/dr-lint",
     "started", ["sim", "drive", LANE, "--world", "track", "--steer-by", "lane", "--minutes", "0.01", "--out",
                 f"{W}/dr-lint"], "SIGINT"),
    ("train with views, then again with other views", ["train", TRK_LONG, "train.views=[[0.1, 5]]"],
     f"{W}/run-trk-long", "ckpt", ["train", TRK_LONG, "train.views=[[0.2, 5]]", "train.epochs=1"], "SIGINT"),
    ("train with views, killed, then again without them", ["train", TRK_LONG, "train.views=[[0.1, 5]]",
                                                          f"out={W}/run-trk-kill"], f"{W}/run-trk-kill", "ckpt",
     ["train", TRK_LONG, "train.epochs=1", f"out={W}/run-trk-kill"], "SIGKILL"),
    ("train with lane_weight, then again with another", ["train", TRK_LONG, "train.lane_weight=0.5",
                                                        f"out={W}/run-trk-lane"], f"{W}/run-trk-lane", "ckpt",
     ["train", TRK_LONG, "train.lane_weight=1.0", "train.epochs=1", f"out={W}/run-trk-lane"], "SIGINT"),
]
REFUSED_AGAIN = {"train with views, then again with other views": ["views"],
                 "train with views, killed, then again without them": ["views"],
                 "train with lane_weight, then again with another": ["lane_weight"]}


def interrupted_then(argv, out, ready, again, sig):
    """round 2's `interrupted` (a traceback or an exit in more than one line of the interrupted run is the case's)."""
    return round2.interrupted(argv, out, ready, again, sig)


API = [  # (label, "module:name", args, kwargs, hint, expect)
    ("View(0.5, 10)", "steerlab.data.views:View", (0.5, 10), {}, ["shift_m"], "refuse"),
    ("View([0.5, 0.5], [10, 10])", "steerlab.data.views:View", ([0.5, 0.5], [10, 10]), {}, ["shift_m"], "refuse"),
    ("View((0.5, 0.5), (10, 10))", "steerlab.data.views:View", ((0.5, 0.5), (10, 10)), {}, [], "ok"),
    ("View((np.float32 0.1, ...))", "steerlab.data.views:View", ((np.float32(0.1), np.float32(0.1)), (0.0, 0.0)), {},
     ["shift_m"], "ok"),
    ("View((0.1, 0.1), (0.26, 0.26)) (radians)", "steerlab.data.views:View", ((0.1, 0.1), (0.26, 0.26)), {}, [],
     "ok"),
    ("View((0.1, 0.1), (0, 0), draw='1')", "steerlab.data.views:View", ((0.1, 0.1), (0.0, 0.0)), {"draw": "1"},
     ["draw"], "refuse"),
    ("View((0.1, 0.1), (0, 0), draw=-1)", "steerlab.data.views:View", ((0.1, 0.1), (0.0, 0.0)), {"draw": -1},
     ["draw"], "refuse"),
    ("View((nan, nan), (0, 0))", "steerlab.data.views:View", ((float("nan"),) * 2, (0.0, 0.0)), {}, ["shift_m"],
     "refuse"),
    ("View.parse_option([0.5, '10deg'])", f"{HERE}:parse_view", ([0.5, "10deg"],), {}, ["10deg", "yaw_deg"],
     "refuse"),
    ("View.parse_option('0.5,10')", f"{HERE}:parse_view", ("0.5,10",), {}, ["0.5,10"], "refuse"),
    ("View.parse_option({'shift_m': 0.5, 'yaw_deg': 10})", f"{HERE}:parse_view", ({"shift_m": 0.5, "yaw_deg": 10},),
     {}, ["shift_m", "pair"], "refuse"),
    ("View.parse_option(np.array([0.5, 10]))", f"{HERE}:parse_view", (np.array([0.5, 10.0]),), {},
     ["pair", "array"], "ok"),
    ("View(...).offsets(-1)", f"{HERE}:view_offsets", (-1,), {}, ["n", "-1"], "refuse"),
    ("View(...).offsets(2.5)", f"{HERE}:view_offsets", (2.5,), {}, ["n", "2.5"], "refuse"),
    ("load_config(views as a text)", "steerlab.train.config:load_config", (None,),
     {"base": {"data": SIM, "train": {"views": "[[0.5, 10]]"}}}, ["views"], "refuse"),
    ("load_config(views of a View)", f"{HERE}:config_with_view", (), {}, [], "ok"),
    ("load_config(recovery_s='0.3')", "steerlab.train.config:load_config", (None,),
     {"base": {"data": SIM, "train": {"recovery_s": "0.3"}}}, ["recovery_s"], "refuse"),
    ("load_config(calibration=Path)", "steerlab.train.config:load_config", (None,),
     {"base": {"data": TUB, "train": {"views": [[0.1, 5]], "calibration": Path(CAL)}}}, ["calibration"], "ok"),
    ("load_config(lane_weight=True)", "steerlab.train.config:load_config", (None,),
     {"base": {"data": TRK, "train": {"lane_weight": True}}}, ["lane_weight"], "refuse"),
    ("TrainOptions(views=[[0.5, 10]]) directly", f"{HERE}:train_options", (), {"views": [[0.5, 10]]}, ["views"],
     "ok"),
    ("TrainOptions(views=((0.5, 10),)) directly, then a config", f"{HERE}:train_config_direct", (),
     {"views": ((0.5, 10),)}, ["views"], "ok"),
    ("TrainOptions(views=((9, 0),)) directly, then a config", f"{HERE}:train_config_direct", (),
     {"views": ((9, 0),)}, ["views", "2"], "refuse"),
    ("TrainOptions(views='[[0.5, 10]]') directly, then a config", f"{HERE}:train_config_direct", (),
     {"views": "[[0.5, 10]]"}, ["views"], "refuse"),
    ("TrainOptions(lane_weight='0.5')", f"{HERE}:train_options", (), {"lane_weight": "0.5"}, ["lane_weight"],
     "refuse"),
    ("TrainOptions(calibration=123)", f"{HERE}:train_options", (), {"calibration": 123}, ["calibration"], "refuse"),
    ("TrackDriveOptions(throttle_floor=20)", "steerlab.sim.track.world:TrackDriveOptions", (),
     {"throttle_floor": 20.0}, ["throttle_floor"], "refuse"),
    ("TrackDriveOptions(throttle_floor='0.2')", "steerlab.sim.track.world:TrackDriveOptions", (),
     {"throttle_floor": "0.2"}, ["throttle_floor"], "refuse"),
    ("TrackDriveOptions(throttle_scale=0)", "steerlab.sim.track.world:TrackDriveOptions", (),
     {"throttle_scale": 0.0}, ["throttle_scale"], "refuse"),
    ("TrackDriveOptions(throttle_scale=np.float64(1.2))", "steerlab.sim.track.world:TrackDriveOptions", (),
     {"throttle_scale": np.float64(1.2)}, ["throttle_scale"], "ok"),
    ("TrackDriveOptions(steer_by='Lane')", "steerlab.sim.track.world:TrackDriveOptions", (), {"steer_by": "Lane"},
     ["steer_by"], "refuse"),
    ("TrackDriveOptions(steer_by=True)", "steerlab.sim.track.world:TrackDriveOptions", (), {"steer_by": True},
     ["steer_by"], "refuse"),
    ("TrackDriveOptions(latency=0.05) (seconds)", "steerlab.sim.track.world:TrackDriveOptions", (),
     {"latency": 0.05}, ["latency"], "refuse"),
    ("TrackDriveOptions(light=55)", "steerlab.sim.track.world:TrackDriveOptions", (), {"light": 55.0}, ["light"],
     "refuse"),
    ("TrackDriveOptions(throttle_floor=0.6, max_throttle=0.5)", "steerlab.sim.track.world:TrackDriveOptions", (),
     {"throttle_floor": 0.6, "max_throttle": 0.5}, ["throttle_floor", "max_throttle"], "refuse"),
    ("TrackSuiteOptions(steer_by='lanes')", "steerlab.sim.track.suite:TrackSuiteOptions", (), {"steer_by": "lanes"},
     ["steer_by"], "refuse"),
    ("TrackSuiteOptions(throttle_floor=-0.1)", "steerlab.sim.track.suite:TrackSuiteOptions", (),
     {"throttle_floor": -0.1}, ["throttle_floor"], "refuse"),
    ("TrackReplayOptions(mount_height=15) (cm)", "steerlab.sim.track.replay:TrackReplayOptions", (),
     {"mount_height": 15.0}, ["mount_height"], "refuse"),
    ("TrackReplayOptions(pitch=0.35) (radians)", "steerlab.sim.track.replay:TrackReplayOptions", (), {"pitch": 0.35},
     ["pitch"], "ok"),
    ("TrackReplayOptions(calibration=Path)", "steerlab.sim.track.replay:TrackReplayOptions", (),
     {"calibration": Path(CAL)}, ["calibration"], "refuse"),
    ("TrackReplayOptions(lane_width=90) (cm)", "steerlab.sim.track.replay:TrackReplayOptions", (),
     {"lane_width": 90.0}, ["lane_width"], "warn"),
    ("SteerlabPilot(lane.pt, steer_by='Lane')", "steerlab.donkey:SteerlabPilot", (LANE,), {"steer_by": "Lane"},
     ["steer_by", "Lane"], "refuse"),
    ("SteerlabPilot(donkey.pt, steer_by='lane')", "steerlab.donkey:SteerlabPilot", (DK,), {"steer_by": "lane"},
     ["lane", "donkey.pt"], "refuse"),
    ("SteerlabPilot(lane.pt, steer_by='lane')", "steerlab.donkey:SteerlabPilot", (LANE,), {"steer_by": "lane"}, [],
     "ok"),
    ("SteerlabPilot(lane.pt, steer_by=None)", "steerlab.donkey:SteerlabPilot", (LANE,), {"steer_by": None},
     ["steer_by"], "refuse"),
    ("SteerlabPilot(donkey.pt, throttle_floor=20)", "steerlab.donkey:SteerlabPilot", (DK,), {"throttle_floor": 20.0},
     ["throttle_floor"], "refuse"),
    ("SteerlabPilot(donkey.pt, throttle_scale=0)", "steerlab.donkey:SteerlabPilot", (DK,), {"throttle_scale": 0.0},
     ["throttle_scale"], "refuse"),
    ("SteerlabPilot(donkey.pt, throttle_scale='1.2')", "steerlab.donkey:SteerlabPilot", (DK,),
     {"throttle_scale": "1.2"}, ["throttle_scale"], "refuse"),
    ("SteerlabPilot(donkey.pt, throttle_scale=120) (percent)", "steerlab.donkey:SteerlabPilot", (DK,),
     {"throttle_scale": 120.0}, ["throttle_scale"], "refuse"),
    ("SteerlabPilot(donkey.pt, throttle_floor=0.6, max_throttle=0.5)", "steerlab.donkey:SteerlabPilot", (DK,),
     {"throttle_floor": 0.6, "max_throttle": 0.5}, ["throttle_floor", "max_throttle"], "refuse"),
    ("SteerlabPilot(donkey.pt, throttle_floor=nan)", "steerlab.donkey:SteerlabPilot", (DK,),
     {"throttle_floor": float("nan")}, ["throttle_floor"], "refuse"),
    ("SteerlabPilot(lane.pt, steer_by='lane').run(BGR 120x160 frame)", f"{HERE}:lane_run", (), {}, [], "ok"),
    ("SteerlabPilot(lane.pt, steer_by='lane').run(a 160x320 frame)", f"{HERE}:lane_run", ((160, 320, 3),), {},
     ["160x320", "120x160"], "refuse"),
    ("Pilot(lane.pt).step(frame, speed=40 km/h)", f"{HERE}:lane_step", (40.0,), {}, ["speed"], "warn"),
    ("open_recording(wood-tape, full_lock_deg=0.44)", "steerlab.data.readers:open_recording", (WOOD,),
     {"options": {"full_lock_deg": 0.44}}, ["full_lock_deg"], "warn"),
    ("open_recording(wood-tape, frame_range=(0.0, 4.0))", "steerlab.data.readers:open_recording", (WOOD,),
     {"frame_range": (0.0, 4.0)}, ["range"], "refuse"),
    ("open_recording(wood-tape, frame_range=(0, 9000))", "steerlab.data.readers:open_recording", (WOOD,),
     {"frame_range": (0, 9000)}, ["9000", "8000"], "refuse"),
    ("open_recording(wood-tape, options={'skip_missing': 'true'})", "steerlab.data.readers:open_recording", (WOOD,),
     {"options": {"skip_missing": "true"}}, ["skip_missing"], "refuse"),
    ("open_recording(wood-tape/manifest.json)", "steerlab.data.readers:open_recording",
     (f"{WOOD}/manifest.json",), {}, ["manifest.json"], "refuse"),
    ("open_recording(bytes path)", "steerlab.data.readers:open_recording", (b"/tmp/x",), {}, ["recording", "path"],
     "refuse"),
    ("Source(wood-tape, range=(0, 20)) evaluate", f"{HERE}:evaluate_source", ((0, 20),), {}, ["range"], "ok"),
    ("Source(wood-tape, range='0:20', reader='skip_missing=true') evaluate", f"{HERE}:evaluate_source", ("0:20",),
     {"reader": "skip_missing=true"}, ["reader"], "refuse"),
    ("evaluate(donkey.pt, Source(wood-tape), out=a.pt)", f"{HERE}:evaluate_source", ("0:20",), {"out": CK},
     ["a.pt"], "refuse"),
    ("load_calibration(cal.json, base=None)", "steerlab.data.fisheye:load_calibration", (CAL,), {"base": None},
     ["base", "FisheyeCamera"], "refuse"),
    ("load_calibration(123)", "steerlab.data.fisheye:load_calibration", (123,), {}, ["123", "calibration"],
     "refuse"),
    ("load_calibration(a.pt)", "steerlab.data.fisheye:load_calibration", (CK,), {}, ["a.pt"], "refuse"),
    ("load_calibration(the tub folder)", "steerlab.data.fisheye:load_calibration", (TUB,), {}, ["tub"], "refuse"),
    ("lens_of(sim recording, calibration)", f"{HERE}:lens_of_sim", (), {}, ["cal.json", "donkey"], "refuse"),
    ("warp(frame, 'sim', None, shift 3 m)", f"{HERE}:warp_frame", ("sim", 3.0, 0.0), {}, ["shift", "2"], "ok"),
    ("warp(frame, 'nothere', None, 0.1, 0)", f"{HERE}:warp_frame", ("nothere", 0.1, 0.0), {}, ["nothere"],
     "refuse"),
    ("warp(frame, 'sim', None, 0.1, 0.26 (radians))", f"{HERE}:warp_frame", ("sim", 0.1, 0.26), {}, [], "ok"),
    ("warp(float frame, 'sim', None, 0.1, 5)", f"{HERE}:warp_frame", ("sim", 0.1, 5.0), {"dtype": "float32"},
     ["uint8", "float32", "frame"], "ok"),  # warp: an inner function, its frames checked where they enter
]


def _d_rows():
    rows = [{"name": what, "build": "left_half_written", "kwargs": {"what": what}, "expect": expect, "hint": hint,
             "timeout": 120, **({"refuse_ok": True} if expect == "ok" else {})} for what, expect, hint in HALF]
    for name, argv, out, ready, again, sig in INTERRUPTED:
        hint = REFUSED_AGAIN.get(name)
        rows.append({"name": f"{name} interrupted, then again: " + " ".join(again), "build": "interrupted_then",
                     "kwargs": {"argv": argv, "out": out, "ready": ready, "again": again, "sig": sig},
                     "expect": "refuse" if hint else "ok", "hint": hint, "refuse_ok": True, "timeout": 180})
    rows += [{"name": label, "api": call, "args": args, "kwargs": kw, "hint": hint, "expect": expect,
              **({"refuse_ok": True} if expect == "ok" else {})} for label, call, args, kw, hint, expect in API]
    return _g(rows, "D")


def parse_view(value):
    from steerlab.data.views import View

    return View.parse_option(value, "train.views[0]")


def view_offsets(n):
    from steerlab.data.views import View

    return View((0.0, 0.1), (0.0, 5.0)).offsets(n)


def config_with_view():
    from steerlab.data.views import View
    from steerlab.train.config import load_config

    return load_config(None, base={"data": str(places.FIX / "sim"), "train": {"views": [View((0.5, 0.5),
                                                                                             (10.0, 10.0))]}})


def train_options(**kw):
    from steerlab.train.config import TrainOptions

    return TrainOptions(**kw)


def train_config_direct(**kw):
    from steerlab.train.config import TrainConfig, TrainOptions

    return TrainConfig(data=str(places.FIX / "sim"), train=TrainOptions(**kw))


def lane_run(size=(120, 160, 3)):
    from steerlab.donkey import SteerlabPilot

    return SteerlabPilot(str(places.FIX / "lane.pt"), steer_by="lane").run(np.zeros(size, np.uint8))


def lane_step(speed):
    from steerlab.pilot import Pilot

    return Pilot(str(places.FIX / "lane.pt")).step(np.zeros((120, 160, 3), np.uint8), speed)


def evaluate_source(rng, reader=None, out=None):
    from steerlab.data.readers import Source
    from steerlab.evaluate.offline import evaluate

    src = Source(places.fill(WOOD), rng, reader=reader) if reader is not None else Source(places.fill(WOOD), rng)
    return evaluate(str(places.FIX / "donkey.pt"), src, out or str(places.WORK / "ev-src"), progress=False)


def lens_of_sim():
    from steerlab.data.readers import open_recording
    from steerlab.data.views import lens_of

    return lens_of(open_recording(str(places.FIX / "sim")), str(places.FIX / "cal.json"))


def warp_frame(geometry, shift, yaw, dtype="uint8"):
    from steerlab.data.views import warp

    return warp(np.zeros((160, 320, 3), dtype), geometry, None, shift, yaw)


def _own_outputs(rows):
    """Every command line's output (--out, out=) a folder of its row's own: an output an earlier case wrote is
    refused as another's (a recording, a drive), which is not what a row tries."""
    for n, row in enumerate(rows):
        if "cli" not in row:
            continue
        argv = list(row["cli"])
        for i, a in enumerate(argv):
            if i and argv[i - 1] == "--out" and a.startswith(f"{W}/") and not a.endswith((".pt", ".onnx")):
                argv[i] = f"{a}-{n}"
            elif a.startswith(f"out={W}/"):
                argv[i] = f"{a}-{n}"
        row["cli"] = argv
    return rows


CASES = _own_outputs([*_a_rows(), *_b_rows(), *_c_rows(), *_d_rows()])


def setup():
    """The fixtures of the round beyond the first's: an ONNX export, a calibration (and one of 640x480), an empty
    calibration, predictions, a checkpoint with a lane head, a track-world tub (with its lane values), and configs of
    the tub and the track tub."""
    Fx, Wk = places.FIX, places.WORK
    from steerlab.export import export_onnx

    export_onnx(Fx / "a.pt", Fx / "m.onnx")
    (Fx / "cal.json").write_text(json.dumps(CALIBRATION))
    (Fx / "cal640.json").write_text(json.dumps({**CALIBRATION, "image_size": [640, 480]}))
    (Fx / "empty.json").write_bytes(b"")
    rows = (Fx / "ch2" / "labels.csv").read_text().splitlines()[1:]
    (Fx / "pred.csv").write_text("frame_id,steering_angle\n" + "".join(f"{r.split(',')[0]},0.0\n" for r in rows))
    made(Fx, "normalized", "right", "donkey", name="lane.pt", full_lock_deg=25, lane=True)
    Wk.mkdir(parents=True, exist_ok=True)
    p = subprocess.run([sys.executable, "-m", "steerlab", "sim", "record", "--world", "track", "--minutes", "0.1",
                        "--seed", "5", "--no-drift", "--out", str(Fx / "trk")], capture_output=True, text=True, cwd=Wk)
    if p.returncode:
        raise RuntimeError(f"the track tub: {p.stderr.strip()[-300:]}")
    (Fx / "tub.yaml").write_text(f"data: {Fx / 'tub'}\ncache: {places.ROOT / 'cache'}\nout: {Wk / 'run-tub'}\n"
                                 "reader: {full_lock_deg: 25}\nmodel: {name: pilotnet}\n"
                                 "split: {train: '0:6', val: '6:8'}\ntrain: {epochs: 1, batch_size: 2}\n")
    n = sum(1 for _ in open(Fx / "trk" / "catalog_0.catalog"))
    (Fx / "trk.yaml").write_text(f"data: {Fx / 'trk'}\ncache: {places.ROOT / 'cache'}\nout: {Wk / 'run-trk'}\n"
                                 "reader: {full_lock_deg: 25}\nmodel: {name: pilotnet}\n"
                                 f"split: {{train: '0:{n * 3 // 4}', val: '{n * 3 // 4}:{n - 10}'}}\n"
                                 "train: {epochs: 1, batch_size: 4}\n")
    Path(places.fill(TRK_LONG)).write_text((Fx / "trk.yaml").read_text().replace(
        "train: {epochs: 1, batch_size: 4}", "train: {epochs: 100000, batch_size: 4}").replace(
        str(Wk / "run-trk"), str(Wk / "run-trk-long")).replace(str(places.ROOT / "cache"), str(Wk / "cache-long")))
