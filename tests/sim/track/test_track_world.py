"""The track world wired in: laps and off-track events, the pilot's throttle through the one driving loop, the
donkeycar part as the pilot, another light (`sim record/drive/bench --world track` in test_track_commands.py, the
learned throttle's scale, cap and floor and the pace in test_track_pace.py)."""

import math

import numpy as np
import pytest

from conftest import made
from steerlab.data.car import VehicleState, speed_after
from steerlab.data.recording import SteeringConvention
from steerlab.errors import SteerlabError
from steerlab.pilot import Controls
from steerlab.sim.core.driving import drive_loop
from steerlab.sim.core.part import PartPilot, donkey_pilot
from steerlab.sim.road.world import World
from steerlab.sim.track.look import Look
from steerlab.sim.track.world import Laps, RacerPilot, TrackWorld
from tests.sim.track.pilots import DONKEY, IDEAL, Scripted


def at_speed(world, v):
    st = world.state
    world.smallcar.state = VehicleState(st.x, st.y, st.psi, v)
    return world


def test_laps_are_timed_where_the_progress_passes_the_line():
    laps = Laps(10.0)
    for k in range(1, 81):  # 3 m/s in ticks of 0.1 s, and 2 m back over the line at 4 s
        laps.advance(-2.0 if k == 40 else 0.3, k / 10)
        if k == 50:
            laps.off_track()
    r = laps.result()
    # 10 m is passed between 9.9 m at 3.3 s and 10.2 m at 3.4 s: at 3.3 + 0.1 / 3 s; back to 9.7 m at 4 s and
    # over the line again (no lap), then 20 m between 19.9 m at 7.4 s and 20.2 m at 7.5 s
    assert laps.crossings == pytest.approx([0.0, 3.3 + 0.1 / 3, 7.4 + 0.1 / 3])
    assert r["lap_times_s"] == pytest.approx([10 / 3, 4.1])
    assert r["laps"] == 2 and r["off_track_laps"] == [2] and r["clean_laps"] == 1
    assert r["best_lap_s"] == r["mean_lap_s"] == pytest.approx(10 / 3)
    assert laps.progress == pytest.approx(79 * 0.3 - 2.0)
    first = Laps(10.0)
    first.advance(12.0, 2.0)  # 12 m in the first 2 s from the start: the line passed at 10 / 12 of them
    assert first.crossings == pytest.approx([0.0, 5 / 3])
    assert Laps(5.0).result() == {"laps": 0, "clean_laps": 0, "best_lap_s": None, "mean_lap_s": None,
                                  "lap_times_s": [], "off_track_laps": []}


def test_lap_time_of_a_constant_speed_drive_is_the_lap_over_the_speed():
    """Throttle 0.4 of the 5 m/s motor without drag holds 2 m/s exactly; following the lane centre, a lap takes
    the track's length over 2 m/s (the rear axle cuts the turns by a few millimetres)."""
    world = at_speed(TrackWorld(5, camera=None, throttle=0.4, car=IDEAL), 2.0)
    pilot = Scripted()
    pilot.step = lambda frame, speed=None: Controls(world.expert_steering())
    t = drive_loop(world, pilot, int(round(20 * world.track.length)) + 20, 0.0, 20.0, progress=False)
    assert np.all(t.speed == 2.0) and t.interventions == 0
    r = world.laps.result()
    assert r["laps"] == r["clean_laps"] == 2
    assert r["lap_times_s"] == pytest.approx([world.track.length / 2.0] * 2, rel=5e-3)
    assert r["best_lap_s"] == min(r["lap_times_s"]) and r["mean_lap_s"] == pytest.approx(np.mean(r["lap_times_s"]))


def test_the_expert_races_laps_without_leaving_the_lane():
    for seed in (0, 9402):
        world = TrackWorld(seed, camera=None)
        t = drive_loop(world, RacerPilot(world, seed), 1200, 0.0, 20.0, progress=False)
        r = world.laps.result()
        assert t.interventions == 0 and r["laps"] >= 3 and r["clean_laps"] == r["laps"]
        assert 1.0 < world.track.length / r["mean_lap_s"] < 5.0  # racing speeds of a 1:10 car
        assert sum(r["lap_times_s"]) <= 60.0 and world.overhang() < 0


