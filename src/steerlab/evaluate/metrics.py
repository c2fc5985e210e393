"""Steering metrics. Angles come in radians; MAE and gamma are reported in degrees as the papers do.

Recordings with normalized steering (donkeycar's [-1, 1]) pass their own `deg_per_unit` (the full-lock angle,
NaN when unknown); `mae` and `speed_weighted_mae` are always in the recording's own unit, TRE and QCE are fractions
of frames."""

from __future__ import annotations

import math

import numpy as np

from steerlab.errors import SteerlabError

DEG = math.degrees(1.0)
TRE_THRESHOLD = 0.1  # relative error threshold of TRE
QCE_EDGES_DEG = (-1.0, 1.0)  # class edges of QCE, degrees of the measured wheel: one way, straight, the other
SMOOTHING_ALPHA = 0.2  # the exponential smoothing reported beside raw predictions (paper 002 Eq. 2)


def mse(pred, target) -> float:
    return float(np.mean((np.asarray(pred, float) - np.asarray(target, float)) ** 2))


def rmse(pred, target) -> float:
    return float(np.sqrt(mse(pred, target)))


def mae(pred, target) -> float:
    return float(np.mean(np.abs(np.asarray(pred, float) - np.asarray(target, float))))


def mae_deg(pred, target, deg_per_unit: float = DEG) -> float:
    return mae(pred, target) * deg_per_unit


def gamma_deg(series, deg_per_unit: float = DEG) -> float:
    """Smoothness gamma (paper 000 Eq. 2): standard deviation of successive differences, in degrees."""
    y = np.asarray(series, float)
    if len(y) < 2:
        return float("nan")
    return float(np.std(np.diff(y))) * deg_per_unit


def exponential_smoothing(series, alpha: float = SMOOTHING_ALPHA, restarts=()) -> np.ndarray:
    """s_t = alpha * y_t + (1 - alpha) * s_{t-1}, s_0 = y_0 (paper 002 Eq. 2), started afresh at each index in
    `restarts` (a new segment, a gap in the frames), as the streaming Pilot restarts on `reset()`."""
    y = np.asarray(series, float)
    out = np.empty_like(y)
    starts = set(int(r) for r in restarts) | {0}
    s = 0.0
    for i, v in enumerate(y):
        s = v if i in starts else alpha * v + (1 - alpha) * s
        out[i] = s
    return out


def thresholded_relative_error(pred, target, threshold: float = TRE_THRESHOLD) -> float:
    """Thresholded relative error, TRE (Codevilla et al., ECCV 2018, "On offline evaluation of vision-based
    driving models"): the fraction of frames with |pred - target| > threshold * |target|, so a frame whose
    target is 0 counts for any error. Unitless. Default threshold 0.1, the paper's: an error of less than a
    tenth of the angle steered is right."""
    pred, target = np.asarray(pred, float), np.asarray(target, float)
    return float(np.mean(np.abs(pred - target) > threshold * np.abs(target)))


def quantized_classification_error(pred, target, deg_per_unit: float = DEG, edges_deg=QCE_EDGES_DEG) -> float:
    """Quantized classification error, QCE (Codevilla et al. 2018): the fraction of frames whose
    prediction falls in another steering class than the target. Their Q(x, sigma) has three classes, x < -sigma,
    -sigma <= x < sigma and x >= sigma, with sigma in CARLA's normalized steering; here sigma = 1 degree of the
    wheel the recording measures (the hand wheel for CH2 and the road world, the road wheel for simulator
    and donkeycar data), which puts about a fifth (CH2) to a half (road world) of a recording's frames in
    the straight class. Needs the steering in degrees (a tub without `full_lock_deg` has none)."""
    if not np.isfinite(deg_per_unit):
        raise SteerlabError("QCE needs the steering in degrees; this recording's full-lock angle is unknown")
    edges = np.asarray(edges_deg, float) / deg_per_unit
    classes = [np.digitize(np.asarray(y, float), edges) for y in (pred, target)]
    return float(np.mean(classes[0] != classes[1]))


def speed_weighted_mae(pred, target, speed) -> float:
    """Speed-weighted absolute error (Codevilla et al. 2018), the mean of |pred - target| * |v|: the same
    steering error takes the car further off its path at higher speed. Divided here by the mean |v| so that it
    stays in the steering's unit and equals `mae` at constant speed."""
    v = np.abs(np.asarray(speed, float))
    if not v.mean() > 0:
        raise SteerlabError("the speed-weighted MAE needs a moving car; every speed is 0")
    return float(np.mean(np.abs(np.asarray(pred, float) - np.asarray(target, float)) * v) / v.mean())


def steering_metrics(pred, target, deg_per_unit: float = DEG) -> dict[str, float]:
    """MSE, RMSE and MAE in the steering's unit (rad), MAE (deg), gamma of prediction and of target (deg), TRE,
    and QCE when the steering has degrees."""
    m = {"mse": mse(pred, target), "rmse": rmse(pred, target), "mae": mae(pred, target),
         "mae_deg": mae_deg(pred, target, deg_per_unit), "gamma_deg": gamma_deg(pred, deg_per_unit),
         "target_gamma_deg": gamma_deg(target, deg_per_unit), "tre": thresholded_relative_error(pred, target),
         "frames": int(len(target))}
    if np.isfinite(deg_per_unit):
        m["qce"] = quantized_classification_error(pred, target, deg_per_unit)
    return m


def speed_mae(pred, target) -> float:
    """Mean absolute error of predicted speeds, m/s (paper 002 Table II)."""
    return float(np.mean(np.abs(np.asarray(pred, float) - np.asarray(target, float))))


def accuracy(pred, target) -> float:
    """Fraction of frames whose predicted class is the labelled one (speed commands, paper 002 V-B)."""
    return float(np.mean(np.asarray(pred) == np.asarray(target)))


def all_metrics(pred: dict, truth: dict, deg_per_unit: float = DEG) -> dict[str, float]:
    """Steering metrics, the speed-weighted MAE where the recording has speed (weighted by truth["speed"], the
    next frame's speed: one frame's change does not matter to a weight), and speed MAE, speed-command accuracy
    and the throttle's MAE and RMSE (in the recording's throttle unit) and the lane's MAE (of its three values over
    their scales, `data.labels.LANE`) for models that predict them."""
    m = steering_metrics(pred["steering"], truth["steering"], deg_per_unit)
    if "speed" in truth and np.any(truth["speed"]):
        m["speed_weighted_mae"] = speed_weighted_mae(pred["steering"], truth["steering"], truth["speed"])
    if "speed" in pred:
        m["speed_mae"] = speed_mae(pred["speed"], truth["speed"])
    if "command" in pred:
        m["command_accuracy"] = accuracy(pred["command"], truth["command"])
    if "throttle" in pred and "throttle" in truth:
        m["throttle_mae"] = mae(pred["throttle"], truth["throttle"])
        m["throttle_rmse"] = rmse(pred["throttle"], truth["throttle"])
    if "lane" in pred and "lane" in truth:
        m["lane_mae"] = mae(pred["lane"], truth["lane"])
    return m
