"""steerlab on a donkeycar: the `SteerlabPilot` part inside donkeycar's own vehicle loop (its outputs are what
`steerlab evaluate` predicts on the same records), the ONNX model on a machine without torch, and steerlab's
tub reader against donkeycar's own `Tub`. donkeycar's base package is a test dependency (steerlab[test]);
the tests on the real tubs of ../shared/data/donkeycar skip without them, the others play back tubs that
donkeycar's own `TubWriter` writes."""

import importlib.util
import json
import logging
import math
import subprocess
import sys
import types

import cv2
import numpy as np
import pytest

from conftest import SHARED, made
from steerlab.data.readers import open_recording
from steerlab.control import SpeedControl
from steerlab.data.readers import Source
from steerlab.donkey import SteerlabPilot
from steerlab.errors import SteerlabError
from steerlab.pilot import Pilot

if importlib.util.find_spec("donkeycar") is None:  # a one-line reason naming the package
    pytest.skip("donkeycar has no release for Python %d.%d (its 5.2 and 5.4 cover 3.11-3.13)" % sys.version_info[:2]
                if sys.version_info >= (3, 14) else "donkeycar is not installed: pip install -e '.[test]'",
                allow_module_level=True)

_root = logging.getLogger()
_handlers, _level = _root.handlers[:], _root.level
# importing donkeycar prints its banner and sets the root logger to INFO: undone below
from donkeycar.config import Config  # noqa: E402
from donkeycar.parts.tub_v2 import Tub, TubWriter  # noqa: E402
from donkeycar.pipeline.types import TubRecord  # noqa: E402
from donkeycar.vehicle import Vehicle  # noqa: E402

_root.handlers[:] = _handlers
_root.setLevel(_level)

TUBS = SHARED / "donkeycar"
needs_tubs = pytest.mark.skipif(not (TUBS / "hall" / "manifest.json").exists(), reason="../shared/data absent")
N = 40  # records played through the vehicle loop


@pytest.fixture(autouse=True, scope="module")
def one_torch_thread():
    """One frame of a small model at a time: one torch thread is faster than two (as in the xdist workers)."""
    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    """The models a donkeycar drives with here: PilotNet (donkeycar convention), flow-lstm (recurrent, with
    flow) as a checkpoint and as its ONNX export."""
    from steerlab.export import export_onnx

    folder = tmp_path_factory.mktemp("models")
    lstm = made(folder, "normalized", "right", "donkey", "flow-lstm.pt", model="flow-lstm", seed=1)
    return {"pilotnet": made(folder, "normalized", "right", "donkey"), "flow-lstm": lstm,
            "flow-lstm.onnx": export_onnx(lstm, folder / "flow-lstm.onnx")}


def write_tub(folder, n=N, shape=(120, 160, 3), start_index=0):
    """A tub written by donkeycar's own TubWriter at 20 Hz (its clock is replaced: `_timestamp_ms` 50 ms apart
    whatever the machine's load): a textured scene sliding sideways (so flow sees motion), records
    `start_index`, `start_index` + 1, ..."""
    import donkeycar.parts.tub_v2 as tub_v2

    ticks = iter(1_700_000_000.0 + 0.05 * i for i in range(n))
    tub_v2.time, real = types.SimpleNamespace(time=lambda: next(ticks)), tub_v2.time
    try:
        _write(folder, n, shape, start_index)
    finally:
        tub_v2.time = real
    if start_index:  # the empty catalog the tub began with goes, as in taped-track (donkeycar cannot mmap it)
        lines = (folder / "manifest.json").read_text().splitlines()
        catalogs = json.loads(lines[4])
        for name in [c for c in catalogs["paths"] if not (folder / c).stat().st_size]:
            catalogs["paths"].remove(name)
            (folder / name).unlink()
            (folder / name).with_suffix(".catalog_manifest").unlink()
        (folder / "manifest.json").write_text("\n".join(lines[:4] + [json.dumps(catalogs)]) + "\n")
    return folder


