"""The inputs of the second round of studies/bad_input_round.py (`--round 2`), each a case {name, group, fn,
expect, hint} as in studies/_round_cases.py: every command given the wrong kind of file (A), runs interrupted and
rerun (B), mixed
recordings (C), the Python API with wrong types and units (D), and the scripts of studies/ and benchmarks/ with bad
arguments (E). The fixtures are the first round's (OUT_DIR/fx) and a few more made by `setup`."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

from studies import _round_cases as inputs
from studies.common import made

import steerlab  # the build tried: its scripts are those of studies/ and benchmarks/ beside its src/

REPO = Path(steerlab.__file__).resolve().parents[2]
SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
PY = sys.executable
CALIBRATION = {"image_size": [160, 120], "K": [[81.0, 0.0, 80.0], [0.0, 80.0, 61.0], [0.0, 0.0, 1.0]],
               "D": [-0.02, -0.01, 0.0, 0.005]}


def _steerlab(argv, cwd=None):
    return subprocess.Popen([PY, "-m", "steerlab", *map(str, argv)], cwd=cwd or inputs.WORK, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, start_new_session=True,
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
    recording of the CH2 camera, and the folders a killed `sim record` and a killed `train` leave."""
    F, W = inputs.FIX, inputs.WORK

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
    _kill_when(p, lambda: len(list((F / "rec-cut").rglob("*.jpg"))) > 20, signal.SIGKILL, settle=0.5)
    cfg = F / "cut.yaml"
    cfg.write_text(f"data: {F / 'rec'}\ncache: {F / 'cache-cut'}\nout: {F / 'run-cut'}\n"
                   "split: {train: '0:40', val: '40:60'}\ntrain: {epochs: 100000, batch_size: 4}\n")
    p = _steerlab(["train", cfg])
    _kill_when(p, lambda: (F / "run-cut" / "last.pt").exists(), signal.SIGKILL, settle=0.3)


