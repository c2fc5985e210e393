"""Every config shipped in configs/ loads (known sections and train options) and names models that build with
its options, so a typo in a config is caught here rather than an hour into an experiment."""

from pathlib import Path

import pytest
import yaml

from steerlab.experiment import load_experiment
from steerlab.dagger import dagger_options
from steerlab.options import as_dict
from steerlab.sim.road.suite import suite_options
from steerlab.train.config import load_config

CONFIGS = sorted((Path(__file__).parent.parent / "configs").glob("*.yaml"))


@pytest.mark.parametrize("path", CONFIGS, ids=[p.name for p in CONFIGS])
def test_shipped_config_loads_and_builds(path):
    """Parsing a config builds its model on an input of its preprocessing (a model that cannot take it fails)."""
    raw = yaml.safe_load(path.read_text())
    if "models" in raw:  # an experiment: every entry is a run config of its own
        exp = load_experiment(path)
        cfgs = [exp.run_config(entry, 0) for entry in exp.entries]
        assert len({c.out for c in cfgs}) == len(cfgs), "two entries would share a run folder (set a label)"
    else:
        cfgs = [load_config(path)]
        if cfgs[0].closed_loop is not None:
            suite_options(cfgs[0].closed_loop, "closed_loop")
    for cfg in cfgs:
        if cfg.dagger is not None:
            dagger_options(cfg)


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
    """A config that names only a tub trains the tub default (multimodal-lstm on the MAE, batch 32, Adam 3e-4);
    what the user sets still wins, and other recordings keep the general defaults."""
    tub = tmp_path / "tub"
    tub.mkdir()
    (tub / "manifest.json").write_text("{}")
    (tub / "catalog_0.catalog").write_text("")
    cfg = load_config(None, [f"data={tub}"])
    assert cfg.model.name == "multimodal-lstm"
    assert (cfg.train.loss, cfg.train.batch_size, cfg.train.lr) == ("mae", 32, 3e-4)
    assert cfg.train.epochs == 30  # the general defaults stay under it
    (tmp_path / "mine.yaml").write_text(f"data: {tub}\nmodel: {{name: pilotnet}}\ntrain: {{epochs: 4}}\n")
    cfg = load_config(tmp_path / "mine.yaml", ["train.loss=mse"])
    assert (cfg.model.name, cfg.train.loss, cfg.train.epochs, cfg.train.batch_size) == ("pilotnet", "mse", 4, 32)
    cfg = load_config(None, [f"data={tub}", "model.name=two-stream-flow"])  # trains on a loss of its own
    assert (cfg.train.loss, cfg.train.batch_size) == ("mse", 32)
    cfg = load_config(None, [f"data={tmp_path / 'ch2'}"])
    assert (cfg.model.name, cfg.train.loss, cfg.train.batch_size) == ("pilotnet", "mse", 100)
