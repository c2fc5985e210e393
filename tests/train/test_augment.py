"""What training does to a batch (train/augment.py, train/batches.py) and the bulk dropout of the models
(models/dropout.py), against hand-computed values and OpenCV's own warp."""

import cv2
import numpy as np
import pytest
import torch

from steerlab.data.dataset import CompiledDataset
from steerlab.data.preprocess import PreprocessConfig
from steerlab.models.dropout import Dropout, keep_mask
from steerlab.train.augment import augment, first_channel, hue_turns, mirror, no_motion
from steerlab.train.batches import Batch, FrameBatches


def test_mirror_negates_flow_dx():
    cfg = PreprocessConfig(modalities=("image", "flow"))
    x = torch.zeros((1, 2, 3, 3))
    x[0, 0, :, 0] = torch.tensor([1.0, 2, 3])   # image
    x[0, 0, :, 1] = 5.0                          # dx
    x[0, 0, :, 2] = 7.0                          # dy
    f = mirror(x, cfg)
    assert f[0, 0, :, 0].tolist() == [3, 2, 1]
    assert f[0, 0, :, 1].tolist() == [-5, -5, -5] and f[0, 0, :, 2].tolist() == [7, 7, 7]
    assert x[0, 0, 0, 1] == 5.0  # the input is not modified


def test_no_motion_is_what_a_segment_start_shows():
    x = torch.arange(2 * 1 * 1 * 5, dtype=torch.float32).reshape(2, 1, 1, 5)  # gray image, diff, flow dx, dy, +1
    cfg = PreprocessConfig(modalities=("image", "diff", "flow"))
    out = no_motion(x[..., :4], cfg)
    assert out[..., 0].tolist() == x[..., 0].tolist()  # the image is kept
    assert out[..., 1].tolist() == [[[128.0]], [[128.0]]] and not out[..., 2:4].any()
    stacked = PreprocessConfig(stack=3)  # three gray frames, oldest first: the newest one three times
    assert no_motion(x[..., :3], stacked)[0, 0, 0].tolist() == [2.0, 2.0, 2.0]
    assert no_motion(x[..., :2], PreprocessConfig(stack=2))[1, 0, 0].tolist() == [6.0, 6.0]  # two frames: 6 twice
    flow_first = PreprocessConfig(modalities=("image", "flow", "diff"))  # the flow's two channels, then the diff
    assert no_motion(x[..., :4], flow_first)[1, 0, 0].tolist() == [5.0, 0.0, 0.0, 128.0]
    assert x[0, 0, 0, 0] == 0.0  # the input is not modified
    assert (first_channel(cfg, "image"), first_channel(cfg, "diff"), first_channel(cfg, "flow")) == (0, 1, 2)
    with pytest.raises(KeyError, match="flow"):
        first_channel(stacked, "flow")


def _dataset(images: np.ndarray, steering: list[float], cfg: PreprocessConfig) -> CompiledDataset:
    n = len(images)
    labels = {"steering": np.array(steering), "segment": np.zeros(n, int), "timestamps_ns": np.arange(n) * 50_000_000,
              "frame_ids": np.arange(n)}
    return CompiledDataset(None, cfg, {"image": images}, labels, {"source": "hand-made"})


def test_mirrored_samples_are_mirrored_and_negate_their_steering():
    cfg = PreprocessConfig(width=3, height=2, color="rgb")
    images = np.arange(4 * 2 * 3 * 3, dtype=np.uint8).reshape(4, 2, 3, 3)
    steering = [0.1, -0.2, 0.3, 0.4]
    data = FrameBatches([(_dataset(images, steering, cfg), np.array(steering))], {"mean": [0.0] * 3, "std": [1.0] * 3})
    inputs, targets, _ = data[Batch(np.arange(4), flip=np.array([True, False, True, False]))]
    assert targets["steering"].tolist() == pytest.approx([-0.1, -0.2, -0.3, 0.4])
    x = inputs["x"].permute(0, 2, 3, 1).numpy()  # back to (B, H, W, C)
    np.testing.assert_array_equal(x[[0, 2]], images[[0, 2], :, ::-1])  # left-right
    np.testing.assert_array_equal(x[[1, 3]], images[[1, 3]])


