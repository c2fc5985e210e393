"""Which way a recording's frames turn when its steering turns (data/sense.py), and the mirrored lens."""

import shutil
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from steerlab.data.fisheye import FisheyeCamera, shift_view
from steerlab.data.sense import band_shifts, check_sense, frame_turn
from steerlab.data.tub import read_tub
from steerlab.errors import DataError


def test_band_shifts_hand_computed():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(2, 160))
    b = np.stack([np.roll(a[0], 3), np.roll(a[1], -5)])  # the second row's content 3 px right, the other's 5 px left
    assert np.allclose(band_shifts(a, b), [3.0, -5.0], atol=0.01)
    smooth = np.convolve(rng.normal(size=200), np.ones(9) / 9, "same")[20:180][None]
    half = 0.5 * (smooth + np.roll(smooth, 1, axis=1))  # half a pixel to the right, by linear interpolation
    assert abs(band_shifts(smooth, half)[0] - 0.5) < 0.15


def mirrored_copy(tub, folder):
    """The tub with every frame flipped left-right: a camera flipped in its config."""
    shutil.copytree(tub, folder)
    for f in (folder / "images").glob("*.jpg"):
        Image.open(f).transpose(Image.FLIP_LEFT_RIGHT).save(f, quality=95)
    return folder


def test_frames_turn_with_the_steering_and_a_mirrored_tub_is_refused(track_tub, tmp_path):
    rec = read_tub(track_tub, full_lock_deg=25)
    r, pairs = frame_turn(rec)
    assert r > 0.9 and pairs >= 40  # the track world's expert turns, its frames with it
    check_sense(rec, False, "its views")
    with pytest.raises(DataError, match=r"mirrored is true, but its frames turn with its steering .*leave mirrored"):
        check_sense(rec, True, "its views")
    flipped = read_tub(mirrored_copy(track_tub, tmp_path / "flipped"), full_lock_deg=25)
    r, _ = frame_turn(flipped)
    assert r < -0.9
    with pytest.raises(DataError, match=r"its frames turn against its steering: .*its replay would be of the mirror "
                                        r"image .*give reader option mirrored=true"):
        check_sense(flipped, False, "its replay")
    check_sense(flipped, True, "its replay")
    steady = read_tub(track_tub, full_lock_deg=25)
    steady.steering[:] = 0.1  # a steering that never varies: the frames cannot tell
    assert np.isnan(frame_turn(steady)[0])


def test_the_reader_option_mirrored_reaches_views_and_replay(track_tub, tmp_path):
    from steerlab.sim.track.replay import TrackReplayOptions
    from steerlab.train.config import load_config
    from steerlab.train.sources import check_views

    flipped = mirrored_copy(track_tub, tmp_path / "flipped")
    cfg = load_config(None, base={"data": str(flipped), "reader": {"full_lock_deg": 25}, "out": str(tmp_path / "r"),
                                  "train": {"views": [[[-0.1, 0.1], [-10, 10]]]}})
    with pytest.raises(DataError, match="mirrored=true"):
        check_views(cfg, read_tub(flipped, full_lock_deg=25))
    with pytest.raises(DataError, match="mirrored=true"):
        TrackReplayOptions().setup(read_tub(flipped, full_lock_deg=25))
    rec = read_tub(flipped, full_lock_deg=25, mirrored=True)
    assert rec.fisheye.mirrored
    check_views(cfg, rec)
    assert TrackReplayOptions().setup(rec).replay.fisheye.mirrored


def test_a_mirrored_lens_warps_as_the_mirror_image_of_the_world():
    """A lens symmetric about its centre column: the mirrored camera's view moved left and turned left is the plain
    camera's view moved right and turned right (the mirror image of the world), pixel for pixel."""
    lens = FisheyeCamera(cx=79.5)
    rng = np.random.default_rng(1)
    frame = np.repeat(np.repeat(rng.integers(0, 255, (30, 40, 3), dtype=np.uint8), 4, 0), 4, 1)
    mirrored = shift_view(frame, FisheyeCamera(cx=79.5, mirrored=True), 0.1, 8.0).astype(int)
    assert np.abs(mirrored - shift_view(frame, lens, -0.1, -8.0).astype(int)).max() <= 1
    assert np.abs(mirrored - shift_view(frame, lens, 0.1, 8.0).astype(int)).mean() > 10


@pytest.mark.skipif(not (Path(__file__).parents[2].parent / "shared" / "data" / "donkeycar" / "hall").is_dir(),
                    reason="../shared/data not here")
def test_the_shared_tubs_frames_turn_with_their_steering_but_taped_tracks():
    """As docs/results/donkeycar.md measures them (hall +0.92, taped-track -0.87, wood-tape +0.94), and as the
    studies read them (`studies.common.donkeycar.reader`)."""
    from studies.common.donkeycar import TUB_NAMES, TUBS, reader

    for name in TUB_NAMES:
        r, pairs = frame_turn(read_tub(TUBS / name, full_lock_deg=25, skip_missing=True))
        assert (r < -0.8 if name == "taped-track" else r > 0.85) and pairs > 850, (name, r, pairs)
        assert reader(name).get("mirrored", False) == (name == "taped-track")
