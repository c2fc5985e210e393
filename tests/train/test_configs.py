"""Every config shipped in configs/ builds what it is documented to build: its model(s) with their options and
input, the split and the train options, and its dagger:, closed_loop:, replay: and tune: sections parsed; and every
value a config writes reaches what is built. A typo in a config, or a default that changes what a config trains,
is caught here rather than an hour into an experiment."""

from pathlib import Path

import pytest
import yaml

from steerlab.dagger import dagger_options
from steerlab.experiment import load_experiment
from steerlab.options import as_dict
from steerlab.sim.worlds import closed_loop
from steerlab.train.config import load_config
from steerlab.tune.space import search_space
from tests.train.shipped import EXPECTED

ROOT = Path(__file__).resolve().parents[2]
CONFIGS = sorted((ROOT / "configs").glob("*.yaml"))

# The donkeycar tubs the configs train on: the two real tubs and the track world's recordings (`steerlab sim
# record --world track` writes tubs). A tub's config gets the tub defaults under its own settings, so what such a
# config builds depends on the data being a tub; the test puts stand-in tubs there.
TUBS = ["../shared/data/donkeycar/hall", "../shared/data/donkeycar/taped-track",
        *(f"runs/track/tub-{k}" for k in range(1, 5)), *(f"runs/race/tubs/taped-{k}-1min" for k in range(5, 17)),
        *(f"runs/race/tubs/centre-{k}-1min" for k in range(17, 21))]


def run_line(cfg) -> str:
    """What a run config trains, in words."""
    pre, t = cfg.preprocessing(), cfg.train
    options = ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                        for k, v in sorted(cfg.model.options.items()))
    line = f"{cfg.model.name}({options}) {sum(pre.channels().values())}@{pre.width}x{pre.height} {pre.color}"
    if "flow" in pre.modalities:
        line += f" {pre.flow} flow"
    line += f", split {cfg.split.train}/{cfg.split.val}, epochs {t.epochs}"
    line += " keeping the last" if t.keep == "last" else f" with patience {t.patience}"
    line += f", batch {t.batch_size}, lr {t.lr:g}, {t.loss}"
    parts = [line] + [words for given, words in [
        (t.throttle_weight, f"throttle weight {t.throttle_weight:g}"),
        (t.flip, "flips"),
        (t.side_cameras, "side cameras"),
        (t.min_speed, f"from {t.min_speed:g} m/s"),
        (t.motion_dropout, f"motion dropout {t.motion_dropout:g}"),
        (t.rotation_deg, f"rotation +-{t.rotation_deg:g} deg"),
        (t.brightness, f"brightness 1 +- {t.brightness:g}"),
        (t.hue_deg, f"hue +-{t.hue_deg:g} deg"),
        (t.target_shift_s, f"target {t.target_shift_s:g} s ahead"),
        (t.recovery_weight > 1, f"recover episodes drawn {t.recovery_weight} times"),
        (t.epoch_samples, f"at least {t.epoch_samples} samples an epoch"),
        (t.exclude_episodes, "without " + " and ".join(t.exclude_episodes)),
        (t.views, "views " + " ".join(v.describe() for v in t.views)),
        (t.recovery_distance_m, f"returning within {t.recovery_distance_m or 0:g} m"),
        (t.views and t.recovery_distance_m is None, f"back on the path in {t.recovery_s:g} s"),
        (cfg.extra_data, f"{len(cfg.extra_data)} extra recordings"),
        (t.init, f"from {t.init}"),
    ] if given]
    return ", ".join(parts)


def dagger_line(o) -> str:
    where = {"road": "the road world", "track": "the track world", "replay": "replay"}[o.world]
    line = f"dagger in {where}: {o.iterations} rounds of {o.epochs} epochs, beta {o.beta:g} x {o.beta_decay:g} a round"
    if o.world == "road":
        line += f", {o.minutes:g} min of {o.own.roads} roads"
    if o.world == "track":
        line += f", {o.minutes:g} min of tracks"
    if o.world == "replay":
        line += f", at {o.own.speed:g} m/s" if o.own.speed else ", at the recorded speed"
    elif o.suite:
        line += f", suite {o.suite}" + (f" at {o.suite_minutes:g} min" if o.suite_minutes else "")
    return line + f", workers {o.workers}"