def test_augmentation_hand_computed():
    cfg = PreprocessConfig(modalities=("image", "flow"))
    x = torch.zeros((1, 10, 20, 3))
    x[..., 0], x[..., 1] = 100.0, 1.0  # uniform image, flow (1, 0) everywhere
    angle, factor = (lambda r: (r.uniform(-10, 10), r.uniform(0.8, 1.2)))(np.random.default_rng(5))
    out = augment(x.clone(), cfg, np.random.default_rng(5), rotation_deg=10, brightness=0.2)
    a = np.radians(angle)
    np.testing.assert_allclose(out[0, 5, 10], [100 * factor, np.cos(a), -np.sin(a)], rtol=1e-5)
    np.testing.assert_allclose(out[0, ..., 0], 100 * factor, rtol=1e-5)  # the corners too: the border repeated
    x[..., 1], x[..., 2] = 3.0, 2.0  # flow (3, 2): (3 cos a + 2 sin a, 2 cos a - 3 sin a)
    out = augment(x.clone(), cfg, np.random.default_rng(5), rotation_deg=10, brightness=0.2)
    np.testing.assert_allclose(out[0, 5, 10, 1:], [3 * np.cos(a) + 2 * np.sin(a), 2 * np.cos(a) - 3 * np.sin(a)],
                               rtol=1e-5)
    x[..., 0] = 250.0
    assert augment(x.clone(), cfg, np.random.default_rng(1), 0, 0.5)[..., 0].max() <= 255


def test_each_sample_gets_the_draws_it_gets_augmented_alone():
    """A batch's draws go to its samples one sample after the other (hue angle, then brightness factor), as when
    each sample is augmented on its own: a seed gives the same training data batched or not."""
    cfg = PreprocessConfig(color="rgb")
    x = torch.from_numpy(np.random.default_rng(0).uniform(0, 255, (3, 4, 5, 3)).astype(np.float32))
    out = augment(x.clone(), cfg, np.random.default_rng(7), rotation_deg=0, brightness=0.3, hue_deg=90)
    r = np.random.default_rng(7)
    for i in range(3):
        hue, factor = r.uniform(-90, 90), r.uniform(0.7, 1.3)
        want = np.clip(np.clip(x[i].numpy() @ hue_turns(np.array([hue]))[0].T, 0, 255) * factor, 0, 255)
        np.testing.assert_allclose(out[i].numpy(), want, rtol=1e-5, atol=1e-3)
    # rotation and brightness: a uniform image and flow (1, 0), whose vectors turn by each sample's own angle
    cfg = PreprocessConfig(modalities=("image", "flow"))
    x = torch.zeros((3, 10, 20, 3))
    x[..., 0], x[..., 1] = 100.0, 1.0
    out = augment(x.clone(), cfg, np.random.default_rng(8), rotation_deg=20, brightness=0.3)
    r = np.random.default_rng(8)
    for i in range(3):
        a, factor = np.radians(r.uniform(-20, 20)), r.uniform(0.7, 1.3)
        np.testing.assert_allclose(out[i, 5, 10], [100 * factor, np.cos(a), -np.sin(a)], rtol=1e-5)


def test_brightness_scales_only_the_brightness_channel_of_each_frame():
    """Gray and RGB: every channel of the image; YUV: Y; HSV: V; the difference image never (hand-computed)."""
    factor = np.random.default_rng(4).uniform(0.5, 1.5)
    for color, channels, scaled in [("gray", 1, [True]), ("rgb", 3, [True] * 3), ("yuv", 3, [True, False, False]),
                                    ("hsv", 3, [False, False, True])]:
        cfg = PreprocessConfig(color=color, stack=2, modalities=("image", "diff"))
        x = torch.full((1, 2, 2, 3 * channels), 100.0)
        out = augment(x.clone(), cfg, np.random.default_rng(4), 0, 0.5)[0, 0, 0].tolist()
        want = [100 * factor if on else 100.0 for on in scaled] * 2 + [100.0] * channels
        assert out == pytest.approx(want, rel=1e-5), color


def test_rotation_turns_the_image_as_opencv_does():
    cfg = PreprocessConfig(width=64, height=48, color="gray")
    yy, xx = np.mgrid[0:48, 0:64].astype(np.float32)
    img = 2 * xx + yy  # a smooth ramp: any turn moves every value
    out = augment(torch.from_numpy(img[None, ..., None].copy()), cfg, np.random.default_rng(2), 15, 0)[0, ..., 0]
    angle = np.random.default_rng(2).uniform(-15, 15)
    want = cv2.warpAffine(img, cv2.getRotationMatrix2D((31.5, 23.5), angle, 1.0), (64, 48), flags=cv2.INTER_LINEAR,
                          borderMode=cv2.BORDER_REPLICATE)
    np.testing.assert_allclose(out.numpy()[8:-8, 8:-8], want[8:-8, 8:-8], atol=1e-2)
    assert abs(angle) > 5 and np.abs(out.numpy() - img)[8:-8, 8:-8].mean() > 1  # it did turn


