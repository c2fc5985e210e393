"""The learned throttle on the track (its scale, its cap both ways, the part's floor while the car stands) and
the pace: laps timed over the same tracks for a track and for the suite, the expert's reference laps under the
model's cap."""

import csv
from dataclasses import replace

import numpy as np
import pytest

from conftest import made
from steerlab.cli import main
from steerlab.data.car import CARS, steady_speed
from steerlab.errors import SteerlabError
from steerlab.pilot import Controls
from steerlab.sim.core.part import donkey_pilot
from steerlab.sim.track.world import Laps, TrackWorld


def test_the_throttle_scale_multiplies_the_learned_throttle_before_the_cap(tmp_path):
    """--throttle-scale: the part's throttle is the model's times the scale, then capped (hand-computed products and
    caps); a scale of 0.1 under a cap of 1 drives at less than half the top speed of the model's own throttle."""
    from steerlab.pilot import Pilot

    ckpt = made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25, throttle=True)
    frame = TrackWorld(9401, 0.9, "taped", 20.0).render()
    learned = Pilot(ckpt).step(frame, 0.0).throttle
    assert learned > 0
    for scale, cap, expected in [(1.0, 1.0, learned), (0.5, 1.0, 0.5 * learned), (3.0, 1.0, min(3 * learned, 1.0)),
                                 (2.0, learned, learned)]:
        got = donkey_pilot(ckpt, 0.3, max_throttle=cap, throttle_scale=scale).step(frame, 0.0).throttle
        assert got == pytest.approx(expected, abs=1e-5)
    speeds = {}
    for scale in ("1", "0.1"):
        out = tmp_path / scale
        assert main(["sim", "drive", str(ckpt), "--world", "track", "--minutes", "0.02", "--max-throttle", "1",
                     "--throttle-scale", scale, "--out", str(out)]) == 0
        with open(out / "trajectory.csv") as f:
            speeds[scale] = max(float(r["speed"]) for r in csv.DictReader(f))
    assert 0 < speeds["0.1"] < speeds["1"] / 2


def test_the_learned_throttle_is_capped_both_ways_and_braking_is_scaled_too(tmp_path):
    """The part's throttle of a model that learned it, by hand: the learned value times the scale, then capped to
    +-max_throttle, forward and braking alike (the model's answers replaced by known ones)."""
    from steerlab.donkey import SteerlabPilot

    ckpt = made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25, throttle=True)
    frame = np.zeros((120, 160, 3), np.uint8)
    for learned, scale, cap, expected in [(0.4, 0.5, 0.3, 0.2), (0.4, 2.0, 0.5, 0.5), (-0.8, 0.5, 0.3, -0.3),
                                          (-0.8, 0.5, 0.5, -0.4), (-0.8, 2.0, 1.0, -1.0)]:
        part = SteerlabPilot(ckpt, throttle_scale=scale, max_throttle=cap)
        part.pilot.step = lambda image, speed=None, learned=learned: Controls(0.1, throttle=learned)
        assert part.run(frame) == pytest.approx((0.1, expected))
    # a speed-command model: the throttle steps by command_step up (2) or down (0) from 0.3, within [0, max_throttle]
    command = made(tmp_path, "normalized", "right", "donkey", name="command.pt", model="speed-command")
    part = SteerlabPilot(command, 0.3, command_step=0.1, max_throttle=0.5)
    for said, expected in [(2, 0.4), (2, 0.5), (2, 0.5), (0, 0.4), (0, 0.3), (0, 0.2), (0, 0.1), (0, 0.0), (0, 0.0)]:
        part.pilot.step = lambda image, speed=None, said=said: Controls(0.0, command=said)
        assert part.run(frame)[1] == pytest.approx(expected)
    # the part's numbers in their intervals: closed ends taken, open ones and booleans refused, the interval named
    steering = made(tmp_path, "normalized", "right", "donkey", name="steering.pt", full_lock_deg=25)
    SteerlabPilot(steering, throttle=0.0, kp=0.0, ki=0.0, command_step=0.0, max_throttle=1.0)
    for given, said in [({"throttle": True}, r"throttle must be a number in \[0, 1\], got True"),
                        ({"throttle": 1.5}, r"throttle must be a number in \[0, 1\], got 1.5"),
                        ({"max_throttle": 0.0}, r"max_throttle must be a number in \(0, 1\], got 0.0")]:
        with pytest.raises(SteerlabError, match=f"^SteerlabPilot: {said}$"):
            SteerlabPilot(steering, **given)


