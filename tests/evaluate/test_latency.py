"""`steerlab latency`: the table and files it writes, the thread limit inside the timed steps, ONNX Runtime."""

import csv

import cv2
import torch

from conftest import made
from steerlab.cli import main
from steerlab.evaluate.latency import COLUMNS, measure, synthetic_frames
from steerlab.export import export_onnx
from steerlab.pilot import Pilot


def test_cli_times_untrained_models_and_writes_the_table(tmp_path, capsys):
    assert main(["latency", "--models", "zero,pilotnet", "--frames", "5", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "| model | runtime | frame | threads |" in out and "| fits 20 Hz (50 ms) | headroom at 20 Hz |" in out
    with open(tmp_path / "latency.csv") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == COLUMNS
    assert [(r["model"], r["runtime"]) for r in rows] == [(m, rt) for m in ("zero", "pilotnet")
                                                          for rt in ("torch", "onnx")]
    for r in rows:
        assert (r["geometry"], r["width"], r["height"], r["threads"], r["frames"]) == ("donkey", "160", "120", "1",
                                                                                        "5")
        assert all(float(r[k]) > 0 for k in COLUMNS if k.endswith(("_ms", "_fps")) or k == "headroom_20hz")
        assert float(r["pilot_median_ms"]) >= float(r["model_median_ms"])
        assert r["fits_20hz"] == str(float(r["pilot_p99_ms"]) <= 50)
    assert (tmp_path / "latency.md").read_text() in out


def test_threads_are_held_inside_the_timed_steps_and_restored(tmp_path):
    pilot = Pilot(made(tmp_path))
    seen, step = [], pilot.step
    pilot.step = lambda *a: seen.append((torch.get_num_threads(), cv2.getNumThreads())) or step(*a)
    before = torch.get_num_threads(), cv2.getNumThreads()
    torch.set_num_threads(2)
    try:
        r = measure(pilot, synthetic_frames("sim"), count=3, threads=1, warmup=2)
        assert seen == [(1, 1)] * 5 and torch.get_num_threads() == 2  # restored
    finally:
        torch.set_num_threads(before[0])
    assert cv2.getNumThreads() == before[1]
    assert set(r) == {"pilot", "model"} and all(v > 0 for part in r.values() for v in part.values())


def test_onnx_runtime_with_its_threads(tmp_path, capsys):
    onnx = export_onnx(made(tmp_path), tmp_path / "m.onnx")
    assert Pilot(onnx, threads=1).net.session.get_session_options().intra_op_num_threads == 1
    assert main(["latency", str(onnx), "--runtime", "onnx", "--frames", "3", "--out", str(tmp_path / "o")]) == 0
    with open(tmp_path / "o" / "latency.csv") as f:
        rows = list(csv.DictReader(f))
    assert [(r["model"], r["runtime"], r["geometry"], r["source"]) for r in rows] == [
        ("pilotnet", "onnx", "sim", str(onnx))]
    assert "| pilotnet (m.onnx) | onnx | 320x160 | 1 |" in capsys.readouterr().out