def test_hue_turn_hand_computed():
    def turn(deg):
        return hue_turns(np.array([deg]))[0]

    # a third of a turn about the gray axis moves each primary to the next: red -> green -> blue
    np.testing.assert_allclose(turn(120) @ [255, 0, 0], [0, 255, 0], atol=1e-4)
    np.testing.assert_allclose(turn(-120) @ [0, 0, 255], [0, 255, 0], atol=1e-4)
    # a sixth: red paint becomes yellow (the negative blue is clipped by augment); grays never move
    np.testing.assert_allclose(turn(60) @ [200, 30, 30], [143.33, 143.33, -26.67], atol=0.01)
    np.testing.assert_allclose(turn(37) @ [90, 90, 90], [90, 90, 90], atol=1e-4)
    np.testing.assert_allclose(turn(25) @ turn(-25), np.eye(3), atol=1e-6)
    # OpenCV's rotation about the same axis
    np.testing.assert_allclose(turn(77), cv2.Rodrigues(np.full(3, np.radians(77) / np.sqrt(3)))[0], atol=1e-6)


def test_hue_augmentation_turns_every_stacked_frame_alike():
    cfg = PreprocessConfig(stack=2)
    x = torch.zeros((2, 4, 5, 6))
    x[..., :3] = x[..., 3:] = torch.tensor([200.0, 30.0, 30.0])   # red in both frames of each sample
    x[1, 0, 0] = 90.0                                              # one gray pixel
    angles = np.random.default_rng(3).uniform(-180, 180, 2)
    out = augment(x.clone(), cfg, np.random.default_rng(3), 0, 0, hue_deg=180)
    for i, a in enumerate(angles):
        want = np.clip(hue_turns(np.array([a]))[0] @ [200.0, 30.0, 30.0], 0, 255)
        np.testing.assert_allclose(out[i, 1, 1], np.concatenate([want, want]), rtol=1e-5)
    np.testing.assert_allclose(out[1, 0, 0], 90.0, rtol=1e-5)
    with_diff = torch.cat([x, torch.full((2, 4, 5, 3), 7.0)], dim=-1)  # and a difference image, which stays
    turned = augment(with_diff, PreprocessConfig(stack=2, modalities=("image", "diff")), np.random.default_rng(3), 0,
                     0, hue_deg=180)
    np.testing.assert_allclose(turned[..., :6], out, rtol=1e-5)
    assert (turned[..., 6:] == 7.0).all()
    assert not np.allclose(out[0, 1, 1], out[1, 1, 1])  # a draw per sample


def test_dropout_keeps_one_minus_p_scaled_and_is_the_identity_in_evaluation():
    torch.manual_seed(0)
    x = torch.ones(64, 24, 30, 40)
    drop = Dropout(0.2)
    y = drop(x)
    kept = y != 0
    n = kept.numel()
    assert abs(kept.float().mean().item() - 0.8) < 4 * np.sqrt(0.8 * 0.2 / n)
    assert torch.all(y[kept] == 1.25)
    # each of the four 16-bit words of a 64-bit draw keeps alike (no word is biased)
    for w in range(4):
        assert abs(kept.flatten()[w::4].float().mean().item() - 0.8) < 4 * np.sqrt(0.8 * 0.2 / (n / 4))
    assert torch.equal(drop.eval()(x), x)
    assert torch.equal(Dropout(0.0).train()(x), x)


def test_dropout_masks_follow_torchs_seed_and_layout():
    torch.manual_seed(7)
    a = keep_mask(torch.empty(1000), 0.5)
    b = keep_mask(torch.empty(1000), 0.5)
    torch.manual_seed(7)
    assert torch.equal(keep_mask(torch.empty(1000), 0.5), a) and not torch.equal(a, b)
    x = torch.randn(2, 8, 5, 6).contiguous(memory_format=torch.channels_last)
    assert keep_mask(x, 0.3).is_contiguous(memory_format=torch.channels_last)
    assert keep_mask(x[:, :, ::2], 0.3).shape == (2, 8, 3, 6)  # a strided input


def test_dropout_gradient_is_the_mask():
    torch.manual_seed(1)
    x = torch.randn(8, 50, requires_grad=True)
    y = Dropout(0.4)(x)
    y.backward(torch.full_like(y, 2.0))
    mask = (y / x).detach()
    np.testing.assert_allclose(x.grad, 2.0 * mask, rtol=1e-6)
    kept = mask.numpy() != 0
    np.testing.assert_allclose(mask.numpy()[kept], 1 / 0.6, rtol=1e-6)
    assert 0 < kept.mean() < 1


