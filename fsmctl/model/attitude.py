"""Quaternions and MRPs: the conversions between the plug-in's quaternion states and the model's MRPs.

Used by the python-control plug-in (:mod:`fsmctl.plugin.iosys`, quaternion plant states) and by
:meth:`fsmctl.simulation.result.SimulationResult.to_time_response`; written once, here, in CasADi.
"""

from __future__ import annotations

import functools
from typing import Any

import casadi as ca
import numpy as np

__all__ = ["quaternion_from_mrp", "mrp_from_quaternion"]

# The three formulas below are the only place they are written; tests check them against
# scipy.spatial.transform.Rotation and against the MRP kinematics of eq 3.


def quaternion_rate_expression(q, omega, gain: float):
    """``q_dot = 1/2 B(q) omega + gain (1 - q.q) q`` (Schaub & Junkins eq 3.104 plus drift control), in CasADi.

    ``B(q) omega = (-q_v . omega, q0 omega + q_v x omega)`` with the body rate ``omega`` in B.  The drift term
    is radial: it leaves ``q / |q|`` (the attitude) unchanged and drives ``|q|`` to 1 at the rate ``2 gain``.
    The plug-in's quaternion plants (:mod:`fsmctl.plugin.iosys`, :mod:`fsmctl.plugin.hardware`) are built on it.

    Parameters
    ----------
    q : casadi.SX or casadi.MX, shape (4,)
        Euler parameters, scalar first.
    omega : casadi.SX or casadi.MX, shape (3,)
        Body rate (rad/s).
    gain : float
        Drift-control gain (1/s).

    Returns
    -------
    casadi.SX or casadi.MX, shape (4,)

    Examples
    --------
    >>> import casadi as ca
    >>> float(quaternion_rate_expression(ca.DM([1, 0, 0, 0]), ca.DM([0, 0, 2]), 1.0)[3])
    1.0
    """
    q0, qv = q[0], q[1:4]
    rate = 0.5 * ca.vertcat(-ca.dot(qv, omega), q0 * omega + ca.cross(qv, omega))
    return rate + gain * (1 - ca.dot(q, q)) * q


def mrp_of_quaternion_expression(q):
    """The MRP of ``q / |q|`` in the shadow set: ``sign(q0) q_v / (|q| + |q0|)`` (``|sigma| <= 1``, no cancellation).

    ``q0 >= 0`` gives ``q_v / (1 + q0)`` (the principal rotation, ``phi <= 180 deg``); ``q0 < 0`` gives the shadow
    MRP ``-q_v / (1 - q0)`` of the same attitude.  The CasADi expression behind :func:`mrp_from_quaternion`.

    Parameters
    ----------
    q : casadi.SX or casadi.MX, shape (4,)
        Euler parameters of any non-zero norm, scalar first.

    Returns
    -------
    casadi.SX or casadi.MX, shape (3,)

    Examples
    --------
    >>> import casadi as ca
    >>> mrp_of_quaternion_expression(ca.DM([0, 0, 0, 2])).full().ravel().tolist()
    [0.0, 0.0, 1.0]
    """
    q0, qv = q[0], q[1:4]
    sign = ca.if_else(q0 < 0, -1, 1)
    return sign * qv / (ca.norm_2(q) + ca.fabs(q0))


def _quaternion_of_mrp(sigma):
    """Euler parameters of an MRP: ``((1 - s^2), 2 sigma) / (1 + s^2)`` with ``s^2 = sigma.sigma`` (``q0 >= 0`` iff ``|sigma| <= 1``)."""
    s2 = ca.dot(sigma, sigma)
    return ca.vertcat(1 - s2, 2 * sigma) / (1 + s2)


@functools.cache
def _conversion(kind: str) -> ca.Function:
    if kind == "mrp":
        q = ca.SX.sym("q", 4)
        return ca.Function("mrp_of_quaternion", [q], [mrp_of_quaternion_expression(q)])
    sigma = ca.SX.sym("sigma", 3)
    return ca.Function("quaternion_of_mrp", [sigma], [_quaternion_of_mrp(sigma)])


def _map_rows(fn: ca.Function, x: Any, n_in: int, n_out: int, what: str) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.ndim == 0 or a.shape[-1] != n_in:
        raise ValueError(f"expected {what} with a last axis of length {n_in}, got shape {a.shape}")
    flat = a.reshape(-1, n_in)
    if flat.shape[0] == 0:
        return np.zeros((*a.shape[:-1], n_out))
    out = np.asarray(fn.map(flat.shape[0])(flat.T)).reshape(n_out, -1)
    return out.T.reshape(*a.shape[:-1], n_out)


def quaternion_from_mrp(sigma) -> np.ndarray:
    """Euler parameters (scalar first) of MRPs.

    Parameters
    ----------
    sigma : array_like, shape (..., 3)
        MRPs of the rotation from N to B (any magnitude; ``|sigma| <= 1`` gives ``q0 >= 0``).

    Returns
    -------
    numpy.ndarray, shape (..., 4)
        Unit quaternions ``(q0, q1, q2, q3)``.

    Examples
    --------
    >>> from fsmctl.model.attitude import quaternion_from_mrp
    >>> quaternion_from_mrp([0.0, 0.0, 1.0]).round(12).tolist()  # 180 deg about z
    [0.0, 0.0, 0.0, 1.0]
    """
    return _map_rows(_conversion("quaternion"), sigma, 3, 4, "MRPs")


def mrp_from_quaternion(q) -> np.ndarray:
    """MRPs in the shadow set (``|sigma| <= 1``) of quaternions of any non-zero norm.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Euler parameters ``(q0, q1, q2, q3)``, scalar first; ``q`` and ``c q`` (``c != 0``) are one attitude.

    Returns
    -------
    numpy.ndarray, shape (..., 3)

    Examples
    --------
    >>> from fsmctl.model.attitude import mrp_from_quaternion
    >>> (mrp_from_quaternion([-0.6, 0.0, 0.0, 0.8]).round(12) + 0.0).tolist()  # 254 deg about z = -106 deg
    [0.0, 0.0, -0.5]
    """
    return _map_rows(_conversion("mrp"), q, 4, 3, "quaternions")