def tune_line(space) -> str:
    parts = []
    for key, d in space.items():
        if hasattr(d, "choices"):
            parts.append(f"{key} " + " or ".join(map(str, d.choices)))
        else:
            parts.append(f"{key} {d.low:g}..{d.high:g}" + (" log" if d.log else ""))
    return "tune: " + ", ".join(parts)


def plain(value):
    """A parsed value as YAML writes it: tuples as lists, a value that writes itself (a view) as it does."""
    if hasattr(value, "as_dict"):
        return value.as_dict()
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    return value


def assert_written_reaches(cfg, written: dict) -> None:
    """Every value of the sections `written` (a config's, as YAML read it) is the parsed config's."""
    for key, value in written.items():
        if key in ("preprocess", "split", "train"):
            parsed = getattr(cfg, key)
            for k, v in value.items():
                assert plain(getattr(parsed, k)) == v, f"{key}.{k}"
        elif key == "model":
            assert cfg.model.name == value["name"]
            assert {k: v for k, v in value.items() if k != "name"} == dict(cfg.model.options)
        elif key not in ("dagger", "tune", "closed_loop", "replay", "models"):
            assert plain(getattr(cfg, key)) == value, key


def assert_section_reaches(options, written: dict) -> None:
    for key, value in written.items():  # a dagger section's keys of its world: its own options
        assert getattr(options if hasattr(options, key) else options.own, key) == value, key


@pytest.fixture
def stand_in_tubs(tmp_path, monkeypatch):
    """A working folder where the configs' tubs are tubs (a manifest and a catalog), so that a config builds what
    it builds on its real data whether ../shared is there or not."""
    repo = tmp_path / "repo"
    for tub in TUBS:
        folder = repo / tub
        folder.mkdir(parents=True)
        (folder / "manifest.json").write_text("{}")
        (folder / "catalog_0.catalog").write_text("")
    monkeypatch.chdir(repo)


def test_every_shipped_config_is_listed():
    assert sorted(EXPECTED) == [p.name for p in CONFIGS]


@pytest.mark.parametrize("path", CONFIGS, ids=[p.name for p in CONFIGS])
def test_shipped_config_builds_what_it_says(path, stand_in_tubs):
    """Parsing a config builds its model on an input of its preprocessing (a model that cannot take it fails),
    every value it writes reaches the parsed config, and what it trains is what EXPECTED says."""
    assert what_it_builds(path) == EXPECTED[path.name]


def what_it_builds(path: Path) -> list[str]:
    """The lines of EXPECTED for the config `path`, checking on the way that every value it writes is parsed."""
    raw = yaml.safe_load(path.read_text())
    lines = []
    if "models" in raw:  # an experiment: every entry is a run config of its own
        exp = load_experiment(path)
        shared = {k: v for k, v in raw.items() if k not in ("models", "closed_loop", "replay")}
        cfgs = [exp.run_config(entry, 0) for entry in exp.entries]
        assert len({cfg.out for cfg in cfgs}) == len(cfgs), "two entries would share a run folder (set a label)"
        for entry, item, cfg in zip(exp.entries, raw["models"], cfgs):
            lines.append(f"{entry.name}: {run_line(cfg)}")
            written = {**shared, "model": item["model"],
                       "preprocess": {**shared.get("preprocess", {}), **item.get("preprocess", {})},
                       "train": {**shared.get("train", {}), **item.get("train", {})}}
            del written["out"]
            assert_written_reaches(cfg, written)
            assert cfg.out == str(Path(raw["out"]) / entry.name / "seed0")
            if cfg.dagger is not None:
                assert_section_reaches(dagger_options(cfg), {**raw.get("dagger", {}), **item.get("dagger", {})})
        if "dagger" in raw:
            lines.append(dagger_line(dagger_options(cfgs[0])))
        if exp.closed_loop is not None:
            assert_section_reaches(exp.closed_loop, raw["closed_loop"])
            o = exp.closed_loop
            lines.append(f"closed loop: suite {o.suite}, {o.place_minutes:g} min per road, workers {o.workers}")
        if exp.replay is not None:
            assert_section_reaches(exp.replay, raw["replay"])
            lines.append("replay " + (f"at {exp.replay.speed:g} m/s" if exp.replay.speed else "at the recorded speed"))
    else:
        cfg = load_config(path)
        lines.append(run_line(cfg))
        assert_written_reaches(cfg, raw)
        if cfg.dagger is not None:
            o = dagger_options(cfg)
            assert_section_reaches(o, raw["dagger"])
            lines.append(dagger_line(o))
        if cfg.closed_loop is not None:
            assert_section_reaches(closed_loop(cfg.closed_loop)[1], raw["closed_loop"])
        if cfg.tune is not None:
            space = search_space(cfg.tune, cfg)
            for key, rng in raw["tune"].items():
                d = space[key]
                assert (list(d.choices) if isinstance(rng, list) else {"low": d.low, "high": d.high, "log": d.log}) \
                    == (rng if isinstance(rng, list) else {"log": False, **rng}), key
            lines.append(tune_line(space))
    return lines


