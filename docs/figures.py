"""Regenerate the figures of the docs.

python docs/figures.py                     # docs/architecture/road-world.md: a preprocessed synthetic frame next to a
                                           # preprocessed real frame per camera geometry, the donkeycar crop
                                           # (needs ../shared/data)
python docs/figures.py open-vs-closed runs/experiment-synthetic runs/experiment-recipe
                                           # docs/results/closing-the-gap.md: validation RMSE vs autonomy,
                                           # before and after
python docs/figures.py track-race runs/readme/drive
                                           # README: a track drive's plot beside what its camera saw, from
                                           # steerlab sim drive CKPT --world track --seed 9503 --minutes 1
                                           #   --max-throttle 1 --throttle-scale 1.2 --out runs/readme/drive
python docs/figures.py varied-rooms        # docs/results/racing.md: what the camera of `sim record --world track
                                           # --vary` sees on tracks 1-12, a third of the way round each
"""

import csv
import sys
from pathlib import Path

import cv2
import numpy as np

from steerlab.data.geometry import camera, shift_view
from steerlab.data.preprocess import PreprocessConfig, crop_resize
from steerlab.data.readers import open_recording
from steerlab.evaluate.plots import plot_open_vs_closed
from steerlab.sim.road.render import Renderer
from steerlab.sim.road.road import LANE_CENTER, Road

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[1] / "shared" / "data"


def side_by_side(real_bgr, preset: str, out: Path) -> None:
    cfg = PreprocessConfig.from_dict({"preset": preset})
    road = Road(2, "country", 2000)
    x, y, psi = road.pose(40.0, LANE_CENTER)
    synthetic = Renderer(road, preset).render(x, y, psi, 40.0)
    pair = [cv2.resize(crop_resize(f, cfg), (400, 132), interpolation=cv2.INTER_NEAREST) for f in (real_bgr, synthetic)]
    cv2.imwrite(str(out), np.hstack([pair[0], np.full((132, 8, 3), 255, np.uint8), pair[1]]))


def views(real_bgr, out: Path) -> None:
    """A real CH2 frame seen from 0.5 m left, as recorded, 0.5 m right and turned 3 degrees left (preprocessed)."""
    cfg = PreprocessConfig.from_dict({"preset": "ch2"})
    cam = camera("ch2")
    frames = [shift_view(real_bgr, cam, 0.5, 0.0), real_bgr, shift_view(real_bgr, cam, -0.5, 0.0),
              shift_view(real_bgr, cam, 0.0, 3.0)]
    tiles = [cv2.resize(crop_resize(f, cfg), (300, 99), interpolation=cv2.INTER_AREA) for f in frames]
    gap = np.full((99, 6, 3), 255, np.uint8)
    cv2.imwrite(str(out), np.hstack([tiles[0], gap, tiles[1], gap, tiles[2], gap, tiles[3]]))


def donkey(frames: list, out: Path) -> None:
    """donkeycar frames (160x120) with the donkey crop marked, each beside its preprocessed image."""
    cfg = PreprocessConfig.from_dict({"preset": "donkey", "color": "rgb"})
    rows = []
    for bgr in frames:
        raw = cv2.resize(bgr, (320, 240), interpolation=cv2.INTER_NEAREST)
        cv2.rectangle(raw, (0, 2 * cfg.crop[0]), (319, 239), (0, 0, 255), 2)
        pre = cv2.resize(crop_resize(bgr, cfg), (400, 132), interpolation=cv2.INTER_NEAREST)
        pre = np.vstack([pre, np.full((240 - 132, 400, 3), 255, np.uint8)])
        rows.append(np.hstack([raw, np.full((240, 8, 3), 255, np.uint8), pre]))
    cv2.imwrite(str(out), np.vstack([rows[0], np.full((8, rows[0].shape[1], 3), 255, np.uint8), rows[1]]))


def main() -> None:
    ch2 = open_recording(DATA / "udacity-ch2", "0:2400", DATA / "udacity-ch2" / "CH2_final_evaluation.csv")
    side_by_side(ch2.load_frame(1000), "ch2", HERE / "img" / "geometry_ch2.png")
    views(ch2.load_frame(1000), HERE / "img" / "views_ch2.png")
    sim = open_recording(DATA / "udacity-sim-track1")
    side_by_side(sim.load_frame(300), "sim", HERE / "img" / "geometry_sim.png")
    tubs = [open_recording(DATA / "donkeycar" / t, options={"skip_missing": True}) for t in ("hall", "taped-track")]
    donkey([tubs[0].load_frame(1500), tubs[1].load_frame(500)], HERE / "img" / "geometry_donkey.png")


def open_vs_closed(before: str, after: str) -> None:
    """The trained models of two experiments (before and after the closed-loop recipe), ablations left out."""
    tables = {}
    for name, folder in (("before: one country road, no recovery data", before), ("after: the recipe", after)):
        with open(Path(folder) / "table.csv") as f:
            tables[name] = [r for r in csv.DictReader(f) if float(r["epoch_mean"]) > 0 and r["label"] == r["model"]]
    plot_open_vs_closed(HERE / "img" / "open_vs_closed.png", tables)


def track_race(drive: str) -> None:
    """A track drive's plot (track.png) and its camera's frames (frames.png) side by side, at the plot's height."""
    paths = [Path(drive) / name for name in ("track.png", "frames.png")]
    missing = [str(p) for p in paths if not p.is_file()]
    if missing:
        sys.exit(f"error: {', '.join(missing)} not found: give the folder of a track drive "
                 "(steerlab sim drive CKPT --world track --out DIR)")
    plot, frames = (cv2.imread(str(p)) for p in paths)
    h = round(plot.shape[0] * 0.75)
    plot = cv2.resize(plot, (round(plot.shape[1] * 0.75), h), interpolation=cv2.INTER_AREA)
    frames = cv2.resize(frames, (round(frames.shape[1] * h / frames.shape[0]), h), interpolation=cv2.INTER_AREA)
    cv2.imwrite(str(HERE / "img" / "track_race.jpg"), np.hstack([plot, np.full((h, 8, 3), 255, np.uint8), frames]),
                [cv2.IMWRITE_JPEG_QUALITY, 88])


def varied_rooms() -> None:
    """The frame of a varied recording's camera (its jittered mount, at its JPEG quality) on the lane centre a
    third of the way round tracks 1-12, in two rows of six."""
    from steerlab.sim.track.world import TrackRecordOptions, TrackWorld

    frames = []
    for seed in range(1, 13):
        o = TrackRecordOptions(seed=seed, vary=True)
        world = TrackWorld(seed, camera=o.camera(), look=o.look())
        s = world.track.length / 3
        frame = world.renderer.render(*(float(v) for v in world.track.pose(s)), s)
        jpeg = cv2.imencode(".jpg", frame, [cv2.IMWRITE_JPEG_QUALITY, o.look().jpeg_quality])[1]
        frames.append(cv2.imdecode(jpeg, cv2.IMREAD_COLOR))
    cv2.imwrite(str(HERE / "img" / "varied_rooms.jpg"), np.vstack([np.hstack(frames[:6]), np.hstack(frames[6:])]),
                [cv2.IMWRITE_JPEG_QUALITY, 90])


if __name__ == "__main__":
    if sys.argv[1:2] == ["open-vs-closed"]:
        open_vs_closed(*sys.argv[2:4])
    elif sys.argv[1:2] == ["track-race"]:
        track_race(sys.argv[2])
    elif sys.argv[1:2] == ["varied-rooms"]:
        varied_rooms()
    else:
        main()
