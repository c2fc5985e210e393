"""The first round's inputs (tests/rounds/run.py): every numeric flag of every command with values the bad-input
tests do not use, reader options of the wrong type, config keys given what they cannot mean, outputs over inputs
under several spellings, files saved in the ways people save them, and the Python API. `CASES` is the table, one
row a case (its keys: tests/rounds/run.py, `case_of`); the builders below it make what a row cannot write down
(a broken file, a call on an object), and the two sweeps the rows of the build's own options."""

import json
import shutil
import subprocess

import numpy as np

from tests.rounds import places

F, W = "{fx}", "{work}"
CK, SIM, TUB, CH2 = f"{F}/a.pt", f"{F}/sim", f"{F}/tub", f"{F}/ch2"
CONFIG = f"{F}/c.yaml"

# A. every numeric flag of every command, with values the sweeps do not list (`numeric_flags`): the arguments
# each command needs besides the flag
COMMON = {"sim record": ["--out", f"{W}/rec-new"], "sim drive": [CK, "--out", f"{W}/drive"],
          "sim bench": [CK, "--out", f"{W}/bench"], "replay": [CK, "--data", SIM, "--out", f"{W}/replay"],
          "latency": ["--models", "zero"], "experiment": [CONFIG], "train": [CONFIG], "tune": [CONFIG],
          "demo": ["--out", f"{W}/demo"], "serve": [CK]}
# values an option's type takes that mean nothing for it (a new user would call them mistakes)
MEANINGLESS = {(c, k, v) for c in ("sim record", "sim drive", "sim bench", "demo") for k in ("minutes", "fps",
               "chunk_minutes", "suite_minutes", "dagger_minutes") for v in ("1e-300", "1e12")} | {
    (c, "speed", v) for c in ("replay",) for v in ("1e12",)} | {(c, k, "1e12") for c in ("sim record", "sim drive",
                                                               "demo") for k in ("fps",)}

# B. reader options, wrong types, through compile
READER_OPTIONS = [(TUB, ["full_lock_deg={a: 1}", "full_lock_deg=-25", "full_lock_deg=90", "full_lock_deg=nan",
                         "skip_missing=yes please", "skip_missing=0", "strict=[true]", "strict=null"]),
                  (SIM, ["strict=maybe", "strict=2", "strict={}", "strict=~"]),
                  (f"{SIM}/driving_log.csv", ["strict=on?", "strict=1.0"])]

# C. config keys: every key of the config given what it cannot mean (`config_keys`), and these
KEYS = ["train.seed=-5", "train.seed=1e20", "train.exclude_episodes=[drift]", "train.exclude_episodes=[]",
        f"extra_data=[{SIM}]", f"extra_data=[{F}/sim-link]", f"extra_data=[{SIM}/driving_log.csv]",
        "train.views=[[0.5]]", "train.workers=-1", "split.train=0:99"]

# D. outputs over inputs and into folders of others, under several spellings: absolute, relative to where the
# cases run, and "with a trailing slash" as Path(...) wrote it (which drops the slash: the first spelling again)
OUTPUTS = [SIM, "../fx/sim", SIM, f"{F}/sim-link", f"{F}/rec", f"{F}/rec/center", f"{F}/run", CH2, TUB]
INTO = [["evaluate", CK, "--data", SIM, "--out", "{out}"],
        ["sim", "bench", CK, "--minutes", "0.01", "--out", "{out}"],
        ["sim", "drive", CK, "--minutes", "0.01", "--out", "{out}"],
        ["replay", CK, "--data", SIM, "--out", "{out}"],
        ["latency", "--models", "zero", "--frames", "5", "--out", "{out}"],
        ["compile", "--data", SIM, "--cache", "{out}"],
        ["sim", "record", "--minutes", "0.01", "--out", "{out}"],
        ["train", CONFIG, "out={out}"],
        ["sim", "dagger", CONFIG, "out={out}"]]
INPUTS = [CK, f"{F}/a-link.pt", "../fx/a.pt", f"{F}/b.pt", f"{F}/run/best.pt", f"{F}/run/last.pt",
          f"{SIM}/driving_log.csv", CONFIG]
