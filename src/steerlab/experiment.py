"""`steerlab experiment`: train several models, several seeds each, on identical splits, and tabulate them in
the form of paper 000 Table I (model, input, input shape, MSE mean +- std, gamma, target gamma) and of paper
002 Tables I-II (steering MAE, speed MAE, speed-command accuracy), optionally with closed-loop columns (every
run drives the suite of the `closed_loop:` section's world: its columns, `WorldEntry.report.table`, such as
autonomy per road type, interventions per km and command gamma, and one figure per road or track with every
model's seed-0 drive on it) and the streaming latency of every model. With closed-loop columns the experiment also
plots open-loop error against autonomy and says how well each open-loop metric ranks the models' driving and which
ranks it best; when the validation frames hold drift-and-recover episodes it plots them in the form of paper 000
Fig. 6."""

from __future__ import annotations

import csv
import filecmp
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from steerlab.files import write_json
from steerlab.dagger import dagger_options, round_suite, run_dagger
from steerlab.data.labels import COMMANDS, speed_targets
from steerlab.data.preprocess import PreprocessConfig
from steerlab.data.recording import SteeringConvention
from steerlab.data.splits import make_split
from steerlab.errors import SteerlabError
from steerlab.evaluate.latency import measure
from steerlab.evaluate.metrics import (SMOOTHING_ALPHA, accuracy, all_metrics, exponential_smoothing, speed_mae,
                                       steering_metrics)
from steerlab.evaluate.plots import plot_open_vs_closed, plot_recovery, plot_steering, rank_correlation
from steerlab.evaluate.scoring import read_steering_csv
from steerlab.paths import check_outputs
from steerlab.options import Options, SPEED, as_dict, option, parse
from steerlab.pilot import Pilot
from steerlab.sim.core.entry import WorldEntry
from steerlab.sim.worlds import closed_loop
from steerlab.split_replay import SplitReplay
from steerlab.train.config import TrainConfig, another_config, layered, override_key, parse_config, read_yaml
from steerlab.train.loop import run_changes, train
from steerlab.train.sources import main_recording, prepare_dataset

LATENCY_FRAMES = 200


@dataclass(frozen=True)
class ReplayOn(Options):
    """An experiment's `replay:` section: replay every run on its validation frames ({} for the recorded or
    estimated speed, or {speed: M/S})."""

    speed: float | None = option(None, SPEED)


@dataclass(frozen=True)
class Entry:
    """One row of an experiment: a training-config fragment over the shared sections."""

    model: dict
    label: str | None = None
    preprocess: dict = option({})
    train: dict = option({})
    dagger: dict | None = None

    @property
    def name(self) -> str:
        return self.label or self.model.get("name", "?")


@dataclass(frozen=True)
class ExperimentConfig:
    """An experiment: the shared training-config sections, the `models` entries, and optionally the
    closed-loop suite (`closed_loop`: the suite options of the world `world`) and replay (`replay`) every run is
    driven on."""

    shared: dict
    entries: tuple[Entry, ...]
    closed_loop: Options | None = None
    replay: ReplayOn | None = None
    overrides: tuple[str, ...] = ()
    world: WorldEntry | None = None

    @property
    def out(self) -> Path:
        """The experiment's folder: the config's `out`, or an `out=...` override of it."""
        out = layered(self.shared, overrides=[o for o in self.overrides if override_key(o) == "out"])
        return Path(out.get("out", "runs/experiment"))

    def run_config(self, entry: Entry, seed: int) -> TrainConfig:
        """The training config of one run: the shared sections, then the entry's, then the overrides; written to
        <out>/<label>/seed<seed> (whatever the overrides say of `out`)."""
        base = {**self.shared, "model": entry.model,
                "preprocess": {**self.shared.get("preprocess", {}), **entry.preprocess},
                "train": {**self.shared.get("train", {}), **entry.train, "seed": seed}}
        if entry.dagger is not None or self.shared.get("dagger") is not None:
            base["dagger"] = {**(self.shared.get("dagger") or {}), **(entry.dagger or {})}
        mine = [o for o in self.overrides if override_key(o) != "out"]  # `out` names the experiment's
        return parse_config(base, overrides=[*mine, f"out={self.out / entry.name / f'seed{seed}'}"])


