import argparse
import csv
import json

import numpy as np
import pytest

from conftest import drawn_pixels, image_of, legend_of
from steerlab.cli import build_parser, main
from steerlab.evaluate.scoring import read_steering_csv
from steerlab.sim.core.driving import Trajectory
from steerlab.models import list_models


def _subcommands(parser, prefix=()):
    """Every subcommand of the parser, found in the parser itself (so that a new one cannot be missed)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found = list(_subcommands(sub, (*prefix, name)))
                yield from found or [(*prefix, name)]


def test_every_subcommand_has_help_with_an_example(capsys):
    commands = list(_subcommands(build_parser()))
    assert len(commands) == 18 and ("sim", "dagger") in commands and ("latency",) in commands
    for argv in [(), *commands]:
        assert main([*argv, "--help"]) == 0
        out = capsys.readouterr().out
        assert out.startswith(f"usage: steerlab {' '.join(argv)}".rstrip()), out[:80]
        assert not argv or "example: steerlab " + " ".join(argv) in out.replace("\n", " "), argv


def test_the_command_line_starts_without_torch_or_matplotlib():
    """`steerlab --help`, and any command before it does its work, builds the parser from the options alone: torch
    and matplotlib (a second of the start between them) are imported by the commands that use them."""
    import subprocess
    import sys

    code = ("import sys; from steerlab.cli import build_parser; build_parser(); "
            "print(sorted(m for m in ('torch', 'matplotlib') if m in sys.modules))")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0 and run.stdout.strip() == "[]", run.stdout + run.stderr


def test_a_wrong_option_value_is_one_line_naming_the_flag(capsys):
    assert main(["sim", "bench", "x.pt", "--workers", "two"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "argument --workers: invalid int value: 'two'" in err


def test_compile_train_evaluate_drive(tiny_recording, tmp_path, capsys, saved_figures):
    cache = str(tmp_path / "cache")
    assert main(["compile", "--data", str(tiny_recording), "--modalities", "image,diff", "--cache", cache]) == 0
    assert "diff: (300, 66, 200, 1) uint8" in capsys.readouterr().out
    cfg = tmp_path / "c.yaml"
    cfg.write_text(f"data: {tiny_recording}\ncache: {cache}\nsplit: {{train: '0:240', val: '240:300'}}\n")
    run = tmp_path / "run"
    assert main(["train", str(cfg), "train.epochs=1", f"out={run}"]) == 0
    assert "best checkpoint" in capsys.readouterr().out
    assert main(["evaluate", str(run / "best.pt"), "--data", str(tiny_recording), "--range", "240:300",
                 "--out", str(tmp_path / "eval")]) == 0
    assert main(["score", "--truth", str(tmp_path / "eval" / "predictions.csv"),
                 "--pred", str(tmp_path / "eval" / "predictions.csv")]) == 2  # no 'public' column
    assert "needs a 'public' column" in capsys.readouterr().err
    assert main(["sim", "drive", str(run / "best.pt"), "--minutes", "0.05", "--out", str(tmp_path / "drive")]) == 0
    result = json.loads((tmp_path / "drive" / "drive.json").read_text())
    offsets = [abs(float(r["lateral_offset_m"])) for r in csv.DictReader(open(tmp_path / "drive" / "trajectory.csv"))]
    assert len(offsets) == 60 and result["label"] == "pilotnet"  # 0.05 min at 20 frames/s
    assert result["mean_abs_offset_m"] == pytest.approx(sum(offsets) / 60, abs=1e-4)
    # frames.png: the frames kept every 5 s, here the first, as the road world renders it (country road 100)
    from steerlab.sim.road.world import World

    np.testing.assert_array_equal(image_of(tmp_path / "drive" / "frames.png"),
                                  World(100, "country", "sim", 3.0, 20.0).render())
    # path.png: the driven path on the map and its offset, both drawn; the legend names the lane and the model
    png = tmp_path / "drive" / "path.png"
    img = image_of(png)
    assert img.shape[:2] == (500, 1300)
    the_map, offsets = saved_figures[str(png)].axes
    assert legend_of(the_map) == ["lane centre", "pilotnet"]
    drive = Trajectory.read(tmp_path / "drive" / "trajectory.csv")
    path, line = the_map.get_lines()[-1], offsets.get_lines()[0]
    np.testing.assert_allclose(path.get_xydata(), np.c_[drive.x, drive.y], atol=1e-4)  # as the csv rounds
    np.testing.assert_allclose(line.get_ydata(), drive.offset, atol=1e-4)
    assert drawn_pixels(img, the_map, path.get_color()) > 50 and drawn_pixels(img, offsets, line.get_color()) > 500


def test_models_lists_every_model_with_its_needs(capsys):
    assert main(["models"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines] == list_models()
    assert "recurrent, predicts command, needs speed" in next(x for x in lines if x.startswith("speed-command"))


def test_train_errors_are_one_line(tmp_path, capsys):
    assert main(["train", str(tmp_path / "none.yaml")]) == 2
    assert "config file not found" in capsys.readouterr().err
    assert main(["experiment", str(tmp_path / "none.yaml")]) == 2
    assert "none.yaml: config file not found" in capsys.readouterr().err
    assert main(["evaluate", str(tmp_path / "x.pt"), "--data", str(tmp_path)]) == 2
    assert capsys.readouterr().err.startswith("error: ")
    bad = tmp_path / "bad_suite.yaml"  # refused before the first model trains
    bad.write_text(f"data: {tmp_path}\nout: {tmp_path / 'exp'}\nclosed_loop: {{suite: v9}}\n"
                   "models:\n  - {model: {name: pilotnet}}\n")
    assert main(["experiment", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "bad_suite.yaml: closed_loop.suite must be v1, got 'v9'" in err
    assert not (tmp_path / "exp").exists()
    bad.write_text(f"data: {tmp_path}\nout: {tmp_path / 'exp'}\nmodels:\n  - {{model: {{name: pilotnet}}}}\n"
                   "  - {model: {name: yang-base}, dagger: {round: 2}}\n")
    assert main(["experiment", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "bad_suite.yaml: models entry 2: unknown dagger options ['round']" in err
    bad.write_text(f"data: {tmp_path}\nmodels:\n  - {{train: {{epochs: 1}}}}\n")
    assert main(["experiment", str(bad)]) == 2
    assert "models entry 1 needs a model section with a name" in capsys.readouterr().err
    bad.write_text(f"data: {tmp_path}\nmodels:\n  - {{model: {{name: pilotnet}}}}\n  - {{model: {{name: pilotnett}}}}\n")
    assert main(["experiment", str(bad)]) == 2
    assert "models entry 2: unknown model 'pilotnett'" in capsys.readouterr().err
    assert not (tmp_path / "exp").exists()


def test_experiment_table(tiny_recording, tmp_path, capsys, saved_figures):
    cfg = tmp_path / "exp.yaml"
    cfg.write_text(f"""
