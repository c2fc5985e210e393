"""Virtual views (`train.views`, data/views.py): a view is fixed or drawn for every frame; a donkey-camera
recording's views are warped through its fisheye and labelled with the steering replay gives a car there
(data/path.py), both checked against the truth the track world has: the frame its renderer draws at the moved
camera and the expert's steering there."""

from dataclasses import replace

import numpy as np
import pytest

from steerlab.data import fisheye
from steerlab.data.car import CARS, throttle_speeds
from steerlab.data.dataset import compile_recording
from steerlab.data.path import human_path, view_steering
from steerlab.data.preprocess import preprocess
from steerlab.data.readers import open_recording
from steerlab.data.views import View, lens_of
from steerlab.errors import SteerlabError
from steerlab.train.config import load_config
from steerlab.train.sources import prepare_dataset, view_labels
from studies import view_truth

CAR = CARS["donkey"]


def test_a_view_is_a_number_or_a_range_for_each_of_shift_and_turn():
    fixed = View.parse_option([0.1, -5], "v")
    assert (fixed.shift_m, fixed.yaw_deg) == ((0.1, 0.1), (-5.0, -5.0)) and fixed.as_dict() == [0.1, -5.0]
    drawn = View.parse_option([[-0.2, 0.2], 3], "v")
    assert drawn.as_dict() == [[-0.2, 0.2], 3.0] and View.parse_option(drawn.as_dict(), "v") == drawn
    shift, yaw = fixed.offsets(50)
    assert np.all(shift == 0.1) and np.all(yaw == -5.0)  # a fixed view is exactly its value on every frame
    s0, _ = drawn.offsets(2000)
    s1, _ = View(drawn.shift_m, drawn.yaw_deg, draw=1).offsets(2000)
    assert np.array_equal(s0, drawn.offsets(2000)[0]) and not np.array_equal(s0, s1)  # the same draw, another view
    assert -0.2 <= s0.min() < -0.19 and 0.19 < s0.max() <= 0.2 and abs(s0.mean()) < 0.01  # uniform over the range
    assert np.histogram(s0, 4, (-0.2, 0.2))[0].min() > 450
    assert "#1" in View(drawn.shift_m, drawn.yaw_deg, draw=1).name and fixed.name == "+0.1m-5deg"


@pytest.mark.parametrize("bad, says", [([0.5], "must be a \\[shift_m, yaw_deg\\] pair"),
                                       ([0.1, 2, 3], "pair"), ("0.1", "pair"),
                                       ([[0.2, -0.2], 0], "lo <= hi"),
                                       ([0, [1, 2, 3]], "yaw_deg must be a number or a range \\[lo, hi\\] of two "
                                                        "numbers, got \\[1, 2, 3\\]"),
                                       (["left", 0], "a number or a range"), ([0, 95], "within \\+-45 degrees"),
                                       ([5, 0], "shift_m .* within \\+-2 m"), ([[-3, 0], 0], "within \\+-2 m"),
                                       (["0.5", "10"], "a number or a range"),  # a number as text, as options
                                       ([0, 0], "a view of \\[0, 0\\] .* is the frame itself"),
                                       ([[0, 0], [0.0, 0]], "is the frame itself")])
def test_a_view_that_is_not_a_pair_of_numbers_or_ranges_is_refused(bad, says):
    with pytest.raises(SteerlabError, match=says):
        View.parse_option(bad, "train.views[0]")


@pytest.mark.parametrize("shift, yaw", [((0.2, 0.1), (0, 0)), (0.1, (0, 0)), ((0, 0), (50, 50)), (("a", 1), (0, 0))])
def test_a_view_made_in_python_is_checked_as_one_from_a_config(shift, yaw):
    with pytest.raises(SteerlabError, match="a view's (shift_m|yaw_deg) must be a range"):
        View(shift, yaw)


