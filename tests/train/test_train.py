import csv
import shutil
from dataclasses import replace

import numpy as np
import pytest
import torch

from conftest import drawn_pixels, image_of, legend_of
from steerlab.checkpoint import load_checkpoint
from steerlab.data.car import CH2_CAR
from steerlab.data.readers import Source, open_recording
from steerlab.errors import SteerlabError
from steerlab.evaluate.offline import evaluate
from steerlab.models import list_models, model_class
from steerlab.sim.road.world import RecordOptions
from steerlab.train import loop, sources
from steerlab.train.batches import EpochSampler, FrameBatches, balance_weights, loader
from steerlab.train.config import TrainOptions, load_config
from steerlab.train.distributed import Ranks
from tests.train.runs import _cfg, _log


def test_training_lowers_loss_and_checkpoint_reproduces(tiny_recording, tmp_path, saved_figures):
    best = loop.train(_cfg(tiny_recording, tmp_path), progress=False)
    rows = _log(tmp_path)
    assert len(rows) == 4
    assert float(rows[-1]["train_loss"]) < float(rows[0]["train_loss"])
    # the training pass alone, then the epoch with its validation of 60 frames after it
    assert all(0 < float(r["train_seconds"]) < float(r["seconds"]) for r in rows)
    # the streaming evaluation of the best checkpoint reproduces its validation predictions in batch
    m = evaluate(tmp_path / "run" / "best.pt", Source(str(tiny_recording), "240:300"), tmp_path / "eval",
                 progress=False)
    assert m["frames"] == 60
    assert m["rmse"] == pytest.approx(best["rmse"], rel=1e-3)
    with open(tmp_path / "eval" / "predictions.csv") as f:
        table = list(csv.reader(f))
    assert table[0] == ["frame_id", "steering_angle"] and len(table) == 61
    # its plot: 11 x 3.6 inches at 110 dpi; the recorded and the predicted steering of the 60 frames in degrees,
    # both drawn across the axes, and the legend naming them
    png = tmp_path / "eval" / "steering.png"
    img = image_of(png)
    assert img.shape[:2] == (396, 1210)
    ax = saved_figures[str(png)].axes[0]
    assert legend_of(ax) == ["target", "pilotnet"]
    target, predicted = ax.get_lines()
    np.testing.assert_allclose(target.get_ydata(), np.degrees(open_recording(tiny_recording, "240:300").steering))
    np.testing.assert_allclose(predicted.get_ydata(), np.degrees([float(r[1]) for r in table[1:]]), atol=1e-4)
    assert drawn_pixels(img, ax, target.get_color()) > 500 and drawn_pixels(img, ax, predicted.get_color()) > 500


@pytest.mark.parametrize("keep, epochs, best_epoch", [("best", 2, 1), ("last", 3, 3)])
def test_keep_best_stops_early_and_keep_last_keeps_the_final_epoch(tiny_recording, tmp_path, monkeypatch, keep,
                                                                   epochs, best_epoch):
    """The validation RMSE is made to rise every epoch. keep: best stops after `patience` (1) epochs without a
    better one and keeps epoch 1; keep: last (a refit whose validation block is held out) trains every epoch
    and keeps the final one."""
    scripted = iter([0.1, 0.2, 0.3])
    real = loop.all_metrics
    monkeypatch.setattr(loop, "all_metrics", lambda *a: {**real(*a), "rmse": next(scripted)})
    best = loop.train(_cfg(tiny_recording, tmp_path, epochs=3, patience=1, keep=keep), progress=False)
    assert len(_log(tmp_path)) == epochs and best["epoch"] == best_epoch
    assert torch.load(tmp_path / "run" / "best.pt", weights_only=True)["metrics"]["epoch"] == best_epoch


def test_mae_loss_hand_computed_and_picks_best_epoch_by_mae(tiny_recording, tmp_path):
    out, y = {"steering": torch.tensor([0.5, -1.0, 0.0])}, {"steering": torch.tensor([0.0, 1.0, 0.0])}
    net = torch.nn.Linear(1, 1)  # a model without a loss of its own
    assert float(loop.objective(net, out, y, "mse")) == pytest.approx((0.25 + 4.0) / 3)
    assert float(loop.objective(net, out, y, "mae")) == pytest.approx(2.5 / 3)
    best = loop.train(_cfg(tiny_recording, tmp_path, loss="mae"), progress=False)
    rows = _log(tmp_path)
    assert float(rows[-1]["train_loss"]) < float(rows[0]["train_loss"])
    assert best["mae"] == pytest.approx(min(float(r["val_mae"]) for r in rows), rel=1e-6)
    with pytest.raises(SteerlabError, match="train.loss must be mse or mae, got 'l2'"):
        _cfg(tiny_recording, tmp_path, loss="l2")
    with pytest.raises(SteerlabError, match="trains on a loss of its own"):
        _cfg(tiny_recording, tmp_path / "b", loss="mae", model={"name": "multitask-speed"})


