"""Theorem 2's delta requirement as a certified bound, and the reaching condition certified or refuted.

:func:`delta_requirements` (:mod:`fsmctl.proofs.theorem2`) samples the requirement of the corrected Theorem 2
(Liang et al. 2012, eqs 29-33): per agent ``i`` and axis ``k``, ``(1 + kappa_i) |d_i|_k`` (``d = s_dot`` at
``delta = 0`` without coordination, ``Delta_J_i = kappa_i J0_i``) over the region box of ``(sigma_e, omega_e)`` and
the bound boxes of ``omega_d``, the disturbance ``u_d`` and ``omega_d_dot``.  A sampled supremum is a lower
estimate.  :func:`certified_delta_requirements` encloses the same quantity by branch and bound on interval
arithmetic with outward rounding (:func:`fsmctl.enclosures.branch_bound.bound_maximum`) over the whole box
``x = (sigma_e, omega_e, omega_d, u_d, omega_d_dot)`` (15 inputs; the true ``J`` of the agent, its ``J0`` and the
law's parameters fixed): ``lower <= sup <= upper``, ``upper`` certified whatever the budget, ``lower`` a rigorous
value at a witness point.  ``u_d`` and ``omega_d_dot`` enter ``d`` affinely, so the sup over their boxes is the
one :func:`delta_requirements` computes exactly.

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
from scipy import optimize

from fsmctl.enclosures.branch_bound import Budget
from fsmctl.enclosures.intervals import IntervalFunction
from fsmctl.model.scenario import Scenario
from fsmctl.proofs import theorem2 as t2
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


BAND_SHRINK = 0.05
"""The pieces of the Remark 6 band: ``|sigma_e,k| <= (1 - BAND_SHRINK) epsilon`` and the two outer pieces from that
bound outwards (they overlap the band's piece at its end: the pieces cover the box).

The law recomputes ``sigma_e`` from the state (an MRP-quaternion-MRP round trip, the identity for ``|sigma| < 1``),
which interval arithmetic widens by a relative ``O(|sigma|^2)`` (below 1% on ``|sigma_e,k| <= 0.05``).  Cut 5%
inside the band, the band's piece decides the law's test ``|sigma_e,k| >= epsilon`` false (the singular branch
``|sigma_e,k|^(alpha-1)`` is dropped) and the outer pieces keep that branch away from 0: every piece is finite."""

LIPSCHITZ_FIXES = ("switch",)
"""Remark 6 devices whose drift is known continuous across ``|sigma_e,k| = epsilon`` (the C^1 extension: value and
slope of ``sig(x)^alpha`` match there; the shadow-set switch of the MRP stays outside ``|sigma| < 1``).  With such a
device the mean-value form is used on every box whose gradient enclosure is finite, although the evaluator flags the
box as possibly switching (see :func:`_search`)."""

BATCH = 2048
"""Boxes split per pass of the search (more when the queue is long: an eighth of it)."""


def _pieces(lo: np.ndarray, hi: np.ndarray, epsilon: float | None) -> tuple[np.ndarray, np.ndarray]:
    """``(15, P)`` start boxes: the box cut along each ``sigma_e`` component at ``+-(1 - BAND_SHRINK) epsilon``
    (None: not cut; :data:`BAND_SHRINK`)."""
    per_dim = []
    for k in range(3):
        a, b = lo[k], hi[k]
        c = (1 - BAND_SHRINK) * epsilon if epsilon else None
        if c is None or b <= (1 + BAND_SHRINK) * epsilon:
            per_dim.append([(a, b)] if c is None or b <= c else [(a, -c), (-c, c), (c, b)])
            continue
        z = (1 + BAND_SHRINK) * epsilon
        per_dim.append([(a, -z), (-z, -c), (-c, c), (c, z), (z, b)])
    los, his = [], []
    for p0 in per_dim[0]:
        for p1 in per_dim[1]:
            for p2 in per_dim[2]:
                L, H = lo.copy(), hi.copy()
                L[:3], H[:3] = (p0[0], p1[0], p2[0]), (p0[1], p1[1], p2[1])
                los.append(L)
                his.append(H)
    return np.stack(los, axis=1), np.stack(his, axis=1)


@dataclass(frozen=True)
class _Found:
    """Per output ``k`` of a search: ``lower[k] <= max y_k <= upper[k]``, ``y_k(witness[:, k]) >= lower[k]``."""

    upper: np.ndarray
    lower: np.ndarray
    witness: np.ndarray
    boxes: int
    converged: np.ndarray
    seconds: float


def _dn(x):
    return np.nextafter(x, -np.inf)


def _upr(x):
    return np.nextafter(x, np.inf)


def _product(alo, ahi, blo, bhi):
    """Outward-rounded interval product (NaN from ``0 * inf`` taken as the infinite bound)."""
    with np.errstate(invalid="ignore", over="ignore"):
        p = np.stack([alo * blo, alo * bhi, ahi * blo, ahi * bhi])
    return _dn(np.where(np.isnan(p), -np.inf, p).min(axis=0)), _upr(np.where(np.isnan(p), np.inf, p).max(axis=0))


def _enclose(f: IntervalFunction, jac: IntervalFunction, lo, hi, lipschitz: bool, epsilon: float | None = None):
    """Every output over ``(n, N)`` boxes: the natural extension intersected with the mean-value form about the
    centre ``f(c) + J(X) (X - c)`` (outward rounding), valid where ``f`` is Lipschitz on the box: the evaluator
    proves it continuous, or ``lipschitz`` (known continuous), and the Jacobian's enclosure is finite.

    With ``epsilon``, a box meeting the zone ``(1 +- BAND_SHRINK) epsilon`` of ``|sigma_e,j|`` (where the evaluator
    cannot decide the law's test ``|sigma_e,j| >= epsilon`` and adds both branches) is also enclosed by the mean-value
    form about a face: ``f(X_F) + sum_j J_j(X) (X_j - b_j)``, ``X_F`` the box with each such ``sigma_e,j`` fixed at
    the end ``b_j`` farther from the zone (there the test is decided), valid by the mean-value theorem on the
    segments from ``x`` to its projection on ``X_F`` (they lie in the box).

    Returns ``(upper (m, N), Jacobian lo and hi (n, m, N), valid (N,), centre (n, N), certified lower at the centre
    (m, N))``.
    """
    m, n = f.n_out, f.n_in
    e = f.enclose(lo, hi)
    c = np.minimum(np.maximum(0.5 * (lo + hi), lo), hi)
    ec = f.enclose(c, c)
    g = jac.enclose(lo, hi)
    glo, ghi = g.lo.reshape(n, m, -1), g.hi.reshape(n, m, -1)  # y = jacobian (m x n), column-major
    dlo, dhi = _dn(lo - c), _upr(hi - c)
    mhi = ec.hi.copy()
    with np.errstate(invalid="ignore", over="ignore"):
        for i in range(n):
            _, thi = _product(glo[i], ghi[i], dlo[i], dhi[i])
            mhi = _upr(mhi + thi)
    finite = np.all(np.isfinite(glo) & np.isfinite(ghi), axis=(0, 1))
    valid = (e.continuous | lipschitz) & finite
    upper = np.where(valid & ~np.isnan(mhi), np.minimum(e.hi, mhi), e.hi)
    if epsilon is not None:
        upper = np.where(valid, np.minimum(upper, _face_form(f, lo, hi, glo, ghi, epsilon)), upper)
    upper = np.where(np.isnan(upper), np.inf, upper)
    at = np.where(np.isnan(ec.lo), -np.inf, ec.lo)
    return upper, glo, ghi, valid, c, at


def _face_form(f: IntervalFunction, lo, hi, glo, ghi, epsilon: float) -> np.ndarray:
    """Upper bounds of the mean-value form about the faces of :func:`_enclose` (inf where no ``sigma_e`` component
    meets the zone)."""
    zlo, zhi = (1 - BAND_SHRINK) * epsilon, (1 + BAND_SHRINK) * epsilon
    meets = ((hi[:3] >= zlo) & (lo[:3] <= zhi)) | ((hi[:3] >= -zhi) & (lo[:3] <= -zlo))
    any_ = meets.any(axis=0)
    if not any_.any():
        return np.full((f.n_out, lo.shape[1]), np.inf)
    far = np.where(np.abs(np.abs(lo[:3]) - epsilon) >= np.abs(np.abs(hi[:3]) - epsilon), lo[:3], hi[:3])
    flo, fhi = lo.copy(), hi.copy()
    flo[:3] = np.where(meets, far, lo[:3])
    fhi[:3] = np.where(meets, far, hi[:3])
    mhi = f.enclose(flo, fhi).hi
    with np.errstate(invalid="ignore", over="ignore"):
        for j in range(3):
            dlo = np.where(meets[j], _dn(lo[j] - far[j]), 0.0)
            dhi = np.where(meets[j], _upr(hi[j] - far[j]), 0.0)
            _, thi = _product(glo[j], ghi[j], dlo, dhi)
            mhi = _upr(mhi + thi)
    return np.where(any_ & ~np.isnan(mhi), mhi, np.inf)


def _to_faces(lo, hi, glo, ghi, valid) -> None:
    """Monotonicity test (single output): where ``df/dx_i >= 0`` on a box on which ``f`` is Lipschitz, its maximum is
    on the face ``x_i = hi_i`` (``<= 0``: ``x_i = lo_i``); the box is replaced by that face, in place."""
    up = (glo[:, 0, :] >= 0) & valid[None, :]
    down = (ghi[:, 0, :] <= 0) & valid[None, :] & ~up
    lo[up] = hi[up]
    hi[down] = lo[down]


def _search(
    f: IntervalFunction,
    jac: IntervalFunction,
    lo: np.ndarray,
    hi: np.ndarray,
    *,
    seconds: float,
    max_boxes: int,
    relative_gap: float,
    lipschitz: bool,
    seeds: np.ndarray,
    epsilon: float | None = None,
) -> _Found:
    """Best-first branch and bound of the maxima of all outputs of ``f`` at once over the union of the start boxes
    ``(n, P)``.

    One queue holds every box that may still hold the maximum of some output (its upper bound exceeds that output's
    best certified value by more than the gap); each pass splits the boxes of largest relative excess, in two, along
    the input of largest ``width x |gradient|`` (gradient of the output with the largest excess).  With one output a
    box where ``f`` is monotone in an input is reduced to the face holding the maximum (:func:`_to_faces`).
    ``upper[k]`` is the largest upper bound of output ``k`` over the queue and over every box dropped (a dropped box's
    bound is kept); ``lower[k]`` the best certified value at a point: box centres and ``seeds`` ``(n, S)``.
    """
    t0 = time.perf_counter()
    m = f.n_out
    scale = np.where(hi.max(axis=1) > lo.min(axis=1), hi.max(axis=1) - lo.min(axis=1), 1.0)
    qlo, qhi = lo.copy(), hi.copy()
    qub, glo, ghi, valid, c, at = _enclose(f, jac, qlo, qhi, lipschitz, epsilon)
    qmag = np.maximum(np.abs(glo), np.abs(ghi))
    best, witness = np.full(m, -np.inf), np.zeros((f.n_in, m))
    sv = f.enclose(seeds, seeds).lo
    sv = np.where(np.isnan(sv), -np.inf, sv)
    dropped = np.full(m, -np.inf)
    boxes = qlo.shape[1]
    for values, points in ((sv, seeds), (at, c)):
        j = values.argmax(axis=1)
        better = values[np.arange(m), j] > best
        best = np.where(better, values[np.arange(m), j], best)
        witness[:, better] = points[:, j[better]]
    while True:
        tol = relative_gap * np.maximum(best, 0.0)
        upper = np.maximum(np.maximum(best, dropped), qub.max(axis=1) if qub.size else -np.inf)
        converged = np.isfinite(upper) & (upper - best <= relative_gap * np.maximum(upper, 0.0))
        if converged.all() or boxes >= max_boxes or time.perf_counter() - t0 > seconds or not qub.size:
            return _Found(upper, best, witness, boxes, converged, time.perf_counter() - t0)
        need = qub > (best + tol)[:, None]
        keep = need.any(axis=0) & np.any(qhi > qlo, axis=0)  # a point box is final: its bound is kept
        if not keep.all():
            dropped = np.maximum(dropped, np.where(~keep[None, :], qub, -np.inf).max(axis=1))
            qlo, qhi, qub, qmag, need = qlo[:, keep], qhi[:, keep], qub[:, keep], qmag[:, :, keep], need[:, keep]
            if not qub.size:
                continue
        excess = np.where(need, (qub - best[:, None]) / np.maximum(np.abs(best), 1e-300)[:, None], -np.inf)
        priority = excess.max(axis=0)
        take = min(qub.shape[1], max(BATCH, qub.shape[1] // 8))
        order = np.argpartition(-priority, take - 1)[:take] if take < priority.size else np.arange(priority.size)
        rest = np.ones(priority.size, bool)
        rest[order] = False
        blo, bhi = qlo[:, order], qhi[:, order]
        k = excess[:, order].argmax(axis=0)
        mag = qmag[:, k, order]  # (n, take): the gradient of the output that most needs the box
        width = (bhi - blo) / scale[:, None]
        score = np.where(width > 0, width * np.where(np.isfinite(mag), mag, 1e300) * scale[:, None], -1.0)
        dims = np.where(score.max(axis=0) > 0, score.argmax(axis=0), width.argmax(axis=0))
        cols = np.arange(take)
        mid = 0.5 * (blo[dims, cols] + bhi[dims, cols])
        nlo, nhi = np.concatenate([blo, blo], axis=1), np.concatenate([bhi, bhi], axis=1)
        nhi[dims, cols] = mid
        nlo[dims, take + cols] = mid
        nub, glo, ghi, valid, c, at = _enclose(f, jac, nlo, nhi, lipschitz, epsilon)
        if m == 1:
            _to_faces(nlo, nhi, glo, ghi, valid)
        boxes += nlo.shape[1]
        j = at.argmax(axis=1)
        better = at[np.arange(m), j] > best
        best = np.where(better, at[np.arange(m), j], best)
        witness[:, better] = c[:, j[better]]
        qlo = np.concatenate([qlo[:, rest], nlo], axis=1)
        qhi = np.concatenate([qhi[:, rest], nhi], axis=1)
        qub = np.concatenate([qub[:, rest], nub], axis=1)
        qmag = np.concatenate([qmag[:, :, rest], np.maximum(np.abs(glo), np.abs(ghi))], axis=2)


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


def _requirement_search(runner: _Runner, error_model: str, agent, params: np.ndarray, lo, hi) -> _Found:
    """The search of ``max |d_k|`` on the 9 inputs of :func:`_reduced_functions`; its witnesses lifted to the 15
    inputs, where the lower bounds are re-certified with the 15-input ``|d|`` (a rigorous value at the point)."""
    per_axis, parts, floats = _reduced_functions(error_model, agent.J0_array, agent.J_true, params, hi[9:])
    seeds = _seeds(lo[:9], hi[:9])
    seeds = np.hstack([seeds, _local_maxima(floats, lo[:9], hi[:9], seeds)])
    found = [runner.run(g, grad, lo[:9], hi[:9], seeds) for g, grad in per_axis]
    m = _Found(
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
    return _Found(m.upper, lower, points, m.boxes, m.converged & (m.upper - lower <= runner.gap * m.upper), m.seconds)


class _Runner:
    """Splits a budget's time and boxes equally among the searches still to run (one per group, or three for a
    non-proportional ``Delta_J``), each over the pieces of :func:`_pieces`."""

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
    ) -> _Found:
        seconds = max(self.budget.max_seconds - (time.perf_counter() - self.t0), 0.05) / self.left
        boxes = max((self.budget.max_boxes - self.boxes) // self.left, 1)
        self.left = max(self.left - 1, 1)
        plo, phi = _pieces(lo, hi, self.epsilon)
        found = _search(
            f,
            jac,
            plo,
            phi,
            seconds=seconds,
            max_boxes=boxes,
            relative_gap=self.gap,
            lipschitz=self.lipschitz,
            seeds=_seeds(lo, hi) if seeds is None else seeds,
            epsilon=self.epsilon,
        )
        self.boxes += found.boxes
        return found


def _seeds(lo: np.ndarray, hi: np.ndarray, n: int = 256) -> np.ndarray:
    """``(15, 2n)`` seeded points of the box: random corners and uniform points (first witnesses of the search)."""
    rng = np.random.default_rng(0)
    x = lo[:, None] + (hi - lo)[:, None] * rng.integers(0, 2, (lo.size, n))
    return np.hstack([x, lo[:, None] + (hi - lo)[:, None] * rng.uniform(0, 1, (lo.size, n))])


LOCAL_STARTS = 3
"""Starts per output of the float local search for the first witnesses: the best seeds, and the same with every
``sigma_e`` component at 0 (the centre of the Remark 6 band, where its slope ``r1`` is largest)."""


def _local_maxima(floats: ca.Function, lo: np.ndarray, hi: np.ndarray, seeds: np.ndarray) -> np.ndarray:
    """Points of the box where each output of ``floats`` (``y -> (g, dg/dy)``) is locally maximal (L-BFGS-B in
    floats: only candidates, evaluated rigorously by the search)."""
    values = np.asarray(floats.map(seeds.shape[1])(seeds)[0])
    out = []
    bounds = list(zip(lo, hi, strict=True))
    for k in range(values.shape[0]):
        top = seeds[:, np.argsort(-values[k])[:LOCAL_STARTS]]
        centred = top.copy()
        centred[:3] = np.clip(0.0, lo[:3, None], hi[:3, None])
        for start in np.hstack([top, centred]).T:

            def minus(z, k=k):
                v, jac = floats(z)
                return -float(v[k]), -np.asarray(jac, float)[k]

            r = optimize.minimize(minus, start, jac=True, bounds=bounds, method="L-BFGS-B", options={"maxiter": 50})
            out.append(np.clip(r.x, lo, hi))
    return np.stack(out, axis=1)


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
