"""What an intervention count means on a recording: replay of the human's own steering, of the human's steering
a few ticks late, and of steering straight, on the same frames and at the same speed as `steerlab replay`.

The human's own steering rebuilds the path exactly (0 interventions: the replay is consistent); a human who
reacts 0.1 or 0.2 s late and a driver who never steers bracket what a model's count means there.

python studies/replay_references.py --data ../shared/data/donkeycar/hall --range 4012:5015 \
    --reader skip_missing=true --reader full_lock_deg=25 --speed 2
python studies/replay_references.py --data ../shared/data/donkeycar/hall --range 4012:5015 \
    --reader skip_missing=true --reader full_lock_deg=25 --world track    # a small car's replay (replay/track.py)

With `--checkpoint` (repeatable) trained models drive beside the references. With `--world track --camera-variants`
every driver is replayed again through cameras that differ from the nominal one by -20 % and +20 % in the fisheye's
focal lengths, its distortion coefficients, its height and its pitch, and the drivers' order by interventions in
each is compared with the nominal camera's (Spearman's rank correlation): how much the ranking depends on a camera
that a real tub does not describe.
"""

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.stats import spearmanr

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from common import ARG, existing, machine, guarded  # noqa: E402

from steerlab.data.car import CARS  # noqa: E402
from steerlab.data.fisheye import DONKEY_FISHEYE  # noqa: E402
from steerlab.data.geometry import CAMERAS  # noqa: E402
from steerlab.data.readers import Source, reader_options  # noqa: E402
from steerlab.pilot import Controls, Pilot  # noqa: E402
from steerlab.sim.replay.run import replay_recording  # noqa: E402
from steerlab.sim.replay.track import TrackReplay  # noqa: E402
from steerlab.sim.replay.world import Replay  # noqa: E402
from steerlab.sim.track.track import LANE_WIDTH  # noqa: E402


class Scripted:
    """A pilot that answers tick k with the recorded steering of frame k - delay (or 0 for `None`)."""

    def __init__(self, rec, delay: int | None):
        self.rec, self.delay, self.k = rec, delay, 0
        self.name, self.source, self.geometry, self.convention = "reference", "reference", rec.geometry, rec.convention

    def reset(self) -> None:
        pass

    def step(self, frame, speed=None) -> Controls:
        self.k += 1
        if self.delay is None:
            return Controls(0.0)
        return Controls(float(self.rec.steering[min(max(self.k - 1 - self.delay, 0), len(self.rec) - 1)]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--range")
    ap.add_argument("--labels")
    ap.add_argument("--reader", action="append", default=[], help="reader option KEY=VALUE (repeatable)")
    ap.add_argument("--speed", type=ARG["speed"],
                    help="m/s (default: the recorded speed; --world track: from the throttle)")
    ap.add_argument("--world", choices=("road", "track"), default="road", help="the road replay (default) or the "
                    "small cars' (fisheye, speed from the throttle, the body leaving the lane)")
    ap.add_argument("--lane-width", type=ARG["positive"], default=LANE_WIDTH,
                    help=f"m, --world track (default {LANE_WIDTH})")
    ap.add_argument("--checkpoint", action="append", default=[], type=existing("checkpoint"),
                    help="a trained model to drive as well (repeatable)")
    ap.add_argument("--camera-variants", action="store_true", help="--world track: also through cameras +-20 %% "
                    "in focal length, distortion, height and pitch, and how the drivers' ranking changes")
    args = ap.parse_args()
    rec = Source(args.data, args.range, args.labels, reader_options(args.reader)).open()
    fps = rec.frame_rate()
    speed = args.speed or ("the recorded throttle's" if args.world == "track" else "the recorded")
    drivers = [("the human's steering", lambda: Scripted(rec, 0)),
               *[(f"the human's steering {k} ticks ({k / fps:.2f} s) late", lambda k=k: Scripted(rec, k))
                 for k in (2, 4)],
               ("straight ahead (zero)", lambda: Scripted(rec, None)),
               *[(path, lambda path=path: Pilot(path)) for path in args.checkpoint]]
    nominal = rec.fisheye or DONKEY_FISHEYE
    cameras = [("nominal", nominal)]
    if args.camera_variants and args.world == "track":
        for name, change in (("focal", lambda c, f: {"fx": c.fx * f, "fy": c.fy * f}),
                             ("distortion", lambda c, f: {"d": tuple(v * f for v in c.d)}),
                             ("height", lambda c, f: {"mount_height": c.mount_height * f}),
                             ("pitch", lambda c, f: {"pitch_deg": c.pitch_deg * f})):
            cameras += [(f"{name} {f - 1:+.0%}", replace(nominal, **change(nominal, f))) for f in (0.8, 1.2)]
    print(f"machine: {machine()}\n\n{rec.name} {args.range or ''}, {args.world} replay, at {speed} m/s:\n")
    counts = {}
    for camera, fisheye in cameras:
        print(f"{camera} camera:\n\n| driver | km | interventions | interventions/km | mean abs offset [m] |"
              "\n|---|---|---|---|---|")
        cam, car = CAMERAS[rec.geometry], CARS[rec.geometry]
        for label, make in drivers:
            replay = (TrackReplay(cam, car, args.speed, fisheye=fisheye, lane_width=args.lane_width)
                      if args.world == "track" else Replay(cam, car, args.speed, car.lane_limit_m))
            rows, _ = replay_recording(make(), replay, rec)
            r = next(r for r in rows if r["segment"] == "all")
            counts.setdefault(camera, []).append(r["interventions"])
            print(f"| {label} | {r['km']:.3f} | {r['interventions']} | {r['interventions_per_km']:.1f} | "
                  f"{r['mean_offset_m']:.3f} |", flush=True)
        print()
    if len(cameras) > 1:
        base = np.array(counts["nominal"])
        print("| camera | interventions, driver by driver (the order above) | Spearman with the nominal ranking |\n"
              "|---|---|---|")
        for camera, values in counts.items():
            rho = spearmanr(base, values).statistic
            print(f"| {camera} | {' / '.join(map(str, values))} | {rho:.3f} |")

if __name__ == "__main__":
    guarded(main)
