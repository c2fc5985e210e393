"""studies/tub_replay.py: the folds' blocks and the check that replay separates models, on hand-made results."""

import json

import pytest

from steerlab.errors import SteerlabError
from steerlab.options import as_dict
from steerlab.train.config import load_config
from studies.common import ROOT
from studies.common.donkeycar import TUBS, reader
from studies.tub_replay import checkpoint, fold_blocks, fold_config, rows_of


def test_the_folds_score_blocks_no_model_of_the_fold_trained_on():
    assert fold_blocks("last", 1000) == {"train": "0:700", "val": "700:800", "scored": "800:1000"}
    assert fold_blocks("first", 1000) == {"train": "300:1000", "val": "200:300", "scored": "0:200"}
    assert fold_blocks("first", 3076) == {"train": "922:3076", "val": "615:922", "scored": "0:615"}


def _run(per_100m, mae=0.2, m=50.0, **more):
    return {"mae": mae, "interventions": per_100m * m / 100, "m": m, "per_100m": per_100m, **more}


def test_replay_separates_a_block_where_the_best_trained_model_needs_half_of_what_learned_nothing_needs():
    results = {"hall last zero 0": _run(60), "hall last train-mean 0": _run(50), "hall last pilotnet 0": _run(40),
               "hall last pilotnet-views 0": _run(20, throttle_mae=0.1, gamma_deg=2.0, target_gamma_deg=3.5),
               "hall last pilotnet-views 1": _run(30, throttle_mae=0.3, gamma_deg=1.0, target_gamma_deg=3.5),
               "hall last other-track taped-track-0": _run(90),
               "hall first zero 0": _run(60), "hall first pilotnet-views 0": _run(31),
               "hall first other-track taped-track-0": _run(70)}
    lines, checks = rows_of(results, ["hall"])
    assert checks[("hall", "last")] == (25.0, 50.0, True)  # the views model's two runs: 25; train-mean 50
    assert checks[("hall", "first")] == (31.0, 60.0, False)  # 60 < 2 x 31
    assert "| hall | last (50 m) | pilotnet-views | 2 | 0.2000 (0.2000-0.2000) | - | 0.2000 (0.1000-0.3000) | " \
        "1.500 (1.000-2.000) | 12.5 (10.0-15.0) | 25.0 (20.0-30.0) |" in lines
    assert "| hall | last (50 m) | zero | 1 | 0.2000 | - | - | - | 30.0 | 60.0 |" in lines
    assert "| hall | last | the human (recorded) | | | | | 3.500 | | |" in lines
    assert "| hall | last | **separates** | | | | | | | yes: the best trained model 25.0, the best that learned " \
        "nothing or another track 50.0 |" in lines
    assert lines[-1].endswith("| no: the best trained model 31.0, the best that learned nothing or another track 60.0 |")


def test_donkeycars_linear_model_counts_as_a_trained_model_and_every_mae_is_given_over_its():
    lines, checks = rows_of({"hall last zero 0": _run(60), "hall last donkeycar-linear 0": _run(24, mae=0.25),
                             "hall last pilotnet 0": _run(40, mae=0.2), "hall last pilotnet 1": _run(40, mae=0.1)},
                            ["hall"])
    assert checks[("hall", "last")] == (24.0, 60.0, True)
    assert "| hall | last (50 m) | pilotnet | 2 | 0.1500 (0.1000-0.2000) | 0.60x | - | - | 20.0 (20.0-20.0) | " \
        "40.0 (40.0-40.0) |" in lines


def test_a_block_without_trained_or_null_models_is_not_judged():
    _, checks = rows_of({"hall last zero 0": _run(60)}, ["hall", "wood-tape"])
    assert checks == {("hall", "last"): (None, 60.0, None)}


needs_tubs = pytest.mark.skipif(not (TUBS / "hall" / "manifest.json").exists(), reason="../shared/data absent")


@needs_tubs
def test_each_trained_model_is_its_recipe_on_the_fold_blocks(tmp_path):
    from steerlab.files import read_yaml

    def cfg(model):
        return fold_config(tmp_path, "hall", "first", model, 1, 10, 1000)

    assert (cfg("pilotnet").model.name, cfg("pilotnet").train.views) == ("pilotnet", ())
    assert [(v.shift_m, v.yaw_deg) for v in cfg("pilotnet-views").train.views] == [((-0.15, 0.15), (-15, 15))]
    assert (cfg("tub-default").model.name, cfg("tub-default").train.loss) == ("multimodal-lstm", "mae")  # of then
    assert cfg("tub-default-views").train.recovery_s == 0.3
    linear = cfg("linear-views")
    assert (linear.model.name, linear.preprocess.width, linear.preprocess.height, linear.preprocess.color,
            linear.train.loss, len(linear.train.views)) == ("donkey-linear", 160, 120, "rgb", "mae", 1)
    bare = cfg("linear")  # the tub defaults without the views
    assert (bare.train.views, as_dict(bare.model), as_dict(bare.preprocess)) == ((), as_dict(linear.model),
                                                                               as_dict(linear.preprocess))
    assert as_dict(bare.train) == as_dict(linear.train) | {"views": [], "recovery_s": 1.0}  # no views, no return
    for gentle in (0.2, 0.6, 0.9):  # linear-views but for the point its views' labels pursue
        other = cfg(f"linear-views-{gentle}")
        assert other.train.recovery_s == gentle and linear.train.recovery_s == 0.3
        assert as_dict(other.train) == as_dict(linear.train) | {"recovery_s": gentle}
        assert (as_dict(other.model), as_dict(other.preprocess)) == (as_dict(linear.model), as_dict(linear.preprocess))
    best, shipped = cfg("track-best"), read_yaml(ROOT / "configs" / "track_best.yaml")
    assert (best.model.name, best.preprocess.width, best.train.hue_deg, best.train.flip) == (
        shipped["model"]["name"], shipped["preprocess"]["width"], shipped["train"]["hue_deg"], True)
    for model in ("zero", "track-best"):
        c = cfg(model)
        assert (c.split.train, c.split.val, c.train.epochs, c.train.patience, c.train.seed) == (
            "300:1000", "200:300", 10, 3, 1)
        assert c.out == str(tmp_path / "hall" / "first" / f"{model}-1")


