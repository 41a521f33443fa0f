"""Theorem 2 (robustness, Liang et al. 2012, eqs 29-33): the exact uncertainty and the delta it needs.

Symbolic part
    The exact lumped uncertainty ``Delta_d`` of eq 29 (:func:`fsmctl.symbolic.model.lagrange_uncertainty`)
    contains ``sigma_e_ddot`` and hence the control itself, so the printed condition
    ``(delta_i)_k > |M0^-1 G^-T Delta_d_i|_k`` is circular.  The correct statement works
    with the sliding variable directly.  With the true inertia ``J = J0 + Delta_J``, the law
    built on ``J0`` gives (proved in :func:`sliding_dynamics_identity`)::

        s_dot = -P (delta o sgn(s) + coordination) + P w0 + (P - I) a_eq,
        P  = G J^-1 J0 G^-1,
        w0 = G J0^-1 (u_d - omega^x Delta_J omega - Delta_J omega_r_dot),
        a_eq = -(G_dot omega_e + c1 sigma_e_dot + c2 alpha |sigma_e|^(alpha-1) o sigma_e_dot).

    For ``Delta_J = kappa J0`` (the paper's ``0.3 J0``) ``P = I/(1 + kappa)`` and the
    sufficient condition is ``(delta_i)_k > |w0 - kappa a_eq|_k`` (times nothing: the factor
    ``1/(1+kappa)`` multiplies both the switching and the coordination term, which stays
    dissipative under Theorem 1's condition).

Numeric part
    :func:`delta_requirements` evaluates ``d = s_dot`` at ``delta = 0``, no coordination
    (and ``P``), by automatic differentiation of the *generated* functions (the paper's law as it flies,
    ``generated/laws/fsm``: ``law_constants``, ``law_local_*``, ``law_control_*``; the model's ``plant_rhs``)
    along the true rigid-body motion,
    over a stated box of ``(sigma_e, omega_e)`` and the bound boxes of ``omega_d``,
    ``omega_d_dot`` and the disturbance, and on the reference trajectory itself.
"""

from __future__ import annotations

import functools
import json
import math
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from fsmctl.errors import InputError
from fsmctl.model.casadi_eval import evaluate_mapped
from fsmctl.model.generated_code import casadi_function, generated_dir, law_sx_function
from fsmctl.model.laws import LawCode, resolve_law
from fsmctl.model.scenario import Scenario

__all__ = [
    "AgentDelta",
    "Region",
    "Theorem2Numeric",
    "delta_requirements",
    "delta_margin",
    "drift_function",
    "format_vector",
    "fsm_deltas",
    "fsm_parameters",
    "proportional_kappa",
    "reference_delta_requirement",
]


@dataclass(frozen=True)
class Region:
    """The state box the requirement is computed over: ``|sigma_e,k| <= sigma``, ``|omega_e,k| <= omega``.

    Theorem 2 (Liang et al. 2012, eqs 29-33) needs ``(delta_i)_k > |M0i^-1 G_ei^-T Delta_d_i|_k`` wherever the
    agent flies; :func:`delta_requirements` evaluates the right-hand side over this box.

    Parameters
    ----------
    sigma : float
        Bound of each MRP error component.
    omega : float
        Bound of each rate error component (rad/s).

    Examples
    --------
    >>> from fsmctl.proofs import Region
    >>> Region().describe()
    '|sigma_e,k| <= 0.05, |omega_e,k| <= 0.05 rad/s'
    """

    sigma: float = 0.05
    omega: float = 0.05
    """rad/s"""

    def describe(self) -> str:
        """One line naming the box (for reports)."""
        return f"|sigma_e,k| <= {self.sigma:g}, |omega_e,k| <= {self.omega:g} rad/s"


@dataclass(frozen=True)
class AgentDelta:
    """Theorem 2's requirement for one agent (1/s^2 per axis)."""

    agent: int
    configured: tuple[float, float, float]
    region: tuple[float, float, float]
    """sup over the region (and the bound boxes of reference and disturbance)"""
    reference_trajectory: tuple[float, float, float]
    """max over t of the value at sigma_e = 0, omega_e = 0 with the scenario's actual signals"""
    reference_bound: tuple[float, float, float]
    """sup at sigma_e = 0, omega_e = 0 over the bound boxes of reference and disturbance"""
    kappa: float | None
    """Delta_J = kappa J0 (proportional uncertainty), else None"""
    worst_state: tuple[tuple[float, ...], tuple[float, ...]] = ((), ())
    """(sigma_e, omega_e) of the largest requirement"""
    note: str = ""

    @property
    def ok(self) -> bool:
        return all(c > r for c, r in zip(self.configured, self.region, strict=True))


