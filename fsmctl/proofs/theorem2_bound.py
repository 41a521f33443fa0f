"""Theorem 2's delta requirement as a certified bound, and the reaching condition certified or refuted.

:func:`delta_requirements` (:mod:`fsmctl.proofs.theorem2`) samples the requirement of the corrected Theorem 2
(Liang et al. 2012, eqs 29-33): per agent ``i`` and axis ``k``, ``(1 + kappa_i) |d_i|_k`` (``d = s_dot`` at
``delta = 0`` without coordination, ``Delta_J_i = kappa_i J0_i``) over the region box of ``(sigma_e, omega_e)`` and
the bound boxes of ``omega_d``, the disturbance ``u_d`` and ``omega_d_dot``.  A sampled supremum is a lower
estimate.  :func:`certified_delta_requirements` encloses the same quantity by branch and bound on interval
arithmetic with outward rounding (:func:`fsmctl.proofs.theorem2_search.search_maxima`), the true ``J`` of the agent,
its ``J0`` and the law's parameters fixed: ``lower <= sup <= upper``, ``upper`` certified whatever the budget,
``lower`` a rigorous value at a witness point ``x = (sigma_e, omega_e, omega_d, u_d, omega_d_dot)`` (15 inputs).
``d`` is affine in ``(u_d, omega_d_dot)``, so their maximum is exact (:func:`_reduced_functions`) and the search runs
on the 9 inputs ``(sigma_e, omega_e, omega_d)``, one search per axis, over the box cut at the Remark 6 band.

The mean-value form and the monotonicity test need the drift Lipschitz on a box: the evaluator proves it where no
test of the law may switch; with the switch device of Remark 6 (:data:`LIPSCHITZ_FIXES`) it is known everywhere on
the region (the device is C^1 across ``|sigma_e,k| = epsilon`` and ``|sigma| < 1`` keeps the MRP shadow switch out).

Verdict per agent: *proved* when the configured ``delta_i`` exceeds ``upper`` on every axis (then on the region
every ``s_k s_dot_k < 0`` outside the boundary layer: the reaching condition of Theorem 2 holds there, by the
theorem's argument), *refuted* when it is below ``lower`` on some axis, else *open*.

When refuted, :func:`refute_reaching` looks for a point of the region where the full law (configured ``delta``, no
coordination) has ``s_k s_dot_k > 0`` *and* ``s^T s_dot > 0`` rigorously (ball arithmetic,
:meth:`fsmctl.enclosures.intervals.IntervalFunction.evaluate_ball`): there ``V = s^T s / 2`` increases, so the
reaching condition fails.

A non-proportional ``Delta_J`` uses the general form of :func:`delta_requirements`:
``(I - Q) delta >= dbar + Q cbar`` with ``Q = sup |P - I|`` (entrywise) and ``cbar = (sum_j k^i + k^j) sup |s|``;
each supremum is bounded by its own branch and bound and ``(I - Q)^-1 >= 0`` is monotone, so the result is an
upper bound; its ``lower`` is the certified lower bound of ``sup |d_k|`` alone (the general form is a sufficient
condition, a value below it refutes nothing: such an agent is never *refuted*).
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass

import casadi as ca
import flint
import numpy as np

from fsmctl.enclosures.branch_bound import Budget
from fsmctl.enclosures.intervals import IntervalFunction
from fsmctl.model.scenario import Scenario
from fsmctl.proofs import theorem2 as t2
from fsmctl.proofs import theorem2_search as ts
from fsmctl.proofs.theorem2 import Region

__all__ = [
    "BENCHMARK_BUDGET",
    "PROVE_BUDGET",
    "RELATIVE_GAP",
    "AgentBound",
    "AxisBound",
    "ReachingPoint",
    "Theorem2Bound",
    "certified_delta_requirements",
    "refute_reaching",
    "requirement_functions",
]

PROVE_BUDGET = Budget(max_boxes=4_000_000, max_seconds=24.0)
"""Work of ``fsmctl prove theorem2-delta``'s certified bound, shared by every distinct agent and axis (the time
left is split equally among the bounds still to compute)."""

BENCHMARK_BUDGET = Budget(max_boxes=400_000_000, max_seconds=3600.0)
"""Work allowed to reach :data:`RELATIVE_GAP` on the paper scenario (the benchmark; the target is under 5 min)."""

RELATIVE_GAP = 1e-3
"""A bound stops when ``upper - lower <= RELATIVE_GAP * upper``."""

VARIABLES = ("sigma_e", "omega_e", "omega_d", "u_d", "omega_d_dot")
"""The 15 inputs of the bounded functions, three components each, in this order."""


@dataclass(frozen=True)
class AxisBound:
    """``lower <= sup (1+kappa)|d_k| <= upper`` for one agent and axis (1/s^2)."""

    axis: int
    """1, 2, 3"""
    configured: float
    upper: float
    """certified: the requirement is at most this everywhere on the box"""
    lower: float
    """certified: the requirement is at least this at :attr:`witness`"""
    witness: tuple[float, ...]
    """the 15 inputs (:data:`VARIABLES`) of the witness point"""
    converged: bool
    boxes: int
    """of the group's search (its three axes are bounded together)"""
    seconds: float

    @property
    def gap(self) -> float:
        return self.upper - self.lower


