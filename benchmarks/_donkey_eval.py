"""Run inside donkeycar's own environment (never imported by steerlab): predict the steering of the records
listed in a JSON file with a model trained by `donkey train`, in record order, as a car would run it.

python _donkey_eval.py CONFIG.py MODEL TYPE RECORDS.json OUT.json
RECORDS.json: {"images": [paths...], "angles": [...]}; OUT.json gets {"pred": [...], "mae": ...}.
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
    pred = []
    for path in records["images"]:
        angle, _ = model.run(load_image(path, cfg))
        pred.append(float(angle))
    mae = float(np.mean(np.abs(np.array(pred) - np.array(records["angles"]))))
    open(out_path, "w").write(json.dumps({"pred": pred, "mae": mae}))


if __name__ == "__main__":
    main()
