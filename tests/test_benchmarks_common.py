"""benchmarks/common.py, what the timings and the studies share: the median timer, the JSON report every timing
writes, and the expert's recordings of a suite's places that replay is compared on."""

import importlib.util
import json
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location("benchmarks_common", ROOT / "benchmarks" / "common.py")
common = importlib.util.module_from_spec(spec)
spec.loader.exec_module(common)


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


def test_the_expert_is_recorded_on_every_place_of_a_suite_once(tmp_path):
    """The road suite's roads (the track suite's tracks go the same way, through the registry of worlds)."""
    from steerlab.data.readers import open_recording
    from steerlab.sim.worlds import WORLDS

    recs = common.record_expert("road", tmp_path, 0.01)
    roads = WORLDS["road"].suite_options().drives()
    first = tmp_path / "expert" / "country-9101"
    assert list(recs) == roads and recs[roads[0]] == first
    assert len(open_recording(first)) == 12  # 0.01 min at 20 frames/s
    (tmp_path / "replay" / "country-9101").mkdir(parents=True)
    stamp = (first / "minutes.json").stat().st_mtime_ns
    common.record_expert("road", tmp_path, 0.01)  # reused, with its replays
    assert (first / "minutes.json").stat().st_mtime_ns == stamp and (tmp_path / "replay" / "country-9101").exists()
    common.record_expert("road", tmp_path, 0.02)  # other minutes: recorded anew, the old replays deleted
    assert len(open_recording(first)) == 24 and not (tmp_path / "replay" / "country-9101").exists()
