"""What a lane head sees, open loop, by pose: its offset and heading errors on tracks no model trained on, per range of
the true offset and heading, against the spread of the true values there.

The held-out frames are recorded here where missing (`OUT/tubs`): on tracks `TRACKS` (taped and centre-line, each in
its own room, never in a recipe's tubs), the racing expert's own drive (`sim record --minutes 0.5 --no-drift`: the
frames a model sees where the expert drives) and pose frames drawn wider than any recipe's (`--poses --pose-offset
1.5 --pose-heading 40 --pose-seed 7`: across the lane, beyond its edges and turned further than trained). Each
checkpoint's Pilot sees every frame alone (its memory cleared before each). Per bin of the true |offset| (in half
lane widths) and of the true |heading| (degrees): the mean absolute error of the head's offset (cm) and heading
(degrees), and the standard deviation of the true values in the bin (what a head that answers the bin's mean would
miss by, about). `OUT/lane_head.md`, `.json`.

python -m studies.lane_head CHECKPOINT [CHECKPOINT ...] [--labels a,b] [--out runs/lane-head]
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from steerlab.cli import path_option, run_script, script_parser
from steerlab.data.readers import open_recording
from steerlab.errors import SteerlabError
from steerlab.options import Options, option
from steerlab.pilot import Pilot
from steerlab.sim.track.track import LANE_WIDTH
from studies.common import ROOT, machine, track_tub

TRACKS = (("taped", 70), ("taped", 71), ("taped", 72), ("taped", 73), ("centre", 74), ("centre", 75))
POSES = ["--poses", "--pose-offset", "1.5", "--pose-heading", "40", "--pose-seed", "7"]
OFFSET_BINS = (0.0, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5)  # |offset| over half the lane width
HEADING_BINS = (0.0, 5.0, 10.0, 20.0, 30.0, 40.0)    # |heading|, degrees


def held_out(tubs: Path) -> dict[str, list[Path]]:
    """The held-out tubs, recorded where missing: {"driving": [...], "poses": [...]}."""
    out = {"driving": [], "poses": []}
    for style, seed in TRACKS:
        for kind, extra in (("driving", ["--no-drift"]), ("poses", POSES)):
            out[kind].append(track_tub(tubs / f"{style}-{seed}-{kind}", "--style", style, "--seed", str(seed),
                                       "--minutes", "0.5", *extra))
    return out


def seen(checkpoint: Path, tubs: list[Path]) -> tuple[np.ndarray, np.ndarray]:
    """(true, predicted) lane values (N, 3) of every frame of `tubs`, each frame seen alone."""
    pilot = Pilot(checkpoint)
    if "lane" not in pilot.targets:
        raise SteerlabError(f"{checkpoint}: model {pilot.name!r} has no lane head (train.lane_weight > 0)")
    true, predicted = [], []
    for tub in tubs:
        rec = open_recording(tub)
        true.append(np.stack([rec.extra["lateral_offset"], rec.extra["heading_error"], rec.extra["curvature"]], 1))
        for path in rec.frames["center"]:
            pilot.reset()
            predicted.append(pilot.step(cv2.imread(str(path))).lane)
    return np.concatenate(true), np.asarray(predicted)


def by_bin(true: np.ndarray, predicted: np.ndarray, column: int, edges, scale: float) -> list[dict]:
    """Per bin of |true[:, column]| / scale within `edges`: frames, the offset's and heading's MAE and spread."""
    key = np.abs(true[:, column]) / scale
    rows = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        m = (key >= lo) & ((key < hi) | (hi == edges[-1]))  # the last bin holds its upper edge and beyond
        if not m.any():
            continue
        err = np.abs(predicted[m] - true[m])
        rows.append({"bin": "all" if hi == math.inf else f"{lo:g}-{hi:g}", "n": int(m.sum()),
                     "offset_mae_cm": 100 * float(err[:, 0].mean()), "offset_sd_cm": 100 * float(true[m, 0].std()),
                     "heading_mae_deg": math.degrees(float(err[:, 1].mean())),
                     "heading_sd_deg": math.degrees(float(true[m, 1].std())),
                     "curvature_mae": float(err[:, 2].mean()), "curvature_sd": float(true[m, 2].std())})
    return rows


@dataclass(frozen=True)
class LaneHead(Options):
    labels: str | None = option(None, help="comma list of a label per checkpoint (default: their folders' names)")
    out: str = option(str(ROOT / "runs" / "lane-head"), path="folder", help="the study's folder")


def parser():
    p = script_parser(__spec__.name, __doc__, LaneHead)
    path_option(p, "checkpoints", kind="file", nargs="+", help="checkpoints with a lane head (.pt or .onnx)")
    return p


def main(a, o: LaneHead) -> None:
    ckpts = [Path(c) for c in a.checkpoints]
    labels = o.labels.split(",") if o.labels else [c.parent.parent.name + "/" + c.parent.name for c in ckpts]
    if len(labels) != len(ckpts):
        raise SteerlabError(f"--labels names {len(labels)} checkpoints; {len(ckpts)} are given")
    out = Path(o.out)
    tubs = held_out(out / "tubs")
    half = LANE_WIDTH / 2
    results, lines = [], [f"machine: {machine()}", "",
                          "| model | frames | bin | n | offset MAE [cm] | offset sd [cm] | heading MAE [deg] | "
                          "heading sd [deg] | curvature MAE [1/m] | curvature sd [1/m] |", "|" + "---|" * 10]
    for label, ckpt in zip(labels, ckpts):
        for kind, where in tubs.items():
            true, predicted = seen(ckpt, where)
            for axis, column, edges, scale in (("|offset| / half lane", 0, OFFSET_BINS, half),
                                               ("|heading| deg", 1, HEADING_BINS, math.radians(1))):
                for r in by_bin(true, predicted, column, (0, math.inf), scale) + by_bin(true, predicted, column,
                                                                                         edges, scale):
                    results.append({"model": label, "frames": kind, "axis": axis, **r})
                    lines.append(f"| {label} | {kind} | {axis} {r['bin']} | {r['n']} | {r['offset_mae_cm']:.1f} | "
                                 f"{r['offset_sd_cm']:.1f} | {r['heading_mae_deg']:.1f} | {r['heading_sd_deg']:.1f} | "
                                 f"{r['curvature_mae']:.3f} | {r['curvature_sd']:.3f} |")
                if kind == "driving":
                    break  # the expert's drive spans no range of headings: its offset rows alone
    out.mkdir(parents=True, exist_ok=True)
    (out / "lane_head.md").write_text("\n".join(lines) + "\n")
    (out / "lane_head.json").write_text(json.dumps(results, indent=1))
    print("\n".join(lines))


if __name__ == "__main__":
    run_script(parser(), main)
