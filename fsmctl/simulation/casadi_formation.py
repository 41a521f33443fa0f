"""The formation assembled from the law's and the model's CasADi functions, evaluated by CasADi itself.

Used (1) as the simulator backend when no C compiler is available (``FSMCTL_NO_COMPILE=1``: the functions are
the serialized ``*.casadi`` files of ``generated/casadi`` and of the law's folder), and (2) by the benchmarks
as "a Python loop calling CasADi".

It flies any law through the contract of :mod:`fsmctl.symbolic.law` (``law_constants``, ``law_local_<model>``,
``law_control_<model>``) with the semantics of the compiled engine, ``fsmctl/csrc/formation.c``:

* state ``x = [sigma_d, (sigma_i, omega_i, z_i) per agent]`` (:attr:`PackedProblem.stride`,
  :meth:`PackedProblem.agent_slice`); MRPs are switched to the shadow set after every step;
* the neighbour aggregation is :func:`fsmctl.model.coupling.aggregate`, with the link weights
  ``k^j_ij(t)`` of :meth:`PackedProblem.link_weights`; the fixed-step RK4 loop evaluates them at the step
  midpoint for all four stages (:func:`step_times`), the adaptive loop at each stage's own time;
* zero-order hold (``hold_steps > 0``): the torque, the commanded torque, the law-state rates and the
  broadcast are computed at the sample instants only and held in between;
* what is recorded at an output time: the state, the true error state (the model's ``error_state_*``), the
  broadcast and the applied torque of the step's first stage; the run statistics with :class:`RunStatistics`;
* a non-finite torque command or state stops the run with the compiled engine's error.

Fixed-step RK4: the step is one CasADi ``Function`` (:meth:`FormationFunctions.rk4_step`, built on
:func:`rk4_update`); :meth:`casadi.Function.mapaccum` runs the steps between two outputs inside CasADi, so
Python is visited once per output sample.  Adaptive (``dopri45``): the Dormand-Prince 5(4) loop of
``formation.c`` (its step-size control, events and statistics) with one CasADi call per attempted step.
"""

from __future__ import annotations

import sys
import time

import casadi as ca
import numpy as np

from fsmctl.model.coupling import aggregate
from fsmctl.model.generated_code import casadi_function
from fsmctl.model.problem import PackedProblem
from fsmctl.simulation.failures import SimulationError, nonfinite_hint

__all__ = [
    "FormationFunctions",
    "RunStatistics",
    "formation_functions",
    "rk4_update",
    "simulate_casadi",
    "step_times",
]


# ----------------------------------------------------------------------------- the rules, written once


def step_times(p: PackedProblem, k: int | np.ndarray):
    """Times of RK4 step ``k`` (formation.c ``simulate_rk4``): ``(t, t_half, t_next, t_link)``.

    ``t_link`` is where the piecewise-constant link weights are read for all four stages: the step midpoint,
    i.e. the value that holds on the step when no switch lies strictly inside it (a switch on the step grid
    is then integrated exactly).  ``k`` may be an array of step indices.
    """
    k = np.asarray(k, dtype=float) if isinstance(k, np.ndarray) else float(k)
    half = p.t0 + (k + 0.5) * p.dt
    return p.t0 + k * p.dt, half, p.t0 + (k + 1.0) * p.dt, half


def rk4_update(f, x, k1, dt: float, t_half, t_next):
    """Stages 2-4 and the update of one classical RK4 step, given the first stage's slope ``k1``.

    ``f(t, x)`` is the right-hand side of stages 2-4 (its link weights and any held control bound by the
    caller); works on NumPy arrays and on CasADi expressions alike.  The arithmetic is formation.c's.
    """
    k2 = f(t_half, x + 0.5 * dt * k1)
    k3 = f(t_half, x + 0.5 * dt * k2)
    k4 = f(t_next, x + dt * k3)
    return x + dt / 6.0 * (k1 + 2.0 * (k2 + k3) + k4)