@pytest.mark.parametrize("call, says", [(lambda: View((0.1, 0.1), (0, 0), draw="1"), "a view's draw must be an"),
                                        (lambda: View((0.1, 0.1), (0, 0), draw=-1), "a view's draw must be an"),
                                        (lambda: View((0.1, 0.2), (0, 0)).offsets(-1), r"View.offsets\(n\) must be"),
                                        (lambda: View((0.1, 0.2), (0, 0)).offsets(2.5), r"View.offsets\(n\) must be")])
def test_a_views_draw_and_count_are_whole_numbers_of_at_least_0(call, says):
    with pytest.raises(SteerlabError, match=says):
        call()


@pytest.fixture(scope="module")
def drive():
    """The racing expert's drive of 20 s on track 21 (a matte floor; no drift), noise-free frames
    (`studies.view_truth.drive`)."""
    world, rows = view_truth.drive(21)
    assert world.renderer.room.gloss == 0  # a floor that mirrors nothing: what the floor shows does not move
    return world, rows


@pytest.mark.parametrize("shift, yaw", [(0.12, 0.0), (-0.12, 0.0), (0.0, 12.0), (-0.1, -10.0)])
def test_a_fisheye_view_is_the_frame_the_renderer_draws_at_the_moved_camera_on_the_floor(drive, shift, yaw):
    """On a matte floor the warped frame is within half the unwarped frame's difference from the frame drawn there
    (what is left: the lens's vignette, which stays where it is, and the texture's filtering; a glossy floor's
    mirror and glare move with the camera and leave more: docs/results/views.md has the numbers). Above the
    horizon a turn is exact for everything however near and a shift moves nothing (the walls are taken to be far
    away): not better than unwarped."""
    world, rows = drive
    for k in (20, 150, 260):
        state, s = rows[k][0], rows[k][1]
        floor, floor0, sky, sky0 = view_truth.floor_errors(world, state, s, shift, yaw)
        assert floor < 0.5 * floor0, (k, floor, floor0)
        if shift == 0:
            assert sky < 0.3 * sky0, (k, sky, sky0)
        elif yaw == 0:
            assert abs(sky - sky0) < 0.5  # a shift leaves the walls where they were: said, not warped
        else:
            assert sky < 0.5 * sky0  # the turn is warped


def test_a_small_cars_view_label_is_the_track_experts_steering_at_the_moved_camera(drive):
    """The label of a view (replay's return to the path rebuilt from the recorded steering and throttle, as
    training rebuilds it from a tub) against the expert's steering (`expert_controls`) with the car moved so
    (`studies.view_truth.label_agreement`): the labels' corrections follow the expert's when the return point lies
    as far ahead as the expert's own (0.3 s), and are gentler for replay's 0.9 s."""
    world, rows = drive
    agree = view_truth.label_agreement(world, rows, 0, (0.3, 0.9))
    near, far = agree[0.3], agree[0.9]
    assert near["r"] > 0.9 and 0.5 < near["slope"] < 1.2 and near["mae_rad"] < 0.4 * near["spread_rad"]
    assert 0.1 < far["slope"] < 0.6 * near["slope"]
    wheel = np.array([r[2] for r in rows])
    t = np.arange(len(rows)) / world.fps
    path = human_path(wheel, throttle_speeds(np.array([r[3] for r in rows]), t, CAR), t, CAR)
    on_path = view_steering(path, np.zeros(len(rows)), np.zeros(len(rows)), CAR, 0.3)
    assert np.allclose(on_path, wheel, atol=1e-12)  # on the path: the recorded steering itself