def _write(folder, n, shape, start_index):
    writer = TubWriter(str(folder), inputs=["cam/image_array", "user/angle", "user/throttle", "user/mode"],
                       types=["image_array", "float", "float", "str"])
    writer.tub.manifest.current_index = start_index  # as in a tub whose first catalogs were removed
    rng = np.random.default_rng(0)
    scene = cv2.GaussianBlur(rng.integers(0, 255, (shape[0], shape[1] + 3 * n, 3), dtype=np.uint8), (9, 9), 3)
    for i in range(n):
        writer.run(np.ascontiguousarray(scene[:, 3 * i: 3 * i + shape[1]]), round(0.5 * math.sin(i / 4), 3), 0.3,
                   "user")
    writer.close()


class TubCamera:
    """A donkeycar part that plays a tub back as the camera: each loop the next record's image as donkeycar's
    training reads it (`TubRecord.image()`, RGB at the configured size) and the record's `_index`; `now` is
    the record's time (s), the clock of a part that plays along."""

    def __init__(self, path, width=160, height=120):
        self.tub = Tub(str(path), read_only=True)
        self.records = iter(self.tub)
        self.cfg = Config()
        self.cfg.IMAGE_W, self.cfg.IMAGE_H, self.cfg.IMAGE_DEPTH = width, height, 3
        self.now = 0.0

    def run(self):
        record = next(self.records)
        self.now = record["_timestamp_ms"] / 1000
        return TubRecord(self.cfg, self.tub.base_path, record).image(), record["_index"]

    def shutdown(self):
        self.tub.close()


class Log:
    def __init__(self):
        self.rows = []

    def run(self, *values):
        self.rows.append(values)


def drive(tub, model, loops=N, camera=None, **options):
    """Run donkeycar's Vehicle loop: tub camera -> a SteerlabPilot part of `model` (in autopilot; its clock the
    tub's, so a gap in the recording is a gap for the part, whatever the machine's load) -> a log of its
    outputs. Returns the log and the loop's result (None when a part raised: donkeycar prints the traceback
    and stops)."""
    car = Vehicle()
    car.mem["run_pilot"] = True
    cam = TubCamera(tub, **(camera or {}))
    part = SteerlabPilot(model, clock=lambda: cam.now, **options)
    car.add(cam, outputs=["cam/image_array", "tub/index"])
    car.add(part, inputs=["cam/image_array"], outputs=["pilot/angle", "pilot/throttle"], run_condition="run_pilot")
    log = Log()
    car.add(log, inputs=["tub/index", "pilot/angle", "pilot/throttle"])
    return log.rows, car.start(rate_hz=1000, max_loop_count=loops)


def evaluated(model, data, tmp_path, n=N):
    """What `steerlab evaluate` predicts on the first n records (its predictions.csv)."""
    from steerlab.evaluate.offline import evaluate

    out = tmp_path / f"eval-{model.name}"
    evaluate(model, Source(str(data), f"0:{n}"), out, progress=False)
    return np.loadtxt(out / "predictions.csv", delimiter=",", skiprows=1)


@pytest.mark.parametrize("model", ["pilotnet", "flow-lstm", "flow-lstm.onnx"])
@pytest.mark.parametrize("source", ["donkeycar-written", pytest.param("hall", marks=needs_tubs)])
def test_donkey_part_in_the_vehicle_loop_predicts_what_evaluate_does(source, model, models, tmp_path):
    tub = write_tub(tmp_path / "tub") if source == "donkeycar-written" else TUBS / "hall"
    rows, result = drive(tub, models[model], throttle=0.25)
    assert result is not None and result[0] == N, "the vehicle loop stopped early (traceback above)"
    index, angle, throttle = map(np.array, zip(*rows))
    expected = evaluated(models[model], tub, tmp_path)
    np.testing.assert_array_equal(index, expected[:, 0])  # frame ids of a tub: the records' _index
    np.testing.assert_array_equal(angle, np.clip(expected[:, 1], -1, 1))  # the same Pilot on the same pixels
    assert np.ptp(angle) > 1e-5 and np.all(np.abs(angle) < 1)  # the model's values, not a constant or clipped
    assert np.all(throttle == 0.25)


