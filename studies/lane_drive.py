"""Where a model leaves the lane, frame by frame: one drive of a checkpoint on a track of the track world (`steerlab
sim drive --world track`, the same options), each frame's steering beside the racing expert's from the same pose (pure
pursuit of the lane centre, `TrackWorld.expert_steering`: the label the pose frames and DAgger give there) and, for a
model with a lane head, the lane the head sees beside the world's true lane there.

Per frame (`OUT/frames.csv`): the place on the lap, the speed, the true lane (the rear axle's offset from the lane
centre, m, left positive; the heading error, rad; the lane's curvature, 1/m, positive turning left), the lane the
head sees (empty without a lane head), the steering sent (the model's convention) and as a road-wheel angle (rad,
positive left) beside the expert's, and whether the car was put back after it. `OUT/lane_drive.md`: where on the lap
the car was put back, and per 2 m of the lap the mean absolute true offset, heading and curvature beside the head's
errors, and the mean road-wheel angle sent beside the expert's and their mean absolute difference; `OUT/before.png`:
the frames of the last second before the second put-back (the first lap starts from rest; the first where there is
one only), every fourth up to the last, each with its place, true and seen offset, steering sent and the expert's;
the drive's own files (`trajectory.csv`, `drive.json`, `frames.png`) beside them. The model's answers are compared
with the lane and pose of the frame it saw: a drive with `--latency` is refused.

python -m studies.lane_drive CHECKPOINT --seed 9505 [--style taped] [--minutes 2] [--max-throttle 1]
    [--throttle-scale 1.2] [--throttle-floor 0.2] [--steer-by lane] [--out runs/lane-drive]
"""

from __future__ import annotations

import csv
import math
from collections import deque
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from steerlab.cli import path_option, run_script, script_parser
from steerlab.options import option
from steerlab.sim.track.run import checkpoint_pilot, drive
from steerlab.sim.track.world import TrackDriveOptions
from studies.common import ROOT, machine

BIN_M = 2.0  # the lap's stretches the errors are averaged over
BEFORE_S = 1.0  # the frames shown before a put-back


@dataclass(frozen=True)
class LaneDrive(TrackDriveOptions):
    out: str = option(str(ROOT / "runs" / "lane-drive"), path="folder", help="the study's folder")

    @classmethod
    def related(cls, v):
        yield from super().related(v)
        if v.latency:
            yield "latency", "0 here (the model's answers are compared with the lane and pose of the frame it saw)"


class Seeing:
    """The pilot of `checkpoint_pilot`, its every answer's lane (its head's; NaN without one) and steering kept, and the
    frames of the last BEFORE_S seconds before each put-back (the drive resets the pilot then)."""

    def __init__(self, inner, fps: float):
        self.inner, self.seen, self.before = inner, [], []
        self.recent = deque(maxlen=int(BEFORE_S * fps))
        for name in ("name", "geometry", "source", "convention", "car"):
            if hasattr(inner, name):
                setattr(self, name, getattr(inner, name))

    def step(self, frame, speed=None):
        controls = self.inner.step(frame, speed)
        lane = self.inner.part.controls.lane or (math.nan,) * 3
        self.seen.append((*(float(v) for v in lane), float(controls.steering)))
        self.recent.append((len(self.seen) - 1, frame.copy()))
        return controls

    def reset(self) -> None:
        if self.recent:
            self.before.append(list(self.recent))
            self.recent.clear()
        self.inner.reset()

    def close(self) -> None:
        close = getattr(self.inner, "close", None)
        if callable(close):
            close()


def _number(value: float, digits: int = 3) -> str:
    return "-" if math.isnan(value) else f"{value:.{digits}f}"


def stretch_rows(rows: list[dict], lap_m: float) -> list[str]:
    """Per BIN_M of the lap: frames, the mean |true| offset, heading, curvature and the head's mean absolute errors
    ("-" without a lane head), the mean road-wheel angle sent and the expert's, their mean absolute difference, and the
    put-backs."""
    lines = []
    for lo in np.arange(0.0, lap_m, BIN_M):
        here = [r for r in rows if lo <= r["place_m"] < lo + BIN_M]
        if not here:
            continue

        def mean(key, minus=None, signed=False):  # the mean |value| (|value - minus|: an error), or the mean value
            values = [r[key] - (r[minus] if minus else 0.0) for r in here]
            return _number(float(np.mean(values if signed else np.abs(values))))

        lines.append(f"| {lo:.0f}-{min(lo + BIN_M, lap_m):.0f} | {len(here)} | {mean('offset_m')} | "
                     f"{mean('seen_offset_m', 'offset_m')} | {mean('heading_rad')} | "
                     f"{mean('seen_heading_rad', 'heading_rad')} | {mean('curvature')} | "
                     f"{mean('seen_curvature', 'curvature')} | {mean('road_wheel', signed=True)} | "
                     f"{mean('expert_road_wheel', signed=True)} | {mean('road_wheel', 'expert_road_wheel')} | "
                     f"{sum(r['put_back'] for r in here)} |")
    return lines


