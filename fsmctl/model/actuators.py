"""Reaction-wheel commands: from the law's body torque (and open-loop per-wheel commands) to wheel motor torques.

The rules (applied at every control instant by the compiled loop, ``fsmctl/csrc/formation.c``,
``wheel_commands``; this NumPy transcription is held equal to it by ``tests/test_wheels.py``):

1. minimum-norm distribution ``u_w* = -P u`` with ``P = pinv(G_s)`` (``G_s``: the ``3 x N`` spin axes),
   so that the wheels' reaction on the hub, ``-G_s u_w*``, is the commanded body torque ``u``;
2. plus the open-loop motor torque commands of that instant, if any (``actuator.wheel_commands``, or the
   ``wheel_commands`` callable of :func:`fsmctl.simulate`; Basilisk's ``motorTorque`` sign: positive spins the
   wheel up along ``g``);
3. the torque limit, one of :data:`ALLOCATIONS` (``actuator.allocation``):

   * ``"scaled"`` (the default): with ``r = max_i |u_w_i| / max_torque_i``, every wheel torque is divided by
     ``max(1, r)``: the body torque keeps its direction and the most loaded wheel sits at its limit;
   * ``"clipped"`` (Basilisk's ``reactionWheelStateEffector``): each wheel is clipped to
     ``[-max_torque_i, max_torque_i]`` on its own (the body torque turns away from the command when a wheel
     saturates).

Between control instants the wheel commands are held; the speed limit and friction
(:func:`fsmctl.symbolic.hardware.wheel_speed_gate`, :func:`~fsmctl.symbolic.hardware.wheel_friction`) act on the
held commands, the speed limit decided as :data:`SPEED_GATES` says (``actuator.speed_gate``).
"""

from __future__ import annotations

import numpy as np

from fsmctl.errors import InputError

ALLOCATIONS: dict[str, str] = {
    "scaled": "every wheel divided by one factor when one would exceed its max_torque (the body torque keeps its "
    "direction)",
    "clipped": "each wheel clipped to +-max_torque on its own (Basilisk's rule)",
}
"""The torque-limit rules of the reaction wheels (``actuator.allocation``), the default first."""

SPEED_GATES: dict[str, str] = {
    "continuous": "the speed limit evaluated at every evaluation of the dynamics (every RK4 stage)",
    "step_start": "the speed limit decided from the speeds at the start of each integrator step and held over the "
    "step (Basilisk's timing)",
}
"""When the wheels' speed limit is decided (``actuator.speed_gate``), the default first."""

