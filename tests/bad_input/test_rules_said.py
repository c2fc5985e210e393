"""The rules of a new user's round, each with its cases: implausible input is said, the API raises steerlab's errors,
messages name what is wrong and what to do (the units and orders every other message uses)."""

import math

import numpy as np
import pytest

from conftest import made
from steerlab.cli import main
from steerlab.data.car import CARS
from steerlab.data.readers import open_recording
from steerlab.data.recording import PLAUSIBLE_LOCKS
from steerlab.errors import DataError, SteerlabError
from tests.inputs import ch2

CH2_LOCK = CARS["ch2"].full_lock * CARS["ch2"].steering_ratio  # rad of the steering wheel at full lock


@pytest.mark.parametrize("value, refused", [(-19.2, True), (PLAUSIBLE_LOCKS * CH2_LOCK * 1.01, True),
                                            (math.degrees(0.3), True), (-PLAUSIBLE_LOCKS * CH2_LOCK * 0.99, False),
                                            (2.5, False)])
def test_steering_no_car_gives_is_refused_naming_the_frame(tmp_path, value, refused):
    folder = ch2(tmp_path / "ch2")
    labels = folder / "labels.csv"
    rows = labels.read_text().splitlines()
    fid = rows[4].split(",")[0]
    rows[4] = f"{fid},{value},1"
    labels.write_text("\n".join(rows) + "\n")
    if not refused:
        assert open_recording(folder).steering[3] == pytest.approx(value)
        return
    with pytest.raises(DataError, match=rf"frame 3 \(id {fid}\): steering {value:g} is "
                                        rf"{abs(value) / CH2_LOCK:.1f} times the car's full lock \(8.14 rad of the "
                                        r"steering-wheel angle\): no car steers so far; convert the column"):
        open_recording(folder)


def test_timestamps_that_do_not_increase_name_both_frames_and_the_fix(tmp_path):
    from steerlab.data.recording import Recording, SteeringConvention

    with pytest.raises(DataError, match=r"/rec: timestamps must increase: frame 2 \(id 12\) is at 50 ns, not after "
                                        r"frame 1 at 50 ns; sort the frames by time, or remove the repeated ones$"):
        Recording(name="rec", source=tmp_path / "rec", frames={"center": [tmp_path / "f.jpg"] * 3},
                  timestamps_ns=np.array([0, 50, 50]), steering=np.zeros(3),
                  convention=SteeringConvention("road_wheel", "left"), frame_ids=np.array([10, 11, 12]))


def test_the_api_raises_steerlabs_errors_for_a_clock_and_a_checkpoint_dict(tmp_path):
    from steerlab.checkpoint import load_checkpoint
    from steerlab.donkey import SteerlabPilot
    from steerlab.pilot import Pilot

    ckpt = made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25)
    frame = np.zeros((120, 160, 3), np.uint8)
    for clock in (lambda: "x", lambda: None, lambda: math.nan, lambda: True):
        part = SteerlabPilot(ckpt, clock=clock)
        with pytest.raises(SteerlabError, match=r"^SteerlabPilot: clock\(\) must return seconds, a finite number"):
            part.run(frame)
    loaded = load_checkpoint(ckpt)
    for key in ("model", "stats", "preprocess", "convention", "model_cfg"):
        broken = {k: v for k, v in loaded.items() if k != key}
        with pytest.raises(SteerlabError, match=rf"not a steerlab checkpoint \(it lacks '{key}'\)"):
            Pilot(broken)
    assert Pilot(loaded).name == "pilotnet"


@pytest.mark.parametrize("fx", [1.0, 10.0, 20.0])
def test_a_calibration_in_the_wrong_units_is_blamed_on_k_not_d(fx):
    from steerlab.data.fisheye import FisheyeCamera

    with pytest.raises(SteerlabError, match=rf"^the focal lengths fx={fx:g}, fy={fx:g} px put the image's corners "):
        FisheyeCamera(fx=fx, fy=fx)
    with pytest.raises(SteerlabError, match=r"^fisheye coefficients D="):
        FisheyeCamera(d=(-1.0, 0.0, 0.0, 0.0))


