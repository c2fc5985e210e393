"""The Python API, one rule with the command line: the Pilot and the donkeycar part refuse what is not a frame,
a speed, a checkpoint or an option they can use, with a SteerlabError that names what is expected."""

import re

import cv2
import numpy as np
import pytest

from steerlab.errors import SteerlabError
from tests.inputs import made


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
