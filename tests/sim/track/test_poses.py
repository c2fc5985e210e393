"""Frames from every pose (`steerlab sim record --world track --poses`, sim/track/poses.py): each frame is the one
the driving loop renders at its pose, each label the expert's controls there, and the draw is what the manifest
says."""

import json
import math

import cv2
import numpy as np
import pytest

from steerlab.cli import main
from steerlab.data.readers import open_recording
from steerlab.data.recording import SteeringConvention
from steerlab.data.writer import TUB_JPEG
from steerlab.errors import SteerlabError
from steerlab.pilot import Controls
from steerlab.sim.core.driving import drive_loop
from steerlab.data.car import VehicleState
from steerlab.sim.track.expert import expert_controls
from steerlab.sim.track.poses import draw
from steerlab.sim.track.track import LANE_WIDTH
from steerlab.sim.track.world import DRIFT_EVERY_S, RacerPilot, TrackRecordOptions, TrackWorld


def records(tub):
    return [json.loads(line) for line in (tub / "catalog_0.catalog").read_text().splitlines()]


def metadata(tub):
    return json.loads((tub / "manifest.json").read_text().splitlines()[2])


class Still:
    """A pilot that keeps the wheels straight and rolls: the one tick the driving loop renders."""

    name, geometry, source = "still", "donkey", "a test"
    convention = SteeringConvention("road_wheel", "left")

    def step(self, frame, speed=None):
        return Controls(0.0, throttle=0.0)

    def reset(self):
        pass


def test_a_pose_frame_is_the_driving_loops_frame_there_labelled_with_the_experts_controls(tmp_path):
    tub = tmp_path / "poses"
    assert main(["sim", "record", "--world", "track", "--seed", "27", "--minutes", "0.1", "--poses",
                 "--out", str(tub)]) == 0
    recs = records(tub)
    assert len(recs) == 120 and len({r["_session_id"] for r in recs}) == 120  # every pose a session of its own
    # the places and speeds: the expert's drive of the same minutes, driven here without a frame
    line = TrackWorld(27, camera=None)
    t = drive_loop(line, RacerPilot(line, 27, DRIFT_EVERY_S), 120, 0.0, 20.0, progress=False)
    offset, heading = draw(metadata(tub)["poses"], 27, 120)  # the draw the manifest describes
    world = TrackWorld(27)
    full_lock = world.car.full_lock
    for k in (0, 37, 119):
        r = recs[k]
        x, y, psi = (float(v) for v in world.track.pose(t.s[k], offset[k]))
        state = VehicleState(x, y, psi + heading[k], float(t.speed[k]))
        world.smallcar.state, world.s = state, float(t.s[k])
        seen = {}
        drive_loop(world, Still(), 1, 10.0, 20.0, progress=False, on_step=lambda tick: seen.update(frame=tick.frame))
        jpeg = cv2.imdecode(cv2.imencode(".jpg", seen["frame"], TUB_JPEG)[1], 1)
        np.testing.assert_array_equal(cv2.imread(str(tub / "images" / r["cam/image_array"])), jpeg)
        wheel, throttle = expert_controls(world.track, state, float(t.s[k]), world.car)
        assert r["user/angle"] == pytest.approx(float(np.clip(-wheel / full_lock, -1, 1)), abs=1e-12)
        assert r["user/throttle"] == pytest.approx(float(np.clip(throttle, -1, 1)), abs=1e-12)
        assert r["lane/curvature"] == pytest.approx(float(world.track.curvature(t.s[k])), abs=1e-12)
        # the lane values are the pose, read back by projecting the rear axle onto the lane centre
        assert (r["lane/offset"], r["lane/heading"]) == pytest.approx((offset[k], heading[k]), abs=2e-3)
    # the reader reads it with its lane values; a car turned towards the left steers right
    rec = open_recording(tub, options={"full_lock_deg": 25})
    assert len(rec) == 120 and len(rec.segments()) == 120
    turned = (rec.extra["heading_error"] > 0.3) & (np.abs(rec.extra["lateral_offset"]) < 0.1)
    assert turned.any() and np.all(rec.steering[turned] > 0)
    # same options, same bytes; another seed of the draw, other poses at the same places
    again = tmp_path / "again"
    main(["sim", "record", "--world", "track", "--seed", "27", "--minutes", "0.1", "--poses", "--out", str(again)])
    assert records(again) == recs
    other = tmp_path / "other"
    main(["sim", "record", "--world", "track", "--seed", "27", "--minutes", "0.1", "--poses", "--pose-seed", "1",
          "--out", str(other)])
    assert not np.isclose([r["lane/offset"] for r in records(other)], [r["lane/offset"] for r in recs]).any()


def uniform_ks(values, lo, hi) -> float:
    """Kolmogorov-Smirnov distance of `values` from the uniform distribution on [lo, hi]."""
    x = np.sort((np.asarray(values) - lo) / (hi - lo))
    n = len(x)
    return float(max(np.max(np.arange(1, n + 1) / n - x), np.max(x - np.arange(n) / n)))


@pytest.mark.parametrize("given, offset_m, heading_deg", [
    ([], 1.25 * LANE_WIDTH / 2, 30.0),
    (["--pose-offset", "0.5", "--pose-heading", "10", "--lane-width", "0.6"], 0.5 * 0.6 / 2, 10.0),
])
def test_the_poses_are_drawn_as_the_manifest_says(tmp_path, given, offset_m, heading_deg):
    tub = tmp_path / "poses"
    assert main(["sim", "record", "--world", "track", "--seed", "31", "--minutes", "0.25", "--poses", *given,
                 "--out", str(tub)]) == 0
    poses = metadata(tub)["poses"]
    assert poses["offset_m"] == pytest.approx(offset_m) and poses["heading_deg"] == heading_deg
    assert poses["seed"] == 0
    recs = records(tub)
    offset = np.array([r["lane/offset"] for r in recs])
    heading = np.degrees([r["lane/heading"] for r in recs])
    # the lane values are the pose drawn (the rear axle's offset and heading, read back by projection: 2e-3 m, rad)
    assert np.abs(offset).max() <= offset_m + 2e-3 and np.abs(heading).max() <= heading_deg + 0.12
    # uniform: the KS distance of 300 draws below its 1 % critical value, 1.63 / sqrt(n)
    assert uniform_ks(offset, -offset_m, offset_m) < 1.63 / math.sqrt(len(recs))
    assert uniform_ks(heading, -heading_deg, heading_deg) < 1.63 / math.sqrt(len(recs))
    # and independent of each other
    assert abs(np.corrcoef(offset, heading)[0, 1]) < 0.15


def test_pose_options_without_poses_and_poses_in_another_layout_are_refused():
    for given in ({"pose_seed": 3}, {"pose_offset": 1.0}, {"pose_heading": 20.0}):
        with pytest.raises(SteerlabError, match=f"{next(iter(given))} must be given only with poses"):
            TrackRecordOptions(**given)
    with pytest.raises(SteerlabError, match="layout must be tub with poses"):
        TrackRecordOptions(poses=True, layout="steerlab")
    assert TrackRecordOptions(poses=True, pose_offset=2.0).pose_offset == 2.0
