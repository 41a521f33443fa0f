"""Formation error metrics (Liang et al. 2012, eqs 42-43) and run summaries.

Principal angles and relative attitudes are evaluated with the generated MRP
functions (``mrp_principal_angle``, ``mrp_error``), mapped over the samples by
CasADi (through NumPy buffers, :func:`fsmctl.casadi_eval.evaluate_mapped`), so no
MRP formula is re-typed here.
"""

from __future__ import annotations

import numpy as np

from .casadi_eval import evaluate_mapped
from .generated_code import casadi_function

__all__ = [
    "principal_angles",
    "relative_principal_angles",
    "aaem_deg",
    "raem_deg",
    "settling_time",
    "steady_state_max",
]


def principal_angles(sigma: np.ndarray) -> np.ndarray:
    """``theta = 4 atan|sigma|`` (eq 2) for an array ``(..., 3)`` of MRPs; returns ``(...)`` in rad."""
    sigma = np.asarray(sigma, dtype=float)
    flat = sigma.reshape(-1, 3)
    if flat.shape[0] == 0:
        return np.zeros(sigma.shape[:-1])
    (theta,) = evaluate_mapped(casadi_function("mrp_principal_angle"), flat.shape[0], [flat])  # (m, 1)
    return theta.reshape(sigma.shape[:-1])


def relative_principal_angles(sigma_e: np.ndarray) -> np.ndarray:
    """Principal angle between every pair of agents: ``(T, n, 3) -> (T, n, n)`` rad.

    The relative attitude of i with respect to j is ``sigma_ei (x) sigma_ej^-1``
    (equal to ``sigma_i (x) sigma_j^-1``: the reference cancels).
    """
    sigma_e = np.asarray(sigma_e, dtype=float)
    T, n, _ = sigma_e.shape
    out = np.zeros((T, n, n))
    iu, ju = np.triu_indices(n, k=1)
    if iu.size == 0 or T == 0:
        return out
    # theta_ij = theta_ji (the inverse rotation has the same angle): evaluate each unordered pair once
    a = sigma_e[:, iu, :].reshape(-1, 3)
    b = sigma_e[:, ju, :].reshape(-1, 3)
    (rel,) = evaluate_mapped(casadi_function("mrp_error"), a.shape[0], [a, b])  # (T * pairs, 3)
    theta = principal_angles(rel).reshape(T, iu.size)
    out[:, iu, ju] = theta
    out[:, ju, iu] = theta
    return out


def aaem_deg(theta_e: np.ndarray) -> np.ndarray:
    """Absolute attitude error metric (eq 42): ``(180/pi) sqrt(mean_i theta_ei^2)``; ``(T, n) -> (T,)``."""
    return np.degrees(np.sqrt(np.mean(np.square(theta_e), axis=-1)))


def raem_deg(theta_ij: np.ndarray) -> np.ndarray:
    """Relative attitude error metric (eq 43): ``(180/pi) sqrt(sum_{i != j} theta_ij^2 / (n (n-1)))``.

    For the paper's n = 6 the divisor is 30, as printed.
    """
    n = theta_ij.shape[-1]
    if n < 2:
        return np.zeros(theta_ij.shape[:-2])
    return np.degrees(np.sqrt(np.sum(np.square(theta_ij), axis=(-2, -1)) / (n * (n - 1))))


def settling_time(time: np.ndarray, metric: np.ndarray, tolerance: float) -> float:
    """First time after which ``metric`` stays at or below ``tolerance`` (NaN if it never settles).

    A NaN sample counts as not settled.
    """
    above = np.nonzero(~(np.asarray(metric) <= tolerance))[0]
    if above.size == 0:
        return float(time[0])
    last = above[-1]
    return float(time[last + 1]) if last + 1 < len(time) else float("nan")


def steady_state_max(time: np.ndarray, metric: np.ndarray, window: float) -> float:
    """``max metric`` over the final ``window`` seconds."""
    time = np.asarray(time)
    return float(np.max(np.asarray(metric)[time >= time[-1] - window - 1e-12]))
