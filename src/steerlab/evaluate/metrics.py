"""Steering metrics. Angles come in radians; MAE and gamma are reported in degrees as the papers do.

Recordings with normalized steering (donkeycar's [-1, 1]) pass their own `deg_per_unit` (the full-lock angle,
NaN when unknown); `mae` is always in the recording's own unit."""

from __future__ import annotations

import math

import numpy as np

DEG = math.degrees(1.0)


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


def exponential_smoothing(series, alpha: float = 0.2) -> np.ndarray:
    """s_t = alpha * y_t + (1 - alpha) * s_{t-1}, s_0 = y_0 (paper 002 Eq. 2)."""
    y = np.asarray(series, float)
    out = np.empty_like(y)
    s = y[0] if len(y) else 0.0
    for i, v in enumerate(y):
        s = alpha * v + (1 - alpha) * s
        out[i] = s
    return out


def steering_metrics(pred, target, deg_per_unit: float = DEG) -> dict[str, float]:
    """MSE, RMSE and MAE in the steering's unit (rad), MAE (deg), gamma of prediction and of target (deg)."""
    return {"mse": mse(pred, target), "rmse": rmse(pred, target), "mae": mae(pred, target),
            "mae_deg": mae_deg(pred, target, deg_per_unit), "gamma_deg": gamma_deg(pred, deg_per_unit),
            "target_gamma_deg": gamma_deg(target, deg_per_unit), "frames": int(len(target))}


def speed_mae(pred, target) -> float:
    """Mean absolute error of predicted speeds, m/s (paper 002 Table II)."""
    return float(np.mean(np.abs(np.asarray(pred, float) - np.asarray(target, float))))


def accuracy(pred, target) -> float:
    """Fraction of frames whose predicted class is the labelled one (speed commands, paper 002 V-B)."""
    return float(np.mean(np.asarray(pred) == np.asarray(target)))


def all_metrics(pred: dict, truth: dict, deg_per_unit: float = DEG) -> dict[str, float]:
    """Steering metrics, plus speed MAE and speed-command accuracy for models that predict them."""
    m = steering_metrics(pred["steering"], truth["steering"], deg_per_unit)
    if "speed" in pred:
        m["speed_mae"] = speed_mae(pred["speed"], truth["speed"])
    if "command" in pred:
        m["command_accuracy"] = accuracy(pred["command"], truth["command"])
    return m
