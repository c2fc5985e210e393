"""Rule 4, implausible values said: a measured speed beyond any car's, a focal length too long to see, predictions
in degrees where radians are expected, answers beyond a steering wheel's turns, a full-lock angle in radians; a
negative speed refused, a plausible value taken without a word."""

import functools
import json
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest

from steerlab.errors import SteerlabError
from tests.inputs import ch2, made, tub


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
