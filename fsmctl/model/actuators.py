"""Reaction-wheel torque distribution: from the law's body torque to wheel motor torques.

The rule (applied at every control instant by the compiled loop, ``fsmctl/csrc/formation.c``,
``wheel_commands``; this NumPy transcription is held equal to it by ``tests/test_wheels.py``):

1. minimum-norm distribution ``u_w* = -P u`` with ``P = pinv(G_s)`` (``G_s``: the ``3 x N`` spin axes),
   so that the wheels' reaction on the hub, ``-G_s u_w*``, is the commanded body torque ``u``;
2. direction-preserving saturation: with ``r = max_i |u_w*_i| / max_torque_i``, every wheel torque is
   divided by ``max(1, r)``: the body torque keeps its direction and the most loaded wheel sits at its
   limit (clipping wheels one by one would turn the torque away from the command).

Between control instants the wheel commands are held; the speed limit and friction act continuously
(:func:`fsmctl.symbolic.hardware.wheel_motor_torque`).
"""

from __future__ import annotations

import numpy as np

from fsmctl.errors import InputError

__all__ = [
    "distribution_matrix",
    "distribute",
    "body_torque_capacity",
    "max_body_torque",
    "spin_inertia_matrix",
    "hub_inertia_problem",
]


def spin_inertia_matrix(axes: np.ndarray, spin_inertia: np.ndarray) -> np.ndarray:
    """``J_spin = sum_k J_s,k g_k g_k^T`` (3, 3): the wheels' spin part of the spacecraft inertia.

    Parameters
    ----------
    axes : numpy.ndarray
        ``(3, N)`` unit spin axes ``g_k`` of the ``N`` wheels (body frame), ``G_s``.
    spin_inertia : numpy.ndarray
        ``(N,)`` spin inertias ``J_s,k`` (kg m^2).

    Returns
    -------
    numpy.ndarray
        ``(3, 3)`` symmetric matrix (kg m^2).

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.model import spin_inertia_matrix
    >>> spin_inertia_matrix(np.eye(3), np.array([1.0, 2.0, 3.0])).diagonal().tolist()
    [1.0, 2.0, 3.0]
    """
    G = np.asarray(axes, dtype=float)
    return (G * np.asarray(spin_inertia, dtype=float)) @ G.T


def hub_inertia_problem(J: np.ndarray, J_spin: np.ndarray) -> str | None:
    """Why ``J - J_spin`` is not a rigid hub's inertia (not positive definite; the wheels' spin inertia exceeds the
    spacecraft's), or None.

    ``J`` is the whole spacecraft's inertia, wheels included; the gyrostat (:mod:`fsmctl.symbolic.hardware`) solves
    ``(J - J_spin) omega_dot = ...``, which describes no body when the wheels' spin inertia exceeds the spacecraft's.

    Parameters
    ----------
    J : numpy.ndarray
        ``(3, 3)`` inertia of the whole spacecraft (kg m^2).
    J_spin : numpy.ndarray
        ``(3, 3)`` spin inertia of the wheels (:func:`spin_inertia_matrix`).

    Returns
    -------
    str or None
        The problem, with the eigenvalues of ``J - J_spin``, or None when the hub inertia is positive definite.

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.model.actuators import hub_inertia_problem
    >>> hub_inertia_problem(np.eye(3), 0.1 * np.eye(3)) is None
    True
    >>> hub_inertia_problem(np.eye(3), 2.0 * np.eye(3))[:48]
    'the hub inertia J - J_spin (J_spin = sum J_s g g'
    """
    hub = np.asarray(J, dtype=float) - np.asarray(J_spin, dtype=float)
    eig = np.linalg.eigvalsh(0.5 * (hub + hub.T))
    if eig[0] > 1e-9 * abs(eig[-1]):
        return None
    return (
        f"the hub inertia J - J_spin (J_spin = sum J_s g g^T) is not positive definite, eigenvalues "
        f"{np.round(eig, 6).tolist()} kg m^2 (J is the whole spacecraft, wheels included)"
    )


def distribution_matrix(axes: np.ndarray) -> np.ndarray:
    """``(N, 3)`` minimum-norm distribution matrix ``P = pinv(G_s)`` of the ``(3, N)`` unit spin axes.

    Parameters
    ----------
    axes : numpy.ndarray
        ``(3, N)`` spin axes ``G_s``, of rank 3 (the wheels must span the body frame).

    Returns
    -------
    numpy.ndarray
        ``(N, 3)`` Moore-Penrose pseudo-inverse, so that ``G_s P = I``.

    Raises
    ------
    InputError
        ``axes`` is not a ``3 x N`` matrix of rank 3 (a ``ValueError``).

    Examples
    --------
    Four wheels, three on the body axes and one skewed:

    >>> import numpy as np
    >>> from fsmctl.model import distribution_matrix
    >>> G = np.hstack([np.eye(3), np.ones((3, 1)) / np.sqrt(3)])
    >>> P = distribution_matrix(G)
    >>> P.shape, np.allclose(G @ P, np.eye(3))
    ((4, 3), True)
    """
    G = np.asarray(axes, dtype=float)
    if G.ndim != 2 or G.shape[0] != 3 or np.linalg.matrix_rank(G) < 3:
        raise InputError(f"axes: expected a 3 x N matrix of rank 3, got shape {G.shape}")
    return np.linalg.pinv(G)


