"""The second round's inputs (`python -m tests.rounds.run --round 2`), each a row as in round1.py, with its group:
every command given the wrong kind of file (A), runs interrupted and rerun (B) and mixed recordings (C) here; the
Python API with wrong types and units (D, round2_api.py) and the scripts of studies/ and benchmarks/ with bad
arguments (E, round2_scripts.py). The fixtures are the first round's (OUT_DIR/fx) and a few more made by `setup`."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

from tests.inputs import made
from tests.rounds import places, round2_api, round2_scripts
from tests.rounds.places import name_of

F, W, S = "{fx}", "{work}", "{shared}"
CK, SIM, TUB, CH2, REC = f"{F}/a.pt", f"{F}/sim", f"{F}/tub", f"{F}/ch2", f"{F}/rec"
JPG = f"{SIM}/IMG/center_2020_01_01_00_00_00_000.jpg"  # the driving log's first frame
# what a killed `sim record` and a killed `train` leave (`setup`): a recording is written into a hidden `.NAME.part`
# folder and renamed to NAME once whole (data/writer.py), so a killed one leaves only that
CUT, RUN_CUT = f"{F}/.rec-cut.part", f"{F}/run-cut"
REAL_SIM, REAL_CH2, REAL_TUBS = f"{S}/udacity-sim-track1", f"{S}/udacity-ch2", f"{S}/donkeycar"
LONG = f"{W}/long.yaml"  # a config whose training and tuning last (`setup`)
CALIBRATION = {"image_size": [160, 120], "K": [[81.0, 0.0, 80.0], [0.0, 80.0, 61.0], [0.0, 0.0, 1.0]],
               "D": [-0.02, -0.01, 0.0, 0.005]}

# A. every input of every command given each kind of file it does not take, and every output named as a file or
# folder of another kind
KINDS = {"checkpoint": CK, "onnx": f"{F}/m.onnx", "tub": TUB, "driving-log folder": SIM,
         "driving log": f"{SIM}/driving_log.csv", "CH2 folder": CH2, "CH2 labels": f"{CH2}/labels.csv",
         "recording": REC, "config": f"{F}/c.yaml", "empty folder": f"{F}/empty", "empty file": f"{F}/empty.csv",
         "interrupted record": CUT, "interrupted train": RUN_CUT, "frame": JPG, "calibration": f"{F}/cal.json",
         "real CH2 answers": f"{REAL_CH2}/CH2_final_evaluation.csv", "real tub": f"{REAL_TUBS}/taped-track"}
RECORDINGS = {"tub", "driving-log folder", "driving log", "CH2 folder", "recording", "real tub"}
SIM_DATA = {"driving-log folder", "driving log", "recording"}  # the camera and convention of a.pt
BY_MODEL = ("tub", "CH2 folder", "real tub")  # kinds whose refusal may name the model instead
SLOTS = [  # name, argv of X, the kinds it takes (not tried), the kinds whose refusal may name the model instead
    ("compile --data", ["compile", "--data", "{x}", "--range", "0:6", "--cache", f"{W}/cache"], RECORDINGS, ()),
    ("compile --labels", ["compile", "--data", CH2, "--labels", "{x}", "--cache", f"{W}/cache"], {"CH2 labels"}, ()),
    ("evaluate CHECKPOINT", ["evaluate", "{x}", "--data", SIM, "--out", f"{W}/ev"], {"checkpoint", "onnx"}, ()),
    ("evaluate --data", ["evaluate", CK, "--data", "{x}", "--range", "0:6", "--out", f"{W}/ev"], SIM_DATA, BY_MODEL),
    ("score --truth", ["score", "--truth", "{x}", "--pred", f"{F}/pred.csv"], {"CH2 labels"}, ()),
    ("score --pred", ["score", "--truth", f"{CH2}/labels.csv", "--pred", "{x}"], {"CH2 labels"}, ()),
    ("ensemble", ["ensemble", "{x}", f"{F}/b.pt", "--out", f"{W}/e.pt"], {"checkpoint"}, ()),
    ("export", ["export", "{x}", "--out", f"{W}/m.onnx"], {"checkpoint"}, ()),
    ("export --calib", ["export", CK, "--out", f"{W}/m8.onnx", "--int8", "--calib", "{x}", "--calib-range", "0:6"],
     SIM_DATA, BY_MODEL),
    ("latency CHECKPOINT", ["latency", "{x}", "--frames", "5", "--out", f"{W}/lat"], {"checkpoint", "onnx"}, ()),
    ("latency --data", ["latency", "--models", "zero", "--frames", "5", "--data", "{x}", "--out", f"{W}/lat"],
     RECORDINGS, ()),  # an untrained model: built for any camera
    ("train CONFIG", ["train", "{x}"], {"config"}, ()),
    ("experiment CONFIG", ["experiment", "{x}", "--seeds", "1"], {"config"}, ()),
    ("tune CONFIG", ["tune", "{x}", "--trials", "1"], {"config"}, ()),
    ("tune --storage", ["tune", f"{F}/t.yaml", "--trials", "1", "--storage", "{x}", f"out={W}/tn"], set(), ()),
    ("sim record --calibration", ["sim", "record", "--world", "track", "--minutes", "0.01", "--calibration", "{x}",
                                  "--out", f"{W}/trk"], {"calibration"}, ()),
    ("sim drive", ["sim", "drive", "{x}", "--minutes", "0.01", "--out", f"{W}/dr"], {"checkpoint", "onnx"}, ()),
    ("sim bench", ["sim", "bench", "{x}", "--minutes", "0.01", "--out", f"{W}/bn"], {"checkpoint", "onnx"}, ()),
    ("sim dagger", ["sim", "dagger", "{x}"], {"config"}, ()),
    ("replay CHECKPOINT", ["replay", "{x}", "--data", SIM, "--out", f"{W}/rp"], {"checkpoint", "onnx"}, ()),
    ("replay --data", ["replay", CK, "--data", "{x}", "--range", "0:6", "--out", f"{W}/rp"], SIM_DATA, BY_MODEL),
    ("serve", ["serve", "{x}", "--port", "4599"], set(), ()),
    ("train train.init", ["train", f"{F}/c.yaml", "train.init={x}", f"out={W}/ti"], {"checkpoint"}, ()),
    ("train train.teacher", ["train", f"{F}/c.yaml", "train.teacher={x}", f"out={W}/tt"], {"checkpoint"}, ()),
    ("train data", ["train", f"{F}/c.yaml", "data={x}", f"out={W}/td"], {"driving-log folder", "driving log",
                                                                          "recording"}, ()),
    ("train extra_data", ["train", f"{F}/c.yaml", "extra_data=[{x}]", f"out={W}/tx"], {"recording"}, BY_MODEL),
]
# outputs (the first round tried recordings, runs, CH2 folders and tubs): every kind but those, and the empty
# folder, which an output may be
OUTPUTS = [
    ("evaluate --out", ["evaluate", CK, "--data", SIM, "--out", "{x}"]),
    ("sim record --out", ["sim", "record", "--minutes", "0.01", "--out", "{x}"]),
    ("serve --record", ["serve", CK, "--port", "4599", "--record", "{x}"]),
    ("demo --out", ["demo", "--minutes", "0.01", "--out", "{x}"]),
    ("export --out", ["export", CK, "--out", "{x}"]),
    ("ensemble --out", ["ensemble", CK, f"{F}/b.pt", "--out", "{x}"]),
    ("train out", ["train", f"{F}/c.yaml", "out={x}"]),
    ("tune out", ["tune", f"{F}/t.yaml", "--trials", "1", "out={x}"]),
    ("latency --out", ["latency", "--models", "zero", "--frames", "5", "--out", "{x}"]),
]
TRIED_BEFORE = {"tub", "driving-log folder", "CH2 folder", "recording", "empty folder"}
TAKEN = {("export --out", "onnx"), ("ensemble --out", "checkpoint")}


def _with(argv: list[str], x: str) -> list[str]:
    return [a.replace("{x}", x) for a in argv]


def _hint(slot, kind, x, by_model) -> list[str]:
    hint = [name_of(x), "a.pt", "c.yaml"] if kind in by_model else [name_of(x)]
    hint += ["pred.csv"] if slot == "score --truth" else []  # the predictions lack the answers' frames
    return hint + (["split.val"] if slot == "train data" else [])  # the key whose range the recording cannot hold


KIND_ROWS = [{"name": f"{slot} <- {kind}: " + " ".join(_with(argv, x)), "cli": _with(argv, x),
              "hint": _hint(slot, kind, x, by_model), "group": "A"}
             for slot, argv, takes, by_model in SLOTS for kind, x in KINDS.items()
             if not (kind in takes or (slot == "serve" and kind in ("checkpoint", "onnx")))]
OUTPUT_ROWS = [{"name": f"{slot} <- {kind}: " + " ".join(_with(argv, x)), "cli": _with(argv, x), "hint": [name_of(x)],
                "stage": slot.startswith("serve"), "group": "A"}  # a server taken would serve until stopped
               for slot, argv in OUTPUTS for kind, x in KINDS.items() if kind not in TRIED_BEFORE
               and (slot, kind) not in TAKEN]

# B. runs interrupted (Ctrl-C, or killed) and run again: what they leave given to every command
ON_WHAT_IS_LEFT = [["evaluate", CK, "--data", CUT, "--out", f"{W}/ev-cut"], ["compile", "--data", CUT, "--cache",
                   f"{W}/cache"], ["replay", CK, "--data", CUT, "--out", f"{W}/rp-cut"],
                   ["train", f"{F}/c.yaml", f"data={CUT}", f"out={W}/tr-cut"],
                   ["latency", "--models", "zero", "--data", CUT, "--frames", "5"],
                   ["export", CK, "--out", f"{W}/cut.onnx", "--int8", "--calib", CUT],
                   ["evaluate", RUN_CUT, "--data", SIM, "--out", f"{W}/ev-run"],
                   ["sim", "drive", RUN_CUT, "--minutes", "0.01", "--out", f"{W}/dr-run"],
                   ["ensemble", RUN_CUT, CK, "--out", f"{W}/e-run.pt"],
                   ["evaluate", f"{RUN_CUT}/best.pt", "--data", SIM, "--out", f"{W}/ev-best"]]
AGAIN = [  # name, what the killed run left (copied), the command run again in the copy ({copy}), what may refuse
    ("sim record again where a record was killed", CUT, ".rec-again.part",
     ["sim", "record", "--minutes", "0.01", "--out", f"{W}/rec-again"], False),
    ("sim record again into a killed record's folder", CUT, "rec-again2",
     ["sim", "record", "--minutes", "0.01", "--out", "{copy}"], True),
    ("train again into a killed train's folder", RUN_CUT, "run-again", ["train", f"{F}/c.yaml", "out={copy}"], True),
    ("train again with the killed train's own config", RUN_CUT, "run-again2",
     ["train", f"{F}/cut.yaml", "train.epochs=1", "out={copy}"], False),
]
INTERRUPTED = [  # name, argv, its output, when it is interrupted (ready), the command run then, the signal
    ("sim record", ["sim", "record", "--minutes", "5", "--out", f"{W}/rec-int"], f"{W}/rec-int", "grows",
     ["sim", "record", "--minutes", "0.01", "--out", f"{W}/rec-int"], "SIGINT"),
    ("train", ["train", LONG], f"{W}/run-long", "ckpt", ["train", LONG, "train.epochs=1"], "SIGINT"),
    ("train, killed", ["train", LONG, f"out={W}/run-kill"], f"{W}/run-kill", "ckpt",
     ["train", LONG, "train.epochs=1", f"out={W}/run-kill"], "SIGKILL"),
    ("compile of the real driving log", ["compile", "--data", REAL_SIM, "--cache", f"{W}/cache-int"],
     f"{W}/cache-int", "started", ["compile", "--data", REAL_SIM, "--range", "0:50", "--cache", f"{W}/cache-int"],
     "SIGINT"),
    ("evaluate on the real driving log", ["evaluate", CK, "--data", REAL_SIM, "--out", f"{W}/ev-int"],
     f"{W}/ev-int", "started", ["evaluate", CK, "--data", SIM, "--out", f"{W}/ev-int"], "SIGINT"),
    ("replay", ["replay", CK, "--data", REAL_SIM, "--out", f"{W}/rp-int"], f"{W}/rp-int", "started",
     ["replay", CK, "--data", SIM, "--out", f"{W}/rp-int"], "SIGINT"),
    ("sim bench", ["sim", "bench", CK, "--minutes", "2", "--out", f"{W}/bn-int"], f"{W}/bn-int", "started",
     ["sim", "bench", CK, "--minutes", "0.01", "--roads", "twisty", "--out", f"{W}/bn-int"], "SIGINT"),
    ("tune", ["tune", LONG, "--trials", "50", f"out={W}/tn-int"], f"{W}/tn-int", "grows",
     ["tune", LONG, "--trials", "1", "train.epochs=1", f"out={W}/tn-int"], "SIGINT"),
    ("sim dagger", ["sim", "dagger", LONG, f"out={W}/dg-int"], f"{W}/dg-int", "grows",
     ["sim", "dagger", LONG, "train.epochs=1", "dagger.rounds=1", "dagger.minutes=0.02", f"out={W}/dg-int"],
     "SIGINT"),
    ("sim record, killed", ["sim", "record", "--minutes", "5", "--out", f"{W}/rec-kill"], f"{W}/rec-kill", "grows",
     ["train", f"{F}/c.yaml", f"data={W}/rec-kill", f"out={W}/run-rk"], "SIGKILL"),
]
B_ROWS = [
    *[{"cli": argv, "hint": [name_of(a) for a in argv if a.startswith(F)][:1] + ["rec-cut", "run-cut"], "group": "B"}
      for argv in ON_WHAT_IS_LEFT],
    {"cli": ["evaluate", f"{RUN_CUT}/last.pt", "--data", REC, "--out", f"{W}/ev-last"], "expect": "ok", "group": "B"},
    *[{"name": name, "build": "again_in_a_copy", "kwargs": {"left": left, "copy": copy, "argv": argv}, "expect": "ok",
       **({"refuse_ok": True} if refuse_ok else {}), "group": "B"} for name, left, copy, argv, refuse_ok in AGAIN],
    *[{"name": f"{name} interrupted, then again: " + " ".join(again), "build": "interrupted",
       "kwargs": {"argv": argv, "out": out, "ready": ready, "again": again, "sig": sig}, "expect": "ok",
       "refuse_ok": True, "timeout": 150, "group": "B"} for name, argv, out, ready, again, sig in INTERRUPTED],
    {"name": "Ctrl-C while steerlab starts (its imports)", "build": "ctrl_c_at_start", "expect": "ok", "group": "B"},
]

# C. mixed recordings: frames of another size, another camera, another convention, real recordings
ODD_FRAMES = [(SIM, "center_*.jpg"), (TUB, "*_cam_image_array_.jpg"), (REC, "center/*.jpg")]
ODD_SIZES = [(480, 640), (120, 160), (160, 320), (66, 200)]
OWN_SIZE = {("sim", (160, 320)), ("tub", (120, 160)), ("rec", (160, 320))}  # the size of the recording's frames
ALL_FRAMES = [("160x120 (another camera)", "a driving log", SIM, (120, 160), "center_*.jpg", ["160x120", "sim"]),
              ("640x480", "a driving log", SIM, (480, 640), "center_*.jpg", ["640x480", "sim"]),
              ("200x66", "a recording", REC, (66, 200), "center/*.jpg", ["200x66", "rec"])]
MIXED = [  # command lines, the names their line must say, and what is expected when it is not a refusal
    (["train", f"{F}/c.yaml", f"data={REC}", f"extra_data=[{F}/rec-ch2]", "split.train=0:40", "split.val=40:60",
      f"out={W}/mix-geo"], ["rec-ch2", "ch2"]),
    (["train", f"{F}/c.yaml", f"data={F}/rec-ch2", f"extra_data=[{REC}]", "split.train=0:40", "split.val=40:60",
      f"out={W}/mix-geo2"], ["rec-ch2", "rec", "ch2"]),
    (["evaluate", CK, "--data", f"{F}/rec-ch2", "--out", f"{W}/ev-ch2rec"], ["rec-ch2", "ch2"]),
    (["replay", CK, "--data", f"{F}/rec-ch2", "--out", f"{W}/rp-ch2rec"], ["rec-ch2", "ch2"]),
    (["evaluate", f"{F}/ch2.pt", "--data", REC, "--out", f"{W}/ev-ch2ck"], ["ch2.pt", "rec"]),
    (["replay", f"{F}/donkey.pt", "--data", SIM, "--out", f"{W}/rp-dk"], ["donkey.pt", "sim"]),
    (["latency", f"{F}/donkey.pt", "--data", SIM, "--frames", "5"], ["donkey.pt", "sim"]),
    (["export", f"{F}/donkey.pt", "--out", f"{W}/dk8.onnx", "--int8", "--calib", SIM], ["donkey.pt", "sim"]),
    (["evaluate", f"{F}/donkey.pt", "--data", TUB, "--reader", "full_lock_deg=30", "--out", f"{W}/ev-dk30"],
     ["full_lock", "25", "30"], "warn"),
    (["replay", CK, "--data", SIM, "--speed", "60", "--out", f"{W}/rp-60"], ["--speed"], "warn"),
    (["replay", CK, "--data", REC, "--speed", "50", "--out", f"{W}/rp-50"], ["--speed"], "warn"),
    (["ensemble", CK, f"{F}/donkey.pt", "--out", f"{W}/e-mix.pt"], ["donkey.pt", "a.pt"]),
    (["ensemble", f"{F}/ch2.pt", f"{F}/donkey.pt", "--out", f"{W}/e-mix2.pt"], ["donkey.pt", "ch2.pt"]),
    (["sim", "bench", CK, f"{F}/donkey.pt", "--minutes", "0.01", "--out", f"{W}/bn-mix"], ["donkey.pt"]),
    (["replay", CK, f"{F}/ch2.pt", "--data", SIM, "--out", f"{W}/rp-mix"], ["ch2.pt"]),
    (["latency", CK, f"{F}/donkey.pt", "--data", SIM, "--frames", "5"], ["donkey.pt"]),
    # the real recordings
    (["compile", "--data", REAL_CH2, "--range", "2390:2410", "--cache", f"{W}/cache"], [".jpg"]),
    (["compile", "--data", REAL_CH2, "--cache", f"{W}/cache"], [".jpg", "range"]),
    (["compile", "--data", REAL_SIM, "--range", "1400:1500", "--cache", f"{W}/cache"], ["1500", "1459"]),
    (["compile", "--data", REAL_CH2, "--labels", f"{REAL_CH2}/exampleSubmissionFinal.csv", "--range", "0:20",
      "--cache", f"{W}/cache"], None, "ok"),
    (["compile", "--data", f"{REAL_TUBS}/taped-track", "--cache", f"{W}/cache"], ["skip_missing"]),
    (["evaluate", CK, "--data", REAL_CH2, "--range", "0:20", "--out", f"{W}/ev-rch2"], ["a.pt", "ch2"]),
    (["evaluate", f"{F}/donkey.pt", "--data", f"{REAL_TUBS}/hall", "--range", "0:20", "--out", f"{W}/ev-hall"], None,
     "ok"),
    (["evaluate", f"{F}/donkey.pt", "--data", REAL_SIM, "--range", "0:20", "--out", f"{W}/ev-dksim"],
     ["donkey.pt", "sim"]),
    (["evaluate", CK, "--data", REAL_SIM, "--range", "0:20", "--out", f"{W}/ev-rsim"], None, "ok"),
    (["evaluate", f"{F}/ch2.pt", "--data", REAL_CH2, "--range", "0:20", "--out", f"{W}/ev-ch2r"], None, "ok"),
    (["evaluate", f"{F}/ch2.pt", "--data", f"{REAL_TUBS}/hall", "--range", "0:20", "--out", f"{W}/ev-ch2hall"],
     ["ch2.pt", "hall"]),
    (["compile", "--data", REAL_TUBS, "--cache", f"{W}/cache"], ["donkeycar"]),
    (["compile", "--data", S, "--cache", f"{W}/cache"], ["data"]),
    (["compile", "--data", f"{REAL_SIM}/IMG", "--cache", f"{W}/cache"], ["IMG"]),
    (["compile", "--data", f"{REAL_CH2}/center", "--cache", f"{W}/cache"], ["center"]),
    (["train", f"{F}/c.yaml", f"data={REAL_TUBS}/hall", f"extra_data=[{SIM}]", f"out={W}/mix-real"],
     ["sim", "hall", "donkey"]),
]
C_ROWS = [
    *[{"name": f"compile {name_of(src)} with one frame of {size[1]}x{size[0]}", "build": "one_odd_frame",
       "kwargs": {"src": src, "pattern": pattern, "size": size}, "hint": ["frame", ".jpg"],
       "expect": "ok" if (name_of(src), size) in OWN_SIZE else "refuse", "group": "C"}
      for src, pattern in ODD_FRAMES for size in ODD_SIZES],
    *[{"name": f"evaluate a.pt on {what} whose frames are all {label}", "build": "all_frames",
       "kwargs": {"src": src, "size": size, "pattern": pattern}, "hint": hint, "group": "C"}
      for label, what, src, size, pattern, hint in ALL_FRAMES],
    *[{"cli": argv, "hint": hint, **({"expect": expect[0]} if expect else {}), "group": "C"}
      for argv, hint, *expect in MIXED],
]

CASES = [*KIND_ROWS, *OUTPUT_ROWS, *B_ROWS, *C_ROWS, *round2_api.CASES, *round2_scripts.CASES]


def _steerlab(argv, cwd=None):
    return subprocess.Popen([sys.executable, "-m", "steerlab", *map(str, argv)], cwd=cwd or places.WORK,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))  # Ctrl-C as from a
    # shell's foreground, also when the round runs in the background (where SIGINT is ignored and inherited)


def _kill_when(proc, ready, sig, settle=1.0, limit=60.0):
    """Sends `sig` to `proc` once `ready()` holds (and `settle` s more), as a user's Ctrl-C or a power cut;
    returns (exit code, stderr)."""
    deadline = time.monotonic() + limit
    while not ready() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.2)
    time.sleep(settle)
    if proc.poll() is None:
        os.killpg(proc.pid, sig)  # the command and its workers, as a terminal's Ctrl-C
    _, err = proc.communicate(timeout=60)
    return proc.returncode, err


def setup():
    """The first round's fixtures and more: an ONNX export, an empty folder and file, a calibration, predictions, a
    recording of the CH2 camera, the folders a killed `sim record` and a killed `train` leave, and a long config."""
    F, W = places.FIX, places.WORK

    from steerlab.export import export_onnx
    from steerlab.sim.road.run import RecordOptions, record

    export_onnx(F / "a.pt", F / "m.onnx")
    (F / "empty").mkdir()
    (F / "empty.csv").write_bytes(b"")
    (F / "cal.json").write_text(json.dumps(CALIBRATION))
    (F / "t.yaml").write_text((F / "c.yaml").read_text() + "tune: {train.lr: {low: 1.0e-4, high: 1.0e-2, log: true}}\n")
    rows = (F / "ch2" / "labels.csv").read_text().splitlines()[1:]
    (F / "pred.csv").write_text("frame_id,steering_angle\n" + "".join(f"{r.split(',')[0]},0.0\n" for r in rows))
    record(F / "rec-ch2", RecordOptions(seed=1, minutes=0.05, side_cameras=False, geometry="ch2"), progress=False)
    made(F, "steering_wheel", "left", "ch2", name="ch2.pt")
    W.mkdir(parents=True, exist_ok=True)
    p = _steerlab(["sim", "record", "--minutes", "5", "--seed", "4", "--out", F / "rec-cut"])
    cut = Path(places.fill(CUT))
    _kill_when(p, lambda: len(list(cut.rglob("*.jpg"))) > 20, signal.SIGKILL, settle=0.5)
    if (F / "rec-cut").exists() or not cut.is_dir():
        raise RuntimeError(f"sim record was not killed while it recorded: {CUT} is not what it left")
    cfg = F / "cut.yaml"
    cfg.write_text(f"data: {F / 'rec'}\ncache: {F / 'cache-cut'}\nout: {F / 'run-cut'}\n"
                   "split: {train: '0:40', val: '40:60'}\ntrain: {epochs: 100000, batch_size: 4}\n")
    p = _steerlab(["train", cfg])
    _kill_when(p, lambda: (F / "run-cut" / "last.pt").exists(), signal.SIGKILL, settle=0.3)
    Path(places.fill(LONG)).write_text(f"data: {F / 'rec'}\ncache: {W / 'cache-long'}\nout: {W / 'run-long'}\n"
                                       "split: {train: '0:40', val: '40:60'}\n"
                                       "train: {epochs: 100000, batch_size: 4}\n"
                                       "tune: {train.lr: {low: 1.0e-4, high: 1.0e-2, log: true}}\n")


def _m(*argv):
    from steerlab.cli import main

    return main(list(map(str, argv)))


def _copy_of(src, name):
    dst = places.WORK / name
    shutil.rmtree(dst, ignore_errors=True)
    shutil.copytree(src, dst, symlinks=True)
    return dst


def again_in_a_copy(left, copy, argv):
    """`argv` run on a copy (WORK/`copy`) of what a killed run left (`left`), named `{copy}` in it."""
    where = str(_copy_of(left, copy))
    return _m(*[a.replace("{copy}", where) for a in argv])


def grows(p):
    """`p` or the hidden folder a recording is written into before it becomes `p` holds files."""
    return any(q.exists() and any(q.rglob("*")) for q in (p, p.parent / f".{p.name}.part"))


_begun = {}


def started(p):
    return time.monotonic() - _begun.setdefault(p, time.monotonic()) > 6  # 6 s in


def ckpt(p):
    return (p / "last.pt").exists()


def interrupted(argv, out, ready, again, sig):
    """`steerlab ARGV` interrupted by `sig` when `ready(out)` holds (`grows`, `started` or `ckpt`), then `again`;
    a traceback in the interrupted run's stderr is a traceback of the case."""
    out, sig, ready = Path(out), getattr(signal, sig), globals()[ready]
    shutil.rmtree(out, ignore_errors=True)
    if out.suffix:
        out.unlink(missing_ok=True)
    code, err = _kill_when(_steerlab(argv), lambda: ready(out), sig)
    if "Traceback" in err:
        raise RuntimeError(f"interrupted run: {err.strip().splitlines()[-1]}")
    if sig == signal.SIGINT and code != 0 and (code != 130 or "interrupted" not in err):  # 0: done before
        raise RuntimeError(f"interrupted run: exit code {code}, stderr {err.strip()[-200:]!r}")
    return _m(*again)


