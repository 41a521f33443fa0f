"""The paper's law on flight hardware: what the wheels allow, and how each law fares (the ``paper-hardware`` study).

:func:`momentum_budget` states, per spacecraft and independently of any control law, what the reaction wheels
must do to bring it onto the reference: the momentum they must end up holding, whether the array can hold it
(the array's momentum envelope along that direction, a linear programme), and the shortest time their torques
allow (:func:`fsmctl.studies.momentum.angular_momentum_bound`, which handles wheels).  :func:`hardware_study`
flies the built-in laws on a hardware scenario and tabulates the metrics (:func:`fsmctl.studies.compare.run_metrics`),
including the wheels' peak momentum.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fsmctl.errors import InputError
from fsmctl.model.scenario import Scenario
from fsmctl.studies.momentum import angular_momentum_bound, reference_trajectory

__all__ = [
    "WheelBudget",
    "momentum_budget",
    "momentum_envelope",
    "TorqueDemand",
    "torque_demand",
]


def momentum_envelope(axes: np.ndarray, limits: np.ndarray, direction: np.ndarray) -> float:
    """Largest ``|h|`` along ``direction`` with ``h = G_s x``, ``|x_k| <= limits_k``: the array's envelope, by linear
    programming (:func:`scipy.optimize.linprog`).

    Parameters
    ----------
    axes : numpy.ndarray
        ``(3, N)`` spin axes ``G_s``.
    limits : numpy.ndarray
        ``(N,)`` per-wheel limits (N m s for momentum limits, ``J_s,k`` times the speed limit).
    direction : numpy.ndarray
        ``(3,)`` direction (not necessarily unit).

    Returns
    -------
    float
        The largest magnitude along ``direction`` (the unit of ``limits``).

    Raises
    ------
    RuntimeError
        The linear programme fails (it does not for finite limits).

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.studies import momentum_envelope
    >>> round(momentum_envelope(np.eye(3), np.ones(3), np.array([1.0, 1.0, 0.0])), 6)  # sqrt(2)
    1.414214
    """
    from scipy.optimize import linprog

    G = np.asarray(axes, dtype=float)
    lim = np.asarray(limits, dtype=float)
    d = np.asarray(direction, dtype=float)
    d = d / np.linalg.norm(d)
    n = lim.size
    c = np.zeros(n + 1)
    c[-1] = -1.0  # maximise alpha
    A_eq = np.hstack([G, -d[:, None]])
    bounds = [(-x, x) for x in lim] + [(0, None)]
    res = linprog(c, A_eq=A_eq, b_eq=np.zeros(3), bounds=bounds, method="highs")
    if not res.success:
        raise RuntimeError(f"momentum envelope: the linear programme failed ({res.message})")
    return float(res.x[-1])


@dataclass(frozen=True)
class WheelBudget:
    """What the wheels of one spacecraft must do to bring it onto the reference (law-independent).

    Parameters
    ----------
    agent : int
        The spacecraft (1-based).
    H0_N_m_s : float
        ``|H|``: total angular momentum of the spacecraft (hub and wheels), conserved but for the disturbance.
    wheel_momentum_needed_N_m_s : float
        ``|h(T)| = |C_d H - (J - J_spin) omega_d|`` at the bound's time T: the momentum the wheels must then hold.
    wheel_momentum_envelope_N_m_s : float
        The array's largest momentum along that direction (speed limits; :func:`momentum_envelope`).
    momentum_feasible : bool
        ``needed <= envelope``.
    min_time_s : float
        Lower bound on the time to reach the reference, from the wheels' torque (and the disturbance).

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.studies import momentum_budget
    >>> b = momentum_budget(fsmctl.load_scenario("paper-hardware"))[0]
    >>> b.agent, b.momentum_feasible, b.wheel_momentum_needed_N_m_s < b.wheel_momentum_envelope_N_m_s
    (1, True, True)
    """

    agent: int
    """1-based"""
    H0_N_m_s: float
    """|H|: total angular momentum of the spacecraft (hub and wheels), conserved but for the disturbance"""
    wheel_momentum_needed_N_m_s: float
    """|h(T)| = |C_d H - (J - J_spin) omega_d| at the bound's time T: the momentum the wheels must then hold"""
    wheel_momentum_envelope_N_m_s: float
    """the array's largest momentum along that direction (speed limits)"""
    momentum_feasible: bool
    """needed <= envelope"""
    min_time_s: float
    """lower bound on the time to reach the reference, from the wheels' torque (and the disturbance)"""