def test_smoothness_term_hand_computed_and_recurrent_only(tiny_recording, tmp_path):
    """One window of three frames: predictions 0, 1, 1 against labels 0, 0, 2. Steering errors 0, 1, -1;
    changes predicted 1, 0 against recorded 0, 2, so change errors 1, -2."""
    out, y = {"steering": torch.tensor([[0.0, 1.0, 1.0]])}, {"steering": torch.tensor([[0.0, 0.0, 2.0]])}
    net = torch.nn.Linear(1, 1)
    assert float(loop.objective(net, out, y, "mse", 0.5)) == pytest.approx(2 / 3 + 0.5 * 5 / 2)
    assert float(loop.objective(net, out, y, "mae", 0.5)) == pytest.approx(2 / 3 + 0.5 * 3 / 2)
    assert float(loop.objective(net, out, y, "mse", 0.0)) == pytest.approx(2 / 3)
    runs = {}
    for weight in (0.0, 100.0):  # the term reaches training: the same seed, a much higher training loss
        cfg = _cfg(tiny_recording, tmp_path / str(weight), epochs=1, smoothness=weight,
                   model={"name": "lstm", "seq_len": 5}, split={"train": "0:100", "val": "100:120"})
        loop.train(cfg, progress=False)
        with open(tmp_path / str(weight) / "run" / "log.csv") as f:
            runs[weight] = float(next(csv.DictReader(f))["train_loss"])
    assert runs[100.0] > 1.5 * runs[0.0]
    with pytest.raises(SteerlabError, match="train.smoothness needs a recurrent model"):
        _cfg(tiny_recording, tmp_path, smoothness=1.0)
    with pytest.raises(SteerlabError, match="train.smoothness needs windows of at least 2 frames; model.seq_len is 1"):
        load_config(None, base={"data": str(tiny_recording), "model": {"name": "lstm", "seq_len": 1},
                                "train": {"smoothness": 1.0}})
    with pytest.raises(SteerlabError, match="train.smoothness must be a finite number of at least 0, got -1"):
        _cfg(tiny_recording, tmp_path, smoothness=-1)


def test_exclude_episodes_drops_the_drift_out_frames_of_training_only(tmp_path):
    """A road-world drive whose first drift-out comes early (seed 26, 12 s at 5 frames/s: normal 0-25, drift-out
    26-32, recover 33-39, normal 40-59), trained with side cameras on frames 0-29 and validated on 30-59, the
    same drive also an extra recording: training draws every frame of the split and of the extra recording
    whose episode label (log.csv, read here as text) is not drift-out, from each of the three cameras, and no
    other; validation keeps its drift-out frames."""
    from steerlab.sim.road.run import record

    rec = record(tmp_path / "rec", RecordOptions(seed=26, minutes=0.2, fps=5), progress=False)
    with open(rec / "log.csv") as f:
        episode = [row["episode"] for row in csv.DictReader(f)]
    assert [i for i, e in enumerate(episode) if e == "drift-out"] == list(range(26, 33))
    shutil.copytree(rec, tmp_path / "again")  # the same drive, as another recording
    cfg = _cfg(rec, tmp_path, epochs=1, side_cameras=True, exclude_episodes=["drift-out"],
               split={"train": "0:30", "val": "30:60"}, extra=[str(tmp_path / "again")])
    run = loop.build(cfg.for_car(CH2_CAR), Ranks(), False, None, None)
    drawn = np.concatenate([batch.codes for batch in run.sampler])
    assert len(drawn) == len(set(drawn.tolist()))  # each once an epoch
    stream = np.searchsorted(run.data.offsets, drawn, side="right") - 1  # of each sample code
    kept = set(zip(stream.tolist(), (drawn - run.data.offsets[stream]).tolist()))  # (stream, frame)
    not_drift = [i for i, e in enumerate(episode) if e != "drift-out"]
    # streams 0-2: the recording's centre, left and right cameras on frames 0-29; 3-5: the extra recording's, whole
    expected = ({(k, i) for k in range(3) for i in not_drift if i < 30}
                | {(k, i) for k in range(3, 6) for i in not_drift})
    assert kept == expected
    assert list(run.val_idx) == list(range(30, 60))  # validation keeps drift-out frames 30-32
    assert {episode[i] for i in range(60)} - {episode[i] for _, i in kept} == {"drift-out"}
    (tmp_path / "run").mkdir()
    loop.fit(run, Ranks(), False)  # and it trains on them
    assert len(_log(tmp_path)) == 1