def load_experiment(path: str | Path, overrides=()) -> ExperimentConfig:
    """An experiment config, every entry checked (its run config parsed, its DAgger options too) before any
    work."""
    raw = read_yaml(path, "sections with a 'models' list")
    if not isinstance(raw.get("models"), list) or not raw["models"]:
        raise SteerlabError(f"{path}: an experiment config needs a non-empty 'models' list")
    shared = {k: v for k, v in raw.items() if k not in ("models", "closed_loop", "replay")}
    try:
        world, closed = (None, None) if raw.get("closed_loop") is None else closed_loop(raw["closed_loop"])
        replay = None if raw.get("replay") is None else parse(ReplayOn, raw["replay"], "replay")
    except SteerlabError as e:
        raise SteerlabError(f"{path}: {e}") from None
    entries = []
    for i, item in enumerate(raw["models"]):
        if not isinstance(item, dict) or not isinstance(item.get("model"), dict) or "name" not in item["model"]:
            raise SteerlabError(f"{path}: models entry {i + 1} needs a model section with a name, got {item!r}")
        try:
            entries.append(parse(Entry, item, "models entry"))
        except SteerlabError as e:
            raise SteerlabError(f"{path}: models entry {i + 1}: {e}") from None
    if any(override_key(o) == "train.seed" for o in overrides):  # it would give every run one seed
        raise SteerlabError("override train.seed: an experiment's runs take the seeds 0..N-1 of steerlab experiment "
                            "--seeds; leave it out")
    exp = ExperimentConfig(shared, tuple(entries), closed, replay, tuple(overrides), world)
    names = [e.name for e in exp.entries]
    for i, name in enumerate(names):  # two entries of one name would share their run folders and their row
        if name in names[:i]:
            raise SteerlabError(f"{path}: models entries {names.index(name) + 1} and {i + 1} are both named "
                                f"{name!r}; give one a label")
    for i, entry in enumerate(exp.entries):  # a bad entry is an error before the first model trains
        try:
            cfg = exp.run_config(entry, 0)
            if cfg.dagger is not None:
                dagger_options(cfg)
        except SteerlabError as e:
            raise SteerlabError(f"{path}: models entry {i + 1}: {e}") from None
    return exp


def run_experiment(path: str | Path, overrides=(), seeds: int = 3, progress: bool = True) -> Path:
    """Every entry of the config's `models` list is a training config fragment (`model`, and optionally
    `label`, `preprocess`, `train`, `dagger`) applied on top of the shared config; an entry or the shared
    config with a `dagger` section trains by DAgger. An optional `closed_loop` section ({suite: v1, minutes,
    workers}) drives every trained model on the closed-loop suite; an optional `replay` section ({speed: M/S},
    or {} for the recorded or estimated speed) replays every trained model on the validation frames of the
    recording itself (`steerlab replay`). Finished runs and drives are reused, so an
    interrupted experiment continues where it stopped."""
    exp = load_experiment(path, overrides)
    out = exp.out
    check_outputs({"output folder (out)": out}, inputs=[path, *exp.run_config(exp.entries[0], 0).inputs()],
                  kind="experiment")
    rows, preds, suites = [], {}, {}
    labels = frames = deg = split_replay = cfg = None
    for entry in exp.entries:
        runs = []
        for seed in range(seeds):
            cfg = exp.run_config(entry, seed)
            run_dir = Path(cfg.out)
            done = run_dir / "metrics.json"
            if done.exists() and (changes := run_changes(run_dir, cfg)):
                raise another_config(run_dir, changes)
            if not done.exists():
                if progress:
                    print(f"== {entry.name}, seed {seed}")
                if cfg.dagger is not None:
                    run_dagger(cfg, progress=progress)  # writes metrics.json
                else:
                    write_json(done, train(cfg, progress=progress))
            if labels is None:
                ds = prepare_dataset(cfg, progress=False)
                labels, deg = ds.labels, SteeringConvention(**ds.meta["convention"]).degrees_per_unit
            # the run's own metrics win; those from its predictions fill in metrics added since it was trained
            run = {**_smoothed(run_dir, labels, deg), **json.loads(done.read_text()), "train_s": _train_seconds(run_dir)}
            if exp.closed_loop:
                checkpoint = suite_checkpoint(run_dir, cfg, exp.closed_loop)
                run.update(exp.world.report.metrics(checkpoint, exp.closed_loop, progress, plots=False))
                if seed == 0:
                    suites[entry.name] = checkpoint.parent / "suite"
            if exp.replay is not None:
                split_replay = split_replay or SplitReplay(cfg, exp.replay.speed)
                run.update(split_replay.evaluate(run_dir / "best.pt", run_dir / "replay", progress))
            runs.append(run)
        if frames is None:
            frames = _latency_frames(cfg)
        rows.append(_row(entry.name, cfg.model.name, cfg.preprocessing(), runs,
                         _latency(out / entry.name / "seed0", frames), exp.world))
        preds[entry.name] = read_steering_csv(out / entry.name / "seed0" / "val_predictions.csv")
    _write(out, rows, preds, cfg, seeds, _speed_references(labels, next(iter(preds.values()))[0]), exp.world)
    if suites:
        exp.world.report.plot_drives(out, suites, exp.closed_loop)
    return out / "table.md"