OVER = [["ensemble", CK, f"{F}/b.pt", "--out", "{out}"],
        ["evaluate", CK, "--data", SIM, "--out", f"{W}/ev", "--video", "{out}"],
        ["sim", "drive", CK, "--minutes", "0.01", "--out", f"{W}/dv", "--video", "{out}"]]
LONG = f"{W}/{'n' * 300}"
RO = "{root}/ro"  # a folder no one can write (made by `setup`)
READ_ONLY = [["evaluate", CK, "--data", SIM, "--out", f"{RO}/x"], ["ensemble", CK, f"{F}/b.pt", "--out", f"{RO}/e.pt"],
             ["export", CK, "--out", f"{RO}/m.onnx"], ["sim", "record", "--minutes", "0.01", "--out", f"{RO}/r"],
             ["train", CONFIG, f"out={RO}/r"], ["latency", "--models", "zero", "--frames", "5", "--out", RO],
             ["compile", "--data", SIM, "--cache", f"{RO}/c"], ["sim", "drive", CK, "--minutes", "0.01", "--out", RO],
             ["replay", CK, "--data", SIM, "--out", f"{RO}/rp"], ["sim", "bench", CK, "--minutes", "0.01", "--out", RO]]


def _into(argv: list[str], out: str) -> list[str]:
    return [a.replace("{out}", out) for a in argv]


# E. files as people save them, and not: a label file and a driving log saved each way (`compile_variant`), a
# config (`train_config`) and a calibration (`record_with_calibration`)
SAVED = [("bom", "ok"), ("crlf", "ok"), ("bom+crlf", "ok"), ("blank lines", "ok"), ("no final newline", "ok"),
         ("utf16", "refuse"), ("latin1 byte", "refuse"), ("dup column", "refuse"), ("rows reversed", "refuse"),
         ("nul bytes", "refuse")]
CONFIGS = [("dup key", "train: {epochs: 2}\ntrain: {epochs: 1}\n", "refuse"), ("latin1", b"# caf\xe9\n", "refuse"),
           ("bom", b"\xef\xbb\xbf", "ok"), ("crlf", "train:\r\n  epochs: 1\r\n", "ok"),
           ("tab", "train:\n\tepochs: 1\n", "refuse"), ("dup nested", "train: {epochs: 1, epochs: 2}\n", "refuse"),
           ("utf16", "# x\n".encode("utf-16"), "refuse")]
CALIBRATIONS = [("nan", '{"image_size": [160, 120], "K": [[80, 0, 80], [0, 80, 60], [0, 0, 1]], "D": [NaN, 0, 0, 0]}'),
                ("dup", '{"image_size": [160, 120], "K": [[80, 0, 80], [0, 80, 60], [0, 0, 1]], '
                        '"D": [0, 0, 0, 0], "D": [1, 0, 0, 0]}'),
                ("huge fx", '{"image_size": [160, 120], "K": [[80000, 0, 80], [0, 80000, 60], [0, 0, 1]], '
                            '"D": [0, 0, 0, 0]}'),
                ("mm fx", '{"image_size": [160, 120], "K": [[3.0, 0, 80], [0, 3.0, 60], [0, 0, 1]], '
                          '"D": [0, 0, 0, 0]}')]

# F. the Python API: the Pilot's speed (`pilot_step`) and threads, option dataclasses made directly, the readers'
# options, predictions in degrees, a checkpoint saved again by torch.save, an evaluation of one frame, an
# experiment's out= override
SPEEDS = [(-5.0, "refuse"), (-0.001, "refuse"), (float("inf"), "refuse"), ("3", "refuse"), (None, "ok"), (12.0, "ok"),
          (500.0, "warn"), (np.float32(-1), "refuse"), (True, "refuse")]
