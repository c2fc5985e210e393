"""int8 ONNX export: static quantization calibrated on a recording's frames, the same metadata and sha256 check."""

import numpy as np
import onnx
import pytest

from conftest import flip_bytes
from steerlab.cli import main
from steerlab.data.readers import open_recording
from steerlab.errors import SteerlabError
from steerlab.export import export_onnx
from steerlab.runtime import read_metadata
from steerlab.pilot import Pilot


def test_int8_export_drives_like_fp32(tmp_path, tiny_checkpoint, tiny_recording):
    fp32 = export_onnx(tiny_checkpoint, tmp_path / "m.onnx")
    int8 = tmp_path / "m-int8.onnx"
    assert main(["export", str(tiny_checkpoint), "--out", str(int8), "--int8", "--calib", str(tiny_recording),
                 "--calib-range", "0:240"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m-int8.onnx", "m.onnx"]  # nothing else left behind
    assert int8.stat().st_size < 0.3 * fp32.stat().st_size
    meta, meta32 = read_metadata(int8)[0], read_metadata(fp32)[0]
    assert meta.pop("int8") == {"calibration": str(tiny_recording), "range": "0:240", "frames": 240}
    assert meta == meta32
    ops = {n.op_type for n in onnx.load(int8).graph.node}
    assert {"QuantizeLinear", "DequantizeLinear"} <= ops

    rec = open_recording(tiny_recording, "240:300")  # the validation frames: not calibrated on
    a, b = Pilot(fp32), Pilot(int8)
    steering = np.array([(a.step(rec.load_frame(i)).steering, b.step(rec.load_frame(i)).steering)
                         for i in range(len(rec))])
    error = np.abs(steering[:, 0] - steering[:, 1])
    assert error.max() < 2e-3  # radians; about 4e-4 measured

    flip_bytes(int8)
    with pytest.raises(SteerlabError, match=r"m-int8.onnx: the model does not match the sha256 in its metadata"):
        Pilot(int8)


def test_int8_recurrent_model_keeps_its_lstm_in_fp32(tmp_path, tiny_recording):
    from test_export_serve import untrained

    path = export_onnx(untrained(tmp_path, "lstm", "sim"), tmp_path / "m.onnx", tiny_recording)
    assert read_metadata(path)[0]["int8"] == {"calibration": str(tiny_recording), "range": "0:300", "frames": 300}
    nodes = onnx.load(path).graph.node
    dequantized = {n.output[0] for n in nodes if n.op_type == "DequantizeLinear"}
    lstm = [n for n in nodes if n.op_type == "LSTM"]
    assert lstm and not dequantized & set(lstm[0].input) and any(n.op_type == "Conv" for n in nodes)
    frame = open_recording(tiny_recording, "0:1").load_frame(0)
    assert np.isfinite(Pilot(path).step(frame).steering)


def test_int8_refuses_a_model_with_nothing_to_quantize(tmp_path, tiny_recording):
    from test_export_serve import untrained

    with pytest.raises(SteerlabError, match="the model has no convolution or matrix product to quantize"):
        export_onnx(untrained(tmp_path, "zero", "sim"), tmp_path / "m.onnx", tiny_recording)
    assert not list(tmp_path.glob("*.onnx*"))