def strip(frames: list, rows: list[dict], path: Path) -> None:
    """Every fourth frame of `frames` ((index, BGR) pairs), twice its size, with its place, offsets and road-wheel
    angles (the model's, the expert's) written on."""
    tiles = []
    for k, frame in frames[::-4][:6][::-1]:  # the last frame, and every fourth before it
        tile = cv2.resize(frame, (frame.shape[1] * 2, frame.shape[0] * 2), interpolation=cv2.INTER_NEAREST)
        r = rows[k]
        seen = "-" if math.isnan(r["seen_offset_m"]) else f"{100 * r['seen_offset_m']:+.0f}"
        for line, text in enumerate((f"{r['place_m']:.1f} m  {r['speed']:.1f} m/s",
                                     f"offset {100 * r['offset_m']:+.0f} cm, seen {seen}",
                                     f"steer {r['road_wheel']:+.2f}, expert {r['expert_road_wheel']:+.2f}")):
            for colour, width in (((0, 0, 0), 3), ((255, 255, 255), 1)):  # white on a black outline
                cv2.putText(tile, text, (4, 16 + 16 * line), cv2.FONT_HERSHEY_SIMPLEX, 0.45, colour, width,
                            cv2.LINE_AA)
        tiles.append(tile)
    tiles += [np.zeros_like(tiles[0])] * (-len(tiles) % 3)
    cv2.imwrite(str(path), np.concatenate([np.concatenate(tiles[i:i + 3], 1) for i in range(0, len(tiles), 3)], 0))


def parser():
    p = script_parser(__spec__.name, __doc__, LaneDrive)
    path_option(p, "checkpoint", kind="file", help="a checkpoint (.pt or .onnx); one with a lane head "
                "(train.lane_weight) shows the lane it sees too")
    return p


def main(a, o: LaneDrive) -> None:
    pilot = checkpoint_pilot(a.checkpoint, o)
    out = Path(o.out)
    seeing = Seeing(pilot, o.fps)
    ticks = []

    def on_step(t):  # the pose the frame was rendered from: its true lane and the expert's steering there
        w = t.world
        ticks.append((w.s % w.track.length, w.state.v, t.offset, t.heading, float(w.track.curvature(w.s)), t.model,
                      t.expert, t.intervention))

    result = drive(seeing, out, o, progress=True, plot=False, on_step=on_step)
    rows = [{"tick": k, "place_m": place, "speed": v, "offset_m": offset, "heading_rad": heading,
             "curvature": curvature, "seen_offset_m": seen[0], "seen_heading_rad": seen[1], "seen_curvature": seen[2],
             "steering": seen[3], "road_wheel": wheel, "expert_road_wheel": expert,
             "put_back": int(k + 1 < len(ticks) and ticks[k + 1][-1])}
            for k, ((place, v, offset, heading, curvature, wheel, expert, _), seen)
            in enumerate(zip(ticks, seeing.seen, strict=True))]
    with open(out / "frames.csv", "w", newline="") as f:
        w = csv.DictWriter(f, list(rows[0]))
        w.writeheader()
        w.writerows({k: "" if isinstance(v, float) and math.isnan(v) else v for k, v in r.items()} for r in rows)
    places = [f"{r['place_m']:.1f}" for r in rows if r["put_back"]]
    lines = [f"machine: {machine()}", "", f"{a.checkpoint} on {o.style} track {o.seed} ({result.lap_m:.1f} m lap), "
             f"{o.minutes:g} min, steering by its {o.steer_by}: {result.laps} laps, {result.clean_laps} clean, "
             f"{result.off_track} put back, at {', '.join(places) or '-'} m of the lap.", "",
             "| lap [m] | frames | offset [m] | seen offset error [m] | heading [rad] | seen heading error [rad] | "
             "curvature [1/m] | seen curvature error [1/m] | road wheel [rad] | the expert's [rad] | "
             "road wheel error [rad] | put back |", "|" + "---|" * 12,
             *stretch_rows(rows, result.lap_m)]
    (out / "lane_drive.md").write_text("\n".join(lines) + "\n")
    if seeing.before:
        strip(seeing.before[min(1, len(seeing.before) - 1)], rows, out / "before.png")
    seeing.close()
    print("\n".join(lines))
    print(f"wrote {out / 'frames.csv'}, {out / 'lane_drive.md'}" + (", before.png" if seeing.before else ""))


if __name__ == "__main__":
    run_script(parser(), main)
