"""What each config shipped in configs/ builds, in the words of tests/train/test_configs.py: a table, `EXPECTED`,
by config file."""

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
    "donkey_tub.yaml": [
        "donkey-linear() 3@160x120 rgb, split 0:3510/3510:4012, epochs 30 with patience 5, batch 32, lr 0.0003, mae, "
        "throttle weight 0.5, views -0.15..+0.15 m -15..+15 deg, back on the path in 0.3 s",
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