@dataclass(frozen=True)
class Theorem2Numeric:
    """Outcome of :func:`delta_requirements`."""

    region: Region
    agents: tuple[AgentDelta, ...]
    samples: int
    """state samples per agent (each combined with the exact sup over the affine inputs)"""
    trajectory_samples: int
    description: str
    largest_scale: float | None = None
    """largest f in [0, 1] such that the configured delta meets the requirement on f * region (None: not searched)"""
    coupling: str = ""
    seconds: float = 0.0
    extra: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return all(a.ok for a in self.agents)


def _load(name: str) -> ca.Function:
    return ca.Function.deserialize((generated_dir() / "casadi" / f"{name}.casadi").read_text())


def _paper_law() -> LawCode:
    """The paper's law (``generated/laws/fsm``): Theorem 2 is about it."""
    return resolve_law("fsm")


def _offset(law: LawCode, name: str) -> tuple[int, int]:
    """``(start, size)`` of a parameter in the law's packed vector."""
    k = 0
    for p in law.parameters:
        if p.name == name:
            return k, p.size
        k += p.size
    raise KeyError(name)  # pragma: no cover - the paper's law declares the names used here


def _cache_slot(law: LawCode, name: str) -> tuple[int, int]:
    """``(start, size)`` of a stage in the law's cache (``law.json``)."""
    k = 0
    for entry in json.loads((law.folder / "law.json").read_text("utf-8"))["cache"]:
        if entry["name"] == name:
            return k, int(entry["size"])
        k += int(entry["size"])
    raise KeyError(name)  # pragma: no cover - the paper's law caches its error state


DRIFT_OUTPUTS = ("d", "P", "A", "B", "s")
DRIFT_INPUTS = ("sigma_e", "omega_e", "omega_d", "u_d", "J0", "J", "params", "omega_d_dot")


@functools.cache
def drift_function(error_model: str, outputs: tuple[str, ...] = DRIFT_OUTPUTS) -> ca.Function:
    """CasADi function of the sliding-variable dynamics at ``delta = 0`` built from the generated functions.

    Inputs ``(sigma_e, omega_e, omega_d, u_d, J0, J, params, omega_d_dot)``, ``params`` the paper's law's
    packed parameters (a row of :func:`fsm_parameters`; its ``delta`` is not read: ``d`` is at ``delta = 0``);
    outputs
    ``d`` (``s_dot`` with ``delta = 0`` and no coordination), ``P`` (``-ds_dot/d coordination``),
    ``A = dd/du_d``, ``B = dd/domega_d_dot`` (``d`` is affine in both) and ``s``.
    ``s_dot`` is the exact time derivative of the generated ``s(sigma, omega, sigma_d, omega_d)``
    along the rigid-body motion (``plant_rhs`` with the true ``J``, control ``u_commanded`` from the law's
    ``law_control_<error_model>`` with ``J0``, the reference frame moving with ``omega_d``),
    taken at ``sigma_d = 0`` (the error dynamics do not depend on ``sigma_d``).
    Liang et al. 2012, eqs 16-20, 29-30.

    Parameters
    ----------
    error_model : str
        ``"paper"`` or ``"exact"`` (the law's generated ``law_local_*``/``law_control_*`` pair).
    outputs : tuple of str
        A subset of ``("d", "P", "A", "B", "s")``, in that order by default.  A function with fewer
        outputs evaluates only the part of the same expression graph they need: its values are those of
        the full function, bit for bit, at a lower cost (the trajectory scan needs only ``d`` and ``P``).

    Returns
    -------
    casadi.Function
        ``(sigma_e, omega_e, omega_d, u_d, J0, J, params, omega_d_dot) -> outputs``.

    Examples
    --------
    At the reference (``sigma_e = 0``, ``omega_e = 0``) without disturbance or reference motion the sliding
    variable stays 0:

    >>> import numpy as np, fsmctl
    >>> from fsmctl.proofs.theorem2 import drift_function, fsm_parameters
    >>> paper = fsmctl.paper_scenario("1")
    >>> J0, z = paper.agents[0].J0_array, np.zeros(3)
    >>> d = drift_function("paper", ("d",))(z, z, z, z, J0, 1.3 * J0, fsm_parameters(paper)[0], z)
    >>> np.asarray(d).ravel().tolist()
    [0.0, 0.0, 0.0]
    """
    unknown = [o for o in outputs if o not in DRIFT_OUTPUTS]
    if unknown or not outputs:
        raise ValueError(f"drift_function: outputs must be a non-empty subset of {DRIFT_OUTPUTS}, got {outputs!r}")
    inputs, exprs = _drift_expressions(error_model)
    name = f"theorem2_drift_{error_model}" + ("" if tuple(outputs) == DRIFT_OUTPUTS else "_" + "_".join(outputs))
    return ca.Function(name, list(inputs), [exprs[o] for o in outputs], list(DRIFT_INPUTS), list(outputs))