OPTIONS = [("steerlab.sim.road.world:RecordOptions", {"seed": -1}),
           ("steerlab.sim.road.world:RecordOptions", {"minutes": 1e-9}),
           ("steerlab.sim.road.world:RecordOptions", {"fps": 1e9}),
           ("steerlab.sim.road.world:RecordOptions", {"fps": 0.001}),
           ("steerlab.sim.road.world:DriveOptions", {"seed": 2**70}),
           ("steerlab.sim.road.world:DriveOptions", {"minutes": 0.0001, "fps": 20}),
           ("steerlab.sim.road.world:DriveOptions", {"minutes": 10**9}),
           ("steerlab.sim.track.world:TrackRecordOptions", {"seed": -3}),
           ("steerlab.sim.track.world:TrackDriveOptions", {"minutes": 1e-7}),
           ("steerlab.sim.road.suite:SuiteOptions", {"roads": "twisty,twisty"}),
           ("steerlab.sim.road.suite:SuiteOptions", {"minutes": 1e-9}),
           ("steerlab.sim.track.suite:TrackSuiteOptions", {"styles": "taped,taped"}),
           ("steerlab.evaluate.latency:LatencyOptions", {"threads": 10**5}),
           ("steerlab.serve:ServeOptions", {"set_speed": 1e6}),
           ("steerlab.sim.replay.run:ReplayOptions", {"speed": 1e6}),
           ("steerlab.sim.replay.run:ReplayOptions", {"fov": 720.0}),
           ("steerlab.sim.replay.run:ReplayOptions", {"max_heading": 1e6}),
           ("steerlab.dagger:DaggerOptions", {"seeds_from": -100}),
           ("steerlab.dagger:DaggerOptions", {"minutes": 1e-9}),
           ("steerlab.tune.options:TuneOptions", {"seed": -1}),
           ("steerlab.demo:DemoOptions", {"fps": 1e7})]
READERS = [(TUB, {"skip_missing": "maybe"}), (TUB, {"full_lock_deg": [25]}), (TUB, {"strict": 1}),
           (TUB, {"full_lock_deg": "25deg"}), (SIM, {"strict": "false"})]

CASES = [
    {"sweep": "numeric_flags"},
    *[{"cli": ["compile", "--data", data, "--reader", opt, "--cache", f"{W}/cache"],
       "hint": ["reader", opt.split("=")[0]]} for data, opts in READER_OPTIONS for opt in opts],
    {"sweep": "config_keys"},
    *[{"cli": ["train", CONFIG, key, f"out={W}/run-k"],
       "expect": "ok" if key == "train.exclude_episodes=[]" else "refuse"} for key in KEYS],
    *[{"cli": _into(argv, out)} for out in OUTPUTS for argv in INTO],
    *[{"cli": _into(argv, out)} for out in INPUTS for argv in OVER],
    {"cli": ["ensemble", CK, f"{F}/a-link.pt", "--out", f"{W}/e.pt"]},
    {"cli": ["sim", "bench", CK, f"{F}/a-link.pt", "--minutes", "0.01"]},
    {"cli": ["replay", CK, f"{F}/a-link.pt", "--data", SIM]},
    {"cli": ["latency", CK, f"{F}/a-link.pt", "--frames", "5"]},
    {"cli": ["tune", CONFIG, "--storage", f"{SIM}/driving_log.csv", f"out={W}/tn"]},
    {"cli": ["tune", CONFIG, "--storage", f"sqlite:///{CONFIG}", f"out={W}/tn"]},
    {"cli": ["evaluate", CK, "--data", SIM, "--out", LONG]},
    {"cli": ["ensemble", CK, f"{F}/b.pt", "--out", f"{LONG}.pt"]},
    {"cli": ["sim", "record", "--minutes", "0.01", "--out", LONG]}, {"cli": ["train", CONFIG, f"out={LONG}"]},
    {"cli": ["export", CK, "--out", f"{LONG}.onnx"]}, {"cli": ["latency", "--models", "zero", "--out", LONG]},
    *[{"cli": argv, "hint": [RO]} for argv in READ_ONLY],
    *[{"name": f"compile {layout} {name}", "build": "compile_variant", "kwargs": {"name": name, "layout": layout},
       "expect": expect, "hint": ["labels.csv", "driving_log.csv"]}
      for name, expect in SAVED for layout in ("ch2", "sim") if not (layout == "sim" and name == "dup column")],
    *[{"name": f"config {name}", "build": "train_config", "kwargs": {"name": name, "text": text}, "expect": expect,
       "hint": ["cfg-"]} for name, text, expect in CONFIGS],
    *[{"name": f"calibration {name}", "build": "record_with_calibration", "kwargs": {"name": name, "content": content},
       "hint": ["cal-"]} for name, content in CALIBRATIONS],
    *[{"name": f"Pilot.step(frame, {v!r})", "api": "pilot_step", "args": [v], "expect": expect, "hint": ["speed"]}
      for v, expect in SPEEDS],
    *[{"name": f"Pilot(threads={t!r})", "api": "steerlab.pilot:Pilot", "args": [CK], "kwargs": {"threads": t},
       "hint": ["threads"]} for t in (0, -1, 10**6, 2.0, "2")],
    *[{"name": f"{cls.split(':')[1]}({kw})", "api": cls, "kwargs": kw, "hint": list(kw)} for cls, kw in OPTIONS],
    *[{"name": f"open_recording({places.name_of(data)}, {opts})", "api": "steerlab.data.readers:open_recording",
       "args": [data], "kwargs": {"options": opts}, "hint": list(opts)} for data, opts in READERS],
    {"name": "score(predictions in degrees)", "api": "score_in_degrees", "expect": "warn", "hint": ["degrees"]},
    {"name": "load_checkpoint(re-saved by torch.save)", "api": "resaved_by_torch", "hint": ["resaved.pt"]},
    {"name": "evaluate --range 0:1 writes valid JSON", "build": "metrics_of_one_frame", "expect": "ok"},
    {"name": "experiment out=NEW", "build": "experiment_out", "expect": "ok", "refuse_ok": True},
]