def _kept_after_free(keep: bool) -> float:
    """MB of resident memory that a fresh Python still holds after a 64 MB block was written and freed, with or
    without `keep_freed_memory`."""
    import subprocess
    import sys

    code = f"""
import numpy as np
from steerlab.train.host import keep_freed_memory
assert keep_freed_memory() if {keep} else True
def rss():
    return int(next(l for l in open("/proc/self/status") if l.startswith("VmRSS")).split()[1]) / 1024
before = rss()
a = np.ones(16 * 2 ** 20, np.float32)
del a
print(rss() - before)
"""
    return float(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout)


def test_freed_memory_is_kept_for_the_next_step():
    import ctypes.util

    if ctypes.util.find_library("c") != "libc.so.6":
        pytest.skip("glibc only")
    assert _kept_after_free(False) < 16  # malloc's default: the block was mapped, and unmapped when freed
    assert _kept_after_free(True) > 60  # kept: the next step's block of this size touches no fresh page


@pytest.mark.parametrize("native", [True, False])
def test_bf16_precision_trains_in_bfloat16_where_the_cpu_has_it_and_in_float32_where_it_would_be_emulated(
        tiny_recording, tmp_path, monkeypatch, capsys, native):
    from steerlab.train import loop
    from steerlab.train.config import load_config

    seen = []
    monkeypatch.setattr(loop, "bf16_instructions", lambda: native)
    forward = torch.nn.Conv2d.forward

    def spied(self, x):
        y = forward(self, x)
        seen.append(y.dtype)
        return y

    monkeypatch.setattr(torch.nn.Conv2d, "forward", spied)
    cfg = load_config(None, base={"data": str(tiny_recording), "cache": str(tmp_path / "cache"),
                                  "out": str(tmp_path / "r"), "split": {"train": "0:32", "val": "32:40"},
                                  "preprocess": {"width": 64, "height": 64}, "model": {"name": "pilotnet"},
                                  "train": {"epochs": 1, "batch_size": 32, "precision": "bf16"}})
    loop.train(cfg, progress=False)  # said whether the run shows its progress or not
    said = "bfloat16 is emulated and slower: training in float32" in capsys.readouterr().err
    assert said != native
    assert (torch.bfloat16 in seen) == native  # the forward pass of training
    assert torch.float32 in seen  # validation
    ckpt = torch.load(tmp_path / "r" / "best.pt", weights_only=True)
    assert all(v.dtype == torch.float32 for v in ckpt["state_dict"].values() if v.is_floating_point())


ZEN4 = "processor\t: 0\nmodel name\t: AMD EPYC\nflags\t\t: fpu sse avx avx2 avx512f avx512_vnni avx512_bf16\n"
ZEN3 = "processor\t: 0\nmodel name\t: AMD EPYC 7763\nflags\t\t: fpu sse avx avx2 fma\n"
SAPPHIRE = "flags\t\t: avx2 avx512f avx512_vnni amx_bf16 amx_int8 amx_tile\n"
PI5 = "processor\t: 0\nBogoMIPS\t: 108.00\nFeatures\t: fp asimd evtstrm aes pmull sha1 sha2 crc32 asimdrdm asimddp\n"


@pytest.mark.parametrize("cpuinfo, environ, bf16, sets", [
    (ZEN4, {}, True, "AVX2, AVX-512, VNNI, BF16"),
    (ZEN4, {"ONEDNN_MAX_CPU_ISA": "AVX2"}, False, "AVX2, AVX-512, VNNI, BF16"),  # oneDNN held below bfloat16
    (ZEN4, {"ONEDNN_MAX_CPU_ISA": "avx512_core_bf16"}, True, "AVX2, AVX-512, VNNI, BF16"),
    (ZEN3, {}, False, "AVX2 (no AVX-512)"),
    (SAPPHIRE, {}, True, "AVX2, AVX-512, VNNI, AMX-BF16, AMX-INT8"),
    (PI5, {}, False, "NEON, dot product"),
    ("processor\t: 0\n", {}, None, "instruction sets unknown"),  # no flags line: not known
])
def test_the_cpus_instruction_sets_and_whether_it_computes_in_bfloat16(cpuinfo, environ, bf16, sets):
    from steerlab.cpu import bf16_instructions, instruction_sets

    assert bf16_instructions(cpuinfo, environ) is bf16
    assert instruction_sets(cpuinfo).split(": ", 1)[1] == sets


def test_the_cpus_name():
    from steerlab.cpu import model_name

    assert model_name(ZEN3) == "AMD EPYC 7763"