def test_donkey_onnx_part_runs_without_torch(models, tmp_path):
    """On the car: Pilot("model.onnx") and the part in a Python where importing torch (or onnx) fails."""
    rgb = np.stack(frames(8))
    np.save(tmp_path / "frames.npy", rgb)
    code = f"""
import importlib.abc, json, sys
class NoTorch(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in ("torch", "onnx"):
            raise ImportError("no " + name + " on this car")
sys.meta_path.insert(0, NoTorch())
import numpy as np
from steerlab.donkey import SteerlabPilot
from steerlab.pilot import Pilot
frames = np.load({str(tmp_path / "frames.npy")!r})
part, pilot = SteerlabPilot({str(models["flow-lstm.onnx"])!r}), Pilot({str(models["flow-lstm.onnx"])!r})
angles = [part.run(f)[0] for f in frames]
steering = [pilot.step(np.ascontiguousarray(f[..., ::-1])).steering for f in frames]
print(json.dumps({{"angles": angles, "steering": steering,
                  "torch": sorted(m for m in sys.modules if m.split(".")[0] in ("torch", "onnx"))}}))
"""
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    got = json.loads(run.stdout.strip().splitlines()[-1])
    assert got["torch"] == []
    part, pilot = SteerlabPilot(models["flow-lstm"]), Pilot(models["flow-lstm"])  # torch, in this process
    np.testing.assert_allclose(got["angles"], [part.run(f)[0] for f in rgb], atol=1e-5)
    np.testing.assert_allclose(got["steering"], [pilot.step(np.ascontiguousarray(f[..., ::-1])).steering
                                                 for f in rgb], atol=1e-5)


@pytest.mark.parametrize("bad", [(240, 320, 3), (120, 160), (120, 160, 4), "float32"])
def test_donkey_part_refuses_a_frame_of_another_shape(bad, models):
    part = SteerlabPilot(models["pilotnet"])
    frame = np.zeros((120, 160, 3), np.float32) if bad == "float32" else np.zeros(bad, np.uint8)
    got = "120x160x3 float32" if bad == "float32" else f"{'x'.join(map(str, bad))} uint8"
    with pytest.raises(SteerlabError, match=rf"the camera frame is {got}; model.pt \(model 'pilotnet'\) expects "
                                            r"120x160x3 uint8 RGB frames of the 'donkey' camera it was trained on "
                                            r"\(donkeycar config: IMAGE_H = 120, IMAGE_W = 160, IMAGE_DEPTH = 3\)"):
        part.run(frame)


def test_donkey_vehicle_stops_on_a_tub_of_another_size(models, tmp_path, capsys):
    """A tub (or camera) at 320x240 reaching a model of the 120x160 donkey camera: the part raises on the first
    frame, donkeycar's loop prints the error and stops the car."""
    tub = write_tub(tmp_path / "tub", n=3, shape=(240, 320, 3))
    rows, result = drive(tub, models["flow-lstm.onnx"], loops=3, camera={"width": 320, "height": 240})
    assert result is None and rows == []  # the parts after it never ran
    err = capsys.readouterr().err
    assert "SteerlabError: SteerlabPilot: the camera frame is 240x320x3 uint8; flow-lstm.onnx (model 'flow-lstm') " \
           "expects 120x160x3 uint8 RGB frames" in err


