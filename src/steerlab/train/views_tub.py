"""The views a config trains on, written as a donkeycar tub for another trainer (donkeycar's own: `donkey train
--tub TUB,VIEWS`): every record warped through the tub's fisheye to the view `train.views` draws for it (a car moved
and turned on the flat floor), labelled with the steering back to the recorded path as steerlab labels it
(`sources.view_labels`), its throttle kept. The same extra frames steerlab's views models see."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

from steerlab.data.recording import SteeringConvention
from steerlab.data.tub import is_tub
from steerlab.data.views import lens_of, warp
from steerlab.data.writer import TubWriter
from steerlab.errors import SteerlabError
from steerlab.train.config import TrainConfig
from steerlab.train.sources import check_views, main_recording, prepare_dataset, steering_ahead, view_labels


def write_views_tub(cfg: TrainConfig, out: str | Path, keep: set[int] | None = None, progress: bool = True) -> Path:
    """The views of `cfg` (its data a donkeycar tub, its `train.views` not empty) of the records `keep` (record
    `_index` values; None: every record of the config's range), written as a tub at the tub's own resolution into
    `out`: each view of the list in turn (its draws fixed by its place there), each view's records a session that
    starts a second after the last."""
    from tqdm import tqdm

    rec = main_recording(cfg)  # a path that is not there is said as every command says it
    if not is_tub(Path(cfg.data)):
        raise SteerlabError(f"{cfg.data}: the views are written as a donkeycar tub, for donkeycar's trainer; the "
                            "config's data must be a donkeycar tub")
    if not cfg.train.views:
        raise SteerlabError(f"{cfg.data}: the config has no train.views to write: give train.views (the tub "
                            "defaults have them when the config names no model and the reader gives the car's "
                            "full-lock angle, e.g. reader.full_lock_deg=25)")
    check_views(cfg, rec)
    ds = prepare_dataset(cfg, progress=progress)
    lens, conv = lens_of(rec, cfg.train.calibration), SteeringConvention(**ds.meta["convention"])
    ahead = steering_ahead(ds, cfg.train.target_shift_s)
    records = [i for i in range(len(rec)) if keep is None or int(rec.frame_ids[i]) in keep]
    writer = TubWriter(out, math.degrees(rec.convention.full_lock))
    t0 = rec.timestamps_ns[0]
    gap = int(rec.timestamps_ns[records[-1]] - t0) + 1_000_000_000 if records else 0  # each view a second later
    with tqdm(total=len(records) * len(cfg.train.views), desc="views", unit="frame",
              disable=None if progress else True) as bar:
        for k, view in enumerate(cfg.train.views):
            view = replace(view, draw=k)
            shift, yaw = view.offsets(len(ds))  # the draws training's compile of this view makes
            angle = view_labels(ds, ahead, view, cfg.train, conv)  # the tub's unit: the servo, positive right
            for n, i in enumerate(records):
                frame = warp(rec.load_frame(i), rec.geometry, lens, float(shift[i]), float(yaw[i]))
                writer.add(frame, k * gap + int(rec.timestamps_ns[i] - t0),
                           -float(angle[i]) * rec.convention.full_lock, float(rec.throttle[i]), new_session=n == 0)
                bar.update()
    return writer.close()
