"""The paper's law on flight hardware: what the wheels allow, and how each law fares (the ``paper-hardware`` study).

:func:`momentum_budget` states, per spacecraft and independently of any control law, what the reaction wheels
must do to bring it onto the reference: the momentum they must end up holding, whether the array can hold it
(the array's momentum envelope along that direction, a linear programme), and the shortest time their torques
allow (:func:`fsmctl.studies.reproduce.angular_momentum_bound`, which handles wheels).  :func:`hardware_study`
flies the built-in laws on a hardware scenario and tabulates the metrics (:func:`fsmctl.studies.compare.run_metrics`),
including the wheels' peak momentum.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

from fsmctl.model.scenario import Scenario
from fsmctl.studies.reproduce import angular_momentum_bound, reference_trajectory

__all__ = ["WheelBudget", "momentum_budget", "momentum_envelope"]


def momentum_envelope(axes: np.ndarray, limits: np.ndarray, direction: np.ndarray) -> float:
    """Largest ``|h|`` along ``direction`` with ``h = G_s x``, ``|x_k| <= limits_k`` (N m s for momentum limits):
    the array's envelope, by linear programming (:func:`scipy.optimize.linprog`).

    Examples
    --------
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
    """What the wheels of one spacecraft must do to bring it onto the reference (law-independent)."""

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

    Examples
    --------
    >>> import fsmctl
    >>> budget = momentum_budget(fsmctl.load_scenario("paper-hardware"))
    >>> all(b.momentum_feasible for b in budget), min(b.min_time_s for b in budget) > 60
    (True, True)
    """
    from fsmctl.model.generated_code import casadi_function

    act = scenario.actuator
    if not act.enabled:
        raise ValueError("momentum_budget: the scenario has no reaction wheels (actuator.kind = 'ideal')")
    G = act.spin_axes()
    Js = act.per_wheel("spin_inertia")
    J_spin = (G * Js) @ G.T
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


def budget_table(budget: Sequence[WheelBudget]) -> list[dict]:
    """Rows (dicts) of a budget, for a DataFrame or a CSV writer."""
    return [asdict(b) for b in budget]
