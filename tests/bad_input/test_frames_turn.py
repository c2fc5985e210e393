"""The rule: views and the small cars' replay of a tub whose frames turn against its steering are refused, one line
naming the tub, the correlation and the fix (reader option mirrored), on every command that warps its frames; and
`mirrored` is refused where the frames turn with the steering (data/sense.py)."""

import re
import shutil
from pathlib import Path

import pytest
from PIL import Image

from steerlab.cli import main

CONFIG = str(Path(__file__).parents[2] / "configs" / "donkey_tub.yaml")


def commands(tub: Path, out: Path) -> dict[str, list[str]]:
    fake = out / "model.pt"
    fake.parent.mkdir(parents=True, exist_ok=True)
    fake.write_bytes(b"not read: the recording is refused first")
    return {"views": ["views", CONFIG, f"data={tub}", "reader.full_lock_deg=25", "--out", str(out / "v")],
            "train": ["train", CONFIG, f"data={tub}", "reader.full_lock_deg=25", f"out={out / 't'}",
                      "train.epochs=1"],
            "replay": ["replay", str(fake), "--data", str(tub), "--reader", "full_lock_deg=25", "--out",
                       str(out / "r")]}


@pytest.mark.parametrize("command", ["views", "train", "replay"])
@pytest.mark.parametrize("case", ["flipped", "mirrored but not"])
def test_frames_that_turn_against_the_steering(track_tub, tmp_path, capsys, command, case):
    tub = tmp_path / "tub"
    shutil.copytree(track_tub, tub)
    if case == "flipped":
        for f in (tub / "images").glob("*.jpg"):
            Image.open(f).transpose(Image.FLIP_LEFT_RIGHT).save(f, quality=95)
    args = commands(tub, tmp_path / "out")[command]
    if case == "mirrored but not":
        args += ["reader.mirrored=true"] if command != "replay" else ["--reader", "mirrored=true"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    expected = ("its frames turn against its steering: .* give reader option mirrored=true" if case == "flipped"
                else "reader option mirrored is true, but its frames turn with its steering .* leave mirrored out")
    assert re.search(rf"{tub}: {expected}", err), err
    assert not any((tmp_path / "out" / d).exists() for d in ("v", "t", "r"))
