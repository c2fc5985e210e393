"""Replay against the truth of a world's suite (`studies/replay_vs_road_suite.py`,
`studies/replay_vs_track_suite.py`): `record_expert`, `train_baseline`, `train_snapshots`, `replayed`,
`replay_missing`, `r2`, `correlations`, `correlation_table`, `scatter_axes`, `write_table`."""

from __future__ import annotations

import csv
import json
import shutil
import sys
import time
from pathlib import Path

import numpy as np

# replay against the truth of a world's suite

def record_expert(world: str, out: Path, minutes: float) -> dict[tuple[str, int], Path]:
    """The expert on every place of the default suite of `world` ("road": its roads, "track": its tracks), for
    `minutes` each, recorded for evaluation: the suite's own road or track, as the suite's drives for those
    minutes see it (`record_options` of the world's suite options, `record(..., suite_ok=True)`), into
    out/expert/<kind>-<seed>. A recording of the same minutes is reused; one of other minutes is recorded anew, and
    its replays (out/replay/<kind>-<seed>) are deleted."""
    from steerlab.sim.worlds import WORLDS

    w = WORLDS[world]
    suite = w.suite.options(minutes=minutes)
    recs = {}
    for kind, seed in suite.drives():
        folder = out / "expert" / f"{kind}-{seed}"
        stamp = folder / "minutes.json"
        if not (stamp.exists() and json.loads(stamp.read_text())["minutes"] == minutes):
            shutil.rmtree(folder, ignore_errors=True)
            shutil.rmtree(out / "replay" / folder.name, ignore_errors=True)
            t0 = time.time()
            w.record.run(folder, suite.record_options(kind, seed), progress=False, suite_ok=True)
            stamp.write_text(json.dumps({"minutes": minutes}))
            print(f"recorded the expert on {kind}-{seed} ({minutes:g} min) in {time.time() - t0:.0f} s", flush=True)
        recs[(kind, seed)] = folder
    return recs


def train_baseline(name: str, config, folder: Path) -> Path:
    """A baseline model (zero, train-mean) trained by `config` (a `TrainConfig`) and its best.pt copied to
    folder/<name>.pt; reused when there."""
    from steerlab.train.loop import train

    target = folder / f"{name}.pt"
    if not target.exists():
        folder.mkdir(parents=True, exist_ok=True)
        train(config, progress=False)
        shutil.copy(Path(config.out) / "best.pt", target)
    return target


def train_snapshots(name: str, config, keep: list[int], folder: Path) -> list[Path]:
    """Checkpoints of one training run at several stages: `config` (a `TrainConfig` of max(keep) epochs) trained
    once, the weights after each epoch of `keep` copied to folder/<name>-e<epoch>.pt; reused when all are there.
    A run interrupted between two snapshots resumes; one that cannot give a missing snapshot any more ends the
    study with the folder to delete."""
    from steerlab.train.loop import train

    targets = {e: folder / f"{name}-e{e}.pt" for e in keep}
    if all(t.exists() for t in targets.values()):
        return list(targets.values())
    folder.mkdir(parents=True, exist_ok=True)
    run, t0 = Path(config.out), time.time()

    def on_epoch(epoch, metrics):
        print(f"  {name} epoch {epoch}: val rmse {metrics['rmse']:.4f} ({time.time() - t0:.0f} s)", flush=True)
        if epoch in targets:
            shutil.copy(run / "last.pt", targets[epoch])

    train(config, progress=False, on_epoch=on_epoch)
    if not targets[max(keep)].exists():  # the run had already finished its epochs before it was stopped
        shutil.copy(run / "last.pt", targets[max(keep)])
    missing = [str(t) for t in targets.values() if not t.exists()]
    if missing:
        sys.exit(f"{name}: the snapshots {', '.join(missing)} are missing; delete {run} to train it again")
    print(f"trained {name} ({max(keep)} epochs) in {time.time() - t0:.0f} s", flush=True)
    return list(targets.values())


def replayed(where: Path) -> dict[str, dict]:
    """The rows of every replay.csv in the sub-folders of `where`, by checkpoint label."""
    rows = {}
    for f in sorted(where.glob("*/replay.csv")):
        with open(f, newline="") as table:
            rows.update({r["checkpoint"]: r for r in csv.DictReader(table)})
    return rows


