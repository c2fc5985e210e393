"""Group D of the third round: interrupted workflows, outputs left half written, the Python API with wrong types
and units."""

import json
import os
import shutil


from tests.rounds import places, round2
from tests.rounds.round3.calls import API
from tests.rounds.round3.common import W, DK, LANE, WOOD, _g

HERE = __name__


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


def _d_rows():
    rows = [{"name": what, "build": f"{HERE}:left_half_written", "kwargs": {"what": what}, "expect": expect,
             "hint": hint, "timeout": 120, **({"refuse_ok": True} if expect == "ok" else {})} for what, expect, hint in HALF]
    for name, argv, out, ready, again, sig in INTERRUPTED:
        hint = REFUSED_AGAIN.get(name)
        rows.append({"name": f"{name} interrupted, then again: " + " ".join(again), "build": f"{HERE}:interrupted_then",
                     "kwargs": {"argv": argv, "out": out, "ready": ready, "again": again, "sig": sig},
                     "expect": "refuse" if hint else "ok", "hint": hint, "refuse_ok": True, "timeout": 180})
    rows += [{"name": label, "api": call, "args": args, "kwargs": kw, "hint": hint, "expect": expect,
              **({"refuse_ok": True} if expect == "ok" else {})} for label, call, args, kw, hint, expect in API]
    return _g(rows, "D")
