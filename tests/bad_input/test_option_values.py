"""Rule 1, every value checked where it enters: a value an option, a flag or a config key cannot take (out
of its range, of another type, an option of another world or model, a combination that means nothing) is refused
by the real command in one line naming the option and what it takes, before any work."""

import pytest

from steerlab.options import WORKERS
from tests.bad_input.builders import (_compile, _track, _train, _tub_replay, _tune_space, _tune_storage, _with, config,
                                      refused_in_one_line)
from tests.inputs import ch2, made, sim_log, tub

# each case: a function (tmp_path, stack) -> the command's arguments, and the message's substring (builders.py)
BAD_INPUTS = {
    # d) options checked for type and range when the config is read, before the dataset compiles
    **{f"train {o}": (_train(o), f"{o.split('=')[0]} must be {expected}, got {got}") for o, expected, got in [
        ("train.lr=nan", "a positive finite number", "'nan'"),
        ("train.lr=-1", "a positive finite number", "-1"),
        ("train.lr=fast", "a positive finite number", "'fast'"),
        ("train.lr=inf", "a positive finite number", "'inf'"),
        ("train.epochs=-1", "an integer of at least 1 (at most 1000000)", "-1"),
        ("train.epochs=0", "an integer of at least 1 (at most 1000000)", "0"),
        ("train.epochs=abc", "an integer of at least 1 (at most 1000000)", "'abc'"),
        ("train.epochs=1.5", "an integer of at least 1 (at most 1000000)", "1.5"),
        ("train.batch_size=0", "an integer of at least 1 (at most 1000000)", "0"),
        ("train.batch_size=ten", "an integer of at least 1 (at most 1000000)", "'ten'"),
        ("model.dropout=2", "a number in [0, 1)", "2"),
        ("train.loss=l2", "mse or mae", "'l2'"),
        ("train.keep=first", "best or last", "'first'"),
        ("train.smoothness=-0.5", "a finite number of at least 0", "-0.5"),
    ]},
    "sim dagger with a suite road type that does not exist": (
        lambda t, s: ["sim", "dagger", str(config(t, sim_log(t / "sim"))), "dagger.suite_roads=twisty,mountain"],
        "dagger.suite_roads must be a comma list of road types of country, highway, twisty, each once, got "
        "'twisty,mountain'"),
    "sim dagger in the track world with a track style that does not exist": (
        lambda t, s: ["sim", "dagger", str(config(t, tub(t / "tub"))), "dagger.world=track", "dagger.suite=t1",
                      "dagger.suite_styles=gravel"],
        "dagger.suite_styles must be a comma list of track styles of taped, centre, each once, got 'gravel'"),
    "sim dagger in the track world with zero rollout minutes": (
        lambda t, s: ["sim", "dagger", str(config(t, tub(t / "tub"))), "dagger.world=track", "dagger.suite=t1",
                      "dagger.minutes=0"],
        "dagger.minutes must be a number in (0, 1440] min, got 0"),
    "sim dagger in the track world with an option of the road world": (
        lambda t, s: ["sim", "dagger", str(config(t, tub(t / "tub"))), "dagger.world=track", "dagger.suite=t1",
                      "dagger.suite_roads=taped"],
        "dagger.suite_roads is an option of dagger.world road; dagger.world track does not take it"),
    "sim dagger in replay with a suite": (
        lambda t, s: ["sim", "dagger", str(config(t, sim_log(t / "sim"))), "dagger.world=replay", "dagger.suite=v1"],
        "dagger.suite is an option of dagger.world road and track; dagger.world replay does not take it"),
    "an override whose value is not YAML": (_train("train.lr=,"), "override 'train.lr=,': the value is not valid YAML "
                                                               "(expected the node content, but found ','); quote "
                                                               "it: train.lr='\",\"'"),
    "sim dagger with no suite road type": (
        lambda t, s: ["sim", "dagger", str(config(t, sim_log(t / "sim"))), 'dagger.suite_roads=","'],
        "dagger.suite_roads must be a comma list of road types of country, highway, twisty, each once, got ','"),
    # smoothness in the loss needs windows of consecutive frames
    "train smoothness of a single-frame model": (_train("train.smoothness=1", "model.name=pilotnet"),
                                                 "train.smoothness needs a recurrent model"),
    # the hue turns RGB colours only
    "train hue of a gray input": (_train("train.hue_deg=90", "preprocess.color=gray"),
                                  "train.hue_deg turns the hue of RGB inputs; preprocess.color is gray"),
    # h) options of the closed-loop commands, checked before anything drives
    "bench smoothing 5": (_with("--smoothing", "5"), "--smoothing must be a number in (0, 1], got 5"),
    "bench smoothing 0": (_with("--smoothing", "0"), "--smoothing must be a number in (0, 1], got 0"),
    "bench workers 0": (_with("--workers", "0"), f"--workers must be {WORKERS.words(int)}, got 0"),
    "bench workers -3": (_with("--workers", "-3"), f"--workers must be {WORKERS.words(int)}, got -3"),
    "bench minutes inf": (_with("--minutes", "inf"), "--minutes must be a number in (0, 1440] min, got inf"),
    "bench minutes nan": (_with("--minutes", "nan"), "--minutes must be a number in (0, 1440] min, got nan"),
    "drive smoothing 1.5": (_with("--smoothing", "1.5", command="sim drive"),
                            "--smoothing must be a number in (0, 1], got 1.5"),
    "drive minutes -inf": (_with("--minutes=-inf", command="sim drive"),
                           "--minutes must be a number in (0, 1440] min, got -inf"),
    "serve smoothing -1": (lambda t, s: ["serve", str(made(t)), "--smoothing", "-1"],
                           "--smoothing must be a number in (0, 1], got -1"),
    "replay workers 0": (_with("--workers", "0", command="replay"), f"--workers must be {WORKERS.words(int)}"),
    "replay smoothing 0": (_with("--smoothing", "0", command="replay"), "--smoothing must be a number in (0, 1], got 0"),
    "replay limit -1": (_with("--limit", "-1", command="replay"), "--limit must be a number in (0, 5] m, got -1"),
    "replay max heading inf": (_with("--max-heading", "inf", command="replay"),
                               "--max-heading must be a number in [1, 90] degrees (not radians), got inf"),
    "replay speed -3": (_with("--speed", "-3", command="replay"), "--speed must be a number in (0, 100] m/s, got -3"),
    # the replay of small cars (a tub: the track world's replay)
    "replay lane width 0": (_tub_replay("--lane-width", "0"), "--lane-width must be a number in (0.2, 2] m, wider than "
                                                          "the car's 0.2 m body, got 0"),
    "replay lane width narrower than the car": (_tub_replay("--lane-width", "0.15"),
                                                "--lane-width must be a number in (0.2, 2] m, wider than the "
                                                "car's 0.2 m body, got 0.15"),
    "replay tub speed nan": (_tub_replay("--speed", "nan"), "--speed must be a number in (0, 100] m/s, got nan"),
    "replay speed inf": (_with("--speed", "inf", command="replay"),
                         "--speed must be a number in (0, 100] m/s, got inf"),
    "replay in an unknown world": (_tub_replay("--world", "moon"),
                                   "argument --world: invalid choice: 'moon' (choose from 'road', 'track')"),
    "replay a tub with a road option": (_tub_replay("--max-heading", "5"),
                                        "--max-heading is an option of the road world (--world road); the track "
                                        "world does not take it"),
    "replay a road recording with a track option": (_with("--lane-width", "0.5", command="replay"),
                                                    "--lane-width is an option of the track world (--world track)"),
    "replay the throttle of a model without one": (_tub_replay("--throttle", "model"),
                                                   "model.pt predicts no throttle: steerlab replay --throttle model "
                                                   "needs a model that learned it"),
    "replay the model's throttle at a given speed": (_tub_replay("--throttle", "model", "--speed", "2"),
                                                     "--speed must be left out when the throttle is the "
                                                     "model's (it sets the speed), got 2"),
    "tune heartbeat 5,2": (_tune_storage("sqlite:///{tmp}/s.db", heartbeat="5,2"),
                           "STEERLAB_TUNE_HEARTBEAT='5,2': expected INTERVAL,GRACE in whole seconds with 0 < INTERVAL "
                           "< GRACE"),
    # l) latency: models, threads and checkpoints checked before anything is timed
    "latency unknown model": (lambda t, s: ["latency", "--models", "pilotnet,pilot-net", "--out", str(t / "out")],
                              "models pilotnet,pilot-net: steerlab has no pilot-net models; choose models of "
                              "cg23,"),
    "latency a model twice": (lambda t, s: ["latency", "--models", "zero,zero", "--out", str(t / "out")],
                              "models zero,zero: zero named twice; choose models of cg23,"),
    "latency all and a model": (lambda t, s: ["latency", "--models", "all,zero", "--out", str(t / "out")],
                                "models all,zero: 'all' names every model already"),
    "latency threads 0": (lambda t, s: ["latency", "--models", "zero", "--threads", "0", "--out", str(t / "out")],
                          "--threads must be an integer in [1, "),
    "latency threads -1": (lambda t, s: ["latency", "--models", "zero", "--threads", "-1", "--out", str(t / "out")],
                           "--threads must be an integer in [1, "),
    "train model.seq_len=0": (_train("model.name=lstm", "model.seq_len=0"),
                              "model.seq_len must be an integer in [1, 1000], got 0"),
    "train model.seq_len=ten": (_train("model.name=lstm", "model.seq_len=ten"),
                                "model.seq_len must be an integer in [1, 1000], got 'ten'"),
    "train an input too small for the model": (_train("preprocess.width=20", "preprocess.height=10"),
                                               "model 'pilotnet' cannot take a 20x10 input"),
    "train preprocess.width=0": (_train("preprocess.width=0"), "preprocess.width must be an integer in [1, 4096]"),
    "compile a CH2 folder with --camera left": (
        lambda t, s: ["compile", "--data", str(ch2(t / "ch2")), "--camera", "left", "--cache", str(t / "cache")],
        "has no 'left' camera (it has center)"),
    "tune a range the option does not take": (_tune_space({"model.dropout": {"low": 0.5, "high": 3.0}}),
                                              "tune: model.dropout takes a number in [0, 1), and the range or "
                                              "choices give 3.0"),
    "sim drive in an unknown world": (lambda t, s: ["sim", "drive", str(made(t)), "--world", "moon"],
                                      "argument --world: invalid choice: 'moon' (choose from 'road', 'track')"),
    "track lane width 0": (_track("record", "--lane-width", "0"), "--lane-width must be a number in (0.2, 2] m, wider "
                                                                  "than the car's 0.2 m body, got 0"),
    "track lane width -0.5": (_track("drive", "--lane-width=-0.5"), "--lane-width must be a number in (0.2, 2] m"),
    "track record with a road option": (_track("record", "--road", "twisty"),
                                        "--road is an option of the road world (--world road)"),
    "track record in the simulator's layout": (_track("record", "--layout", "udacity-sim"),
                                               "--layout must be tub or steerlab, got 'udacity-sim'"),
    "track record a suite track": (_track("record", "--seed", "9401"), "track seeds 9000-9999 are reserved"),
    "track drive with a throttle cap above 1": (_track("drive", "--max-throttle", "1.5"),
                                                "--max-throttle must be a number in (0, 1], got 1.5"),
    "road drive with a track option": (lambda t, s: ["sim", "drive", str(made(t)), "--throttle", "0.5"],
                                       "--throttle is an option of the track world (--world track)"),
    "train the throttle with a model that cannot": (_train("model.name=two-stream-flow", "train.throttle_weight=1"),
                                                    "train.throttle_weight: model 'two-stream-flow' does not learn a "
                                                    "throttle; these do: cg23"),
    "set model.throttle by hand": (_train("model.throttle=true"), "model.throttle is not set by hand: training adds "
                                                                  "the throttle output when train.throttle_weight > 0"),
    "drive minutes that hold no frame": (_with("--minutes", "1e-9", command="sim drive"),
                                         "--minutes must be at least one frame's time: 0.000833 min at 20 frames/s"),
    "a reader option that is a list": (_compile(lambda t: tub(t / "tub"), "full_lock_deg=[25]"),
                                       "reader.full_lock_deg must be a number in (0, 90) degrees, got [25]"),
    "a reader option that is not a boolean": (_compile(lambda t: tub(t / "tub"), "skip_missing=maybe"),
                                              "reader.skip_missing must be true or false, got 'maybe'"),
    "latency on more threads than the machine has": (
        lambda t, s: ["latency", "--models", "zero", "--threads", "100000"], "--threads must be an integer in [1, "),
    "an episode that does not exist": (_train("train.exclude_episodes=[drift-outt]"),
                                       "train.exclude_episodes[0] must be normal, drift-out, recover or rollout"),
    "a suite road type named twice": (_with("--roads", "twisty,twisty"),
                                      "--roads must be a comma list of road types of country, highway, twisty, each "
                                      "once, got 'twisty,twisty'"),
    "export int8 without calibration data": (lambda t, s: ["export", str(made(t)), "--out", str(t / "m.onnx"),
                                                           "--int8"], "--int8 needs calibration data: --calib"),
    "export int8 calibration range inverted": (lambda t, s: ["export", str(made(t)), "--out", str(t / "m.onnx"),
                                                             "--int8", "--calib", str(sim_log(t / "sim")),
                                                             "--calib-range", "5:2"],
                                               "driving_log.csv: frame range 5:2 is empty: START must be below STOP"),
}


@pytest.mark.parametrize("case", BAD_INPUTS)
def test_bad_input_is_refused_in_one_line(case, tmp_path, capsys):
    refused_in_one_line(BAD_INPUTS[case], tmp_path, capsys)
