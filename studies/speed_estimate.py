"""The speed that replay estimates from a recording's frames (`data.speed.estimate_speed`: optical flow of the
road plane through the camera's height and pitch), against the recorded speed where there is one.

python studies/speed_estimate.py
Recordings: two synthetic drives made here (the camera geometry is exactly known), the Udacity simulator lap,
CH2 (no speed signal) and the donkeycar hall tub (no speed signal) from ../shared/data.
"""

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from common import SHARED  # noqa: E402

from steerlab.data.geometry import CAMERAS  # noqa: E402
from steerlab.data.readers import open_recording  # noqa: E402
from steerlab.data.speed import estimate_speed  # noqa: E402
from steerlab.sim.road.run import record  # noqa: E402
from steerlab.sim.road.world import RecordOptions  # noqa: E402


def main() -> None:
    argparse.ArgumentParser(description=__doc__.split("\n\n")[0]).parse_args()  # it takes no arguments
    print("| recording | estimated [m/s] | recorded, median [m/s] | seconds |\n|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        recordings = [
            ("synthetic twisty road, seed 11, 15 s", lambda: record(Path(tmp) / "twisty", RecordOptions(
             seed=11, minutes=0.25, road="twisty", drift=False, side_cameras=False), progress=False), None, None, None),
            ("synthetic country road, seed 3, 30 s", lambda: record(Path(tmp) / "country", RecordOptions(
             seed=3, minutes=0.5, drift=False, side_cameras=False), progress=False), None, None, None),
            ("Udacity simulator lap, rows 0-899", lambda: SHARED / "udacity-sim-track1" / "driving_log.csv",
             "0:900", None, None),
            ("Udacity CH2, frames 0-2399", lambda: SHARED / "udacity-ch2", "0:2400",
             SHARED / "udacity-ch2" / "CH2_final_evaluation.csv", None),
            ("Udacity CH2, frames 1800-2399", lambda: SHARED / "udacity-ch2", "1800:2400",
             SHARED / "udacity-ch2" / "CH2_final_evaluation.csv", None),
            ("donkeycar hall tub", lambda: SHARED / "donkeycar" / "hall", None, None, {"full_lock_deg": 25}),
        ]
        for name, path, frames, labels, reader in recordings:
            source = path()
            if not Path(source).exists():
                print(f"| {name} | skipped: {source} not found | | |")
                continue
            rec = open_recording(source, frames, labels, reader)
            start = time.perf_counter()
            estimate = estimate_speed(rec, CAMERAS[rec.geometry])
            recorded = "none" if rec.speed is None else f"{np.median(rec.speed):.2f}"
            print(f"| {name} | {estimate:.2f} | {recorded} | {time.perf_counter() - start:.1f} |")


if __name__ == "__main__":
    main()
