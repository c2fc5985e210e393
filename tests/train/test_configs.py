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

ROOT = Path(__file__).resolve().parents[2]
CONFIGS = sorted((ROOT / "configs").glob("*.yaml"))

# The donkeycar tubs the configs train on: the two real tubs and the track world's recordings (`steerlab sim
# record --world track` writes tubs). A tub's config gets the tub defaults under its own settings, so what such a
# config builds depends on the data being a tub; the test puts stand-in tubs there.
TUBS = ["../shared/data/donkeycar/hall", "../shared/data/donkeycar/taped-track",
        *(f"runs/track/tub-{k}" for k in range(1, 5)), *(f"runs/race/tubs/taped-{k}-1min" for k in range(5, 17)),
        *(f"runs/race/tubs/centre-{k}-1min" for k in range(17, 21))]

# What each config builds, by hand from its comments and docs/results/ (whose tables print the input as
# channels@width x height): the run (an experiment: every entry's run, in order, with its label), then its sections.
EXPECTED = {
    "ch2_best.yaml": [
        "flow-lstm(dropout=0.46827, hidden=37) 5@200x66 yuv dis flow, split 0:1800/1800:2400, epochs 6 keeping the "
        "last, batch 14, lr 0.000461481, mse",
    ],
    "ch2_pilotnet.yaml": [
        "pilotnet(dropout=0.5) 1@200x66 gray, split 0:1800/1800:2400, epochs 40 with patience 8, batch 100, lr "
        "0.0001, mse",
    ],
    "ch2_replay_dagger.yaml": [
        "pilotnet(dropout=0.5) 1@200x66 gray, split 0:1800/1800:2400, epochs 12 with patience 4, batch 100, lr "
        "0.0001, mse, views -0.5 m +0 deg +0.5 m +0 deg, returning within 20 m",
        "dagger in replay: 2 rounds of 4 epochs, beta 0.5 x 0.5 a round, at 15 m/s, workers 1",
    ],
    "dagger_demo.yaml": [
        "pilotnet(dropout=0.3) 1@200x66 gray, split 0:7680/7680:9600, epochs 5 with patience 3, batch 16, lr 0.0003, "
        "mse, flips, side cameras, without drift-out",
        "dagger in the road world: 2 rounds of 2 epochs, beta 0.5 x 0.5 a round, 2 min of twisty roads, suite v1, "
        "workers 2",
    ],
    "dagger_demo_replay.yaml": [
        "pilotnet(dropout=0.3) 1@200x66 gray, split 0:7680/7680:9600, epochs 5 with patience 3, batch 16, lr 0.0003, "
        "mse, flips, side cameras, without drift-out",
        "dagger in replay: 2 rounds of 2 epochs, beta 0.5 x 0.5 a round, at the recorded speed, workers 2",
    ],
    "dagger_pilotnet.yaml": [
        "pilotnet(dropout=0.3) 1@200x66 gray, split 0:11520/11520:14400, epochs 10 with patience 4, batch 100, lr "
        "0.0003, mse, flips, side cameras, without drift-out",
        "dagger in the road world: 2 rounds of 3 epochs, beta 0.5 x 0.5 a round, 3 min of twisty,country roads, "
        "suite v1, workers 2",
    ],
    "donkey_best.yaml": [
        "multimodal-lstm() 3@200x66 gray farneback flow, split 0:4012/4012:5015, epochs 25 keeping the last, batch "
        "32, lr 0.0003, mae, throttle weight 0.5",
    ],
    "donkey_hall.yaml": [
        "multimodal-lstm() 3@200x66 gray farneback flow, split 0:3510/3510:4012, epochs 30 with patience 5, batch "
        "32, lr 0.0003, mae, throttle weight 0.5",
    ],
    "donkey_replay_dagger.yaml": [
        "multimodal-lstm() 3@200x66 gray farneback flow, split 0:3510/3510:4012, epochs 30 with patience 5, batch "
        "32, lr 0.0003, mae, throttle weight 0.5",
        "dagger in replay: 2 rounds of 4 epochs, beta 0.5 x 0.5 a round, at 2 m/s, workers 1",
    ],
    "experiment_batch16.yaml": [
        "pilotnet: pilotnet(dropout=0.3) 1@200x66 gray, split 0:7680/7680:9600, epochs 5 with patience 3, batch 16, "
        "lr 0.0003, mse, flips, side cameras, without drift-out",
        "pilotnet-diff: pilotnet-diff(dropout=0.3) 2@200x66 gray, split 0:7680/7680:9600, epochs 5 with patience 3, "
        "batch 16, lr 0.0003, mse, flips, side cameras, motion dropout 0.5, without drift-out",
        "pilotnet-flow: pilotnet-flow(dropout=0.3) 3@200x66 gray farneback flow, split 0:7680/7680:9600, epochs 5 "
        "with patience 3, batch 16, lr 0.0003, mse, flips, side cameras, motion dropout 0.5, without drift-out",
        "two-stream-flow: two-stream-flow(dropout=0.3) 3@200x66 gray farneback flow, split 0:7680/7680:9600, epochs "
        "5 with patience 3, batch 16, lr 0.0003, mse, flips, side cameras, motion dropout 0.5, without drift-out",
        "cg23: cg23(dropout=0.3) 1@200x66 gray, split 0:7680/7680:9600, epochs 5 with patience 3, batch 16, lr "
        "0.0003, mse, flips, side cameras, without drift-out",
        "closed loop: suite v1, 1 min per road, workers 1",
    ],
    "experiment_ch2.yaml": [
        "zero: zero() 1@200x66 gray, split 0:1800/1800:2400, epochs 30 with patience 6, batch 100, lr 0.0001, mse",
        "train-mean: train-mean() 1@200x66 gray, split 0:1800/1800:2400, epochs 30 with patience 6, batch 100, lr "
        "0.0001, mse",
        "pilotnet: pilotnet(dropout=0.5) 1@200x66 gray, split 0:1800/1800:2400, epochs 30 with patience 6, batch "
        "100, lr 0.0001, mse",
        "pilotnet-diff: pilotnet-diff(dropout=0.5) 2@200x66 gray, split 0:1800/1800:2400, epochs 30 with patience 6, "
        "batch 100, lr 0.0001, mse",
        "pilotnet-flow: pilotnet-flow(dropout=0.5) 3@200x66 gray farneback flow, split 0:1800/1800:2400, epochs 30 "
        "with patience 6, batch 100, lr 0.0001, mse",
        "cnn3d: cnn3d(dropout=0.5) 3@200x66 gray, split 0:1800/1800:2400, epochs 30 with patience 6, batch 100, lr "
        "0.0001, mse",
        "two-stream-flow: two-stream-flow(dropout=0.5) 3@200x66 gray farneback flow, split 0:1800/1800:2400, epochs "
        "30 with patience 6, batch 100, lr 0.0001, mse",
        "lstm: lstm(dropout=0.5) 1@200x66 gray, split 0:1800/1800:2400, epochs 30 with patience 6, batch 10, lr "
        "0.0001, mse",
        "multimodal-lstm: multimodal-lstm(dropout=0.5) 3@200x66 gray farneback flow, split 0:1800/1800:2400, epochs "
        "30 with patience 6, batch 10, lr 0.0001, mse",
        "flow-lstm: flow-lstm(dropout=0.5) 5@200x66 yuv farneback flow, split 0:1800/1800:2400, epochs 30 with "
        "patience 6, batch 10, lr 0.0001, mse",
        "cg23: cg23(dropout=0.5) 1@200x66 gray, split 0:1800/1800:2400, epochs 30 with patience 6, batch 100, lr "
        "0.0001, mse",
        "yang-base: yang-base(dropout=0.5) 3@96x96 hsv, split 0:1800/1800:2400, epochs 30 with patience 6, batch "
        "100, lr 0.0001, mse",
    ],
    "experiment_ch2_recipe.yaml": [
        "multimodal-lstm: multimodal-lstm(dropout=0.5) 3@200x66 gray farneback flow, split 0:1800/1800:2400, epochs "
        "30 with patience 6, batch 10, lr 0.0001, mse, motion dropout 0.5, views -0.5 m +0 deg +0.5 m +0 deg, "
        "returning within 20 m",
        "flow-lstm: flow-lstm(dropout=0.5) 5@200x66 yuv farneback flow, split 0:1800/1800:2400, epochs 30 with "
        "patience 6, batch 10, lr 0.0001, mse, motion dropout 0.5, views -0.5 m +0 deg +0.5 m +0 deg, returning "
        "within 20 m",
    ],
    "experiment_ch2_replay.yaml": [
        "zero: zero() 1@200x66 gray, split 0:1800/1800:2400, epochs 30 with patience 6, batch 100, lr 0.0001, mse",
        "train-mean: train-mean() 1@200x66 gray, split 0:1800/1800:2400, epochs 30 with patience 6, batch 100, lr "
        "0.0001, mse",
        "pilotnet: pilotnet(dropout=0.5) 1@200x66 gray, split 0:1800/1800:2400, epochs 30 with patience 6, batch "
        "100, lr 0.0001, mse",
        "flow-lstm: flow-lstm(dropout=0.5) 5@200x66 yuv farneback flow, split 0:1800/1800:2400, epochs 30 with "
        "patience 6, batch 10, lr 0.0001, mse",
        "flow-lstm views: flow-lstm(dropout=0.5) 5@200x66 yuv farneback flow, split 0:1800/1800:2400, epochs 30 with "
        "patience 6, batch 10, lr 0.0001, mse, views -0.25 m +0 deg +0.25 m +0 deg, returning within 80 m",
        "multimodal-lstm: multimodal-lstm(dropout=0.5) 3@200x66 gray farneback flow, split 0:1800/1800:2400, epochs "
        "30 with patience 6, batch 10, lr 0.0001, mse",
        "replay at 15 m/s",
    ],
    "experiment_ch2_tuned.yaml": [
        "multimodal-lstm default: multimodal-lstm(dropout=0.5, hidden=100) 3@200x66 gray farneback flow, split "
        "0:1800/1800:2400, epochs 30 with patience 6, batch 10, lr 0.0001, mse",
        "multimodal-lstm tuned: multimodal-lstm(dropout=0.308, hidden=307) 3@200x66 gray farneback flow, split "
        "0:1800/1800:2400, epochs 30 with patience 6, batch 10, lr 0.000319, mse",
        "multimodal-lstm tuned re-ranked: multimodal-lstm(dropout=0.238, hidden=392) 3@200x66 gray farneback flow, "
        "split 0:1800/1800:2400, epochs 30 with patience 6, batch 10, lr 0.000437, mse",
        "flow-lstm default: flow-lstm(dropout=0.5, hidden=100) 5@200x66 yuv farneback flow, split 0:1800/1800:2400, "
        "epochs 30 with patience 6, batch 10, lr 0.0001, mse",
        "flow-lstm tuned: flow-lstm(dropout=0.102, hidden=193) 5@200x66 yuv dis flow, split 0:1800/1800:2400, epochs "
        "30 with patience 6, batch 14, lr 0.000653, mse",
    ],
    "experiment_ch2_views.yaml": [
        "multimodal-lstm: multimodal-lstm(dropout=0.5) 3@200x66 gray farneback flow, split 0:1800/1800:2400, epochs "
        "30 with patience 6, batch 10, lr 0.0001, mse, views -0.25 m +0 deg +0.25 m +0 deg, returning within 80 m",
        "flow-lstm: flow-lstm(dropout=0.5) 5@200x66 yuv farneback flow, split 0:1800/1800:2400, epochs 30 with "
        "patience 6, batch 10, lr 0.0001, mse, views -0.25 m +0 deg +0.25 m +0 deg, returning within 80 m",
    ],
    "experiment_dagger.yaml": [
        "pilotnet-flow: pilotnet-flow(dropout=0.3) 3@200x66 gray farneback flow, split 0:7680/7680:9600, epochs 5 "
        "with patience 3, batch 16, lr 0.0003, mse, flips, side cameras, motion dropout 0.5, without drift-out",
        "yang-base: yang-base(dropout=0.3) 3@96x96 hsv, split 0:7680/7680:9600, epochs 5 with patience 3, batch 8, "
        "lr 0.0003, mse, flips, side cameras, without drift-out",
        "multitask-speed: multitask-speed(dropout=0.3) 3@96x96 hsv, split 0:7680/7680:9600, epochs 5 with patience "
        "3, batch 8, lr 0.0003, mse, flips, side cameras, without drift-out",
        "dagger in the road world: 2 rounds of 3 epochs, beta 0.5 x 0.5 a round, 2 min of twisty,country roads, "
        "suite v1 at 1 min, workers 1",
        "closed loop: suite v1, 1 min per road, workers 1",
    ],
    "experiment_flow_lstm_no_md.yaml": [
        "flow-lstm no-motion-dropout: flow-lstm(dropout=0.3) 5@200x66 yuv farneback flow, split 0:7680/7680:9600, "
        "epochs 5 with patience 3, batch 8, lr 0.0003, mse, flips, side cameras, without drift-out",
        "closed loop: suite v1, 1 min per road, workers 1",
    ],
    "experiment_recipe.yaml": [
        "zero: zero() 1@200x66 gray, split 0:7680/7680:9600, epochs 5 with patience 3, batch 64, lr 0.0003, mse, "
        "flips, side cameras, without drift-out",
        "train-mean: train-mean() 1@200x66 gray, split 0:7680/7680:9600, epochs 5 with patience 3, batch 64, lr "
        "0.0003, mse, flips, side cameras, without drift-out",
        "pilotnet: pilotnet(dropout=0.3) 1@200x66 gray, split 0:7680/7680:9600, epochs 5 with patience 3, batch 64, "
        "lr 0.0003, mse, flips, side cameras, without drift-out",
        "pilotnet-diff: pilotnet-diff(dropout=0.3) 2@200x66 gray, split 0:7680/7680:9600, epochs 5 with patience 3, "
        "batch 64, lr 0.0003, mse, flips, side cameras, motion dropout 0.5, without drift-out",
        "pilotnet-flow: pilotnet-flow(dropout=0.3) 3@200x66 gray farneback flow, split 0:7680/7680:9600, epochs 5 "
        "with patience 3, batch 64, lr 0.0003, mse, flips, side cameras, motion dropout 0.5, without drift-out",
        "cnn3d: cnn3d(dropout=0.3) 3@200x66 gray, split 0:7680/7680:9600, epochs 3 with patience 3, batch 64, lr "
        "0.0003, mse, flips, side cameras, motion dropout 0.5, without drift-out",
        "two-stream-flow: two-stream-flow(dropout=0.3) 3@200x66 gray farneback flow, split 0:7680/7680:9600, epochs "
        "5 with patience 3, batch 64, lr 0.0003, mse, flips, side cameras, motion dropout 0.5, without drift-out",
        "lstm: lstm(dropout=0.3) 1@200x66 gray, split 0:7680/7680:9600, epochs 5 with patience 3, batch 8, lr "
        "0.0003, mse, flips, side cameras, without drift-out",
        "multimodal-lstm: multimodal-lstm(dropout=0.3) 3@200x66 gray farneback flow, split 0:7680/7680:9600, epochs "
        "5 with patience 3, batch 8, lr 0.0003, mse, flips, side cameras, motion dropout 0.5, without drift-out",
        "flow-lstm: flow-lstm(dropout=0.3) 5@200x66 yuv farneback flow, split 0:7680/7680:9600, epochs 5 with "
        "patience 3, batch 8, lr 0.0003, mse, flips, side cameras, motion dropout 0.5, without drift-out",
        "cg23: cg23(dropout=0.3) 1@200x66 gray, split 0:7680/7680:9600, epochs 5 with patience 3, batch 64, lr "
        "0.0003, mse, flips, side cameras, without drift-out",
        "yang-base: yang-base(dropout=0.3) 3@96x96 hsv, split 0:7680/7680:9600, epochs 5 with patience 3, batch 8, "
        "lr 0.0003, mse, flips, side cameras, without drift-out",
        "speed-command: speed-command(dropout=0.3) 3@96x96 hsv, split 0:7680/7680:9600, epochs 5 with patience 3, "
        "batch 8, lr 0.0003, mse, flips, side cameras, without drift-out",
        "multitask-speed: multitask-speed(dropout=0.3) 3@96x96 hsv, split 0:7680/7680:9600, epochs 5 with patience "
        "3, batch 8, lr 0.0003, mse, flips, side cameras, without drift-out",
        "pilotnet-flow no-motion-dropout: pilotnet-flow(dropout=0.3) 3@200x66 gray farneback flow, split "
        "0:7680/7680:9600, epochs 5 with patience 3, batch 64, lr 0.0003, mse, flips, side cameras, without "
        "drift-out",
        "multimodal-lstm no-motion-dropout: multimodal-lstm(dropout=0.3) 3@200x66 gray farneback flow, split "
        "0:7680/7680:9600, epochs 5 with patience 3, batch 8, lr 0.0003, mse, flips, side cameras, without drift-out",
        "pilotnet-flow target-shift-0.2s: pilotnet-flow(dropout=0.3) 3@200x66 gray farneback flow, split "
        "0:7680/7680:9600, epochs 5 with patience 3, batch 64, lr 0.0003, mse, flips, side cameras, target 0.2 s "
        "ahead, without drift-out",
        "pilotnet-flow recovery-weight-3: pilotnet-flow(dropout=0.3) 3@200x66 gray farneback flow, split "
        "0:7680/7680:9600, epochs 5 with patience 3, batch 64, lr 0.0003, mse, flips, side cameras, recover episodes "
        "drawn 3 times, without drift-out",
        "yang-base batch-64: yang-base(dropout=0.3) 3@96x96 hsv, split 0:7680/7680:9600, epochs 5 with patience 3, "
        "batch 64, lr 0.0003, mse, flips, side cameras, without drift-out",
        "multitask-speed batch-64: multitask-speed(dropout=0.3) 3@96x96 hsv, split 0:7680/7680:9600, epochs 5 with "
        "patience 3, batch 64, lr 0.0003, mse, flips, side cameras, without drift-out",
        "closed loop: suite v1, 1 min per road, workers 2",
    ],
    "experiment_recovery.yaml": [
        "pilotnet with recover frames: pilotnet(dropout=0.3) 1@200x66 gray, split 720:3600/0:720, epochs 8 with "
        "patience 3, batch 64, lr 0.0003, mse, flips, without drift-out",
        "pilotnet without recover frames: pilotnet(dropout=0.3) 1@200x66 gray, split 720:3600/0:720, epochs 8 with "
        "patience 3, batch 64, lr 0.0003, mse, flips, without drift-out and recover",
        "closed loop: suite v1, 1 min per road, workers 2",
    ],
    "experiment_sim.yaml": [
        "zero: zero() 1@200x66 gray, split 300:1459/0:300, epochs 15 with patience 5, batch 64, lr 0.0003, mse, "
        "flips, side cameras, from 1 m/s",
        "train-mean: train-mean() 1@200x66 gray, split 300:1459/0:300, epochs 15 with patience 5, batch 64, lr "
        "0.0003, mse, flips, side cameras, from 1 m/s",
        "pilotnet: pilotnet(dropout=0.5) 1@200x66 gray, split 300:1459/0:300, epochs 15 with patience 5, batch 64, "
        "lr 0.0003, mse, flips, side cameras, from 1 m/s",
        "pilotnet-diff: pilotnet-diff(dropout=0.5) 2@200x66 gray, split 300:1459/0:300, epochs 15 with patience 5, "
        "batch 64, lr 0.0003, mse, flips, side cameras, from 1 m/s",
        "pilotnet-flow: pilotnet-flow(dropout=0.5) 3@200x66 gray farneback flow, split 300:1459/0:300, epochs 15 "
        "with patience 5, batch 64, lr 0.0003, mse, flips, side cameras, from 1 m/s",
        "cnn3d: cnn3d(dropout=0.5) 3@200x66 gray, split 300:1459/0:300, epochs 15 with patience 5, batch 64, lr "
        "0.0003, mse, flips, side cameras, from 1 m/s",
        "two-stream-flow: two-stream-flow(dropout=0.5) 3@200x66 gray farneback flow, split 300:1459/0:300, epochs 15 "
        "with patience 5, batch 64, lr 0.0003, mse, flips, side cameras, from 1 m/s",
        "lstm: lstm(dropout=0.5) 1@200x66 gray, split 300:1459/0:300, epochs 15 with patience 5, batch 8, lr 0.0003, "
        "mse, flips, side cameras, from 1 m/s",
        "multimodal-lstm: multimodal-lstm(dropout=0.5) 3@200x66 gray farneback flow, split 300:1459/0:300, epochs 15 "
        "with patience 5, batch 8, lr 0.0003, mse, flips, side cameras, from 1 m/s",
        "flow-lstm: flow-lstm(dropout=0.5) 5@200x66 yuv farneback flow, split 300:1459/0:300, epochs 15 with "
        "patience 5, batch 8, lr 0.0003, mse, flips, side cameras, from 1 m/s",
        "cg23: cg23(dropout=0.5) 1@200x66 gray, split 300:1459/0:300, epochs 15 with patience 5, batch 64, lr "
        "0.0003, mse, flips, side cameras, from 1 m/s",
        "yang-base: yang-base(dropout=0.5) 3@96x96 hsv, split 300:1459/0:300, epochs 15 with patience 5, batch 64, "
        "lr 0.0003, mse, flips, side cameras, from 1 m/s",
        "speed-command: speed-command(dropout=0.5) 3@96x96 hsv, split 300:1459/0:300, epochs 15 with patience 5, "
        "batch 8, lr 0.0003, mse, flips, side cameras, from 1 m/s",
        "multitask-speed: multitask-speed(dropout=0.5) 3@96x96 hsv, split 300:1459/0:300, epochs 15 with patience 5, "
        "batch 64, lr 0.0003, mse, flips, side cameras, from 1 m/s",
        "replay at the recorded speed",
    ],
    "experiment_synthetic.yaml": [
        "zero: zero() 1@200x66 gray, split 0:2880/2880:3600, epochs 8 with patience 3, batch 64, lr 0.0003, mse, "
        "flips, from 4 m/s, without drift-out",
        "train-mean: train-mean() 1@200x66 gray, split 0:2880/2880:3600, epochs 8 with patience 3, batch 64, lr "
        "0.0003, mse, flips, from 4 m/s, without drift-out",
        "pilotnet: pilotnet(dropout=0.3) 1@200x66 gray, split 0:2880/2880:3600, epochs 8 with patience 3, batch 64, "
        "lr 0.0003, mse, flips, from 4 m/s, without drift-out",
        "pilotnet-diff: pilotnet-diff(dropout=0.3) 2@200x66 gray, split 0:2880/2880:3600, epochs 8 with patience 3, "
        "batch 64, lr 0.0003, mse, flips, from 4 m/s, without drift-out",
        "pilotnet-flow: pilotnet-flow(dropout=0.3) 3@200x66 gray farneback flow, split 0:2880/2880:3600, epochs 8 "
        "with patience 3, batch 64, lr 0.0003, mse, flips, from 4 m/s, without drift-out",
        "cnn3d: cnn3d(dropout=0.3) 3@200x66 gray, split 0:2880/2880:3600, epochs 8 with patience 3, batch 64, lr "
        "0.0003, mse, flips, from 4 m/s, without drift-out",
        "two-stream-flow: two-stream-flow(dropout=0.3) 3@200x66 gray farneback flow, split 0:2880/2880:3600, epochs "
        "8 with patience 3, batch 64, lr 0.0003, mse, flips, from 4 m/s, without drift-out",
        "lstm: lstm(dropout=0.3) 1@200x66 gray, split 0:2880/2880:3600, epochs 8 with patience 3, batch 8, lr "
        "0.0003, mse, flips, from 4 m/s, without drift-out",
        "multimodal-lstm: multimodal-lstm(dropout=0.3) 3@200x66 gray farneback flow, split 0:2880/2880:3600, epochs "
        "8 with patience 3, batch 8, lr 0.0003, mse, flips, from 4 m/s, without drift-out",
        "flow-lstm: flow-lstm(dropout=0.3) 5@200x66 yuv farneback flow, split 0:2880/2880:3600, epochs 8 with "
        "patience 3, batch 8, lr 0.0003, mse, flips, from 4 m/s, without drift-out",
        "cg23: cg23(dropout=0.3) 1@200x66 gray, split 0:2880/2880:3600, epochs 8 with patience 3, batch 64, lr "
        "0.0003, mse, flips, from 4 m/s, without drift-out",
        "yang-base: yang-base(dropout=0.3) 3@96x96 hsv, split 0:2880/2880:3600, epochs 8 with patience 3, batch 64, "
        "lr 0.0003, mse, flips, from 4 m/s, without drift-out",
        "speed-command: speed-command(dropout=0.3) 3@96x96 hsv, split 0:2880/2880:3600, epochs 8 with patience 3, "
        "batch 8, lr 0.0003, mse, flips, from 4 m/s, without drift-out",
        "multitask-speed: multitask-speed(dropout=0.3) 3@96x96 hsv, split 0:2880/2880:3600, epochs 8 with patience "
        "3, batch 64, lr 0.0003, mse, flips, from 4 m/s, without drift-out",
        "closed loop: suite v1, 1 min per road, workers 2",
    ],
    "recipe_pilotnet.yaml": [
        "pilotnet(dropout=0.3) 1@200x66 gray, split 0:7680/7680:9600, epochs 5 with patience 3, batch 64, lr 0.0003, "
        "mse, flips, side cameras, without drift-out",
    ],
    "sim_replay_dagger.yaml": [
        "multimodal-lstm(dropout=0.5) 3@200x66 gray farneback flow, split 300:1459/0:300, epochs 15 with patience 5, "
        "batch 8, lr 0.0003, mse, flips, side cameras, from 1 m/s",
        "dagger in replay: 2 rounds of 4 epochs, beta 0.5 x 0.5 a round, at the recorded speed, workers 1",
    ],
    "track_dagger.yaml": [
        "multimodal-lstm() 3@200x66 gray farneback flow, split 0:3000/3000:3538, epochs 1 with patience 3, batch 32, "
        "lr 0.0003, mae, throttle weight 0.5, 3 extra recordings, from runs/track/default/best.pt",
        "dagger in the track world: 3 rounds of 3 epochs, beta 0.5 x 0.5 a round, 2 min of tracks, suite t1 at 1 "
        "min, workers 2",
    ],
    "track_best.yaml": [
        "donkey-linear() 3@160x120 rgb, split 0:933/933:1173, epochs 15 with patience 3, batch 128, lr 0.001, "
        "mae, throttle weight 1, flips, brightness 1 +- 0.25, hue +-180 deg, at least 3700 samples an epoch, "
        "15 extra recordings",
    ],
    "track_default.yaml": [
        "multimodal-lstm() 3@200x66 gray farneback flow, split 0:3000/3000:3538, epochs 8 with patience 3, batch 32, "
        "lr 0.0003, mae, throttle weight 0.5, 3 extra recordings",
    ],
    "track_pilotnet.yaml": [
        "pilotnet() 1@200x66 gray, split 0:3000/3000:3538, epochs 6 with patience 3, batch 32, lr 0.0003, mae, "
        "throttle weight 0.5, 3 extra recordings",
    ],
    "tune_ch2_selection.yaml": [
        "flow-lstm(dropout=0.5, hidden=100) 5@200x66 yuv farneback flow, split 0:1200/1200:1800, epochs 9 with "
        "patience 9, batch 10, lr 0.0001, mse",
        "tune: train.lr 1e-05..0.003 log, train.batch_size 4..16, model.dropout 0..0.75, model.hidden 32..256 log, "
        "preprocess.flow farneback or dis",
    ],
    "tune_flow_lstm.yaml": [
        "flow-lstm(dropout=0.5, hidden=100) 5@200x66 yuv farneback flow, split 0:1800/1800:2400, epochs 9 with "
        "patience 9, batch 10, lr 0.0001, mse",
        "tune: train.lr 1e-05..0.003 log, train.batch_size 4..16, model.dropout 0..0.75, model.hidden 32..256 log, "
        "preprocess.flow farneback or dis",
    ],
    "tune_multimodal_lstm.yaml": [
        "multimodal-lstm(dropout=0.5, hidden=100) 3@200x66 gray farneback flow, split 0:1800/1800:2400, epochs 9 "
        "with patience 9, batch 10, lr 0.0001, mse",
        "tune: train.lr 1e-06..0.001 log, train.batch_size 4..10, model.dropout 0..0.75, model.hidden 64..512 log",
    ],
    "tune_pruning_sim.yaml": [
        "pilotnet(dropout=0.5) 1@200x66 gray, split 0:700/700:900, epochs 27 with patience 27, batch 32, lr 0.0001, "
        "mse",
        "tune: train.lr 1e-05..0.003 log, train.batch_size 8..64 log, model.dropout 0..0.75",
    ],
}


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
        (t.views, "views " + " ".join(f"{x:+g} m {y:+g} deg" for x, y in t.views)),
        (t.recovery_distance_m, f"returning within {t.recovery_distance_m or 0:g} m"),
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
    """A parsed value as YAML writes it: tuples as lists."""
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
               off_track=139.3, pace=0.997, pace_tracks=3, each=[])
    names = ("mae-throttle-2", "donkeycar-rooms", "donkeycar-rooms-throttle-2")
    lines = recipes.markdown([dict(row, recipe=name) for name in names], "t1").splitlines()[-3:]
    assert [line.split(" | ")[1] for line in lines] == [
        recipes.RECIPES["mae-throttle-2"].what, "donkeycar's own trainer and part, on the tubs of rooms",
        "donkeycar's own trainer and part, on the tubs of rooms, its throttle times 2 before the cap"]
    assert lines[0].endswith("| 0.5 | 3 | 55.0 | 61.0 | 4.7 of 8 | 2.45 | 139.3 | 0.997 (3) |")
