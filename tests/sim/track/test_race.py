"""The levers of racing small cars: a limit on the steering's change per frame, the latency of a real part, DAgger's
labels under the cap the car drives with, the track world's cheap augmentation (other rooms, other camera mounts),
the selection tracks, and a random split as donkeycar's trainer makes it."""

import json

import numpy as np
import pytest

from steerlab.data.car import CARS, steady_speed
from steerlab.data.readers import Source
from steerlab.data.recording import SteeringConvention
from steerlab.data.splits import Split, make_split
from steerlab.errors import SteerlabError
from steerlab.pilot import Controls, Pilot
from steerlab.sim.core.driving import drive_loop
from steerlab.sim.track.world import TrackWorld
from tests.pilot.samples import frames, untrained


def test_the_steering_step_limits_the_change_from_frame_to_frame(tmp_path):
    """Unlimited, the untrained model's steering jumps between frames by more than the step; limited, it moves by at
    most the step, starting where the model starts, and follows it where the model moves less; stream() gives the
    same. A reset lets the next frame start anywhere."""
    model = untrained(tmp_path, "pilotnet")
    bgr = frames(12)
    free = [Pilot(model).step(f).steering for f in bgr]  # each frame on its own: a fresh Pilot
    step = float(np.median(np.abs(np.diff(free)))) / 2
    limited = Pilot(model, steering_step=step)
    got = [limited.step(f).steering for f in bgr]
    assert got[0] == free[0] and np.max(np.abs(np.diff(got))) <= step + 1e-12 < np.max(np.abs(np.diff(free)))
    expected = [free[0]]
    for y in free[1:]:
        expected.append(float(np.clip(y, expected[-1] - step, expected[-1] + step)))
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    limited.reset()
    assert [c.steering for c in limited.stream(bgr)] == got
    limited.reset()
    assert limited.step(bgr[5]).steering == free[5]
    with pytest.raises(SteerlabError, match="steering_step must be a positive finite number"):
        Pilot(model, steering_step=0.0)


class Counting:
    """A world whose frame k is filled with k, standing still."""

    car, steering_ratio, s, done = CARS["donkey"], 1.0, 0.0, False

    def __init__(self):
        self.k = 0
        self.state = TrackWorld(1, camera=None).state

    def intervene(self, limit_m):
        return False, 0.0, 0.0

    def render(self, lateral=0.0):
        return np.full((2, 2, 3), self.k, np.uint8)

    def expert_steering(self):
        return 0.0

    def step(self, road_wheel, throttle=None):
        self.k += 1

    def record_row(self, tick):
        return {}


class Seeing:
    name, geometry, source = "seeing", None, "seeing"
    convention = SteeringConvention("road_wheel", "left")

    def __init__(self):
        self.seen = []

    def step(self, frame, speed=None):
        self.seen.append(int(frame[0, 0, 0]))
        return Controls(0.0)

    def reset(self):
        pass


@pytest.mark.parametrize("latency, seen", [(0, [0, 1, 2, 3, 4, 5]), (1, [0, 0, 1, 2, 3, 4]), (2, [0, 0, 0, 1, 2, 3])])
def test_with_latency_the_pilot_steers_on_an_older_frame(latency, seen):
    pilot, world = Seeing(), Counting()
    drive_loop(world, pilot, 6, 0.0, 20.0, progress=False, latency=latency)
    assert pilot.seen == seen


def test_a_capped_dagger_rollout_labels_throttles_the_car_can_follow(tmp_path):
    """Under the cap 0.3 the expert's throttle labels stay within it, and when the expert drives (beta 1) the car
    never goes faster than throttle 0.3 holds."""
    from steerlab.sim.track.run import rollout
    from tests.sim.track.pilots import Scripted

    r = rollout(Scripted(0.0, throttle=0.3), tmp_path / "r", 7, 0.1, "taped", beta=1.0, max_throttle=0.3)
    rec = Source(str(tmp_path / "r")).open()
    assert r.off_track == 0 and np.max(np.abs(rec.throttle)) <= 0.3 + 1e-6 and np.max(rec.throttle) > 0.25
    assert r.mean_speed <= steady_speed(0.3, 1 / 20, CARS["donkey"])