def test_the_expert_as_a_pilot_drifts_out_recovers_and_keeps_under_its_cap():
    """With drift episodes every 2 s, the expert drifts out by its offset and recovers (never leaving the lane);
    its throttle is capped at 0.5 and it brakes below zero into the turns."""
    world = TrackWorld(0, camera=None)
    pilot = RacerPilot(world, 0, drift_every_s=2.0, max_throttle=0.5)
    episodes, throttles = [], []

    def on_step(tick):
        episodes.append(pilot.episode)
        throttles.append(tick.throttle)

    t = drive_loop(world, pilot, 400, 0.0, 20.0, progress=False, on_step=on_step)
    assert t.interventions == 0 and {"normal", "drift-out", "recover"} == set(episodes)
    assert max(throttles) == 0.5 and min(throttles) < 0
    pilot.racer.act = lambda state, s, offset, t: (0.1, -0.9, "normal")  # a harder brake than the cap: capped too
    assert pilot.step(None) == Controls(0.1, throttle=-0.5)


def test_full_lock_leaves_the_lane_when_the_body_corner_crosses_the_line_and_the_car_is_put_back():
    """From the start line at 1 m/s with full left lock the rear axle turns on a circle of radius
    wheelbase / tan(25 deg); the front left corner of the body (0.35 m ahead of the axle, 0.1 m left) crosses the
    lane's edge 0.45 m left of the centre at heading theta where R (1 - cos) + 0.35 sin + 0.1 cos = 0.45."""
    world = at_speed(TrackWorld(2, camera=None, throttle=0.2, car=IDEAL), 1.0)
    radius = DONKEY.wheelbase / math.tan(DONKEY.full_lock)
    lo, hi = 0.0, math.pi / 2
    for _ in range(60):
        theta = (lo + hi) / 2
        lateral = radius * (1 - math.cos(theta)) + 0.35 * math.sin(theta) + 0.1 * math.cos(theta)
        lo, hi = (theta, hi) if lateral < world.track.lane_width / 2 else (lo, theta)
    crossing = theta * radius / 1.0 * 20  # in ticks
    assert abs(crossing - round(crossing)) > 0.1  # not on a tick: the tick of the event is unambiguous
    pilot = Scripted(DONKEY.full_lock)
    t = drive_loop(world, pilot, 100, 0.0, 20.0, progress=False)
    events = np.flatnonzero(t.intervention)
    assert events[0] == math.ceil(crossing)
    assert np.abs(t.offset[events]).max() < 1e-3 and np.abs(t.heading[events]).max() < 1e-3  # on the centre line
    assert np.all(t.speed == 1.0)  # at its speed
    assert pilot.resets == t.interventions == len(events) >= 5
    assert world.laps.dirty == {1}
    # a bit more room: the body may overhang by 5 cm before it counts, so the first event comes later
    again = drive_loop(at_speed(TrackWorld(2, camera=None, throttle=0.2, car=IDEAL), 1.0), Scripted(DONKEY.full_lock),
                       100, 0.05, 20.0, progress=False)
    assert np.flatnonzero(again.intervention)[0] > events[0]


def test_a_pilot_that_steers_straight_leaves_the_lane_at_every_turn():
    world = TrackWorld(1, camera=None)
    pilot = Scripted(0.0)
    t = drive_loop(world, pilot, 1200, 0.0, 20.0, progress=False)
    hits = t.intervention
    assert t.interventions >= 10 and pilot.resets == t.interventions
    assert np.abs(t.offset[hits]).max() < 1e-3  # put back on the lane centre (to the sampling of the track)
    assert world.laps.progress > world.track.length  # put back where it left, it goes on round the track
    r = world.laps.result()
    assert r["laps"] >= 1 and r["clean_laps"] == 0 and set(r["off_track_laps"]) >= set(range(1, r["laps"] + 1))


