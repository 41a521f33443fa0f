"""The formation assembled from the per-agent CasADi functions, evaluated by CasADi itself.

Used (1) as the simulator backend when no C compiler is available (same
per-agent functions, loaded from ``generated/casadi/*.casadi``), and (2) by the
benchmarks as "a Python loop calling the CasADi function per step".

The RK4 step is one CasADi ``Function``; :meth:`ca.Function.mapaccum` runs the
steps between two outputs inside CasADi, so Python is visited once per output
sample, not once per step.
"""

from __future__ import annotations

import sys

import casadi as ca
import numpy as np

from fsmctl.model.generated_code import casadi_function
from fsmctl.model.problem import PackedProblem

__all__ = ["FormationFunctions", "formation_functions", "simulate_casadi"]


class FormationFunctions:
    """CasADi functions of a packed formation: ``control(t, x, kj)``, ``dynamics(t, x, u)``, ``rk4_step``."""

    def __init__(self, p: PackedProblem):
        self.p = p
        n = p.n_agents
        sliding = casadi_function("sliding_exact" if p.error_model == 1 else "sliding_paper")
        core = casadi_function("control_core")
        plant = casadi_function("plant_rhs")
        ref = casadi_function("reference_rhs")
        dist = casadi_function("disturbance_torque")
        shadow = casadi_function("mrp_shadow")
        consts = casadi_function("sliding_constants")
        gc = [float(consts(p.gains[i])) for i in range(n)]

        t = ca.MX.sym("t")
        x = ca.MX.sym("x", 3 + 6 * n)
        kj = ca.MX.sym("kj", max(p.n_links, 1))
        sd = x[0:3]
        _, wd, wdd = ref(t, sd, p.ref_params)
        parts = [
            sliding(x[3 + 6 * i : 6 + 6 * i], x[6 + 6 * i : 9 + 6 * i], sd, wd, wdd, p.gains[i], gc[i])
            for i in range(n)
        ]
        s = [q[0] for q in parts]
        received = [ca.MX.zeros(3) for _ in range(n)]
        ksum = np.zeros(n)
        for e in range(p.n_links):
            i, j = int(p.link_receiver[e]), int(p.link_sender[e])
            received[i] = received[i] + kj[e] * s[j]
            ksum[i] += p.link_k_i[e]
        u, uu = [], []
        for i in range(n):
            si, se, we, wr, wrd, slope = parts[i]
            ui, uui = core(
                se, we, wr, wrd, si, slope, p.J0[i], p.gains[i], p.delta[i], ksum[i], received[i], p.u_max[i]
            )
            u.append(ui)
            uu.append(uui)
        U = ca.horzcat(*u)
        self.control = ca.Function(
            "formation_control",
            [t, x, kj],
            [
                U,
                ca.horzcat(*uu),
                ca.horzcat(*s),
                ca.horzcat(*[q[1] for q in parts]),
                ca.horzcat(*[q[2] for q in parts]),
            ],
            ["t", "x", "kj"],
            ["u", "u_unsat", "s", "sigma_e", "omega_e"],
        )

        ua = ca.MX.sym("u", 3, n)
        sd_dot, _, _ = ref(t, sd, p.ref_params)
        dx = [sd_dot]
        for i in range(n):
            d = dist(t, p.dist_params[i])
            sdot, wdot = plant(x[3 + 6 * i : 6 + 6 * i], x[6 + 6 * i : 9 + 6 * i], ua[:, i] + d, p.J_true[i])
            dx += [sdot, wdot]
        self.dynamics = ca.Function("formation_dynamics", [t, x, ua], [ca.vertcat(*dx)], ["t", "x", "u"], ["dx"])

        xs = ca.MX.sym("x", 3 + 6 * n)
        blocks = [shadow(xs[0:3])]
        for i in range(n):
            blocks += [shadow(xs[3 + 6 * i : 6 + 6 * i]), xs[6 + 6 * i : 9 + 6 * i]]
        self.shadow = ca.Function("formation_shadow", [xs], [ca.vertcat(*blocks)])
        self._step = None

    def rhs(self, t: float, x: np.ndarray, kj: np.ndarray) -> np.ndarray:
        u = self.control(t, x, kj)[0]
        return np.asarray(self.dynamics(t, x, u)).ravel()

    def rk4_step(self) -> ca.Function:
        """``(xa, t, kj_t, kj_half, kj_end, sample) -> (xa_next, u, u_unsat, s, sigma_e, omega_e)``.

        ``xa = [x, u_hold]`` carries the held torque (zero-order hold) from step to step.
        The three weight vectors are the link weights used by stage 1, stages 2-3 and stage 4;
        :func:`simulate_casadi` passes the step-midpoint weights for all three, like ``formation.c``.
        """
        if self._step is not None:
            return self._step
        p = self.p
        n, L, dt = p.n_agents, max(p.n_links, 1), p.dt
        nx = 3 + 6 * n
        xa = ca.MX.sym("xa", nx + 3 * n)
        x, uh = xa[:nx], xa[nx:]
        t = ca.MX.sym("t")
        k1w, k2w, k4w = (ca.MX.sym(f"kj{i}", L) for i in (1, 2, 4))
        sample = ca.MX.sym("sample")
        continuous = p.hold_steps <= 0
        u1, uu1, s1, se1, we1 = self.control(t, x, k1w)
        u1 = ca.reshape(u1, 3 * n, 1)
        uu1 = ca.reshape(uu1, 3 * n, 1)
        if not continuous:  # zero-order hold: new control only at sample instants
            u1 = ca.if_else(sample, u1, uh)
            uu1 = ca.if_else(sample, uu1, ca.MX.nan(3 * n, 1))
        U1 = ca.reshape(u1, 3, n)

        def stage(tt, xx, kw):
            if continuous:
                return self.dynamics(tt, xx, self.control(tt, xx, kw)[0])
            return self.dynamics(tt, xx, U1)

        d1 = self.dynamics(t, x, U1)
        d2 = stage(t + dt / 2, x + dt / 2 * d1, k2w)
        d3 = stage(t + dt / 2, x + dt / 2 * d2, k2w)
        d4 = stage(t + dt, x + dt * d3, k4w)
        xn = self.shadow(x + dt / 6 * (d1 + 2 * d2 + 2 * d3 + d4))
        flat = [ca.reshape(m, 3 * n, 1) for m in (s1, se1, we1)]
        self._step = ca.Function(
            "rk4_step",
            [xa, t, k1w, k2w, k4w, sample],
            [ca.vertcat(xn, u1), u1, uu1, *flat],
            ["xa", "t", "kj1", "kj2", "kj4", "sample"],
            ["xa_next", "u", "u_unsat", "s", "sigma_e", "omega_e"],
        )
        return self._step