def replay_missing(ckpts: list[Path], labels: list[str], source, where: Path, options, what: str) -> dict[str, dict]:
    """Replay on the recording of `source` (a `Source`) with `options` (a world's replay options) the checkpoints
    whose label is not replayed in `where` yet, together, into a new numbered sub-folder of `where` (so that a
    later run with more checkpoints adds a batch); `what` names the recording in the line printed. Returns
    `replayed(where)`."""
    from steerlab.sim.replay.run import run_replay

    done = replayed(where)
    missing = [c for c, label in zip(ckpts, labels) if label not in done]
    if missing:
        t0 = time.time()
        run_replay(missing, source, where / str(len(list(where.glob("*/replay.csv")))), options, progress=False)
        print(f"replayed {len(missing)} checkpoints on {what} in {time.time() - t0:.0f} s", flush=True)
    return replayed(where)


def r2(x, y) -> float:
    """The squared Pearson correlation (a straight line's fit); NaN for fewer than three points or a constant."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    if len(x) < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return float("nan")
    return float(np.corrcoef(x, y)[0, 1] ** 2)


def correlations(truth, replay) -> dict:
    """Spearman's rank correlation (tied values share their mean rank), R^2 and the number of points."""
    from steerlab.evaluate.plots import rank_correlation

    return {"spearman": rank_correlation(replay, truth), "r2": r2(replay, truth), "n": len(truth)}


def correlation_table(groups: dict[str, list[tuple[float, float]]], place: str, truth: str,
                      replay: str) -> list[str]:
    """A Markdown table of replay against truth in groups of places (a road type, a track style, "all"), one
    (truth, replay) pair per checkpoint and place: the pairs, Spearman, R^2 and the means. `place` names a place
    ("road"), `truth` and `replay` the two measures ("int/km")."""
    lines = [f"| {place}s | pairs (checkpoint x {place}) | Spearman | R^2 | true {truth} (mean) | "
             f"replay {replay} (mean) |", "|---|---|---|---|---|---|"]
    for group, pairs in groups.items():
        t, p = np.array(pairs, float).T
        c = correlations(t, p)
        lines.append(f"| {group} | {len(pairs)} | {c['spearman']:.3f} | {c['r2']:.3f} | {t.mean():.2f} | "
                     f"{p.mean():.2f} |")
    return lines


def scatter_axes(ax, labels: list[str], truth, replay, corr: dict, xlabel: str, ylabel: str, title: str = "",
                 fit: bool = False) -> None:
    """One panel of replay against truth: a point per checkpoint with its label, the correlations (`corr`) in the
    title after `title`, and the line y = x or, with `fit` (two measures of different scales), the least-squares
    line."""
    t, p = np.asarray(truth, float), np.asarray(replay, float)
    ax.scatter(t, p, s=25)
    for label, x, y in zip(labels, t, p):
        ax.annotate(label, (x, y), fontsize=6, alpha=0.8, xytext=(2, 2), textcoords="offset points")
    if fit:
        slope, icept = np.polyfit(t, p, 1) if np.ptp(t) > 0 else (0.0, float(p.mean()))
        xs = np.array([t.min(), t.max()])
        ax.plot(xs, slope * xs + icept, "k:", lw=0.8, label=f"fit: replay = {slope:.2f} x truth + {icept:.2f}")
        ax.legend(loc="upper left", fontsize=8)
    else:
        lo, hi = min(t.min(), p.min()), max(t.max(), p.max())
        pad = 0.05 * (hi - lo + 1e-9)
        ax.plot([lo - pad, hi + pad], [lo - pad, hi + pad], "k:", lw=0.8)
    ax.set_title(f"{title}Spearman {corr['spearman']:.2f}, R$^2$ {corr['r2']:.2f} ({corr['n']} checkpoints)")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)


def write_table(path: Path, rows: list[dict]) -> None:
    """Rows of a study's results as CSV, floats to 6 significant digits."""
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, list(rows[0]))
        w.writeheader()
        w.writerows([{k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()} for r in rows])
