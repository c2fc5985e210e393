"""What the tests of the Pilot and its exports give it: an untrained checkpoint of any model (`untrained`) and
frames that move (`frames`). The tests of the track world's races use them too."""

import numpy as np
import torch

from conftest import CH2
from steerlab.checkpoint import save_checkpoint
from steerlab.data.preprocess import PreprocessOptions
from steerlab.data.readers import open_recording
from steerlab.data.recording import SteeringConvention
from steerlab.models import create_model
from steerlab.models.registry import ModelSpec


def untrained(tmp_path, name: str, geometry: str = "ch2", size: dict | None = None):
    """A checkpoint of `name` with random weights and non-trivial standardisation statistics (input `size`:
    {width, height}, default the geometry's)."""
    pre = ModelSpec(name, {}).preprocess(PreprocessOptions(preset=geometry, **(size or {}))).resolve()
    c = sum(pre.channels().values())
    model_cfg = {"in_channels": c, "height": pre.height, "width": pre.width}
    torch.manual_seed(0)
    model = create_model(name, **model_cfg)
    path = tmp_path / f"{name}.pt"
    save_checkpoint(path, model, model_cfg, pre, {"mean": [100.0] * c, "std": [50.0] * c},
                    SteeringConvention(), {"rmse": 0.1}, geometry=geometry, frame_rate=20.0)
    return path


def frames(n: int) -> list[np.ndarray]:
    """Real CH2 frames when ../shared is there, else textured frames that move."""
    if (CH2 / "CH2_final_evaluation.csv").exists():
        rec = open_recording(CH2, f"0:{n}", CH2 / "CH2_final_evaluation.csv")
        return [rec.load_frame(i) for i in range(n)]
    rng = np.random.default_rng(0)
    base = rng.integers(0, 255, (480, 700, 3), dtype=np.uint8)
    return [np.ascontiguousarray(base[:, 3 * i: 3 * i + 640]) for i in range(n)]