def main_cases():
    F, W = inputs.FIX, inputs.WORK
    cases = []
    group = ["A"]

    def add(name, fn, expect="refuse", hint=None, after=None, **kw):
        if group[0] == "D":  # what a function of the Python API returns is no exit code
            fn = (lambda f: lambda: (f(), 0)[1])(fn)
        cases.append({"name": name, "group": group[0], "fn": fn, "expect": expect, "hint": hint, "after": after,
                      **kw})

    def cli(argv, expect="refuse", hint=None, after=None, name=None, stage=False, **kw):
        def fn(a=list(map(str, argv))):
            from steerlab.cli import main as m
            return m(a)
        fn.stage = stage
        add(name or " ".join(map(str, argv)), fn, expect, hint, after, **kw)

    ck, sim, tubp, ch2p, rec = F / "a.pt", F / "sim", F / "tub", F / "ch2", F / "rec"
    jpg = sorted((sim / "IMG").iterdir())[0]
    kinds = {"checkpoint": ck, "onnx": F / "m.onnx", "tub": tubp, "driving-log folder": sim,
             "driving log": sim / "driving_log.csv", "CH2 folder": ch2p, "CH2 labels": ch2p / "labels.csv",
             "recording": rec, "config": F / "c.yaml", "empty folder": F / "empty", "empty file": F / "empty.csv",
             "interrupted record": F / "rec-cut", "interrupted train": F / "run-cut", "frame": jpg,
             "calibration": F / "cal.json", "real CH2 answers": SHARED / "udacity-ch2" / "CH2_final_evaluation.csv",
             "real tub": SHARED / "donkeycar" / "taped-track"}
    recordings = {"tub", "driving-log folder", "driving log", "CH2 folder", "recording", "real tub"}
    sim_data = {"driving-log folder", "driving log", "recording"}  # the camera and convention of a.pt
    everything = set(kinds)
    # A. every input of every command given each kind of file it does not take
    slots = [  # name, argv of X, the kinds it takes (not tried), the kinds whose refusal may name the model instead
        ("compile --data", lambda x: ["compile", "--data", x, "--range", "0:6", "--cache", W / "cache"], recordings,
         ()),
        ("compile --labels", lambda x: ["compile", "--data", ch2p, "--labels", x, "--cache", W / "cache"],
         {"CH2 labels"}, ()),
        ("evaluate CHECKPOINT", lambda x: ["evaluate", x, "--data", sim, "--out", W / "ev"], {"checkpoint", "onnx"},
         ()),
        ("evaluate --data", lambda x: ["evaluate", ck, "--data", x, "--range", "0:6", "--out", W / "ev"], sim_data,
         ("tub", "CH2 folder", "real tub")),
        ("score --truth", lambda x: ["score", "--truth", x, "--pred", F / "pred.csv"], {"CH2 labels"}, ()),
        ("score --pred", lambda x: ["score", "--truth", ch2p / "labels.csv", "--pred", x], {"CH2 labels"}, ()),
        ("ensemble", lambda x: ["ensemble", x, F / "b.pt", "--out", W / "e.pt"], {"checkpoint"}, ()),
        ("export", lambda x: ["export", x, "--out", W / "m.onnx"], {"checkpoint"}, ()),
        ("export --calib", lambda x: ["export", ck, "--out", W / "m8.onnx", "--int8", "--calib", x,
                                      "--calib-range", "0:6"], sim_data, ("tub", "CH2 folder", "real tub")),
        ("latency CHECKPOINT", lambda x: ["latency", x, "--frames", "5", "--out", W / "lat"], {"checkpoint", "onnx"},
         ()),
        ("latency --data", lambda x: ["latency", "--models", "zero", "--frames", "5", "--data", x, "--out",
                                      W / "lat"], recordings, ()),  # an untrained model: built for any camera
        ("train CONFIG", lambda x: ["train", x], {"config"}, ()),
        ("experiment CONFIG", lambda x: ["experiment", x, "--seeds", "1"], {"config"}, ()),
        ("tune CONFIG", lambda x: ["tune", x, "--trials", "1"], {"config"}, ()),
        ("tune --storage", lambda x: ["tune", F / "t.yaml", "--trials", "1", "--storage", x, f"out={W / 'tn'}"],
         set(), ()),
        ("sim record --calibration", lambda x: ["sim", "record", "--world", "track", "--minutes", "0.01",
                                                "--calibration", x, "--out", W / "trk"], {"calibration"}, ()),
        ("sim drive", lambda x: ["sim", "drive", x, "--minutes", "0.01", "--out", W / "dr"], {"checkpoint", "onnx"},
         ()),
        ("sim bench", lambda x: ["sim", "bench", x, "--minutes", "0.01", "--out", W / "bn"], {"checkpoint", "onnx"},
         ()),
        ("sim dagger", lambda x: ["sim", "dagger", x], {"config"}, ()),
        ("replay CHECKPOINT", lambda x: ["replay", x, "--data", sim, "--out", W / "rp"], {"checkpoint", "onnx"}, ()),
        ("replay --data", lambda x: ["replay", ck, "--data", x, "--range", "0:6", "--out", W / "rp"], sim_data,
         ("tub", "CH2 folder", "real tub")),
        ("serve", lambda x: ["serve", x, "--port", "4599"], set(), ()),
        ("train train.init", lambda x: ["train", F / "c.yaml", f"train.init={x}", f"out={W / 'ti'}"],
         {"checkpoint"}, ()),
        ("train train.teacher", lambda x: ["train", F / "c.yaml", f"train.teacher={x}", f"out={W / 'tt'}"],
         {"checkpoint"}, ()),
        ("train data", lambda x: ["train", F / "c.yaml", f"data={x}", f"out={W / 'td'}"],
         {"driving-log folder", "driving log", "recording"}, ()),
        ("train extra_data", lambda x: ["train", F / "c.yaml", f"extra_data=[{x}]", f"out={W / 'tx'}"],
         {"recording"}, ("tub", "CH2 folder", "real tub")),
    ]
    for slot, argv, takes, by_model in slots:
        for kind, x in kinds.items():
            if kind in takes or (slot == "serve" and kind in ("checkpoint", "onnx")):
                continue
            hint = [x.name, "a.pt", "c.yaml"] if kind in by_model else [x.name]
            hint += ["pred.csv"] if slot == "score --truth" else []  # the predictions lack the answers' frames
            hint += ["split.val"] if slot == "train data" else []  # the key whose range the recording cannot hold
            cli(argv(x), hint=hint, name=f"{slot} <- {kind}: " + " ".join(map(str, argv(x))))
    # outputs: a command's output named as a file or folder of another kind (the first round tried recordings,
    # runs, CH2 folders and tubs): every kind but those, and the empty folder, which an output may be
    outputs = [
        ("evaluate --out", lambda x: ["evaluate", ck, "--data", sim, "--out", x]),
        ("sim record --out", lambda x: ["sim", "record", "--minutes", "0.01", "--out", x]),
        ("serve --record", lambda x: ["serve", ck, "--port", "4599", "--record", x]),
        ("demo --out", lambda x: ["demo", "--minutes", "0.01", "--out", x]),
        ("export --out", lambda x: ["export", ck, "--out", x]),
        ("ensemble --out", lambda x: ["ensemble", ck, F / "b.pt", "--out", x]),
        ("train out", lambda x: ["train", F / "c.yaml", f"out={x}"]),
        ("tune out", lambda x: ["tune", F / "t.yaml", "--trials", "1", f"out={x}"]),
        ("latency --out", lambda x: ["latency", "--models", "zero", "--frames", "5", "--out", x]),
    ]
    tried_before = {"tub", "driving-log folder", "CH2 folder", "recording", "empty folder"}
    for slot, argv in outputs:
        for kind, x in kinds.items():
            if kind in tried_before or (slot, kind) in {("export --out", "onnx"), ("ensemble --out", "checkpoint")}:
                continue
            cli(argv(x), hint=[x.name], name=f"{slot} <- {kind}: " + " ".join(map(str, argv(x))),
                stage=slot.startswith("serve"))  # a server taken would serve until stopped

    # B. runs interrupted (Ctrl-C, or killed) and run again
    group[0] = "B"

    def copy_of(src, name):
        dst = W / name
        shutil.rmtree(dst, ignore_errors=True)
        shutil.copytree(src, dst, symlinks=True)
        return dst

    def m(*argv):
        from steerlab.cli import main
        return main(list(map(str, argv)))

    cut, run_cut = F / "rec-cut", F / "run-cut"
    for argv in (["evaluate", ck, "--data", cut, "--out", W / "ev-cut"], ["compile", "--data", cut, "--cache",
                 W / "cache"], ["replay", ck, "--data", cut, "--out", W / "rp-cut"],
                 ["train", F / "c.yaml", f"data={cut}", f"out={W / 'tr-cut'}"],
                 ["latency", "--models", "zero", "--data", cut, "--frames", "5"],
                 ["export", ck, "--out", W / "cut.onnx", "--int8", "--calib", cut],
                 ["evaluate", run_cut, "--data", sim, "--out", W / "ev-run"],
                 ["sim", "drive", run_cut, "--minutes", "0.01", "--out", W / "dr-run"],
                 ["ensemble", run_cut, ck, "--out", W / "e-run.pt"],
                 ["evaluate", run_cut / "best.pt", "--data", sim, "--out", W / "ev-best"]):
        cli(argv, hint=[Path(str(a)).name for a in argv if str(a).startswith(str(F))][:1] + ["rec-cut", "run-cut"])
    cli(["evaluate", run_cut / "last.pt", "--data", rec, "--out", W / "ev-last"], expect="ok")
    add("sim record again over a killed record's folder",
        lambda: m("sim", "record", "--minutes", "0.01", "--out", copy_of(cut, "rec-again")), "ok", refuse_ok=True)
    add("train again into a killed train's folder",
        lambda: m("train", F / "c.yaml", f"out={copy_of(run_cut, 'run-again')}"), "ok", refuse_ok=True)
    add("train again with the killed train's own config",
        lambda: m("train", F / "cut.yaml", "train.epochs=1", f"out={copy_of(run_cut, 'run-again2')}"), "ok")

    def interrupted(argv, out, ready, again=None, sig=signal.SIGINT):
        """`steerlab ARGV` interrupted when `ready(out)` holds, then run again (`again`, default the same argv);
        a traceback in the interrupted run's stderr is a traceback of the case."""
        def fn():
            shutil.rmtree(out, ignore_errors=True)
            if out.suffix:
                out.unlink(missing_ok=True)
            code, err = _kill_when(_steerlab(argv), lambda: ready(out), sig)
            if "Traceback" in err:
                raise RuntimeError(f"interrupted run: {err.strip().splitlines()[-1]}")
            if sig == signal.SIGINT and code != 0 and (code != 130 or "interrupted" not in err):  # 0: done before
                raise RuntimeError(f"interrupted run: exit code {code}, stderr {err.strip()[-200:]!r}")
            return m(*(again or argv))
        return fn

    grows = lambda p: p.exists() and any(p.rglob("*"))  # noqa: E731
    begun = {}
    started = lambda p: time.monotonic() - begun.setdefault(p, time.monotonic()) > 6  # noqa: E731  (6 s in)
    ckpt = lambda p: (p / "last.pt").exists()  # noqa: E731
    long_cfg = W / "long.yaml"
    long_cfg.parent.mkdir(parents=True, exist_ok=True)
    long_cfg.write_text(f"data: {rec}\ncache: {W / 'cache-long'}\nout: {W / 'run-long'}\n"
                        "split: {train: '0:40', val: '40:60'}\ntrain: {epochs: 100000, batch_size: 4}\n"
                        "tune: {train.lr: {low: 1.0e-4, high: 1.0e-2, log: true}}\n")
    real_sim = SHARED / "udacity-sim-track1"
    for name, argv, out, ready, again, sig in (
            ("sim record", ["sim", "record", "--minutes", "5", "--out", W / "rec-int"], W / "rec-int", grows,
             ["sim", "record", "--minutes", "0.01", "--out", W / "rec-int"], signal.SIGINT),
            ("train", ["train", long_cfg], W / "run-long", ckpt, ["train", long_cfg, "train.epochs=1"], signal.SIGINT),
            ("train, killed", ["train", long_cfg, f"out={W / 'run-kill'}"], W / "run-kill", ckpt,
             ["train", long_cfg, "train.epochs=1", f"out={W / 'run-kill'}"], signal.SIGKILL),
            ("compile of the real driving log", ["compile", "--data", real_sim, "--cache", W / "cache-int"],
             W / "cache-int", started, ["compile", "--data", real_sim, "--range", "0:50", "--cache", W / "cache-int"],
             signal.SIGINT),
            ("evaluate on the real driving log", ["evaluate", ck, "--data", real_sim, "--out", W / "ev-int"],
             W / "ev-int", started, ["evaluate", ck, "--data", sim, "--out", W / "ev-int"], signal.SIGINT),
            ("replay", ["replay", ck, "--data", real_sim, "--out", W / "rp-int"], W / "rp-int", started,
             ["replay", ck, "--data", sim, "--out", W / "rp-int"], signal.SIGINT),
            ("sim bench", ["sim", "bench", ck, "--minutes", "2", "--out", W / "bn-int"], W / "bn-int",
             started, ["sim", "bench", ck, "--minutes", "0.01", "--roads", "twisty", "--out", W / "bn-int"],
             signal.SIGINT),
            ("tune", ["tune", long_cfg, "--trials", "50", f"out={W / 'tn-int'}"], W / "tn-int", grows,
             ["tune", long_cfg, "--trials", "1", "train.epochs=1", f"out={W / 'tn-int'}"], signal.SIGINT),
            ("sim dagger", ["sim", "dagger", long_cfg, f"out={W / 'dg-int'}"], W / "dg-int", grows,
             ["sim", "dagger", long_cfg, "train.epochs=1", "dagger.rounds=1", "dagger.minutes=0.02",
              f"out={W / 'dg-int'}"], signal.SIGINT),
            ("sim record, killed", ["sim", "record", "--minutes", "5", "--out", W / "rec-kill"], W / "rec-kill",
             grows, ["train", F / "c.yaml", f"data={W / 'rec-kill'}", f"out={W / 'run-rk'}"], signal.SIGKILL)):
        add(f"{name} interrupted, then again: " + " ".join(map(str, again)),
            interrupted(argv, out, ready, again, sig), "ok", refuse_ok=True, timeout=150)

    def ctrl_c_at_start():
        p = _steerlab(["sim", "record", "--minutes", "0.01", "--out", W / "rec-start"])
        code, err = _kill_when(p, lambda: True, signal.SIGINT, settle=1.0)
        print(err.strip(), file=sys.stderr)  # a traceback in it is the case's
        return 0

    add("Ctrl-C while steerlab starts (its imports)", ctrl_c_at_start, "ok")

    # C. mixed recordings: frames of another size, another camera, another convention, real recordings
    group[0] = "C"

    def odd_frame(src, pattern, size, index=3):
        def fn():
            import cv2
            import numpy as np
            d = copy_of(src, f"odd-{src.name}-{size[0]}x{size[1]}")
            frame = sorted(d.rglob(pattern))[index]
            img = np.full((*size, 3), 90, np.uint8)
            cv2.imwrite(str(frame), img)
            return d, frame
        return fn

    for src, pattern in ((sim, "center_*.jpg"), (tubp, "*_cam_image_array_.jpg"), (rec, "center/*.jpg")):
        for size in ((480, 640), (120, 160), (160, 320), (66, 200)):
            make = odd_frame(src, pattern, size)

            def go(make=make):
                d, frame = make()
                return m("compile", "--data", d, "--cache", W / "cache")
            add(f"compile {src.name} with one frame of {size[1]}x{size[0]}", go, hint=["frame", ".jpg"],
                expect="ok" if (src.name, size) in {("sim", (160, 320)), ("tub", (120, 160)),
                                                    ("rec", (160, 320))} else "refuse")

    def whole(src, size, pattern):
        def go():
            import cv2
            import numpy as np
            d = copy_of(src, f"all-{src.name}-{size[1]}")
            for f in d.rglob(pattern):
                cv2.imwrite(str(f), np.full((*size, 3), 90, np.uint8))
            return m("evaluate", ck, "--data", d, "--out", W / f"ev-all-{src.name}")
        return go

    add("evaluate a.pt on a driving log whose frames are all 160x120 (another camera)",
        whole(sim, (120, 160), "center_*.jpg"), hint=["160x120", "sim"])
    add("evaluate a.pt on a driving log whose frames are all 640x480", whole(sim, (480, 640), "center_*.jpg"),
        hint=["640x480", "sim"])
    add("evaluate a.pt on a recording whose frames are all 200x66", whole(rec, (66, 200), "center/*.jpg"),
        hint=["200x66", "rec"])
    cli(["train", F / "c.yaml", f"data={rec}", f"extra_data=[{F / 'rec-ch2'}]", "split.train=0:40",
         "split.val=40:60", f"out={W / 'mix-geo'}"], hint=["rec-ch2", "ch2"])
    cli(["train", F / "c.yaml", f"data={F / 'rec-ch2'}", f"extra_data=[{rec}]", "split.train=0:40",
         "split.val=40:60", f"out={W / 'mix-geo2'}"], hint=["rec-ch2", "rec", "ch2"])
    cli(["evaluate", ck, "--data", F / "rec-ch2", "--out", W / "ev-ch2rec"], hint=["rec-ch2", "ch2"])
    cli(["replay", ck, "--data", F / "rec-ch2", "--out", W / "rp-ch2rec"], hint=["rec-ch2", "ch2"])
    cli(["evaluate", F / "ch2.pt", "--data", rec, "--out", W / "ev-ch2ck"], hint=["ch2.pt", "rec"])
    cli(["replay", F / "donkey.pt", "--data", sim, "--out", W / "rp-dk"], hint=["donkey.pt", "sim"])
    cli(["latency", F / "donkey.pt", "--data", sim, "--frames", "5"], hint=["donkey.pt", "sim"])
    cli(["export", F / "donkey.pt", "--out", W / "dk8.onnx", "--int8", "--calib", sim], hint=["donkey.pt", "sim"])
    cli(["evaluate", F / "donkey.pt", "--data", tubp, "--reader", "full_lock_deg=30", "--out", W / "ev-dk30"],
        expect="warn", hint=["full_lock", "25", "30"])
    cli(["replay", ck, "--data", sim, "--speed", "60", "--out", W / "rp-60"], expect="warn", hint=["--speed"])
    cli(["replay", ck, "--data", rec, "--speed", "50", "--out", W / "rp-50"], expect="warn", hint=["--speed"])
    cli(["ensemble", ck, F / "donkey.pt", "--out", W / "e-mix.pt"], hint=["donkey.pt", "a.pt"])
    cli(["ensemble", F / "ch2.pt", F / "donkey.pt", "--out", W / "e-mix2.pt"], hint=["donkey.pt", "ch2.pt"])
    cli(["sim", "bench", ck, F / "donkey.pt", "--minutes", "0.01", "--out", W / "bn-mix"], hint=["donkey.pt"])
    cli(["replay", ck, F / "ch2.pt", "--data", sim, "--out", W / "rp-mix"], hint=["ch2.pt"])
    cli(["latency", ck, F / "donkey.pt", "--data", sim, "--frames", "5"], hint=["donkey.pt"])
    # the real recordings
    ch2r, tubr = SHARED / "udacity-ch2", SHARED / "donkeycar"
    cli(["compile", "--data", ch2r, "--range", "2390:2410", "--cache", W / "cache"], hint=[".jpg"])
    cli(["compile", "--data", ch2r, "--cache", W / "cache"], hint=[".jpg", "range"])
    cli(["compile", "--data", real_sim, "--range", "1400:1500", "--cache", W / "cache"], hint=["1500", "1459"])
    cli(["compile", "--data", ch2r, "--labels", ch2r / "exampleSubmissionFinal.csv", "--range", "0:20", "--cache",
         W / "cache"], expect="ok")
    cli(["compile", "--data", tubr / "taped-track", "--cache", W / "cache"], hint=["skip_missing"])
    cli(["evaluate", ck, "--data", ch2r, "--range", "0:20", "--out", W / "ev-rch2"], hint=["a.pt", "ch2"])
    cli(["evaluate", F / "donkey.pt", "--data", tubr / "hall", "--range", "0:20", "--out", W / "ev-hall"],
        expect="ok")
    cli(["evaluate", F / "donkey.pt", "--data", real_sim, "--range", "0:20", "--out", W / "ev-dksim"],
        hint=["donkey.pt", "sim"])
    cli(["evaluate", ck, "--data", real_sim, "--range", "0:20", "--out", W / "ev-rsim"], expect="ok")
    cli(["evaluate", F / "ch2.pt", "--data", ch2r, "--range", "0:20", "--out", W / "ev-ch2r"], expect="ok")
    cli(["evaluate", F / "ch2.pt", "--data", tubr / "hall", "--range", "0:20", "--out", W / "ev-ch2hall"],
        hint=["ch2.pt", "hall"])
    cli(["compile", "--data", tubr, "--cache", W / "cache"], hint=["donkeycar"])
    cli(["compile", "--data", SHARED, "--cache", W / "cache"], hint=["data"])
    cli(["compile", "--data", real_sim / "IMG", "--cache", W / "cache"], hint=["IMG"])
    cli(["compile", "--data", ch2r / "center", "--cache", W / "cache"], hint=["center"])
    cli(["train", F / "c.yaml", f"data={tubr / 'hall'}", f"extra_data=[{sim}]", f"out={W / 'mix-real'}"],
        hint=["sim", "hall", "donkey"])

    # D. the Python API: wrong types, and numbers in other units
    group[0] = "D"
    import numpy as np

    def pilot(*a, **k):
        from steerlab.pilot import Pilot
        return Pilot(*a, **k)

    for label, args, kw, hint in (
            ("Pilot(123)", (123,), {}, ["checkpoint"]), ("Pilot(None)", (None,), {}, ["checkpoint"]),
            ("Pilot(tub folder)", (str(tubp),), {}, ["tub"]), ("Pilot(config)", (str(F / "c.yaml"),), {}, ["c.yaml"]),
            ("Pilot({})", ({},), {}, ["checkpoint"]), ("Pilot([a.pt])", ([str(ck)],), {}, ["checkpoint"]),
            ("Pilot(b'bytes')", (b"PK\x03\x04",), {}, ["checkpoint"]),
            ("Pilot(smoothing='0.5')", (str(ck),), {"smoothing": "0.5"}, ["smoothing"]),
            ("Pilot(smoothing=True)", (str(ck),), {"smoothing": True}, ["smoothing"]),
            ("Pilot(steering_step=-1)", (str(ck),), {"steering_step": -1.0}, ["steering_step"]),
            ("Pilot(steering_step='0.1')", (str(ck),), {"steering_step": "0.1"}, ["steering_step"]),
            ("Pilot(other_camera='no')", (str(ck),), {"other_camera": "no"}, ["other_camera"]),
            ("Pilot(threads=None, smoothing=nan)", (str(ck),), {"smoothing": float("nan")}, ["smoothing"])):
        add(label, lambda a=args, k=kw: pilot(*a, **k), hint=hint)
    ckd = {"road": ck}

    def step(frame, speed=None, checkpoint=None):
        return lambda: pilot(str(checkpoint or ckd["road"])).step(frame() if callable(frame) else frame, speed)

    jpeg_bytes = jpg.read_bytes()
    for label, frame, hint in (
            ("a list", lambda: [[0, 0, 0]] * 10, ["frame"]), ("None", None, ["frame"]),
            ("float32 0..1", lambda: np.zeros((160, 320, 3), np.float32), ["float32", "uint8"]),
            ("gray 2-D", lambda: np.zeros((160, 320), np.uint8), ["160x320", "frame"]),
            ("RGBA", lambda: np.zeros((160, 320, 4), np.uint8), ["160x320x4", "frame"]),
            ("channels first", lambda: np.zeros((3, 160, 320), np.uint8), ["3x160x320", "frame"]),
            ("empty bytes", b"", ["frame", "image"]), ("random bytes", lambda: bytes(range(256)) * 4,
                                                       ["frame", "image"]),
            ("a path", str(jpg), ["frame", "path"]), ("a Path", jpg, ["frame", "path"]),
            ("640x480", lambda: np.zeros((480, 640, 3), np.uint8), ["480", "640"]),
            ("int16", lambda: np.zeros((160, 320, 3), np.int16), ["int16", "uint8"]),
            ("bool", lambda: np.zeros((160, 320, 3), bool), ["bool", "uint8"]),
            ("a scalar", lambda: np.uint8(3), ["frame"]), ("a 0-size frame", lambda: np.zeros((0, 0, 3), np.uint8),
                                                         ["frame", "0x0"]),
            ("truncated JPEG", jpeg_bytes[: len(jpeg_bytes) // 3], ["frame", "image", "JPEG"])):
        add(f"Pilot.step({label})", step(frame), hint=hint)
    add("Pilot.step(jpeg bytes)", step(jpeg_bytes), "ok")
    for label, speed, expect in (("40 for a road model", 40.0, "ok"), ("'12'", "12", "refuse"),
                                 ("[12.0]", [12.0], "refuse"), ("np.array(12.0)", np.array(12.0), "ok"),
                                 ("nan", float("nan"), "refuse"), ("complex", 3 + 0j, "refuse")):
        add(f"Pilot.step(frame, speed={label})", step(lambda: np.zeros((160, 320, 3), np.uint8), speed),
            expect, hint=["speed"])

    def stream(frames, speeds=None, load=None):
        def fn():
            p = pilot(str(ck))
            return list(p.stream(frames() if callable(frames) else frames, speeds, load))
        return fn

    zeros = lambda: np.zeros((160, 320, 3), np.uint8)  # noqa: E731
    for label, frames, speeds, load, hint in (
            ("frames=None", None, None, None, ["frames"]), ("frames=one frame", zeros, None, None, ["frame"]),
            ("speeds='fast'", lambda: [zeros(), zeros()], "fast", None, ["speed"]),
            ("speeds=5.0", lambda: [zeros(), zeros()], 5.0, None, ["speed"]),
            ("load=5", lambda: [0, 1], None, 5, ["load"]),
            ("frames of two sizes", lambda: [zeros(), np.zeros((120, 160, 3), np.uint8)], None, None,
             ["120", "160"]),
            ("a frame that is None in the middle", lambda: [zeros(), None, zeros()], None, None, ["frame"])):
        add(f"Pilot.stream({label})", stream(frames, speeds, load), hint=hint)
    add("Pilot.stream([0, 1], load=a function)", stream(lambda: [0, 1], None, lambda i: zeros()), "ok")

    def part(*a, **k):
        from steerlab.donkey import SteerlabPilot
        return SteerlabPilot(*a, **k)

    dk = str(F / "donkey.pt")
    for label, kw, hint in (
            ("full_lock_deg='25'", {"full_lock_deg": "25"}, ["full_lock_deg"]),
            ("throttle=-0.1", {"throttle": -0.1}, ["throttle"]), ("throttle=True", {"throttle": True}, ["throttle"]),
            ("throttle='0.3'", {"throttle": "0.3"}, ["throttle"]), ("max_throttle=2", {"max_throttle": 2.0},
                                                                     ["max_throttle"]),
            ("kp=-1", {"kp": -1.0}, ["kp"]), ("threads=0", {"threads": 0}, ["threads"]),
            ("reset_after_s=0", {"reset_after_s": 0}, ["reset_after_s"]),
            ("reset_after_s=500 (ms?)", {"reset_after_s": "500"}, ["reset_after_s"]),
            ("smoothing=2", {"smoothing": 2.0}, ["smoothing"]), ("steering_step=0", {"steering_step": 0.0},
                                                                  ["steering_step"]),
            ("command_step=nan", {"command_step": float("nan")}, ["command_step"]),
            ("throttle_scale=[1]", {"throttle_scale": [1.0]}, ["throttle_scale"]),
            ("throttle_floor=-0.1", {"throttle_floor": -0.1}, ["throttle_floor"]),
            ("throttle_floor='0.2'", {"throttle_floor": "0.2"}, ["throttle_floor"])):
        add(f"SteerlabPilot(donkey.pt, {label})", lambda kw=kw: part(dk, **kw), hint=hint)
    add("SteerlabPilot(a tub folder)", lambda: part(str(tubp)), hint=["tub"])
    add("SteerlabPilot(None)", lambda: part(None), hint=["model"])

    def run_part(img, speed=None):
        return lambda: part(dk).run(img() if callable(img) else img, speed)

    for label, img, speed, hint in (
            ("float frame", lambda: np.zeros((120, 160, 3), np.float64), None, ["float64"]),
            ("a list", lambda: np.zeros((120, 160, 3), np.uint8).tolist(), None, ["int64", "frame"]),
            ("640x480", lambda: np.zeros((480, 640, 3), np.uint8), None, ["480x640x3"]),
            ("gray", lambda: np.zeros((120, 160), np.uint8), None, ["120x160"]),
            ("JPEG bytes", lambda: jpeg_bytes, None, ["frame"]),
            ("speed -1", lambda: np.zeros((120, 160, 3), np.uint8), -1.0, ["speed"]),
            ("speed '3'", lambda: np.zeros((120, 160, 3), np.uint8), "3", ["speed"])):
        add(f"SteerlabPilot.run({label})", run_part(img, speed), hint=hint)

    def reader(*a, **k):
        from steerlab.data.readers import open_recording
        return lambda: open_recording(*a, **k)

    for label, a, k, hint in (
            ("123", (123,), {}, ["recording", "123"]), ("None", (None,), {}, ["recording"]),
            ("frame_range=5", (str(sim),), {"frame_range": 5}, ["range", "5"]),
            ("frame_range='5'", (str(sim),), {"frame_range": "5"}, ["range", "5"]),
            ("frame_range='a:b'", (str(sim),), {"frame_range": "a:b"}, ["range", "a:b"]),
            ("frame_range=(0, 100)", (str(sim),), {"frame_range": (0, 100)}, ["range", "100"]),
            ("frame_range=(5, 2)", (str(sim),), {"frame_range": (5, 2)}, ["range", "5"]),
            ("labels=123", (str(ch2p),), {"labels": 123}, ["labels", "123"]),
            ("options='strict=true'", (str(sim),), {"options": "strict=true"}, ["option"]),
            ("options={'full_lock_deg': 25} on a driving log", (str(sim),), {"options": {"full_lock_deg": 25}},
             ["full_lock_deg"]),
            ("options=[('strict', True)]", (str(sim),), {"options": [("strict", True)]}, ["option"]),
            ("a checkpoint", (str(ck),), {}, ["a.pt"]), ("an ONNX file", (str(F / "m.onnx"),), {}, ["m.onnx"])):
        add(f"open_recording({label})", reader(*a, **k), hint=hint)
    add("open_recording(sim, frame_range=[0, 4])", reader(str(sim), frame_range=[0, 4]), "ok")

    def api_call(path, *a, **k):
        def fn():
            import importlib
            mod, name = path.split(":")
            return getattr(importlib.import_module(mod), name)(*a, **k)
        return fn

    from steerlab.data.readers import Source

    for label, path, a, k, hint in (
            ("load_config(nothere.yaml)", "steerlab.train.config:load_config", (str(W / "nothere.yaml"),), {},
             ["nothere.yaml"]),
            ("load_config(c.yaml, overrides='train.lr=1')", "steerlab.train.config:load_config",
             (str(F / "c.yaml"),), {"overrides": "train.lr=1"}, ["overrides"]),
            ("load_config(a.pt)", "steerlab.train.config:load_config", (str(ck),), {}, ["a.pt"]),
            ("load_config(base=[1])", "steerlab.train.config:load_config", (None,), {"base": [1]}, ["config"]),
            ("train({'data': ...})", "steerlab.train.loop:train", ({"data": str(sim)},), {}, ["TrainConfig"]),
            ("train(None)", "steerlab.train.loop:train", (None,), {}, ["TrainConfig"]),
            ("train(c.yaml path)", "steerlab.train.loop:train", (str(F / "c.yaml"),), {}, ["TrainConfig"]),
            ("evaluate(a.pt, 'sim' as a str)", "steerlab.evaluate.offline:evaluate", (str(ck), str(sim),
                                                                                     str(W / "ev-api")), {},
             ["Source"]),
            ("evaluate(123, Source)", "steerlab.evaluate.offline:evaluate", (123, Source(str(sim)), str(W / "ev-api2")),
             {}, ["checkpoint"]),
            ("evaluate(a.pt, Source, out=sim)", "steerlab.evaluate.offline:evaluate",
             (str(ck), Source(str(sim)), str(sim)), {}, ["sim"]),
            ("evaluate(a.pt, Source, camera='left')", "steerlab.evaluate.offline:evaluate",
             (str(ck), Source(str(sim)), str(W / "ev-api3")), {"camera": "left"}, ["left"]),
            ("evaluate(a.pt, Source(range=5))", "steerlab.evaluate.offline:evaluate",
             (str(ck), Source(str(sim), range=5), str(W / "ev-api4")), {}, ["range"]),
            ("score(labels, a CH2 folder)", "steerlab.evaluate.scoring:score", (str(ch2p / "labels.csv"), str(ch2p)),
             {}, ["ch2"]),
            ("score(predictions, labels) (swapped)", "steerlab.evaluate.scoring:score",
             (str(F / "pred.csv"), str(ch2p / "labels.csv")), {}, ["public", "pred.csv"]),
            ("export_onnx(a.pt, 'm')", "steerlab.export:export_onnx", (str(ck), str(W / "m")), {}, [".onnx"]),
            ("export_onnx(a.pt, out over c.yaml)", "steerlab.export:export_onnx", (str(ck), str(F / "c.yaml")), {},
             ["c.yaml"]),
            ("export_onnx(m.onnx, ...)", "steerlab.export:export_onnx", (str(F / "m.onnx"), str(W / "m2.onnx")), {},
             ["m.onnx"]),
            ("save_ensemble([a.pt])", "steerlab.checkpoint:save_ensemble", ([str(ck)], str(W / "e1.pt")), {},
             ["two"]),
            ("save_ensemble('a.pt', ...)", "steerlab.checkpoint:save_ensemble", (str(ck), str(W / "e2.pt")), {},
             ["checkpoints"]),
            ("save_ensemble([a.pt, b.pt], out=a.pt)", "steerlab.checkpoint:save_ensemble",
             ([str(ck), str(F / "b.pt")], str(ck)), {}, ["a.pt"]),
            ("load_checkpoint(m.onnx)", "steerlab.checkpoint:load_checkpoint", (str(F / "m.onnx"),), {}, ["m.onnx"]),
            ("load_checkpoint(tub folder)", "steerlab.checkpoint:load_checkpoint", (str(tubp),), {}, ["tub"]),
            ("load_checkpoint(None)", "steerlab.checkpoint:load_checkpoint", (None,), {}, ["checkpoint"]),
            ("read_steering_csv(driving_log.csv)", "steerlab.evaluate.scoring:read_steering_csv",
             (str(sim / "driving_log.csv"),), {}, ["driving_log.csv"])):
        add(label, api_call(path, *a, **k), hint=hint)
    for label, cls_path, kw, hint in (
            ("ReplayOptions(fov=1.2) (radians?)", "steerlab.sim.replay.run:ReplayOptions", {"fov": 1.2}, ["fov"]),
            ("ReplayOptions(mount_height=150) (cm?)", "steerlab.sim.replay.run:ReplayOptions",
             {"mount_height": 150.0}, ["mount_height"]),
            ("ReplayOptions(workers='2')", "steerlab.sim.replay.run:ReplayOptions", {"workers": "2"}, ["workers"]),
            ("TrackDriveOptions(lane_width=60) (cm?)", "steerlab.sim.track.world:TrackDriveOptions",
             {"lane_width": 60.0}, ["lane_width"]),
            ("TrackDriveOptions(latency=50) (ms?)", "steerlab.sim.track.world:TrackDriveOptions", {"latency": 50.0},
             ["latency"]),
            ("DriveOptions(limit_m='100')", "steerlab.sim.road.world:DriveOptions", {"limit_m": "100"},
             ["limit_m"]),
            ("RecordOptions(geometry='donkey')", "steerlab.sim.road.world:RecordOptions", {"geometry": "donkey"},
             ["geometry"]),
            ("RecordOptions(road='Twisty')", "steerlab.sim.road.world:RecordOptions", {"road": "Twisty"}, ["road"])):
        add(label, api_call(cls_path, **kw), expect="refuse" if "(" not in label.split(")", 1)[1] else "warn",
            hint=hint)

    # E. the scripts of studies/ and benchmarks/, with bad arguments
    group[0] = "E"

    def script(path, *argv, timeout=25):
        """`python -m MODULE ARGV` (PATH as a module) from the repository: its exit code and stderr, as the CLI's
        (argparse's usage line left out, `prog: error:` read as `error:`); still running after `timeout` s: taken
        (exit code 0)."""
        def fn():
            module = path.removesuffix(".py").replace("/", ".")
            p = subprocess.Popen([PY, "-m", module, *map(str, argv)], cwd=REPO, stdout=subprocess.DEVNULL,
                                 stderr=subprocess.PIPE, text=True, start_new_session=True)
            try:
                _, err = p.communicate(timeout=timeout)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.communicate()
                print(f"still running after {timeout} s", file=sys.stderr)
                return 0
            if "Traceback" in err:
                print(err, file=sys.stderr)
                return 1
            lines = [line for line in err.splitlines() if line.strip()]
            said = [("error:" + line.split(": error:", 1)[1]) if ": error:" in line else line for line in lines
                    if not line.startswith(("usage:", "   ")) and ("error:" in line or "warning:" in line)]
            print("\n".join(said or lines), file=sys.stderr)
            return 2 if p.returncode in (1, 2) and said else p.returncode
        return fn

    nothere = W / "nothere"
    for path, argv, hint in (
            ("studies/donkeycar_tubs.py", ["--seeds", "0"], ["--seeds"]),
            ("studies/donkeycar_tubs.py", ["--epochs", "-1"], ["--epochs"]),
            ("studies/donkeycar_tubs.py", ["--tubs", "nothere"], ["nothere"]),
            ("studies/donkeycar_tubs.py", ["--models", "pilot-net"], ["pilot-net"]),
            ("studies/pruning_replay.py", [nothere], ["nothere"]),
            ("studies/pruning_replay.py", [sim], ["study.journal", "sim"]),
            ("studies/pruning_replay.py", [ck], ["a.pt"]),
            ("studies/pruning_replay.py", [F / "empty", "--factors", "0"], ["--factors", "empty"]),
            ("studies/replay_references.py", ["--data", nothere], ["nothere"]),
            ("studies/replay_references.py", ["--data", ck], ["a.pt"]),
            ("studies/replay_references.py", ["--data", sim, "--speed", "-3"], ["--speed"]),
            ("studies/replay_references.py", ["--data", sim, "--checkpoint", W / "gone.pt"], ["gone.pt"]),
            ("studies/replay_references.py", ["--data", sim, "--lane-width", "0"], ["--lane-width"]),
            ("studies/replay_vs_road_suite.py", ["--minutes", "-1", "--out", W / "rvr"], ["--minutes"]),
            ("studies/replay_vs_road_suite.py", ["--workers", "0", "--out", W / "rvr"], ["--workers"]),
            ("studies/replay_vs_road_suite.py", ["--out", sim], ["sim"]),
            ("studies/replay_vs_track_suite.py", ["--minutes", "0", "--out", W / "rvt"], ["--minutes"]),
            ("studies/replay_vs_track_suite.py", ["--tubs", nothere, "--out", W / "rvt"], ["nothere"]),
            ("studies/replay_vs_track_suite.py", ["--workers", "-1", "--out", W / "rvt"], ["--workers"]),
            ("studies/replay_vs_track_suite.py", ["--out", tubp], ["tub"]),
            ("studies/same_batches.py", ["--before", nothere], ["nothere"]),
            ("studies/same_batches.py", ["--before", REPO, "--batches", "0"], ["--batches"]),
            ("studies/same_batches.py", ["--before", REPO, "--config", nothere], ["nothere"]),
            ("studies/track_recipes.py", ["--recipes", "foo", "--out", W / "race"], ["foo"]),
            ("studies/track_recipes.py", ["--seeds", "x", "--out", W / "race"], ["--seeds", "'x'"]),
            ("studies/track_recipes.py", ["--caps", "2", "--out", W / "race"], ["--caps"]),
            ("studies/track_recipes.py", ["--workers", "0", "--out", W / "race"], ["--workers"]),
            ("studies/track_recipes.py", ["--suite", "v1", "--out", W / "race"], ["--suite", "v1"]),
            ("studies/track_recipes.py", ["--out", sim], ["sim"]),
            ("studies/tub_pretraining.py", ["--seeds", "0"], ["--seeds"]),
            ("studies/tub_pretraining.py", ["--tubs", "nothere"], ["nothere"]),
            ("studies/speed_estimate.py", ["--minutes", "1"], ["--minutes", "unrecognized"]),
            ("benchmarks/bench_ddp.py", ["--epochs", "0"], ["--epochs"]),
            ("benchmarks/bench_ddp.py", ["--model", "pilot-net"], ["pilot-net"]),
            ("benchmarks/bench_serve.py", [W / "gone.pt"], ["gone.pt"]),
            ("benchmarks/bench_serve.py", [sim], ["sim"]),
            ("benchmarks/bench_throughput.py", ["--models", "foo"], ["foo"]),
            ("benchmarks/bench_track_drive.py", ["--minutes", "-1"], ["--minutes"]),
            ("benchmarks/bench_track_drive.py", ["--checkpoint", W / "gone.pt"], ["gone.pt"]),
            ("benchmarks/bench_track_drive.py", ["--checkpoint", tubp], ["tub"]),
            ("benchmarks/bench_train_step.py", ["--before", "nothere"], ["nothere"]),
            ("benchmarks/bench_vs_donkeycar.py", ["--epochs", "0"], ["--epochs"]),
            ("benchmarks/bench_checkpoint.py", ["--json", sim], ["sim", "--json"]),
            ("benchmarks/bench_checkpoint.py", ["--json", ck], ["a.pt", "--json"]),
            ("benchmarks/bench_pilot.py", ["--json", F / "empty"], ["empty", "--json"]),
            ("benchmarks/bench_render.py", ["--json", F / "c.yaml"], ["c.yaml", "--json"]),
            ("benchmarks/bench_compile.py", ["--frames", "10"], ["--frames"]),
            ("benchmarks/bench_stream.py", ["--threads", "2"], ["--threads"])):
        add(f"{path} " + " ".join(map(str, argv)), script(path, *argv), hint=hint)
    return cases
