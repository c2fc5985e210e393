"""Run inside donkeycar's own environment (never imported by steerlab): donkeycar's pilot part for a model
trained by `donkey train`, behind a pipe. After a line "ready", each frame read from stdin (IMAGE_H x IMAGE_W x 3
uint8 RGB, as a donkeycar camera delivers it) is answered on stdout with the part's (angle, throttle) as two
float64.

python _donkey_part.py CONFIG.py MODEL TYPE
"""

import os
import sys

ANSWERS = os.fdopen(os.dup(1), "wb")
os.dup2(2, 1)  # whatever donkeycar (its banner on import) and TensorFlow print goes to stderr, not into the answers

import numpy as np  # noqa: E402
from donkeycar.config import load_config  # noqa: E402
from donkeycar.utils import get_model_by_type  # noqa: E402


def main() -> None:
    config_path, model_path, model_type = sys.argv[1:4]
    answers = ANSWERS
    cfg = load_config(config_path)
    part = get_model_by_type(model_type, cfg)
    part.load(model_path)
    size = cfg.IMAGE_H * cfg.IMAGE_W * cfg.IMAGE_DEPTH
    frames = sys.stdin.buffer
    answers.write(b"ready\n")
    answers.flush()
    while len(frame := frames.read(size)) == size:
        angle, throttle = part.run(np.frombuffer(frame, np.uint8).reshape(cfg.IMAGE_H, cfg.IMAGE_W, cfg.IMAGE_DEPTH))
        answers.write(np.array([angle, throttle], np.float64).tobytes())
        answers.flush()


if __name__ == "__main__":
    main()
