"""ONNX export and the Pilot on ONNX Runtime; the simulator drive server."""

import base64
import socket
import subprocess
import sys
import threading
import time

import cv2
import numpy as np
import pytest
import torch

from conftest import SIM, flip_bytes, made, resaved
from steerlab.data.readers import open_recording
from steerlab.data.recording import SteeringConvention
from steerlab.errors import SteerlabError
from steerlab.export import export_onnx
from steerlab.models import list_models
from steerlab.pilot import Pilot
from steerlab.control import SpeedControl
from steerlab.serve import DriveSession, to_simulator
from tests.pilot.samples import frames, untrained


@pytest.mark.parametrize("name", list_models())
def test_onnx_pilot_matches_torch(tmp_path, name):
    ckpt = untrained(tmp_path, name)
    onnx = export_onnx(ckpt, tmp_path / "m.onnx")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([ckpt.name, "m.onnx"])  # self-contained
    torch_pilot, onnx_pilot = Pilot(ckpt), Pilot(onnx)
    assert onnx_pilot.convention == torch_pilot.convention and onnx_pilot.config == torch_pilot.config
    for i, frame in enumerate(frames(12)):
        if i == 8:  # a new segment: both forget the past (recurrent state, previous frame)
            torch_pilot.reset()
            onnx_pilot.reset()
        a, b = torch_pilot.step(frame, 10.0 + i), onnx_pilot.step(frame, 10.0 + i)
        assert b.steering == pytest.approx(a.steering, abs=1e-4)
        assert (a.speed is None) == (b.speed is None) and a.command == b.command
        if a.speed is not None:
            assert b.speed == pytest.approx(a.speed, abs=1e-4)


@pytest.mark.parametrize("name", ["pilotnet", "flow-lstm", "multitask-speed"])
def test_an_ensemble_runs_the_mean_of_its_members_on_torch_and_onnx(tmp_path, name):
    """`steerlab ensemble`: each member standardises with its own statistics (one member's differ here) and
    keeps its own recurrent state; the steering (and speed) is the members' mean, also after a reset and in
    the ONNX export."""
    from steerlab.cli import main

    members = [made(tmp_path, "steering_wheel", "left", "ch2", f"m{s}.pt", model=name, seed=s) for s in range(3)]
    ckpt = torch.load(members[1], weights_only=True)
    ckpt["stats"] = {"mean": [m + 60.0 for m in ckpt["stats"]["mean"]], "std": [s / 8 for s in ckpt["stats"]["std"]]}
    resaved(members[1], ckpt)
    assert main(["ensemble", *map(str, members), "--out", str(tmp_path / "ens.pt")]) == 0
    ensemble = Pilot(tmp_path / "ens.pt")
    onnx = Pilot(export_onnx(tmp_path / "ens.pt", tmp_path / "ens.onnx"))
    pilots = [Pilot(m) for m in members]
    for i, frame in enumerate(frames(8)):
        if i == 5:
            for p in [ensemble, onnx, *pilots]:
                p.reset()
        outs = [p.step(frame, 10.0 + i) for p in pilots]
        mean = np.mean([o.steering for o in outs])
        assert np.ptp([o.steering for o in outs]) > 1e-4  # the members differ: the mean is a real test
        for e in (ensemble.step(frame, 10.0 + i), onnx.step(frame, 10.0 + i)):
            assert e.steering == pytest.approx(mean, abs=1e-4)
            if name == "multitask-speed":
                assert e.speed == pytest.approx(np.mean([o.speed for o in outs]), abs=1e-4)


