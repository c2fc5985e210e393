"""Recordings and checkpoints that do not belong together: a steering convention or a camera geometry other
than the data's or the world's (a checkpoint meeting a recording, the simulator, a teacher, an ensemble's members,
extra data) is refused in one line before any work, unless its option allows it (then converted, said)."""

import cv2
import pytest

from steerlab.cli import main
from tests.bad_input.builders import _train, _with, config, refused_in_one_line
from tests.inputs import ch2, made, sim_log, tub


def _evaluate_on_ch2(**convention):
    def command(tmp_path, stack):
        data = ch2(tmp_path / "ch2")
        return ["evaluate", str(made(tmp_path, **convention)), "--data", str(data), "--labels",
                str(data / "labels.csv"), "--out", str(tmp_path / "eval")]
    return command


def _serve(**convention):
    return lambda tmp_path, stack: ["serve", str(made(tmp_path, **convention)), "--port", "4599"]


def _corrupt(folder):
    """The tub `folder` with its fourth frame no image."""
    (folder / "images" / "3_cam_image_array_.jpg").write_bytes(b"no JPEG")
    return folder


# each case: a function (tmp_path, stack) -> the command's arguments, and the message's substring (builders.py)
BAD_INPUTS = {
    "track recipe on tubs of another camera": (
        lambda t, s: ["train", str(config(t, sim_log(t / "sim"))), "preprocess.preset=donkey"],
        "holds frames of the 'sim' camera; the config's preprocess.preset donkey is for the 'donkey' camera"),
    "sim dagger in the track world on a road recording": (
        lambda t, s: ["sim", "dagger", str(config(t, sim_log(t / "sim"))), "dagger.world=track", "dagger.suite=t1"],
        "dagger.world: track renders the donkey camera, and"),
    "sim dagger in the track world with a road suite": (
        lambda t, s: ["sim", "dagger", str(config(t, tub(t / "tub"))), "dagger.world=track", "dagger.suite=v1"],
        "dagger.suite: v1 is a road suite; world track drives a track suite (t1, s1, t2, t3) or none (null)"),
    "sim dagger in replay on a tub without its full-lock angle": (
        lambda t, s: ["sim", "dagger", str(config(t, tub(t / "tub"))), "dagger.world=replay"],
        "tub: replay cannot turn its steering into a wheel angle: normalized steering needs the car's full-lock angle"),
    "sim dagger on roads with a tub": (lambda t, s: ["sim", "dagger", str(config(t, tub(t / "tub")))],
                                       "holds 'donkey' frames: choose world track"),
    "views of a recording that is not a tub": (
        lambda t, s: ["views", str(config(t, sim_log(t / "sim"), views=[[0.1, 0]])), "--out", str(t / "v")],
        "the views are written as a donkeycar tub, for donkeycar's trainer; the config's data must be a donkeycar tub"),
    "views of a config without views": (
        lambda t, s: ["views", str(config(t, tub(t / "tub"))), "--out", str(t / "v")],
        "tub: the config has no train.views to write: give train.views (the tub defaults have them when"),
    "views of a tub without its full-lock angle": (
        lambda t, s: ["views", str(config(t, tub(t / "tub"), views=[[0.1, 0]])), "--out", str(t / "v")],
        "tub: train.views of a small car rebuild its path from the steering: normalized steering needs the car's "
        "full-lock angle"),
    "train views of a tub with a record without its throttle": (
        lambda t, s: ["train", str(config(t, tub(t / "tub", {0: {"user/throttle": None}}), views=[[0.1, 0]])),
                      "reader={full_lock_deg: 25}"],
        "tub: records neither speed nor throttle: train.views of a small car need the speed it drove at (from the "
        "throttle, as replay takes it); train without views (train.views=[])"),
    "views of a recording that is not there": (
        lambda t, s: ["views", str(config(t, t / "none")), "--out", str(t / "v")], "none: recording not found"),
    "views of a tub with a corrupt frame": (
        lambda t, s: ["views", str(config(t, _corrupt(tub(t / "tub")), views=[[0.1, 0]])), "reader={full_lock_deg: 25}",
                      "--out", str(t / "v")],
        "3_cam_image_array_.jpg: cannot decode image (corrupt or not a JPEG/PNG)", ("cache/",)),
    "views with out=": (
        lambda t, s: ["views", str(config(t, tub(t / "tub"))), "out=elsewhere", "--out", str(t / "v")],
        "out=elsewhere: steerlab views writes the tub --out names; a config's out (its training run's folder) is not "
        "used here: leave it out"),
    "train init of another geometry": (lambda t, s: _train(f"train.init={made(t, geometry='ch2')}")(t, s),
                                       "model.pt: train.init was trained on the 'ch2' camera geometry and ",
                                       ("run/", "cache/")),  # known once the data is compiled (kept for reuse)
    "train teacher of another convention": (
        lambda t, s: _train(f"train.teacher={made(t, 'steering_wheel', 'left')}")(t, s),
        "model.pt: train.teacher predicts steering_wheel/left steering and ", ("run/", "cache/")),
    # ensembles: members that the Pilot would run differently
    "ensemble of mixed conventions": (lambda t, s: ["ensemble", str(made(t, name="a.pt")),
                                                    str(made(t, "normalized", "right", name="b.pt")), "--out",
                                                    str(t / "e.pt")], "a.pt differ in steering convention ("),
    "ensemble of two geometries": (lambda t, s: ["ensemble", str(made(t, name="a.pt")),
                                                 str(made(t, geometry="ch2", name="b.pt")), "--out", str(t / "e.pt")],
                                   "a.pt differ in camera geometry (ch2 and sim): an ensemble averages models of one "
                                   "camera geometry"),
    # g) steering conventions where a checkpoint meets data or the simulator
    "evaluate simulator checkpoint on CH2": (_evaluate_on_ch2(), "model.pt predicts road_wheel/right steering and "),
    "evaluate donkeycar checkpoint on CH2": (_evaluate_on_ch2(kind="normalized", geometry="donkey"),
                                             "records steering_wheel/left steering: the metrics would mix units; "),
    "serve donkeycar checkpoint": (_serve(kind="normalized", geometry="donkey"),
                                   "model.pt cannot drive the simulator: it predicts normalized steering without "
                                   "a full-lock angle"),
    "serve CH2-cropped checkpoint": (_serve(kind="steering_wheel", positive="left", geometry="ch2"),
                                     "model.pt cannot drive the simulator: crop (268, 0, 0, 0) removes the whole "
                                     "320x160 frame"),
    "replay tub model without full lock": (
        lambda t, s: ["replay", str(made(t, "normalized", "right", "donkey")), "--data", str(tub(t / "tub")),
                      "--out", str(t / "out")],
        "model.pt: its steering cannot become a wheel angle: normalized steering needs the car's full-lock angle"),
    "replay another camera": (lambda t, s: ["replay", str(made(t, "steering_wheel", "left", "ch2")), "--data",
                                            str(sim_log(t / "sim")), "--out", str(t / "out")],
                              "model.pt was trained on the 'ch2' camera geometry and"),
    "replay a road recording in the track world": (_with("--world", "track", command="replay"),
                                                   "the track replay is for the donkey camera"),
    # o) messages that name the file, the option that exists and the fix
    "evaluate a CH2 checkpoint on a tub": (
        lambda t, s: ["evaluate", str(made(t, "steering_wheel", "left", "ch2")), "--data", str(tub(t / "tub")),
                      "--out", str(t / "eval")],
        "and the recording's camera geometry (donkey) is not the model's (ch2) either"),
    "export int8 of a CH2 checkpoint calibrated on a tub": (
        lambda t, s: ["export", str(made(t, "steering_wheel", "left", "ch2")), "--out", str(t / "m.onnx"), "--int8",
                      "--calib", str(tub(t / "tub"))],
        "the recording's camera geometry (donkey) is not the model's (ch2)"),
    "sim drive a tub checkpoint": (lambda t, s: ["sim", "drive", str(made(t, "normalized", "right", "donkey")),
                                                 "--out", str(t / "d")],
                                   "model.pt: model 'pilotnet' was trained on the 'donkey' camera, which the road "
                                   "world does not render"),
    "sim drive a tub checkpoint with the sim camera": (
        lambda t, s: ["sim", "drive", str(made(t, "normalized", "right", "donkey")), "--geometry", "sim", "--out",
                      str(t / "d")],
        "model.pt: model 'pilotnet' predicts normalized steering without a full-lock angle"),
    "track drive a road checkpoint": (lambda t, s: ["sim", "drive", str(made(t)), "--world", "track"],
                                      "model.pt: model 'pilotnet' was trained on the 'sim' camera; the track world "
                                      "renders the donkeycar camera"),
}