def momentum_budget(scenario: Scenario, *, step: float = 0.05) -> list[WheelBudget]:
    """Per spacecraft: the wheel momentum needed on the reference, the array's envelope and the time bound.

    Parameters
    ----------
    scenario : Scenario
        A scenario with ``actuator.kind = "reaction_wheels"``.
    step : float
        Time grid of the bound's search (s).

    Returns
    -------
    list of WheelBudget
        One per spacecraft, in order.

    Raises
    ------
    InputError
        The scenario has no reaction wheels (a ``ValueError``).

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.studies import momentum_budget
    >>> budget = momentum_budget(fsmctl.load_scenario("paper-hardware"))
    >>> all(b.momentum_feasible for b in budget), min(b.min_time_s for b in budget) > 60
    (True, True)
    """
    from fsmctl.model.generated_code import casadi_function

    act = scenario.actuator
    if not act.enabled:
        raise InputError("momentum_budget: the scenario has no reaction wheels (actuator.kind = 'ideal')")
    G = act.spin_axes()
    Js = act.per_wheel("spin_inertia")
    J_spin = act.spin_inertia_matrix()
    h_max = Js * act.per_wheel("max_speed")
    bounds = angular_momentum_bound(scenario, step=step)
    horizon = max(b.min_time_s for b in bounds) + step
    times, sigma_d, omega_d = reference_trajectory(scenario, horizon, step)
    dcm = casadi_function("mrp_to_dcm")
    out = []
    for a, b in zip(scenario.agents, bounds, strict=True):
        C0 = np.asarray(dcm(np.asarray(a.sigma0, float)))
        H = C0.T @ (a.J_true @ np.asarray(a.omega0) + G @ (Js * act.per_wheel("initial_speed")))
        k = min(round(b.min_time_s / step), times.size - 1)
        Cd = np.asarray(dcm(sigma_d[k]))
        h = Cd @ H - (a.J_true - J_spin) @ omega_d[k]
        need = float(np.linalg.norm(h))
        envelope = momentum_envelope(G, h_max, h) if need > 0 and np.all(np.isfinite(h_max)) else math.inf
        out.append(
            WheelBudget(
                agent=b.agent,
                H0_N_m_s=float(np.linalg.norm(H)),
                wheel_momentum_needed_N_m_s=need,
                wheel_momentum_envelope_N_m_s=envelope,
                momentum_feasible=need <= envelope,
                min_time_s=b.min_time_s,
            )
        )
    return out


@dataclass(frozen=True)
class TorqueDemand:
    """The torque one spacecraft needs just to follow the reference and to reject its disturbance, next to what
    its actuator delivers (law-independent).

    Parameters
    ----------
    agent : int
        The spacecraft (1-based).
    reference_peak_N_m : float
        Max over the horizon of ``|J omega_d_dot + omega_d x J omega_d|`` (eq 4 on the reference, ``J = J0 + dJ``).
    reference_mean_N_m : float
        Its mean over the horizon.
    disturbance_peak_N_m : float
        ``max |d(t)|`` (eq 29).
    capacity_max_N_m : float
        The largest body torque the actuator can deliver (any direction; ideal: ``sqrt(3) torque_limit``).
    capacity_min_N_m : float
        The torque the actuator delivers in its weakest direction (wheels: with the minimum-norm split; ideal:
        ``torque_limit``).

    Examples
    --------
    Case 1 of the paper (ideal actuator, 2 N m per axis):

    >>> import fsmctl
    >>> from fsmctl.studies import torque_demand
    >>> d = torque_demand(fsmctl.paper_scenario("1"))[0]
    >>> d.capacity_min_N_m, round(d.capacity_max_N_m, 4), d.reference_peak_N_m < d.capacity_min_N_m
    (2.0, 3.4641, True)
    """

    agent: int
    """1-based"""
    reference_peak_N_m: float
    """max over the horizon of |J omega_d_dot + omega_d x J omega_d| (eq 4 on the reference, J = J0 + dJ)"""
    reference_mean_N_m: float
    disturbance_peak_N_m: float
    """max |d(t)|"""
    capacity_max_N_m: float
    """the largest body torque the actuator can deliver (any direction; ideal: sqrt(3) torque_limit)"""
    capacity_min_N_m: float
    """the torque the actuator delivers in its weakest direction (wheels: with the minimum-norm split; ideal:
    torque_limit)"""


def torque_demand(scenario: Scenario, *, step: float = 0.1) -> list[TorqueDemand]:
    """Per spacecraft: the torque the reference and the disturbance demand over the horizon, and the actuator's.

    Following the reference exactly needs ``tau = J omega_d_dot + omega_d x (J omega_d)`` (Liang et al. 2012, eq 4
    with ``omega = omega_d``; with wheels at zero momentum): where this exceeds what the actuator delivers, no law
    can track the reference there.

    Parameters
    ----------
    scenario : Scenario
        The scenario (its reference, agents, horizon and actuator).
    step : float
        Time grid (s) of the maxima and means.

    Returns
    -------
    list of TorqueDemand
        One per spacecraft, in order.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.studies import torque_demand
    >>> demand = torque_demand(fsmctl.load_scenario("paper-hardware"))
    >>> max(d.reference_peak_N_m for d in demand) > demand[0].capacity_max_N_m  # the wheels cannot follow it
    True
    """
    from fsmctl.model.actuators import body_torque_capacity, max_body_torque
    from fsmctl.model.generated_code import casadi_function

    t = np.arange(0.0, scenario.simulation.t_final + step / 2, step)
    ref = casadi_function("reference_rhs").map(t.size)  # omega_d(t), omega_d_dot(t): the generated reference
    _, w, w_dot = (
        np.asarray(v, dtype=float).T
        for v in ref(
            t[None, :], np.zeros((3, t.size)), np.repeat(scenario.reference.omega.params()[:, None], t.size, 1)
        )
    )
    act, limit = scenario.actuator, scenario.controller.torque_limit
    if act.enabled:
        lim = act.per_wheel("max_torque")
        cap_max = min(max_body_torque(act.spin_axes(), lim), math.sqrt(3) * limit)
        cap_min = min(body_torque_capacity(act.spin_axes(), lim)["min"], limit)
    else:
        cap_max, cap_min = math.sqrt(3) * limit, limit
    out = []
    for i, a in enumerate(scenario.agents):
        J = a.J_true
        tau = np.linalg.norm(w_dot @ J.T + np.cross(w, w @ J.T), axis=1)
        d = np.linalg.norm(a.disturbance(t), axis=1)
        out.append(
            TorqueDemand(
                agent=i + 1,
                reference_peak_N_m=float(tau.max()),
                reference_mean_N_m=float(tau.mean()),
                disturbance_peak_N_m=float(d.max()),
                capacity_max_N_m=float(cap_max),
                capacity_min_N_m=float(cap_min),
            )
        )
    return out