def test_the_loop_passes_the_pilots_throttle_and_the_road_world_keeps_its_speeds():
    world = TrackWorld(3, camera=None, car=IDEAL)
    t = drive_loop(world, Scripted(0.0, throttle=0.6), 10, 0.0, 20.0, progress=False)
    # from standstill the speed approaches 0.6 x 5 m/s with the 0.3 s lag: 3 (1 - exp(-k 0.05 / 0.3))
    np.testing.assert_allclose(t.speed, 3.0 * (1 - np.exp(-np.arange(10) * 0.05 / 0.3)), atol=1e-12)
    v = world.state.v
    drive_loop(world, Scripted(0.0, throttle=-1.0), 1, 0.0, 20.0, progress=False)  # the ESC brakes
    assert world.state.v == pytest.approx(speed_after(v, -1.0, 0.05, IDEAL)) and world.applied == -1.0
    assert world.record_row(0)["brake"] == 1.0 and world.record_row(0)["throttle"] == 0.0
    # a pilot that gives no throttle drives at the world's constant one
    t = drive_loop(TrackWorld(3, camera=None, throttle=0.2, car=IDEAL), Scripted(0.0), 10, 0.0, 20.0, progress=False)
    np.testing.assert_allclose(t.speed, 1.0 * (1 - np.exp(-np.arange(10) * 0.05 / 0.3)), atol=1e-12)
    # the road world follows its road's speed profile whatever throttle a pilot gives
    pilot = Scripted(0.0)
    pilot.convention = SteeringConvention("steering_wheel", "left")
    runs = []
    for throttle in (None, 1.0, -1.0):
        pilot.throttle = throttle
        runs.append(drive_loop(World(4, "country", "sim", 5.0), pilot, 40, 1.0, 20.0, progress=False).speed)
    assert np.array_equal(runs[0], runs[1]) and np.array_equal(runs[0], runs[2])


class Part:
    """A donkeycar part: run(img_arr) -> (angle, throttle); it records what it was given."""

    def __init__(self, angle=0.5, throttle=0.25):
        self.out, self.frames = (angle, throttle), []

    def run(self, img_arr):
        self.frames.append(img_arr)
        return self.out


def test_any_donkeycar_part_drives_through_the_adapter():
    part = Part(angle=0.5, throttle=0.25)
    pilot = PartPilot(part, 25.0)
    world = TrackWorld(1)
    frame = world.render()  # BGR; the part gets RGB, as donkeycar's cameras give it
    t = drive_loop(world, pilot, 3, 0.0, 20.0, progress=False)
    assert part.frames[0].shape == (120, 160, 3) and np.array_equal(part.frames[0], frame[..., ::-1])
    assert pilot.name == "Part" and pilot.geometry == "donkey"
    # angle 0.5, positive right: half of the 25-degree lock to the right; its throttle moves the car
    assert pilot.convention.to_road_wheel_left(0.5, 1.0) == pytest.approx(-math.radians(12.5))
    assert np.all(t.command == 0.5) and world.applied == 0.25 and world.state.v > 0
    assert pilot.step(frame).steering == 0.5
    part.out = (3.0, -2.0)  # beyond what the servo and the ESC take
    assert (pilot.step(frame).steering, pilot.step(frame).throttle) == (1.0, -1.0)
    for bad in (None, (0.1,), ("left", 0.2), (float("nan"), 0.1)):
        part.out = bad
        with pytest.raises(SteerlabError, match="run"):
            pilot.step(frame)
    with pytest.raises(SteerlabError, match="not a donkeycar part"):
        PartPilot(object(), 25.0)


def test_the_steerlab_part_as_pilot_gives_what_the_part_gives(tmp_path):
    from steerlab.donkey import SteerlabPilot

    ckpt = made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25)
    pilot = donkey_pilot(ckpt, throttle=0.35)
    part = SteerlabPilot(ckpt, 0.35, full_lock_deg=25.0, reset_after_s=None)
    world = TrackWorld(1)
    frames = [world.render()]
    for _ in range(3):
        world.step(0.0, 0.5)
        frames.append(world.render())
    for frame in frames:
        controls = pilot.step(frame, world.state.v)
        assert (controls.steering, controls.throttle) == part.run(frame[..., ::-1], world.state.v)
    assert controls.throttle == 0.35 and pilot.geometry == "donkey" and pilot.name == "pilotnet"


def test_another_light_scales_the_rooms_frames_and_leaves_the_room_as_drawn():
    """A look's light level replaces the room's drawn one and nothing else: at its own level the frame is the same bytes;
    at half of it the frame's mean is half (within the rounding to 8 bits); the floor, the tape and the track are
    the ones drawn."""
    own = TrackWorld(9506, 0.9, "taped", 20.0)
    level = own.renderer.room.light
    same, half = (TrackWorld(9506, 0.9, "taped", 20.0, look=Look(light=v)) for v in (level, level / 2))
    assert np.array_equal(same.render(), own.render())
    assert half.renderer.room.tape_name == own.renderer.room.tape_name and half.track.length == own.track.length
    assert half.render().mean() / own.render().mean() == pytest.approx(0.5, abs=0.01)