def test_a_track_recorded_in_another_room_and_camera_mount(tmp_path):
    from steerlab.cli import main

    out = {}
    variants = (("plain", []), ("room", ["--room", "77"]), ("mount", ["--mount-height", "0.2", "--pitch", "25"]))
    for name, extra in variants:
        out[name] = tmp_path / name
        assert main(["sim", "record", "--world", "track", "--seed", "5", "--minutes", "0.01", "--layout", "steerlab",
                     "--no-drift", *extra, "--out", str(out[name])]) == 0
    recs = {k: Source(str(v)).open() for k, v in out.items()}
    frame = {k: r.load_frame(3).astype(int) for k, r in recs.items()}
    assert np.abs(frame["room"] - frame["plain"]).mean() > 10 and np.abs(frame["mount"] - frame["plain"]).mean() > 5
    np.testing.assert_array_equal(recs["room"].steering, recs["plain"].steering)  # the same drive, another look
    assert (recs["mount"].fisheye.mount_height, recs["mount"].fisheye.pitch_deg) == (0.2, 25.0)
    assert json.loads((out["room"] / "recording.json").read_text())["room"] == 77
    assert main(["sim", "record", "--seed", "5", "--minutes", "0.01", "--room", "3", "--out", str(tmp_path / "x")]) == 2


def test_the_selection_tracks_are_not_the_suites_and_are_never_recorded(tmp_path):
    from steerlab.sim.track.run import record
    from steerlab.sim.track.suite import TRACK_SUITES, TrackSuiteOptions
    from steerlab.sim.track.world import TrackRecordOptions

    seeds = {s: {t for ts in TRACK_SUITES[s]["tracks"].values() for t in ts} for s in ("t1", "s1", "t2", "t3")}
    assert all(len(s) == 8 for s in seeds.values())
    assert len(set().union(*seeds.values())) == 32  # no track in two suites
    assert [d[1] for d in TrackSuiteOptions(suite="s1").drives()] == sorted(seeds["s1"])
    for seed in (9501, 9701, 9752, 9801):
        with pytest.raises(SteerlabError, match="reserved for the track suites"):
            record(tmp_path / "r", TrackRecordOptions(seed=seed, minutes=0.01), progress=False)


def test_the_suites_that_results_are_scored_on_are_pinned():
    """Every track and road of the suites, as docs/results name them (racing.md, road-world.md): a suite changed by
    a digit scores other tracks than its results say, so a change here is a new suite under a new name."""
    from steerlab.sim.road.suite import SUITES
    from steerlab.sim.track.suite import TRACK_SUITES

    two_minutes = {"minutes": 2.0, "lane_width": 0.9}
    assert TRACK_SUITES == {
        "t1": {**two_minutes, "tracks": {"taped": [9401, 9402, 9403, 9404, 9405, 9406], "centre": [9451, 9452]}},
        "s1": {**two_minutes, "tracks": {"taped": [9501, 9502, 9503, 9504, 9505, 9506], "centre": [9551, 9552]}},
        "t2": {**two_minutes, "tracks": {"taped": [9701, 9702, 9703, 9704, 9705, 9706], "centre": [9751, 9752]}},
        "t3": {**two_minutes, "tracks": {"taped": [9801, 9802, 9803, 9804, 9805, 9806], "centre": [9851, 9852]}}}
    assert SUITES == {"v1": {"minutes": 3.0, "roads": {"country": [9101, 9102, 9103, 9104, 9105],
                                                       "highway": [9201, 9202, 9203], "twisty": [9301, 9302, 9303]}}}


def test_a_random_split_draws_frames_as_its_seed_says():
    split = Split.parse_option({"random": 0.25, "seed": 4}, "split")
    train, val = make_split(split, 40)
    again = make_split(split, 40)[1]
    other = make_split(Split.parse_option({"random": 0.25, "seed": 5}, "split"), 40)[1]
    assert len(val) == 10 and len(train) == 30 and not set(train) & set(val) and set(train) | set(val) == set(range(40))
    assert list(val) == list(again) and list(val) != list(other) and list(val) != list(range(10))
    assert split.as_dict() == {"random": 0.25, "seed": 4}
    for bad, message in (({"random": 1.0}, "split.random must be a number in (0, 1)"),
                         ({"random": 0.2, "val": "0:3"}, "random takes only a seed beside it"),
                         ({"seed": 1, "train": "0:3", "val": "3:5"}, "split.seed is the seed of a random split")):
        with pytest.raises(SteerlabError, match=message.replace("(", r"\(").replace(")", r"\)")):
            Split.parse_option(bad, "split")


def test_a_random_split_refuses_a_recurrent_model(tmp_path):
    from steerlab.train.config import load_config

    with pytest.raises(SteerlabError, match="split.random draws single frames; model 'lstm' trains on sequences"):
        load_config(None, base={"data": str(tmp_path), "model": {"name": "lstm"}, "split": {"random": 0.2}})
