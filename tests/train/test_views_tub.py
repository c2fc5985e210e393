"""train/views_tub.py and `steerlab views`: the views a config trains on, written as a tub for donkeycar's trainer."""

import numpy as np

from steerlab.cli import main
from steerlab.data.readers import open_recording
from steerlab.data.recording import SteeringConvention
from steerlab.data.views import lens_of, warp
from steerlab.train.config import load_config
from steerlab.train.sources import main_recording, prepare_dataset, view_labels
from steerlab.train.views_tub import write_views_tub

LOCK = {"full_lock_deg": 25}


def test_the_views_written_as_a_tub_are_the_frames_and_labels_steerlab_trains_on(track_tub, tmp_path):
    """donkeycar's trainer gets the same extra frames: each kept record warped to the view steerlab draws for it,
    labelled as steerlab labels it (`view_labels`), its throttle kept; the records outside `keep` left out."""
    cfg = load_config(None, base={"data": str(track_tub), "reader": LOCK, "cache": str(tmp_path / "cache"),
                                  "out": str(tmp_path),
                                  "train": {"views": [[[0.05, 0.15], [-10, 10]]], "recovery_s": 0.3}})
    rec = main_recording(cfg)
    keep = {int(i) for i in rec.frame_ids[10:30]}
    tub = open_recording(write_views_tub(cfg, tmp_path / "views", keep, progress=False))
    view = cfg.train.views[0]
    warped = prepare_dataset(cfg, progress=False, view=view)
    ds = prepare_dataset(cfg, progress=False)
    labels = view_labels(warped, ds.steering, view, cfg.train, SteeringConvention(**ds.meta["convention"]))
    assert len(tub) == 20 and np.ptp(labels[10:30]) > 0.05
    np.testing.assert_allclose(tub.steering, labels[10:30], atol=1e-6)
    np.testing.assert_allclose(tub.throttle, rec.throttle[10:30], atol=1e-6)
    shift, yaw = warped.labels["view_shift_m"], warped.labels["view_yaw_deg"]
    for k in (0, 19):
        want = warp(rec.load_frame(10 + k), rec.geometry, lens_of(rec), float(shift[10 + k]), float(yaw[10 + k]))
        other = warp(rec.load_frame(10 + k), rec.geometry, lens_of(rec), float(-shift[10 + k]), 0.0)
        got = tub.load_frame(k).astype(float)
        assert np.abs(got - want).mean() < 3 < np.abs(got - other).mean()  # its own draw, through the JPEG


def test_steerlab_views_writes_each_view_of_the_configs_records_a_session_each(track_tub, tmp_path, capsys):
    """The command on a config of the tub defaults (no model named, the full lock given): one view of every record
    of its range; two views of the same ranges: each a session of its own, in the list's order, the second its own
    draw."""
    cfg = tmp_path / "c.yaml"
    cfg.write_text(f"data: {track_tub}\nreader: {{full_lock_deg: 25}}\ncache: {tmp_path / 'cache'}\nrange: '0:12'\n")
    assert main(["views", str(cfg), "--out", str(tmp_path / "one")]) == 0
    assert f"wrote {tmp_path / 'one'}: 1 view(s) of records 0:12 of {track_tub}" in capsys.readouterr().out
    one = open_recording(str(tmp_path / "one"))
    assert len(one) == 12 and len(one.segments()) == 1
    views = "train.views=[[[-0.15, 0.15], [-15, 15]], [[-0.15, 0.15], [-15, 15]]]"
    assert main(["views", str(cfg), views, "train.recovery_s=0.3", "--out", str(tmp_path / "two")]) == 0
    two = open_recording(str(tmp_path / "two"))
    assert len(two) == 24 and [b - a for a, b in two.segments()] == [12, 12]
    assert len(set(two.extra["session"][:12])) == len(set(two.extra["session"][12:])) == 1
    assert two.extra["session"][0] != two.extra["session"][12]
    first = np.stack([two.load_frame(i).astype(float) for i in range(12)])
    np.testing.assert_allclose(first, np.stack([one.load_frame(i) for i in range(12)]), atol=0)  # the same draw
    np.testing.assert_allclose(two.steering[:12], one.steering, atol=1e-6)
    assert np.abs(two.load_frame(12).astype(float) - one.load_frame(0)).mean() > 3  # the second: a draw of its own