def test_donkey_steering_conventions(tmp_path):
    rng = np.random.default_rng(0)
    # the simulator's road-wheel angle, positive right: refused without the car's full lock, then angle / lock
    sim = made(tmp_path, "road_wheel", "right", "sim", name="sim.pt")
    with pytest.raises(SteerlabError, match=r"sim.pt predicts the road-wheel angle \(positive right\); donkeycar "
                                            r"steers with a servo command in \[-1, 1\]: give the car's full-lock "
                                            r"road-wheel angle, SteerlabPilot\(.*sim.pt', full_lock_deg=\.\.\.\)"):
        SteerlabPilot(sim)
    frame = rng.integers(0, 255, (160, 320, 3), dtype=np.uint8)
    y = Pilot(sim).step(frame[..., ::-1].copy()).steering
    assert SteerlabPilot(sim, full_lock_deg=25).run(frame)[0] == pytest.approx(np.clip(y / math.radians(25), -1, 1))
    # CH2's steering-wheel angle, positive left: through the steering ratio, the sign turned
    ch2 = made(tmp_path, "steering_wheel", "left", "ch2", name="ch2.pt")
    with pytest.raises(SteerlabError, match=r"ch2.pt predicts the steering-wheel angle \(positive left\)"):
        SteerlabPilot(ch2)
    frame = rng.integers(0, 255, (480, 640, 3), dtype=np.uint8)
    y = Pilot(ch2).step(frame[..., ::-1].copy()).steering
    assert SteerlabPilot(ch2, full_lock_deg=0.5).run(frame)[0] == pytest.approx(
        np.clip(-y / 14.8 / math.radians(0.5), -1, 1))
    # a tub model: passed through; rescaled when its car's full lock and this car's are both known
    tub = made(tmp_path, "normalized", "right", "donkey", name="tub.pt", full_lock_deg=20)
    frame = rng.integers(0, 255, (120, 160, 3), dtype=np.uint8)
    y = Pilot(tub).step(frame[..., ::-1].copy()).steering
    assert SteerlabPilot(tub).run(frame)[0] == pytest.approx(np.clip(y, -1, 1))
    assert SteerlabPilot(tub, full_lock_deg=25).run(frame)[0] == pytest.approx(np.clip(y * 20 / 25, -1, 1))
    with pytest.raises(SteerlabError, match=r"full_lock_deg must be a number in \(0, 89\], got -3"):
        SteerlabPilot(tub, full_lock_deg=-3)
    with pytest.raises(SteerlabError, match=r"throttle must be a number in \[0, 1\], got 1.5"):
        SteerlabPilot(tub, throttle=1.5)


def frames(n, seed=0):
    rng = np.random.default_rng(seed)
    scene = cv2.GaussianBlur(rng.integers(0, 255, (120, 160 + 3 * n, 3), dtype=np.uint8), (9, 9), 3)
    return [np.ascontiguousarray(scene[:, 3 * i: 3 * i + 160]) for i in range(n)]


def test_donkey_throttle_of_speed_models(tmp_path):
    """multitask-speed: PI control of the measured speed to the predicted one (it needs the measured speed);
    speed-command: the throttle steps with the commands."""
    speed_model = made(tmp_path, "normalized", "right", "donkey", "speed.pt", model="multitask-speed", seed=1)
    part = SteerlabPilot(speed_model, throttle=0.2, max_throttle=0.6)
    with pytest.raises(SteerlabError, match=r"model 'multitask-speed' needs the measured speed \(m/s\) with every "
                                            r"frame: add the car's odometry \(HAVE_ODOM = True\) and "
                                            r"inputs=\['cam/image_array', 'enc/speed'\]"):
        part.run(frames(1)[0])
    pilot, pi = Pilot(speed_model), SpeedControl(0.1, 0.01, cruise=0.2, low=0.0, high=0.6)
    for i, f in enumerate(frames(6)):
        v = 1.0 + 0.1 * i
        out = pilot.step(f[..., ::-1].copy(), v)
        assert part.run(f, v) == pytest.approx((np.clip(out.steering, -1, 1), pi.update(out.speed, v)))
    command_model = made(tmp_path, "normalized", "right", "donkey", "command.pt", model="speed-command", seed=1)
    part, pilot, throttle = SteerlabPilot(command_model, 0.3, command_step=0.05), Pilot(command_model), 0.3
    for f in frames(6):
        throttle = np.clip(throttle + 0.05 * (pilot.step(f[..., ::-1].copy()).command - 1), 0, 0.5)
        assert part.run(f)[1] == pytest.approx(throttle)
    with pytest.raises(SteerlabError, match=r"the cruising throttle 0.7 exceeds max_throttle 0.5"):
        SteerlabPilot(command_model, 0.7)


def test_donkey_speed_control_holds_the_predicted_speed():
    pi, v = SpeedControl(0.1, 0.01, cruise=0.2, low=0.0, high=1.0), 0.0  # the donkeycar part's gains
    for _ in range(600):  # an RC car whose acceleration follows the throttle, with drag
        v += 0.05 * (8.0 * pi.update(3.0, v) - 0.5 * v)
    assert v == pytest.approx(3.0, abs=0.05)


