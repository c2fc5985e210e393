import warnings

import numpy as np
import pytest

from steerlab.data.labels import speed_commands, speed_targets
from steerlab.data.splits import Split, make_split, paper_protocol
from steerlab.errors import DataError, SteerlabError
from steerlab.evaluate.metrics import (all_metrics, exponential_smoothing, gamma_deg, quantized_classification_error,
                                       speed_weighted_mae, steering_metrics, thresholded_relative_error)
from steerlab.evaluate.scoring import read_steering_csv, score, write_predictions

from conftest import CH2, needs_ch2


def test_gamma_hand_computed():
    # successive differences 1, 2, 3 degrees -> population std sqrt(2/3)
    assert gamma_deg(np.radians([0, 1, 3, 6])) == pytest.approx(np.sqrt(2 / 3))
    assert gamma_deg([0.1, 0.2]) == 0.0 and np.isnan(gamma_deg([0.1]))  # one difference: no spread; none: undefined
    m = steering_metrics(np.radians([1, 1]), np.radians([0, 2]))
    assert m["mae_deg"] == pytest.approx(1.0) and m["rmse"] == pytest.approx(np.radians(1))


def test_exponential_smoothing_hand_computed():
    np.testing.assert_allclose(exponential_smoothing([0, 10, 10], 0.2), [0, 2, 3.6])
    # restarted at index 2 (a new segment): the third value starts afresh
    np.testing.assert_allclose(exponential_smoothing([0, 10, 10, 0], 0.5, restarts=[2]), [0, 5, 10, 5])


def test_speed_commands_hand_made_series():
    t = np.arange(8) * 500_000_000  # 2 Hz, so the 1 s interval spans 2 frames
    v = np.array([10, 10, 10.1, 11, 12, 12, 11, 10.0])
    # acc over [t, t+1 s]: 0.1, 1.0, 1.9, 1.0, -1.0, -2.0, then -2.0 over the last 0.5 s, 0 at the end
    assert speed_commands(v, t).tolist() == [1, 2, 2, 2, 0, 0, 0, 1]


def test_speed_targets_stay_inside_segments():
    t = np.arange(6) * 500_000_000
    v = np.array([10, 11, 12, 5, 5, 4.0])
    out = speed_targets(v, t, np.array([0, 0, 0, 1, 1, 1]))
    assert out["speed"].tolist() == [11, 12, 12, 5, 4, 4]  # next frame's speed; a segment's last keeps its own
    # segment 0: +2 m/s over 1 s, then +1 over the last 0.5 s; segment 1: -1 m/s over 1 s, -2 m/s^2, end
    assert out["command"].tolist() == [2, 2, 1, 0, 0, 1]


def test_speed_metrics_hand_computed():
    pred = {"steering": np.zeros(4), "speed": np.array([10, 11, 12, 13.0]), "command": np.array([0, 1, 1, 2])}
    truth = {"steering": np.zeros(4), "speed": np.array([10, 12, 12, 12.5]), "command": np.array([0, 1, 2, 0])}
    m = all_metrics(pred, truth)
    assert m["speed_mae"] == pytest.approx(1.5 / 4) and m["command_accuracy"] == 0.5
    assert "speed_mae" not in all_metrics({"steering": np.zeros(4)}, truth)


def test_thresholded_relative_error_hand_computed():
    pred, target = np.array([0, 1.05, 2, -1, 0.5]), np.array([0, 1, 1, -1.2, 0])
    # errors 0, 0.05, 1, 0.2, 0.5 against 0.1 |target| = 0, 0.1, 0.1, 0.12, 0: the last three are wrong
    assert thresholded_relative_error(pred, target) == pytest.approx(3 / 5)
    assert thresholded_relative_error(pred, target, threshold=0.2) == pytest.approx(2 / 5)  # 0.2 < 0.24: 4th right
    assert steering_metrics(pred, target)["tre"] == pytest.approx(3 / 5)


