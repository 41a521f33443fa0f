"""The step-size report: bounds on a closed loop's fastest rates against the RK4 step ``dt``.

:func:`step_size_report` (and the :class:`~fsmctl.simulation.failures.StepSizeWarning` that
:func:`fsmctl.simulation.simulator.simulate` gives before a run), and the checks of the law at the initial state.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from fsmctl.model.problem import PackedProblem, pack
from fsmctl.model.scenario import Scenario
from fsmctl.simulation.failures import StepSizeWarning, nonfinite_hint, singularity_fix_none

# ----------------------------------------------------------------------------- step size

MAX_ROTATION_PER_STEP = 0.1
"""rad: largest rotation per RK4 step ``max|omega| dt`` without :class:`StepSizeWarning`."""
MAX_STEP_RATE = 0.5
"""Largest ``dt * rho`` (``rho``: bound on the loop's fastest rate, 1/s) without :class:`StepSizeWarning`."""


def step_size_report(scenario: Scenario | PackedProblem) -> dict:
    """Bounds on the fastest rates of a scenario's closed loop and what they mean for the RK4 step ``dt``.

    Rates (1/s), each from the (packed) scenario alone, no run; over agents the worst value is taken:

    * ``surface`` and ``layer``: the law's own rates, as it declares them
      (:meth:`fsmctl.symbolic.law.LawBuilder.loop_rates`, evaluated per agent): for the paper's law
      ``surface = c1 + c2 r1``, the sliding surface (eq 13) on which ``sigma_e`` decays at
      ``c1 + c2 d sig(x)^alpha/dx`` with the slope's largest value in the Remark 6 band (``r1 = (2 - alpha)
      epsilon^(alpha-1)`` for ``switch``, the ``c2 r1`` of the paper scenario's [choices] 'step' text), and
      ``layer = max delta_k / phi`` inside the boundary layer ``sat(s/phi)`` (Remark 7; 0 for ``sgn``)
      (:func:`fsmctl.symbolic.fsm_parameters.fsm_loop_rates`).  A law that declares none gets ``surface``
      from its linearisation at the initial state (finite differences of the generated law, ``a + sqrt(b)``
      for ``omega_dot = J0^-1 u`` with ``a = ||J0^-1 du/domega||``, ``b = ||J0^-1 du/dsigma|| / 4``; an
      estimate) and ``layer = 0``.
    * ``coordination = max_i (sum_j k^i_ij + sum_j max_t |k^j_ij(t)|)``: Gershgorin's bound on the
      eigenvalues of the coupling ``k_sum_i s_i - sum_j k^j_ij s_j`` (eq 19) over the receiving agents.
    * ``gain = max_i ||(J0_i + delta_J_i)^-1 J0_i||_2``: the controller computes torques with ``J0``, the plant
      divides by ``J = J0 + delta_J``, so every closed-loop rate is scaled by up to this factor (the
      conditioning of ``J0`` against ``J0 + delta_J``; 1/1.3 in the paper's Case 1).  With
      ``s = sigma_e_dot + a sigma_e`` the linearised loop per axis is
      ``sigma_e_ddot = -g((a + b + k) sigma_e_dot + (b + k) a sigma_e)``, whose roots
      have modulus at most ``max(g, sqrt(g)) (a + b + k)``: ``loop = max(gain, sqrt(gain)) (surface + layer
      + coordination)`` (0 with the controller disabled).
    * ``gyroscopic = max_i sqrt(sum_k ||A_ik||^2) omega_max``: the Jacobian of Euler's
      ``-J^-1 (omega x J omega)`` is ``sum_k omega_k A_k`` with ``A_k = J^-1 ((J e_k)^x - e_k^x J)``, of norm at
      most ``|omega| sqrt(sum_k ||A_k||^2)`` (Cauchy-Schwarz).  For a rigid body (``|J2 - J3| <= J1``, the
      triangle inequality) this is about ``|omega|``; an unphysical or ill-conditioned inertia makes it
      large (``(J2 - J3)/J1 omega`` of Euler's equations).  ``omega_max`` is the largest initial body rate
      ``|omega_i(0)|`` or the reference's rate bound ``|omega_d|`` (amplitude + offset).

    * ``wheel_friction = max_ik (c_v,k + c_c,k / b) m_ik`` (reaction wheels): a wheel's spin relative to the hub
      obeys ``J_s Omega_dot = u_motor - c_v Omega - c_c sat(Omega / b) - J_s g^T omega_dot``
      (:func:`fsmctl.symbolic.hardware.wheel_motor_torque`, Schaub & Junkins eq 4.146), and with the hub's reaction
      ``omega_dot = -(J - J_spin)^-1 g u_net`` a friction torque ``f`` changes ``Omega`` at ``f m`` per second, with
      ``m_ik = 1/J_s,k + g_k^T (J_i - J_spin,i)^-1 g_k``.  Inside the stiction band ``|Omega| < b`` the friction
      ``(c_v + c_c / b) Omega`` is a decay at this rate, so ``dt * wheel_friction`` is judged like ``dt rho``
      (:data:`MAX_STEP_RATE`): one step changes the speed by ``c_c m dt``, which must stay below half the band ``b``,
      the wheel's speed scale of the friction (beyond it RK4 turns the decay into a growing oscillation: a wheel
      whose friction creates energy).  With ``b = 0`` (``sgn``) the band is 0 and the friction of a wheel near rest
      is never resolved by a fixed step: its speed jumps by ``2 c_c m dt`` at every crossing of 0
      (``wheel_chatter``, rad/s; reported, not judged: sgn friction has no speed scale of its own; a band
      ``b >= c_c m dt / MAX_STEP_RATE`` resolves it).

    ``rho = loop + gyroscopic`` bounds the spectral radius of the linearised right-hand side (a sum of
    the parts' norms).  RK4 is stable for ``dt rho < 2.78`` on the negative real axis and accurate to
    ``(dt rho)^5 / 120`` per step; ``dt rho <= 0.5`` (:data:`MAX_STEP_RATE`, ``dt`` at most half the fastest
    time constant ``1/rho``) keeps that below 3e-4.  ``rotation = omega_max dt`` must stay below
    :data:`MAX_ROTATION_PER_STEP` (0.1 rad): the kinematics ``sigma_dot = G(sigma) omega`` are integrated
    through the MRP shadow switch, and a step that turns the body by a sizeable angle loses accuracy however
    slow the loop is.  The paper scenario (dt = 1 ms, Case 1): ``rho ~ 78 1/s``, ``dt rho ~ 0.08``, rotation 7e-4 rad.

    Parameters
    ----------
    scenario : Scenario or PackedProblem
        The scenario (or its packed form, :func:`fsmctl.model.problem.pack`).

    Returns
    -------
    dict
        These rates (1/s), ``rho``, ``omega_max`` (rad/s), ``rotation_per_step`` (rad), ``dt`` and the list
        ``problems`` (empty when the step is fine; only the fixed-step RK4 integrator is judged: dopri45
        controls its own steps).

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.simulation import step_size_report
    >>> report = step_size_report(fsmctl.paper_scenario("1"))
    >>> round(report["rho"], 1), round(report["dt"] * report["rho"], 3), report["problems"]
    (77.5, 0.078, [])
    """
    p = pack(scenario) if isinstance(scenario, Scenario) else scenario
    n = p.n_agents
    J, J0 = np.asarray(p.J_true, dtype=float), np.asarray(p.J0, dtype=float)
    declared = p.law.loop_rates(p.params)  # the law's own bounds (LawBuilder.loop_rates), the worst agent
    if declared is not None:
        surface, layer = declared
    else:  # a law that declares none: its linearisation at the initial state, by finite differences (an estimate)
        surface, layer = _law_rate_estimate(p), 0.0
    k_in = np.zeros(n)
    for e in range(p.n_links):
        start, count = int(p.sched_start[e]), int(p.sched_count[e])
        k_in[int(p.link_receiver[e])] += abs(float(p.link_k_i[e])) + float(
            np.max(np.abs(p.sched_values[start : start + count]))
        )
    coordination = float(k_in.max()) if n else 0.0
    gain = max(float(np.linalg.norm(np.linalg.solve(J[i], J0[i]), 2)) for i in range(n))
    enabled = bool(np.any(p.u_max > 0))  # a disabled controller is packed with a zero torque limit
    loop = max(gain, math.sqrt(gain)) * (surface + layer + coordination) if enabled else 0.0
    omega0 = p.x0[3:].reshape(n, p.stride)[:, 3:6]
    ref = np.asarray(p.ref_params, dtype=float)
    omega_max = max(
        float(np.max(np.linalg.norm(omega0, axis=1))), float(np.linalg.norm(np.abs(ref[0:3]) + np.abs(ref[9:12])))
    )
    gyroscopic = _gyroscopic_gain(J) * omega_max
    rho = loop + gyroscopic
    dt = p.dt
    friction, chatter, m_worst, coulomb, viscous, band, spin = _wheel_friction_rate(p, J)
    problems = []
    if p.integrator == 0:  # rk4
        if dt * rho > MAX_STEP_RATE:
            parts = ", ".join(
                f"{name} {value:.3g}"
                for name, value in (
                    ("law surface", surface),
                    ("law layer", layer),
                    ("coordination", coordination),
                    ("inertia gain ||J^-1 J0||", gain),
                    ("gyroscopic", gyroscopic),
                )
            )
            problems.append(
                f"dt = {dt:g} s is coarse for the loop's fastest rate rho ~ {rho:.3g} 1/s (dt rho = {dt * rho:.3g} > "
                f"{MAX_STEP_RATE:g}; {parts}): use dt <= {MAX_STEP_RATE / rho:.2g} s"
            )
        if omega_max * dt > MAX_ROTATION_PER_STEP:
            problems.append(
                f"dt = {dt:g} s turns a body by up to {omega_max * dt:.3g} rad per step (|omega| <= {omega_max:.3g} "
                f"rad/s; bound {MAX_ROTATION_PER_STEP:g} rad): use dt <= {MAX_ROTATION_PER_STEP / omega_max:.2g} s"
            )
        if dt * friction > MAX_STEP_RATE:
            problems.append(
                f"dt = {dt:g} s cannot resolve the reaction wheels' friction: it changes a wheel's speed at up to "
                f"{friction:.3g} 1/s inside the stiction band (coulomb_friction {coulomb:.3g} N m over coulomb_band "
                f"{band:g} rad/s, viscous_friction {viscous:.3g} N m s, spin inertia {spin:.3g} kg m^2; dt rate = "
                f"{dt * friction:.3g} > {MAX_STEP_RATE:g}), and the wheel would gain energy from it: use dt <= "
                f"{MAX_STEP_RATE / friction:.2g} s or a wider coulomb_band (>= {coulomb * m_worst * dt / MAX_STEP_RATE:.2g} "
                "rad/s)"
            )
    return {
        "dt": dt,
        "surface": surface,
        "layer": layer,
        "coordination": coordination,
        "gain": gain,
        "loop": loop,
        "gyroscopic": gyroscopic,
        "rho": rho,
        "omega_max": omega_max,
        "rotation_per_step": omega_max * dt,
        "wheel_friction": friction,
        "wheel_chatter": chatter,
        "problems": problems,
    }


def _wheel_friction_rate(p: PackedProblem, J: np.ndarray) -> tuple[float, float, float, float, float, float, float]:
    """``(rate, chatter, m, coulomb, viscous, band, J_s)`` of the worst wheel (see :func:`step_size_report`): the
    friction's decay rate inside the stiction band (1/s), the speed jump ``2 c_c m dt`` of sgn friction (rad/s, only
    for ``b = 0``), and that wheel's ``m = 1/J_s + g^T (J - J_spin)^-1 g`` and friction settings; zeros without
    wheels."""
    hw = p.hardware
    worst = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    for i in range(hw.n_wheels and p.n_agents):
        hub = np.linalg.inv(J[i] - hw.J_spin[i])
        for k in range(hw.n_wheels):
            g, Js = hw.wheel_axes[i, k], float(hw.wheel_Js[i, k])
            _, viscous, coulomb, band = (float(x) for x in hw.wheel_params[i, k])
            m = 1.0 / Js + float(g @ hub @ g)
            rate = (viscous + (coulomb / band if band > 0 else 0.0)) * m
            chatter = 2.0 * coulomb * m * p.dt if band == 0 else 0.0
            if (rate, chatter) > worst[:2]:
                worst = (rate, chatter, m, coulomb, viscous, band, Js)
    return worst


def _law_rate_estimate(p: PackedProblem, h: float = 1e-6) -> float:
    """A law's loop rate at the initial state (1/s): ``a + sqrt(b)`` for the linearised ``omega_dot = J0^-1 u`` with
    ``a = ||J0^-1 du/domega||``, ``b = ||J0^-1 du/dsigma|| / 4`` (``G(0) = I/4``), the worst agent; finite
    differences of the generated law with no neighbours (an estimate, for laws without a closed form here; an agent
    where they are not finite is left out, :func:`_check_law_at_start` refuses a law not finite there)."""
    n = p.n_agents
    x0 = _initial_states(p)
    # per agent its initial state, then that state with each of sigma, omega moved by h: one evaluation of all
    shifted = np.repeat(x0[:, None, :], 7, axis=1)
    shifted[:, np.arange(1, 7), np.arange(6)] += h
    torque = _law_outputs(p, np.repeat(np.arange(n), 7))(shifted.reshape(n * 7, -1))["torque"].reshape(n, 7, 3)
    worst = 0.0
    for i in range(n):
        jac = ((torque[i, 1:] - torque[i, 0]) / h).T  # (3, 6): d torque / d (sigma, omega)
        if not np.all(np.isfinite(jac)):
            continue
        Jinv = np.linalg.inv(p.J0[i])
        a = float(np.linalg.norm(Jinv @ jac[:, 3:6], 2))
        b = float(np.linalg.norm(Jinv @ jac[:, 0:3], 2)) / 4.0
        worst = max(worst, a + math.sqrt(b))
    return worst


def _initial_states(p: PackedProblem) -> np.ndarray:
    """``(n_agents, stride)``: row ``i`` is agent ``i``'s initial ``[sigma, omega, z, Omega]``."""
    return np.array([p.x0[p.agent_slice(i)] for i in range(p.n_agents)])


def _law_outputs(p: PackedProblem, agents: np.ndarray):
    """``X -> {name: (m, k) array}``: the law of agent ``agents[r]`` at its state ``X[r]`` (attitude, rate, law state)
    at ``t = 0`` for every row ``r`` at once (one mapped call of each generated function), each alone (no neighbours,
    no torque limit): its ``constants``, ``broadcast``, ``torque`` and ``law state derivative``."""
    from fsmctl.model.generated_code import casadi_function

    agents = np.asarray(agents, dtype=int)
    m, ns = len(agents), p.n_states
    model = "exact" if p.error_model == 1 else "paper"
    local, control = p.law.casadi(f"law_local_{model}").map(m), p.law.casadi(f"law_control_{model}").map(m)
    _, wd, wdd = (
        np.asarray(v, dtype=float).ravel() for v in casadi_function("reference_rhs")(0.0, p.x0[:3], p.ref_params)
    )
    params = np.asarray(p.params, dtype=float)[agents].T  # (parameters, m): column r is agent agents[r]'s
    k = np.asarray(p.law.casadi("law_constants").map(m)(params), dtype=float).reshape(-1, m)
    J0 = np.hstack([p.J0[i] for i in agents])  # the 3 x 3 blocks side by side

    def outputs(X: np.ndarray) -> dict[str, np.ndarray]:
        X = np.asarray(X, dtype=float).T
        args = [0.0, X[0:3], X[3:6], X[6 : 6 + ns], p.x0[:3], wd, wdd, J0, params, k]
        broadcast, cache = local(*args)
        _, u, z_dot = control(*args, cache, 0.0, np.zeros(p.n_broadcast), 0.0, np.inf)
        flat = {"constants": k, "broadcast": broadcast, "torque": u, "law state derivative": z_dot}
        return {name: np.asarray(v, dtype=float).reshape(-1, m).T for name, v in flat.items()}

    return outputs


def _check_law_at_start(p: PackedProblem) -> None:
    """Refuse a law that is not finite at an agent's initial state (NaN or inf): it would fly NaN."""
    from fsmctl.model.laws import LawError

    n = p.n_agents
    values = _law_outputs(p, np.arange(n))(_initial_states(p))
    if all(np.isfinite(v).all() for v in values.values()):
        return
    for i in range(n):
        for name, value in values.items():
            if not np.all(np.isfinite(value[i])):
                shown = ", ".join(f"{v:g}" for v in value[i])
                why = (
                    nonfinite_hint(p).strip()
                    if singularity_fix_none(p)
                    else "(a division by zero, or a root or log of a negative number?)"
                )
                raise LawError(
                    f"law {p.law.name!r}: its {name} is not finite at the initial state of agent {i + 1} "
                    f"([{shown}]): the law is undefined there {why}; fix the law or the initial state"
                )


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _gyroscopic_gain(J: np.ndarray) -> float:
    """``max_i sqrt(sum_k ||A_ik||_2^2)`` with ``A_ik = J_i^-1 ((J_i e_k)^x - e_k^x J_i)``: the Jacobian of Euler's
    ``-J^-1 (omega x J omega)`` is ``sum_k omega_k A_k``, whose norm is at most this times ``|omega|``."""
    worst = 0.0
    for Ji in J:
        Jinv = np.linalg.inv(Ji)
        parts = np.stack([Jinv @ (_skew(Ji[:, k]) - _skew(np.eye(3)[k]) @ Ji) for k in range(3)])
        norms = np.linalg.svd(parts, compute_uv=False)[:, 0]  # ||A_k||_2 (numpy.linalg.norm's ord=2, in one call)
        worst = max(worst, math.sqrt(sum(float(x) ** 2 for x in norms)))
    return worst


def _warn_step_size(scenario: Scenario, p: PackedProblem) -> None:
    for problem in step_size_report(p)["problems"]:
        warnings.warn(f"{scenario.label}: {problem}", StepSizeWarning, stacklevel=3)


def _warn_rotation_reached(scenario: Scenario, omega: np.ndarray) -> None:
    """After an RK4 run: the rotation per step actually reached (largest |omega| of the output samples)."""
    if scenario.simulation.integrator != "rk4" or omega.size == 0:
        return
    dt = scenario.simulation.dt
    peak = 0.0
    for start in range(0, omega.shape[0], 4096):  # blocks: no (T, n) temporary
        block = omega[start : start + 4096]
        peak = max(peak, float(np.sqrt(np.max(np.einsum("...k,...k->...", block, block)))))
    if not math.isfinite(peak) or peak * dt > MAX_ROTATION_PER_STEP:
        warnings.warn(
            f"{scenario.label}: a body reached |omega| = {peak:.4g} rad/s, {peak * dt:.3g} rad per step of "
            f"dt = {dt:g} s (bound {MAX_ROTATION_PER_STEP:g} rad): the results are not resolved in time; "
            f"use dt <= {MAX_ROTATION_PER_STEP / peak if peak > 0 else dt:.2g} s or check the inertias and gains",
            StepSizeWarning,
            stacklevel=3,
        )