def test_the_parts_throttle_floor_holds_only_while_the_measured_speed_says_the_car_stands(tmp_path):
    """`SteerlabPilot(throttle_floor=)` on a car, by hand: a learned brake (-0.2, scaled 1.5 to -0.3) becomes the
    floor 0.25 below 0.1 m/s and stays a brake at 0.1 m/s and above; a floor at the cap holds the car at the cap, one
    above it is refused; without the measured speed, or on a model of a constant throttle, the part refuses in one
    line."""
    from steerlab.donkey import SteerlabPilot
    from steerlab.sim.core.part import donkey_pilot

    ckpt = made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25, throttle=True)
    frame = np.zeros((120, 160, 3), np.uint8)
    for speed, cap, expected in [(0.0, 1.0, 0.25), (0.09, 1.0, 0.25), (0.1, 1.0, -0.3), (2.0, 1.0, -0.3),
                                 (0.0, 0.25, 0.25)]:
        part = SteerlabPilot(ckpt, throttle_scale=1.5, throttle_floor=0.25, max_throttle=cap)
        part.pilot.step = lambda image, speed=None: Controls(0.1, throttle=-0.2)
        assert part.run(frame, speed) == pytest.approx((0.1, expected))
    part = SteerlabPilot(ckpt, throttle_scale=1.5, throttle_floor=0.25, max_throttle=1.0)
    part.pilot.step = lambda image, speed=None: Controls(0.1, throttle=0.6)  # above the floor: as it is
    assert part.run(frame, 0.0) == pytest.approx((0.1, 0.9))
    # in the track world the part's floor as on the car: at the cap of 0.15 it gives 0.15; above it, refused
    world_part = donkey_pilot(ckpt, 0.3, max_throttle=0.15, throttle_floor=0.15)
    world_part.part.pilot.step = lambda image, speed=None: Controls(0.1, throttle=-0.2)
    assert world_part.step(frame, 0.0).throttle == pytest.approx(0.15)
    with pytest.raises(SteerlabError, match=r"^SteerlabPilot: throttle_floor must be at most max_throttle \(0.15\)"):
        donkey_pilot(ckpt, 0.3, max_throttle=0.15, throttle_floor=0.5)
    with pytest.raises(SteerlabError, match=r"^SteerlabPilot: the throttle floor needs the measured speed \(m/s\) "
                                            r"with every frame: add the car's odometry \(HAVE_ODOM = True\)"):
        part.run(frame)
    with pytest.raises(SteerlabError, match=r"^SteerlabPilot: throttle_floor must be a number in \[0, 1\], got 1.5$"):
        SteerlabPilot(ckpt, throttle_floor=1.5)
    steering = made(tmp_path, "normalized", "right", "donkey", name="steering.pt", full_lock_deg=25)
    with pytest.raises(SteerlabError, match=r"^SteerlabPilot: throttle_floor shapes a learned throttle; steering.pt "
                                            r"drives at a constant throttle"):
        SteerlabPilot(steering, throttle_floor=0.2)


def timed_laps(length: float, crossings: list[float], dirty: list[int]) -> dict:
    """`Laps.result()` of a car that passes the start line at `crossings` (s) and leaves the lane in the laps
    `dirty` (1-based): the progress of each lap added in one step that ends on the line."""
    laps = Laps(length)
    for k, t in enumerate(crossings, start=1):
        if k in dirty:
            laps.off_track()
        laps.advance(length, t)
    return laps.result()


