"""Round trip of the simulator drive server: a python-socketio client (the simulator's protocol, over a
websocket on loopback) sends telemetry with the real 320x160 frames of the Udacity simulator recording and
waits for each steer command. The baseline, measured in the same run: the same messages answered in this process
by the server's own session (`serve.DriveSession.command`: base64 and JPEG decode, the pilot, the speed
controller), so that round trip / in process is what the server's process, socket.io and the websocket add.

python benchmarks/bench_serve.py [CHECKPOINT_OR_ONNX ...] [--json PATH]
Without checkpoints: untrained pilotnet on the simulator preset (the cost does not depend on the weights), as a
.pt checkpoint and exported to ONNX. Target: p99 <= 20 ms for pilotnet.
"""

import base64
import socket
import subprocess
import sys
import tempfile
import threading
import time
import warnings
from pathlib import Path

import numpy as np

with warnings.catch_warnings():  # eventlet, imported by python-socketio 4, announces its maintenance mode
    warnings.simplefilter("ignore")
    import socketio

from common import Report, SHARED, arguments, each_ms, machine, guarded  # noqa: E402

from steerlab.checkpoint import save_checkpoint  # noqa: E402
from steerlab.data.preprocess import PreprocessConfig  # noqa: E402
from steerlab.data.readers import open_recording  # noqa: E402
from steerlab.data.simlog import SIM_CONVENTION  # noqa: E402
from steerlab.export import export_onnx  # noqa: E402
from steerlab.models import create_model  # noqa: E402
from steerlab.pilot import Pilot  # noqa: E402
from steerlab.serve import DriveSession, ServeOptions  # noqa: E402

FRAMES, WARMUP, TARGET_P99_MS = 500, 20, 20.0
SIM = SHARED / "udacity-sim-track1"


def pilotnet(folder: Path) -> Path:
    cfg = PreprocessConfig.from_dict({"preset": "sim"})
    model_cfg = {"in_channels": 1, "height": cfg.height, "width": cfg.width}
    path = folder / "pilotnet.pt"
    save_checkpoint(path, create_model("pilotnet", **model_cfg), model_cfg, cfg, {"mean": [0.0], "std": [1.0]},
                    SIM_CONVENTION, {}, geometry="sim")
    return path


def telemetry(i: int, image: str) -> dict:
    """The simulator's telemetry message of frame i."""
    return {"steering_angle": "0", "throttle": "0.2", "speed": f"{9 + i % 3}", "image": image}


def in_process(model: Path, images: list[str]) -> np.ndarray:
    """Milliseconds per message (after the warm-up) of the server's session answering it in this process."""
    session = DriveSession(Pilot(model), ServeOptions().set_speed, source=model)
    return each_ms(lambda i: session.command(telemetry(i, images[i])), range(len(images)))[0][WARMUP:]


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

        def ask(i: int) -> None:
            got.clear()
            client.emit("telemetry", telemetry(i, images[i]))
            if not got.wait(10):
                raise RuntimeError("no answer from the server")

        return each_ms(ask, range(len(images)))[0][WARMUP:]
    finally:
        client.disconnect()
        server.terminate()
        server.wait()


def main() -> None:
    ap = arguments(__doc__)
    ap.add_argument("models", nargs="*", metavar="CHECKPOINT_OR_ONNX", help="models to serve (default: an untrained "
                    "pilotnet, .pt and .onnx)")
    args = ap.parse_args()
    if not (SIM / "driving_log.csv").exists():
        print(f"skipped: {SIM} not found (the benchmark replays its frames)")
        return
    report = Report(__file__, {"frames": FRAMES, "warmup": WARMUP, "target_p99_ms": TARGET_P99_MS,
                               "models": args.models or ["pilotnet.pt", "pilotnet.onnx"]}, args.json)
    rec = open_recording(SIM, f"0:{FRAMES}")
    images = [base64.b64encode(Path(p).read_bytes()).decode() for p in rec.frames["center"]]
    print(f"machine: {machine()}; {len(images)} simulator frames 320x160 JPEG, socket.io over websocket, loopback")
    with tempfile.TemporaryDirectory() as tmp:
        models = [Path(a) for a in args.models]
        if not models:
            pt = pilotnet(Path(tmp))
            models = [pt, export_onnx(pt, Path(tmp) / "pilotnet.onnx")]
        for model in models:
            base, ms = in_process(model, images), round_trips(model, images)
            p50, p99, b50 = np.percentile(ms, 50), np.percentile(ms, 99), np.percentile(base, 50)
            print(f"{model.name:<16} round trip p50 {p50:6.2f} ms  p99 {p99:6.2f} ms  max {ms.max():6.2f} ms  "
                  f"(in process p50 {b50:6.2f} ms: x{p50 / b50:.2f}; target p99 <= {TARGET_P99_MS:g} ms: "
                  f"x{p99 / TARGET_P99_MS:.2f})")
            report.add(model.name, round_trip_p50_ms=p50, round_trip_p99_ms=p99, round_trip_max_ms=ms.max(),
                       in_process_p50_ms=b50, in_process_p99_ms=np.percentile(base, 99),
                       round_trip_vs_in_process=p50 / b50, p99_vs_target=p99 / TARGET_P99_MS)
    report.write()


if __name__ == "__main__":
    guarded(main)
