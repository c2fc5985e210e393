"""Shared helpers for the benchmark scripts (run from the repository root)."""

from __future__ import annotations

import platform
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


def machine() -> str:
    return f"{platform.processor() or platform.machine()}, {torch.get_num_threads()} torch threads, torch {torch.__version__}"