def test_onnx_bad_files(tmp_path):
    import onnx

    onnx_path = export_onnx(untrained(tmp_path, "pilotnet"), tmp_path / "m.onnx")
    good = onnx_path.read_bytes()
    proto = onnx.load(onnx_path)
    del proto.metadata_props[:]  # an ONNX model from elsewhere, or exported when the metadata was a sidecar
    onnx.save(proto, tmp_path / "plain.onnx")
    with pytest.raises(SteerlabError, match=r"plain.onnx: no steerlab metadata in the model: not written by "
                                            r"steerlab export, or by a version that kept it in a .json sidecar"):
        Pilot(tmp_path / "plain.onnx")
    (tmp_path / "half.onnx").write_bytes(good[: len(good) // 3])  # cut off mid-weights
    with pytest.raises(SteerlabError, match=r"half.onnx: not an ONNX model \(damaged or truncated\?\)"):
        Pilot(tmp_path / "half.onnx")
    with pytest.raises(SteerlabError, match=r"nothere.onnx: ONNX file not found"):
        Pilot(tmp_path / "nothere.onnx")
    with pytest.raises(SteerlabError, match="must end in .onnx"):
        export_onnx(untrained(tmp_path, "pilotnet"), tmp_path / "m.bin")


def test_onnx_is_self_contained_and_checks_its_hash_on_load(tmp_path):
    """The metadata lives in the model (ONNX Runtime reads it as custom metadata); a sha256 over the graph,
    the weights and the metadata, kept in the metadata too, refuses flipped weight bytes and edited metadata."""
    import json

    import onnx
    import onnxruntime as ort

    from steerlab.runtime import content_sha256

    onnx_path = export_onnx(untrained(tmp_path, "lstm"), tmp_path / "m.onnx")
    props = ort.InferenceSession(str(onnx_path)).get_modelmeta().custom_metadata_map
    meta = json.loads(props["steerlab"])
    assert meta["model"] == "lstm" and meta["state_shape"] and meta["stats"]["mean"] == [100.0]
    assert meta["convention"] == SteeringConvention().as_dict() and meta["geometry"] == "ch2"
    assert props["steerlab_sha256"] == content_sha256(onnx_path.read_bytes())[0]
    copied = tmp_path / "elsewhere" / "copy.onnx"  # a copied model drives on its own
    copied.parent.mkdir()
    copied.write_bytes(onnx_path.read_bytes())
    frame = frames(1)[0]
    assert Pilot(copied).step(frame).steering == pytest.approx(Pilot(onnx_path).step(frame).steering, abs=1e-6)
    good = onnx_path.read_bytes()
    flip_bytes(onnx_path)
    with pytest.raises(SteerlabError, match=r"m.onnx: the model does not match the sha256 in its metadata: the "
                                            r"file is damaged or was changed after export"):
        Pilot(onnx_path)
    proto = onnx.load_from_string(good)  # the metadata edited: other statistics
    entry = next(p for p in proto.metadata_props if p.key == "steerlab")
    entry.value = entry.value.replace("100.0", "90.0")
    onnx_path.write_bytes(proto.SerializeToString())
    with pytest.raises(SteerlabError, match=r"m.onnx: the model does not match the sha256 in its metadata"):
        Pilot(onnx_path)
    onnx_path.write_bytes(good)
    Pilot(onnx_path).step(frame)


def test_speed_controller_holds_the_set_speed():
    pi, v = SpeedControl(), 0.0  # the simulator server's: kp 0.2, ki 0.01, throttle in [-1, 1]
    for _ in range(400):  # a car whose acceleration follows the throttle, with drag
        v += 0.05 * (4.0 * pi.update(5.0, v) - 0.1 * v)
    assert v == pytest.approx(5.0, abs=0.05)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def sim_jpegs(tiny_recording, n: int) -> list[bytes]:
    if (SIM / "driving_log.csv").exists():
        rec = open_recording(SIM, f"0:{n}")
    else:
        rec = open_recording(tiny_recording, f"0:{n}")
    return [cv2.imencode(".jpg", rec.load_frame(i))[1].tobytes() for i in range(n)]


def test_serve_answers_every_frame_like_the_pilot(tiny_checkpoint, tiny_recording, tmp_path):
    import socketio

    port, jpegs = _free_port(), sim_jpegs(tiny_recording, 30)
    server = subprocess.Popen([sys.executable, "-m", "steerlab", "serve", str(tiny_checkpoint), "--port", str(port),
                               "--record", str(tmp_path / "drive")], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True)
    client, replies, got = socketio.Client(), [], threading.Event()
    client.on("steer", lambda data: (replies.append(data), got.set()))
    try:
        listening = server.stdout.readline()  # the server says so once it listens; nothing if it exited
        assert listening.startswith("steerlab serve: "), server.communicate(timeout=10)[1]
        client.connect(f"http://127.0.0.1:{port}")
        assert got.wait(60)  # the greeting: stand still
        assert replies.pop() == {"steering_angle": "0.0", "throttle": "0.0"}
        speeds = [8.0 + 0.1 * i for i in range(len(jpegs))]  # mph
        messages = [{"steering_angle": "0", "throttle": "0", "speed": str(s), "image": base64.b64encode(j).decode()}
                    for s, j in zip(speeds, jpegs)]
        messages.insert(10, {"steering_angle": "0", "throttle": "0", "speed": "9.0", "image": "not base64 !"})
        tiny = cv2.imencode(".jpg", np.zeros((1, 1, 3), np.uint8))[1].tobytes()
        messages.insert(20, jpeg_message(tiny))  # a 1x1 frame: answered, and the server keeps serving
        messages.insert(25, jpeg_message(jpegs[0], mph=-50))  # impossible speeds: a safe stop, never recorded
        messages.insert(26, jpeg_message(jpegs[0], mph=1e300))
        for m in messages:
            got.clear()
            client.emit("telemetry", m)
            assert got.wait(10)
        got.clear()
        client.emit("telemetry")  # no payload at all: malformed, a safe stop
        assert got.wait(10) and replies.pop() == {"steering_angle": "0.0", "throttle": "0.0"}
        client.emit("telemetry", {})  # manual mode: no command comes back
        time.sleep(0.3)
        assert len(replies) == len(messages)
    finally:
        client.disconnect()
        server.terminate()
        _, err = server.communicate(timeout=10)
    assert replies[10] == {"steering_angle": "0.0", "throttle": "-1.0"}  # safe stop, braking at 4 m/s
    assert "telemetry frame 11: missing or undecodable image; sent a safe stop" in err
    assert replies[20] == {"steering_angle": "0.0", "throttle": "-1.0"}
    assert "telemetry frame 21: the image is 1x1, not the simulator's 320x160; sent a safe stop" in err
    assert replies[25] == replies[26] == {"steering_angle": "0.0", "throttle": "0.0"}
    assert "a speed of -50 mph is none a car drives at" in err and "a telemetry event with 0 payloads" in err
    assert "Traceback" not in err, err
    del replies[26], replies[25], replies[20], replies[10]
    pilot, pi = Pilot(tiny_checkpoint), SpeedControl()
    for reply, jpeg, mph in zip(replies, jpegs, speeds):
        v = mph * 0.44704
        expected = to_simulator(pilot, pilot.step(cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR),
                                                  v).steering)
        assert float(reply["steering_angle"]) == pytest.approx(expected, abs=1e-5)
        assert float(reply["throttle"]) == pytest.approx(pi.update(4.0, v), abs=1e-5)
    drive = open_recording(tmp_path / "drive")  # the recorded session reads as a simulator log
    assert len(drive) == len(jpegs)
    assert drive.steering / np.radians(25) == pytest.approx([float(r["steering_angle"]) for r in replies], abs=1e-5)


def jpeg_message(jpeg: bytes, mph: float = 9.0) -> dict:
    return {"steering_angle": "0", "throttle": "0", "speed": str(mph), "image": base64.b64encode(jpeg).decode()}


def test_drive_session_answers_frames_of_another_size(tiny_checkpoint, tiny_recording, tmp_path, capsys):
    session = DriveSession(Pilot(tiny_checkpoint), 4.0, tmp_path / "drive")
    good = sim_jpegs(tiny_recording, 2)
    odd = {size: cv2.imencode(".jpg", np.full((size[1], size[0], 3), 90, np.uint8))[1].tobytes()
           for size in [(1, 1), (320, 50), (640, 480), (160, 320)]}
    replies = [session.command(jpeg_message(good[0]))]
    capsys.readouterr()
    for n, ((w, h), jpeg) in enumerate(odd.items(), start=2):
        assert session.command(jpeg_message(jpeg)) == {"steering_angle": "0.0", "throttle": "-1.0"}  # safe stop
        err = capsys.readouterr().err
        assert err == f"warning: telemetry frame {n}: the image is {w}x{h}, not the simulator's 320x160; sent a " \
                      "safe stop\n"
    replies.append(session.command(jpeg_message(good[1])))  # and it keeps driving
    pilot = Pilot(tiny_checkpoint)
    for reply, jpeg in zip(replies, good):
        frame = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
        assert float(reply["steering_angle"]) == pytest.approx(to_simulator(pilot, pilot.step(frame, 4.0).steering),
                                                               abs=1e-5)
    assert (session.frames, session.bad) == (2, 4)
    assert len(open_recording(tmp_path / "drive")) == 2  # bad frames are not recorded


def test_serve_refuses_at_start_what_it_can_never_drive(tmp_path):
    donkey = tmp_path / "donkey.pt"
    ckpt = torch.load(untrained(tmp_path, "pilotnet", "donkey"), weights_only=True)
    ckpt["convention"] = SteeringConvention("normalized", "right").as_dict()  # no full-lock angle
    resaved(donkey, ckpt)
    with pytest.raises(SteerlabError, match=r"donkey.pt cannot drive the simulator: it predicts normalized "
                                            r"steering without a full-lock angle"):
        DriveSession(Pilot(donkey), 4.0, tmp_path / "drive", donkey)
    with pytest.raises(SteerlabError, match=r"model 'pilotnet' cannot drive the simulator: crop \(268, 0, 0, 0\) "
                                            r"removes the whole 320x160 frame"):
        DriveSession(Pilot(untrained(tmp_path, "pilotnet", "ch2")), 4.0, tmp_path / "drive")
    assert not (tmp_path / "drive").exists()
    ckpt["convention"]["full_lock"] = float(np.radians(25))  # a donkeycar whose full lock is known drives
    resaved(donkey, ckpt)
    DriveSession(Pilot(donkey), 4.0)


def test_export_command(tmp_path, capsys):
    from steerlab.cli import main

    ckpt = untrained(tmp_path, "lstm")
    assert main(["export", str(ckpt), "--out", str(tmp_path / "out" / "lstm.onnx")]) == 0
    assert [p.name for p in (tmp_path / "out").iterdir()] == ["lstm.onnx"]  # no sidecar: one file
    assert "preprocessing and statistics in its metadata" in capsys.readouterr().out
    assert main(["export", str(tmp_path / "missing.pt"), "--out", str(tmp_path / "m.onnx")]) == 2
    assert "missing.pt: checkpoint not found" in capsys.readouterr().err