class RunStatistics:
    """Saturated time, total variation and largest commanded torque of a run (formation.c ``accumulate``).

    Every interval adds: ``h`` to ``saturated_time[i]`` when some ``|u_commanded_i,k| > u_max_i``,
    ``sum_k |u_i,k - u_i,k(previous interval)|`` to ``u_total_variation[i]`` (not for the first interval),
    and ``max_k |u_commanded_i,k|`` into ``u_unsat_max[i]``.
    """

    def __init__(self, u_max: np.ndarray):
        self.u_max = np.asarray(u_max, dtype=float).reshape(-1)
        n = self.u_max.size
        self.saturated_time = np.zeros(n)
        self.u_total_variation = np.zeros(n)
        self.u_unsat_max = np.zeros(n)
        self._u_prev: np.ndarray | None = None

    def add(self, u, u_commanded, h) -> None:
        """Intervals of lengths ``h`` (scalar or ``(m,)``) over which ``u`` / ``u_commanded`` (``(m, n, 3)``) were applied."""
        n = self.u_max.size
        u = np.asarray(u, dtype=float).reshape(-1, n, 3)
        uu = np.asarray(u_commanded, dtype=float).reshape(-1, n, 3)
        if u.shape[0] == 0:
            return
        h = np.broadcast_to(np.asarray(h, dtype=float), (u.shape[0],))
        saturated = np.any(np.abs(uu) > self.u_max[None, :, None], axis=2)
        # running sums in the C loop's order (cumsum adds sequentially): the same doubles, not just close ones
        added = np.where(saturated, h[:, None], 0.0)
        self.saturated_time = np.cumsum(np.vstack([self.saturated_time, added]), axis=0)[-1]
        self.u_unsat_max = np.maximum(self.u_unsat_max, np.abs(uu).max(axis=(0, 2)))
        seq = u if self._u_prev is None else np.concatenate([self._u_prev[None], u])
        steps = np.abs(np.diff(seq, axis=0))
        variation = (steps[:, :, 0] + steps[:, :, 1]) + steps[:, :, 2]
        self.u_total_variation = np.cumsum(np.vstack([self.u_total_variation, variation]), axis=0)[-1]
        self._u_prev = u[-1].copy()

    def as_dict(self) -> dict:
        return {
            "saturated_time": self.saturated_time,
            "u_total_variation": self.u_total_variation,
            "u_unsat_max": self.u_unsat_max,
        }


# ----------------------------------------------------------------------------- the formation in CasADi