def test_quantized_classification_error_hand_computed():
    # normalized steering, full lock 25 deg: the class edges of +-1 deg are +-0.04; -0.04 is straight, 0.04 is not
    target = np.array([-0.12, -0.02, 0, 0.04, 0.2])  # classes -, 0, 0, +, +
    pred = np.array([-0.06, -0.04, 0.036, 0.05, 0.02])  # classes -, 0, 0, +, 0
    assert quantized_classification_error(pred, target, deg_per_unit=25.0) == pytest.approx(1 / 5)
    # radians of a steering wheel: 0.5 and -0.5 deg are both straight, 1.5 deg is not
    m = steering_metrics(np.radians([0.5, 1.5, -2]), np.radians([-0.5, 0.5, -3]))
    assert m["qce"] == pytest.approx(1 / 3)
    assert "qce" not in steering_metrics(pred, target, deg_per_unit=np.nan)  # a tub without full_lock_deg
    with pytest.raises(SteerlabError, match="QCE needs the steering in degrees"):
        quantized_classification_error(pred, target, deg_per_unit=np.nan)


def test_speed_weighted_mae_hand_computed():
    pred, target, speed = np.zeros(5), np.array([0.1, 0.2, 0, 0, -0.1]), np.array([10, 20, 30, 0, 40.0])
    # |error| * speed = 1, 4, 0, 0, 4: mean 1.8, over the mean speed 20 -> 0.09 (the plain MAE is 0.08)
    assert speed_weighted_mae(pred, target, speed) == pytest.approx(0.09)
    assert speed_weighted_mae(pred, target, np.full(5, 7.0)) == pytest.approx(0.08)  # constant speed: the MAE
    m = all_metrics({"steering": pred}, {"steering": target, "speed": speed})
    assert m["speed_weighted_mae"] == pytest.approx(0.09) and "speed_mae" not in m
    assert "speed_weighted_mae" not in all_metrics({"steering": pred}, {"steering": target})  # no speed: absent
    assert "speed_weighted_mae" not in all_metrics({"steering": pred}, {"steering": target, "speed": np.zeros(5)})
    with pytest.raises(SteerlabError, match="needs a moving car"):
        speed_weighted_mae(pred, target, np.zeros(5))


def test_experiment_names_the_metric_that_predicts_driving_best(tmp_path):
    from steerlab.experiment import _open_vs_closed

    def table(autonomy, **metrics):
        keys = ("mse", "mae_deg", "gamma_deg", "smoothed_rmse", "smoothed_gamma_deg", "tre", "qce",
                "speed_weighted_mae")
        return [{"label": f"m{i}", "epoch_mean": 3.0, "rmse_mean": 0.1, "autonomy_mean": a,
                 "replay_autonomy_mean": np.nan, **{f"{k}_mean": metrics.get(k, [np.nan] * 4)[i] for k in keys}} for i, a in enumerate(autonomy)]

    # the smoother models drive worse (gamma +1); QCE ranks the errors exactly as the models drive (-1)
    rows = table([100, 90, 80, 70], mse=[2, 1, 3, 4], mae_deg=[2, 1, 3, 4], gamma_deg=[4, 3, 2, 1], tre=[1, 2, 4, 3],
                 smoothed_rmse=[1, 3, 2, 4], smoothed_gamma_deg=[1, 1, 1, 1], qce=[0.1, 0.2, 0.3, 0.4])
    text = _open_vs_closed(tmp_path, rows)
    assert "MSE -0.80, MAE -0.80, gamma +1.00, smoothed RMSE -0.80, smoothed gamma -, TRE -0.80, QCE -1.00, " \
           "speed-weighted MAE -." in text
    assert "The open-loop metric that predicts driving best here is QCE (-1.00)." in text
    rows = table([70, 80, 90, 100], mse=[2, 1, 3, 4], qce=[0.1, 0.2, 0.3, 0.4])  # lower error, worse driving
    assert "No open-loop metric here ranks the models the way they drive" in _open_vs_closed(tmp_path, rows)


