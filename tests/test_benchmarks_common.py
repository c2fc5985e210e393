"""benchmarks/common.py, what the timings share: the median timer and the JSON report every timing writes."""

import json
import time

import numpy as np

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