def setup():
    """The folder no one can write (immutable), beside the fixtures."""
    ro = places.ROOT / "ro"
    ro.mkdir(exist_ok=True)
    subprocess.run(["chattr", "+i", str(ro)])


def numeric_flags():
    """Every numeric flag of every command of `COMMON`: garbage refused; a value far beyond what the option means
    (a limit of 1e12 m, smoothing of 1e-300) judged by hand in MEANINGLESS."""
    from steerlab.cli import OPTIONS, build_parser, flag
    from steerlab.options import optional, options_of

    build_parser()
    seen, rows = set(), []
    for command, classes in OPTIONS.items():
        for cls in classes:
            for o in options_of(cls):
                kind = optional(o.kind)[0]
                if kind not in (int, float) or (command, o.key) in seen or command not in COMMON:
                    continue
                seen.add((command, o.key))
                values = ["1e400", "-1e400", "0x1f", "", "-0.0000001"] + (["2.5e9", "99999999999"]
                                                                          if kind is int else ["1e-300", "1e12"])
                for v in values:
                    if command == "serve" and o.key == "port":
                        continue
                    expect = "refuse" if v not in ("1e-300", "1e12") or (command, o.key, v) in MEANINGLESS else "ok"
                    if o.key == "pitch" and v == "-0.0000001":
                        expect = "ok"  # a camera tilted up a little
                    rows.append({"cli": [*command.split(), *COMMON[command], f"{flag(o.key)}={v}"], "expect": expect,
                                 "hint": [flag(o.key)], "stage": True})
    return rows


def config_keys():
    """Every key of the training config but its paths given a mapping, a nested list and 1e400 (train refuses
    before any work)."""
    from steerlab.options import optional, options_of
    from steerlab.train.config import TrainConfig

    return [{"cli": ["train", CONFIG, f"{o.key}={v}", f"out={W}/run-c"], "hint": [o.key.split(".")[-1]]}
            for o in options_of(TrainConfig) if o.key not in ("data", "out", "cache")
            for v in ("{x: 1}", "[[1]]", "1e400") if not (optional(o.kind)[0] in (dict,) and v.startswith("{"))]


CHANGES = {  # how each way of saving changes a file's bytes
    "bom": lambda b: b"\xef\xbb\xbf" + b, "crlf": lambda b: b.replace(b"\n", b"\r\n"),
    "bom+crlf": lambda b: b"\xef\xbb\xbf" + b.replace(b"\n", b"\r\n"), "blank lines": lambda b: b + b"\n\n",
    "no final newline": lambda b: b.rstrip(b"\n"), "utf16": lambda b: b.decode().encode("utf-16"),
    "latin1 byte": lambda b: b.replace(b"\n", b"\xe9\n", 1),
    "dup column": lambda b: b.replace(b"public", b"steering_angle", 1),
    "rows reversed": lambda b: b"\n".join([b.splitlines()[0], *reversed(b.splitlines()[1:])]) + b"\n",
    "nul bytes": lambda b: b.replace(b"\n", b"\x00\n", 2),
}