def test_run_config_merges_entry_over_shared_sections(tmp_path):
    (tmp_path / "exp.yaml").write_text(yaml.safe_dump({
        "data": "runs/x", "out": "runs/exp", "preprocess": {"preset": "sim", "color": "gray"},
        "train": {"epochs": 5, "batch_size": 64},
        "models": [{"label": "flow b8", "model": {"name": "pilotnet"}, "preprocess": {"color": "yuv"},
                    "train": {"batch_size": 8}}]}))
    exp = load_experiment(tmp_path / "exp.yaml", ["train.lr=0.001"])
    cfg = exp.run_config(exp.entries[0], 2)
    assert {k: v for k, v in as_dict(cfg.preprocess).items() if v is not None} == {"preset": "sim", "color": "yuv"}
    assert (cfg.train.epochs, cfg.train.batch_size, cfg.train.seed, cfg.train.lr) == (5, 8, 2, 0.001)
    assert cfg.out == str(Path("runs/exp") / "flow b8" / "seed2")


def test_a_donkeycar_tub_gets_the_tub_defaults_under_the_users_settings(tmp_path):
    """A config that names only a tub trains the tub defaults (donkey-linear on the whole 160x120 RGB frame, the MAE,
    batch 32, Adam 3e-4, the views where the reader gives the full lock); what the user sets still wins, a model
    section of the user's keeps its input and gets no views, and other recordings keep the general defaults."""
    tub = tmp_path / "tub"
    tub.mkdir()
    (tub / "manifest.json").write_text("{}")
    (tub / "catalog_0.catalog").write_text("")
    full_lock = "reader={full_lock_deg: 25}"
    cfg = load_config(None, [f"data={tub}", full_lock])
    assert cfg.model.name == "donkey-linear"
    assert (cfg.preprocess.crop, cfg.preprocess.width, cfg.preprocess.height, cfg.preprocess.color) == (
        (0, 0, 0, 0), 160, 120, "rgb")
    assert (cfg.train.loss, cfg.train.batch_size, cfg.train.lr, cfg.train.throttle_weight) == ("mae", 32, 3e-4, 0.5)
    assert ([[list(v.shift_m), list(v.yaw_deg)] for v in cfg.train.views], cfg.train.recovery_s) == (
        [[[-0.15, 0.15], [-15, 15]]], 0.3)
    assert cfg.train.epochs == 30  # the general defaults stay under it
    cfg = load_config(None, [f"data={tub}"])  # without the full lock: no views (training says so)
    assert (cfg.model.name, cfg.train.views) == ("donkey-linear", ())
    cfg = load_config(None, [f"data={tub}", full_lock, "train.recovery_s=0.5"])  # a view option of the user's
    assert (len(cfg.train.views), cfg.train.recovery_s) == (1, 0.5)
    for own in ("train.views=[]", "train.side_cameras=false", "train.lane_weight=0"):  # a recovery of the user's
        cfg = load_config(None, [f"data={tub}", full_lock, own])
        assert (cfg.model.name, cfg.train.views, cfg.train.recovery_s) == ("donkey-linear", (), 1.0), own
    (tmp_path / "mine.yaml").write_text(f"data: {tub}\nmodel: {{name: pilotnet}}\ntrain: {{epochs: 4}}\n")
    cfg = load_config(tmp_path / "mine.yaml", ["train.loss=mse", full_lock])
    assert (cfg.model.name, cfg.train.loss, cfg.train.epochs, cfg.train.batch_size) == ("pilotnet", "mse", 4, 32)
    assert (cfg.preprocess, cfg.train.views) == (load_config(None, ["data=x"]).preprocess, ())  # its own input
    cfg = load_config(None, [f"data={tub}", "model.name=two-stream-flow"])  # trains on a loss of its own
    assert (cfg.train.loss, cfg.train.batch_size) == ("mse", 32)
    cfg = load_config(None, [f"data={tmp_path / 'ch2'}"])
    assert (cfg.model.name, cfg.train.loss, cfg.train.batch_size, cfg.train.views) == ("pilotnet", "mse", 100, ())