def test_the_pace_of_a_track_and_of_the_suite_is_over_the_same_tracks():
    """Three tracks (expert laps 10, 8 and 9 s); X laps A in 12 s and C in 9.9 s but never B cleanly, Y laps A in
    11 s and B in 10 s but never C cleanly. The headline pace of each is over A alone, the one track both finished."""
    from steerlab.sim.track.run import TrackDrive
    from steerlab.sim.track.suite import drive_row, round_columns, summarize

    def drive(label, style, seed, crossings, dirty=()):
        r = timed_laps(40.0, crossings, list(dirty))
        return TrackDrive(label, seed, style, 0.9, 40.0, 1.0, float(len(crossings)), **r, off_track=len(dirty),
                          off_track_per_lap=len(dirty) / len(crossings), off_track_per_km=0.0, autonomy=100.0,
                          distance_km=0.04 * len(crossings), mean_speed=3.0, mean_abs_offset_m=0.1,
                          max_abs_offset_m=0.2, command_gamma_deg=float(seed))

    expert = {1: drive("expert", "taped", 1, [10, 20, 30]), 2: drive("expert", "taped", 2, [8, 16, 24]),
              3: drive("expert", "centre", 3, [9, 18, 27])}
    laps = {("X", 1): ([13, 24, 36, 48], [1]), ("X", 2): ([10, 21], [1, 2]), ("X", 3): ([9.9, 19.8], []),
            ("Y", 1): ([11, 22], []), ("Y", 2): ([10, 20, 30], [2]), ("Y", 3): ([9, 18], [1, 2])}
    style = {1: "taped", 2: "taped", 3: "centre"}
    rows = [drive_row(drive(label, style[seed], seed, *laps[label, seed]), expert[seed], label, f"{label}.pt",
                      style[seed], seed) for label in "XY" for seed in (1, 2, 3)]
    pace = {(r.label, r.seed): r.pace for r in rows}
    # X on A: clean laps 2-4 of 11, 12 and 12 s; on B none; on C 9.9 s twice. Y on B: laps 1 and 3, 10 s each.
    assert pace == pytest.approx({("X", 1): (35 / 3) / 10, ("X", 2): None, ("X", 3): 1.1, ("Y", 1): 1.1,
                                  ("Y", 2): 10 / 8, ("Y", 3): None})
    summary = {(s.label, s.style): s for s in summarize(rows)}
    x, y = summary["X", "all"], summary["Y", "all"]
    assert (x.laps, x.clean_laps, x.finished, x.tracks, x.off_track) == (8, 5, 2, 3, 3)
    assert (y.laps, y.clean_laps, y.finished, y.tracks, y.off_track) == (7, 4, 2, 3, 3)
    assert x.clean_pct == pytest.approx(62.5) and y.clean_pct == pytest.approx(400 / 7)
    assert (x.pace, x.pace_tracks, y.pace, y.pace_tracks) == (pytest.approx(35 / 30), 1, pytest.approx(1.1), 1)
    assert summary["X", "taped"].pace == pytest.approx(35 / 30) and summary["X", "centre"].pace is None
    assert summary["X", "centre"].finished == 1 and summary["Y", "centre"].finished == 0
    # a row carries its drive and the expert's laps: X on A laps in 13, 11, 12 and 12 s, the first not clean
    assert vars(rows[0]) == pytest.approx(
        {"label": "X", "checkpoint": "X.pt", "style": "taped", "seed": 1, "lap_m": 40.0, "minutes": 1.0,
         "laps_driven": 4.0, "laps": 4, "clean_laps": 3, "best_lap_s": 11.0, "mean_lap_s": 35 / 3,
         "expert_best_lap_s": 10.0, "expert_mean_lap_s": 10.0, "pace": 35 / 30, "off_track": 1,
         "off_track_per_lap": 0.25, "off_track_per_km": 0.0, "autonomy": 100.0, "distance_km": 0.16,
         "mean_speed": 3.0, "mean_abs_offset_m": 0.1, "command_gamma_deg": 1.0})
    # X drove 3 minutes and 0.32 km (8 laps of 40 m) with 3 events: autonomy 1 - 3 x 6 s / 180 s; gamma 1, 2, 3
    assert (x.minutes, x.distance_km, x.off_track_per_lap, x.off_track_per_km, x.autonomy, x.command_gamma_deg) == \
        pytest.approx((3.0, 0.32, 3 / 8, 3 / 0.32, 90.0, 2.0))
    assert (y.off_track_per_lap, y.off_track_per_km) == pytest.approx((3 / 7, 3 / 0.28))
    taped = summary["X", "taped"]
    assert (taped.minutes, taped.distance_km, taped.autonomy, taped.command_gamma_deg) == \
        pytest.approx((2.0, 0.24, (1 - 3 * 6 / 120) * 100, 1.5))
    x_only = [s for s in summarize(rows) if s.label == "X"]
    assert round_columns(x_only) == pytest.approx({"clean_laps_pct": 62.5, "lap_ratio": 35 / 30,
                                                   "off_track_per_lap": 0.375})
    # a label that completes no lap: half a lap driven (0.16 km) with one event; its DAgger columns are empty
    (z,) = [s for s in summarize([replace(rows[0], label="Z", laps=0, clean_laps=0, laps_driven=0.5, pace=None)])
            if s.style == "all"]
    assert (z.clean_pct, z.pace, z.off_track_per_lap, z.off_track_per_km) == (None, None, 2.0, pytest.approx(6.25))
    assert round_columns([z]) == {"clean_laps_pct": "", "lap_ratio": "", "off_track_per_lap": 2.0}


def test_the_experts_reference_laps_are_driven_under_the_models_cap(tmp_path):
    from steerlab.sim.track.run import drive_expert
    from steerlab.sim.track.suite import TrackSuiteOptions

    laps = {}
    for cap in (0.5, 1.0):
        o = TrackSuiteOptions(minutes=0.5, max_throttle=cap)
        r = drive_expert(tmp_path / f"cap{cap}", o.drive_options("taped", 9406))
        laps[cap] = r
        assert r.off_track == 0 and r.clean_laps == r.laps >= 2
        rows = (tmp_path / f"cap{cap}" / "trajectory.csv").read_text().split()[1:]
        speeds = [float(row.split(",")[6]) for row in rows]
        assert max(speeds) <= steady_speed(cap, 1 / 20, CARS["donkey"]) + 1e-3  # never faster than the cap holds
    assert laps[0.5].mean_lap_s > 1.1 * laps[1.0].mean_lap_s
