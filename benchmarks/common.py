"""Shared helpers for the benchmark scripts (run from the repository root)."""

from __future__ import annotations

import platform
import subprocess
import sys
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "data"
CH2 = SHARED / "udacity-ch2"


def need_ch2() -> None:
    if not (CH2 / "CH2_final_evaluation.csv").exists():
        print(f"skipped: {CH2} not found (the benchmark uses the real CH2 frames)")
        sys.exit(0)


def track_tubs() -> list[Path]:
    """The racing expert's tubs of the track world that configs/track_*.yaml train on (tracks 1-4, 3 minutes
    each, in runs/track), recorded first where they are missing."""
    tubs = [ROOT / "runs" / "track" / f"tub-{seed}" for seed in (1, 2, 3, 4)]
    for seed, tub in enumerate(tubs, 1):
        if not (tub / "manifest.json").exists():
            subprocess.run([sys.executable, "-m", "steerlab", "sim", "record", "--world", "track", "--seed", str(seed),
                            "--minutes", "3", "--out", str(tub)], check=True)
    return tubs


def machine() -> str:
    return f"{platform.processor() or platform.machine()}, {torch.get_num_threads()} torch threads, torch {torch.__version__}"