__all__ = [
    "ALLOCATIONS",
    "SPEED_GATES",
    "distribution_matrix",
    "sample_wheel_commands",
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


def distribute(
    u_body: np.ndarray,
    pinv: np.ndarray,
    max_torque: np.ndarray,
    command: np.ndarray | None = None,
    allocation: str = "scaled",
) -> tuple[np.ndarray, float]:
    """Wheel motor torques ``(N,)`` for the body torque ``u_body`` (3,), and the load factor ``max(1, r)``.

    The module's rules: ``u_w = -P u`` (minimum norm), plus ``command`` (open-loop motor torques), then the
    torque limit ``allocation``: ``"scaled"`` divides every torque by ``max(1, r)``,
    ``r = max_i |u_w_i| / max_torque_i`` (the direction of the body torque is kept); ``"clipped"`` clips each
    torque to ``[-max_torque_i, max_torque_i]``.

    Parameters
    ----------
    u_body : numpy.ndarray
        ``(3,)`` body torque the law commands (N m).
    pinv : numpy.ndarray
        ``(N, 3)`` distribution matrix (:func:`distribution_matrix`).
    max_torque : numpy.ndarray
        ``(N,)`` motor torque limit of each wheel (N m).
    command : numpy.ndarray, optional
        ``(N,)`` open-loop motor torques added before the limit (N m; positive spins the wheel up along its axis).
    allocation : {"scaled", "clipped"}
        The torque-limit rule (:data:`ALLOCATIONS`).

    Returns
    -------
    u_w : numpy.ndarray
        ``(N,)`` wheel motor torques (N m); their reaction on the hub is ``-G_s u_w``.
    scale : float
        ``max(1, r)`` before the limit: 1 when no wheel saturates (under either rule).

    Raises
    ------
    InputError
        ``allocation`` is not one of :data:`ALLOCATIONS`.

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.model import distribute, distribution_matrix
    >>> P = distribution_matrix(np.eye(3))
    >>> u_w, scale = distribute(np.array([0.3, 0.1, 0.0]), P, np.full(3, 0.2))
    >>> u_w.round(6).tolist(), scale
    ([-0.2, -0.066667, -0.0], 1.5)
    >>> distribute(np.array([0.3, 0.1, 0.0]), P, np.full(3, 0.2), allocation="clipped")[0].tolist()
    [-0.2, -0.1, -0.0]
    >>> distribute(np.zeros(3), P, np.full(3, 0.2), command=np.array([0.05, 0.0, 0.5]), allocation="clipped")[0].tolist()
    [0.05, 0.0, 0.2]
    """
    if allocation not in ALLOCATIONS:
        raise InputError(f"allocation: expected one of {', '.join(map(repr, ALLOCATIONS))}, got {allocation!r}")
    pinv = np.asarray(pinv, dtype=float)
    lim = np.asarray(max_torque, dtype=float)
    u_w = np.empty(pinv.shape[0])
    u = np.asarray(u_body, dtype=float)
    cmd = None if command is None else np.asarray(command, dtype=float)
    r = 0.0
    for i in range(pinv.shape[0]):  # the C loop's order of operations, so that the results are bit-identical
        u_w[i] = -(pinv[i, 0] * u[0] + pinv[i, 1] * u[1] + pinv[i, 2] * u[2])
        if cmd is not None:
            u_w[i] += cmd[i]
        r = max(r, abs(u_w[i]) / lim[i])
    scale = max(1.0, r)
    if allocation == "clipped":
        for i in range(u_w.size):
            if u_w[i] > lim[i]:
                u_w[i] = lim[i]
            elif u_w[i] < -lim[i]:
                u_w[i] = -lim[i]
        return u_w, scale
    return (u_w / scale if scale > 1.0 else u_w), scale


def sample_wheel_commands(time: np.ndarray, torque: np.ndarray, instants: np.ndarray) -> np.ndarray:
    """A zero-order-hold table of wheel commands sampled at the control instants.

    Row ``m`` of ``torque`` holds on ``[time[m], time[m+1])`` (the last row to the end); before ``time[0]`` the
    commands are 0.  An instant within ``1e-9 max(1, |t|)`` of a table time counts as at it (``q * period``
    rounding).

    Parameters
    ----------
    time : numpy.ndarray
        ``(T,)`` strictly increasing times (s).
    torque : numpy.ndarray
        ``(T, ...)`` commands (N m), e.g. ``(T, n_agents, n_wheels)``.
    instants : numpy.ndarray
        ``(Q,)`` control instants (s).

    Returns
    -------
    numpy.ndarray
        ``(Q, ...)`` the commands at each instant.

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.model.actuators import sample_wheel_commands
    >>> sample_wheel_commands(np.array([1.0, 2.0]), np.array([[0.1], [0.2]]), np.arange(4) * 0.7).ravel().tolist()
    [0.0, 0.0, 0.1, 0.2]
    """
    t = np.asarray(time, dtype=float)
    a = np.asarray(torque, dtype=float)
    q = np.asarray(instants, dtype=float)
    row = np.searchsorted(t, q + 1e-9 * np.maximum(1.0, np.abs(q)), side="right") - 1
    out = np.zeros((q.size, *a.shape[1:]))
    on = row >= 0
    out[on] = a[row[on]]
    return out


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