def test_an_extra_recording_without_side_cameras_adds_its_centre_frames(tiny_recording, tmp_path):
    """A DAgger rollout in replay records only the view the car saw: with side cameras on, the main recording
    gives three streams and such an extra recording one; a main recording without side cameras is an error."""
    from steerlab.sim.road.run import record

    centre_only = record(tmp_path / "centre", RecordOptions(seed=4, minutes=0.02, side_cameras=False), progress=False)
    cfg = _cfg(tiny_recording, tmp_path, side_cameras=True, extra=[str(centre_only)]).for_car(CH2_CAR)
    ds = sources.prepare_dataset(cfg, progress=False)
    train_idx = np.arange(240)
    streams, codes = sources.training_sources(cfg, ds, train_idx, progress=False)
    n_extra = len(sources.prepare_dataset(cfg, progress=False, data=str(centre_only)))
    assert len(streams) == 4 and len(codes) == 3 * 240 + n_extra
    alone = replace(cfg, data=str(centre_only), extra_data=())
    with pytest.raises(SteerlabError, match="has no 'left' camera"):
        sources.training_sources(alone, sources.prepare_dataset(alone, progress=False), np.arange(n_extra),
                                 progress=False)


def test_distillation_trains_on_the_teachers_predictions(tiny_recording, tiny_checkpoint, tmp_path):
    """train.teacher: the main recording's targets are the teacher's streamed predictions (what `steerlab
    evaluate` writes for it), side cameras add their recovery angle to them, validation keeps the recording."""
    cfg = _cfg(tiny_recording, tmp_path, epochs=1, side_cameras=True, teacher=str(tiny_checkpoint)).for_car(CH2_CAR)
    ds = sources.prepare_dataset(cfg, progress=False)
    streams, _ = sources.training_sources(cfg, ds, np.arange(240), False, load_checkpoint(tiny_checkpoint))
    evaluate(tiny_checkpoint, Source(str(tiny_recording)), tmp_path / "teacher", progress=False)
    with open(tmp_path / "teacher" / "predictions.csv") as f:
        taught = np.array([float(r["steering_angle"]) for r in csv.DictReader(f)])
    assert streams[0][1] == pytest.approx(taught, abs=1e-5)
    assert not np.allclose(taught, ds.steering, atol=1e-3)  # the teacher is not the recording
    left = sources.recovery_labels(streams[1][0], taught, 0.508, 0.0, cfg.train)
    assert streams[1][1] == pytest.approx(left, abs=1e-5)
    best = loop.train(cfg, progress=False)
    with open(tmp_path / "run" / "val_predictions.csv") as f:
        pred = np.array([float(r["steering_angle"]) for r in csv.DictReader(f)])
    assert best["rmse"] == pytest.approx(np.sqrt(np.mean((pred - ds.steering[240:300]) ** 2)), rel=1e-4)


def test_side_camera_labels_hand_computed(tiny_recording, tmp_path):
    ds = sources.prepare_dataset(_cfg(tiny_recording, tmp_path), progress=False, camera="left")
    tc = TrainOptions(recovery_s=1.0, steering_ratio=10.0)
    y = sources.recovery_labels(ds, ds.steering, 0.5, 0.0, tc)
    v = ds.labels["speed"][0]
    # left camera: steer right by arctan(0.5 / v) at the road wheel = 10x that at the steering wheel
    assert y[0] == pytest.approx(ds.steering[0] - 10 * np.arctan(0.5 / v))
    # turned 2 degrees to the left as well: 2 more degrees to the right at the road wheel
    y = sources.recovery_labels(ds, ds.steering, 0.5, 2.0, tc)
    assert y[0] == pytest.approx(ds.steering[0] - 10 * (np.arctan(0.5 / v) + np.radians(2.0)))


