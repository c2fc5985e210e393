import numpy as np
import pytest

from steerlab.data.labels import speed_commands, speed_targets
from steerlab.data.splits import make_split, paper_protocol
from steerlab.errors import DataError, SteerlabError
from steerlab.evaluate.metrics import all_metrics, exponential_smoothing, gamma_deg, steering_metrics
from steerlab.evaluate.scoring import score, write_predictions

from conftest import CH2, needs_ch2


def test_gamma_hand_computed():
    # successive differences 1, 2, 3 degrees -> population std sqrt(2/3)
    assert gamma_deg(np.radians([0, 1, 3, 6])) == pytest.approx(np.sqrt(2 / 3))
    m = steering_metrics(np.radians([1, 1]), np.radians([0, 2]))
    assert m["mae_deg"] == pytest.approx(1.0) and m["rmse"] == pytest.approx(np.radians(1))


def test_exponential_smoothing_hand_computed():
    np.testing.assert_allclose(exponential_smoothing([0, 10, 10], 0.2), [0, 2, 3.6])


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


def test_splits():
    tr, va = make_split({"train": "0:1800", "val": "1800:2400"}, 2400)
    assert (tr[0], tr[-1], va[0], va[-1]) == (0, 1799, 1800, 2399)
    with pytest.raises(SteerlabError, match="overlap"):
        make_split({"train": "0:1900", "val": "1800:2400"}, 2400)
    with pytest.raises(SteerlabError, match="empty or outside"):
        make_split({"train": "0:1800", "val": "2400:2400"}, 2400)
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
        "frame_id,steering_angle\n1,0\n2,0\n2,0\n3,0\n": "row 4: duplicate frame_id 2",
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
    assert np.isnan(rank_correlation([1, 2, 3], [100, 100, 100]))  # every model drives equally well
    assert np.isnan(rank_correlation([1, 2], [1, 2]))


def test_metrics_in_normalized_units():
    """A donkeycar tub's [-1, 1] steering: MAE in its own unit always, degrees only with a full-lock angle."""
    pred, target = np.array([0.0, 0.5, -0.5]), np.array([0.1, 0.3, -0.5])
    m = steering_metrics(pred, target, deg_per_unit=25.0)
    assert m["mae"] == pytest.approx(0.1) and m["mae_deg"] == pytest.approx(2.5)
    assert m["gamma_deg"] == pytest.approx(np.std([0.5, -1.0]) * 25.0)
    assert np.isnan(steering_metrics(pred, target, deg_per_unit=np.nan)["mae_deg"])
    assert steering_metrics(pred, target)["mae_deg"] == pytest.approx(np.degrees(0.1))