@functools.cache
def _drift_expressions(error_model: str, keep_delta: bool = False) -> tuple[tuple[ca.SX, ...], dict[str, ca.SX]]:
    """The symbolic inputs and outputs of :func:`drift_function` (built once per error model).

    With ``keep_delta`` the law's ``delta`` (read from ``params``) is kept: ``d`` is then ``s_dot`` of the full law
    without coordination (the reaching condition's ``s_dot``), not the drift at ``delta = 0``.
    """
    fsm = _paper_law()
    local = law_sx_function(fsm.folder, f"law_local_{error_model}")
    control = law_sx_function(fsm.folder, f"law_control_{error_model}")
    const = law_sx_function(fsm.folder, "law_constants")
    plant = _load("plant_rhs")
    sym = ca.SX.sym
    sig, om, sigd = sym("sigma", 3), sym("omega", 3), sym("sigma_d", 3)
    se, we, wd, wdd, ud = sym("sigma_e", 3), sym("omega_e", 3), sym("omega_d", 3), sym("omega_d_dot", 3), sym("u_d", 3)
    J0, J, params, coord = sym("J0", 3, 3), sym("J", 3, 3), sym("params", fsm.n_params), sym("coordination", 3)
    zero = ca.SX.zeros(3)
    k, n = _offset(fsm, "delta")
    # delta = 0: the drift of eqs 30-33
    p = params if keep_delta else ca.vertcat(params[:k], ca.SX.zeros(n), params[k + n :])
    gc = const(p)
    z = ca.SX.zeros(fsm.n_states)
    s, cache = local(0, sig, om, z, sigd, wd, wdd, J0, p, gc)
    # coordination k_sum s - received = -(-coord); u_commanded: Theorem 2 ignores the torque limit
    u = control(0, sig, om, z, sigd, wd, wdd, J0, p, gc, cache, 0, -coord, 0, 1e300)[1]
    sig_dot, om_dot = plant(sig, om, u + ud, J)
    sigd_dot, _ = plant(sigd, wd, zero, J0)  # G(sigma_d) omega_d
    x = ca.vertcat(sig, om, sigd, wd)
    xdot = ca.vertcat(sig_dot, om_dot, sigd_dot, wdd)
    s_dot = ca.jtimes(s, x, xdot)  # s does not depend on omega_d_dot (checked below)
    if ca.jacobian(s, wdd).nnz() != 0:  # pragma: no cover - structural guarantee of the generated code
        raise RuntimeError("the generated sliding variable depends on omega_d_dot; extend the derivative")
    k, n = _cache_slot(fsm, "omega_r")
    omega_r = local(0, se, zero, z, zero, wd, wdd, J0, p, gc)[1][k : k + n]
    state = ca.vertcat(sig, om, sigd)
    at = ca.vertcat(se, we + omega_r, zero)
    s_dot, s = ca.substitute([s_dot, s], [state], [at])
    d = ca.substitute(s_dot, coord, zero)
    P = -ca.jacobian(s_dot, coord)
    A = ca.jacobian(d, ud)
    B = ca.jacobian(d, wdd)
    return (se, we, wd, ud, J0, J, params, wdd), {"d": d, "P": P, "A": A, "B": B, "s": s}


def proportional_kappa(J0: np.ndarray, delta_J: np.ndarray) -> float | None:
    """``kappa`` with ``Delta_J = kappa J0`` (Liang et al. 2012, eq 29 and Sec. 4: ``0.3 J0``).

    Parameters
    ----------
    J0, delta_J : array_like
        Nominal inertia and its perturbation (3x3).

    Returns
    -------
    float or None
        ``kappa`` when ``Delta_J = kappa J0`` to 1e-12 relative, else None (then ``P = G J^-1 J0 G^-1``
        is not a scalar and the general bound is used).
    """
    J0, dJ = np.asarray(J0, float), np.asarray(delta_J, float)
    kappa = float(np.trace(dJ) / np.trace(J0))
    if np.max(np.abs(dJ - kappa * J0)) <= 1e-12 * np.max(np.abs(J0)):
        return kappa
    return None