@dataclass(frozen=True)
class AgentBound:
    """The certified requirement of the agents sharing ``J0``, ``J``, parameters and bounds (they have equal bounds)."""

    agents: tuple[int, ...]
    """1-based"""
    kappa: float | None
    axes: tuple[AxisBound, ...]

    @property
    def verdict(self) -> str:
        """``proved`` (configured > upper on every axis), ``refuted`` (configured < lower on some axis), ``open``."""
        if all(a.configured > a.upper for a in self.axes):
            return "proved"
        if self.kappa is not None and any(a.configured < a.lower for a in self.axes):
            return "refuted"
        return "open"


@dataclass(frozen=True)
class ReachingPoint:
    """A point where the full law's ``s^T s_dot > 0`` is proved in ball arithmetic (``V = s^T s/2`` increases)."""

    agent: int
    axis: int
    """the axis whose requirement the configured delta misses (``s_k s_dot_k > 0`` there)"""
    point: tuple[float, ...]
    """the 15 inputs (:data:`VARIABLES`)"""
    s: tuple[str, ...]
    s_dot: tuple[str, ...]
    """balls as text (``[mid +/- rad]``)"""
    s_dot_s: str
    """``s^T s_dot`` (a ball, positive)"""
    how: str
    """how the point was found"""


@dataclass(frozen=True)
class Theorem2Bound:
    """Outcome of :func:`certified_delta_requirements`."""

    region: t2.Region
    groups: tuple[AgentBound, ...]
    reaching: ReachingPoint | None
    reaching_note: str
    budget: Budget
    seconds: float

    @property
    def verdict(self) -> str:
        """``refuted`` if some group is, ``proved`` if all are, else ``open``."""
        v = [g.verdict for g in self.groups]
        return "refuted" if "refuted" in v else "proved" if all(x == "proved" for x in v) else "open"

    @property
    def boxes(self) -> int:
        """Boxes evaluated by every group's search."""
        return sum(g.axes[0].boxes for g in self.groups)