def formation_functions(p: PackedProblem) -> FormationFunctions:
    """Build the formation's CasADi functions for a packed problem."""
    return FormationFunctions(p)


def simulate_casadi(p: PackedProblem, *, progress: bool = False, label: str = "simulate") -> dict:
    """The simulator loop of ``formation.c`` in CasADi's virtual machine (RK4), or SciPy (adaptive)."""
    import time

    f = formation_functions(p)
    n, every = p.n_agents, p.output_every
    t0 = time.perf_counter()
    if p.integrator == 1:
        return _adaptive(f, p, t0)
    step = f.rk4_step()
    chunk = step.mapaccum("chunk", every, [0], [0])
    # outputs at every output_every-th step and at the final one; preallocated (no list of rows + copy)
    T = -(-p.n_steps // every) + 1
    rows = {k: np.zeros((T, n, 3)) for k in ("sigma", "omega", "sigma_e", "omega_e", "s", "u", "u_unsat")}
    rows["t"] = np.zeros(T)
    rows["sigma_d"] = np.zeros((T, 3))
    r = 0
    x = p.x0.copy()
    x = np.asarray(f.shadow(x)).ravel()
    u_hold = np.zeros(3 * n)
    uu_hold = np.zeros(3 * n)
    sat_time = np.zeros(n)
    tv = np.zeros(n)
    uu_max = np.zeros(n)
    u_prev = None
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(
            total=p.n_steps, desc=f"{label} (casadi-vm)", unit="step", unit_scale=True, leave=False, file=sys.stderr
        )
    k = 0
    try:
        while True:
            # outputs at step k (a multiple of output_every)
            tk = p.t0 + k * p.dt
            # link weights at the step midpoint, as in formation.c (simulate_rk4): the value holding on the step
            kw_k = p.link_weights(tk + 0.5 * p.dt) if p.n_links else [0.0]
            u, uu, s, se, we = (np.asarray(v) for v in f.control(tk, x, kw_k))
            if p.hold_steps > 0 and k % p.hold_steps != 0:
                u, uu = u_hold.reshape(n, 3).T, uu_hold.reshape(n, 3).T
            rows["t"][r] = tk
            rows["sigma_d"][r] = x[:3]
            xs = x[3:].reshape(n, 6)
            rows["sigma"][r] = xs[:, :3]
            rows["omega"][r] = xs[:, 3:]
            for key, val in (("u", u), ("u_unsat", uu), ("s", s), ("sigma_e", se), ("omega_e", we)):
                rows[key][r] = val.T
            r += 1
            if k >= p.n_steps:
                break
            m = min(every, p.n_steps - k)
            steps = np.arange(k, k + m)
            ts = p.t0 + steps * p.dt
            # every stage of a step uses the link weights at the step midpoint (see formation.c, simulate_rk4)
            kw_mid = p.link_weights(ts + 0.5 * p.dt) if p.n_links else np.zeros((1, m))
            kw = [kw_mid, kw_mid, kw_mid]
            samples = np.array([1.0 if p.hold_steps <= 0 or s_ % p.hold_steps == 0 else 0.0 for s_ in steps])
            if m == every:
                fn = chunk
            else:
                fn = step.mapaccum("tail", m, [0], [0])
            out = fn(np.concatenate([x, u_hold]), ts, kw[0], kw[1], kw[2], samples)
            xn, U, UU = (np.asarray(v) for v in out[:3])
            if p.hold_steps > 0:  # unsaturated command of a held step = that of its sample
                for c in range(m):
                    UU[:, c] = UU[:, c] if samples[c] else (UU[:, c - 1] if c else uu_hold)
                uu_hold = UU[:, -1].copy()
            x = xn[: 3 + 6 * n, -1].copy()
            u_hold = xn[3 + 6 * n :, -1].copy()
            # as formation.c: the saturation would silently turn a NaN command into -u_max
            if not np.all(np.isfinite(uu)):
                _fail_nonfinite_control(p, tk, uu.T)
            if not np.all(np.isfinite(UU)):
                c = int(np.nonzero(~np.all(np.isfinite(UU), axis=0))[0][0])
                _fail_nonfinite_control(p, float(ts[c]), UU[:, c].reshape(n, 3))
            if not np.all(np.isfinite(x)):
                from fsmctl.simulation.simulator import SimulationError

                raise SimulationError(f"simulation failed: a state became non-finite near t = {ts[-1] + p.dt:.6g} s")
            for c in range(m):
                ua = U[:, c].reshape(n, 3)
                uua = UU[:, c].reshape(n, 3)
                sat_time += p.dt * np.any(np.abs(uua) > p.u_max[:, None], axis=1)
                uu_max = np.maximum(uu_max, np.abs(uua).max(axis=1))
                if u_prev is not None:
                    tv += np.abs(ua - u_prev).sum(axis=1)
                u_prev = ua
            k += m
            if bar is not None:
                bar.update(m)
    finally:
        if bar is not None:
            bar.close()
    raw = {key: v[:r] for key, v in rows.items()}
    raw.update(
        saturated_time=sat_time,
        u_total_variation=tv,
        u_unsat_max=uu_max,
        wall_time=time.perf_counter() - t0,
        backend="casadi-vm",
        steps_taken=p.n_steps,
        steps_rejected=0,
    )
    return raw


def _fail_nonfinite_control(p: PackedProblem, t_bad: float, commands: np.ndarray) -> None:
    """Raise the compiled driver's error for a non-finite torque command; ``commands`` is ``(n, 3)`` at ``t_bad``."""
    from fsmctl.simulation.simulator import SimulationError

    agent = int(np.nonzero(~np.isfinite(np.asarray(commands).reshape(-1, 3)).all(axis=1))[0][0]) + 1
    hint = (
        " (the Remark 6 term alpha|sigma_e|^(alpha-1) is singular with singularity_fix = 'none'; use 'switch')"
        if any(p.gains[:, 5] == 0)
        else " (check inertias, gains and the step size)"
    )
    raise SimulationError(
        f"simulation failed: the control law returned a non-finite torque command at t = {t_bad:.6g} s in agent {agent}"
        + hint
    )


def _adaptive(f: FormationFunctions, p: PackedProblem, t0_wall: float) -> dict:
    """Adaptive fallback: SciPy's RK45 on the CasADi right-hand side (continuous control only).

    The statistics (saturated time, total variation) are sampled on the output grid, not per step.
    """
    import time

    from scipy.integrate import solve_ivp

    from fsmctl.simulation.simulator import SimulationError

    if p.hold_steps > 0:
        raise SimulationError("the adaptive integrator with sampled control needs the compiled backend; use rk4")
    n = p.n_agents
    t_end = p.t0 + p.n_steps * p.dt
    t_eval = p.t0 + np.arange(p.n_outputs) * p.output_every * p.dt
    if p.n_steps % p.output_every == 0:
        t_eval[-1] = t_end  # the final state, exactly (rounding could put it outside t_span)
    sol = solve_ivp(
        lambda t, x: f.rhs(t, x, p.link_weights(t) if p.n_links else [0.0]),
        (p.t0, t_end),
        np.asarray(f.shadow(p.x0)).ravel(),
        t_eval=t_eval,
        rtol=p.rtol,
        atol=p.atol,
        method="RK45",
    )
    if not sol.success:
        raise SimulationError(f"adaptive integration failed: {sol.message}")
    T = len(sol.t)
    raw = {k: np.zeros((T, n, 3)) for k in ("sigma", "omega", "sigma_e", "omega_e", "s", "u", "u_unsat")}
    # solve_ivp cannot reset states, so the MRPs are integrated unswitched (valid below 360 deg); the recorded
    # attitudes are mapped to the shadow set (|sigma| <= 1) like the compiled loop's
    states = np.zeros((T, sol.y.shape[0]))
    for r, (tk, yk) in enumerate(zip(sol.t, sol.y.T, strict=True)):
        xk = states[r] = np.asarray(f.shadow(yk)).ravel()
        u, uu, s, se, we = (np.asarray(v).T for v in f.control(tk, xk, p.link_weights(tk) if p.n_links else [0.0]))
        xs = xk[3:].reshape(n, 6)
        raw["sigma"][r] = xs[:, :3]
        raw["omega"][r] = xs[:, 3:]
        for key, val in (("u", u), ("u_unsat", uu), ("s", s), ("sigma_e", se), ("omega_e", we)):
            raw[key][r] = val
    del sol.y
    if not np.all(np.isfinite(raw["u_unsat"])):
        k = int(np.nonzero(~np.all(np.isfinite(raw["u_unsat"]), axis=(1, 2)))[0][0])
        _fail_nonfinite_control(p, float(sol.t[k]), raw["u_unsat"][k])
    dt_out = p.output_every * p.dt
    raw.update(
        t=sol.t,
        sigma_d=states[:, :3],
        saturated_time=dt_out * np.sum(np.any(np.abs(raw["u_unsat"]) > p.u_max[None, :, None], axis=2), axis=0),
        u_total_variation=np.abs(np.diff(raw["u"], axis=0)).sum(axis=(0, 2)),
        u_unsat_max=np.abs(raw["u_unsat"]).max(axis=(0, 2)),
        wall_time=time.perf_counter() - t0_wall,
        backend="casadi-vm",
        steps_taken=int(sol.nfev // 6),
        steps_rejected=0,
    )
    return raw
