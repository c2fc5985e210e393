"""Round trip of the simulator drive server: a python-socketio client (the simulator's protocol, over a
websocket on loopback) sends telemetry with the real 320x160 frames of the Udacity simulator recording and
waits for each steer command.

python benchmarks/bench_serve.py [CHECKPOINT_OR_ONNX ...]
Without arguments: untrained pilotnet on the simulator preset (the cost does not depend on the weights), as a
.pt checkpoint and exported to ONNX. Target: p99 <= 20 ms for pilotnet.
"""

import base64
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import warnings

import numpy as np

with warnings.catch_warnings():  # eventlet, imported by python-socketio 4, announces its maintenance mode
    warnings.simplefilter("ignore")
    import socketio

from _common import SHARED, machine

from steerlab.checkpoint import save_checkpoint
from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.readers import open_recording
from steerlab.data.simlog import SIM_CONVENTION
from steerlab.export import export_onnx
from steerlab.models import create_model

FRAMES, WARMUP = 500, 20
SIM = SHARED / "udacity-sim-track1"


def pilotnet(folder: Path) -> Path:
    cfg = PreprocessConfig.from_dict({"preset": "sim"})
    model_cfg = {"in_channels": 1, "height": cfg.height, "width": cfg.width}
    path = folder / "pilotnet.pt"
    save_checkpoint(path, create_model("pilotnet", **model_cfg), model_cfg, cfg, {"mean": [0.0], "std": [1.0]},
                    SIM_CONVENTION, {}, geometry="sim")
    return path


def round_trips(model: Path, images: list[str]) -> np.ndarray:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    server = subprocess.Popen([sys.executable, "-m", "steerlab", "serve", str(model), "--port", str(port)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    client, got = socketio.Client(), threading.Event()
    client.on("steer", lambda data: got.set())
    try:
        for _ in range(200):
            try:
                client.connect(f"http://127.0.0.1:{port}", transports=["websocket"])
                break
            except socketio.exceptions.ConnectionError:
                time.sleep(0.1)
        got.wait(10)
        ms = []
        for i, image in enumerate(images):
            got.clear()
            t = time.perf_counter()
            client.emit("telemetry", {"steering_angle": "0", "throttle": "0.2", "speed": f"{9 + i % 3}",
                                      "image": image})
            if not got.wait(10):
                raise RuntimeError("no answer from the server")
            ms.append((time.perf_counter() - t) * 1000)
        return np.array(ms[WARMUP:])
    finally:
        client.disconnect()
        server.terminate()
        server.wait()


def main() -> None:
    if not (SIM / "driving_log.csv").exists():
        print(f"skipped: {SIM} not found (the benchmark replays its frames)")
        return
    rec = open_recording(SIM, f"0:{FRAMES}")
    images = [base64.b64encode(Path(p).read_bytes()).decode() for p in rec.frames["center"]]
    print(f"machine: {machine()}; {len(images)} simulator frames 320x160 JPEG, socket.io over websocket, loopback")
    with tempfile.TemporaryDirectory() as tmp:
        models = [Path(a) for a in sys.argv[1:]]
        if not models:
            pt = pilotnet(Path(tmp))
            models = [pt, export_onnx(pt, Path(tmp) / "pilotnet.onnx")]
        for model in models:
            ms = round_trips(model, images)
            print(f"{model.name:<16} round trip p50 {np.percentile(ms, 50):6.2f} ms  "
                  f"p99 {np.percentile(ms, 99):6.2f} ms  max {ms.max():6.2f} ms  (target p99 <= 20 ms)")


if __name__ == "__main__":
    main()
