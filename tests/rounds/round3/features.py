"""Group B of the third round: the features added since the second."""

import numpy as np

from tests.rounds import places
from tests.rounds.round3.common import F, W, S, CK, SIM, TUB, CH2, DK, LANE, CONFIG, TUBCFG, TRKCFG, WOOD, HALL, CAL, _g

HERE = __name__


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
