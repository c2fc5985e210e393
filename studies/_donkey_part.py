"""Run inside donkeycar's own environment (never imported by steerlab): donkeycar's pilot part behind a pipe. After
a line "ready", each frame read from stdin (H x W x 3 uint8 RGB, as a donkeycar camera delivers it) is answered on
stdout with the part's (angle, throttle) as two float64.

python _donkey_part.py CONFIG.py MODEL TYPE
    a model trained by `donkey train` (TYPE linear, rnn, ...); frames of the config's IMAGE_H x IMAGE_W
python _donkey_part.py CONFIG.py RULE.json cv [LOW,HIGH] W H
    the `cv_control` template's line follower (donkeycar.parts.line_follower.LineFollower and its PID, the
    template's config): its COLOR_THRESHOLD_LOW/HIGH the HSV triples [LOW,HIGH] (JSON; RULE.json, the rule they
    were set by, is only named), frames of W x H resized to the config's camera size; its PID's clock is the vehicle
    loop's (DRIVE_LOOP_HZ), one tick a frame
"""

import json
import os
import sys

ANSWERS = os.fdopen(os.dup(1), "wb")
os.dup2(2, 1)  # whatever donkeycar (its banner on import) and TensorFlow print goes to stderr, not into the answers

import numpy as np  # noqa: E402
from donkeycar.config import load_config  # noqa: E402


def model_part(cfg, model_path: str, model_type: str):
    from donkeycar.utils import get_model_by_type

    part = get_model_by_type(model_type, cfg)
    part.load(model_path)
    shape = (cfg.IMAGE_H, cfg.IMAGE_W, cfg.IMAGE_DEPTH)
    return shape, lambda img: part.run(img)


def line_follower(cfg, thresholds: str, width: int, height: int):
    import cv2
    from donkeycar.parts.line_follower import LineFollower
    from simple_pid import PID

    low, high = json.loads(thresholds)
    cfg.COLOR_THRESHOLD_LOW, cfg.COLOR_THRESHOLD_HIGH, cfg.OVERLAY_IMAGE = tuple(low), tuple(high), False
    ticks = [0]
    pid = PID(Kp=cfg.PID_P, Ki=cfg.PID_I, Kd=cfg.PID_D, time_fn=lambda: ticks[0] / cfg.DRIVE_LOOP_HZ)
    part = LineFollower(pid, cfg)

    def run(img):
        ticks[0] += 1
        steering, throttle, _ = part.run(cv2.resize(img, (cfg.IMAGE_W, cfg.IMAGE_H), interpolation=cv2.INTER_LINEAR))
        return steering, throttle

    return (height, width, 3), run


def main() -> None:
    config_path, model_path, model_type = sys.argv[1:4]
    answers = ANSWERS
    cfg = load_config(config_path)
    if model_type == "cv":
        shape, run = line_follower(cfg, sys.argv[4], int(sys.argv[5]), int(sys.argv[6]))
    else:
        shape, run = model_part(cfg, model_path, model_type)
    size = int(np.prod(shape))
    frames = sys.stdin.buffer
    answers.write(b"ready\n")
    answers.flush()
    while len(frame := frames.read(size)) == size:
        angle, throttle = run(np.frombuffer(frame, np.uint8).reshape(shape))
        answers.write(np.array([angle, throttle], np.float64).tobytes())
        answers.flush()


if __name__ == "__main__":
    main()