def _levels(r: float) -> np.ndarray:
    return np.array([-r, 0.0, r]) if r > 0 else np.array([0.0])


def _box_points(bound: np.ndarray) -> np.ndarray:
    """Vertices and centre of the box ``|x_k| <= bound_k`` (3 x m, duplicates removed)."""
    pts = [np.zeros(3)]
    for sx in (-1, 1):
        for sy in (-1, 1):
            for sz in (-1, 1):
                pts.append(np.array([sx, sy, sz]) * bound)
    return np.unique(np.array(pts), axis=0).T


def _state_samples(
    region: Region, wd_bound: np.ndarray, n_random: int, rng, omega_vertices_only: bool = False
) -> tuple[np.ndarray, ...]:
    ls, lw = _levels(region.sigma), _levels(region.omega)
    if omega_vertices_only and region.omega > 0:
        lw = np.array([-region.omega, region.omega])
    S = np.array(np.meshgrid(ls, ls, ls, indexing="ij")).reshape(3, -1)
    W = np.array(np.meshgrid(lw, lw, lw, indexing="ij")).reshape(3, -1)
    WD = _box_points(wd_bound)
    iS, iW, iD = np.meshgrid(np.arange(S.shape[1]), np.arange(W.shape[1]), np.arange(WD.shape[1]), indexing="ij")
    sig, om, wd = S[:, iS.ravel()], W[:, iW.ravel()], WD[:, iD.ravel()]
    if n_random > 0 and (region.sigma > 0 or region.omega > 0):
        sig = np.hstack([sig, rng.uniform(-region.sigma, region.sigma, (3, n_random))])
        om = np.hstack([om, rng.uniform(-region.omega, region.omega, (3, n_random))])
        wd = np.hstack([wd, rng.uniform(-1, 1, (3, n_random)) * wd_bound[:, None]])
    return sig, om, wd


def _evaluate(fn: ca.Function, sig, om, wd, ud, J0, J, params, wdd) -> list[np.ndarray]:
    """``fn`` (a :func:`drift_function`) on the columns of ``sig, om, wd, ud, wdd`` (3, n), one ``J0, J, params``.

    Returns each output in the layout of the ``DM`` results of ``fn.map(n)`` converted by ``np.array``:
    vectors (``d``, ``s``) as C-contiguous (3, n), matrices (``P``, ``A``, ``B``) as (n, 3, 3) views of a
    (3, n, 3) array, so every later NumPy reduction sees the same memory order; evaluated through NumPy
    buffers (:func:`fsmctl.model.casadi_eval.evaluate_mapped`).
    """
    n = sig.shape[1]
    args = [np.transpose(x) for x in (sig, om, wd, ud)]  # (n, 3): sample-major
    args += [np.transpose(J0), np.transpose(J), params, np.transpose(wdd)]  # matrices column-major
    out = []
    for v in evaluate_mapped(fn, n, args, shared=(4, 5, 6)):
        if v.ndim == 2:  # (n, 3) -> (3, n)
            out.append(np.ascontiguousarray(v.T))
        else:  # (n, 3 columns, 3 rows) -> (3 rows, n, 3 columns) -> (n, 3, 3)
            out.append(np.ascontiguousarray(v.transpose(2, 0, 1)).transpose(1, 0, 2))
    return out


def _requirement(kappa, d, P, A, B, u_bound, wdd_bound, coord_bound):
    """Per-sample requirement (3, n) for delta, from ``d`` at zero affine inputs and their bound boxes."""
    dbar = np.abs(d) + np.einsum("nkl,l->kn", np.abs(A), u_bound) + np.einsum("nkl,l->kn", np.abs(B), wdd_bound)
    if kappa is not None:
        return (1.0 + kappa) * dbar
    # general Delta_J: (I - Q) delta >= dbar + Q cbar with Q = |P - I| (entrywise sup), see module docstring
    Q = np.max(np.abs(P - np.eye(3)[None]), axis=0)
    rho = float(np.max(np.abs(np.linalg.eigvals(Q))))
    if rho >= 1:
        return np.full_like(dbar, np.inf)
    rhs = dbar + (Q @ coord_bound)[:, None]
    return np.linalg.solve(np.eye(3) - Q, rhs)