@pytest.mark.parametrize("case", BAD_INPUTS)
def test_bad_input_is_refused_in_one_line(case, tmp_path, capsys):
    refused_in_one_line(BAD_INPUTS[case], tmp_path, capsys)


def test_convention_mismatch_allowed_converts_with_a_warning(tmp_path, capsys):
    import numpy as np

    from steerlab.pilot import Pilot

    data, ckpt = ch2(tmp_path / "ch2"), made(tmp_path)  # a simulator checkpoint (road wheel, positive right)
    assert main(["evaluate", str(ckpt), "--data", str(data), "--labels", str(data / "labels.csv"), "--out",
                 str(tmp_path / "eval"), "--allow-convention-mismatch", "--allow-other-camera"]) == 0
    err = capsys.readouterr().err
    assert "predicts road_wheel/right steering" in err and "converted to the recording's convention" in err
    predicted = np.loadtxt(tmp_path / "eval" / "predictions.csv", delimiter=",", skiprows=1, ndmin=2)[:, 1]
    pilot = Pilot(ckpt, other_camera=True)
    raw = [pilot.step(cv2.imread(str(p))).steering for p in sorted((data / "center").glob("*.jpg"))]
    # the simulator's road-wheel angle, positive right, as CH2's steering-wheel angle, positive left
    np.testing.assert_allclose(predicted, -14.8 * np.array(raw), rtol=1e-4, atol=1e-6)


