import hashlib
from dataclasses import replace

import numpy as np
import pytest

from steerlab.cli import main
from steerlab.data.car import CH2_CAR, Vehicle, VehicleState
from steerlab.data.labels import speed_commands
from steerlab.data.readers import open_recording
from steerlab.errors import SteerlabError
from steerlab.sim.road.render import Renderer
from steerlab.sim.road.road import EDGE, LANE_CENTER, LINE_WIDTH, Road
from steerlab.sim.core.driving import autonomy
from steerlab.sim.road.run import record
from steerlab.sim.road.world import RecordOptions


def _digest(folder):
    h = hashlib.sha256()
    for p in sorted(folder.rglob("*")):
        if p.is_file():
            h.update(p.relative_to(folder).as_posix().encode())
            h.update(p.read_bytes())
    return h.hexdigest()


def test_same_seed_same_bytes(tmp_path):
    a = record(tmp_path / "a", RecordOptions(seed=7, minutes=0.025), progress=False)
    b = record(tmp_path / "b", RecordOptions(seed=7, minutes=0.025), progress=False)
    c = record(tmp_path / "c", RecordOptions(seed=8, minutes=0.025), progress=False)
    assert _digest(a) == _digest(b) != _digest(c)


def test_roads_from_seeds_and_types():
    assert np.array_equal(Road(1).kappa, Road(1).kappa)
    assert not np.array_equal(Road(1).kappa[:2000], Road(2).kappa[:2000])
    radius = {p: 1 / np.abs(Road(5, p, 8000).kappa).max() for p in ("highway", "country", "twisty")}
    assert radius["highway"] > radius["country"] > radius["twisty"] >= 35
    with pytest.raises(SteerlabError, match="unknown road type"):
        Road(1, "autobahn")


def _marking_columns(img, row):
    """Centres of the runs of bright marking pixels in one image row."""
    bright = img[row].astype(int).sum(1) > 3 * 200
    cols = np.flatnonzero(bright)
    runs = np.split(cols, np.flatnonzero(np.diff(cols) > 1) + 1)
    return [r.mean() for r in runs if len(r)]


def test_camera_geometry_vanishing_point_and_shift():
    road = Road(1)  # every road starts with 60 m of straight
    r = Renderer(road, "ch2")
    x, y, psi = road.pose(2.0, LANE_CENTER)
    img = r.render(x, y, psi, 2.0)
    rows = (420, 460)
    right = [_marking_columns(img, v)[-1] for v in rows]
    # right edge line at 1.8 m right of the camera: column = cx + f * 1.8 / depth(row)
    for v, col in zip(rows, right):
        k = v - r.first_row
        assert col == pytest.approx(r.cam.width / 2 + r.cam.focal * (EDGE - LINE_WIDTH / 2 + LANE_CENTER) / r.ray[k] - 0.5, abs=2.0)
    # extend the line through the two rows up to the horizon: it meets the image centre there
    slope = (right[1] - right[0]) / (rows[1] - rows[0])
    assert right[0] + slope * (r.horizon - rows[0]) == pytest.approx(r.cam.width / 2, abs=3.0)
    # moving the camera 0.5 m left moves the right edge line to the right, by f * 0.5 / depth
    shifted = r.render(x, y, psi, 2.0, shift=0.5)
    v = 380
    moved = _marking_columns(shifted, v)[-1] - _marking_columns(img, v)[-1]
    assert moved == pytest.approx(r.cam.focal * 0.5 / r.ray[v - r.first_row], abs=1.5)


def test_vehicle_follows_hand_computed_arc():
    delta, v, wb = 0.1, 10.0, 2.85
    car = Vehicle(VehicleState(0.0, 0.0, 0.0, v), replace(CH2_CAR, drag=0.0))
    for _ in range(200):
        car.step(delta, 0.0, 0.0, 0.01)
    radius = wb / np.tan(delta)
    phi = v * 2.0 / radius
    s = car.state
    assert s.x == pytest.approx(radius * np.sin(phi), abs=1e-3)
    assert s.y == pytest.approx(radius * (1 - np.cos(phi)), abs=1e-3)
    assert s.psi == pytest.approx(phi, abs=1e-6)


@pytest.fixture
def blank_frames(monkeypatch):
    """Recordings whose frames are blank: for tests of the expert's driving, which the frames do not change."""
    from steerlab.sim.road.world import World

    monkeypatch.setattr(World, "render", lambda self, shift=0.0: np.zeros((160, 320, 3), np.uint8))


@pytest.mark.parametrize("seed", [11, 12, 13])
def test_expert_alone_never_needs_intervention(tmp_path, seed, blank_frames):
    out = record(tmp_path / "r", RecordOptions(seed=seed, minutes=0.75, side_cameras=False), progress=False)
    rec = open_recording(out)
    off = rec.extra["lateral_offset"]
    assert np.abs(off).max() < 1.0
    assert autonomy(int((np.abs(off) > 1.0).sum()), len(rec) / 20) == 100.0
    assert {"normal", "drift-out", "recover"} <= set(rec.extra["episode"])