data: {tiny_recording}
cache: {tmp_path / 'cache'}
split: {{train: "0:80", val: "80:160"}}
train: {{epochs: 1, batch_size: 16}}
out: {tmp_path / 'exp'}
closed_loop: {{suite: v1, minutes: 0.01, workers: 1, roads: twisty}}
replay: {{}}
models:
  - {{model: {{name: zero}}}}
  - {{model: {{name: pilotnet-flow}}, label: flow, preprocess: {{width: 128, height: 64}}}}
  - {{model: {{name: multitask-speed}}}}
""")
    assert main(["experiment", str(cfg), "--seeds", "2"]) == 0
    text = (tmp_path / "exp" / "table.md").read_text()
    assert "| zero | image (gray) | 1@200x66 |" in text and "| flow | image+flow (gray) | 3@128x64 |" in text
    assert (tmp_path / "exp" / "flow" / "seed1" / "best.pt").exists()
    check_predictions_plot(tmp_path / "exp", saved_figures)
    # one figure per road with every model's seed-0 drive on it; the runs' own suites draw none
    assert sorted(p.name for p in (tmp_path / "exp" / "roads").iterdir()) == [f"twisty-930{k}.png" for k in (1, 2, 3)]
    assert not list((tmp_path / "exp").glob("*/seed*/suite/roads"))
    check_road_plot(tmp_path / "exp", "twisty-9302", saved_figures)
    assert ("| autonomy [%] | country / highway / twisty [%] | interventions/km | command gamma [deg] | "
            "worst seed: country / highway / twisty [%] |") in text
    assert "holding the current speed" in text
    assert "Rank correlation of the open-loop metrics with autonomy: not defined here" in text  # two trained models
    check_open_vs_closed_plot(tmp_path / "exp", saved_figures)
    speed_row = next(line for line in text.splitlines() if line.startswith("| multitask-speed | ") and "+-" in line
                     and "@" not in line)  # the paper 002 table: steering MAE, speed MAE, command accuracy
    assert speed_row.split("|")[3].strip() != "-" and speed_row.split("|")[4].strip() == "-"
    rows = list(csv.DictReader(open(tmp_path / "exp" / "table.csv")))
    assert rows[0]["seeds"] == "2" and float(rows[0]["mse_std"]) == 0.0  # zero predicts the same every seed
    for row in rows:  # the worst seed per road type is the lower of the two seeds' suites
        folder = tmp_path / "exp" / row["label"]
        twisty = [next(float(r["autonomy"]) for r in csv.DictReader(open(folder / f"seed{s}" / "suite" / "summary.csv"))
                       if r["road_type"] == "twisty") for s in (0, 1)]
        assert float(row["autonomy_twisty_min"]) == pytest.approx(min(twisty))
    assert float(rows[0]["smoothed_rmse_mean"]) == pytest.approx(float(rows[0]["rmse_mean"]))  # smoothing 0 is 0
    # train time: the seconds of the run's epoch log (the baseline writes none)
    logs = [sum(float(r["seconds"]) for r in csv.DictReader(open(tmp_path / "exp" / "flow" / f"seed{s}" / "log.csv")))
            for s in (0, 1)]
    flow = next(r for r in rows if r["label"] == "flow")
    assert float(flow["train_s_mean"]) == pytest.approx(sum(logs) / 2) and float(rows[0]["train_s_mean"]) == 0.0
    # replay of the validation frames: every run's replay.csv, its mean in the table
    assert "Closed-loop replay of the validation frames" in text and "replay interventions/km" in text
    replayed = [next(csv.DictReader(open(tmp_path / "exp" / "flow" / f"seed{s}" / "replay" / "replay.csv")))
                for s in (0, 1)]
    assert all(r["frames"] == "80" and r["speed_source"] == "recorded" for r in replayed)
    assert float(flow["replay_interventions_per_km_mean"]) == pytest.approx(
        sum(float(r["interventions_per_km"]) for r in replayed) / 2, rel=1e-4)


def check_predictions_plot(exp, saved_figures):
    """predictions.png: 11 x 3.6 inches at 110 dpi, the validation steering and every model's seed-0 predictions
    over the 80 validation frames in degrees, each drawn, and a legend naming them."""
    img = image_of(exp / "predictions.png")
    assert img.shape[:2] == (396, 1210)
    ax = saved_figures[str(exp / "predictions.png")].axes[0]
    assert legend_of(ax) == ["target", "zero", "flow", "multitask-speed"]
    lines = ax.get_lines()
    assert [len(line.get_ydata()) for line in lines] == [80] * 4
    for line, label in zip(lines[1:], ["zero", "flow", "multitask-speed"]):
        predicted = read_steering_csv(exp / label / "seed0" / "val_predictions.csv")[1]
        np.testing.assert_allclose(line.get_ydata(), np.degrees(predicted), atol=1e-4)
    assert min(drawn_pixels(img, ax, line.get_color()) for line in lines) > 500  # about 1,700-2,400 each


def check_road_plot(exp, road, saved_figures):
    """roads/ROAD.png: 13 x 5 inches at 100 dpi; on the map (left) and in the offsets (right) every model's seed-0
    drive as its trajectory.csv has it, each drawn, and a legend naming the models with their autonomy."""
    png = exp / "roads" / f"{road}.png"
    img = image_of(png)
    assert img.shape[:2] == (500, 1300)
    the_map, offsets = saved_figures[str(png)].axes
    legend = legend_of(the_map)
    assert legend[0] == "lane centre" and [t.split(" (")[0] for t in legend[1:]] == ["zero", "flow", "multitask-speed"]
    paths, lines = the_map.get_lines()[-3:], offsets.get_lines()[:3]
    for path, line, label in zip(paths, lines, ["zero", "flow", "multitask-speed"]):
        drive = Trajectory.read(next((exp / label / "seed0" / "suite").glob(f"*/{road}/trajectory.csv")))
        assert len(drive) == 12  # 0.01 minutes at 20 frames/s
        np.testing.assert_allclose(path.get_xydata(), np.c_[drive.x, drive.y], atol=1e-4)  # as the csv rounds
        np.testing.assert_allclose(line.get_ydata(), drive.offset, atol=1e-4)
        assert drawn_pixels(img, offsets, line.get_color()) > 100  # 400-700 measured
    # the three paths start together on the map, so the last drawn covers the first: they are drawn together
    assert sum(drawn_pixels(img, the_map, path.get_color()) for path in paths) > 100  # 260 measured


def check_open_vs_closed_plot(exp, saved_figures):
    """open_vs_closed.png: 8 x 5.5 inches at 100 dpi, one point per trained model at its validation RMSE and
    its autonomy on the suite (table.csv), drawn, and the legend."""
    img = image_of(exp / "open_vs_closed.png")
    assert img.shape[:2] == (550, 800)
    ax = saved_figures[str(exp / "open_vs_closed.png")].axes[0]
    assert legend_of(ax) == ["models"]
    trained = [r for r in csv.DictReader(open(exp / "table.csv")) if float(r["epoch_mean"]) > 0]
    points = ax.collections[0]
    np.testing.assert_allclose(points.get_offsets(), [[float(r["rmse_mean"]), float(r["autonomy_mean"])]
                                                      for r in trained])
    assert drawn_pixels(img, ax, points.get_facecolor()[0]) > 50  # 178 measured, two markers