def _reference_signals(scenario: Scenario, times: np.ndarray):
    """``omega_d(t)``, ``omega_d_dot(t)`` as (3, T), from the generated ``reference_rhs`` (independent of sigma_d)."""
    m = times.size
    _, omega_d, omega_d_dot = evaluate_mapped(
        casadi_function("reference_rhs"), m, [times, np.zeros((m, 3)), scenario.reference.omega.params()], shared=(2,)
    )
    return np.ascontiguousarray(omega_d.T), np.ascontiguousarray(omega_d_dot.T)


def delta_requirements(
    scenario: Scenario,
    region: Region = Region(),
    *,
    n_random: int = 3000,
    seed: int = 0,
    dt_reference: float | None = 0.05,
    search_scale: bool = True,
) -> Theorem2Numeric:
    """The ``delta_i`` Theorem 2 needs for a scenario, by sampling (Liang et al. 2012, eqs 29-33, corrected).

    Parameters
    ----------
    scenario : Scenario
        Supplies ``J0_i``, ``Delta_J_i``, the disturbance and reference bounds, the gains and the configured ``delta_i``.
    region : Region
        The ``(sigma_e, omega_e)`` box; it always contains the reference ``sigma_e = 0, omega_e = 0``.
    n_random : int
        Uniform random samples added to the grid (box corners, face and edge centres, centre).
    seed : int
        Seed of the random samples.
    dt_reference : float or None
        Time step of the scan of the reference trajectory over ``[0, t_final]``; None: no scan (each agent's
        ``reference_trajectory`` is NaN and ``trajectory_samples`` 0; e.g. a Monte Carlo record, which keeps only
        the region and reference-box requirements).
    search_scale : bool
        When the configured delta falls short, bisect for the largest scaled box on which it suffices.

    Returns
    -------
    Theorem2Numeric
        Per agent: the requirement over the region, on the reference trajectory (actual
        signals, max over t) and at the reference under the bound boxes, and the configured delta.

    Examples
    --------
    The paper's formation (Section 4, ``Delta_J = 0.3 J0``) on a small box: its ``delta_i = 0.005`` falls short
    of the about 0.059 the uncertainty needs there (claim ``theorem2-delta`` of ``fsmctl prove``):

    >>> import fsmctl
    >>> from fsmctl.proofs import Region, delta_requirements
    >>> r = delta_requirements(fsmctl.paper_scenario(), Region(sigma=0.01, omega=0.01), n_random=50,
    ...                        dt_reference=1.0, search_scale=False)
    >>> agent = r.agents[0]
    >>> r.ok, agent.configured, [round(x, 3) for x in agent.region]
    (False, (0.005, 0.005, 0.005), [0.059, 0.059, 0.058])
    """
    t_start = time.perf_counter()
    c = scenario.controller
    fn = drift_function(c.error_model)
    fn_dP = drift_function(c.error_model, ("d", "P"))  # the trajectory scan needs no A, B, s
    rows = fsm_parameters(scenario)
    rng = np.random.default_rng(seed)
    wd_bound = scenario.reference.omega.bound()
    wdd_bound = scenario.reference.omega.rate_bound()
    sig, om, wd = _state_samples(region, wd_bound, n_random, rng)
    n = sig.shape[1]
    n_grid = _state_samples(region, wd_bound, 0, rng)[0].shape[1]
    zeros = np.zeros((3, n))
    # reference trajectory: sigma_e = 0, omega_e = 0 with the actual signals
    if dt_reference is None:
        times = np.zeros(0)
    else:
        times = np.arange(0.0, scenario.simulation.t_final + 0.5 * dt_reference, dt_reference)
        omega_d_t, omega_d_dot_t = _reference_signals(scenario, times)
    fsm = _paper_law()
    fix_at, _ = _offset(fsm, "singularity_fix")
    rows_ref = rows.copy()  # at omega_e = 0 the Remark 6 slope multiplies sigma_e_dot = 0
    rows_ref[:, fix_at] = fsm.parameter("singularity_fix").values("switch", "singularity_fix")[0]
    fix_name = fsm.parameter("singularity_fix").choices[int(rows[0, fix_at])]
    # the sliding variable is the same for every agent (it does not involve J): bound it once for the coupling term
    Ki = scenario.topology.k_i_matrix()
    kj_max = scenario.topology.k_j_max_matrix()
    agents = []
    kappas = []
    s_bound = None
    deltas = fsm_deltas(scenario)
    for i, agent in enumerate(scenario.agents):
        J0, J = np.array(agent.J0), agent.J_true
        kappa = proportional_kappa(J0, np.array(agent.delta_J))
        kappas.append(kappa)
        u_bound = agent.disturbance.bound()
        at_ref = np.all(sig == 0, axis=0) & np.all(om == 0, axis=0)
        # sigma_e_dot = 0 at the reference: evaluate it without the 0 * inf of an unfixed slope (gains_ref);
        # a zero region is the reference alone, evaluated once
        only_ref = bool(np.all(at_ref))
        d, P, A, B, s = _evaluate(fn, sig, om, wd, zeros, J0, J, rows_ref[i] if only_ref else rows[i], zeros)
        if np.any(at_ref) and not only_ref:
            r = _evaluate(
                fn, sig[:, at_ref], om[:, at_ref], wd[:, at_ref], zeros[:, at_ref], J0, J, rows_ref[i], zeros[:, at_ref]
            )
            for full, part in zip((d, P, A, B, s), r, strict=True):
                if full.ndim == 2:
                    full[:, at_ref] = part
                else:
                    full[at_ref] = part
        if s_bound is None:
            s_bound = np.max(np.abs(s), axis=1)
        coord_bound = (Ki[i].sum() + kj_max[i].sum()) * s_bound
        req = _requirement(kappa, d, P, A, B, u_bound, wdd_bound, coord_bound)
        req = np.where(np.isfinite(req), req, np.inf)
        region_req = np.max(req, axis=1)
        worst = int(np.argmax(np.max(req / np.maximum(deltas[i], 1e-300)[:, None], axis=0)))
        ref_bound = np.max(req[:, at_ref], axis=1) if np.any(at_ref) else np.full(3, np.nan)
        # trajectory scan
        m = times.size
        if m:
            ud_t = agent.disturbance(times).T
            dt_, Pt = _evaluate(
                fn_dP, np.zeros((3, m)), np.zeros((3, m)), omega_d_t, ud_t, J0, J, rows_ref[i], omega_d_dot_t
            )
            traj = _requirement(
                kappa, dt_, Pt, np.zeros_like(Pt), np.zeros_like(Pt), u_bound * 0, wdd_bound * 0, coord_bound * 0
            )
        else:
            traj = np.full((3, 1), np.nan)
        note = ""
        if kappa is not None:
            dev = float(np.max(np.abs(P - np.eye(3)[None] / (1 + kappa))))
            note = f"Delta_J = {kappa:g} J0: P = I/(1+kappa) = {1 / (1 + kappa):.6g} I (max deviation {dev:.1e})"
        else:
            note = "Delta_J not proportional to J0: conservative bound (I - |P - I|) delta >= dbar + |P - I| cbar"
        if not np.all(np.isfinite(region_req)):
            note += (
                "; unbounded: ds/dt contains c2 alpha |sigma_e,k|^(alpha-1) sigma_e_dot,k, infinite at sigma_e,k = 0 "
                f"with omega_e != 0 (Remark 6; singularity_fix = {fix_name})"
            )
        agents.append(
            AgentDelta(
                agent=i + 1,
                configured=tuple(float(x) for x in deltas[i]),
                region=tuple(float(x) for x in region_req),
                reference_trajectory=tuple(float(x) for x in np.max(traj, axis=1)),
                reference_bound=tuple(float(x) for x in ref_bound),
                kappa=kappa,
                worst_state=(tuple(float(x) for x in sig[:, worst]), tuple(float(x) for x in om[:, worst])),
                note=note,
            )
        )
    coupling = _coupling_text(scenario, kappas)
    result = Theorem2Numeric(
        region=region,
        agents=tuple(agents),
        samples=n,
        trajectory_samples=times.size,
        description=(
            f"{n} state samples per agent: {n_grid} on the grid {{-r, 0, r}}^3 of sigma_e times that of omega_e "
            f"times {_box_points(wd_bound).shape[1]} corner/centre points of the omega_d box |omega_d,k| <= "
            f"{np.round(wd_bound, 6).tolist()} rad/s, plus {n - n_grid} uniform random points (seed {seed}); disturbance |u_d,k| <= bound and |omega_d_dot,k| <= "
            f"{np.round(wdd_bound, 6).tolist()} rad/s^2 enter affinely and are maximised exactly; torque limit ignored "
            f"(as in the paper); true rigid-body kinematics, controller error model '{c.error_model}'"
        ),
        coupling=coupling,
        seconds=time.perf_counter() - t_start,
    )
    if (
        search_scale
        and not result.ok
        and all(all(cf > r for cf, r in zip(a.configured, a.reference_bound, strict=True)) for a in result.agents)
    ):
        scale = _largest_scale(scenario, region, fn, rows, kappas, wd_bound, wdd_bound, s_bound)
        result = Theorem2Numeric(**{**result.__dict__, "largest_scale": scale})
    return Theorem2Numeric(**{**result.__dict__, "seconds": time.perf_counter() - t_start})