def test_experiment_fills_new_metrics_from_a_runs_predictions(tmp_path):
    """Runs trained before a metric existed get it from their val_predictions.csv."""
    from steerlab.experiment import _smoothed

    labels = {"frame_ids": np.arange(10, 16), "steering": np.radians([7, 0, 2, 2, -3, 0.5]), "segment": np.zeros(6),
              "timestamps_ns": np.arange(6) * 50_000_000, "speed": np.arange(1, 7.0)}
    write_predictions(tmp_path / "val_predictions.csv", labels["frame_ids"][1:], np.radians([0, 2.1, 0.5, -3, 0.9]))
    m = _smoothed(tmp_path, labels, np.degrees(1.0))
    # errors 0, 0.1, 1.5, 0, 0.4 deg: the 3rd and 5th off by more than a tenth; the 3rd straight, not turning
    assert m["tre"] == pytest.approx(2 / 5) and m["qce"] == pytest.approx(1 / 5)
    # weighted by the next frame's speed, 3, 4, 5, 6, 6 (the last frame keeps its own)
    assert m["speed_weighted_mae"] == pytest.approx(np.radians((0.1 * 4 + 1.5 * 5 + 0.4 * 6) / 24))
    assert "smoothed_rmse" in m


def test_splits():
    tr, va = make_split(Split.parse_option({"train": "0:1800", "val": "1800:2400"}, "split"), 2400)
    assert (tr[0], tr[-1], va[0], va[-1]) == (0, 1799, 1800, 2399)
    with pytest.raises(SteerlabError, match="overlap"):
        make_split(Split.parse_option({"train": "0:1900", "val": "1800:2400"}, "split"), 2400)
    with pytest.raises(SteerlabError, match="empty or outside"):
        make_split(Split.parse_option({"train": "0:1800", "val": "2400:2400"}, "split"), 2400)
    tr, va = paper_protocol(33808, 3, 1000)
    assert len(va) == 3000 and len(tr) == 30808 and not np.intersect1d(tr, va).size
    assert (np.diff(va) > 1).sum() == 2


@needs_ch2
def test_score_all_zero_against_leaderboard(tmp_path):
    truth = CH2 / "CH2_final_evaluation.csv"
    import csv
    ids = [int(r["frame_id"]) for r in csv.DictReader(open(truth))]
    pred = tmp_path / "zero.csv"
    write_predictions(pred, ids, np.zeros(len(ids)))
    s = score(truth, pred)
    assert s["rmse_public"] == pytest.approx(0.20678229236453141, abs=1e-6)
    assert s["truth_gamma_deg"] == pytest.approx(0.609, abs=0.001)
    assert s["frames"] == 5614 and s["public_frames"] == 2797


def test_score_refuses_bad_predictions(tmp_path):
    truth = tmp_path / "truth.csv"
    truth.write_text("frame_id,steering_angle,public\n1,0.1,1\n2,0.2,0\n3,0.3,1\n")
    cases = {
        "frame_id,steering_angle\n1,0\n2,0\n": "1 frame ids of the answer file are missing, first 3",
        "frame_id,steering_angle\n1,0\n2,0\n3,0\n4,0\n": "1 frame ids are not in the answer file, first 4",
        "frame_id,steering_angle\n1,0\n2,0\n2,0\n3,0\n": "row 4: duplicate frame_id 2 (first on row 3)",
        "frame_id,steering_angle,frame_id\n1,0,1\n": "pred.csv, row 1: the header names column(s) ['frame_id'] twice",
        "frame_id,angle\n1,0\n": "expected columns 'frame_id,steering_angle', got ['frame_id', 'angle']",
        "frame_id,steering_angle\n1,0\n2,nan\n3,0\n": "row 3: steering_angle is 'nan'",
        "id,angle\n1,0\n": "expected columns",
    }
    for text, message in cases.items():
        pred = tmp_path / "pred.csv"
        pred.write_text(text)
        with pytest.raises(DataError) as e:
            score(truth, pred)
        assert message in str(e.value)
    pred.write_text("frame_id,steering_angle\n3,0.3\n1,0.1\n2,0.2\n")
    s = score(truth, pred)
    assert s["rmse"] == 0 and s["rmse_public"] == 0
    (tmp_path / "answers.csv").write_text("frame_id,steering_angle\n1,0.1\n2,0.2\n3,0.3\n")
    with pytest.raises(DataError, match="answers.csv, row 1: the answer file needs a 'public' column"):
        score(tmp_path / "answers.csv", pred)
    with pytest.raises(DataError, match="predictions file not found"):
        score(truth, tmp_path / "none.csv")
    ids, angles, public = read_steering_csv(pred)  # a predictions file has no public column
    assert ids.dtype == np.int64 and ids.tolist() == [3, 1, 2] and angles.tolist() == [0.3, 0.1, 0.2] and public is None