def test_extra_data_of_another_steering_convention_is_refused(tmp_path, capsys):
    """Recordings that do not belong together are not mixed: extra_data whose steering means other angles than the
    config's data (a donkeycar tub's servo command beside the simulator's road-wheel radians) is refused before
    training, as init, teacher and ensemble refuse the same thing."""
    cfg = config(tmp_path, sim_log(tmp_path / "sim"))
    tub(tmp_path / "tub")
    cfg.write_text(cfg.read_text() + f"extra_data: [{tmp_path / 'tub'}]\n")
    assert main(["train", str(cfg)]) == 2
    assert capsys.readouterr().err == (f"error: extra_data {tmp_path / 'tub'} records normalized/right steering and "
                                       "the config's data road_wheel/right: the targets would mean different angles; "
                                       "give recordings of one car (extra_data is read with the readers' default "
                                       "options)\n")
    assert not (tmp_path / "run").exists() and not (tmp_path / "cache").exists()  # refused before any work


def test_replay_refuses_a_recording_whose_steering_means_other_angles_than_the_models(tmp_path, capsys):
    """As evaluate does: a tub read with another full-lock angle than the checkpoint was trained with."""
    ckpt = made(tmp_path, "normalized", "right", "donkey", full_lock_deg=25)
    tub(tmp_path / "tub")
    assert main(["replay", str(ckpt), "--data", str(tmp_path / "tub"), "--reader", "full_lock_deg=30",
                 "--out", str(tmp_path / "replay")]) == 2
    assert capsys.readouterr().err == (f"error: {ckpt} predicts normalized/right (full lock 25 deg) steering and "
                                       f"{tmp_path / 'tub'} records normalized/right (full lock 30 deg) steering: "
                                       "the human's path and the model's steering would be two cars; replay it on "
                                       "recordings of its own convention (the reader options it was trained with)\n")
    assert not (tmp_path / "replay").exists()