def _largest_scale(scenario, region, fn, rows, kappas, wd_bound, wdd_bound, s_bound, iters: int = 10) -> float:
    """Largest f (to 1.4 %, bisection on log10 f) with configured delta > requirement on the grid of f * region."""
    Ki = scenario.topology.k_i_matrix()
    kj_max = scenario.topology.k_j_max_matrix()

    deltas = fsm_deltas(scenario)

    def ok(f: float) -> bool:
        sub = Region(region.sigma * f, region.omega * f)
        sig, om, wd = _state_samples(sub, wd_bound, 0, None, omega_vertices_only=True)
        zeros = np.zeros_like(sig)
        for i, agent in enumerate(scenario.agents):
            d, P, A, B, _ = _evaluate(fn, sig, om, wd, zeros, np.array(agent.J0), agent.J_true, rows[i], zeros)
            cb = (Ki[i].sum() + kj_max[i].sum()) * s_bound * f
            req = np.max(_requirement(kappas[i], d, P, A, B, agent.disturbance.bound(), wdd_bound, cb), axis=1)
            if not np.all(deltas[i] > req):
                return False
        return True

    lo, hi = -6.0, 0.0  # bisection on log10(f): relative resolution 6/2^iters decades
    if not ok(10.0**lo):
        return 0.0
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(10.0**mid) else (lo, mid)
    return 10.0**lo


