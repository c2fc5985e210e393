"""Views against the truth the track world has (`train.views` of a donkey-camera recording, docs/results/views.md):
the frame warped from the camera at pose A to pose B (`fisheye.shift_view`) against the frame the renderer draws at
B, and the view's label (`path.view_steering`: replay's return to the path rebuilt from the recorded steering and
throttle) against the expert's steering at B (`expert.expert_controls`).

On each track of `--tracks` the racing expert drives 20 s (no drift episodes; the frames noise-free, the room as
it is drawn otherwise: its vignette, its floor's mirror and glare), from 5 s on at speed. Frames: at 20 ticks, the
camera moved by each of `MOVES` (shift m to the left, turn degrees to the left); the mean absolute difference
(0-255, over B, G, R) of the warped frame and of the unwarped frame A from the frame rendered at B, on the floor
within 2.5 m and above the horizon, where the warp reads inside the frame. Labels: at 50 ticks, a view drawn
within +-0.15 m and +-15 degrees; the label's correction (the label less the recorded steering) against the
expert's (its steering at B less its steering at A): their correlation, the slope of the label's on the expert's,
and the mean absolute difference beside the mean absolute expert correction, for each pursued point's preview
`PREVIEWS` (train.recovery_s; replay's is 0.9 s). `OUT/view_truth.md`, `.json`.

python -m studies.view_truth [--tracks 21,3,8] [--out runs/view-truth]
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from steerlab.cli import run_script, script_parser
from steerlab.data import fisheye
from steerlab.data.car import CARS, VehicleState, throttle_speeds
from steerlab.data.path import human_path, moved_car, view_steering
from steerlab.options import SEED, Options, option
from steerlab.sim.track.look import Look
from steerlab.sim.track.world import RacerPilot, TrackWorld
from studies.common import ROOT, NumberList, machine

CAR = CARS["donkey"]
MOVES = ((0.12, 0.0), (-0.12, 0.0), (0.0, 12.0), (0.0, -12.0), (-0.1, -10.0), (0.1, 10.0))
PREVIEWS = (0.3, 0.6, 0.9)
TRACKS = NumberList(int, SEED)


def drive(seed: int) -> tuple[TrackWorld, list]:
    """The expert's drive of 20 s on track `seed` (no drift), noise-free frames: the world and each tick's (state,
    arc length, road-wheel angle, throttle) from 5 s on."""
    world = TrackWorld(seed, look=Look(noise=0.0))
    pilot, rows = RacerPilot(world, seed, None), []
    for _ in range(400):
        c = pilot.step(None)
        rows.append((world.state, world.s, c.steering, c.throttle))
        world.step(c.steering, c.throttle)
    return world, rows[100:]


def place(world: TrackWorld, state: VehicleState, s: float, shift: float, yaw: float) -> None:
    """The world's car with its camera `shift` m to the left of the camera of `state`, turned `yaw` degrees."""
    x, y, psi = moved_car(state.x, state.y, state.psi, shift, yaw, CAR.body.camera_forward)
    world.smallcar.state = VehicleState(x, y, psi, state.v)
    world.s = s


def floor_errors(world: TrackWorld, state: VehicleState, s: float, shift: float, yaw: float) -> tuple:
    """(warped, unwarped) mean absolute difference from the frame drawn at the moved camera on the floor within
    2.5 m, then the same above the horizon; where the warp reads inside the frame."""
    cam = world.renderer.cam
    place(world, state, s, 0.0, 0.0)
    a = world.render()
    place(world, state, s, shift, yaw)
    b = world.render().astype(int)
    warped = fisheye.shift_view(a, cam, shift, yaw).astype(int)
    mx, my = fisheye.view_maps(cam, shift, yaw)
    inside = (mx >= 0) & (mx <= cam.width - 1) & (my >= 0) & (my <= cam.height - 1)
    fwd, left, _, below = fisheye._floor_points(cam)
    floor, sky = below & (np.hypot(fwd, left) < 2.5) & inside, ~below & inside
    warp_err, plain_err = np.abs(warped - b).mean(-1), np.abs(a.astype(int) - b).mean(-1)
    return (float(warp_err[floor].mean()), float(plain_err[floor].mean()), float(warp_err[sky].mean()),
            float(plain_err[sky].mean()))