def test_training_warps_a_donkey_recordings_views_through_its_fisheye_and_labels_them_by_replays_return(
        track_tub, tmp_path):
    cfg = load_config(None, [f"data={track_tub}", "model.name=donkey-linear", f"cache={tmp_path / 'cache'}",
                             "reader.full_lock_deg=25",
                             "train.views=[[0.1, 0], [[-0.1, 0.1], [-10, 10]]]", "train.recovery_s=0.3"])
    rec = open_recording(str(track_tub), options={'full_lock_deg': 25})
    assert lens_of(rec) == rec.fisheye and rec.fisheye is not None  # the lens the track world wrote into the tub
    view = cfg.train.views[0]
    warped = prepare_dataset(cfg, progress=False, view=view)
    pre = cfg.preprocessing(rec.geometry)
    for i in (0, 40):
        expected, _ = preprocess(fisheye.shift_view(rec.load_frame(i), rec.fisheye, 0.1, 0.0), pre)
        assert np.array_equal(warped.arrays["image"][i], expected)
    centre = compile_recording(rec, pre, tmp_path / "cache", progress=False)
    steering = centre.steering
    left = view_labels(warped, steering, view, cfg.train)
    # 0.1 m to the left of the path: steer right, which a tub records as positive (normalized, positive right)
    assert rec.convention.positive == "right" and np.all(left > steering)
    drawn = replace(cfg.train.views[1], draw=1)  # the second view of the list, as training draws it
    shift, yaw = drawn.offsets(len(rec))
    assert np.ptp(shift) > 0.1 and np.ptp(yaw) > 10  # drawn for every frame
    labels = view_labels(prepare_dataset(cfg, progress=False, view=drawn), steering, drawn, cfg.train)
    assert np.all(np.abs(labels) <= 1.0)  # within the full lock


@pytest.mark.parametrize("override, says", [
    ("train.views=[[0.1, [2, 1]]]", r"train.views\[0\].yaw_deg must be a range \[lo, hi\] with lo <= hi"),
    ("train.views=[[x, 0]]", r"train.views\[0\].shift_m must be a number or a range"),
    ("train.views=[0.1]", r"train.views\[0\] must be a \[shift_m, yaw_deg\] pair"),
    ("train.calibration=calib.yaml", "train.calibration is the lens that train.views are warped through")])
def test_a_config_with_views_that_cannot_be_drawn_or_a_lens_without_views_is_refused_in_one_line(override, says):
    with pytest.raises(SteerlabError, match=says) as e:
        load_config(None, ["data=x", override])
    assert "\n" not in str(e.value)


def test_a_calibration_for_a_pinhole_cameras_recording_is_refused_before_any_frame_is_warped(tmp_path):
    from tests.inputs import sim_log

    log = sim_log(tmp_path / "sim")
    calib = tmp_path / "calib.yaml"
    calib.write_text("image_size: [160, 120]\nK: [[80, 0, 79], [0, 80, 59], [0, 0, 1]]\nD: [0, 0, 0, 0]\n")
    cfg = load_config(None, [f"data={log}", "train.views=[[0.1, 0]]", f"train.calibration={calib}",
                             f"cache={tmp_path / 'cache'}"])
    with pytest.raises(SteerlabError, match="a fisheye calibration is for recordings of the 'donkey' camera"):
        prepare_dataset(cfg, progress=False, view=cfg.train.views[0])


@pytest.mark.parametrize("lock", [25, 40])
def test_a_small_cars_view_label_corrects_the_target_by_the_recorded_path_within_the_readers_full_lock(
        track_tub, tmp_path, lock):
    """The path is rebuilt from the recorded steering whatever the target is (a target shifted ahead, a teacher's):
    a view from the recorded camera itself keeps every target exactly, and the car's full lock is the reader's
    (a lock of 40 degrees does not cap the labels at 25 / 40 of the servo's range)."""
    cfg = load_config(None, [f"data={track_tub}", "model.name=donkey-linear", f"cache={tmp_path / 'cache'}",
                             f"reader.full_lock_deg={lock}"])
    view = View((0.0, 0.0), (0.0, 0.0))  # the frame itself (a config refuses it: it adds nothing to train on)
    warped = prepare_dataset(cfg, progress=False, view=view)
    target = np.clip(warped.steering[::-1] * 3, -1, 1)  # another target than the recorded steering, at full lock
    assert np.abs(target).max() == 1.0
    assert np.allclose(view_labels(warped, target, view, cfg.train), target, atol=1e-6)
    assert np.array_equal(warped.labels["view_shift_m"], np.zeros(len(warped)))  # the draws the frames were made at