def _coupling_text(scenario: Scenario, kappas: list) -> str:
    if all(k is not None for k in kappas) and len({round(k, 12) for k in kappas}) == 1:
        return (
            f"all agents have Delta_J = {kappas[0]:g} J0: the coordination term is scaled by the common factor "
            f"1/(1+kappa) = {1 / (1 + kappas[0]):.4g} and stays dissipative under Theorem 1's condition"
        )
    if all(k is not None for k in kappas):
        from fsmctl.proofs.theorem1 import scaled_coupling_lambda_min

        lam, t = scaled_coupling_lambda_min(
            scenario.topology, 1.0 / (1.0 + np.asarray(kappas)), scenario.simulation.t_final
        )
        verdict = "holds" if lam >= -1e-9 else "FAILS"
        return (
            "agents have different kappa_i: the coordination term becomes -S^T (D L(t) x I) S with "
            f"D = diag(1/(1+kappa_i)); min_t lambda_min(sym(D L(t))) = {lam:.4g} at t = {t:g} s ({verdict})"
        )
    return (
        "non-proportional Delta_J: the coordination term's (I - P) part is bounded by |P - I| (sum_j k^i + k^j) max|s|"
    )


def reference_delta_requirement(scenario: Scenario, *, dt_reference: float = 0.05) -> np.ndarray:
    """The ``delta_i`` Theorem 2 needs at the reference ``sigma_e = 0, omega_e = 0``, per agent and axis (1/s^2).

    The larger, per agent and axis, of the two reference numbers of ``fsmctl prove theorem2-delta``
    (:func:`delta_requirements` on the zero region): the requirement along the scenario's reference trajectory
    (its actual ``omega_d(t)``, ``omega_d_dot(t)`` and disturbance, max over ``t`` in ``[0, t_final]`` at steps of
    ``dt_reference``) and the one at the reference under the bound boxes of the disturbance and the reference
    rate.  At ``sigma_e = 0, omega_e = 0`` the requirement does not involve ``c1``, ``c2``, ``alpha``, the
    boundary layer or the coupling weights (``a_eq = 0`` and ``s = 0`` there), only the inertia, its uncertainty,
    the disturbance and the reference; the torque limit is ignored, as in the paper.

    Parameters
    ----------
    scenario : Scenario
        Supplies ``J0_i``, ``Delta_J_i``, the disturbances, the reference and the horizon.
    dt_reference : float
        Time step (s) of the scan of the reference trajectory.

    Returns
    -------
    numpy.ndarray
        ``(n_agents, 3)``.

    Examples
    --------
    >>> from fsmctl.model.scenario import paper_scenario
    >>> req = reference_delta_requirement(paper_scenario("1"))
    >>> req.shape, bool(0.001 < req.max() < 0.005)
    ((6, 3), True)
    """
    res = delta_requirements(scenario, Region(0.0, 0.0), n_random=0, dt_reference=dt_reference, search_scale=False)
    return np.array([np.maximum(a.reference_trajectory, a.reference_bound) for a in res.agents], dtype=float).reshape(
        scenario.n_agents, 3
    )


