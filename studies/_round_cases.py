"""The inputs of studies/bad_input_round.py: every numeric flag of every command with values the bad-input tests
do not use, reader options of the wrong type, config keys given what they cannot mean, outputs over inputs under
four spellings, files saved in the ways people save them, and the Python API; each a case {name, fn, expect}.
OUT_DIR is the round's argument (`place`)."""

import json
import os
import shutil
import subprocess
from pathlib import Path

ROOT = FIX = WORK = None  # the round's folder (OUT_DIR), its fixtures and where the cases run in: set by `place`


def place(out_dir) -> None:
    """The round's folders under OUT_DIR, the round's argument."""
    global ROOT, FIX, WORK
    ROOT = Path(out_dir).resolve()
    FIX, WORK = ROOT / "fx", ROOT / "work"


# values an option's type takes that mean nothing for it (a new user would call them mistakes)
MEANINGLESS = {(c, k, v) for c in ("sim record", "sim drive", "sim bench", "demo") for k in ("minutes", "fps",
               "chunk_minutes", "suite_minutes", "dagger_minutes") for v in ("1e-300", "1e12")} | {
    (c, "speed", v) for c in ("replay",) for v in ("1e12",)} | {(c, k, "1e12") for c in ("sim record", "sim drive",
                                                               "demo") for k in ("fps",)}