def distribute(u_body: np.ndarray, pinv: np.ndarray, max_torque: np.ndarray) -> tuple[np.ndarray, float]:
    """Wheel motor torques ``(N,)`` for the body torque ``u_body`` (3,), and the scale factor ``max(1, r)``.

    The module's rule: ``u_w* = -P u`` (minimum norm), then divided by ``max(1, r)``,
    ``r = max_i |u_w*_i| / max_torque_i`` (the direction of the body torque is kept).

    Parameters
    ----------
    u_body : numpy.ndarray
        ``(3,)`` body torque the law commands (N m).
    pinv : numpy.ndarray
        ``(N, 3)`` distribution matrix (:func:`distribution_matrix`).
    max_torque : numpy.ndarray
        ``(N,)`` motor torque limit of each wheel (N m).

    Returns
    -------
    u_w : numpy.ndarray
        ``(N,)`` wheel motor torques (N m); their reaction on the hub is ``-G_s u_w``.
    scale : float
        ``max(1, r)``: 1 when no wheel saturates.

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.model import distribute, distribution_matrix
    >>> u_w, scale = distribute(np.array([0.3, 0.0, 0.0]), distribution_matrix(np.eye(3)), np.full(3, 0.2))
    >>> u_w.tolist(), scale
    ([-0.2, -0.0, -0.0], 1.5)
    """
    pinv = np.asarray(pinv, dtype=float)
    u_w = np.empty(pinv.shape[0])
    u = np.asarray(u_body, dtype=float)
    for i in range(pinv.shape[0]):  # the C loop's order of operations, so that the results are bit-identical
        u_w[i] = -(pinv[i, 0] * u[0] + pinv[i, 1] * u[1] + pinv[i, 2] * u[2])
    r = 0.0
    for i in range(u_w.size):
        r = max(r, abs(u_w[i]) / max_torque[i])
    scale = max(1.0, r)
    return (u_w / scale if scale > 1.0 else u_w), scale


def body_torque_capacity(axes: np.ndarray, max_torque: np.ndarray, directions: int = 2000, seed: int = 0) -> dict:
    """The body torque the distribution rule delivers at saturation, over random unit directions.

    An input to the choice of a ``controller.torque_limit`` that the wheels can honour.

    Parameters
    ----------
    axes : numpy.ndarray
        ``(3, N)`` spin axes ``G_s``.
    max_torque : numpy.ndarray
        ``(N,)`` motor torque limits (N m).
    directions : int, optional
        Number of random unit directions (default 2000).
    seed : int, optional
        Seed of the directions (default 0).

    Returns
    -------
    dict
        ``{"min": ..., "max": ..., "per_axis": [x, y, z]}`` in N m: the smallest and largest magnitude over the
        directions and the body axes, and the magnitude along each body axis.

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.model.actuators import body_torque_capacity
    >>> cap = body_torque_capacity(np.eye(3), np.full(3, 0.2), directions=200)
    >>> cap["per_axis"], round(cap["min"], 3)
    ([0.2, 0.2, 0.2], 0.2)
    """
    G = np.asarray(axes, dtype=float)
    P = distribution_matrix(G)
    lim = np.asarray(max_torque, dtype=float)

    def reach(d):
        w = -P @ d
        return 1.0 / np.max(np.abs(w) / lim)

    rng = np.random.default_rng(seed)
    dirs = rng.normal(size=(directions, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    per_axis = [float(reach(e)) for e in np.eye(3)]
    mags = np.array([reach(d) for d in dirs] + per_axis)
    return {"min": float(mags.min()), "max": float(mags.max()), "per_axis": per_axis}


def max_body_torque(axes: np.ndarray, limits: np.ndarray) -> float:
    """The largest body torque (or momentum) magnitude ``max |G_s x|`` over ``|x_k| <= limits_k``, whatever the
    distribution.

    The maximum of a convex function over the box is at a vertex, so the ``2^N`` sign patterns are enumerated
    (N <= 16; beyond, the bound ``sum_k limits_k``).  An upper bound for momentum-budget arguments (a lower bound on
    any manoeuvre time).

    Parameters
    ----------
    axes : numpy.ndarray
        ``(3, N)`` spin axes ``G_s``.
    limits : numpy.ndarray
        ``(N,)`` per-wheel limits (N m for torques, N m s for momenta); an infinite limit gives ``inf``.

    Returns
    -------
    float
        The largest magnitude (N m, or N m s for momentum limits).

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.model import max_body_torque
    >>> round(max_body_torque(np.eye(3), np.full(3, 1.0)), 6)  # sqrt(3)
    1.732051
    """
    G = np.asarray(axes, dtype=float)
    lim = np.asarray(limits, dtype=float)
    n = lim.size
    if not np.all(np.isfinite(lim)):
        return float("inf")
    if n > 16:
        return float(lim.sum())
    signs = ((np.arange(2**n)[:, None] >> np.arange(n)) & 1) * 2.0 - 1.0
    return float(np.max(np.linalg.norm((signs * lim) @ G.T, axis=1)))
