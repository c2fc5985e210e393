"""Every config shipped in configs/ loads (known sections and train options) and names models that build with
its options, so a typo in a config is caught here rather than an hour into an experiment."""

from pathlib import Path

import pytest
import yaml

from steerlab.data.preprocess import PreprocessConfig
from steerlab.experiment import run_config
from steerlab.models import create_model
from steerlab.sim.bench import suite_minutes
from steerlab.dagger import dagger_options
from steerlab.train.config import load_config
from steerlab.train.sources import model_options, model_preprocess

CONFIGS = sorted((Path(__file__).parent.parent / "configs").glob("*.yaml"))


def _build(cfg: dict) -> None:
    name = cfg["model"]["name"]
    create_model(name, **model_options(cfg["model"], PreprocessConfig.from_dict(model_preprocess(name, cfg["preprocess"]))))


@pytest.mark.parametrize("path", CONFIGS, ids=[p.name for p in CONFIGS])
def test_shipped_config_loads_and_builds(path):
    raw = yaml.safe_load(path.read_text())
    closed = raw.pop("closed_loop", None)
    if closed:
        suite_minutes(closed.get("suite", "v1"), closed.get("minutes"))
    assert set(raw.pop("replay", None) or {}) <= {"speed"}  # an experiment's replay section
    if "models" in raw:  # an experiment: every entry is a run config of its own
        entries = raw.pop("models")
        assert entries
        cfgs = [run_config(raw, entry, seed=0) for entry in entries]
        assert len({c["out"] for c in cfgs}) == len(cfgs), "two entries would share a run folder (set a label)"
    else:
        cfgs = [load_config(path)]
    for cfg in cfgs:
        _build(cfg)
        if cfg.get("dagger"):
            dagger_options(cfg)


def test_run_config_merges_entry_over_shared_sections():
    raw = {"data": "runs/x", "out": "runs/exp", "preprocess": {"preset": "sim", "color": "gray"},
           "train": {"epochs": 5, "batch_size": 64}}
    entry = {"label": "flow b8", "model": {"name": "pilotnet-flow"}, "preprocess": {"color": "yuv"},
             "train": {"batch_size": 8}}
    cfg = run_config(raw, entry, seed=2, overrides=["train.lr=0.001"])
    assert cfg["preprocess"] == {"preset": "sim", "color": "yuv"}
    assert (cfg["train"]["epochs"], cfg["train"]["batch_size"], cfg["train"]["seed"], cfg["train"]["lr"]) == (
        5, 8, 2, 0.001)
    assert cfg["out"] == str(Path("runs/exp") / "flow b8" / "seed2")


def test_a_donkeycar_tub_gets_the_tub_defaults_under_the_users_settings(tmp_path):
    """A config that names only a tub trains the tub default (multimodal-lstm on the MAE, batch 32, Adam 3e-4);
    what the user sets still wins, and other recordings keep the general defaults."""
    tub = tmp_path / "tub"
    tub.mkdir()
    (tub / "manifest.json").write_text("{}")
    (tub / "catalog_0.catalog").write_text("")
    cfg = load_config(None, [f"data={tub}"])
    assert cfg["model"]["name"] == "multimodal-lstm"
    assert (cfg["train"]["loss"], cfg["train"]["batch_size"], cfg["train"]["lr"]) == ("mae", 32, 3e-4)
    assert cfg["train"]["epochs"] == 30  # the general defaults stay under it
    (tmp_path / "mine.yaml").write_text(f"data: {tub}\nmodel: {{name: pilotnet}}\ntrain: {{epochs: 4}}\n")
    cfg = load_config(tmp_path / "mine.yaml", ["train.loss=mse"])
    assert (cfg["model"]["name"], cfg["train"]["loss"], cfg["train"]["epochs"], cfg["train"]["batch_size"]) == (
        "pilotnet", "mse", 4, 32)
    cfg = load_config(None, [f"data={tub}", "model.name=two-stream-flow"])  # trains on a loss of its own
    assert (cfg["train"]["loss"], cfg["train"]["batch_size"]) == ("mse", 32)
    cfg = load_config(None, [f"data={tmp_path / 'ch2'}"])
    assert (cfg["model"]["name"], cfg["train"]["loss"], cfg["train"]["batch_size"]) == ("pilotnet", "mse", 100)