def _speed_references(labels: dict, val_ids: np.ndarray) -> str:
    """What the speed columns must beat on the validation frames: holding the current speed as the next
    frame's, and always predicting the validation frames' most frequent speed command."""
    if "speed" not in labels:
        return ""
    pos = {int(f): i for i, f in enumerate(labels["frame_ids"])}
    idx = np.array([pos[int(f)] for f in val_ids])
    truth = speed_targets(labels["speed"], labels["timestamps_ns"], labels["segment"])
    commands = truth["command"][idx]
    majority = int(np.bincount(commands, minlength=3).argmax())
    return (f"\nReferences on the same validation frames: holding the current speed as the next frame's scores a "
            f"speed MAE of {speed_mae(labels['speed'][idx], truth['speed'][idx]):.3f} m/s; always predicting "
            f"'{COMMANDS[majority]}', the most frequent command there, scores a command accuracy of "
            f"{accuracy(np.full(len(idx), majority), commands):.3f}.\n")


def closed_loop_keys(world: WorldEntry | None) -> list[str]:
    """The closed-loop metrics of an experiment's table in `world` (None: without a suite, none)."""
    return [] if world is None else list(dict.fromkeys(k for c in world.report.table for k in c.keys))


def _row(label: str, model: str, pre: PreprocessConfig, runs: list[dict], latency: dict,
         world: WorldEntry | None) -> dict:
    def stat(key):
        v = np.array([r[key] for r in runs if key in r], float)
        return (v.mean(), v.std()) if len(v) else (np.nan, np.nan)

    row = {"label": label, "model": model,
           "input": "+".join(pre.modalities) + (f" x{pre.stack} frames" if pre.stack > 1 else "") + f" ({pre.color})",
           "shape": f"{sum(pre.channels().values())}@{pre.width}x{pre.height}", "seeds": len(runs),
           "target_gamma_deg": runs[0]["target_gamma_deg"], **latency}
    for key in ("mse", "rmse", "mae", "mae_deg", "gamma_deg", "smoothed_rmse", "smoothed_gamma_deg", "tre", "qce",
                "speed_weighted_mae", "speed_mae", "command_accuracy", "epoch", "train_s", *closed_loop_keys(world),
                *REPLAY):
        row[f"{key}_mean"], row[f"{key}_std"] = stat(key)
    # the worst seed, for targets such as ">= 95 % on every road type with every seed"
    for key in [k for k in closed_loop_keys(world) if k.startswith("autonomy")]:
        row[f"{key}_min"] = min((r[key] for r in runs if key in r), default=np.nan)
    return row


def _train_seconds(run: Path) -> float:
    """Seconds of training from the run's epoch log (a DAgger run: every round's); baselines write none."""
    total = 0.0
    for log in sorted(run.glob("round*/log.csv")) or [run / "log.csv"]:
        if log.exists():
            with open(log) as f:
                total += sum(float(r["seconds"]) for r in csv.DictReader(f))
    return total


def _smoothed(run: Path, labels: dict, deg_per_unit: float) -> dict:
    """The metrics of the run's validation predictions, and their RMSE and gamma after exponential smoothing,
    restarted at every break in the validation frames (a gap in the split or a new segment)."""
    ids, pred, _ = read_steering_csv(run / "val_predictions.csv")
    pos = {int(f): i for i, f in enumerate(labels["frame_ids"])}
    idx = np.array([pos[int(f)] for f in ids])
    breaks = np.flatnonzero((np.diff(idx) != 1) | (np.diff(labels["segment"][idx]) != 0)) + 1
    smooth = exponential_smoothing(pred, restarts=breaks)
    m = steering_metrics(smooth, labels["steering"][idx], deg_per_unit)
    truth = {"steering": labels["steering"][idx]}
    if "speed" in labels:  # as training has it: the next frame's speed
        truth["speed"] = speed_targets(labels["speed"], labels["timestamps_ns"], labels["segment"])["speed"][idx]
    return {**all_metrics({"steering": pred}, truth, deg_per_unit), "smoothed_rmse": m["rmse"],
            "smoothed_gamma_deg": m["gamma_deg"]}


REPLAY = ("replay_autonomy", "replay_interventions_per_km", "replay_mean_offset_m")


