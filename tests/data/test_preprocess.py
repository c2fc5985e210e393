import numpy as np
import pytest

from steerlab.data.dataset import compile_recording
from steerlab.data.modalities import frame_difference, optical_flow
from steerlab.data.preprocess import PreprocessConfig, crop_resize, preprocess
from steerlab.data.readers import open_recording
from steerlab.data.recording import SteeringConvention
from steerlab.errors import SteerlabError
from steerlab.data.inputs import channel_stats, stack_modalities


def test_ch2_crop_and_area_resize_hand_computed():
    img = np.full((480, 640, 3), 255, np.uint8)  # the top 268 rows are sky and must vanish
    img[268:, :320] = 0
    img[268:, 320:] = 200
    out = crop_resize(img, PreprocessConfig.from_dict({"preset": "ch2"}))
    assert out.shape == (66, 200, 3)
    # 640 -> 200 columns: output column 99 covers source 316.8..320, column 100 covers 320..323.2
    assert (out[:, :100] == 0).all() and (out[:, 100:] == 200).all()


def test_colour_spaces():
    red = np.zeros((80, 320, 3), np.uint8)
    red[..., 2] = 255
    cfg = dict(preset="sim")
    img, gray = preprocess(np.pad(red, ((60, 20), (0, 0), (0, 0))), PreprocessConfig.from_dict({**cfg, "color": "gray"}))
    assert img.shape == (66, 200, 1) and int(img[0, 0, 0]) == 76  # 0.299 * 255
    img, _ = preprocess(np.pad(red, ((60, 20), (0, 0), (0, 0))), PreprocessConfig.from_dict({**cfg, "color": "rgb"}))
    assert tuple(img[0, 0]) == (255, 0, 0)
    img, _ = preprocess(np.pad(red, ((60, 20), (0, 0), (0, 0))), PreprocessConfig.from_dict({**cfg, "color": "hsv"}))
    assert tuple(img[0, 0]) == (0, 255, 255)


def test_bad_configs():
    with pytest.raises(SteerlabError, match="unknown colour"):
        PreprocessConfig(color="lab")
    with pytest.raises(SteerlabError, match="preset"):
        PreprocessConfig.from_dict({"preset": "mars"})
    with pytest.raises(SteerlabError, match="removes the whole"):
        crop_resize(np.zeros((100, 100, 3), np.uint8), PreprocessConfig())


def test_frame_difference_hand_computed():
    prev = np.array([[0, 255, 0, 100]], np.uint8)
    cur = np.array([[10, 0, 255, 100]], np.uint8)
    assert frame_difference(prev, cur).tolist() == [[133, 0, 255, 128]]


def test_optical_flow_first_frame_and_shift():
    rng = np.random.default_rng(0)
    base = (rng.random((66, 220)) * 255).astype(np.uint8)
    import cv2
    base = cv2.GaussianBlur(base, (0, 0), 2.0)
    prev, cur = base[:, 10:210].copy(), base[:, 8:208].copy()  # content moves 2 px right
    assert not optical_flow(cur, cur).any()
    for method in ("farneback", "dis"):
        flow = optical_flow(prev, cur, method)
        assert flow.shape == (66, 200, 2)
        inner = flow[15:-15, 20:-20]
        assert np.median(inner[..., 0]) == pytest.approx(2.0, abs=0.3)
        assert np.median(inner[..., 1]) == pytest.approx(0.0, abs=0.3)


def test_compile_segments_modalities_and_reuse(ch2_folder, tmp_path):
    # two segments: a 2 s gap after frame 3
    lines = (ch2_folder / "labels.csv").read_text().splitlines()
    rec = open_recording(ch2_folder, labels=ch2_folder / "labels.csv")
    ts = rec.timestamps_ns.copy()
    ts[3:] += 2_000_000_000
    rec.timestamps_ns = ts
    assert rec.segments() == [(0, 3), (3, 6)]
    cfg = PreprocessConfig(modalities=("image", "diff", "flow"))
    ds = compile_recording(rec, cfg, tmp_path / "cache", progress=False)
    assert ds.arrays["image"].shape == (6, 66, 200, 1) and ds.arrays["flow"].dtype == np.float16
    for first in (0, 3):  # segment starts: no motion seen yet
        assert (ds.arrays["diff"][first] == 128).all()
        assert not ds.arrays["flow"][first].any()
    # inside a segment the difference is that of the preprocessed frames
    img = ds.arrays["image"]
    assert (ds.arrays["diff"][1] == frame_difference(img[0], img[1])).all()
    stamp = (ds.path / "image.npy").stat().st_mtime_ns
    again = compile_recording(rec, cfg, tmp_path / "cache", progress=False)
    assert again.path == ds.path and (ds.path / "image.npy").stat().st_mtime_ns == stamp
    assert len(lines) == 7
    # the same frames and labels read in another steering convention (a tub with and without full_lock_deg)
    rec.convention = SteeringConvention("normalized", "right", 0.5)
    other = compile_recording(rec, cfg, tmp_path / "cache", progress=False)
    assert other.path != ds.path and other.meta["convention"] == rec.convention.as_dict() != ds.meta["convention"]


def test_channel_stats_use_given_frames_only(ch2_folder, tmp_path):
    rec = open_recording(ch2_folder, labels=ch2_folder / "labels.csv")
    cfg = PreprocessConfig()
    ds = compile_recording(rec, cfg, tmp_path / "cache", progress=False)
    stats = channel_stats(ds.arrays, cfg, np.arange(0, 3), np.zeros(6, int))
    x = stack_modalities({"image": ds.arrays["image"][:3]}, cfg)
    assert stats["mean"][0] == pytest.approx(float(x.mean()), rel=1e-6)
    assert stats["std"][0] == pytest.approx(float(x.std()), rel=1e-4)


def test_stacked_frames_never_cross_a_segment_start():
    from steerlab.data.inputs import gather, segment_starts

    cfg = PreprocessConfig(stack=3)
    arrays = {"image": np.arange(6, dtype=np.uint8).reshape(6, 1, 1, 1)}
    starts = segment_starts(np.array([0, 0, 0, 1, 1, 1]))
    assert starts.tolist() == [0, 0, 0, 3, 3, 3]
    x = gather(arrays, cfg, np.arange(6), starts)["image"]
    assert x.shape == (6, 1, 1, 3)
    assert x[:, 0, 0].tolist() == [[0, 0, 0], [0, 0, 1], [0, 1, 2], [3, 3, 3], [3, 3, 4], [3, 4, 5]]
    assert cfg.channels() == {"image": 3}