def _box(scenario: Scenario, region: t2.Region, u_bound: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    wd = scenario.reference.omega.bound()
    wdd = scenario.reference.omega.rate_bound()
    hi = np.concatenate([np.full(3, region.sigma), np.full(3, region.omega), wd, u_bound, wdd]).astype(float)
    return -hi, hi


@functools.cache
def _symbols(error_model: str, keep_delta: bool):
    inputs, exprs = t2._drift_expressions(error_model, keep_delta)
    se, we, wd, ud, J0, J, params, wdd = inputs
    return ca.vertcat(se, we, wd, ud, wdd), ca.vertcat(ca.vec(J0), ca.vec(J), params), exprs


def _fixed(error_model: str, keep_delta: bool, outputs: tuple[str, ...], J0, J, params) -> tuple[ca.SX, ...]:
    x, fixed, exprs = _symbols(error_model, keep_delta)
    values = ca.DM(np.concatenate([np.ravel(J0, order="F"), np.ravel(J, order="F"), np.ravel(params)]))
    out = ca.substitute([exprs[o] for o in outputs], [fixed], [values])
    return (x, *out)


def requirement_functions(
    error_model: str, J0: np.ndarray, J: np.ndarray, params: np.ndarray
) -> tuple[IntervalFunction, list[IntervalFunction]]:
    """``|d_k|`` (3 outputs) of :func:`~fsmctl.proofs.theorem2.drift_function` as a function of the 15 inputs
    :data:`VARIABLES`, with ``J0``, the true ``J`` and the law's packed ``params`` fixed, and per axis its gradient.

    Parameters
    ----------
    error_model : str
        The controller's error model (``"paper"`` or ``"exact"``).
    J0, J : numpy.ndarray
        Nominal and true inertia (3x3).
    params : numpy.ndarray
        The paper's law's packed parameters (a row of :func:`~fsmctl.proofs.theorem2.fsm_parameters`).

    Returns
    -------
    (IntervalFunction, IntervalFunction)
        ``x -> |d|`` and its Jacobian ``x -> d|d|/dx`` (3 x 15, column-major: 45 outputs; row ``k`` is
        ``sign(d_k) dd_k/dx``, whose enclosure contains the Clarke gradient where ``d_k`` may vanish).

    Examples
    --------
    >>> import numpy as np, fsmctl
    >>> from fsmctl.proofs.theorem2 import fsm_parameters
    >>> paper = fsmctl.paper_scenario("1")
    >>> J0 = paper.agents[0].J0_array
    >>> f, jac = requirement_functions("paper", J0, 1.3 * J0, fsm_parameters(paper)[0])
    >>> f.n_in, f.n_out, jac.n_out
    (15, 3, 45)
    """
    x, d = _fixed(error_model, False, ("d",), J0, J, params)
    a = ca.fabs(d)
    f = IntervalFunction(ca.Function("theorem2_abs_d", [x], [a]))
    return f, IntervalFunction(ca.Function("theorem2_abs_d_jacobian", [x], [ca.jacobian(a, x)]))


def _reduced_functions(error_model: str, J0, J, params, half_widths: np.ndarray):
    """``y = (sigma_e, omega_e, omega_d) -> g``, ``g_k = |d_k(y, 0, 0)| + sum_j |A_kj(y)| U_j + sum_j |B_kj(y)| W_j``
    (``U``, ``W``: the half-widths of the ``u_d`` and ``omega_d_dot`` boxes, centred at 0): per axis ``g_k`` and its
    gradient, then the float functions ``y -> (d(y, 0, 0), A(y), B(y))`` and ``y -> (g, dg/dy)``.

    ``d`` is affine in ``(u_d, omega_d_dot)`` (checked: ``A = dd/du_d`` and ``B = dd/domega_d_dot`` do not depend on
    them), so ``g_k(y)`` is exactly the maximum of ``|d_k|`` over those boxes: the search runs on 9 inputs, not 15.
    """
    x, d, A, B = _fixed(error_model, False, ("d", "A", "B"), J0, J, params)
    y, w = x[:9], x[9:]
    if ca.jacobian(ca.vertcat(ca.vec(A), ca.vec(B)), w).nnz() != 0:  # pragma: no cover - structure of the law
        raise RuntimeError("Theorem 2's drift is not affine in (u_d, omega_d_dot); the reduction does not apply")
    d0, A0, B0 = (ca.substitute(v, w, ca.DM.zeros(6)) for v in (d, A, B))
    g = ca.fabs(d0) + ca.mtimes(ca.fabs(ca.horzcat(A0, B0)), ca.DM(np.asarray(half_widths, float)))
    floats = ca.Function("theorem2_max_abs_d", [y], [g, ca.jacobian(g, y)])
    per_axis = [
        (
            IntervalFunction(ca.Function(f"theorem2_max_abs_d{k}", [y], [g[k]])),
            IntervalFunction(ca.Function(f"theorem2_max_abs_d{k}_gradient", [y], [ca.jacobian(g[k], y)])),
        )
        for k in range(3)
    ]
    return per_axis, ca.Function("theorem2_affine_parts", [y], [d0, A0, B0]), floats


def _lift(parts: ca.Function, half_widths: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``(15, m)`` points: ``y[:, k]`` with the ``(u_d, omega_d_dot)`` corner maximising ``|d_k|`` (float signs)."""
    out = np.zeros((15, y.shape[1]))
    for k in range(y.shape[1]):
        d0, A, B = (np.asarray(v, float) for v in parts(y[:, k]))
        sign = 1.0 if d0[k % 3, 0] >= 0 else -1.0
        coef = np.concatenate([A[k % 3], B[k % 3]])
        out[:9, k] = y[:, k]
        out[9:, k] = np.where(sign * coef >= 0, 1.0, -1.0) * half_widths
    return out


def _general_functions(error_model: str, J0, J, params):
    """``|P - I|`` (9 outputs, column-major) and ``|s|`` (3) with their Jacobians, for a non-proportional Delta_J."""
    x, P, s = _fixed(error_model, False, ("P", "s"), J0, J, params)
    x = x[:9]  # neither depends on (u_d, omega_d_dot)
    q = ca.fabs(ca.vec(P - ca.DM.eye(3)))
    a = ca.fabs(s)
    fq = IntervalFunction(ca.Function("theorem2_abs_P_minus_I", [x], [q]))
    fs = IntervalFunction(ca.Function("theorem2_abs_s", [x], [a]))
    gq = IntervalFunction(ca.Function("theorem2_abs_P_minus_I_jacobian", [x], [ca.jacobian(q, x)]))
    gs = IntervalFunction(ca.Function("theorem2_abs_s_jacobian", [x], [ca.jacobian(a, x)]))
    return (fq, gq), (fs, gs)


LIPSCHITZ_FIXES = ("switch",)
"""Remark 6 devices whose drift is known continuous across ``|sigma_e,k| = epsilon`` (the C^1 extension: value and
slope of ``sig(x)^alpha`` match there; the shadow-set switch of the MRP stays outside ``|sigma| < 1``).  With such a
device the mean-value form is used on every box whose gradient enclosure is finite, although the evaluator flags the
box as possibly switching (see :func:`fsmctl.proofs.theorem2_search.search_maxima`)."""


def _up(x: flint.arb) -> float:
    """A float >= every point of the ball."""
    return float(np.nextafter(float(x.upper()), np.inf)) if x.is_finite() else np.inf


def _down(x: flint.arb) -> float:
    return float(np.nextafter(float(x.lower()), -np.inf)) if x.is_finite() else -np.inf


def _scaled(kappa: float, lower: float, upper: float) -> tuple[float, float]:
    """``(1+kappa) [lower, upper]`` rounded outward (NaN/inf upper: unbounded; a lower bound below 0 is 0)."""
    factor = 1 + flint.arb(kappa)
    low = max(_down(factor * flint.arb(float(lower))), 0.0) if np.isfinite(lower) and lower > 0 else 0.0
    return low, _up(factor * flint.arb(float(upper))) if np.isfinite(upper) else np.inf


def _general_upper(dbar: np.ndarray, Q: np.ndarray, cbar: float) -> np.ndarray:
    """Upper bound of ``(I - Q)^-1 (dbar + Q cbar 1)`` in ball arithmetic (inf when ``I - Q`` may be singular or
    the Neumann series may diverge)."""
    if not (np.all(np.isfinite(dbar)) and np.all(np.isfinite(Q)) and np.isfinite(cbar)):
        return np.full(3, np.inf)
    if float(np.max(np.abs(np.linalg.eigvals(Q)))) >= 1 - 1e-9:
        return np.full(3, np.inf)
    A = flint.arb_mat(3, 3, [flint.arb(float(i == j)) - flint.arb(float(Q[i, j])) for i in range(3) for j in range(3)])
    rhs = flint.arb_mat(
        3, 1, [flint.arb(float(dbar[i])) + flint.arb(float(Q[i].sum())) * flint.arb(cbar) for i in range(3)]
    )
    try:
        sol = A.solve(rhs)
    except ZeroDivisionError:
        return np.full(3, np.inf)
    return np.array([_up(sol[i, 0]) for i in range(3)])


def _requirement_search(runner: _Runner, error_model: str, agent, params: np.ndarray, lo, hi) -> ts.Maxima:
    """The search of ``max |d_k|`` on the 9 inputs of :func:`_reduced_functions`; its witnesses lifted to the 15
    inputs, where the lower bounds are re-certified with the 15-input ``|d|`` (a rigorous value at the point)."""
    per_axis, parts, floats = _reduced_functions(error_model, agent.J0_array, agent.J_true, params, hi[9:])
    seeds = ts.seed_points(lo[:9], hi[:9])
    seeds = np.hstack([seeds, ts.local_maxima(floats, lo[:9], hi[:9], seeds)])
    found = [runner.run(g, grad, lo[:9], hi[:9], seeds) for g, grad in per_axis]
    m = ts.Maxima(
        np.concatenate([r.upper for r in found]),
        np.concatenate([r.lower for r in found]),
        np.hstack([r.witness for r in found]),
        sum(r.boxes for r in found),
        np.concatenate([r.converged for r in found]),
        sum(r.seconds for r in found),
    )
    points = _lift(parts, hi[9:], m.witness)
    x, d = _fixed(error_model, False, ("d",), agent.J0_array, agent.J_true, params)
    at = (
        IntervalFunction(ca.Function("theorem2_abs_d", [x], [ca.fabs(d)]))
        .enclose(points, points)
        .lo[np.arange(3), np.arange(3)]
    )
    lower = np.where(np.isnan(at), -np.inf, at)
    return ts.Maxima(
        m.upper, lower, points, m.boxes, m.converged & (m.upper - lower <= runner.gap * m.upper), m.seconds
    )


class _Runner:
    """Splits a budget's time and boxes equally among the searches still to run (one per group, or three for a
    non-proportional ``Delta_J``), each over the pieces of :func:`~fsmctl.proofs.theorem2_search.band_pieces`."""

    def __init__(self, budget: Budget, calls: int, relative_gap: float, epsilon: float | None, lipschitz: bool):
        self.budget, self.left, self.gap, self.epsilon, self.lipschitz = budget, calls, relative_gap, epsilon, lipschitz
        self.t0, self.boxes = time.perf_counter(), 0

    def run(
        self,
        f: IntervalFunction,
        jac: IntervalFunction,
        lo: np.ndarray,
        hi: np.ndarray,
        seeds: np.ndarray | None = None,
    ) -> ts.Maxima:
        seconds = max(self.budget.max_seconds - (time.perf_counter() - self.t0), 0.05) / self.left
        boxes = max((self.budget.max_boxes - self.boxes) // self.left, 1)
        self.left = max(self.left - 1, 1)
        plo, phi = ts.band_pieces(lo, hi, self.epsilon)
        found = ts.search_maxima(
            f,
            jac,
            plo,
            phi,
            seconds=seconds,
            max_boxes=boxes,
            relative_gap=self.gap,
            lipschitz=self.lipschitz,
            seeds=ts.seed_points(lo, hi) if seeds is None else seeds,
            epsilon=self.epsilon,
        )
        self.boxes += found.boxes
        return found


def _lipschitz(rows: np.ndarray, region: t2.Region) -> bool:
    """Every agent uses a device of :data:`LIPSCHITZ_FIXES` and ``|sigma| < 1`` on the region (no shadow switch)."""
    fsm = t2._paper_law()
    at_fix, _ = t2._offset(fsm, "singularity_fix")
    known = [fsm.parameter("singularity_fix").values(name, "singularity_fix")[0] for name in LIPSCHITZ_FIXES]
    return bool(np.all(np.isin(rows[:, at_fix], known))) and 3 * region.sigma**2 < 1


def _band(scenario: Scenario, rows: np.ndarray) -> float | None:
    """The Remark 6 band's epsilon when every agent uses the switch or clamp device (else None: no cut)."""
    fsm = t2._paper_law()
    at_fix, _ = t2._offset(fsm, "singularity_fix")
    at_eps, _ = t2._offset(fsm, "epsilon")
    if np.all(rows[:, at_fix] > 0) and np.all(rows[:, at_eps] == rows[0, at_eps]):
        return float(rows[0, at_eps])
    return None


def _group_key(agent, params_row, u_bound) -> tuple:
    return (
        tuple(np.ravel(agent.J0_array)),
        tuple(np.ravel(agent.J_true)),
        tuple(np.ravel(params_row)),
        tuple(np.ravel(u_bound)),
    )


def _rows(scenario: Scenario, region: t2.Region) -> np.ndarray:
    """The law's packed parameters per agent; at the reference alone with the Remark 6 fix on (as
    :func:`~fsmctl.proofs.theorem2.delta_requirements`: ``sigma_e_dot = 0`` there, the slope multiplies 0)."""
    rows = t2.fsm_parameters(scenario)
    if region.sigma == 0 and region.omega == 0:
        fsm = t2._paper_law()
        at, _ = t2._offset(fsm, "singularity_fix")
        rows = rows.copy()
        rows[:, at] = fsm.parameter("singularity_fix").values("switch", "singularity_fix")[0]
    return rows


def certified_delta_requirements(
    scenario: Scenario,
    region: Region | None = None,
    *,
    budget: Budget = PROVE_BUDGET,
    relative_gap: float = RELATIVE_GAP,
    refute: bool = True,
) -> Theorem2Bound:
    """Certified ``[lower, upper]`` of Theorem 2's delta requirement per agent and axis, and its verdict.

    Parameters
    ----------
    scenario : Scenario
        The paper's law's scenario (its inertias, uncertainty, disturbance and reference bounds, parameters, delta).
    region : Region, optional
        The ``(sigma_e, omega_e)`` box (default :class:`~fsmctl.proofs.theorem2.Region`'s).
    budget : Budget
        Total work of every bound (shared; see :data:`PROVE_BUDGET`, :data:`BENCHMARK_BUDGET`).  The upper bounds
        are certified whatever the budget; a small budget widens the interval.
    relative_gap : float
        Each bound stops at ``upper - lower <= relative_gap * upper``.
    refute : bool
        When a group is refuted, look for a point where the reaching condition fails (:func:`refute_reaching`).

    Returns
    -------
    Theorem2Bound

    Examples
    --------
    At the reference alone (only ``omega_d``, ``u_d`` and ``omega_d_dot`` vary), with 300 boxes per agent and axis, a
    raised ``delta = 0.5`` is proved (the requirement there is ~0.001, its certified upper bound then ~0.05):

    >>> import fsmctl
    >>> from fsmctl.enclosures.branch_bound import Budget
    >>> from fsmctl.proofs.theorem2 import Region
    >>> raised = fsmctl.paper_scenario("1").replace(controller={"delta": [0.5, 0.5, 0.5]})
    >>> r = certified_delta_requirements(raised, Region(0.0, 0.0), budget=Budget(max_boxes=5400, max_seconds=300.0))
    >>> r.verdict, len(r.groups), all(0 < a.lower < a.upper < 0.5 for g in r.groups for a in g.axes)
    ('proved', 6, True)
    """
    t0 = time.perf_counter()
    region = Region() if region is None else region
    rows = _rows(scenario, region)
    deltas = t2.fsm_deltas(scenario)
    error_model = scenario.controller.error_model
    groups: dict[tuple, list[int]] = {}
    for i, agent in enumerate(scenario.agents):
        groups.setdefault(_group_key(agent, rows[i], agent.disturbance.bound()), []).append(i)
    kappas = [t2.proportional_kappa(a.J0_array, np.asarray(a.delta_J, float)) for a in scenario.agents]
    calls = sum(3 if kappas[m[0]] is not None else 5 for m in groups.values())
    runner = _Runner(budget, calls, relative_gap, _band(scenario, rows), _lipschitz(rows, region))
    Ki, kj = scenario.topology.k_i_matrix(), scenario.topology.k_j_max_matrix()
    out = []
    for members in groups.values():
        i = members[0]
        agent = scenario.agents[i]
        lo, hi = _box(scenario, region, agent.disturbance.bound())
        m = _requirement_search(runner, error_model, agent, rows[i], lo, hi)
        lo, hi = lo[:9], hi[:9]
        kappa = kappas[i]
        if kappa is not None:
            scaled = [_scaled(kappa, m.lower[k], m.upper[k]) for k in range(3)]
        else:
            (fq, gq), (fs, gs) = _general_functions(error_model, agent.J0_array, agent.J_true, rows[i])
            Q = runner.run(fq, gq, lo, hi).upper.reshape(3, 3, order="F")
            s_up = float(runner.run(fs, gs, lo, hi).upper.max())
            cbar = float(Ki[i].sum() + kj[i].sum()) * s_up
            upper = _general_upper(m.upper, Q, cbar)
            scaled = [(max(float(m.lower[k]), 0.0), float(upper[k])) for k in range(3)]
        axes = tuple(
            AxisBound(
                axis=k + 1,
                configured=float(deltas[i][k]),
                upper=scaled[k][1],
                lower=scaled[k][0],
                witness=tuple(float(v) for v in m.witness[:, k]),
                converged=bool(m.converged[k]) and np.isfinite(scaled[k][1]),
                boxes=int(m.boxes),
                seconds=float(m.seconds),
            )
            for k in range(3)
        )
        out.append(AgentBound(agents=tuple(m + 1 for m in members), kappa=kappa, axes=axes))
    reaching, note = None, ""
    refuted = [g for g in out if g.verdict == "refuted"]
    if refute and refuted:
        reaching, note = _first_refutation(scenario, region, refuted, rows)
    elif all(g.verdict == "proved" for g in out):
        note = (
            "the configured delta exceeds the certified requirement on every axis: on the region s_k s_dot_k < 0 "
            "wherever |s_k| exceeds the boundary layer (Theorem 2's argument), so V = s^T s/2 decreases there"
        )
    else:
        note = "the certified interval contains the configured delta on some axis: the reaching condition is open"
    return Theorem2Bound(region, tuple(out), reaching, note, budget, time.perf_counter() - t0)


def _first_refutation(scenario, region, refuted, rows) -> tuple[ReachingPoint | None, str]:
    tried = 0
    for g in refuted:
        for a in g.axes:
            if a.configured < a.lower:
                tried += 1
                p = refute_reaching(scenario, region, g.agents[0], a.axis, np.array(a.witness), rows=rows)
                if p is not None:
                    return p, ""
    return None, (
        f"no point with a proved s^T s_dot > 0 was found near the {tried} witness point(s) of a refuted axis; the "
        "requirement is refuted, the reaching condition itself is not"
    )


@functools.cache
def _reaching_function(error_model: str, J0: tuple, J: tuple, params: tuple) -> tuple[IntervalFunction, ca.Function]:
    x, s, s_dot = _fixed(
        error_model, True, ("s", "d"), np.reshape(J0, (3, 3)), np.reshape(J, (3, 3)), np.asarray(params)
    )
    fn = ca.Function("theorem2_reaching", [x], [s, s_dot, ca.dot(s, s_dot)])
    return IntervalFunction(fn), fn


def refute_reaching(
    scenario: Scenario,
    region: t2.Region,
    agent: int,
    axis: int,
    witness: np.ndarray,
    *,
    rows: np.ndarray | None = None,
) -> ReachingPoint | None:
    """A point of the box where the full law's reaching condition ``s^T s_dot < 0`` fails, proved in ball arithmetic.

    Tries the witness of the requirement, then the witness with ``omega_e`` moved (inside the region) so that
    ``s_k`` has the sign of ``d_k`` beyond the boundary layer and the other ``s_j`` vanish; each candidate is
    accepted only when ``s_k s_dot_k > 0`` and ``s^T s_dot > 0`` are proved with the configured delta, no
    coordination.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    region : Region
        The ``(sigma_e, omega_e)`` box the point must lie in.
    agent, axis : int
        1-based.
    witness : numpy.ndarray
        A point of the 15 inputs :data:`VARIABLES` (e.g. :attr:`AxisBound.witness`).
    rows : numpy.ndarray, optional
        The packed parameters per agent (default :func:`~fsmctl.proofs.theorem2.fsm_parameters`).

    Returns
    -------
    ReachingPoint or None
        None when no candidate is proved.
    """
    rows = t2.fsm_parameters(scenario) if rows is None else rows
    a = scenario.agents[agent - 1]
    key = (tuple(np.ravel(a.J0_array)), tuple(np.ravel(a.J_true)), tuple(np.ravel(rows[agent - 1])))
    ball, fn = _reaching_function(scenario.controller.error_model, *key)
    k = axis - 1
    for how, x in _candidates(fn, region, k, np.asarray(witness, float)):
        try:
            y = ball.evaluate_ball(x)
        except (ValueError, ZeroDivisionError):
            continue  # a comparison of the law undecided at this point (on a switching surface)
        s, s_dot, v = y[0:3], y[3:6], y[6]
        if (s[k] * s_dot[k]) > 0 and v > 0:
            return ReachingPoint(
                agent=agent,
                axis=axis,
                point=tuple(float(t) for t in x),
                s=tuple(b.str(6, radius=True) for b in s),
                s_dot=tuple(b.str(6, radius=True) for b in s_dot),
                s_dot_s=v.str(6, radius=True),
                how=how,
            )
    return None


def _candidates(fn: ca.Function, region: t2.Region, k: int, x0: np.ndarray):
    """The witness, then ``omega_e`` moved (Newton steps on ``s(omega_e)``, clipped to the region) to put ``s_k`` at
    the sign of ``s_dot_k`` and the other ``s_j`` at 0 (only a guess: each candidate is then checked rigorously)."""
    yield "the witness of the requirement's bound", x0
    s, s_dot = (np.asarray(v, float).ravel() for v in fn(x0)[:2])
    target_sign = np.sign(s_dot[k]) or 1.0
    for level in (0.9, 0.5, 0.25, 0.1, 0.03):
        x = x0.copy()
        x[[j for j in range(3) if j != k]] = 0.0  # sigma_e,j = 0 off the axis: the other s_j reachable by omega_e
        target = np.zeros(3)
        target[k] = target_sign * level * region.omega
        for _ in range(6):
            s = np.asarray(fn(x)[0], float).ravel()
            jac = np.empty((3, 3))
            for j in range(3):
                e = x.copy()
                e[3 + j] += 1e-7
                jac[:, j] = (np.asarray(fn(e)[0], float).ravel() - s) / 1e-7
            try:
                step = np.linalg.solve(jac, target - s)
            except np.linalg.LinAlgError:
                break
            x[3:6] = np.clip(x[3:6] + step, -region.omega, region.omega)
        yield (
            f"the witness with sigma_e,j = 0 off axis {k + 1}, omega_e moved to s_{k + 1} = {target[k]:.3g}, s_j = 0",
            x,
        )