def test_balanced_sampling_thins_straight_driving():
    steering = np.concatenate([np.zeros(1000), np.linspace(-1, -0.1, 25), np.linspace(0.1, 1, 25)])
    codes = np.arange(len(steering))
    kept = EpochSampler(codes, 64, seed=0, weights=balance_weights(steering)).order()
    # 25 bins of 0.08: 1000 straight frames in the middle one, 1-2 turning frames in 22 others; the cap is
    # the mean count of the non-empty bins, 1050 / 23 = 46: every turning frame stays, ~46 straight ones do
    assert np.isin(codes[1000:], kept).all()
    assert 20 < np.isin(codes[:1000], kept).sum() < 70


def test_min_speed_drops_slow_frames(tiny_recording, tmp_path):
    ds = sources.prepare_dataset(_cfg(tiny_recording, tmp_path), progress=False)
    v = ds.labels["speed"]
    idx = sources.usable_frames(ds, np.arange(len(ds)), "training", min_speed=np.median(v))
    assert (v[idx] >= np.median(v)).all() and len(idx) < len(ds)
    with pytest.raises(SteerlabError, match=rf"validation split is empty once frames slower than train.min_speed=90 "
                       rf"m/s are dropped \(.* drives at most {v.max():.3g} m/s\): lower train.min_speed"):
        sources.usable_frames(ds, np.arange(len(ds)), "validation", min_speed=90)


def test_balance_refuses_recurrent_models(tiny_recording, tmp_path):
    with pytest.raises(SteerlabError, match="balanced sampling picks single frames"):
        _cfg(tiny_recording, tmp_path, balance=True, model={"name": "lstm"})


@pytest.mark.parametrize("model", ["speed-command", "multitask-speed"])
def test_speed_models_need_speed(model, ch2_folder, tmp_path):
    cfg = load_config(None, base={"data": str(ch2_folder), "cache": str(tmp_path / "cache"), "out": str(tmp_path / "r"),
                                  "split": {"train": "0:4", "val": "4:6"}, "model": {"name": model}})
    with pytest.raises(SteerlabError, match=f"model '{model}' needs a recording with speed"):
        loop.train(cfg, progress=False)


def test_baselines(tiny_recording, tmp_path):
    cfg = _cfg(tiny_recording, tmp_path, model={"name": "train-mean"})
    m = loop.train(cfg, progress=False)
    ds = sources.prepare_dataset(cfg, progress=False)
    mean = ds.steering[:240].mean()
    assert m["rmse"] == pytest.approx(np.sqrt(np.mean((ds.steering[240:300] - mean) ** 2)))


def test_config_errors(tmp_path):
    with pytest.raises(SteerlabError, match="config file not found"):
        load_config(tmp_path / "x.yaml")
    with pytest.raises(SteerlabError, match="names no data"):
        load_config(None)
    with pytest.raises(SteerlabError, match="unknown train options"):
        load_config(None, ["data=x", "train.epoch=3"])
    cfg = load_config(None, ["data=x", "train.epochs=3", "split.train=0:10", "split.val=10:20", "train.lr=1e-4"])
    assert cfg.train.epochs == 3 and cfg.train.batch_size == 100
    assert cfg.train.lr == 1e-4 and isinstance(cfg.train.lr, float)  # YAML 1.1 reads 1e-4 as text: parsed once
    with pytest.raises(SteerlabError, match=r"train.views\[0\] must be a \[shift_m, yaw_deg\] pair"):
        load_config(None, ["data=x", "train.views=[[0.5]]"])
    assert cfg.split.train == "0:10"
    (tmp_path / "c.yaml").write_text("data: x\nsplit: {train: 10:20, val: 20:30}\n")
    with pytest.raises(SteerlabError, match="quote it"):
        load_config(tmp_path / "c.yaml")


@pytest.mark.parametrize("model, pre", [(n, {}) for n in list_models()] + [
    ("pilotnet", {"modalities": ["image", "diff", "flow"], "stack": 3, "color": "yuv"})])
