"""Group C of the third round: real-world data mistakes, a copy of a fixture edited, then a command on it."""

import json
import shutil
from pathlib import Path


from tests.rounds import places
from tests.rounds.round3.edits import EDITS
from tests.rounds.round3.common import W, CK, SIM, TUB, CH2, DK, CONFIG, WOOD, REAL_SIM, CALIBRATION, _g

HERE = __name__


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
        row = {"name": f"{cmd} of a copy: {name}", "build": f"{HERE}:edited", "kwargs": {"src": src, "name": name,
                                                                                  "cmd": cmd}, "hint": hint,
               "timeout": 120 if src == "wood" else 45}
        if expect:
            row["expect"] = expect[0]
            if expect[0] == "ok":
                row["refuse_ok"] = True  # what is tried: one line or taken, never a traceback
        rows.append(row)
    for name, content, hint, expect in CALIBS:
        for how in ("train", "record"):
            rows.append({"name": f"{how} with a calibration: {name}", "build": f"{HERE}:with_calibration",
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
