"""benchmarks/common.py, what the timings share: the median timer and the JSON report every timing writes."""

import json
import time

import numpy as np
import pytest

from benchmarks import common
from studies.common import ROOT


def test_median_seconds_times_the_runs_after_the_warmup(monkeypatch):
    calls = []
    assert common.timed(lambda: time.sleep(0.01)) >= 0.01
    durations = iter([5.0, 1.0, 3.0])
    monkeypatch.setattr(common, "timed", lambda fn: next(durations))
    assert common.median_seconds(lambda: calls.append(1), runs=3, warmup=2) == 3.0
    assert len(calls) == 2  # the warm-up calls, not timed
    monkeypatch.setattr(common, "timed", lambda fn: 2.0)
    assert common.per_second(lambda: None, 10, runs=1, warmup=0) == 5.0


def test_a_report_writes_the_machine_the_settings_and_every_number_as_json(tmp_path):
    assert common.Report("benchmarks/bench_x.py", {}).path == ROOT / "runs" / "benchmarks" / "bench_x.json"
    report = common.Report("benchmarks/bench_x.py", {"frames": np.int64(3), "runs": (1, 2)}, tmp_path / "x.json")
    report.add("country", fps=np.float64(10.0), ratio=float("nan"))
    report.add("country", decode_fps=20)
    data = json.loads(report.write().read_text())
    assert data["script"] == "bench_x" and data["machine"] == common.machine()
    assert data["settings"] == {"frames": 3, "runs": [1, 2]}
    assert data["results"] == {"country": {"fps": 10.0, "ratio": None, "decode_fps": 20}}  # NaN: not measured
    assert set(data["load_average"]) == {"start", "end"}


def test_donkeycars_training_pass_is_timed_apart_from_its_validation(monkeypatch, tmp_path):
    """bench_vs_donkeycar reads donkeycar's training pass from the lines Keras prints (their shape as donkeycar 5.3
    prints them): an epoch's batch lines k/N until N-1, its N/N line only after the validation. Hand-computed: epoch
    2 starts at 3.0, its batch 3 of 4 ends at 4.6, its batches take 0.5 and 0.6 s (median 0.55): a pass of 2.15 s,
    an epoch of 2.5 s (5.5 - 3.0)."""
    from benchmarks import bench_vs_donkeycar as bench

    said = [(0.0, "INFO:donkeycar.pipeline.training:Records # Training 512"),
            (0.0, "INFO:donkeycar.pipeline.training:Records # Validation 128")]
    for start, batches, end in ((0.0, (1.0, 1.5, 2.0, 2.9), 3.0), (3.0, (3.5, 4.0, 4.6, 5.5), 5.5)):
        said.append((start, "Epoch 1/2"))
        said += [(t, f"{k}/4 [{'=' * k}>{'.' * (4 - k)}] - ETA: 1s - loss: 0.3") for k, t in enumerate(batches, 1)]
        said.append((end, "4/4 [====] - 3s 600ms/step - loss: 0.2 - val_loss: 0.1"))
    monkeypatch.setattr(bench, "donkey_python", lambda: tmp_path / "bin" / "python")
    monkeypatch.setattr(bench, "donkey_car", lambda python, car: car.mkdir(parents=True) or car)
    monkeypatch.setattr(bench, "run", lambda cmd, log, cwd=None: ([(t, line + "\n") for t, line in said], 900.0))
    r = bench.donkeycar_side([tmp_path / "tub"], 2, tmp_path)
    assert (r["records"], r["validation_records"]) == (512, 128)
    assert r["train_pass_s"] == pytest.approx(2.15) and r["epoch_s"] == pytest.approx(2.5)
    assert r["first_epoch_s"] == pytest.approx(3.0) and r["train_records_per_s"] == pytest.approx(512 / 2.15)