def test_every_model_learns_and_streams_as_in_batch(model, pre, tiny_recording, tmp_path):
    """Two epochs lower the training loss; then the Pilot, fed the raw frames (and speeds) of the first 40 frames
    one by one, reproduces the batch path (which runs recurrent models statefully through the range)
    for every output: stacked frames, difference, flow, speed history and LSTM state."""
    from steerlab.checkpoint import load_checkpoint, model_from_checkpoint

    cls = model_class(model)
    # frame models on frames smaller than 200x66 (quicker, same paths); recurrent models keep their size, where
    # two epochs of 5 windows lower the loss
    small = {} if "width" in cls.inputs or cls.recurrent else {"width": 128, "height": 64}
    cfg = _cfg(tiny_recording, tmp_path, epochs=2, batch_size=5, split={"train": "0:60", "val": "60:80"},
               model={"name": model, **({"dropout": 0.0} if cls.trainable else {})},
               preprocess={**small, **pre})  # recurrent: 3 windows of 10 frames
    loop.train(cfg, progress=False)
    if cls.trainable:
        rows = _log(tmp_path)
        assert float(rows[-1]["train_loss"]) < float(rows[0]["train_loss"])
    evaluate(tmp_path / "run" / "best.pt", Source(str(tiny_recording), "0:40"), tmp_path / "eval", progress=False)
    with open(tmp_path / "eval" / "predictions.csv") as f:
        streamed = list(csv.DictReader(f))
    ckpt = load_checkpoint(tmp_path / "run" / "best.pt")
    net = model_from_checkpoint(ckpt)[0]
    ds = sources.prepare_dataset(cfg, progress=False)
    batch = loop.predict(net, FrameBatches([(ds, ds.steering)], ckpt["stats"], net.speed_history), np.arange(40),
                         batch_size=64)
    np.testing.assert_allclose([float(r["steering_angle"]) for r in streamed], batch["steering"], atol=1e-4)
    for k in set(batch) - {"steering"}:
        np.testing.assert_allclose([float(r[k]) for r in streamed], batch[k], atol=1e-3)


def test_a_short_recording_draws_every_sample_as_often_as_epoch_samples_asks(tiny_recording, tmp_path):
    """train.epoch_samples: 40 training frames and at least 100 samples an epoch: every frame drawn ceil(100 / 40) =
    3 times an epoch, in batches of 32 (120 samples: 3 full batches and 24); at most 40 asked of 40 frames, or the
    option unset, each once."""
    def drawn(**options):
        cfg = _cfg(tiny_recording, tmp_path, split={"train": "0:40", "val": "40:60"}, **options).for_car(CH2_CAR)
        codes = np.concatenate([batch.codes for batch in loop.build(cfg, Ranks(), False, None, None).sampler])
        return np.unique(codes, return_counts=True)[1]

    assert drawn(epoch_samples=100).tolist() == [3] * 40
    assert drawn(epoch_samples=40).tolist() == drawn().tolist() == [1] * 40
    assert drawn(epoch_samples=41).tolist() == [2] * 40
    with pytest.raises(SteerlabError, match="train.epoch_samples must be"):
        _cfg(tiny_recording, tmp_path, epoch_samples=-1)


def test_epoch_samples_multiplies_the_repeats_of_recovery_weighting(tmp_path):
    """Road-world seed 26 at 5 frames/s (recover frames 33-39), trained on frames 0-49 with recovery_weight 3: 43
    frames drawn once and 7 three times, 64 an epoch; at least 200 an epoch draws each ceil(200 / 64) = 4 times
    as often: 4 and 12."""
    from steerlab.sim.road.run import record

    rec = record(tmp_path / "rec", RecordOptions(seed=26, minutes=0.2, fps=5), progress=False)
    for options, low, high in [({}, 1, 3), ({"epoch_samples": 200}, 4, 12)]:
        cfg = _cfg(rec, tmp_path, recovery_weight=3, split={"train": "0:50", "val": "50:60"}, **options)
        codes = np.concatenate([b.codes for b in loop.build(cfg.for_car(CH2_CAR), Ranks(), False, None, None).sampler])
        counts = np.bincount(codes, minlength=50)
        assert counts[33:40].tolist() == [high] * 7 and np.delete(counts, range(33, 40)).tolist() == [low] * 43