def label_agreement(world: TrackWorld, rows: list, seed: int, previews=PREVIEWS) -> dict[float, dict]:
    """Per preview: the views' label corrections against the expert's at 50 ticks (see the module's docstring)."""
    wheel = np.array([r[2] for r in rows])
    t = np.arange(len(rows)) / world.fps
    path = human_path(wheel, throttle_speeds(np.array([r[3] for r in rows]), t, CAR), t, CAR)
    rng = np.random.default_rng(seed)
    js = rng.choice(len(rows) - 40, 50, replace=False)
    shift, yaw = np.zeros(len(rows)), np.zeros(len(rows))
    shift[js], yaw[js] = rng.uniform(-0.15, 0.15, 50), rng.uniform(-15, 15, 50)
    truth = []
    for j in js:
        place(world, rows[j][0], rows[j][1], 0.0, 0.0)
        on_path = world.expert_controls()[0]
        place(world, rows[j][0], rows[j][1], shift[j], yaw[j])
        truth.append(world.expert_controls()[0] - on_path)
    truth = np.array(truth)
    out = {}
    for preview in previews:
        label = view_steering(path, shift, yaw, CAR, preview)[js] - wheel[js]
        out[preview] = {"r": float(np.corrcoef(label, truth)[0, 1]), "slope": float(np.polyfit(truth, label, 1)[0]),
                        "mae_rad": float(np.abs(label - truth).mean()), "spread_rad": float(np.abs(truth).mean())}
    return out


@dataclass(frozen=True)
class ViewTruth(Options):
    tracks: str = option("21,3,8", TRACKS, TRACKS.words, help="comma list of track seeds (21: a matte floor)")
    out: str = option(str(ROOT / "runs" / "view-truth"), path="folder", help="the study's folder")


def main(a, o: ViewTruth) -> None:
    results, frames, labels = [], [], []
    for seed in TRACKS.of(o.tracks):
        world, rows = drive(seed)
        gloss = float(world.renderer.room.gloss)
        for shift, yaw in MOVES:
            e = np.array([floor_errors(world, rows[k][0], rows[k][1], shift, yaw) for k in range(0, 300, 15)])
            r = {"track": seed, "gloss": gloss, "shift_m": shift, "yaw_deg": yaw,
                 **dict(zip(("floor_warped", "floor_unwarped", "above_warped", "above_unwarped"), e.mean(0)))}
            results.append({"kind": "frames", **r})
            frames.append(f"| {seed} | {gloss:.2f} | {shift:+g} m {yaw:+g} deg | {r['floor_warped']:.2f} | "
                          f"{r['floor_unwarped']:.2f} | {r['above_warped']:.2f} | {r['above_unwarped']:.2f} |")
        for preview, r in label_agreement(world, rows, seed).items():
            results.append({"kind": "labels", "track": seed, "preview_s": preview, **r})
            labels.append(f"| {seed} | {preview:g} | {r['r']:.3f} | {r['slope']:.2f} | {100 * r['mae_rad']:.2f} | "
                          f"{100 * r['spread_rad']:.2f} |")
    lines = [f"machine: {machine()}", "", "| track | floor gloss | camera moved | floor: warped | floor: unwarped | "
             "above the horizon: warped | unwarped |", "|" + "---|" * 7, *frames, "",
             "| track | preview [s] | r | slope | MAE [10^-2 rad] | expert's mean correction [10^-2 rad] |",
             "|" + "---|" * 6, *labels]
    out = Path(o.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "view_truth.md").write_text("\n".join(lines) + "\n")
    (out / "view_truth.json").write_text(json.dumps(results, indent=1))
    print("\n".join(lines))


def parser():
    return script_parser(__spec__.name, __doc__, ViewTruth)


if __name__ == "__main__":
    run_script(parser(), main)