def main_cases():

    F = FIX
    cases = []

    def cli(argv, expect="refuse", hint=None, stage=False, **kw):
        def fn(a=list(map(str, argv))):
            from steerlab.cli import main as m
            return m(a)
        fn.stage = stage
        cases.append({"name": " ".join(map(str, argv)), "fn": fn, "expect": expect, "hint": hint, **kw})

    def api(name, fn, expect="refuse", hint=None):
        cases.append({"name": name, "fn": lambda: (fn(), 0)[1], "expect": expect, "hint": hint})

    ck, sim, tubp, ch2p = F / "a.pt", F / "sim", F / "tub", F / "ch2"
    common = {"sim record": ["--out", WORK / "rec-new"], "sim drive": [ck, "--out", WORK / "drive"],
              "sim bench": [ck, "--out", WORK / "bench"], "replay": [ck, "--data", sim, "--out", WORK / "replay"],
              "latency": ["--models", "zero"], "experiment": [F / "c.yaml"], "train": [F / "c.yaml"],
              "tune": [F / "c.yaml"], "demo": ["--out", WORK / "demo"], "serve": [ck]}
    # A. every numeric flag of every command, with values the sweeps do not list
    from steerlab.cli import OPTIONS, build_parser, flag
    from steerlab.options import optional, options_of

    build_parser()
    seen = set()
    for command, classes in OPTIONS.items():
        for cls in classes:
            for o in options_of(cls):
                kind = optional(o.kind)[0]
                if kind not in (int, float) or (command, o.key) in seen or command not in common:
                    continue
                seen.add((command, o.key))
                values = ["1e400", "-1e400", "0x1f", "", "-0.0000001"] + (["2.5e9", "99999999999"]
                                                                          if kind is int else ["1e-300", "1e12"])
                for v in values:
                    if command == "serve" and o.key == "port":
                        continue
                    # garbage is refused; a value far beyond what the option means (a limit of 1e12 m, smoothing
                    # of 1e-300) is judged by hand below
                    expect = "refuse" if v not in ("1e-300", "1e12") or (command, o.key, v) in MEANINGLESS else "ok"
                    if o.key == "pitch" and v == "-0.0000001":
                        expect = "ok"  # a camera tilted up a little
                    cli([*command.split(), *common[command], f"{flag(o.key)}={v}"], expect=expect,
                        hint=[flag(o.key)], stage=True)
    # B. reader options, wrong types, through compile
    for data, opts in ((tubp, ["full_lock_deg={a: 1}", "full_lock_deg=-25", "full_lock_deg=90", "full_lock_deg=nan",
                                "skip_missing=yes please", "skip_missing=0", "strict=[true]", "strict=null"]),
                       (sim, ["strict=maybe", "strict=2", "strict={}", "strict=~"]),
                       (sim / "driving_log.csv", ["strict=on?", "strict=1.0"])):
        for opt in opts:
            cli(["compile", "--data", data, "--reader", opt, "--cache", WORK / "cache"], hint=["reader", opt.split("=")[0]])
    # C. config keys of every section, wrong types (train refuses before any work)
    from steerlab.train.config import TrainConfig

    for o in options_of(TrainConfig):
        if o.key in ("data", "out", "cache"):
            continue
        for v in ("{x: 1}", "[[1]]", "1e400"):
            if optional(o.kind)[0] in (dict,) and v.startswith("{"):
                continue
            cli(["train", F / "c.yaml", f"{o.key}={v}", f"out={WORK / 'run-c'}"], hint=[o.key.split(".")[-1]])
    for key in ("train.seed=-5", "train.seed=1e20", "train.exclude_episodes=[drift]", "train.exclude_episodes=[]",
                f"extra_data=[{sim}]", f"extra_data=[{F / 'sim-link'}]", f"extra_data=[{sim}/driving_log.csv]",
                "train.views=[[0.5]]", "train.workers=-1", "split.train=0:99"):
        cli(["train", F / "c.yaml", key, f"out={WORK / 'run-k'}"],
            expect="ok" if key == "train.exclude_episodes=[]" else "refuse")
    # D. outputs over inputs and into folders of others, under several spellings
    spell = lambda p: [p, Path(os.path.relpath(p, WORK)), Path(str(p) + "/") if p.is_dir() else p]  # noqa: E731
    for out in [*spell(sim), F / "sim-link", F / "rec", F / "rec" / "center", F / "run", ch2p, tubp]:
        cli(["evaluate", ck, "--data", sim, "--out", out])
        cli(["sim", "bench", ck, "--minutes", "0.01", "--out", out])
        cli(["sim", "drive", ck, "--minutes", "0.01", "--out", out])
        cli(["replay", ck, "--data", sim, "--out", out])
        cli(["latency", "--models", "zero", "--frames", "5", "--out", out])
        cli(["compile", "--data", sim, "--cache", out], expect="refuse")
        cli(["sim", "record", "--minutes", "0.01", "--out", out])
        cli(["train", F / "c.yaml", f"out={out}"])
        cli(["sim", "dagger", F / "c.yaml", f"out={out}"])
    for target in (ck, F / "a-link.pt", Path(os.path.relpath(ck, WORK)), F / "b.pt", F / "run" / "best.pt",
                   F / "run" / "last.pt", sim / "driving_log.csv", F / "c.yaml"):
        cli(["ensemble", ck, F / "b.pt", "--out", target])
        cli(["evaluate", ck, "--data", sim, "--out", WORK / "ev", "--video", target])
        cli(["sim", "drive", ck, "--minutes", "0.01", "--out", WORK / "dv", "--video", target])
    cli(["ensemble", ck, F / "a-link.pt", "--out", WORK / "e.pt"])
    cli(["sim", "bench", ck, F / "a-link.pt", "--minutes", "0.01"])
    cli(["replay", ck, F / "a-link.pt", "--data", sim])
    cli(["latency", ck, F / "a-link.pt", "--frames", "5"])
    cli(["tune", F / "c.yaml", "--storage", sim / "driving_log.csv", f"out={WORK / 'tn'}"])
    cli(["tune", F / "c.yaml", "--storage", f"sqlite:///{F / 'c.yaml'}", f"out={WORK / 'tn'}"])
    long = WORK / ("n" * 300)
    for argv in (["evaluate", ck, "--data", sim, "--out", long], ["ensemble", ck, F / "b.pt", "--out", f"{long}.pt"],
                 ["sim", "record", "--minutes", "0.01", "--out", long], ["train", F / "c.yaml", f"out={long}"],
                 ["export", ck, "--out", f"{long}.onnx"], ["latency", "--models", "zero", "--out", long]):
        cli(argv)
    ro = ROOT / "ro"
    ro.mkdir(exist_ok=True)
    subprocess.run(["chattr", "+i", str(ro)])
    for argv in (["evaluate", ck, "--data", sim, "--out", ro / "x"], ["ensemble", ck, F / "b.pt", "--out", ro / "e.pt"],
                 ["export", ck, "--out", ro / "m.onnx"], ["sim", "record", "--minutes", "0.01", "--out", ro / "r"],
                 ["train", F / "c.yaml", f"out={ro / 'r'}"], ["latency", "--models", "zero", "--frames", "5", "--out", ro],
                 ["compile", "--data", sim, "--cache", ro / "c"], ["sim", "drive", ck, "--minutes", "0.01", "--out", ro],
                 ["replay", ck, "--data", sim, "--out", ro / "rp"], ["sim", "bench", ck, "--minutes", "0.01", "--out", ro]):
        cli(argv, hint=[str(ro)])
    # E. files as people save them, and not
    def variant(name, text_or_bytes, layout="ch2"):
        d = WORK / "files" / name
        if d.exists():
            shutil.rmtree(d)
        if layout == "ch2":
            shutil.copytree(ch2p, d)
            target = d / "labels.csv"
        else:
            shutil.copytree(sim, d)
            target = d / "driving_log.csv"
        data = target.read_bytes()
        target.write_bytes(text_or_bytes(data))
        return d, target

    files = {
        "bom": (lambda b: b"\xef\xbb\xbf" + b, "ok"), "crlf": (lambda b: b.replace(b"\n", b"\r\n"), "ok"),
        "bom+crlf": (lambda b: b"\xef\xbb\xbf" + b.replace(b"\n", b"\r\n"), "ok"),
        "blank lines": (lambda b: b + b"\n\n", "ok"), "no final newline": (lambda b: b.rstrip(b"\n"), "ok"),
        "utf16": (lambda b: b.decode().encode("utf-16"), "refuse"),
        "latin1 byte": (lambda b: b.replace(b"\n", b"\xe9\n", 1), "refuse"),
        "dup column": (lambda b: b.replace(b"public", b"steering_angle", 1), "refuse"),
        "rows reversed": (lambda b: b"\n".join([b.splitlines()[0], *reversed(b.splitlines()[1:])]) + b"\n", "refuse"),
        "nul bytes": (lambda b: b.replace(b"\n", b"\x00\n", 2), "refuse"),
    }
    for name, (change, expect) in files.items():
        for layout in ("ch2", "sim"):
            if layout == "sim" and name == "dup column":
                continue
            def go(name=name, change=change, layout=layout):
                d, target = variant(f"{layout}-{name}", change, layout)
                from steerlab.cli import main as m
                return m(["compile", "--data", str(d), *(["--labels", str(target)] if layout == "ch2" else []),
                          "--cache", str(WORK / "cache")])
            cases.append({"name": f"compile {layout} {name}", "fn": go, "expect": expect,
                          "hint": ["labels.csv", "driving_log.csv"]})
    for name, text, expect in (("dup key", "train: {epochs: 2}\ntrain: {epochs: 1}\n", "refuse"),
                               ("latin1", b"# caf\xe9\n", "refuse"), ("bom", b"\xef\xbb\xbf", "ok"),
                               ("crlf", "train:\r\n  epochs: 1\r\n", "ok"), ("tab", "train:\n\tepochs: 1\n", "refuse"),
                               ("dup nested", "train: {epochs: 1, epochs: 2}\n", "refuse"),
                               ("utf16", "# x\n".encode("utf-16"), "refuse")):
        def go(name=name, text=text):
            p = WORK / f"cfg-{name.replace(' ', '_')}.yaml"
            base = (F / "c.yaml").read_text().replace("train: {epochs: 1, batch_size: 2}\n", "").replace(
                str(WORK / "run"), str(WORK / f"run-{name.replace(' ', '_')}"))
            p.write_bytes((text if isinstance(text, bytes) else b"") + base.encode()
                          + ("train: {epochs: 1, batch_size: 2}\n" if name in ("bom", "latin1", "utf16") else
                             "" if isinstance(text, bytes) else text).encode())
            if name == "crlf":
                p.write_bytes(p.read_bytes().replace(b"\n", b"\r\n").replace(b"\r\r\n", b"\r\n"))
            from steerlab.cli import main as m
            return m(["train", str(p)])
        cases.append({"name": f"config {name}", "fn": go, "expect": expect, "hint": ["cfg-"]})
    for name, content in (("nan", '{"image_size": [160, 120], "K": [[80, 0, 80], [0, 80, 60], [0, 0, 1]], '
                                   '"D": [NaN, 0, 0, 0]}'),
                          ("dup", '{"image_size": [160, 120], "K": [[80, 0, 80], [0, 80, 60], [0, 0, 1]], '
                                  '"D": [0, 0, 0, 0], "D": [1, 0, 0, 0]}'),
                          ("huge fx", '{"image_size": [160, 120], "K": [[80000, 0, 80], [0, 80000, 60], [0, 0, 1]], '
                                      '"D": [0, 0, 0, 0]}'),
                          ("mm fx", '{"image_size": [160, 120], "K": [[3.0, 0, 80], [0, 3.0, 60], [0, 0, 1]], '
                                    '"D": [0, 0, 0, 0]}')):
        def go(name=name, content=content):
            p = WORK / f"cal-{name.replace(' ', '_')}.json"
            p.write_text(content)
            from steerlab.cli import main as m
            return m(["sim", "record", "--world", "track", "--minutes", "0.01", "--calibration", str(p), "--out",
                      str(WORK / f"trk-{name.replace(' ', '_')}")])
        cases.append({"name": f"calibration {name}", "fn": go, "expect": "refuse", "hint": ["cal-"]})

    # F. the Python API
    import numpy as np

    def pilot_speed(v):
        from steerlab.pilot import Pilot
        return lambda: Pilot(str(ck)).step(np.zeros((160, 320, 3), np.uint8), v)

    for v, expect in ((-5.0, "refuse"), (-0.001, "refuse"), (float("inf"), "refuse"), ("3", "refuse"), (None, "ok"),
                      (12.0, "ok"), (500.0, "warn"), (np.float32(-1), "refuse"), (True, "refuse")):
        api(f"Pilot.step(frame, {v!r})", pilot_speed(v), expect, hint=["speed"])

    def pilot_threads(t):
        from steerlab.pilot import Pilot
        return lambda: Pilot(str(ck), threads=t)

    for t in (0, -1, 10**6, 2.0, "2"):
        api(f"Pilot(threads={t!r})", pilot_threads(t), hint=["threads"])
    for cls_path, kw in (("steerlab.sim.road.world:RecordOptions", {"seed": -1}),
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
                         ("steerlab.demo:DemoOptions", {"fps": 1e7})):
        def make(cls_path=cls_path, kw=kw):
            import importlib
            mod, name = cls_path.split(":")
            return getattr(importlib.import_module(mod), name)(**kw)
        api(f"{cls_path.split(':')[1]}({kw})", make, hint=list(kw))

    def reader(data, opts):
        from steerlab.data.readers import open_recording
        return lambda: open_recording(str(data), options=opts)

    for data, opts in ((tubp, {"skip_missing": "maybe"}), (tubp, {"full_lock_deg": [25]}), (tubp, {"strict": 1}),
                       (tubp, {"full_lock_deg": "25deg"}), (sim, {"strict": "false"})):
        api(f"open_recording({data.name}, {opts})", reader(data, opts), hint=list(opts))

    def score_deg():
        from steerlab.evaluate.scoring import score
        rows = (ch2p / "labels.csv").read_text().splitlines()
        p = WORK / "pred-deg.csv"
        p.write_text("frame_id,steering_angle\n" + "".join(f"{r.split(',')[0]},{float(r.split(',')[1]) * 57.3 + i}\n"
                                                            for i, r in enumerate(rows[1:])))
        return score(ch2p / "labels.csv", p)

    api("score(predictions in degrees)", score_deg, "warn", hint=["degrees"])

    def plain_torch_save():
        import torch
        from steerlab.checkpoint import load_checkpoint
        raw = torch.load(ck, weights_only=True)
        torch.save(raw, WORK / "resaved.pt")
        return load_checkpoint(WORK / "resaved.pt")

    api("load_checkpoint(re-saved by torch.save)", plain_torch_save, hint=["resaved.pt"])

    def metrics_nan():
        from steerlab.cli import main as m
        code = m(["evaluate", str(ck), "--data", str(sim), "--range", "0:1", "--out", str(WORK / "ev-nan")])
        text = (WORK / "ev-nan" / "metrics.json").read_text()
        json.loads(text, parse_constant=lambda c: (_ for _ in ()).throw(ValueError(c)))
        return code

    cases.append({"name": "evaluate --range 0:1 writes valid JSON", "fn": metrics_nan, "expect": "ok"})

    def experiment_out():
        cfg = WORK / "exp.yaml"
        cfg.write_text((F / "c.yaml").read_text().replace(str(WORK / "run"), str(WORK / "exp-a"))
                       + "models:\n  - {model: {name: zero}}\n  - {model: {name: train-mean}}\n")
        from steerlab.cli import main as m
        m(["experiment", str(cfg), "--seeds", "1", f"out={WORK / 'exp-b'}"])
        if (WORK / "exp-a").exists():
            raise RuntimeError("the table went to the config's out, the runs to the override's")
        return 0

    cases.append({"name": "experiment out=NEW", "fn": experiment_out, "expect": "ok", "refuse_ok": True})
    return cases