def delta_margin(deltas: np.ndarray, required: np.ndarray) -> float:
    """Theorem 2's margin at the reference: ``min`` over agents and axes of ``delta_ik - required_ik`` (1/s^2).

    Non-negative when every configured switching gain covers its requirement (Liang et al. 2012, eqs 30-33 as
    corrected in :mod:`fsmctl.proofs.theorem2`; the theorem asks for ``>``, a margin of exactly 0 is the boundary).

    Parameters
    ----------
    deltas : array_like
        ``(n_agents, 3)`` switching gains as flown (:func:`fsm_deltas`).
    required : array_like
        ``(n_agents, 3)`` requirements (:func:`reference_delta_requirement`).

    Returns
    -------
    float

    Examples
    --------
    >>> delta_margin([[0.005, 0.005, 0.005]], [[0.001, 0.002, 0.0015]])
    0.003
    """
    d, r = np.asarray(deltas, dtype=float), np.asarray(required, dtype=float)
    if d.shape != r.shape:
        raise ValueError(f"delta_margin: deltas {d.shape} and requirements {r.shape} differ in shape")
    return float(np.min(d - r))


def fsm_deltas(scenario: Scenario) -> np.ndarray:
    """``(n, 3)``: each agent's switching gain delta_i (eq 18) as the paper's law flies it (agent, [controller] or
    the law's default).

    Raises
    ------
    InputError
        The scenario's law has no ``delta`` (Theorem 2 is about the paper's law).
    """
    theorems = scenario.law.paper_theorems  # the law's declaration that it is eqs 13-19, with its names
    if theorems is None:
        raise InputError(
            f"Theorem 2 concerns the paper's law and its delta; the scenario flies {scenario.law.name!r}, which does "
            "not declare the paper's theorems (LawBuilder.paper_theorems)"
        )
    return np.array([row[theorems.parameters["delta"]] for row in scenario.law_parameters()], dtype=float)


def fsm_parameters(scenario: Scenario) -> np.ndarray:
    """``(n_agents, n_params)``: the paper's law's packed parameters per agent, as the scenario flies them.

    Theorem 2 is about the paper's law (``generated/laws/fsm``, Liang et al. 2012, eqs 13-19).  Its parameters
    are the flown law's values (:meth:`fsmctl.Scenario.law_parameters`: written, preset or default) of the names
    the paper's law declares, and the paper's law's defaults for the others (a law built on the paper's surface
    shares its names).

    Parameters
    ----------
    scenario : Scenario
        The scenario.

    Returns
    -------
    numpy.ndarray
        One packed row per agent, in the order of ``resolve_law("fsm").parameters``.

    Raises
    ------
    fsmctl.model.LawError
        A flown value outside the paper's law's declared range.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.proofs.theorem2 import fsm_parameters
    >>> fsm_parameters(fsmctl.paper_scenario("1").replace(controller={"surface": "tsm"}))[0].tolist()
    [0.0, 0.8, 0.7, 0.001, 0.0001, 1.0, 0.005, 0.005, 0.005]
    """
    fsm = _paper_law()
    theorems = scenario.law.paper_theorems
    # the flown law's name of each of the paper's parameters: declared (LawBuilder.paper_theorems), else the same
    names = dict(theorems.parameters) if theorems is not None else {p.name: p.name for p in fsm.parameters}
    rows = []
    for values in scenario.law_parameters():
        row: list[float] = []
        for p in fsm.parameters:
            name = names.get(p.name)
            row.extend(p.values(values[name], f"controller.{name}") if name in values else p.default)
        rows.append(row)
    return np.array(rows, dtype=float).reshape(scenario.n_agents, fsm.n_params)


def format_vector(v: tuple[float, ...] | list[float] | np.ndarray) -> str:
    """A per-axis requirement of Theorem 2 (Liang et al. 2012, eqs 30-33) as ``(a, b, c)``.

    Parameters
    ----------
    v : sequence of float
        Values in 1/s^2 (``inf`` when unbounded).

    Returns
    -------
    str
        Three significant digits per component.
    """
    return "(" + ", ".join("inf" if not math.isfinite(x) else f"{x:.3g}" for x in v) + ")"