@needs_tubs
def test_the_tub_defaults_are_the_recipe_the_study_chose(tmp_path):
    """A tub's config that names no model trains what the study's chosen `linear-views` trains: the same input,
    network and training (`TUB_DEFAULTS`, docs/results/donkeycar.md "The tub defaults: linear-views")."""
    chosen = fold_config(tmp_path, "hall", "last", "linear-views", 0, 30, 1000, patience=5)
    shipped = load_config(None, base={"data": chosen.data, "reader": reader("hall")},
                          overrides=["train.epochs=30", "train.patience=5"])
    assert (as_dict(shipped.preprocess), as_dict(shipped.model)) == (as_dict(chosen.preprocess),
                                                                     as_dict(chosen.model))
    assert as_dict(shipped.train) == as_dict(chosen.train) | {"seed": shipped.train.seed}


@needs_tubs
def test_a_finished_run_of_another_recipe_is_refused_not_reused(tmp_path):
    run = tmp_path / "hall" / "last" / "tub-default-0"
    run.mkdir(parents=True)
    other = fold_config(tmp_path, "hall", "last", "pilotnet", 0, 10, 1000)
    (run / "config.json").write_text(json.dumps(as_dict(other)))
    (run / "best.pt").write_bytes(b"")
    with pytest.raises(SteerlabError, match="tub-default's finished run of another config .*model.name"):
        checkpoint(tmp_path, "hall", "last", "tub-default", 0, 10, 1000)
    (run / "config.json").write_text(json.dumps(as_dict(fold_config(tmp_path, "hall", "last", "tub-default", 0, 10,
                                                                    1000))))
    assert checkpoint(tmp_path, "hall", "last", "tub-default", 0, 10, 1000) == run / "best.pt"  # its own: reused


def test_the_recipe_is_chosen_on_the_selection_blocks_by_its_interventions_over_each_tubs_best():
    """Per tub and model scored on both folds: the mean over the folds (of the mean over its runs) of the selection
    blocks' interventions per 100 m, plus one, over the tub's best's plus one; the choice the lowest mean ratio over
    the tubs. hall: pilotnet (10 + 30) / 2 = 20 (the best), pilotnet-views ((25 + 35) / 2 + 30) / 2 = 30: 1, 31/21;
    track-best scored on `last` alone is left out. wood-tape: pilotnet 30, pilotnet-views 0 (the best): 31, 1. Over
    both tubs pilotnet-views (1.476 + 1) / 2 = 1.24x, pilotnet (1 + 31) / 2 = 16.00x. The scored blocks, null models
    and donkeycar's model (no selection score) do not count."""
    from studies.tub_replay import selection_rows

    def run(scored, selection):
        return {**_run(scored), "selection": _run(selection)}

    results = {"hall last pilotnet 0": run(50, 10), "hall first pilotnet 0": run(50, 30),
               "hall last pilotnet-views 0": run(50, 25), "hall last pilotnet-views 1": run(50, 35),
               "hall first pilotnet-views 0": run(50, 30), "hall last track-best 0": run(1, 1),
               "hall last zero 0": run(90, 1), "hall last donkeycar-linear 0": _run(5),
               "wood-tape last pilotnet 0": run(40, 30), "wood-tape first pilotnet 0": run(40, 30),
               "wood-tape last pilotnet-views 0": run(40, 0), "wood-tape first pilotnet-views 0": run(40, 0)}
    lines, chosen = selection_rows(results, ["hall", "wood-tape"])
    assert "| hall | pilotnet-views | 3 | 0.2000 (0.2000-0.2000) | 30.0 (25.0-35.0) | 1.48 |" in lines
    assert "| hall | pilotnet | 2 | 0.2000 (0.2000-0.2000) | 20.0 (10.0-30.0) | 1.00 |" in lines
    assert "| wood-tape | pilotnet | 2 | 0.2000 (0.2000-0.2000) | 30.0 (30.0-30.0) | 31.00 |" in lines
    assert not any("track-best" in line for line in lines)
    assert chosen.startswith("Chosen (the fewest replay interventions per 100 m on the selection blocks, each tub's "
                             "count over its best trained model's (both plus one), averaged over the tubs): "
                             "**pilotnet-views**, 1.24x")
    assert chosen.endswith("pilotnet-views 1.24x, pilotnet 16.00x")