def test_the_batches_do_not_depend_on_the_number_of_workers(tiny_recording, tmp_path):
    """Every random draw (order, flips, motion dropout, augmentation) is made where the batches are drawn, so one
    or two worker processes give the batches that loading in this process gives."""
    cfg = _cfg(tiny_recording, tmp_path, flip=True, motion_dropout=0.5, rotation_deg=5, brightness=0.2,
               model={"name": "pilotnet-flow", "dropout": 0.0}, preprocess={"width": 64, "height": 64},
               split={"train": "0:96", "val": "96:120"}).for_car(CH2_CAR)
    run = loop.build(cfg, Ranks(), False, None, None)
    epochs = {}
    for workers in (0, 2):
        batches = loader(run.data, run.sampler, workers, torch.device("cpu"))
        run.sampler.set_epoch(3)
        epochs[workers] = list(batches)
    assert len(epochs[0]) == len(epochs[2]) == 3  # 96 frames in batches of 32
    for (x0, y0, w0), (x2, y2, w2) in zip(epochs[0], epochs[2]):
        assert torch.equal(x0["x"], x2["x"]) and torch.equal(y0["steering"], y2["steering"]) and w0 == w2
    run.sampler.set_epoch(4)
    assert not torch.equal(next(iter(loader(run.data, run.sampler, 0, torch.device("cpu"))))[0]["x"],
                           epochs[0][0][0]["x"])  # another epoch, another draw


def test_training_on_a_tub_says_degrees_are_unknown(tmp_path, capsys):
    """A tub without a full-lock angle has no degrees: the epoch line and the table say n/a, never nan."""
    from steerlab.cli import main
    from tests.inputs import write_tub

    tub = write_tub(tmp_path / "tub", [(i, "s", 1000 + 50 * i, 0.5 * np.sin(i / 5)) for i in range(40)])
    cfg = tmp_path / "c.yaml"
    cfg.write_text(f"data: {tub}\ncache: {tmp_path / 'cache'}\nout: {tmp_path / 'run'}\nmodel: {{name: pilotnet}}\n"
                   "split: {train: '0:30', val: '30:40'}\ntrain: {epochs: 1, batch_size: 8}\n")
    assert main(["train", str(cfg)]) == 0
    out = capsys.readouterr().out
    assert "nan" not in out.lower() and "degrees n/a: no full-lock angle" in out and "n/a (no full-lock angle" in out


def test_epoch_repeats_hand_computed():
    """At least `epoch_samples` an epoch: every count times ceil(epoch_samples / drawn); none added where an epoch
    draws as many already, or where the option is 0 (unset)."""
    from steerlab.train.batches import epoch_repeats

    assert epoch_repeats(40, None, 100).tolist() == [3] * 40  # ceil(100 / 40)
    assert epoch_repeats(40, None, 41).tolist() == [2] * 40
    assert epoch_repeats(40, None, 40) is None and epoch_repeats(40, None, 0) is None
    assert epoch_repeats(2, np.array([1, 3]), 10).tolist() == [3, 9]  # 4 drawn: ceil(10 / 4) = 3 times over
    assert epoch_repeats(2, np.array([1, 3]), 4).tolist() == [1, 3]
    assert epoch_repeats(0, None, 10) is None  # nothing to draw
    assert epoch_repeats(1, None, 3).tolist() == [3]  # one sample: drawn three times


def test_objective_hand_computed():
    """The objective by hand: the MSE of the steering by default (and no throttle weight unless given), a model's
    own loss given the outputs and targets in that order, and the smoothness term the error of the predicted
    change against the recorded one."""
    out = {"steering": torch.tensor([[0.0, 1.0, 3.0]]), "throttle": torch.tensor([0.5])}
    targets = {"steering": torch.tensor([[1.0, 1.0, 1.0]]), "throttle": torch.tensor([0.0])}
    # steering errors -1, 0, 2: MSE 5/3; predicted changes 1, 2 against 0, 0: MSE of (1, 2) = 5/2
    assert loop.objective(object(), out, targets).item() == pytest.approx(5 / 3)
    assert loop.objective(object(), out, targets, smoothness=2.0).item() == pytest.approx(5 / 3 + 2 * 5 / 2)
    assert loop.objective(object(), out, targets, loss="mae", throttle_weight=4.0).item() == pytest.approx(1 + 2)
    recorded_change = {"steering": torch.tensor([[0.0, 2.0, 2.0]]), "throttle": torch.tensor([0.0])}
    # changes 1, 2 against 2, 0: errors -1, 2, MSE 5/2 (the sum of the changes would give 3, 2: 13/2)
    assert loop.objective(object(), out, recorded_change, smoothness=1.0).item() == pytest.approx(
        (0 + 1 + 1) / 3 + 5 / 2)

    class OwnLoss:
        def loss(self, out, targets):
            return out["steering"].sum() - 10 * targets["steering"].sum()

    assert loop.objective(OwnLoss(), out, targets, loss="mae").item() == pytest.approx(4 - 30)