def test_score_hand_computed(tmp_path, capsys):
    """The leaderboard's numbers on four frames, predicted out of order: errors 0.1, 0.2, 0 and 0 rad; frames 1
    and 3 public ('1', 'True'), 2 and 4 private ('0', 'no')."""
    from steerlab.evaluate.scoring import spread_said

    truth, pred = tmp_path / "truth.csv", tmp_path / "pred.csv"
    truth.write_text("frame_id,steering_angle,public\n1,0.0,1\n2,0.1,0\n3,0.3,True\n4,0.6,no\n")
    pred.write_text("frame_id,steering_angle\n4,0.6\n2,0.3\n1,0.1\n3,0.3\n")
    s = score(truth, pred)
    assert s["rmse"] == pytest.approx(np.sqrt(0.05 / 4)) and s["mae_deg"] == pytest.approx(np.degrees(0.075))
    assert s["rmse_public"] == pytest.approx(np.sqrt(0.01 / 2)) and s["rmse_private"] == pytest.approx(0.2 / np.sqrt(2))
    assert s["gamma_deg"] == pytest.approx(np.degrees(np.std([0.2, 0.0, 0.3])))  # of the predictions, in frame order
    assert s["truth_gamma_deg"] == pytest.approx(np.degrees(0.1 * np.sqrt(2 / 3)))
    assert (s["frames"], s["public_frames"]) == (4, 2)
    truth.write_text("frame_id,steering_angle,public\n1,0.0,1\n2,0.1,true\n")
    pred.write_text("frame_id,steering_angle\n1,0.1\n2,0.1\n")
    with warnings.catch_warnings():  # no private frames: NaN, without a mean taken over nothing
        warnings.simplefilter("error")
        s = score(truth, pred)
    assert s["rmse_public"] == pytest.approx(np.sqrt(0.005)) and np.isnan(s["rmse_private"])
    truth.write_text("frame_id,steering_angle,public\n1,0.0,0\n2,0.1,False\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s = score(truth, pred)
    assert s["rmse_private"] == pytest.approx(np.sqrt(0.005)) and np.isnan(s["rmse_public"])
    assert capsys.readouterr().err == ""
    # answers beyond two turns of the wheel (4 pi rad), predictions spread 20 times as far: both said
    truth.write_text("frame_id,steering_angle,public\n1,12.6,1\n2,12.5,0\n")
    pred.write_text("frame_id,steering_angle\n1,1\n2,-1\n")
    score(truth, pred)
    said = capsys.readouterr().err
    assert "steering angles up to 12.6 rad, beyond a steering wheel's two turns each way (12.57 rad)" in said
    assert "the predictions spread 20 times as far as the answers (std 1 against 0.05): degrees where radians are " \
           "expected, or another unit?" in said
    truth.write_text(f"frame_id,steering_angle,public\n1,{4 * np.pi!r},1\n2,12.4,0\n")  # at two turns: not said
    score(truth, pred)
    assert "two turns" not in capsys.readouterr().err
    assert spread_said(np.array([-1.0, 1.0]), np.array([-0.01, 0.01])) == (
        "the predictions spread 100 times as far as the answers (std 1 against 0.01): degrees where radians are "
        "expected?")
    assert spread_said(np.array([-5.0, 5.0]), np.array([-0.5, 0.5])) is None  # 10 times: not beyond
    assert spread_said(np.array([-1.0, 1.0]), np.array([0.2, 0.2])) is None  # answers that never change
    assert spread_said(np.array([-3.75, 3.75]), np.array([-0.125, 0.125])).endswith("expected, or another unit?")  # 30
    assert spread_said(np.array([-3.8125, 3.8125]), np.array([-0.125, 0.125])).endswith(  # 30.5 times
        "the answers (std 3.812 against 0.125): degrees where radians are expected?")


def test_drift_episodes_and_rank_correlation():
    from steerlab.evaluate.plots import episodes_of, rank_correlation

    labels = np.array(["normal", "drift-out", "drift-out", "recover", "normal", "drift-out", "recover", "recover"])
    assert episodes_of(labels) == [(1, 3, 4), (5, 6, 8)]
    assert episodes_of(np.array(["normal", "drift-out"])) == []  # cut off before the driver corrects
    assert rank_correlation([1, 2, 3, 4], [10, 20, 30, 40]) == pytest.approx(1.0)
    assert rank_correlation([1, 2, 3, 4], [0.4, 0.3, 0.2, 0.1]) == pytest.approx(-1.0)
    assert rank_correlation([1, 2, 3, 4], [1, 3, 2, 4]) == pytest.approx(0.8)
    # ties share their mean rank: y ranks 0.5, 0.5, 2.5, 2.5 against 0, 1, 2, 3 -> 4 / (2 sqrt(5))
    assert rank_correlation([1, 2, 3, 4], [100, 100, 101, 101]) == pytest.approx(2 / np.sqrt(5))
    assert rank_correlation([4, 3, 2, 1], [100, 100, 101, 101]) == pytest.approx(-2 / np.sqrt(5))
    # three ties, unsorted: y ranks 3, 3, 3, 1, 5 against 3, 1, 2, 5, 4 -> -2 / sqrt(10 * 8)
    assert rank_correlation([3, 1, 2, 5, 4], [2, 2, 2, 1, 3]) == pytest.approx(-1 / (2 * np.sqrt(5)))
    from scipy.stats import spearmanr  # scipy comes with the test set (scikit-learn's)

    rng = np.random.default_rng(0)
    for _ in range(20):  # many ties, as autonomy at 100 % gives
        x, y = rng.integers(0, 4, 12), rng.integers(0, 3, 12)
        assert rank_correlation(x, y) == pytest.approx(spearmanr(x, y).statistic, abs=1e-12)
    assert np.isnan(rank_correlation([1, 2, 3], [100, 100, 100]))  # every model drives equally well
    assert np.isnan(rank_correlation([1, 2], [1, 2]))
    assert np.isnan(rank_correlation([1, 2, np.nan], [1, 2, 3]))  # a metric that one run lacks


def test_metrics_in_normalized_units():
    """A donkeycar tub's [-1, 1] steering: MAE in its own unit always, degrees only with a full-lock angle."""
    pred, target = np.array([0.0, 0.5, -0.5]), np.array([0.1, 0.3, -0.5])
    m = steering_metrics(pred, target, deg_per_unit=25.0)
    assert m["mae"] == pytest.approx(0.1) and m["mae_deg"] == pytest.approx(2.5)
    assert m["gamma_deg"] == pytest.approx(np.std([0.5, -1.0]) * 25.0)
    assert np.isnan(steering_metrics(pred, target, deg_per_unit=np.nan)["mae_deg"])
    assert steering_metrics(pred, target)["mae_deg"] == pytest.approx(np.degrees(0.1))