def ctrl_c_at_start():
    p = _steerlab(["sim", "record", "--minutes", "0.01", "--out", places.WORK / "rec-start"])
    code, err = _kill_when(p, lambda: True, signal.SIGINT, settle=1.0)
    print(err.strip(), file=sys.stderr)  # a traceback in it is the case's
    return 0


def one_odd_frame(src, pattern, size, index=3):
    """`compile` of a copy of `src` whose frame `index` (of those `pattern` finds) is of `size` (height, width)."""
    import cv2
    import numpy as np

    d = _copy_of(Path(src), f"odd-{name_of(src)}-{size[0]}x{size[1]}")
    frame = sorted(d.rglob(pattern))[index]
    cv2.imwrite(str(frame), np.full((*size, 3), 90, np.uint8))
    return _m("compile", "--data", d, "--cache", places.WORK / "cache")


def all_frames(src, size, pattern):
    """`evaluate` of a.pt on a copy of `src` whose every frame is of `size` (height, width)."""
    import cv2
    import numpy as np

    d = _copy_of(Path(src), f"all-{name_of(src)}-{size[1]}")
    for f in d.rglob(pattern):
        cv2.imwrite(str(f), np.full((*size, 3), 90, np.uint8))
    return _m("evaluate", places.FIX / "a.pt", "--data", d, "--out", places.WORK / f"ev-all-{name_of(src)}")