class FormationFunctions:
    """CasADi functions of a packed formation flying ``p.law``.

    * ``control(t, x, kw) -> (u, u_commanded, z_dot, broadcast)``: every agent's law (``3 x n``, ``3 x n``,
      ``nz x n``, ``nb x n``) with the link weights ``kw`` (``k^j_ij`` of every link);
    * ``dynamics(t, x, u, z_dot) -> dx``: reference, plants (with the disturbances) and law states;
    * ``errors(t, x) -> (sigma_e, omega_e)``: the true error state (``3 x n`` each), the model's ``error_state_*``;
    * ``shadow(x)``: every MRP with ``|sigma| > 1`` switched to its shadow;
    * ``stage_one(t, x, kw, hold, sample) -> (dx, applied)``: the first stage of a step, where the control is
      computed (continuous control, or ``sample`` = 1) or the ``hold`` is applied; ``hold`` and ``applied``
      are the flat control vector ``[vec(u), vec(u_commanded), vec(z_dot), vec(broadcast)]``
      (:meth:`unpack_control` splits it).
    """

    def __init__(self, p: PackedProblem):
        self.p = p
        law = p.law
        n, nz, nb, S = p.n_agents, p.n_states, p.n_broadcast, p.stride
        self.n, self.nz, self.nb = n, nz, nb
        self.nx = 3 + S * n
        self.n_control = (6 + nz + nb) * n
        self.continuous = p.hold_steps <= 0
        model = "exact" if p.error_model == 1 else "paper"
        local = law.casadi(f"law_local_{model}")
        control = law.casadi(f"law_control_{model}")
        constants_of = law.casadi("law_constants")
        plant = casadi_function("plant_rhs")
        ref = casadi_function("reference_rhs")
        dist = casadi_function("disturbance_torque")
        shadow = casadi_function("mrp_shadow")
        error_state = casadi_function(f"error_state_{model}")
        konst = [constants_of.call([ca.DM(p.params[i])])[0] for i in range(n)]
        L = max(p.n_links, 1)
        self.n_weights = L

        t = ca.MX.sym("t")
        x = ca.MX.sym("x", self.nx)
        kw = ca.MX.sym("kw", L)
        sd = x[0:3]
        sd_dot, wd, wdd = ref(t, sd, p.ref_params)
        agents = [x[p.agent_slice(i)] for i in range(n)]
        sig = [a[0:3] for a in agents]
        om = [a[3:6] for a in agents]
        zs = [a[6:S] for a in agents]
        common = [
            (t, sig[i], om[i], zs[i], sd, wd, wdd, ca.DM(p.J0[i]), ca.DM(p.params[i]), konst[i]) for i in range(n)
        ]
        local_out = [local(*common[i]) for i in range(n)]
        b = [o[0] for o in local_out]
        received, k_sum, k_received_sum = aggregate(
            b,
            [kw[e] for e in range(p.n_links)],
            p.link_receiver,
            p.link_sender,
            p.link_k_i,
            zero=lambda: ca.MX.zeros(nb),
        )
        outs = [
            control(
                *common[i],
                local_out[i][1],
                float(k_sum[i]),
                received[i],
                k_received_sum[i],
                float(p.u_max[i]),
            )
            for i in range(n)
        ]
        U, UU, ZD = (ca.horzcat(*[o[k] for o in outs]) for k in range(3))
        B = ca.horzcat(*b)
        if nz == 0:
            ZD = ca.MX(0, n)
        if nb == 0:
            B = ca.MX(0, n)
        self.control = ca.Function(
            "formation_control",
            [t, x, kw],
            [U, UU, ZD, B],
            ["t", "x", "kw"],
            ["u", "u_commanded", "z_dot", "broadcast"],
        )

        ua = ca.MX.sym("u", 3, n)
        za = ca.MX.sym("z_dot", nz, n)
        dx = [sd_dot]
        for i in range(n):
            d = dist(t, p.dist_params[i])
            sdot, wdot = plant(sig[i], om[i], ua[:, i] + d, ca.DM(p.J_true[i]))
            dx += [sdot, wdot, za[:, i]]
        self.dynamics = ca.Function(
            "formation_dynamics", [t, x, ua, za], [ca.vertcat(*dx)], ["t", "x", "u", "z_dot"], ["dx"]
        )

        errs = [error_state(sig[i], om[i], sd, wd) for i in range(n)]
        self.errors = ca.Function(
            "formation_errors",
            [t, x],
            [ca.horzcat(*[e[0] for e in errs]), ca.horzcat(*[e[1] for e in errs])],
            ["t", "x"],
            ["sigma_e", "omega_e"],
        )

        xs = ca.MX.sym("x", self.nx)
        blocks = [slice(0, 3)] + [slice(p.agent_slice(i).start, p.agent_slice(i).start + 3) for i in range(n)]
        parts, last = [], 0
        for blk in blocks:
            s = xs[blk]
            parts += [xs[last : blk.start], ca.if_else(ca.dot(s, s) > 1.0, shadow(s), s)]
            last = blk.stop
        parts.append(xs[last:])
        self.shadow = ca.Function("formation_shadow", [xs], [ca.vertcat(*parts)], ["x"], ["x_shadow"])

        hold = ca.MX.sym("hold", self.n_control)
        sample = ca.MX.sym("sample")
        applied = self._applied(t, x, kw, hold, sample)
        u_a, _, z_a, _ = self.unpack_control(applied)
        self.stage_one = ca.Function(
            "formation_stage_one",
            [t, x, kw, hold, sample],
            [self.dynamics(t, x, u_a, z_a), applied],
            ["t", "x", "kw", "hold", "sample"],
            ["dx", "applied"],
        )
        self._step = None
        self._dopri = None

    # -- pieces

    def pack_control(self, u, uu, zd, b):
        return ca.vertcat(ca.vec(u), ca.vec(uu), ca.vec(zd), ca.vec(b))

    def unpack_control(self, c):
        """``(u 3 x n, u_commanded 3 x n, z_dot nz x n, broadcast nb x n)`` of a flat control vector."""
        n, nz, nb = self.n, self.nz, self.nb
        o = np.cumsum([0, 3 * n, 3 * n, nz * n, nb * n])
        return (
            ca.reshape(c[o[0] : o[1]], 3, n),
            ca.reshape(c[o[1] : o[2]], 3, n),
            ca.reshape(c[o[2] : o[3]], nz, n),
            ca.reshape(c[o[3] : o[4]], nb, n),
        )

    def unpack_control_numpy(self, c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`unpack_control` of a NumPy array ``(n_control,)`` or ``(n_control, m)``: arrays ``(m, n, k)``."""
        n, nz, nb = self.n, self.nz, self.nb
        c = np.asarray(c, dtype=float).reshape(self.n_control, -1)
        o = np.cumsum([0, 3 * n, 3 * n, nz * n, nb * n])
        m = c.shape[1]
        return tuple(c[o[j] : o[j + 1]].T.reshape(m, n, w) for j, w in enumerate((3, 3, nz, nb)))  # type: ignore[return-value]

    def _applied(self, t, x, kw, hold, sample):
        """The control of a step's first stage: computed (continuous, or at a sample instant) or held."""
        fresh = self.pack_control(*self.control(t, x, kw))
        return fresh if self.continuous else ca.if_else(sample, fresh, hold)

    def _stage(self, kw, applied, commanded: list):
        """The right-hand side of the later stages of a step: the control computed again (continuous) or held."""
        if self.continuous:

            def f(tt, xx):
                u, uu, zd, _ = self.control(tt, xx, kw)
                commanded.append(ca.vec(uu))
                return self.dynamics(tt, xx, u, zd)

            return f
        u_a, _, z_a, _ = self.unpack_control(applied)
        return lambda tt, xx: self.dynamics(tt, xx, u_a, z_a)

    def rhs(self, t: float, x: np.ndarray, kw) -> np.ndarray:
        """The formation's right-hand side with the control computed at ``(t, x)`` (link weights ``kw``)."""
        u, _, zd, _ = self.control(t, x, self.weights_arg(kw))
        return np.asarray(self.dynamics(t, x, u, zd)).ravel()

    def weights_arg(self, kw) -> np.ndarray:
        kw = np.asarray(kw, dtype=float)
        return kw if self.p.n_links else np.zeros((1, *kw.shape[1:]))

    # -- integrators

    def rk4_step(self) -> ca.Function:
        """``(xa, t, t_half, t_next, kw, sample) -> (xa_next, applied, commanded)``: one RK4 step (formation.c).

        ``xa = [x, hold]`` carries the held control (zero-order hold) from step to step; ``kw`` are the link
        weights of all four stages (:func:`step_times`: the step midpoint's); ``sample`` (0/1) says whether the
        control is computed at this step (ignored with continuous control).  ``applied`` is the flat control
        of the first stage; ``commanded`` the commanded torques of stages 2-4 (continuous control; else
        empty), for the non-finite check.
        """
        if self._step is not None:
            return self._step
        p, nx = self.p, self.nx
        xa = ca.MX.sym("xa", nx + self.n_control)
        x, hold = xa[:nx], xa[nx:]
        t, th, t1, sample = (ca.MX.sym(s) for s in ("t", "t_half", "t_next", "sample"))
        kw = ca.MX.sym("kw", self.n_weights)
        k1, applied = self.stage_one(t, x, kw, hold, sample)
        commanded: list = []
        xn = self.shadow(rk4_update(self._stage(kw, applied, commanded), x, k1, p.dt, th, t1))
        self._step = ca.Function(
            "rk4_step",
            [xa, t, th, t1, kw, sample],
            [ca.vertcat(xn, applied), applied, ca.vertcat(*commanded) if commanded else ca.MX(0, 1)],
            ["xa", "t", "t_half", "t_next", "kw", "sample"],
            ["xa_next", "applied", "commanded"],
        )
        return self._step

    def dopri_attempt(self) -> ca.Function:
        """``(x, k1, applied, t, h, kw) -> (x_next, k7, err, commanded)``: one Dormand-Prince 5(4) attempt.

        ``kw`` (``L x 6``): the link weights at the times of stages 2-7; ``err``: formation.c's RMS error norm
        (``atol + rtol max(|x|, |x_next|)``); ``commanded``: the commanded torques of stages 2-7 (continuous
        control), for the non-finite check.
        """
        if self._dopri is not None:
            return self._dopri
        p, nx = self.p, self.nx
        x, k1 = ca.MX.sym("x", nx), ca.MX.sym("k1", nx)
        applied = ca.MX.sym("applied", self.n_control)
        t, h = ca.MX.sym("t"), ca.MX.sym("h")
        kw = ca.MX.sym("kw", self.n_weights, 6)
        commanded: list = []

        def f(stage, tt, xx):
            return self._stage(kw[:, stage], applied, commanded)(tt, xx)

        k2 = f(0, t + _C2 * h, x + h * _A21 * k1)
        k3 = f(1, t + _C3 * h, x + h * (_A31 * k1 + _A32 * k2))
        k4 = f(2, t + _C4 * h, x + h * (_A41 * k1 + _A42 * k2 + _A43 * k3))
        k5 = f(3, t + _C5 * h, x + h * (_A51 * k1 + _A52 * k2 + _A53 * k3 + _A54 * k4))
        k6 = f(4, t + h, x + h * (_A61 * k1 + _A62 * k2 + _A63 * k3 + _A64 * k4 + _A65 * k5))
        xn = x + h * (_B1 * k1 + _B3 * k3 + _B4 * k4 + _B5 * k5 + _B6 * k6)
        k7 = f(5, t + h, xn)
        e = h * (_E1 * k1 + _E3 * k3 + _E4 * k4 + _E5 * k5 + _E6 * k6 + _E7 * k7)
        sc = p.atol + p.rtol * ca.fmax(ca.fabs(x), ca.fabs(xn))
        err = ca.sqrt(ca.sum1((e / sc) ** 2) / nx)
        self._dopri = ca.Function(
            "dopri_attempt",
            [x, k1, applied, t, h, kw],
            [xn, k7, err, ca.vertcat(*commanded) if commanded else ca.MX(0, 1)],
            ["x", "k1", "applied", "t", "h", "kw"],
            ["x_next", "k7", "err", "commanded"],
        )
        return self._dopri


# Dormand-Prince 5(4) coefficients (formation.c)
_C2, _C3, _C4, _C5 = 1.0 / 5, 3.0 / 10, 4.0 / 5, 8.0 / 9
_A21 = 1.0 / 5
_A31, _A32 = 3.0 / 40, 9.0 / 40
_A41, _A42, _A43 = 44.0 / 45, -56.0 / 15, 32.0 / 9
_A51, _A52, _A53, _A54 = 19372.0 / 6561, -25360.0 / 2187, 64448.0 / 6561, -212.0 / 729
_A61, _A62, _A63, _A64, _A65 = 9017.0 / 3168, -355.0 / 33, 46732.0 / 5247, 49.0 / 176, -5103.0 / 18656
_B1, _B3, _B4, _B5, _B6 = 35.0 / 384, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84
_E1, _E3, _E4, _E5, _E6, _E7 = 71.0 / 57600, -71.0 / 16695, 71.0 / 1920, -17253.0 / 339200, 22.0 / 525, -1.0 / 40
_DOPRI_STAGE_TIMES = (_C2, _C3, _C4, _C5, 1.0, 1.0)


def formation_functions(p: PackedProblem) -> FormationFunctions:
    """Build the formation's CasADi functions for a packed problem."""
    return FormationFunctions(p)


# ----------------------------------------------------------------------------- the loops


class _Recorder:
    """The output rows (formation.c ``record``), preallocated."""

    def __init__(self, f: FormationFunctions, capacity: int):
        p, n = f.p, f.n
        self.f = f
        self.rows = {k: np.zeros((capacity, n, 3)) for k in ("sigma", "omega", "sigma_e", "omega_e", "u", "u_unsat")}
        self.rows["broadcast"] = np.zeros((capacity, n, p.n_broadcast))
        self.rows["z"] = np.zeros((capacity, n, p.n_states))
        self.rows["t"] = np.zeros(capacity)
        self.rows["sigma_d"] = np.zeros((capacity, 3))
        self.written = 0

    def record(self, t: float, x: np.ndarray, applied: np.ndarray) -> None:
        r, p, n = self.written, self.f.p, self.f.n
        if r >= self.rows["t"].size:
            return
        self.written += 1
        u, uu, _, b = self.f.unpack_control_numpy(applied)
        se, we = (np.asarray(v).T for v in self.f.errors(t, x))
        agents = x[3:].reshape(n, p.stride)
        rows = self.rows
        rows["t"][r] = t
        rows["sigma_d"][r] = x[:3]
        rows["sigma"][r] = agents[:, 0:3]
        rows["omega"][r] = agents[:, 3:6]
        rows["z"][r] = agents[:, 6:]
        rows["sigma_e"][r] = se
        rows["omega_e"][r] = we
        rows["u"][r] = u[0]
        rows["u_unsat"][r] = uu[0]
        rows["broadcast"][r] = b[0]

    def result(self) -> dict:
        return {k: v[: self.written] for k, v in self.rows.items()}


def _fail(p: PackedProblem, what: str, t_bad: float, who: str, hint: bool = True):
    raise SimulationError(
        f"simulation failed: {what} at t = {t_bad:.6g} s in {who}" + (nonfinite_hint(p) if hint else "")
    )


def _check_commands(p: PackedProblem, t_bad: float, commanded: np.ndarray) -> None:
    """formation.c ``check_commands``: a non-finite commanded torque stops the run (the limit would hide it)."""
    c = np.asarray(commanded, dtype=float).reshape(p.n_agents, 3)
    ok = np.isfinite(c).all(axis=1)
    if not ok.all():
        agent = int(np.nonzero(~ok)[0][0]) + 1
        _fail(p, "the control law returned a non-finite torque command", t_bad, f"agent {agent}")


def _check_state(p: PackedProblem, t_bad: float, x: np.ndarray) -> None:
    bad = np.nonzero(~np.isfinite(x))[0]
    if bad.size:
        k = int(bad[0])
        who = "the reference" if k < 3 else f"agent {(k - 3) // p.stride + 1}"
        _fail(p, "a state became non-finite", t_bad, who)


def _progress_bar(p: PackedProblem, progress: bool, label: str):
    if not progress:
        return None
    from tqdm.auto import tqdm

    return tqdm(
        total=p.n_steps, desc=f"{label} (casadi-vm)", unit="step", unit_scale=True, leave=False, file=sys.stderr
    )


def simulate_casadi(p: PackedProblem, *, progress: bool = False, label: str = "simulate") -> dict:
    """The simulator loop of ``formation.c`` in CasADi's virtual machine: fixed-step RK4 or adaptive dopri45.

    Returns the raw arrays of :func:`fsmctl.simulation.simulator.simulate_packed` (``backend="casadi-vm"``).
    """
    t_start = time.perf_counter()
    f = formation_functions(p)
    bar = _progress_bar(p, progress, label)
    try:
        if p.integrator == 1:
            rec, stats, taken, rejected = _run_dopri(f, bar)
        else:
            rec, stats, taken, rejected = _run_rk4(f, bar)
    finally:
        if bar is not None:
            bar.close()
    raw = rec.result()
    raw.update(stats.as_dict())
    raw.update(wall_time=time.perf_counter() - t_start, backend="casadi-vm", steps_taken=taken, steps_rejected=rejected)
    return raw


def _run_rk4(f: FormationFunctions, bar):
    p, n, nx = f.p, f.n, f.nx
    every = p.output_every
    step = f.rk4_step()
    chunks = {every: step.mapaccum("chunk", every, [0], [0])}
    rec = _Recorder(f, p.n_steps // every + 1)
    stats = RunStatistics(p.u_max)
    x = np.asarray(f.shadow(p.x0)).ravel()
    hold = np.zeros(f.n_control)
    continuous = f.continuous
    k = 0
    while True:
        # the step's first stage at the output time (formation.c: stage_one, then record)
        t, _, _, t_link = step_times(p, k)
        sample = 1.0 if continuous or k % p.hold_steps == 0 else 0.0
        _, applied = f.stage_one(t, x, f.weights_arg(p.link_weights(t_link)), hold, sample)
        applied = np.asarray(applied).ravel()
        _check_commands(p, t, f.unpack_control_numpy(applied)[1])
        rec.record(t, x, applied)
        if k >= p.n_steps:
            break
        m = min(every, p.n_steps - k)
        steps = np.arange(k, k + m)
        ts, ths, t1s, t_links = step_times(p, steps)
        kw = f.weights_arg(p.link_weights(t_links))
        samples = np.ones(m) if continuous else (steps % p.hold_steps == 0).astype(float)
        if m not in chunks:
            chunks[m] = step.mapaccum("tail", m, [0], [0])
        xa, applied_all, commanded = (
            np.asarray(v) for v in chunks[m](np.concatenate([x, hold]), ts, ths, t1s, kw, samples)
        )
        states = xa[:nx].reshape(nx, m)
        u, uu, _, _ = f.unpack_control_numpy(applied_all)
        if not (np.isfinite(uu).all() and np.isfinite(commanded).all() and np.isfinite(states).all()):
            for c in range(m):  # formation.c's checks, in its order
                _check_commands(p, float(ts[c]), uu[c])
                if continuous:
                    for s, tt in enumerate((ths[c], ths[c], t1s[c])):
                        _check_commands(p, float(tt), commanded[3 * n * s : 3 * n * (s + 1), c])
                _check_state(p, float(t1s[c]), states[:, c])
        stats.add(u, uu, p.dt)
        x = states[:, -1].copy()
        hold = xa[nx:, -1].copy()
        k += m
        if bar is not None:
            bar.update(m)
    return rec, stats, p.n_steps, 0


def _run_dopri(f: FormationFunctions, bar):
    """formation.c ``simulate_dopri``: step-size control, output and sample events, statistics per accepted step."""
    p, n = f.p, f.n
    attempt = f.dopri_attempt()
    rec = _Recorder(f, p.n_outputs + 1)
    stats = RunStatistics(p.u_max)
    t0, t_end = p.t0, p.t0 + p.n_steps * p.dt
    out_dt = p.output_every * p.dt
    continuous = f.continuous
    hold_dt = 0.0 if continuous else p.hold_steps * p.dt
    h_min = 1e-12 * max(1.0, p.dt * p.n_steps)  # as fsmctl.simulation.simulator passes to the C loop
    max_steps = 200 * p.n_steps + 10_000
    x = np.asarray(f.shadow(p.x0)).ravel()
    hold = np.zeros(f.n_control)
    m_out = q_hold = attempts = taken = rejected = 0
    t, h, first = t0, p.dt, True
    reported = 0
    while True:
        eps_t = 1e-12 * max(1.0, abs(t))
        sample = False
        if not continuous and abs(t - (t0 + q_hold * hold_dt)) <= eps_t:
            sample = True
            q_hold += 1
        k1, applied = f.stage_one(t, x, f.weights_arg(p.link_weights(t)), hold, float(continuous or sample or first))
        k1, applied = np.asarray(k1).ravel(), np.asarray(applied).ravel()
        hold = applied
        u_snap, uu_snap, _, _ = f.unpack_control_numpy(applied)
        _check_commands(p, t, uu_snap)
        if abs(t - (t0 + m_out * out_dt)) <= eps_t:
            rec.record(t, x, applied)
            m_out += 1
        if t >= t_end - eps_t:
            break
        t_next = min(t_end, t0 + m_out * out_dt)
        if not continuous:
            t_next = min(t_next, t0 + q_hold * hold_dt)
        rejected_in_row = False
        while True:
            attempts += 1
            if attempts > max_steps:
                raise SimulationError("simulation failed: the adaptive integrator exceeded its step budget")
            hs = min(h, t_next - t)
            lands = hs >= t_next - t - eps_t
            if lands:
                hs = t_next - t
            times = np.array([t + c * hs for c in _DOPRI_STAGE_TIMES])
            kw = f.weights_arg(p.link_weights(times))
            xn, _, err, commanded = (np.asarray(v) for v in attempt(x, k1, applied, t, hs, kw.reshape(-1, 6)))
            err = float(np.asarray(err).reshape(()))
            bad = None
            if continuous:
                for s in range(6):
                    c = commanded[3 * n * s : 3 * n * (s + 1)].ravel()
                    if not np.isfinite(c).all():
                        bad = (float(times[s]), c)
                        break
            if not np.isfinite(err):
                err = 1e10
            factor = 0.9 * err**-0.2 if err > 0 else 5.0
            factor = min(5.0, max(0.2, factor))
            if err <= 1.0:
                if bad is not None:
                    _check_commands(p, *bad)
                stats.add(u_snap, uu_snap, hs)
                first = False
                x = xn.ravel()
                t = t_next if lands else t + hs
                h_new = hs * (min(1.0, factor) if rejected_in_row else factor)
                h = max(h, h_new) if (lands and hs < h) else h_new  # a step shortened to land on an event keeps h
                break
            rejected += 1
            rejected_in_row = True
            h = hs * factor
            if h < h_min:
                if bad is not None:
                    _check_commands(p, *bad)
                raise SimulationError(
                    f"simulation failed: the adaptive step size fell below h_min at t = {t:.6g} s "
                    "(discontinuous control? use rk4 or a boundary layer)"
                )
        x = np.asarray(f.shadow(x)).ravel()
        _check_state(p, t, x)
        taken += 1
        if bar is not None:
            done = int((t - t0) / p.dt)
            bar.update(done - reported)
            reported = done
    return rec, stats, taken, rejected
