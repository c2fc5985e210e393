"""Pilot.stream: the pipelined Pilot gives exactly the controls of Pilot.step, frame by frame."""

import cv2
import pytest

from steerlab.errors import SteerlabError
from steerlab.export import export_onnx
from steerlab.pilot import Pilot
from tests.pilot.samples import frames, untrained


@pytest.mark.parametrize("name, runtime", [("pilotnet-flow", "pt"), ("multimodal-lstm", "pt"),
                                           ("multimodal-lstm", "onnx"), ("multitask-speed", "pt")])
def test_stream_equals_step(tmp_path, name, runtime):
    """A flow model, a recurrent flow model on both runtimes and a speed-history model, over two segments:
    stream() from JPEG bytes and from frame indices with a loader equals step() exactly."""
    model = untrained(tmp_path, name)
    if runtime == "onnx":
        model = export_onnx(model, tmp_path / "m.onnx")
    bgr = frames(12)
    jpegs = [cv2.imencode(".jpg", f)[1].tobytes() for f in bgr]
    speeds = [10.0 + i for i in range(12)]
    segments = [(0, 8), (8, 12)]
    stepped, streamed, loaded = Pilot(model, smoothing=0.2), Pilot(model, smoothing=0.2), Pilot(model, smoothing=0.2)
    want, got, got_loaded = [], [], []
    for a, b in segments:
        for p in (stepped, streamed, loaded):
            p.reset()
        want += [stepped.step(jpegs[i], speeds[i]) for i in range(a, b)]
        got += streamed.stream(jpegs[a:b], speeds[a:b])
        got_loaded += loaded.stream(range(a, b), speeds[a:b], load=lambda i: cv2.imdecode(
            cv2.imencode(".jpg", bgr[i])[1], cv2.IMREAD_COLOR))
    assert got == want and got_loaded == want
    assert len({c.steering for c in want}) > 1  # the frames differ, so equality says something


def test_stream_errors(tmp_path):
    pilot = Pilot(untrained(tmp_path, "multitask-speed"))
    with pytest.raises(SteerlabError, match="cannot decode a frame of 3 bytes"):
        list(pilot.stream([b"abc"], [1.0]))
    with pytest.raises(SteerlabError, match="needs the measured speed"):
        list(pilot.stream(frames(2)))
    with pytest.raises(SteerlabError, match=r"more frames than speeds \(1 speed\): give one speed a frame"):
        list(pilot.stream(frames(2), [1.0]))