def suite_checkpoint(run: Path, cfg: TrainConfig, closed) -> Path:
    """The checkpoint that drives the suite for a run: its best.pt, or for a DAgger run whose last round drove
    the same suite for as many minutes, that round's identical copy, so that the round's drives are reused."""
    best = run / "best.pt"
    if cfg.dagger is None:
        return best
    rounds = round_suite(dagger_options(cfg))
    if rounds is None or rounds.suite != closed.suite or rounds.place_minutes != closed.place_minutes:
        return best
    last = max(run.glob("round*/best.pt"), key=lambda p: int(p.parent.name.removeprefix("round")))
    return last if filecmp.cmp(last, best, shallow=False) else best


def _latency_frames(cfg: TrainConfig) -> list[tuple]:
    """Raw frames (and speeds) of the start of the validation split, for the latency column."""
    rec = main_recording(cfg)
    idx = make_split(cfg.split, len(rec), rec.extra.get("session"))[1][:LATENCY_FRAMES]
    return [(rec.load_frame(i), None if rec.speed is None else rec.speed[i]) for i in idx]


def _latency(run: Path, frames: list[tuple]) -> dict:
    """p50 and p99 of the Pilot's time per decoded frame (preprocessing, flow, model), in milliseconds."""
    ms = measure(Pilot(run / "best.pt"), frames)["pilot"]
    return {"latency_p50_ms": ms["median_ms"], "latency_p99_ms": ms["p99_ms"]}


def _fmt(value: float, digits: int, std: float | None = None) -> str:
    if value is None or np.isnan(value):
        return "-"
    return f"{value:.{digits}f}" + (f" +- {std:.{digits}f}" if std is not None else "")


def _closed_cells(r: dict, world: WorldEntry, worst: bool) -> str:
    """A row's closed-loop cells of table.md: the world's columns (and the worst seed's autonomy per kind)."""
    cells = [(_fmt(r[f"{c.keys[0]}_mean"], c.digits, r[f"{c.keys[0]}_std"]) if c.std
              else " / ".join(_fmt(r[f"{k}_mean"], c.digits) for k in c.keys)) for c in world.report.table]
    if worst:
        cells.append(" / ".join(_fmt(r.get(f"{k}_min", np.nan), world.report.worst.digits) for k in world.report.worst.keys))
    return "".join(f" {c} |" for c in cells)


