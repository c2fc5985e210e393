"""Regenerate the figures of docs/ARCHITECTURE.md: a preprocessed synthetic frame next to a preprocessed real
frame for each camera geometry (needs ../shared/data).

python docs/figures.py
"""

from pathlib import Path

import cv2
import numpy as np

from steerlab.data.preprocess import PreprocessConfig, crop_resize
from steerlab.data.readers import open_recording
from steerlab.sim.render import Renderer
from steerlab.sim.road import LANE_CENTER, Road

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[1] / "shared" / "data"


def side_by_side(real_bgr, preset: str, out: Path) -> None:
    cfg = PreprocessConfig.from_dict({"preset": preset})
    road = Road(2, "country", 2000)
    x, y, psi = road.pose(40.0, LANE_CENTER)
    synthetic = Renderer(road, preset).render(x, y, psi, 40.0)
    pair = [cv2.resize(crop_resize(f, cfg), (400, 132), interpolation=cv2.INTER_NEAREST) for f in (real_bgr, synthetic)]
    cv2.imwrite(str(out), np.hstack([pair[0], np.full((132, 8, 3), 255, np.uint8), pair[1]]))


def main() -> None:
    ch2 = open_recording(DATA / "udacity-ch2", "0:2400", DATA / "udacity-ch2" / "CH2_final_evaluation.csv")
    side_by_side(ch2.load_frame(1000), "ch2", HERE / "img" / "geometry_ch2.png")
    sim = open_recording(DATA / "udacity-sim-track1")
    side_by_side(sim.load_frame(300), "sim", HERE / "img" / "geometry_sim.png")


if __name__ == "__main__":
    main()