def test_track_best_is_the_recipe_the_closed_loop_chose(stand_in_tubs):
    """configs/track_best.yaml trains what `studies/track_recipes.py` raced as its chosen recipe: the same tubs, input,
    network and training options, and each race of its header drives as the recipe raced at that cap (its throttle
    scale and floor at rest; docs/results/racing.md, "Racing the track world"), on the selection suite and on t2."""
    from studies import track_recipes as recipes

    best = load_config(ROOT / "configs" / "track_best.yaml")
    chosen = recipes.RECIPES["best-floor-0.2"]
    trained = chosen.starts
    assert not chosen.overrides and set(chosen.race) == {"throttle_scale", "throttle_floor"}
    benches = [line for line in (ROOT / "configs" / "track_best.yaml").read_text().split("\n#   .venv/bin/steerlab ")
               if line.startswith("sim bench")]
    assert [bench.split("--suite ")[1].split()[0] for bench in benches] == ["s1", "t2"]
    for bench in benches:
        assert "--max-throttle 1 " in bench and f"--throttle-scale {chosen.race['throttle_scale']:g} " in bench
        assert f"--throttle-floor {chosen.race['throttle_floor']:g} " in bench, bench
    raced = recipes.recipe_base(trained, Path("runs/race/tubs")) | {"split": as_dict(best.split)}
    overrides = recipes.RECIPES[trained].overrides
    raced = load_config(None, base=raced, overrides=[*overrides, "train.seed=0"])
    assert [best.data, *best.extra_data] == [raced.data, *raced.extra_data]
    for section in ("reader", "preprocess", "model", "train"):
        assert as_dict(getattr(best, section)) == as_dict(getattr(raced, section)), section


def test_the_recipe_table_says_what_each_row_raced():
    """The study's table names each row's recipe; donkeycar's runs on another recipe's tubs, and with their throttle
    scaled (`--donkeycar-throttle-scale`), say so."""
    from studies import track_recipes as recipes

    row = dict(cap=0.5, runs=3, laps=55.0, clean_pct=61.0, finished=4.7, tracks=8, off_track_per_lap=2.45,
               off_track=139.3, pace=0.997, pace_tracks=3, each=[], training_min=None, training_each=[])
    names = ("mae-throttle-2", "donkeycar-rooms", "donkeycar-rooms-throttle-2")
    lines = recipes.markdown([dict(row, recipe=name) for name in names], "t1").splitlines()[-3:]
    assert [line.split(" | ")[1] for line in lines] == [
        recipes.RECIPES["mae-throttle-2"].what, "donkeycar's own trainer and part, on the tubs of rooms",
        "donkeycar's own trainer and part, on the tubs of rooms, its throttle times 2 before the cap"]
    assert lines[0].endswith("| 0.5 | 3 | 55.0 | 61.0 | 4.7 of 8 | 2.45 | 139.3 | 0.997 (3) | - |")


def test_a_number_in_exponent_form_is_a_number_and_a_number_quoted_is_refused(tmp_path):
    """YAML 1.2 reads 1e-3 as a number (PyYAML's YAML 1.1 reads it as text unless written 1.0e-3), so a config says
    lr: 1e-3 as people write it; a number in quotes is text, refused by a number option as an integer one refuses
    it, in the file and on the command line."""
    from steerlab.errors import SteerlabError
    from steerlab.train.config import load_config

    cfg = tmp_path / "c.yaml"
    cfg.write_text("data: x\ntrain: {lr: 1e-3, rotation_deg: 2E+0}\n")
    loaded = load_config(cfg)
    assert (loaded.train.lr, loaded.train.rotation_deg) == (0.001, 2.0)
    assert load_config(cfg, ["train.lr=5e-4"]).train.lr == 5e-4
    for given in (["train.lr='0.001'"], ['train.lr="1e-3"']):
        with pytest.raises(SteerlabError, match=r"train\.lr must be .*got '(0\.001|1e-3)'"):
            load_config(cfg, given)