def _write(out: Path, rows: list[dict], preds: dict, cfg: TrainConfig, seeds: int, references: str,
           world: WorldEntry | None) -> None:
    fields = list(rows[0])
    with open(out / "table.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fields)
        w.writeheader()
        w.writerows(rows)
    closed = world is not None
    worst = closed and seeds > 1
    heads = ([c.header for c in world.report.table] + ([world.report.worst.header] if worst else [])) if closed else []
    lines = [f"{seeds} seed(s) per model (mean +- std over seeds); validation split {as_dict(cfg.split)}; plots: "
             "predictions.png (seed 0)" + (f", {world.suite.figures} (every model's seed-0 drive on each place of the "
                                           "suite)" if closed else "") + ".", "", "Paper 000 Table I form:", "",
             "| model | input | input shape | MSE | gamma [deg] | target gamma [deg] | RMSE | RMSE smoothed "
             f"a={SMOOTHING_ALPHA} | gamma smoothed [deg] | best epoch | train time [s] | latency p50 / p99 [ms] |"
             + "".join(f" {h} |" for h in heads), "|---" * (12 + len(heads)) + "|"]
    for r in rows:
        lines.append(
            f"| {r['label']} | {r['input']} | {r['shape']} | {_fmt(r['mse_mean'], 6, r['mse_std'])} | "
            f"{_fmt(r['gamma_deg_mean'], 3)} | {_fmt(r['target_gamma_deg'], 3)} | {_fmt(r['rmse_mean'], 4)} | "
            f"{_fmt(r['smoothed_rmse_mean'], 4)} | {_fmt(r['smoothed_gamma_deg_mean'], 3)} | "
            f"{_fmt(r['epoch_mean'], 1)} | {_fmt(r['train_s_mean'], 0)} | "
            f"{r['latency_p50_ms']:.2f} / {r['latency_p99_ms']:.2f} |"
            + (_closed_cells(r, world, worst) if closed else ""))
    lines += ["", "Paper 002 Tables I-II form:", "",
              "| model | steering MAE [deg] | speed MAE [m/s] | speed-command accuracy |", "|---|---|---|---|"]
    for r in rows:
        mae = (_fmt(r['mae_deg_mean'], 2, r['mae_deg_std']) if np.isfinite(r['mae_deg_mean'])
               else _fmt(r['mae_mean'], 4, r['mae_std']) + " (steering units)")  # normalized steering
        lines.append(f"| {r['label']} | {mae} | "
                     f"{_fmt(r['speed_mae_mean'], 3, r['speed_mae_std'])} | "
                     f"{_fmt(r['command_accuracy_mean'], 3, r['command_accuracy_std'])} |")
    if not np.isnan(rows[0]["replay_autonomy_mean"]):
        lines += ["", "Closed-loop replay of the validation frames (the recording itself, `steerlab replay`; "
                  "each run's replay.md says the speed):", "",
                  "| model | RMSE | MAE [deg] | replay interventions/km | replay autonomy [%] | mean abs offset [m] |",
                  "|---|---|---|---|---|---|"]
        for r in rows:
            lines.append(f"| {r['label']} | {_fmt(r['rmse_mean'], 4)} | {_fmt(r['mae_deg_mean'], 2)} | "
                         f"{_fmt(r['replay_interventions_per_km_mean'], 1, r['replay_interventions_per_km_std'])} | "
                         f"{_fmt(r['replay_autonomy_mean'], 1)} | {_fmt(r['replay_mean_offset_m_mean'], 3)} |")
    if closed or not np.isnan(rows[0]["replay_autonomy_mean"]):
        lines += ["", _open_vs_closed(out, rows)]
    ds = prepare_dataset(cfg, progress=False)
    ids = next(iter(preds.values()))[0]
    pos = {int(f): i for i, f in enumerate(ds.labels["frame_ids"])}
    idx = np.array([pos[int(f)] for f in ids])
    t = (ds.labels["timestamps_ns"][idx] - ds.labels["timestamps_ns"][idx[0]]) / 1e9
    preds = {k: v[1] for k, v in preds.items()}
    plot_steering(out / "predictions.png", t, ds.steering[idx], preds, title="validation predictions, seed 0")
    if "episode" in ds.labels and plot_recovery(out / "recovery.png", t, ds.steering[idx], preds,
                                                ds.labels["episode"][idx]):
        lines += ["", "Drift-and-recover episodes of the validation frames (paper 000 Fig. 6 form): recovery.png"]
    (out / "table.md").write_text("\n".join(lines) + "\n" + references)


def _open_vs_closed(out: Path, rows: list[dict]) -> str:
    """How well each open-loop metric (and replay, next to the suite) ranks the trained models by autonomy on the
    closed-loop suite, or without a suite in replay, which ranks them best, and the scatter plot."""
    trained = [r for r in rows if r["epoch_mean"] > 0]
    suite = not np.isnan(rows[0].get("autonomy_mean", np.nan))  # without a suite: no closed-loop columns
    target = "autonomy" if suite else "replay autonomy"
    plot_open_vs_closed(out / "open_vs_closed.png", {"models": trained},
                        autonomy="autonomy" if suite else "replay_autonomy")
    keys = [("mse", "MSE"), ("mae_deg", "MAE"), ("gamma_deg", "gamma"), ("smoothed_rmse", "smoothed RMSE"),
            ("smoothed_gamma_deg", "smoothed gamma"), ("tre", "TRE"), ("qce", "QCE"),
            ("speed_weighted_mae", "speed-weighted MAE")]
    if suite and not np.isnan(rows[0]["replay_autonomy_mean"]):
        keys.append(("replay_interventions_per_km", "replay interventions/km"))
    autonomy = [r["autonomy_mean" if suite else "replay_autonomy_mean"] for r in trained]
    rhos = [rank_correlation([r[f"{k}_mean"] for r in trained], autonomy) for k, _ in keys]
    if all(np.isnan(rhos)):
        return (f"Rank correlation of the open-loop metrics with {target}: not defined here (it needs three or more "
                "trained models that do not all drive equally well). Plot: open_vs_closed.png.")
    rho = ", ".join(f"{name} {v:+.2f}" if np.isfinite(v) else f"{name} -" for (_, name), v in zip(keys, rhos))
    # every metric is lower-is-better: the most negative correlation ranks the models most like their driving
    # (the first listed wins a tie)
    best, v = min(((name, v) for (_, name), v in zip(keys, rhos) if np.isfinite(v)), key=lambda p: p[1])
    verdict = (f"The open-loop metric that predicts driving best here is {best} ({v:+.2f})." if v < 0 else
               "No open-loop metric here ranks the models the way they drive (none correlates negatively).")
    return (f"Rank correlation (Spearman) of each metric with {target} over the {len(trained)} trained "
            f"models (-1: lower error always drives better): {rho}. {verdict} Plot: open_vs_closed.png.")
