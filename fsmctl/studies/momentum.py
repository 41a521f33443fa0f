"""A lower bound on the settling time from the torque limit: the spacecraft's angular momentum (Sec. 4).

Independent of the closed-loop simulation: :func:`reference_trajectory` integrates the reference open loop and
:func:`angular_momentum_bound` gives, per agent, the least time in which any controller within the per-axis torque
limit can bring the spacecraft's angular momentum onto the reference's (:class:`MomentumBound`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["MomentumBound", "reference_trajectory", "angular_momentum_bound"]


def reference_trajectory(scenario, t_end: float, step: float = 0.01) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The reference attitude ``sigma_d(t)`` and rate ``omega_d(t)`` on a uniform grid (Sec. 4), open loop.

    Integrates ``sigma_d_dot = G(sigma_d) omega_d(t)`` (eq 3, the generated ``reference_rhs``) with
    fixed-step RK4 and shadow-set switching (generated ``mrp_shadow``), independently of the
    closed-loop simulator.

    Parameters
    ----------
    scenario : Scenario
        Gives ``sigma_d(0)`` and ``omega_d(t)``.
    t_end : float
        Last time (s).
    step : float
        RK4 step (s).

    Returns
    -------
    time : (N,) array
        Grid times (s), ``0, step, ...`` up to at least ``t_end``.
    sigma_d : (N, 3) array
        The reference MRP (shadow set, ``|sigma_d| <= 1``).
    omega_d : (N, 3) array
        The reference rate, rad/s, desired frame.

    Examples
    --------
    >>> from fsmctl import paper_scenario
    >>> t, sigma_d, omega_d = reference_trajectory(paper_scenario("1"), 1.0, step=0.1)
    >>> t.shape, sigma_d.shape
    ((11,), (11, 3))
    >>> sigma_d[0]  # sigma_d(0) of Sec. 4
    array([-0.3, -0.4,  0.4])
    """
    import casadi as ca

    from fsmctl.model.generated_code import casadi_function

    rhs = casadi_function("reference_rhs")
    shadow = casadi_function("mrp_shadow")
    s = ca.MX.sym("sigma_d", 3)
    t = ca.MX.sym("t")
    h = ca.MX.sym("h")
    p = ca.MX.sym("params", 12)

    def f(tt, ss):
        return rhs(tt, ss, p)[0]

    k1 = f(t, s)
    k2 = f(t + h / 2, s + h / 2 * k1)
    k3 = f(t + h / 2, s + h / 2 * k2)
    k4 = f(t + h, s + h * k3)
    step_fn = ca.Function(
        "reference_step", [s, t, h, p], [shadow(s + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)), rhs(t, s, p)[1]]
    )
    n = math.ceil(t_end / step) + 1
    times = np.arange(n) * step
    sigmas, omegas = step_fn.mapaccum("reference_steps", n)(
        np.asarray(scenario.reference.sigma0, float), times[None, :], step, scenario.reference.omega.params()
    )
    sigmas = np.asarray(sigmas).T  # sigma_d(t_1) ... sigma_d(t_n)
    sigma_d = np.vstack([np.asarray(scenario.reference.sigma0, float), sigmas[:-1]])
    return times, sigma_d, np.asarray(omegas).T


@dataclass(frozen=True)
class MomentumBound:
    """Lower bound on the time to bring one spacecraft onto the reference with a per-axis torque limit.

    Physics: in the inertial frame N, ``dH/dt = C^T (u + d)`` with ``H = C^T J omega``
    (``C = [BN]``, J = J0 + ΔJ the true inertia, eq 29), so ``|dH/dt| <= sqrt(3) u_max + |d(t)|``
    when ``|u_k| <= u_max`` per body axis.  With reaction wheels (Schaub & Junkins eq 4.146) the total momentum
    ``H = C^T (J omega + G_s J_s Omega)`` changes only by the disturbance, and the body components of the wheels'
    absolute momentum ``h = J_spin omega + G_s J_s Omega`` only by ``G_s u_net`` (motor torque and friction), at
    most ``max |G_s x|`` over the wheels' torque box (:func:`fsmctl.model.actuators.max_body_torque`); tracking
    needs ``h(T) = C_d H(T) - (J - J_spin) omega_d``, which gives the same inequality with
    ``H_d = C_d^T ((J - J_spin) omega_d + h(0))`` and that rate.  Tracking the reference at time T requires
    ``H(T) = H_d(T) = C_d(T)^T J omega_d(T)`` (body frame = desired frame, omega = omega_d),
    hence ``|H_d(T) - H(0)| <= sqrt(3) u_max T + int_0^T |d| dt``.  ``min_time_s`` is the last
    grid time before that inequality first holds (a lower bound on any settling time).

    Parameters
    ----------
    agent : int
        1-based.
    torque_limit_N_m : float
        The per-axis command limit (``controller.torque_limit``).
    H0_N_m_s : float
        ``|H(0)| = |J omega(0)|``.
    H0_minus_Hd0_N_m_s : float
        ``|H(0) - H_d(0)|``: momentum to remove relative to the reference at t = 0.
    naive_time_s : float
        ``|J omega(0)| / (sqrt(3) u_max)``: removing all of H(0), no reference momentum, no disturbance.
    min_time_no_disturbance_s : float
        The bound with the reference's momentum, without the disturbance.
    min_time_s : float
        The bound with the reference's momentum and the disturbance assisting at full magnitude.
    grid_step_s : float
        The search grid (s).

    Examples
    --------
    The paper's agent 2 (Table 1, J = 1.3 J0):

    >>> from fsmctl import paper_scenario
    >>> b = angular_momentum_bound(paper_scenario("1"))[1]
    >>> b.agent, round(b.H0_N_m_s, 1), round(b.naive_time_s, 1)
    (2, 126.6, 36.6)
    """

    agent: int
    """1-based"""
    torque_limit_N_m: float
    """the per-axis command limit (``controller.torque_limit``)"""
    H0_N_m_s: float
    """|H(0)| = |J omega(0)|"""
    H0_minus_Hd0_N_m_s: float
    """|H(0) - H_d(0)|: momentum to remove relative to the reference at t = 0"""
    naive_time_s: float
    """|J omega(0)| / (sqrt(3) u_max): removing all of H(0), no reference momentum, no disturbance"""
    min_time_no_disturbance_s: float
    """bound with the reference's momentum, without the disturbance"""
    min_time_s: float
    """bound with the reference's momentum and the disturbance assisting at full magnitude (to reach omega = omega_d
    exactly; a settled metric allows a small residual rate, see the report)"""
    grid_step_s: float


