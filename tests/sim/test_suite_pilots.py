"""A suite races any pilot (`core.suite.Entrant`): a checkpoint, or a donkeycar part behind `track.suite.part_entrant`.
A kept drive is reused only for the same pilot (its checkpoint's or its model file's sha256) and the same drive
options, and a part's throttle reaches the car times the suite's throttle scale, then capped."""

import json
from functools import partial

import numpy as np
import pytest

from steerlab.control import Throttle
from steerlab.errors import SteerlabError
from steerlab.sim.core.part import PartPilot
from steerlab.sim.track import world as track_world
from steerlab.sim.track.suite import TrackSuiteOptions, part_entrant, race

MADE = []  # every stub part made, in this process (the suites below drive in it: one worker)


class Stub:
    """A donkeycar part that answers every frame with the same (angle, throttle)."""

    def __init__(self, angle: float, throttle: float):
        self.answer = (angle, throttle)
        MADE.append(self)

    def run(self, img_arr):
        return self.answer


def options(**kw) -> TrackSuiteOptions:
    return TrackSuiteOptions(minutes=0.05, styles="centre", workers=1, **kw)  # 60 ticks on each of 2 tracks


def stub(model, throttle: float = 0.3):
    return part_entrant("stub", model, partial(Stub, 0.0, throttle))


def test_a_parts_throttle_reaches_the_car_scaled_then_capped(tmp_path, monkeypatch):
    """min(cap, scale x throttle): 0.3 x 1.2 = 0.36 under a cap of 0.5; 0.3 x 1.5 = 0.45, capped to 0.4. Without the
    scale the car would get 0.3 both times; capped first, 0.36 and 0.4 x 1.5 = 0.6."""
    applied = []
    step = track_world.TrackWorld.step

    def spy(self, road_wheel, throttle=None):
        if self.renderer is not None:  # the part's drives; the expert's render nothing
            applied.append(throttle)
        return step(self, road_wheel, throttle)

    monkeypatch.setattr(track_world.TrackWorld, "step", spy)
    model = tmp_path / "model.h5"
    model.write_bytes(b"weights")
    for scale, cap, expected in ((1.2, 0.5, 0.36), (1.5, 0.4, 0.4)):
        applied.clear()
        rows = race([stub(model)], tmp_path / f"suite-{scale}", options(throttle_scale=scale, max_throttle=cap),
                    progress=False)
        assert len(applied) == 2 * 60 and applied == pytest.approx([expected] * 120)
        assert [r.label for r in rows] == ["stub", "stub"] and rows[0].checkpoint == str(model)
    # PartPilot alone: the same order, and the angle only limited to the servo's range
    controls = PartPilot(Stub(2.0, -0.5), 25.0, throttle=Throttle(scale=3.0, cap=0.8)).step(
        np.zeros((120, 160, 3), np.uint8))
    assert (controls.steering, controls.throttle) == (1.0, -0.8)


def test_a_kept_drive_is_reused_only_for_the_same_pilot_and_options(tmp_path):
    """The same model file and options: no part is made again. Another model file (other bytes), or another throttle
    scale: every drive is driven again, and its drive.json holds the new key."""
    model = tmp_path / "model.h5"
    model.write_bytes(b"weights")
    out = tmp_path / "suite"

    def made(o: TrackSuiteOptions, throttle: float = 0.3) -> int:
        before = len(MADE)
        race([stub(model, throttle)], out, o, progress=False)
        return len(MADE) - before

    assert made(options()) == 2  # a part per drive: two tracks
    kept = json.loads((out / "stub" / "centre-9451" / "drive.json").read_text())["cache_key"]
    assert made(options()) == 0  # reused
    # the part answers otherwise now, but its model file is the same: its drives are its own and reused
    assert made(options(), throttle=0.9) == 0
    model.write_bytes(b"other weights")  # another model: driven again
    assert made(options()) == 2
    again = json.loads((out / "stub" / "centre-9451" / "drive.json").read_text())["cache_key"]
    assert again["model_sha256"] != kept["model_sha256"] and {**again, "model_sha256": 0} == {**kept, "model_sha256": 0}
    assert made(options(throttle_scale=1.5)) == 2  # other options: driven again
    assert made(options(throttle_scale=1.5)) == 0


def test_a_drive_kept_without_a_key_is_driven_again(tmp_path):
    """A drive.json of a loop that kept no key (donkeycar's drives before the suite raced parts) is not taken."""
    model = tmp_path / "model.h5"
    model.write_bytes(b"weights")
    out = tmp_path / "suite"
    race([stub(model)], out, options(), progress=False)
    for drive in (out / "stub").glob("*/drive.json"):
        data = json.loads(drive.read_text())
        del data["cache_key"]
        drive.write_text(json.dumps(data))
    before = len(MADE)
    race([stub(model)], out, options(), progress=False)
    assert len(MADE) - before == 2


