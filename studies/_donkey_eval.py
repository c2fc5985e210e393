"""Run inside donkeycar's own environment (never imported by steerlab): predict the steering and the throttle
of the records listed in a JSON file with a model trained by `donkey train`, in record order, as a car would
run it.

python _donkey_eval.py CONFIG.py MODEL TYPE RECORDS.json OUT.json
RECORDS.json: {"images": [paths...], "angles": [...], "throttles": [...]}; OUT.json gets {"pred": [...],
"mae": ..., "throttle_pred": [...], "throttle_mae": ...}.
"""

import json
import sys

import numpy as np
from donkeycar.config import load_config
from donkeycar.utils import get_model_by_type, load_image


def main() -> None:
    config_path, model_path, model_type, records_path, out_path = sys.argv[1:6]
    cfg = load_config(config_path)
    model = get_model_by_type(model_type, cfg)
    model.load(model_path)
    records = json.loads(open(records_path).read())
    pred, throttle = [], []
    for path in records["images"]:
        angle, t = model.run(load_image(path, cfg))
        pred.append(float(angle))
        throttle.append(float(t))
    mae = float(np.mean(np.abs(np.array(pred) - np.array(records["angles"]))))
    throttle_mae = float(np.mean(np.abs(np.array(throttle) - np.array(records["throttles"]))))
    open(out_path, "w").write(json.dumps({"pred": pred, "mae": mae, "throttle_pred": throttle,
                                          "throttle_mae": throttle_mae}))


if __name__ == "__main__":
    main()
