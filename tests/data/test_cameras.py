"""A camera of one's own is one call (`cameras.register_camera`): then every option that names a camera, the crop
presets, a video's reader and the car of its frames take it."""

import math

import pytest

from steerlab.errors import SteerlabError
from tests.data.test_sources import write_video


@pytest.fixture
def wide():
    """A 64x48 camera "wide" on a 0.3 m wheelbase car, cropped 8 rows from the top and 2 columns each side."""
    from steerlab.data.car import CARS, DONKEY_CAR
    from steerlab.data.cameras import register_camera
    from steerlab.data.geometry import CAMERAS, Camera
    from steerlab.data.preprocess import CROP_PRESETS

    from dataclasses import replace

    car = replace(DONKEY_CAR, wheelbase=0.3)
    register_camera("wide", Camera(64, 48, 30.0, 24.0, 0.2, 10.0), (8, 0, 2, 2), car)
    yield car
    for registry in (CAMERAS, CROP_PRESETS, CARS):
        del registry["wide"]


def test_a_registered_camera_is_taken_wherever_a_camera_is_named(wide, tmp_path):
    from steerlab.data.car import car_of
    from steerlab.data.preprocess import PreprocessOptions
    from steerlab.data.readers import open_recording
    from steerlab.evaluate.latency import LatencyOptions
    from steerlab.options import parse

    assert parse(PreprocessOptions, {"preset": "wide"}, "preprocess").resolve().crop == (8, 0, 2, 2)
    assert PreprocessOptions().resolve("wide").crop == (8, 0, 2, 2)  # the recording's camera's preset
    assert parse(LatencyOptions, {"geometry": "wide"}, "latency").geometry == "wide"
    assert car_of("wide") is wide
    write_video(tmp_path / "drive.avi", 4)
    (tmp_path / "drive.csv").write_text("frame,steering\n" + "".join(f"{i},0.1\n" for i in range(4)))
    rec = open_recording(tmp_path / "drive.avi", options={"geometry": "wide"})
    assert rec.geometry == "wide" and rec.load_frame(0).shape == (48, 64, 3)
    assert math.isclose(car_of(rec.geometry).wheelbase, 0.3)


def test_an_unregistered_camera_is_refused_naming_the_registered_ones():
    from steerlab.data.preprocess import PreprocessOptions
    from steerlab.options import parse

    with pytest.raises(SteerlabError, match=r"preprocess.preset must be one of the crop presets ch2, sim, donkey, "
                                            r"got 'wide'"):
        parse(PreprocessOptions, {"preset": "wide"}, "preprocess")


@pytest.mark.parametrize("name, crop, message", [
    ("donkey", (0, 0, 0, 0), "camera 'donkey' is registered already"),
    ("my cam", (0, 0, 0, 0), "a camera's name must be a word"),
    ("cam", (0, 0, 0), "crop must be four non-negative integers"),
    ("cam", (0, 0, -1, 0), "crop must be four non-negative integers"),
    ("cam", (30, 18, 0, 0), "that leave some of the 48x64 frame"),
    ("cam", (0, 0, 1.5, 0), "crop must be four non-negative integers"),
    ("cam", None, "crop must be four non-negative integers"),
    ("cam", 5, "crop must be four non-negative integers"),
    ("cam", "0,0,0,0", "crop must be four non-negative integers"),
    ("cam", (True, False, False, False), "crop must be four non-negative integers"),
])
def test_a_camera_that_cannot_be_is_refused(name, crop, message):
    from steerlab.data.car import DONKEY_CAR
    from steerlab.data.cameras import register_camera
    from steerlab.data.geometry import CAMERAS, Camera

    before = dict(CAMERAS)
    with pytest.raises(SteerlabError, match=message):
        register_camera(name, Camera(64, 48, 30.0, 24.0, 0.2, 10.0), crop, DONKEY_CAR)
    assert CAMERAS == before


def _wrong_fields():
    """(class, field, value, message) for every field of a camera and a car: a value of the wrong kind (text for a
    number, a boolean, NaN) and one out of its plausible range (other units: cm for m, radians for degrees)."""
    from steerlab.data.car import Car
    from steerlab.data.geometry import Camera

    camera = {"width": 64, "height": 48, "focal": 30.0, "cy": 24.0, "mount_height": 0.2, "pitch_deg": 10.0}
    car = {"wheelbase": 0.18, "steering_ratio": 1.0, "full_lock_deg": 25.0, "side_camera_offset_m": 0.1,
           "lane_limit_m": 0.3, "speeds": (0.5, 5.0), "max_accel": 3.0, "max_decel": 8.0, "drag": 0.0004}
    implausible = {"width": [0, 64.0, 5000], "height": [0, 48.0], "focal": [-30.0, 0.0], "cy": [-1.0, 49.0],
                   "mount_height": [0.0, 150.0], "pitch_deg": [90.0, -120.0], "wheelbase": [-0.18, 26.0],
                   "steering_ratio": [0.0, 100.0], "full_lock_deg": [0.44, 90.0], "side_camera_offset_m": [-0.5, 50.0],
                   "lane_limit_m": [0.0, 30.0], "speeds": [(5.0, 0.5), (-1.0, 2.0), (1.0, 1.0), (0.5, 500.0)],
                   "max_accel": [0.0, -3.0], "max_decel": [0.0], "drag": [-0.1, 5.0]}
    cases = []
    for cls, good in ((Camera, camera), (Car, car)):
        for name in good:
            for value in (f"{good[name]}", True, float("nan"), *implausible[name]):
                cases.append((cls, good, name, value))
    return cases


@pytest.mark.parametrize("cls, good, name, value", _wrong_fields(), ids=str)
def test_every_field_of_a_camera_and_a_car_refuses_what_it_cannot_be_naming_it(cls, good, name, value):
    """A camera and a car are made in the Python API (`register_camera`'s arguments): each field refuses a value
    of the wrong kind or outside what a camera or car can be, in one line that names it; the good values are taken."""
    cls(**good)
    with pytest.raises(SteerlabError, match=rf"^(camera|car)\.{name} must be .*, got") as e:
        cls(**{**good, name: value})
    assert "\n" not in str(e.value)