def test_speed_commands_have_all_classes(tmp_path, blank_frames):
    rec = open_recording(record(tmp_path / "r", RecordOptions(seed=2, minutes=1.0, side_cameras=False), progress=False))
    assert set(speed_commands(rec.speed, rec.timestamps_ns).tolist()) == {0, 1, 2}


def test_udacity_sim_layout_round_trip(tmp_path):
    out = record(tmp_path / "u", RecordOptions(seed=4, minutes=0.025, layout="udacity-sim"), progress=False)
    native = record(tmp_path / "n", RecordOptions(seed=4, minutes=0.025), progress=False)
    a, b = open_recording(out / "driving_log.csv"), open_recording(native)
    assert a.cameras == ["center", "left", "right"] and len(a) == len(b)
    road_a = a.convention.to_road_wheel_left(a.steering, 14.8)
    road_b = b.convention.to_road_wheel_left(b.steering, 14.8)
    np.testing.assert_allclose(road_a, road_b, atol=1e-5)
    np.testing.assert_allclose(a.speed, b.speed, atol=1e-5)


def test_bad_inputs_give_clear_errors(tmp_path, capsys):
    assert main(["sim", "record", "--out", str(tmp_path / "x"), "--road", "moon"]) == 2
    assert "--road must be highway, country, twisty, mixed (all three) or a comma list of them" in capsys.readouterr().err
    assert main(["sim", "record", "--out", str(tmp_path / "y"), "--minutes", "-1"]) == 2
    assert "--minutes must be a number in (0, 1440] min" in capsys.readouterr().err
    assert main(["sim", "record", "--out", str(tmp_path / "z"), "--geometry", "fisheye", "--minutes", "0.01"]) == 2
    assert "argument --geometry: invalid choice: 'fisheye'" in capsys.readouterr().err
    assert main(["sim", "drive", str(tmp_path / "missing.pt")]) == 2
    assert "checkpoint not found" in capsys.readouterr().err


def test_tiny_demo_end_to_end(tmp_path, capsys):
    out = tmp_path / "demo"
    # 81 frames at 5 fps: the held-out fifth (frames 64:81) lasts the 3 s that the closed-loop replay needs
    assert main(["demo", "--out", str(out), "--minutes", "0.27", "--fps", "5", "--epochs", "1",
                 "--suite-minutes", "0.01", "--dagger-minutes", "0.02", "--workers", "1"]) == 0
    printed = capsys.readouterr().out
    assert "| pilotnet | twisty | 3 |" in printed and "report:" in printed  # the suite's table, at the end
    text = (out / "report.md").read_text()
    assert "Open loop" in text and "| pilotnet | all | 11 |" in text
    assert "| 0 | 1 | - |" in text and "| 1 | 2 | " in text  # the DAgger round added the rollout
    assert len(list((out / "pilotnet" / "round1" / "rollouts").iterdir())) == 1
    assert not list((out / "pilotnet").glob("round*/suite"))  # dagger suite: null, the demo drives the suite once
    assert "## Closed-loop replay (the held-out frames)" in text and "| pilotnet | recording |" in text
    assert len(list((out / "closed-loop" / "roads").glob("*.png"))) == 11


def test_mixed_recording_interleaves_one_road_per_type(tmp_path):
    out = record(tmp_path / "m", RecordOptions(seed=3, minutes=0.06, road="country,twisty,twisty", chunk_minutes=0.01,
                                               side_cameras=False), progress=False)
    rec = open_recording(out)
    assert rec.segments() == [(k, k + 12) for k in range(0, 72, 12)]  # chunks of 12 frames, each a segment
    speed = [rec.speed[a:b] for a, b in rec.segments()]  # country starts at 19 m/s, twisty at 13 m/s
    assert speed[0].mean() > 16 > speed[1].mean() and speed[2].mean() < 16 and speed[3].mean() > 16
    assert abs(speed[2][0] - speed[1][-1]) < 0.1  # the second twisty chunk continues the first one's drive
    with pytest.raises(SteerlabError, match="RecordOptions.road must be highway, country, twisty, mixed"):
        record(tmp_path / "x", RecordOptions(road="country,mountain", minutes=0.01), progress=False)


@pytest.mark.figures
def test_a_drive_plot_draws_the_intervention_limit_it_drove_with(tmp_path, monkeypatch):
    """`sim drive --limit-m 0.4`'s path.png marks +-0.4 m on the offset axis, not the default 1 m."""
    import matplotlib.axes

    from steerlab.sim.core.driving import Trajectory
    from steerlab.sim.road.plots import plot_trajectory
    from steerlab.sim.road.world import make_road

    drawn = []
    monkeypatch.setattr(matplotlib.axes.Axes, "axhline", lambda ax, y=0, **kw: drawn.append(y))
    t = Trajectory(*(np.linspace(0.0, 1.0, 5) for _ in range(9)))
    plot_trajectory(tmp_path / "path.png", make_road(1, "highway", 10), {"model": t}, "title", limit_m=0.4)
    assert drawn == [-0.4, 0.4]
    assert (tmp_path / "path.png").stat().st_size > 0