def compile_variant(name, layout):
    """`compile` of a copy of the CH2 folder (its label file) or the driving log saved the way `name` says."""
    from steerlab.cli import main

    d = places.WORK / "files" / f"{layout}-{name}"
    if d.exists():
        shutil.rmtree(d)
    shutil.copytree(places.FIX / ("ch2" if layout == "ch2" else "sim"), d)
    target = d / ("labels.csv" if layout == "ch2" else "driving_log.csv")
    target.write_bytes(CHANGES[name](target.read_bytes()))
    return main(["compile", "--data", str(d), *(["--labels", str(target)] if layout == "ch2" else []),
                 "--cache", str(places.WORK / "cache")])


def train_config(name, text):
    """`train` of the fixtures' config saved the way `name` says (`text`: bytes put before it, or text after it)."""
    from steerlab.cli import main

    W = places.WORK
    p = W / f"cfg-{name.replace(' ', '_')}.yaml"
    base = (places.FIX / "c.yaml").read_text().replace("train: {epochs: 1, batch_size: 2}\n", "").replace(
        str(W / "run"), str(W / f"run-{name.replace(' ', '_')}"))
    p.write_bytes((text if isinstance(text, bytes) else b"") + base.encode()
                  + ("train: {epochs: 1, batch_size: 2}\n" if name in ("bom", "latin1", "utf16") else
                     "" if isinstance(text, bytes) else text).encode())
    if name == "crlf":
        p.write_bytes(p.read_bytes().replace(b"\n", b"\r\n").replace(b"\r\r\n", b"\r\n"))
    return main(["train", str(p)])


def record_with_calibration(name, content):
    """`sim record --world track` with a calibration file of `content`."""
    from steerlab.cli import main

    p = places.WORK / f"cal-{name.replace(' ', '_')}.json"
    p.write_text(content)
    return main(["sim", "record", "--world", "track", "--minutes", "0.01", "--calibration", str(p), "--out",
                 str(places.WORK / f"trk-{name.replace(' ', '_')}")])


def pilot_step(speed):
    from steerlab.pilot import Pilot

    return Pilot(str(places.FIX / "a.pt")).step(np.zeros((160, 320, 3), np.uint8), speed)


def score_in_degrees():
    """The CH2 answers scored against predictions in degrees."""
    from steerlab.evaluate.scoring import score

    labels = places.FIX / "ch2" / "labels.csv"
    rows = labels.read_text().splitlines()
    p = places.WORK / "pred-deg.csv"
    p.write_text("frame_id,steering_angle\n" + "".join(f"{r.split(',')[0]},{float(r.split(',')[1]) * 57.3 + i}\n"
                                                        for i, r in enumerate(rows[1:])))
    return score(labels, p)


def resaved_by_torch():
    import torch

    from steerlab.checkpoint import load_checkpoint

    raw = torch.load(places.FIX / "a.pt", weights_only=True)
    torch.save(raw, places.WORK / "resaved.pt")
    return load_checkpoint(places.WORK / "resaved.pt")


def metrics_of_one_frame():
    """An evaluation of one frame (no gamma): its metrics.json is valid JSON (no NaN)."""
    from steerlab.cli import main

    out = places.WORK / "ev-nan"
    code = main(["evaluate", str(places.FIX / "a.pt"), "--data", str(places.FIX / "sim"), "--range", "0:1", "--out",
                 str(out)])
    text = (out / "metrics.json").read_text()
    json.loads(text, parse_constant=lambda c: (_ for _ in ()).throw(ValueError(c)))
    return code


def experiment_out():
    """An experiment's out= override moves its table with its runs."""
    from steerlab.cli import main

    W = places.WORK
    cfg = W / "exp.yaml"
    cfg.write_text((places.FIX / "c.yaml").read_text().replace(str(W / "run"), str(W / "exp-a"))
                   + "models:\n  - {model: {name: zero}}\n  - {model: {name: train-mean}}\n")
    main(["experiment", str(cfg), "--seeds", "1", f"out={W / 'exp-b'}"])
    if (W / "exp-a").exists():
        raise RuntimeError("the table went to the config's out, the runs to the override's")
    return 0