def test_two_pilots_of_one_label_and_a_part_out_of_range_are_refused(tmp_path):
    model = tmp_path / "model.h5"
    model.write_bytes(b"weights")
    with pytest.raises(SteerlabError,
                       match="two pilots of the suite are labelled 'stub': give each a label of its own"):
        race([stub(model), stub(model)], tmp_path / "suite", options(), progress=False)
    with pytest.raises(SteerlabError, match=r"^max_throttle must be a number in \(0, 1\], got 1.5$"):
        PartPilot(Stub(0.0, 0.0), 25.0, throttle=Throttle(cap=1.5))
    with pytest.raises(SteerlabError, match=r"^throttle_floor must be a number in \[0, 1\], got -0.1$"):
        PartPilot(Stub(0.0, 0.0), 25.0, throttle=Throttle(floor=-0.1))
    with pytest.raises(SteerlabError, match=r"^throttle must be a steerlab.control.Throttle or None, got 0.5"):
        PartPilot(Stub(0.0, 0.0), 25.0, throttle=0.5)


def test_a_throttle_floor_holds_only_while_the_car_stands():
    """A part that brakes (-0.2): at rest (speed below 0.1 m/s) the car gets the floor 0.15 (a floor at the cap: the
    cap); moving, or with no floor, the brake as it was."""
    frame = np.zeros((120, 160, 3), np.uint8)

    def throttle(speed, floor, cap=1.0):
        return PartPilot(Stub(0.0, -0.2), 25.0, throttle=Throttle(cap=cap, floor=floor)).step(frame, speed).throttle

    assert throttle(0.0, 0.15) == 0.15 and throttle(0.099, 0.15) == 0.15 and throttle(0.0, 0.1, cap=0.1) == 0.1
    assert throttle(0.1, 0.15) == -0.2 and throttle(2.0, 0.15) == -0.2 and throttle(0.0, 0.0) == -0.2
    assert PartPilot(Stub(0.0, 0.4), 25.0, throttle=Throttle(cap=1.0, floor=0.15)).step(frame, 0.0).throttle == 0.4
    assert throttle(None, 0.15) == -0.2  # no speed measured: no floor


def test_a_part_that_brakes_at_rest_stands_and_the_floor_gets_it_going(tmp_path):
    """In the suite: a part that always brakes (-0.1) drives 0 m; with a floor of 0.3 the car leaves the line, then
    creeps on, each time the floor lifts it to 0.1 m/s. The floor changes the drive's key: it is driven again."""
    model = tmp_path / "model.h5"
    model.write_bytes(b"weights")
    out = tmp_path / "suite"
    distance = {}
    for floor in (0.0, 0.3):
        race([stub(model, throttle=-0.1)], out, options(throttle_floor=floor), progress=False)
        distance[floor] = json.loads((out / "stub" / "centre-9451" / "drive.json").read_text())["distance_km"]
    assert distance[0.0] == 0.0 and distance[0.3] > 0.0


def test_a_parts_answer_reaches_the_car_as_the_servo_and_the_esc_take_it():
    """By hand: the part sees the frame as RGB, its angle is limited to [-1, 1] as the servo limits it and its own
    throttle (no shaping given) to the ESC's [-1, 1]; an answer that is not finite is refused."""
    from steerlab.sim.core.part import PartPilot

    class Seeing(Stub):
        def run(self, img_arr):
            self.seen = img_arr
            return self.answer

    frame = np.arange(2 * 3 * 3, dtype=np.uint8).reshape(2, 3, 3)
    part = Seeing(0.5, 0.2)
    PartPilot(part, 25.0).step(frame, 1.0)
    assert np.array_equal(part.seen, frame[..., ::-1])
    for answer, expected in [((1.7, 1.7), (1.0, 1.0)), ((-1.7, -1.7), (-1.0, -1.0)), ((0.3, -0.4), (0.3, -0.4))]:
        controls = PartPilot(Stub(*answer), 25.0).step(frame, 1.0)
        assert (controls.steering, controls.throttle) == pytest.approx(expected)
    for answer in ((float("nan"), 0.2), (0.1, float("inf"))):
        with pytest.raises(SteerlabError, match="finite numbers are expected"):
            PartPilot(Stub(*answer), 25.0).step(frame, 1.0)


class Told(Stub):
    """A part set up for each track: it records the drive options it was told, and answers on that track alone."""

    def __init__(self):
        super().__init__(0.0, 0.3)
        self.told = []

    def on_track(self, drive):
        self.told.append((drive.style, drive.seed, drive.lane_width))

    def run(self, img_arr):
        assert len(self.told) == 1, "driven before it was told its track"
        return self.answer


def test_a_part_with_on_track_is_told_each_drives_track_before_its_first_frame(tmp_path):
    model = tmp_path / "settings.json"
    model.write_text("{}")
    before = len(MADE)
    race([part_entrant("told", model, Told)], tmp_path / "suite", options(), progress=False)
    assert sorted(p.told[0] for p in MADE[before:]) == [("centre", 9451, 0.9), ("centre", 9452, 0.9)]
    assert [len(p.told) for p in MADE[before:]] == [1, 1]  # a part per drive, told once
