"""Two independent references for fsmctl's reaction-wheel model (a helper module, not a test file).

* :func:`basilisk_run`: one Basilisk spacecraft (``spacecraft.Spacecraft`` hub and a
  ``reactionWheelStateEffector`` with ``RWModel = BalancedWheels``), no gravity, Basilisk's RK4 at ``dt``.
* :func:`numpy_gyrostat_run`: a SciPy transcription (``solve_ivp``, DOP853, rtol 1e-12) of the balanced-wheel
  gyrostat equations (Schaub & Junkins, eq 4.146), written from the equations only: it imports neither fsmctl
  nor Basilisk.

Both take the same arguments and return ``dict(time, sigma, omega, Omega, ...)`` sampled at the control
instants ``q * period`` (``q = 0 .. Q``, ``Q = round(t_final / period)``):

* ``J`` (3, 3): inertia of the WHOLE spacecraft, wheels included, about its centre of mass (the wheels sit at
  the centre of mass: no parallel-axis terms);
* ``axes`` (3, N): unit spin axes ``g_i`` as columns; ``spin_inertia``: ``J_s`` (scalar or (N,));
* ``sigma0`` (3,) MRP ``[BN]``, ``omega0`` (3,) body rate (body frame, rad/s), ``Omega0`` (N,) wheel speeds
  relative to the hub (rad/s);
* ``wheel_torques`` (>= Q, N): motor torque on each wheel (N m), command ``q`` held on ``[q T, (q+1) T)``;
* ``max_torque``, ``max_speed`` (scalar or (N,), or None: no limit): Basilisk's per-wheel rules, i.e. a
  command is clipped to ``[-max_torque, max_torque]``, and a wheel with ``|Omega| >= max_speed`` gets no motor
  torque while ``u Omega >= 0``; the speed rule is sampled at every multiple of ``dt`` (where Basilisk's wheel
  module runs) and held in between;
* ``external_torque``: None, (3,) constant, or (>= Q, 3) held per interval; body frame, about the centre of mass.

Equations (``G_s = [g_1 .. g_N]``, ``h_w = sum J_s,i Omega_i g_i``)::

    (J - sum J_s,i g_i g_i^T) omega_dot = -omega x (J omega + h_w) - sum u_i g_i + L_ext
    Omega_dot_i = u_i / J_s,i - g_i^T omega_dot
    sigma_dot = 1/4 [(1 - |sigma|^2) I + 2 sigma^x + 2 sigma sigma^T] omega   (shadow set at |sigma| > 1)

Basilisk conventions found in its source (``reactionWheelStateEffector.cpp``, ``hubEffector.cpp``,
``spacecraft.cpp``, bsk 2.x):

* with ``BalancedWheels`` the wheel effector adds NO mass properties (``updateEffectorMassProps`` only handles
  the jitter models) and contributes ``matrixD -= J_s g g^T``, ``vecRot -= g u + J_s Omega omega x g``: the hub
  inertia ``IHubPntBc_B`` must therefore be the WHOLE spacecraft inertia ``J`` (the wheels' ``Jt``/``Jg``
  never enter); the hub's angular momentum ``IHub omega`` plus the wheels' ``J_s Omega g`` is Basilisk's
  ``totRotAngMomPntC_N``, which we return as a cross-check of that convention;
* the motor command is the ``ArrayMotorTorqueMsg`` read by ``rwMotorCmdInMsg``; ``UpdateState`` of the wheel
  module reads it, clips to ``u_max`` (``u_max <= 0``: no limit), applies ``Omega_max`` with
  ``|Omega| >= Omega_max and Omega u >= 0 -> u = 0`` (``Omega_max <= 0``: no limit), and stores ``u_current``,
  which the spacecraft then uses for every RK4 stage until the next ``UpdateState``;
* ``Spacecraft.UpdateState(t_k)`` integrates the step ``[t_{k-1}, t_k]``, then switches the MRP (``|sigma| > 1``)
  and writes the state messages.

Timing of the commands (why the simulation is stepped interval by interval): the wheel module is scheduled at
``dt`` in the same task as the spacecraft but with a HIGHER priority, so that at every tick ``t_k`` it reads
the command first and the spacecraft then integrates ``[t_{k-1}, t_k]`` with it.  We run Basilisk to the stop
time ``q T`` (ticks up to and including ``q T``), read the states there from the output messages, write
command ``q`` and run on to ``(q+1) T``: the ticks ``q T + dt .. (q+1) T`` all read command ``q``, so it acts
exactly on ``[q T, (q+1) T)``, the speed rule is evaluated with the wheel speed at the start of every RK4 step,
and the samples are the states at exactly ``q T`` (no recorder phase to reason about).  A task at ``period``
writing the message would have to be ordered between the spacecraft and the wheel module inside one tick,
which depends on task priorities; writing from Python between two ``ExecuteSimulation`` calls cannot be
reordered.  ``test_wheels_basilisk.py::test_command_timing`` checks the timing to 1e-12.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

__all__ = [
    "attitude_error",
    "basilisk_run",
    "inertial_momentum",
    "mrp_to_dcm",
    "numpy_gyrostat_run",
    "pyramid_axes",
]


# ----------------------------------------------------------------------------------------------------------------
# shared small helpers (NumPy only)


def pyramid_axes(elevation_deg: float | None = None) -> np.ndarray:
    """(3, 4) spin axes of the classic pyramid: ``(+-1, +-1, 1)/sqrt(3)``, azimuths 45, 135, 225, 315 deg.

    ``elevation_deg`` None: the axes ``(cos az, sin az, 1/sqrt(2)) / |.|`` with elevation atan(1/sqrt(2))
    (35.26 deg), which are exactly ``(+-1, +-1, 1)/sqrt(3)``.
    """
    el = np.arctan(1.0 / np.sqrt(2.0)) if elevation_deg is None else np.radians(elevation_deg)
    az = np.radians([45.0, 135.0, 225.0, 315.0])
    return np.vstack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.full(4, np.sin(el))])


def mrp_to_dcm(sigma) -> np.ndarray:
    """``[BN]`` of the MRP ``sigma`` (maps N components to B components; Schaub & Junkins eq 3.152)."""
    s = np.asarray(sigma, dtype=float)
    s2 = float(s @ s)
    sx = np.array([[0.0, -s[2], s[1]], [s[2], 0.0, -s[0]], [-s[1], s[0], 0.0]])
    return np.eye(3) + (8.0 * sx @ sx - 4.0 * (1.0 - s2) * sx) / (1.0 + s2) ** 2


def _mrp_to_quat(s: np.ndarray) -> np.ndarray:
    s2 = float(s @ s)
    return np.concatenate([[(1.0 - s2) / (1.0 + s2)], 2.0 * s / (1.0 + s2)])


def attitude_error(sigma_a, sigma_b) -> np.ndarray:
    """Principal angle (rad, in [0, pi]) between the attitudes ``sigma_a`` and ``sigma_b`` ((..., 3) each).

    Computed from the relative quaternion with ``atan2`` (accurate near 0, unlike ``arccos`` of the trace), and
    independent of the MRP set each side happens to be on.
    """
    a = np.atleast_2d(np.asarray(sigma_a, dtype=float))
    b = np.atleast_2d(np.asarray(sigma_b, dtype=float))
    out = np.empty(a.shape[0])
    for k in range(a.shape[0]):
        qa, qb = _mrp_to_quat(a[k]), _mrp_to_quat(b[k])
        # q_rel = conj(qa) (x) qb: its scalar part is qa . qb, its vector part a0 b - b0 a - a x b
        w = float(qa @ qb)
        v = qa[0] * qb[1:] - qb[0] * qa[1:] - np.cross(qa[1:], qb[1:])
        out[k] = 2.0 * np.arctan2(np.linalg.norm(v), abs(w))
    return out


def inertial_momentum(J, axes, spin_inertia, sigma, omega, Omega) -> np.ndarray:
    """Total angular momentum in the inertial frame, ``[NB] (J omega + sum J_s Omega g)``, at each sample."""
    J, G = np.asarray(J, dtype=float), np.asarray(axes, dtype=float)
    Js = np.broadcast_to(np.asarray(spin_inertia, dtype=float), (G.shape[1],))
    sigma, omega, Omega = np.atleast_2d(sigma), np.atleast_2d(omega), np.atleast_2d(Omega)
    H = np.empty((sigma.shape[0], 3))
    for k in range(sigma.shape[0]):
        H[k] = mrp_to_dcm(sigma[k]).T @ (J @ omega[k] + G @ (Js * Omega[k]))
    return H


def _common_inputs(J, axes, spin_inertia, wheel_torques, period, t_final, dt, max_torque, max_speed, external_torque):
    J = np.asarray(J, dtype=float).reshape(3, 3)
    G = np.asarray(axes, dtype=float)
    if G.ndim != 2 or G.shape[0] != 3:
        raise ValueError(f"axes: expected (3, N), got {G.shape}")
    N = G.shape[1]
    G = G / np.linalg.norm(G, axis=0)
    Js = np.broadcast_to(np.asarray(spin_inertia, dtype=float), (N,)).copy()
    Q = round(t_final / period)
    if abs(Q * period - t_final) > 1e-9 * period or Q < 1:
        raise ValueError(f"t_final = {t_final} is not a positive multiple of period = {period}")
    n_sub = round(period / dt)
    if abs(n_sub * dt - period) > 1e-9 * dt or n_sub < 1:
        raise ValueError(f"period = {period} is not a positive multiple of dt = {dt}")
    U = np.asarray(wheel_torques, dtype=float).reshape(-1, N)
    if U.shape[0] < Q:
        raise ValueError(f"wheel_torques: {U.shape[0]} samples for {Q} intervals")
    umax = None if max_torque is None else np.broadcast_to(np.asarray(max_torque, dtype=float), (N,)).copy()
    wmax = None if max_speed is None else np.broadcast_to(np.asarray(max_speed, dtype=float), (N,)).copy()
    if external_torque is None:
        L = np.zeros((Q, 3))
    else:
        L = np.asarray(external_torque, dtype=float)
        L = np.broadcast_to(L, (Q, 3)) if L.ndim == 1 else L.reshape(-1, 3)[:Q]
        if L.shape[0] < Q:
            raise ValueError(f"external_torque: {L.shape[0]} samples for {Q} intervals")
    return J, G, N, Js, Q, n_sub, U[:Q], umax, wmax, np.ascontiguousarray(L)


# ----------------------------------------------------------------------------------------------------------------
# Basilisk

_MAX_EFF_CNT = 36  # length of ArrayMotorTorqueMsgPayload.motorTorque (Basilisk's MAX_EFF_CNT)


def basilisk_run(
    J,
    axes,
    spin_inertia,
    sigma0,
    omega0,
    Omega0,
    wheel_torques,
    period,
    t_final,
    dt,
    max_torque=None,
    max_speed=None,
    external_torque=None,
) -> dict:
    """Fly one Basilisk spacecraft with balanced reaction wheels; see the module docstring.

    Returns ``time`` (Q+1,), ``sigma`` (Q+1, 3) (Basilisk's shadow-switched MRP), ``omega`` (Q+1, 3),
    ``Omega`` (Q+1, N), ``u_applied`` (Q, N) (Basilisk's ``u_current`` at the first RK4 step of each interval,
    i.e. after its clipping and speed rule) and ``H_N`` (Q+1, 3) (Basilisk's ``totRotAngMomPntC_N``; NaN at
    t = 0, where Basilisk has not computed it yet).
    """
    from Basilisk.architecture import messaging
    from Basilisk.simulation import extForceTorque, reactionWheelStateEffector, spacecraft
    from Basilisk.utilities import SimulationBaseClass

    J, G, N, Js, Q, n_sub, U, umax, wmax, L = _common_inputs(
        J, axes, spin_inertia, wheel_torques, period, t_final, dt, max_torque, max_speed, external_torque
    )
    if N > _MAX_EFF_CNT:
        raise ValueError(f"{N} wheels: more than Basilisk's ArrayMotorTorqueMsg holds")
    dt_ns = round(dt * 1e9)
    T_ns = dt_ns * n_sub  # integer nanoseconds: the stop times are exact multiples of the task rate
    if abs(dt_ns - dt * 1e9) > 1e-6 * dt * 1e9:
        raise ValueError(f"dt = {dt} s is not a whole number of nanoseconds")

    sim = SimulationBaseClass.SimBaseClass()
    proc = sim.CreateNewProcess("dynamics")
    proc.addTask(sim.CreateNewTask("dynTask", dt_ns))

    sc = spacecraft.Spacecraft()
    sc.ModelTag = "spacecraft"
    sc.hub.mHub = 100.0  # any mass: no gravity, no force, centre of mass at B
    sc.hub.r_BcB_B = [[0.0], [0.0], [0.0]]
    sc.hub.IHubPntBc_B = J.tolist()  # BalancedWheels add no inertia: the hub carries the whole spacecraft's J
    sc.hub.sigma_BNInit = [[float(v)] for v in np.asarray(sigma0, dtype=float)]
    sc.hub.omega_BN_BInit = [[float(v)] for v in np.asarray(omega0, dtype=float)]

    rw_effector = reactionWheelStateEffector.ReactionWheelStateEffector()
    rw_effector.ModelTag = "wheels"
    wheels = []  # keep the Python objects alive: the effector holds shared pointers to them
    Omega0 = np.broadcast_to(np.asarray(Omega0, dtype=float), (N,))
    for i in range(N):
        rw = reactionWheelStateEffector.RWConfigPayload()
        g = G[:, i]
        rw.gsHat_B = [[float(v)] for v in g]
        # any transverse axes completing a frame (used only by the jitter models)
        w2 = np.cross(g, [1.0, 0.0, 0.0])
        if np.linalg.norm(w2) < 0.01:
            w2 = np.cross(g, [0.0, 1.0, 0.0])
        w2 /= np.linalg.norm(w2)
        rw.w2Hat0_B = [[float(v)] for v in w2]
        rw.w3Hat0_B = [[float(v)] for v in np.cross(g, w2)]
        rw.rWB_B = [[0.0], [0.0], [0.0]]
        rw.RWModel = reactionWheelStateEffector.BalancedWheels
        rw.Js = float(Js[i])
        rw.Jt = rw.Jg = 0.5 * float(Js[i])  # not used by BalancedWheels (no mass properties)
        rw.mass = 1.0  # not used by BalancedWheels
        rw.Omega = float(Omega0[i])  # rad/s (the rwFactory helper takes RPM; the payload is SI)
        rw.Omega_max = -1.0 if wmax is None else float(wmax[i])
        rw.u_max = -1.0 if umax is None else float(umax[i])
        rw.u_min = 0.0
        rw.fCoulomb = rw.fStatic = rw.cViscous = 0.0
        rw.betaStatic = -1.0  # Stribeck friction off
        rw.P_max = -1.0  # no power limit
        rw.label = f"RW{i + 1}"
        rw_effector.addReactionWheel(rw)
        wheels.append(rw)
    sc.addStateEffector(rw_effector)

    # priorities (higher first within a tick): the wheel module reads the command before the spacecraft
    # integrates the step that ends at this tick
    sim.AddModelToTask("dynTask", rw_effector, 300)
    ext = None
    if external_torque is not None:
        ext = extForceTorque.ExtForceTorque()
        ext.ModelTag = "externalTorque"
        sc.addDynamicEffector(ext)
        sim.AddModelToTask("dynTask", ext, 200)
    sim.AddModelToTask("dynTask", sc, 100)

    cmd_msg = messaging.ArrayMotorTorqueMsg()
    payload = messaging.ArrayMotorTorqueMsgPayload()

    def write_command(q: int) -> None:
        torques = [0.0] * _MAX_EFF_CNT
        torques[:N] = [float(v) for v in U[q]]
        payload.motorTorque = torques
        cmd_msg.write(payload, q * T_ns)
        if ext is not None:
            # computeForceTorque copies extTorquePntB_B; with no input message linked UpdateState leaves it alone
            ext.extTorquePntB_B = [[float(v)] for v in L[q]]

    write_command(0)
    rw_effector.rwMotorCmdInMsg.subscribeTo(cmd_msg)
    sim.InitializeSimulation()

    time = np.arange(Q + 1) * (T_ns * 1e-9)
    sigma = np.empty((Q + 1, 3))
    omega = np.empty((Q + 1, 3))
    Omega = np.empty((Q + 1, N))
    H_N = np.empty((Q + 1, 3))
    u_applied = np.empty((Q, N))

    def sample(k: int) -> None:
        st = sc.scStateOutMsg.read()
        sigma[k] = st.sigma_BN
        omega[k] = st.omega_BN_B
        Omega[k] = np.asarray(rw_effector.rwSpeedOutMsg.read().wheelSpeeds)[:N]
        H_N[k] = np.asarray(sc.totRotAngMomPntC_N, dtype=float).ravel()

    sample(0)
    H_N[0] = np.nan  # Basilisk computes its momentum after each integration step: none yet at t = 0
    for q in range(Q):
        if q > 0:
            write_command(q)
        # one tick first, to record u_current (the tick at q T + dt applied command q), then the rest
        sim.ConfigureStopTime(q * T_ns + dt_ns)
        sim.ExecuteSimulation()
        u_applied[q] = [w.u_current for w in wheels]
        if n_sub > 1:
            sim.ConfigureStopTime((q + 1) * T_ns)
            sim.ExecuteSimulation()
        sample(q + 1)
    return {"time": time, "sigma": sigma, "omega": omega, "Omega": Omega, "u_applied": u_applied, "H_N": H_N}


# ----------------------------------------------------------------------------------------------------------------
# SciPy oracle


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def numpy_gyrostat_run(
    J,
    axes,
    spin_inertia,
    sigma0,
    omega0,
    Omega0,
    wheel_torques,
    period,
    t_final,
    dt,
    max_torque=None,
    max_speed=None,
    external_torque=None,
    *,
    rtol: float = 1e-12,
    atol: float = 1e-14,
) -> dict:
    """The balanced-wheel gyrostat of the module docstring, integrated by SciPy (DOP853) interval by interval.

    The state ``[sigma, omega, Omega]`` is integrated over each control interval with the held command (clipped
    per wheel to ``max_torque`` as Basilisk does).  With ``max_speed`` the speed rule is evaluated with the wheel
    speeds at every multiple of ``dt`` and held until the next one, as Basilisk's wheel module does at its task
    rate (an interval is cut into ``dt`` pieces only where the rule changes inside it); without it ``dt`` is not
    used.  The MRP is switched to its shadow set (``|sigma| > 1``) at the end of every piece (the MRP equations
    are regular there; only ``|sigma| -> inf`` is singular).  Returns ``time``, ``sigma``, ``omega``, ``Omega`` and
    ``u_applied`` (Q, N) (the torques of the first piece of each interval).
    """
    J, G, N, Js, Q, n_sub, U, umax, wmax, L = _common_inputs(
        J, axes, spin_inertia, wheel_torques, period, t_final, dt, max_torque, max_speed, external_torque
    )
    J_hub_inv = np.linalg.inv(J - (G * Js) @ G.T)

    def rhs(_t, x, u, Lq):
        s, w, W = x[0:3], x[3:6], x[6:]
        H = J @ w + G @ (Js * W)
        wdot = J_hub_inv @ (-np.cross(w, H) - G @ u + Lq)
        s2 = float(s @ s)
        sdot = 0.25 * ((1.0 - s2) * w + 2.0 * np.cross(s, w) + 2.0 * s * float(s @ w))
        Wdot = u / Js - G.T @ wdot
        return np.concatenate([sdot, wdot, Wdot])

    x = np.concatenate([np.asarray(sigma0, dtype=float), np.asarray(omega0, dtype=float)])
    x = np.concatenate([x, np.broadcast_to(np.asarray(Omega0, dtype=float), (N,))])
    if x[0:3] @ x[0:3] > 1.0:
        x[0:3] = -x[0:3] / (x[0:3] @ x[0:3])
    out = np.empty((Q + 1, 6 + N))
    out[0] = x
    u_applied = np.empty((Q, N))
    h = period / n_sub

    def gate(u_cmd, W):
        """Basilisk's speed rule: no motor torque on a wheel at or beyond its limit that would drive it further."""
        if wmax is None:
            return u_cmd
        return np.where((np.abs(W) >= wmax) & (W * u_cmd >= 0.0), 0.0, u_cmd)

    def advance(x, t0, t1, u, Lq, t_eval=None):
        sol = solve_ivp(rhs, (t0, t1), x, method="DOP853", rtol=rtol, atol=atol, args=(u, Lq), t_eval=t_eval)
        if not sol.success:
            raise RuntimeError(sol.message)
        return sol

    def shadow(x):
        s2 = float(x[0:3] @ x[0:3])
        if s2 > 1.0:
            x[0:3] = -x[0:3] / s2
        return x

    for q in range(Q):
        u_cmd = U[q] if umax is None else np.clip(U[q], -umax, umax)
        t0 = q * period
        u = gate(u_cmd, x[6:])
        u_applied[q] = u
        if wmax is None:
            x = shadow(advance(x, t0, t0 + period, u, L[q]).y[:, -1].copy())
        else:
            # the rule is sampled at every tick t0 + p h; integrate the interval in one piece and keep it if the
            # rule gives the same torques at every tick, else redo it tick by tick
            ticks = t0 + h * np.arange(1, n_sub + 1)
            sol = advance(x, t0, t0 + period, u, L[q], t_eval=ticks)
            if all(np.array_equal(gate(u_cmd, sol.y[6:, p]), u) for p in range(n_sub - 1)):
                x = shadow(sol.y[:, -1].copy())
            else:
                for p in range(n_sub):
                    u_p = gate(u_cmd, x[6:])
                    x = shadow(advance(x, t0 + p * h, t0 + (p + 1) * h, u_p, L[q]).y[:, -1].copy())
        out[q + 1] = x
    return {
        "time": np.arange(Q + 1) * period,
        "sigma": out[:, 0:3],
        "omega": out[:, 3:6],
        "Omega": out[:, 6:],
        "u_applied": u_applied,
    }