def test_donkey_part_forgets_the_past_after_a_gap(models):
    """A pause longer than 0.5 s between frames (the pilot switched off and on) starts a new segment, as in
    a recording; a missing frame gives a stop and starts one too; shutdown ends the part."""
    now = [0.0]
    part = SteerlabPilot(models["flow-lstm.onnx"], clock=lambda: now[0])
    fs = frames(8)
    pilot = Pilot(models["flow-lstm.onnx"])
    for i, f in enumerate(fs[:4]):
        now[0] = 0.05 * i
        assert part.run(f)[0] == pytest.approx(np.clip(pilot.step(f[..., ::-1].copy()).steering, -1, 1), abs=1e-6)
    now[0] += 2.0
    pilot.reset()
    assert part.run(fs[4])[0] == pytest.approx(np.clip(pilot.step(fs[4][..., ::-1].copy()).steering, -1, 1),
                                               abs=1e-6)
    assert part.run(None) == (0.0, 0.0)
    pilot.reset()
    assert part.run(fs[5])[0] == pytest.approx(np.clip(pilot.step(fs[5][..., ::-1].copy()).steering, -1, 1),
                                               abs=1e-6)
    part.shutdown()
    with pytest.raises(SteerlabError, match=r"run\(\) after shutdown\(\)"):
        part.run(fs[6])


# ---------------------------------------------------------------- steerlab's tub reader against donkeycar's

@needs_tubs
@pytest.mark.parametrize("name", ["hall", "taped-track", "wood-tape"])
def test_donkey_tub_reader_matches_donkeycars_tub(name):
    path = TUBS / name
    before = {p: p.stat().st_mtime_ns for p in path.iterdir() if p.is_file()}
    tub = Tub(str(path), read_only=True)
    try:
        records = list(tub)
    finally:
        tub.close()
    assert {p: p.stat().st_mtime_ns for p in path.iterdir() if p.is_file()} == before  # donkeycar wrote nothing
    rec = open_recording(path, None, None, {"skip_missing": True})
    missing = [r["_index"] for r in records if not (path / "images" / r["cam/image_array"]).is_file()]
    assert len(missing) == {"hall": 0, "taped-track": 2, "wood-tape": 0}[name]  # donkeycar's does not look at images
    kept = [r for r in records if r["_index"] not in missing]
    assert len(rec) == len(kept) == {"hall": 5015, "taped-track": 3076, "wood-tape": 8000}[name]
    np.testing.assert_array_equal(rec.frame_ids, [r["_index"] for r in kept])
    np.testing.assert_array_equal(rec.steering, [r["user/angle"] for r in kept])
    np.testing.assert_array_equal(rec.throttle, [r["user/throttle"] for r in kept])
    np.testing.assert_array_equal(rec.timestamps_ns, [r["_timestamp_ms"] * 1_000_000 for r in kept])
    assert [p.name for p in rec.frames["center"]] == [r["cam/image_array"] for r in kept]
    assert list(rec.extra["session"]) == [r["_session_id"] for r in kept]
    cfg = Config()
    cfg.IMAGE_W, cfg.IMAGE_H, cfg.IMAGE_DEPTH = 160, 120, 3
    for i in np.linspace(0, len(rec) - 1, 5).astype(int):  # the pixels donkeycar trains on, as steerlab's BGR
        np.testing.assert_array_equal(TubRecord(cfg, str(path), kept[i]).image(), rec.load_frame(i)[..., ::-1])


def test_donkey_deleted_indexes_are_record_indexes(tmp_path):
    """donkeycar's tub editor deletes records by their `_index`; its reader (ManifestIterator, what its
    training reads) skips deleted indexes by record position. They agree when the indexes count from 0;
    steerlab follows the editor, so in a tub whose indexes start at 10000 (as taped-track's) the records the
    user deleted stay deleted, where donkeycar's reader would train on them."""
    for start in (0, 10000):
        folder = write_tub(tmp_path / f"tub-{start}", n=12, start_index=start)
        editor = Tub(str(folder))
        editor.delete_records([start + 3, start + 4])  # what the tub editor does with the records 3 and 4
        editor.close()
        reader = Tub(str(folder), read_only=True)
        donkeycars = [r["_index"] for r in reader]
        reader.close()
        steerlabs = list(open_recording(folder).frame_ids)
        assert steerlabs == [start + i for i in range(12) if i not in (3, 4)]
        assert donkeycars == (steerlabs if start == 0 else [start + i for i in range(12)])
