"""The third round's inputs (`python -m tests.rounds.run --round 3`), each a row as in round1.py, with its group:
the commands of the README's pages (docs/guide/commands.md, which the README links as its commands) with their
arguments misspelled, mistyped, swapped, missing, repeated or pointed at the wrong kind of file (A); the features
added since the second round: `train.views`, `train.calibration`, `train.recovery_s`, `cameras.register_camera`,
the studies `tub_replay` and `view_truth`, `train.lane_weight` and `--steer-by lane`, `--throttle-floor` and
`--throttle-scale`, the real tub wood-tape (B); real-world data mistakes: tubs, driving logs, label files and
calibrations edited or saved by hand in plausible wrong ways, values in other units (C); interrupted workflows and
outputs left half written, and the Python API with wrong types and units (D). The fixtures are the first round's
(OUT_DIR/fx) and a few more made by `setup`: an ONNX export, a calibration, predictions, a checkpoint with a lane
head, a track-world tub, configs of the tub fixtures."""

import json
import subprocess
import sys
from pathlib import Path


from tests.inputs import made
from tests.rounds import places
from tests.rounds.round3.common import W, CALIBRATION
from tests.rounds.round3.api import TRK_LONG, _d_rows
from tests.rounds.round3.commands import _a_rows
from tests.rounds.round3.data import _c_rows
from tests.rounds.round3.features import _b_rows


def _own_outputs(rows):
    """Every command line's output (--out, out=) a folder of its row's own: an output an earlier case wrote is
    refused as another's (a recording, a drive), which is not what a row tries."""
    for n, row in enumerate(rows):
        if "cli" not in row:
            continue
        argv = list(row["cli"])
        for i, a in enumerate(argv):
            if i and argv[i - 1] == "--out" and a.startswith(f"{W}/") and not a.endswith((".pt", ".onnx")):
                argv[i] = f"{a}-{n}"
            elif a.startswith(f"out={W}/"):
                argv[i] = f"{a}-{n}"
        row["cli"] = argv
    return rows


CASES = _own_outputs([*_a_rows(), *_b_rows(), *_c_rows(), *_d_rows()])


def setup():
    """The fixtures of the round beyond the first's: an ONNX export, a calibration (and one of 640x480), an empty
    calibration, predictions, a checkpoint with a lane head, a track-world tub (with its lane values), and configs of
    the tub and the track tub."""
    Fx, Wk = places.FIX, places.WORK
    from steerlab.export import export_onnx

    export_onnx(Fx / "a.pt", Fx / "m.onnx")
    (Fx / "cal.json").write_text(json.dumps(CALIBRATION))
    (Fx / "cal640.json").write_text(json.dumps({**CALIBRATION, "image_size": [640, 480]}))
    (Fx / "empty.json").write_bytes(b"")
    rows = (Fx / "ch2" / "labels.csv").read_text().splitlines()[1:]
    (Fx / "pred.csv").write_text("frame_id,steering_angle\n" + "".join(f"{r.split(',')[0]},0.0\n" for r in rows))
    made(Fx, "normalized", "right", "donkey", name="lane.pt", full_lock_deg=25, lane=True)
    Wk.mkdir(parents=True, exist_ok=True)
    p = subprocess.run([sys.executable, "-m", "steerlab", "sim", "record", "--world", "track", "--minutes", "0.1",
                        "--seed", "5", "--no-drift", "--out", str(Fx / "trk")], capture_output=True, text=True, cwd=Wk)
    if p.returncode:
        raise RuntimeError(f"the track tub: {p.stderr.strip()[-300:]}")
    (Fx / "tub.yaml").write_text(f"data: {Fx / 'tub'}\ncache: {places.ROOT / 'cache'}\nout: {Wk / 'run-tub'}\n"
                                 "reader: {full_lock_deg: 25}\nmodel: {name: pilotnet}\n"
                                 "split: {train: '0:6', val: '6:8'}\ntrain: {epochs: 1, batch_size: 2}\n")
    n = sum(1 for _ in open(Fx / "trk" / "catalog_0.catalog"))
    (Fx / "trk.yaml").write_text(f"data: {Fx / 'trk'}\ncache: {places.ROOT / 'cache'}\nout: {Wk / 'run-trk'}\n"
                                 "reader: {full_lock_deg: 25}\nmodel: {name: pilotnet}\n"
                                 f"split: {{train: '0:{n * 3 // 4}', val: '{n * 3 // 4}:{n - 10}'}}\n"
                                 "train: {epochs: 1, batch_size: 4}\n")
    Path(places.fill(TRK_LONG)).write_text((Fx / "trk.yaml").read_text().replace(
        "train: {epochs: 1, batch_size: 4}", "train: {epochs: 100000, batch_size: 4}").replace(
        str(Wk / "run-trk"), str(Wk / "run-trk-long")).replace(str(places.ROOT / "cache"), str(Wk / "cache-long")))