def angular_momentum_bound(scenario, *, step: float = 0.01) -> list[MomentumBound]:
    """Per-agent lower bound on the settling time allowed by the torque limit (independent of the controller).

    Parameters
    ----------
    scenario : Scenario
        Agents (true inertia J = J0 + ΔJ, eq 29; initial state, Table 1; disturbance d_i(t)),
        reference (Sec. 4) and ``controller.torque_limit`` (per body axis).
    step : float
        Time grid (s) of the search; the bound is conservative by at most one step.

    Returns
    -------
    list of MomentumBound
        One per agent; see :class:`MomentumBound` for the inequality.  With no torque limit every
        bound is 0.

    Examples
    --------
    The agents of the paper's Case 1 that no controller within 2 N m per axis brings onto the reference in
    27 s (the paper's settling time):

    >>> from fsmctl import paper_scenario
    >>> bounds = angular_momentum_bound(paper_scenario("1"))
    >>> [b.agent for b in bounds if b.min_time_s > 27.0]
    [1, 2, 5, 6]
    >>> free = angular_momentum_bound(paper_scenario("1").replace(controller={"torque_limit": float("inf")}))
    >>> {b.min_time_s for b in free}
    {0.0}
    """
    from fsmctl.model.generated_code import casadi_function

    u_max = float(scenario.controller.torque_limit)
    dcm = casadi_function("mrp_to_dcm")
    omega_d_max = float(np.linalg.norm(scenario.reference.omega.bound()))
    out = []
    rate = math.sqrt(3.0) * u_max
    act = scenario.actuator
    G = act.spin_axes() if act.enabled else np.zeros((3, 0))
    Js = act.per_wheel("spin_inertia") if act.enabled else np.zeros(0)
    Om0 = act.per_wheel("initial_speed") if act.enabled else np.zeros(0)
    if act.enabled:
        from fsmctl.model.actuators import max_body_torque

        with np.errstate(invalid="ignore"):  # inf * 0 when there is no speed limit and no viscous friction
            friction = np.nan_to_num(act.per_wheel("viscous_friction") * act.per_wheel("max_speed"), nan=0.0)
        rate = max_body_torque(G, act.per_wheel("max_torque") + friction + act.per_wheel("coulomb_friction"))
    if not math.isfinite(rate):
        for i, a in enumerate(scenario.agents):
            h0 = float(np.linalg.norm(a.J_true @ np.asarray(a.omega0)))
            out.append(MomentumBound(i + 1, u_max, h0, math.nan, 0.0, 0.0, 0.0, step))
        return out
    # The inequality surely holds once sqrt(3) u_max T >= |H(0)| + max |H_d|.
    reach = max(
        float(np.linalg.norm(a.J_true @ np.asarray(a.omega0))) + float(np.linalg.eigvalsh(a.J_true)[-1]) * omega_d_max
        for a in scenario.agents
    )
    times, sigma_d, omega_d = reference_trajectory(scenario, reach / rate + 2 * step, step)
    n = times.size
    C_d = np.asarray(dcm.map(n)(sigma_d.T)).reshape(3, n, 3).transpose(1, 0, 2)  # [DN](t_k)
    J_spin = act.spin_inertia_matrix()
    for i, a in enumerate(scenario.agents):
        J = a.J_true
        C0 = np.asarray(dcm(np.asarray(a.sigma0, float)))
        w0 = np.asarray(a.omega0, float)
        h_rel0 = G @ (Js * Om0)  # wheels: their momentum relative to the hub
        H0 = C0.T @ (J @ w0 + h_rel0)  # the spacecraft's total momentum (inertial)
        h_abs0 = J_spin @ w0 + h_rel0  # body components of the wheels' absolute momentum: they change at G u
        H_d = np.einsum("kji,jl,kl->ki", C_d, J - J_spin, omega_d) + np.einsum("kji,j->ki", C_d, h_abs0)
        gap = np.linalg.norm(H_d - H0, axis=1)
        d_norm = np.linalg.norm(a.disturbance(times), axis=1)
        d_integral = np.concatenate([[0.0], np.cumsum(np.maximum(d_norm[1:], d_norm[:-1]) * step)])  # over-estimate

        def first_time(budget: np.ndarray, gap: np.ndarray = gap) -> float:
            ok = np.nonzero(gap <= budget)[0]
            k = int(ok[0]) if ok.size else n - 1
            return float(times[max(k - 1, 0)])

        out.append(
            MomentumBound(
                agent=i + 1,
                torque_limit_N_m=u_max,
                H0_N_m_s=float(np.linalg.norm(H0)),
                H0_minus_Hd0_N_m_s=float(gap[0]),
                naive_time_s=float(np.linalg.norm(H0)) / rate,
                min_time_no_disturbance_s=first_time(rate * times),
                min_time_s=first_time(rate * times + d_integral),
                grid_step_s=step,
            )
        )
    return out
