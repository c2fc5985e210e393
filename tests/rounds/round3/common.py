"""The places of the third round's fixtures, as its rows write them, and `_g` (a group's rows)."""

F, W, S = "{fx}", "{work}", "{shared}"
CK, SIM, TUB, CH2, REC = f"{F}/a.pt", f"{F}/sim", f"{F}/tub", f"{F}/ch2", f"{F}/rec"
DK, LANE, TRK = f"{F}/donkey.pt", f"{F}/lane.pt", f"{F}/trk"  # a donkey model, one with a lane head, a track tub
CONFIG, TUBCFG, TRKCFG = f"{F}/c.yaml", f"{F}/tub.yaml", f"{F}/trk.yaml"
WOOD, HALL, TAPED = f"{S}/donkeycar/wood-tape", f"{S}/donkeycar/hall", f"{S}/donkeycar/taped-track"
REAL_CH2, REAL_SIM = f"{S}/udacity-ch2", f"{S}/udacity-sim-track1"
CAL = f"{F}/cal.json"
CALIBRATION = {"image_size": [160, 120], "K": [[81.0, 0.0, 80.0], [0.0, 80.0, 61.0], [0.0, 0.0, 1.0]],
               "D": [-0.02, -0.01, 0.0, 0.005]}


def _g(rows, group):
    for r in rows:
        r["group"] = group
    return rows