def test_an_option_of_another_world_is_refused_whatever_its_value(tmp_path, capsys):
    for value in ("3", "0.9"):
        assert main(["sim", "record", "--world", "road", "--lane-width", value, "--out", str(tmp_path / "r")]) == 2
        assert capsys.readouterr().err == ("error: --lane-width is an option of the track world (--world track); "
                                           "the road world does not take it\n")
    assert not (tmp_path / "r").exists()


def test_a_recording_of_black_frames_is_refused_when_compiled(tmp_path, capsys):
    from steerlab.data.writer import TubWriter

    w = TubWriter(tmp_path / "tub", full_lock_deg=25)
    for i in range(6):
        w.add(np.full((120, 160, 3), 3 if i % 2 else 0, np.uint8), i * 50_000_000, 0.01 * i, 0.3)
    tub = w.close()
    assert main(["compile", "--data", str(tub), "--cache", str(tmp_path / "cache")]) == 2
    assert capsys.readouterr().err == (f"error: {tub}: all 6 frames of camera 'center' are black (no pixel reaches 8 "
                                       "of 255): the camera recorded nothing (a lens cap, no exposure?); record it "
                                       "again, or give another recording\n")
    assert not any((tmp_path / "cache").rglob("*.npy"))  # nothing half-written is left
    w = TubWriter(tmp_path / "dim", full_lock_deg=25)  # one frame with light in it is a recording
    for i in range(6):
        w.add(np.full((120, 160, 3), 40 if i == 5 else 0, np.uint8), i * 50_000_000, 0.01 * i, 0.3)
    assert main(["compile", "--data", str(w.close()), "--cache", str(tmp_path / "cache")]) == 0


@pytest.mark.parametrize("layout", ["tub", "steerlab"])
def test_an_interrupted_recording_leaves_nothing_and_a_rerun_records_it(tmp_path, monkeypatch, layout):
    from steerlab.data import writer

    out = tmp_path / "rec"
    cls = writer.TubWriter if layout == "tub" else writer.RecordingWriter
    real = cls.add

    def add(self, *args, **kw):
        if len(getattr(self, "records", None) or getattr(self, "rows", [])) == 5:
            raise KeyboardInterrupt  # Ctrl-C halfway
        return real(self, *args, **kw)

    argv = ["sim", "record", "--world", "track", "--minutes", "0.01", "--layout", layout, "--out", str(out)]
    with monkeypatch.context() as m:
        m.setattr(cls, "add", add)
        assert main(argv) == 130  # "interrupted"
    assert not out.exists() and (tmp_path / ".rec.part").is_dir()  # the half-written recording, hidden beside
    assert main(argv) == 0 and len(open_recording(out)) == 12 and not (tmp_path / ".rec.part").exists()


def test_a_study_whose_recording_fails_ends_in_one_line(tmp_path):
    from studies.common import track_tub

    with pytest.raises(SteerlabError, match=r"^steerlab sim record --world track --seed 9501 --out .* failed \(exit "
                                            r"status 2; its message is above\): fix what it says"):
        track_tub(tmp_path / "tub", "--seed", "9501")  # a suite's reserved seed


@pytest.mark.parametrize("kind, geometry, steering, said", [
    ("road_wheel", "donkey", [0.1, 0.9, 1.5], r"frame 1 \(id 11\): steering 0.9 is 2.1 times the car's full lock "
                                              r"\(0.436 rad of the road-wheel angle\)"),
    ("normalized", "donkey", [0.5, 2.5, 5.0], r"frame 1 \(id 11\): steering 2.5 is 2.5 times the car's full lock "
                                              r"\(1, normalized\)"),
    ("road_wheel", None, [math.nan, 1.2, 0.1], r"frame 1 \(id 11\): steering 1.2 is 2.2 times"),
])
def test_the_first_implausible_frame_is_named_in_every_convention(tmp_path, kind, geometry, steering, said):
    from steerlab.data.recording import Recording, SteeringConvention

    with pytest.raises(DataError, match=said):
        Recording(name="rec", source=tmp_path / "rec", frames={"center": [tmp_path / "f.jpg"] * 3},
                  timestamps_ns=np.array([0, 50, 100]), steering=np.array(steering),
                  convention=SteeringConvention(kind, "left"), frame_ids=np.array([10, 11, 12]),
                  **({"geometry": geometry} if geometry else {"geometry": "unknown"}))
