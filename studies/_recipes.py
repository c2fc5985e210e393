"""The recipes of `studies/track_recipes.py` (its private module): the tubs each trains on (`TUBS`, the rooms'
`AUGMENT`), the base config (`base`: donkeycar linear's recipe written as a steerlab config) and every recipe as a
few `section.key=value` overrides of it (`RECIPES`, `Recipe`)."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from steerlab.data.car import CARS

TUBS = [f"{style}-{seed}" for style in ("taped", "centre") for seed in (1, 2, 3, 4)]
TUB_MINUTES = 2.0
DONKEYCAR = "donkeycar"          # the label of donkeycar's own runs
DONKEYCAR_CV = "donkeycar-cv"    # the label of donkeycar's computer-vision line follower's


def base(tubs: Path) -> dict:
    """donkeycar linear's recipe as a steerlab config: its network (`donkey-linear`) on the whole 160x120 RGB
    frame, the MSE of the steering plus the MAE of the throttle with weight 1 (donkeycar's trainer: the MSE of
    both), batches of 128, Adam 1e-3, early stopping with patience 3 (at most 15 epochs); validation on a block (the
    last 538 records of the first taped tub)."""
    return {"data": str(tubs / TUBS[0]), "extra_data": [str(tubs / t) for t in TUBS[1:]],
            "reader": {"full_lock_deg": CARS["donkey"].full_lock_deg}, "cache": str(tubs.parent / "cache"),
            "preprocess": {"crop": [0, 0, 0, 0], "width": 160, "height": 120, "color": "rgb"},
            "model": {"name": "donkey-linear"}, "split": {"train": "0:1800", "val": "1800:2338"},
            "train": {"epochs": 15, "patience": 3, "batch_size": 128, "lr": 1e-3, "loss": "mse",
                      "throttle_weight": 1.0}}


@dataclass(frozen=True)
class Recipe:
    """What differs from donkeycar's recipe (`what`): config overrides (`{init}` in one stands for the checkpoint of
    the recipe `starts` with the same seed), options of the suite it races with (`race`: a steering step, a
    latency), more tubs to train on (`tubs`: names of `AUGMENT`; with `only`, these tubs instead of `TUBS`, the
    first validating on its last `only` records; with `merged`, these tubs as one, `merged_tub`, split as the
    overrides say), and `starts`: the recipe it builds on (with no overrides it races
    that recipe's checkpoint as it is)."""

    what: str
    overrides: tuple[str, ...] = ()
    race: dict = field(default_factory=dict)
    tubs: tuple[str, ...] = ()
    only: int = 0
    starts: str | None = None
    merged: bool = False


# the same tracks 1-4 in other rooms (floor, light, clutter) and seen from other camera mounts
AUGMENT = {f"{style}-{seed}-room": [style, str(seed), "--room", str(100 + seed), "--mount-height",
                                    str(round(0.15 + 0.02 * (seed - 2.5), 3)), "--pitch", str(20 + 2 * (seed - 2.5))]
           for style in ("taped", "centre") for seed in (1, 2, 3, 4)}
# sixteen other tracks, each in its own room, one minute each: the same 16 minutes as TUBS from 16 rooms, not 4
AUGMENT |= {f"{style}-{seed}-1min": [style, str(seed), "--minutes", "1"]
            for style, seeds in (("taped", range(5, 17)), ("centre", range(17, 21))) for seed in seeds}
ROOMS = tuple(name for name in AUGMENT if name.endswith("-1min"))
# thirty-two more tracks, each in its own room, 30 s each: again 16 minutes, from 32 rooms
AUGMENT |= {f"{style}-{seed}-30s": [style, str(seed), "--minutes", "0.5"]
            for style, seeds in (("taped", range(21, 45)), ("centre", range(45, 53))) for seed in seeds}
ROOMS_32 = tuple(name for name in AUGMENT if name.endswith("-30s"))
# the sixteen rooms' tracks driven without drift-and-recover episodes: no recovery shown
AUGMENT |= {f"{style}-{seed}-1min-no-drift": [style, str(seed), "--minutes", "1", "--no-drift"]
            for style, seeds in (("taped", range(5, 17)), ("centre", range(17, 21))) for seed in seeds}
ROOMS_NO_DRIFT = tuple(name for name in AUGMENT if name.endswith("-no-drift"))
# up to 64 more tracks, a minute each, each in a varied room (`sim record --vary`): three taped to one centre-line,
# the first 16 and 32 of them the smaller sets of the data-scale curve
AUGMENT |= {f"{style}-{seed}-vary": [style, str(seed), "--minutes", "1", "--vary"]
            for style, seeds in (("taped", range(200, 248)), ("centre", range(248, 264))) for seed in seeds}

# frames from poses drawn around the expert's line (`sim record --poses`) on the sixteen rooms' tracks, in their rooms:
# the places and speeds of M minutes of its drive, the rear axle within +-1.25 half lane widths, turned within +-30 deg
POSE_MINUTES = (0.25, 0.5, 1.0)
AUGMENT |= {f"{style}-{seed}-poses-{m:g}": [style, str(seed), "--minutes", f"{m:g}", "--poses"]
            for m in POSE_MINUTES for style, seeds in (("taped", range(5, 17)), ("centre", range(17, 21)))
            for seed in seeds}



def with_poses(minutes: float) -> tuple[str, ...]:
    """The sixteen rooms' tubs and their pose frames of `minutes` each (the first validates)."""
    return (*ROOMS, *(n for n in AUGMENT if n.endswith(f"-poses-{minutes:g}")))


def varied(n: int) -> tuple[str, ...]:
    """The first n varied tubs, three of every four taped (the first validates)."""
    taped, centre = [f"taped-{s}-vary" for s in range(200, 248)], [f"centre-{s}-vary" for s in range(248, 264)]
    return (*taped[: n * 3 // 4], *centre[: n // 4])
COLOUR = ("train.hue_deg=180", "train.brightness=0.25")  # the colours and light of other rooms
# one view of every frame, the camera moved within +-0.15 m and turned within +-15 degrees, back on the path in 0.3 s:
# the train: section's options (the tub studies) and the same as overrides (the recipes)
VIEW = {"views": [[[-0.15, 0.15], [-15, 15]]], "recovery_s": 0.3}


def overrides(train: dict) -> tuple[str, ...]:
    """A train: section's options as a recipe's overrides."""
    return tuple(f"train.{key}={json.dumps(value)}" for key, value in train.items())


VIEWS = overrides(VIEW)
VIEWS_30 = overrides({**VIEW, "views": [[[-0.15, 0.15], [-30, 30]]]})  # turned as far as the pose frames are
BEST = (*COLOUR, "train.flip=true", "train.loss=mae", "train.epoch_samples=3700")  # configs/track_best.yaml
LANE_PACE = (2.0, 3.5, 5.0, 8.0, 12.0, 20.0)  # m/s^2: the pace from the lane's lateral accelerations, chosen on s1
RACE_BEST = {"throttle_scale": 1.2}  # its scale uncapped (and its floor at rest: best-floor-0.2)


def dagger_rounds(epochs: int) -> tuple[str, ...]:
    """The overrides of DAgger in the track world from the recipe a recipe `starts` with: one more epoch, then 3
    rounds of 4 minutes of uncapped rollouts on fresh tracks, `epochs` epochs a round, s1 at 1 minute a track after
    each."""
    return ("train.init={init}", "train.epochs=1",
            "dagger={world: track, suite: s1, suite_minutes: 1.0, iterations: 3, minutes: 4.0, beta: 0.5, "
            f"beta_decay: 0.5, epochs: {epochs}, max_throttle: 1.0, seeds_from: 6000}}")


CROP, GRAY_200x66 = ["preprocess.crop=[40,0,0,0]", "preprocess.height=80"], ["preprocess.width=200",
                                                                             "preprocess.height=66"]
RECIPES = {
    # one factor at a time from donkeycar linear's recipe
    "donkey": Recipe("donkeycar linear's recipe"),
    "crop": Recipe("the donkey crop (the top 40 rows off: 160x80)", tuple(CROP)),
    "gray": Recipe("gray instead of RGB", ("preprocess.color=gray",)),
    "200x66": Recipe("resized to 200x66", tuple(GRAY_200x66)),
    "pilotnet": Recipe("PilotNet's network", ("model.name=pilotnet",)),
    "mae": Recipe("the MAE of the steering", ("train.loss=mae",)),
    "random-split": Recipe("a random 20 % of the first tub validates", ("split={random: 0.2}",)),
    "throttle-0.5": Recipe("the throttle's weight 0.5", ("train.throttle_weight=0.5",)),
    "batch-32": Recipe("batches of 32, Adam 3e-4", ("train.batch_size=32", "train.lr=3.0e-4")),
    "lstm": Recipe("recurrent: the CNN-LSTM", ("model.name=lstm",)),
    "tub-default": Recipe("steerlab's earlier tub default (multimodal-lstm, gray 200x66 crop, MAE, batch 32, Adam "
                          "3e-4, throttle weight 0.5)",
                          ("model.name=multimodal-lstm", "preprocess.crop=[40,0,0,0]", *GRAY_200x66,
                           "preprocess.color=gray", "train.loss=mae", "train.batch_size=32", "train.lr=3.0e-4",
                           "train.throttle_weight=0.5")),
    # the levers of small-car racing, on donkeycar's recipe
    "dagger": Recipe("+ DAgger in the track world: 3 rounds of 4 minutes of rollouts, uncapped, the expert's labels "
                     "at the car's speed", dagger_rounds(3), starts="donkey"),
    "steering-step": Recipe("+ the steering's change limited to 0.1 of full lock per frame",
                            race={"steering_step": 0.1}, starts="donkey"),
    "latency": Recipe("+ a frame one tick old (a real part's latency), labels not shifted", race={"latency": 1},
                      starts="donkey"),
    "latency-matched": Recipe("+ a frame one tick old, trained on the steering one tick later",
                              ("train.target_shift_s=0.05",), race={"latency": 1}),
    "stack-3": Recipe("+ three stacked frames", ("preprocess.stack=3",)),
    "augment": Recipe("+ the same tracks in other rooms and from other camera mounts (8 more tubs)",
                      tubs=tuple(name for name in AUGMENT if name.endswith("-room"))),
    "rooms": Recipe("16 tracks in 16 rooms, 1 minute each, instead of 4 tracks in 4 rooms, 2 minutes each (12 taped, "
                    "4 centre-line; as many records)", tubs=ROOMS, only=240),
    "rooms-colour": Recipe("rooms + the colours and light of other rooms: the hue turned within +-180 degrees and "
                           "the brightness scaled within 1 +- 0.25 (train.hue_deg, train.brightness)",
                           COLOUR, tubs=ROOMS, only=240),
    "rooms-colour-flip": Recipe("rooms-colour + each sample mirrored left-right with probability 0.5, its steering "
                                "negated (paper 002 IV-B1's flips; train.flip): each tub turns one way round its "
                                "loop, 10 of the 16 to the right",
                                (*COLOUR, "train.flip=true"), tubs=ROOMS, only=240),
    "flip-smooth-0.5": Recipe("rooms-colour-flip driven with its steering smoothed, s = 0.5 y + 0.5 s' (paper 002's "
                              "exponential smoothing; --smoothing 0.5)", race={"smoothing": 0.5},
                              starts="rooms-colour-flip"),
    "flip-smooth-0.7": Recipe("rooms-colour-flip driven with its steering smoothed, s = 0.7 y + 0.3 s' "
                              "(--smoothing 0.7)", race={"smoothing": 0.7}, starts="rooms-colour-flip"),
    "flip-step": Recipe("rooms-colour-flip driven with the steering's change limited to 0.1 of full lock per frame",
                        race={"steering_step": 0.1}, starts="rooms-colour-flip"),
    "flip-mae": Recipe("rooms-colour-flip trained on the MAE of the steering (the tub default's loss) instead of "
                       "its MSE (the throttle's error is the MAE in both)",
                       BEST, tubs=ROOMS, only=240),
    "mae-throttle-1.2": Recipe("flip-mae driven with its learned throttle times 1.2 before the cap "
                               "(--throttle-scale 1.2)", race={"throttle_scale": 1.2}, starts="flip-mae"),
    "mae-throttle-1.5": Recipe("flip-mae driven with its learned throttle times 1.5 before the cap "
                               "(--throttle-scale 1.5)", race={"throttle_scale": 1.5}, starts="flip-mae"),
    "mae-throttle-2": Recipe("flip-mae driven with its learned throttle times 2 before the cap "
                             "(--throttle-scale 2)", race={"throttle_scale": 2.0}, starts="flip-mae"),
    "flip-throttle-1.2": Recipe("rooms-colour-flip driven with its learned throttle times 1.2 before the cap "
                                "(--throttle-scale 1.2, as donkeycar's AI_THROTTLE_MULT)", race={"throttle_scale": 1.2},
                                starts="rooms-colour-flip"),
    "flip-throttle-1.5": Recipe("rooms-colour-flip driven with its learned throttle times 1.5 before the cap "
                                "(--throttle-scale 1.5)", race={"throttle_scale": 1.5}, starts="rooms-colour-flip"),
    "rooms-colour-15": Recipe("rooms-colour trained all 15 epochs and the last kept, not stopped early on the "
                              "240-record validation block (donkeycar's trainer stops on a random 20 % of every "
                              "tub, which keeps falling: it trains 30 epochs)",
                              (*COLOUR, "train.keep=last"), tubs=ROOMS, only=240),
    "rooms-32": Recipe("rooms-colour-15 on 32 tracks in 32 rooms, 30 s each (24 taped, 8 centre-line; as many "
                       "records), instead of 16 in 16, a minute each",
                       (*COLOUR, "train.keep=last"), tubs=ROOMS_32, only=240),
    "mae-donkey-split": Recipe("flip-mae on donkeycar's split: the sixteen tubs as one, a random 20 % of all its "
                               "records validating (donkeycar's trainer: a random 80/20 split of every record), "
                               "at track_best's scale (--throttle-scale 1.2)",
                               (*BEST, "split={random: 0.2}"),
                               race={"throttle_scale": 1.2}, tubs=ROOMS, merged=True),
    "donkey-split-floor-0.2": Recipe("mae-donkey-split driven as track_best is: with a throttle of at least 0.2 while "
                                     "the car stands (--throttle-floor 0.2)",
                                     race={**RACE_BEST, "throttle_floor": 0.2}, starts="mae-donkey-split"),
    # the levers of recovery and racing on track_best (flip-mae, x 1.2 uncapped; each alone, without the floor)
    "best-no-drift": Recipe("track_best on the same tracks driven without drift-and-recover episodes (the "
                            "recovery the expert shows left out)", BEST, RACE_BEST, ROOMS_NO_DRIFT, only=240),
    "best-no-drift-floor-0.2": Recipe("best-no-drift driven as track_best is (--throttle-floor 0.2)",
                                      race={**RACE_BEST, "throttle_floor": 0.2}, starts="best-no-drift"),
    # views (train.views through the fisheye, labelled by replay's return to the path, pursuing the point 0.3 s
    # ahead as the expert does: docs/results/views.md) buying back the drift episodes' recovery
    "best-no-drift-views": Recipe("best-no-drift + one view of every frame, its camera moved within +-0.15 m and "
                                  "turned within +-15 degrees (train.views, train.recovery_s 0.3), driven as "
                                  "best-floor-0.2", (*BEST, *VIEWS),
                                  {**RACE_BEST, "throttle_floor": 0.2}, ROOMS_NO_DRIFT, only=240),
    "best-no-drift-views-p15": Recipe("best-no-drift-views trained all 15 epochs (train.patience 15: no early stop on "
                                      "the 240-record validation block), its best epoch there kept",
                                      (*BEST, *VIEWS, "train.patience=15"), {**RACE_BEST, "throttle_floor": 0.2},
                                      ROOMS_NO_DRIFT, only=240),
    "best-no-drift-views-30": Recipe("best-no-drift-views with its views turned within +-30 degrees (the pose frames' "
                                     "range) instead of +-15", (*BEST, *VIEWS_30), {**RACE_BEST, "throttle_floor": 0.2},
                                     ROOMS_NO_DRIFT, only=240),
    "best-views": Recipe("track_best + one view of every frame, its camera moved within +-0.15 m and turned within "
                         "+-15 degrees (train.views, train.recovery_s 0.3), driven as best-floor-0.2",
                         (*BEST, *VIEWS), {**RACE_BEST, "throttle_floor": 0.2}, ROOMS, only=240),
    "best-dagger": Recipe("track_best + DAgger in the track world: 3 rounds of 4 minutes of rollouts on fresh tracks, "
                          "uncapped, the expert's labels at the car's speed, 2 epochs a round",
                          dagger_rounds(2), RACE_BEST, ROOMS, only=240, starts="flip-mae"),
    "best-latency-matched": Recipe("track_best on a frame one tick old (a real part's latency), trained on the "
                                   "steering one tick later", (*BEST, "train.target_shift_s=0.05"),
                                   {**RACE_BEST, "latency": 1}, ROOMS, only=240),
    "best-stack-3": Recipe("track_best on three stacked frames (the motion: whether the car moves at all)",
                           (*BEST, "preprocess.stack=3"), RACE_BEST, ROOMS, only=240),
    "best-floor-0.2": Recipe("track_best driven with a throttle of at least 0.2 while the car stands "
                             "(--throttle-floor 0.2)", race={**RACE_BEST, "throttle_floor": 0.2}, starts="flip-mae"),
    # frames from every pose: track_best's tubs and M minutes of pose frames of each of their tracks
    **{f"best-poses-{m:g}": Recipe(f"track_best + {m:g} min of pose frames of each of its sixteen tracks in its room "
                                   "(sim record --poses: the rear axle within +-1.25 half lane widths, turned within "
                                   "+-30 degrees, the expert's controls from there), driven as best-floor-0.2",
                                   BEST, {**RACE_BEST, "throttle_floor": 0.2},
                                   with_poses(m), only=240)
       for m in POSE_MINUTES},
    # the lane head (train.lane_weight 0.5) on track_best's tubs without and with pose frames, driven by its steering
    # head and by the lane controller on the lane it sees (--steer-by lane)
    "best-lane": Recipe("track_best + a lane head (train.lane_weight 0.5), driven by its steering head as "
                        "best-floor-0.2", (*BEST, "train.lane_weight=0.5"), {**RACE_BEST, "throttle_floor": 0.2},
                        ROOMS, only=240),
    "best-poses-0.5-lane": Recipe("best-poses-0.5 + a lane head (train.lane_weight 0.5), driven by its steering head",
                                  (*BEST, "train.lane_weight=0.5"), {**RACE_BEST, "throttle_floor": 0.2},
                                  with_poses(0.5), only=240),
    **{f"{name}-by-lane": Recipe(f"{name} steering by the lane it sees (--steer-by lane: the lane controller, "
                                 "Stanley's law)", race={**RACE_BEST, "throttle_floor": 0.2, "steer_by": "lane"},
                                 starts=name) for name in ("best-lane", "best-poses-0.5-lane")},
    # the pace from the lane (--throttle-by lane: the speed the curvature its lane head sees allows at a lateral
    # acceleration, control.lane_throttle) instead of its learned throttle, steering by the lane it sees
    **{f"lane-pace-{a:g}": Recipe(f"best-poses-0.5-lane steering by the lane it sees at the pace of that lane's "
                                  f"curvature, lateral acceleration {a:g} m/s^2 (--throttle-by lane --lat-acc {a:g}), "
                                  "uncapped", race={"steer_by": "lane", "throttle_by": "lane", "lat_acc": a},
                                  starts="best-poses-0.5-lane") for a in LANE_PACE},
    "steering-lane-pace-3.5": Recipe("best-poses-0.5-lane steering by its steering head at the pace of the lane's "
                                     "curvature, lateral acceleration 3.5 m/s^2 (--throttle-by lane), uncapped",
                                     race={"throttle_by": "lane", "lat_acc": 3.5}, starts="best-poses-0.5-lane"),
    # the data-scale curve of varied rooms (docs/results/racing.md, "Rooms that cannot be memorised")
    **{f"vary-{n}": Recipe(f"track_best on {n} tracks in {n} varied rooms (sim record --vary), a minute each",
                           BEST, RACE_BEST, varied(n), only=240) for n in (16, 32, 64)},
    **{f"vary-{n}-floor-0.2": Recipe(f"vary-{n} driven with a throttle of at least 0.2 while the car stands "
                                     "(--throttle-floor 0.2), as track_best", race={**RACE_BEST, "throttle_floor": 0.2},
                                     starts=f"vary-{n}") for n in (16, 32, 64)},
    "rooms-dagger": Recipe("rooms + DAgger in the track world: 3 rounds of 4 minutes of rollouts on fresh tracks, "
                           "uncapped, the expert's labels at the car's speed, 2 epochs a round",
                           dagger_rounds(2), tubs=ROOMS, only=240, starts="rooms"),
}
