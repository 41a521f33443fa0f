"""``fsmctl certify``: a Lyapunov certificate for a law's closed loop over a region, with the uncertainty.

The question (:mod:`fsmctl.proofs.certify_problem`): for one agent flying the law, isolated, in error coordinates,
with the true inertia, the disturbance and the reference's motion anywhere in their stated sets, is there a
Lyapunov function ``V`` with ``V_dot < 0`` on the stated region (outside the origin, or outside an inner sublevel
set when a disturbance or a moving reference keeps the error from vanishing)?

The answer is one of three, and never upgraded from one to another:

``certified``
    ``V_dot < 0`` is proved at every point of the region (state and uncertainty) by rigorous enclosures
    (:mod:`fsmctl.enclosures`): **asymptotic** when the origin is an equilibrium for every admissible uncertainty
    (no disturbance, the reference at rest) -- near the origin, where ``V_dot -> 0`` defeats any enclosure, by a
    second-order argument: ``V_dot(0) = 0`` and ``grad V_dot(0) = 0`` proved in ball arithmetic and the Hessian
    of ``V_dot`` negative definite for every matrix of its interval enclosure over a core box (so
    ``V_dot < 0`` on the core except at 0); otherwise **ultimately bounded**: ``V_dot < 0`` on the region outside
    an inner sublevel set ``{V <= c_in}``, whose extent is the certified ultimate error bound (near the origin the
    second-order argument proves ``V_dot < 0`` on the core outside a ball ``|y| <= r*``, and the search covers the
    ball like the rest of the region: ``c_in`` is the largest ``V`` on the leaves where ``V_dot < 0`` is not proved).  The largest
    sublevel set ``{V <= c}`` inside the region (``c`` below ``V`` on the region's boundary) is the estimate of the
    region of attraction; the decrease ``V_dot <= -m`` on ``{c_in <= V <= c}`` bounds the time to reach the inner
    set.  No finite-time certificate is issued: the branch and bound cannot resolve ``V_dot <= -k V^a`` at the
    origin.
``counterexample``
    a point of the region (state and uncertainty) where ``V_dot > 0`` is proved (an outward-rounded enclosure at
    the point, confirmed in 256-bit ball arithmetic), outside the inner set for an ultimately bounded question.
``inconclusive``
    the budget ran out, or boxes were too small to split further, with the covered fraction and where the
    difficulty lies (e.g. the switching surfaces of ``sgn``).

An ultimately bounded question whose closed loop and candidate are polynomial (:mod:`fsmctl.proofs.certify_polynomial`:
the reference at rest, no torque limit, the nominal inertia or the proportional set or independent principal moments
of a diagonal ``J0``) is first answered by a sum-of-squares identity checked
in exact rational arithmetic (:mod:`fsmctl.proofs.certify_sos`, :func:`sos_outcome`): ``V_dot <= -lambda (V - c_in)``
on the whole annulus ``{c_in <= V <= c}`` at once; the branch and bound answers when it does not apply or finds
nothing.

Candidates, in order: the law's declared ``V`` (:meth:`fsmctl.symbolic.law.LawBuilder.lyapunov`); with a
disturbance or a moving reference, the attracting invariant ellipsoid of the linearisation under the bounded inputs
(:func:`fsmctl.proofs.quadratic_forms.invariant_ellipsoid`); when the declared
``V_dot`` is only negative semidefinite at the origin (e.g. ``-P |omega|^2``), the declared ``V`` plus a cross
term ``epsilon sigma_e^T J0 omega_e`` with ``epsilon`` chosen where the nominal Hessian of ``V_dot`` at the origin
is most negative relative to that of ``V``; a quadratic ``x^T P x`` from a semidefinite program on the
linearisation at the vertices of the uncertainty (:func:`fsmctl.proofs.quadratic_forms.quadratic_lyapunov`).
The first candidate that is certified is the answer; a counterexample is reported for the law's declared ``V``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
import sympy as sp

from fsmctl.enclosures.branch_bound import Budget, SignSearch, bound_maximum, enclose_sharp, prove_negative
from fsmctl.enclosures.intervals import IntervalFunction
from fsmctl.proofs.certify_core import CORE_FRACTIONS, QuadraticCore, quadratic_core
from fsmctl.proofs.certify_problem import (
    Candidate,
    CertifyProblem,
    candidate_expression,
)
from fsmctl.proofs.certify_report import BOUNDARY, LEVELS, ORIGIN, SEARCH, SOS
from fsmctl.proofs.certify_sos import exact_polynomial, float_above, float_below, sos_decrease, sos_ultimate_bound
from fsmctl.proofs.certify_symbolic import state_symbols
from fsmctl.proofs.quadratic_forms import invariant_ellipsoid, quadratic_lyapunov
from fsmctl.symbolic.law import Law

__all__ = [
    "ASYMPTOTIC",
    "BALL_PRECISION",
    "CANDIDATE_CHOICES",
    "BOUNDARY_BUDGET",
    "CERTIFIED",
    "COUNTEREXAMPLE",
    "INCONCLUSIVE",
    "ULTIMATELY_BOUNDED",
    "CandidateOutcome",
    "LyapunovPrograms",
    "SearchSettings",
    "boundary_level",
    "certify_candidate",
    "choose_candidates",
    "counterexample_at",
    "inner_target",
    "inside_core",
    "levels_report",
    "lyapunov_programs",
    "origin_argument",
    "sos_outcome",
    "sos_polynomials",
    "split_levels",
    "sublevel_extent",
]

CERTIFIED, COUNTEREXAMPLE, INCONCLUSIVE = "certified", "counterexample", "inconclusive"
ASYMPTOTIC, ULTIMATELY_BOUNDED = "asymptotic", "ultimately bounded"

EPSILON_GRID = tuple(10.0 ** (k / 4) for k in range(-16, 5))
"""cross-term weights screened (1e-4 ... 10): the nominal Hessians at the origin pick the best"""
INNER_FRACTION = 0.5
"""ultimately bounded: leaves where ``V <= INNER_FRACTION c_bnd`` (``c_bnd`` the least ``V`` on the region's boundary)
are left to the inner set unproved"""
SCREEN_FRACTION = 0.1
"""share of the budget spent looking for a counterexample when the origin's argument fails (no certificate is
possible then)"""
BOUNDARY_BUDGET = Budget(max_boxes=100_000, max_seconds=3600.0, batch=4096)
"""the search for V's minimum on the region's boundary: bounded by boxes only, so that a re-check reproduces it"""
BALL_PRECISION = 256
"""bits of the ball arithmetic that confirms counterexamples and the origin's values"""


@dataclass(frozen=True)
class SearchSettings:
    """How hard a certificate is searched for (the budget of each candidate).

    Parameters
    ----------
    max_seconds : float
        Wall-clock seconds of the branch and bound per candidate.
    max_boxes : int
        Boxes evaluated per candidate.
    min_width : float
        Boxes narrower than this fraction of the region in every input are not split further (left undecided).
    batch : int
        Boxes per vectorised evaluation.

    Examples
    --------
    >>> from fsmctl.proofs import SearchSettings
    >>> SearchSettings(max_seconds=10.0).budget().max_seconds
    10.0
    """

    max_seconds: float = 60.0
    max_boxes: int = 2_000_000
    min_width: float = 1.0 / 512
    batch: int = 4096

    def budget(self, seconds: float | None = None) -> Budget:
        """The branch and bound's :class:`~fsmctl.enclosures.branch_bound.Budget` (``seconds``: another time limit).

        Parameters
        ----------
        seconds : float, optional
            A time limit other than ``max_seconds``.

        Returns
        -------
        Budget
        """
        return Budget(self.max_boxes, self.max_seconds if seconds is None else seconds, self.batch)


@dataclass
class CandidateOutcome:
    """What the search established for one candidate (see the module docstring for the verdicts)."""

    candidate: Candidate
    verdict: str
    kind: str | None
    level: float = 0.0
    """``c``: ``{V <= c}`` (its component at the origin) lies in the region and ``V_dot < 0`` on it (outside the
    inner set)"""
    inner_level: float | None = None
    """``c_in`` of an ultimately bounded certificate"""
    ultimate_bound: dict = field(default_factory=dict)
    level_extent: dict = field(default_factory=dict)
    """the box that contains ``{V <= c}``: max ``|sigma_e,k|``, ``|omega_e,k|``"""
    decrease: float | None = None
    """``m``: ``V_dot <= -m`` on ``{c_in <= V <= c}`` outside the core"""
    reach_time: float | None = None
    """s: a bound on the time from ``{V <= c}`` into the inner set (or the core's level set)"""
    core: dict = field(default_factory=dict)
    counterexample: dict | None = None
    search: SignSearch | None = None
    boundary_level: float = math.inf
    inner_target: float | None = None
    """ultimately bounded: the level below which leaves were left to the inner set unproved"""
    notes: list[str] = field(default_factory=list)
    difficulty: str = ""
    seconds: float = 0.0
    sos: dict | None = None
    """an ultimately bounded certificate by sum of squares (:mod:`fsmctl.proofs.certify_sos`): the exact identity"""


# ----------------------------------------------------------------------------------------------- candidates


def _hessians_at_origin(problem: CertifyProblem, V) -> tuple[np.ndarray, np.ndarray]:
    """Nominal (uncertainty at its centre) Hessians of ``V`` and ``V_dot`` in the state at the origin (floats)."""
    fV, _, fW, _ = problem.lyapunov(V)
    xs = problem.x[: problem.n_state]
    x0 = np.zeros(problem.x.numel())
    HV = ca.Function("HV", [problem.x], [ca.hessian(fV(problem.x), xs)[0]])(x0)
    HW = ca.Function("HW", [problem.x], [ca.hessian(fW(problem.x), xs)[0]])(x0)
    return np.array(HV, float), np.array(HW, float)


def _score(HV: np.ndarray, HW: np.ndarray) -> float:
    """``-lambda_max(H_W) / lambda_max(H_V)`` when ``H_V > 0`` and ``H_W < 0`` (a local decay rate), else -inf."""
    if not (np.all(np.isfinite(HV)) and np.all(np.isfinite(HW))):
        return -math.inf
    lv, lw = np.linalg.eigvalsh(0.5 * (HV + HV.T)), np.linalg.eigvalsh(0.5 * (HW + HW.T))
    if lv.min() <= 0 or lw.max() >= 0:
        return -math.inf
    return float(-lw.max() / lv.max())


CANDIDATE_CHOICES = ("auto", "declared")
"""``auto``: the declared V, then the cross-term and quadratic candidates fsmctl finds; ``declared``: only the law's"""


def choose_candidates(
    problem: CertifyProblem,
    law: Law,
    params: np.ndarray,
    J0: np.ndarray,
    inertia_vertices: list[np.ndarray],
    which: str = "auto",
) -> tuple[list[Candidate], list[str]]:
    """The candidates to try, best first, and a note per one left out (see the module docstring).

    Parameters
    ----------
    problem : CertifyProblem
        The closed loop.
    law : fsmctl.symbolic.law.Law
        For its declared ``V``.
    params, J0 : numpy.ndarray
        The agent's packed parameters and nominal inertia.
    inertia_vertices : list of numpy.ndarray
        Values of the uncertainty inputs (``x``'s tail) at which the semidefinite program linearises.
    which : str
        One of :data:`CANDIDATE_CHOICES`.

    Returns
    -------
    (list of Candidate, list of str)
    """
    out: list[Candidate] = []
    notes: list[str] = []
    if law.lyapunov is not None:
        V0 = candidate_expression(law, params, J0)
        out.append(Candidate("declared", V0, note=law.lyapunov.doc))
        if which == "declared":
            return out, notes
        _ellipsoid_candidate(problem, law, params, J0, inertia_vertices, out, notes)
        HV, HW = _hessians_at_origin(problem, V0)
        if _score(HV, HW) == -math.inf and np.all(np.isfinite(HW)):
            scored = []
            for eps in EPSILON_GRID:
                Ve = candidate_expression(law, params, J0, epsilon=eps)
                s = _score(*_hessians_at_origin(problem, Ve))
                if s > -math.inf:
                    scored.append((s, eps, Ve))
            scored.sort(key=lambda r: -r[0])
            for s, eps, Ve in scored[:2]:
                out.append(Candidate("declared + cross term", Ve, epsilon=eps, note=f"local decay rate {s:.3g}"))
            if not scored:
                notes.append("no cross-term weight makes the nominal V_dot negative definite at the origin")
    else:
        notes.append(f"law {law.name!r} declares no Lyapunov candidate (LawBuilder.lyapunov)")
        if which == "declared":
            return out, notes
        _ellipsoid_candidate(problem, law, params, J0, inertia_vertices, out, notes)
    quad = _quadratic_candidate(problem, law, params, J0, inertia_vertices, notes)
    if quad is not None:
        out.append(quad)
    return out, notes


def _ellipsoid_candidate(problem, law, params, J0, vertices, out: list[Candidate], notes: list[str]) -> None:
    """For a question with a disturbance or a moving reference: the attracting ellipsoid of the linearisation
    (:func:`fsmctl.proofs.quadratic_forms.invariant_ellipsoid`) as a candidate, tried right after the law's own."""
    n = problem.n_state
    motion = np.flatnonzero(_motion_mask(problem) & (problem.hi[n:] > 0)) + n
    if motion.size == 0:
        return
    A = _linearisations(problem, vertices, problem.x[:n])
    B = _linearisations(problem, vertices, problem.x[motion])
    if A is None or B is None:
        notes.append("no invariant-ellipsoid candidate: the closed loop has no linearisation at the origin")
        return
    found = invariant_ellipsoid(A, B, problem.hi[motion], problem.hi[:n])
    if found is None:
        notes.append("no invariant-ellipsoid candidate: its linear matrix inequalities are infeasible")
        return
    P, alpha = found
    V = candidate_expression(law, params, J0, P=P)
    out.append(
        Candidate("invariant ellipsoid", V, P=tuple(map(tuple, P.tolist())), note=f"S-procedure rate {alpha:.3g}")
    )


def _linearisations(problem: CertifyProblem, vertices, inputs: ca.SX) -> list[np.ndarray] | None:
    """The Jacobian of the closed loop in ``inputs`` at the origin, at each vertex of the uncertainty (None when one
    is not finite: a switching or fractional-power term)."""
    f = ca.Function("linearisation", [problem.x], [ca.jacobian(problem.field, inputs)])
    mats = [np.array(f(np.concatenate([np.zeros(problem.n_state), v])), float) for v in vertices]
    return mats if all(np.all(np.isfinite(m)) for m in mats) else None


def _quadratic_candidate(problem, law, params, J0, vertices, notes) -> Candidate | None:
    mats = _linearisations(problem, vertices, problem.x[: problem.n_state])
    if mats is None:
        notes.append("the closed loop has no linearisation at the origin (a switching or fractional-power term)")
        return None
    q = quadratic_lyapunov(mats)
    if not q.verified:
        notes.append(f"no quadratic Lyapunov function of the linearisation: {q.detail}")
        return None
    V = candidate_expression(law, params, J0, P=q.P)
    return Candidate("quadratic", V, P=tuple(map(tuple, q.P.tolist())), note=q.detail)


# ----------------------------------------------------------------------------------------------- the search


@dataclass
class LyapunovPrograms:
    """A candidate's ``V``, ``grad V``, ``V_dot`` and ``grad V_dot`` as rigorous evaluators of the input vector."""

    V: IntervalFunction
    dV: IntervalFunction
    W: IntervalFunction
    """``V_dot``"""
    dW: IntervalFunction
    W_function: ca.Function
    V_sx: ca.SX
    neg_V: IntervalFunction
    """``-V`` (minima of ``V`` by :func:`fsmctl.enclosures.branch_bound.bound_maximum`)"""
    neg_dV: IntervalFunction

    def v_bounds(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Enclosure of ``V`` on boxes given as rows ``(k, n_in)``."""
        if lo.shape[0] == 0:
            return np.zeros(0), np.zeros(0)
        a, b, _ = enclose_sharp(self.V, lo.T.copy(), hi.T.copy(), gradient=self.dV)
        return a, b


def lyapunov_programs(problem: CertifyProblem, V) -> LyapunovPrograms:
    """The evaluators of a candidate ``V`` (a SymPy expression in the state symbols) on ``problem``."""
    fV, gV, fW, gW = problem.lyapunov(V)
    progs = [IntervalFunction(f) for f in (fV, gV, fW, gW)]
    v = fV(problem.x)
    neg = IntervalFunction(ca.Function("negV", [problem.x], [-v]))
    neg_grad = IntervalFunction(ca.Function("negV_gradient", [problem.x], [ca.gradient(-v, problem.x)]))
    return LyapunovPrograms(*progs, fW, v, neg, neg_grad)


def origin_argument(
    problem: CertifyProblem, progs: LyapunovPrograms, fractions=CORE_FRACTIONS, box: np.ndarray | None = None
) -> QuadraticCore:
    """The second-order argument near the origin (:func:`fsmctl.proofs.certify_core.quadratic_core`; ``box``: on
    exactly that core box, as fractions of the region per state input)."""
    return quadratic_core(
        problem.x, progs.W_function(problem.x), problem.n_state, problem.lo, problem.hi, fractions=fractions,
        precision=BALL_PRECISION, box=box,
    )  # fmt: skip


def inside_core(problem: CertifyProblem, core: dict, progs: LyapunovPrograms | None = None) -> Callable | None:
    """``inside(lo, hi) -> (N,) bool`` on ``(n_in, N)`` boxes where the origin's argument proves ``V_dot < 0``; None
    when the argument did not pass.

    A box qualifies when it lies in the core box and either the origin is an equilibrium (``r_star = 0``: ``V_dot < 0``
    on the core but at 0), or the box lies outside the ball ``|y| <= r_star``, or (with ``progs``) the concave bound
    about the box's centre ``c`` is negative: ``H + 2 mu I`` negative definite on the core gives, for every
    uncertainty ``u`` of the box, ``V_dot(y) <= V_dot(c) + g(c) . (y - c) - mu |y - c|^2`` (Taylor with the integral
    remainder, scaled state), maximised axis by axis over the box with ``V_dot(c)`` and ``g(c)`` enclosed over the
    box's uncertainty.  The few float operations of that maximum are covered by a relative margin of ``1e-12``.
    """
    if not core.get("passed"):
        return None
    n = problem.n_state
    half = np.asarray(core["half_widths"])[:, None]
    r_star, mu = float(core.get("r_star", 0.0)), float(core.get("mu", 0.0))
    scale = np.maximum(np.abs(problem.lo[:n]), np.abs(problem.hi[:n]))[:, None]

    def inside(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        ok = np.all((lo[:n] >= -half) & (hi[:n] <= half), axis=0)
        if r_star == 0 or not ok.any():
            return ok
        near = np.where(lo[:n] > 0, lo[:n], np.where(hi[:n] < 0, -hi[:n], 0.0))  # the box's point nearest 0
        d = np.nextafter(np.nextafter(near / scale, 0.0) ** 2, 0.0)
        outside = np.nextafter(d.sum(axis=0) * (1 - 1e-12), 0.0) > r_star * r_star * (1 + 1e-12)
        if progs is None:
            return ok & outside
        cols = np.flatnonzero(ok & ~outside)
        concave = np.zeros(lo.shape[1], bool)
        if cols.size and mu > 0:
            concave[cols] = _concave_upper(progs, lo[:, cols], hi[:, cols], n, scale, mu) < 0
        return ok & (outside | concave)

    return inside


def _concave_upper(progs: LyapunovPrograms, lo, hi, n: int, scale: np.ndarray, mu: float) -> np.ndarray:
    """``V_dot(c) + sum_k max_{d_k} (g_k d_k - mu d_k^2)`` over boxes (see :func:`inside_core`)."""
    c_lo, c_hi = lo.copy(), hi.copy()
    c = 0.5 * (lo[:n] + hi[:n])
    c_lo[:n], c_hi[:n] = c, c  # the state at the centre, the uncertainty over the box
    w = progs.W.enclose(c_lo, c_hi).hi[0]
    g = progs.dW.enclose(c_lo, c_hi)
    total = np.where(np.isnan(w), np.inf, w)
    margin = np.abs(total)
    with np.errstate(invalid="ignore", over="ignore"):
        for k in range(n):
            a, b = (lo[k] - c[k]) / scale[k], (hi[k] - c[k]) / scale[k]  # the scaled offsets, a <= 0 <= b
            best = np.full(lo.shape[1], -np.inf)
            for gk in (g.lo[k] * scale[k], g.hi[k] * scale[k]):
                dk = np.clip(gk / (2 * mu), a, b)
                best = np.maximum(best, gk * dk - mu * dk * dk)
            best = np.where(np.isnan(best), np.inf, best)
            total = total + best
            margin = margin + np.abs(best) + mu * np.maximum(a * a, b * b)
    return total + 1e-12 * margin + 1e-300


def excluded(
    problem: CertifyProblem, progs: LyapunovPrograms, core: dict, inner_level: float | None
) -> Callable | None:
    """The search's exclusion: boxes of the core (:func:`inside_core`) and, with ``inner_level``, boxes on which
    ``V <= inner_level`` is proved (they belong to the inner set of an ultimately bounded certificate)."""
    in_core = inside_core(problem, core, progs)
    if inner_level is None:
        return in_core

    def inside(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        _, vhi, _ = enclose_sharp(progs.V, lo, hi, gradient=progs.dV)
        out = vhi <= inner_level
        return out | in_core(lo, hi) if in_core is not None else out

    return inside


def boundary_level(problem: CertifyProblem, progs: LyapunovPrograms, budget: Budget) -> float:
    """A certified lower bound of ``V`` on the boundary of the state region (its faces, by :func:`bound_maximum`)."""
    n = problem.n_state
    neg, neg_grad = progs.neg_V, progs.neg_dV
    best = math.inf
    for k in range(n):
        for side in (problem.lo[k], problem.hi[k]):
            lo, hi = problem.lo.copy(), problem.hi.copy()
            lo[n:], hi[n:] = 0.0, 0.0  # V does not depend on the uncertainty
            lo[k] = hi[k] = side
            m = bound_maximum(neg, lo, hi, gradient=neg_grad, relative_gap=1e-3, budget=budget)
            best = min(best, -m.upper)
    return best


def inner_target(c_bnd: float, asymptotic: bool) -> float | None:
    """The level below which an ultimately bounded question's leaves join the inner set unproved,
    ``INNER_FRACTION c_bnd`` (``V_dot >= 0`` is expected somewhere near the origin, the search need not resolve where);
    None for an asymptotic question or without a positive boundary level."""
    return INNER_FRACTION * c_bnd if not asymptotic and c_bnd > 0 else None


def certify_candidate(
    problem: CertifyProblem,
    candidate: Candidate,
    settings: SearchSettings,
    *,
    progress: Callable[[int, float], None] | None = None,
    stage: Callable[[str], None] | None = None,
) -> CandidateOutcome:
    """Search a certificate for one candidate (see the module docstring).

    Parameters
    ----------
    problem : CertifyProblem
        The closed loop with its uncertainty.
    candidate : Candidate
        ``V``.
    settings : SearchSettings
        The budget.
    progress : callable, optional
        ``progress(boxes, fraction_decided)``.
    stage : callable, optional
        ``stage(step)`` before each step (:data:`fsmctl.proofs.certify_report.STEPS`).

    Returns
    -------
    CandidateOutcome
    """
    t0 = time.perf_counter()
    report = stage or (lambda step: None)
    report(BOUNDARY)
    progs = lyapunov_programs(problem, candidate.expression)
    asymptotic = not np.any(problem.hi[problem.n_state :][_motion_mask(problem)] > 0)
    c_bnd = boundary_level(problem, progs, BOUNDARY_BUDGET)
    sos_why = ""
    if not asymptotic and c_bnd > 0:
        report(SOS)
        sos = sos_outcome(problem, candidate, progs, c_bnd)
        if isinstance(sos, CandidateOutcome):
            sos.seconds = time.perf_counter() - t0
            return sos
        sos_why = sos
    report(ORIGIN)
    core = origin_argument(problem, progs)
    if asymptotic and core.get("passed") and core["r_star"] > 0:  # pragma: no cover - w0 = G = 0 at an equilibrium
        core = QuadraticCore(passed=False, why="V_dot(0) = 0 and grad V_dot(0) = 0 could not be proved")
    # without the origin's argument an asymptotic certificate is out of reach: search only for a counterexample
    # nor, with a V_dot only semidefinite at the origin, an inner set: a short search for a counterexample
    screen = not core.get("passed") and (asymptotic or core.get("semidefinite", False))
    seconds = settings.max_seconds * (SCREEN_FRACTION if screen else 1.0)
    c_target = inner_target(c_bnd, asymptotic)
    report(SEARCH)
    search = prove_negative(
        progs.W, problem.lo, problem.hi, gradient=progs.dW, budget=settings.budget(seconds),
        min_width=settings.min_width, exclude=excluded(problem, progs, core, c_target), progress=progress,
        stop_on_positive=asymptotic,  # any point with V_dot > 0 refutes an asymptotic claim
    )  # fmt: skip
    out = CandidateOutcome(candidate, INCONCLUSIVE, ASYMPTOTIC if asymptotic else ULTIMATELY_BOUNDED, core=core)
    out.search = search
    out.boundary_level = c_bnd
    out.inner_target = c_target
    report(LEVELS)
    _judge(problem, progs, out, asymptotic)
    if sos_why and out.verdict == INCONCLUSIVE:
        out.difficulty = (
            f"{out.difficulty}; sum of squares: {sos_why}" if out.difficulty else f"sum of squares: {sos_why}"
        )
    out.seconds = time.perf_counter() - t0
    return out


SOS_AGREEMENT_POINTS = 32
"""seeded points of the region at which the sum-of-squares route's polynomial ``V_dot`` must agree with the closed
loop's graphs (to ``1e-9``) before it is used"""


def sos_polynomials(
    problem: CertifyProblem, V, W_function: ca.Function
) -> tuple[dict, dict, np.ndarray, list[str]] | str:
    """``(V, V_dot, half_widths, names)`` as exact polynomials in the state and the polynomial model's uncertain
    inputs of positive width (:class:`fsmctl.proofs.certify_polynomial.PolynomialLoop`,
    :func:`fsmctl.proofs.certify_sos.exact_polynomial`), or why the sum-of-squares route does not apply."""
    loop = problem.polynomial
    if isinstance(loop, str):
        return f"the closed loop is not polynomial here: {loop}"
    n = problem.n_state
    s, w, z = state_symbols(n - 6)
    symbols = [*s, *w, *z, *loop.symbols()]
    half = np.concatenate([problem.hi[:n], loop.half_widths])
    zero = {x: 0 for x, h in zip(symbols, half, strict=True) if h == 0}
    keep = [x for x, h in zip(symbols, half, strict=True) if h > 0]
    Vr = sp.sympify(V).xreplace({f: sp.Rational(f) for f in sp.sympify(V).atoms(sp.Float)}).xreplace(zero)
    field_ = loop.field.xreplace(zero)
    Vp = exact_polynomial(Vr, keep)
    if Vp is None:
        return "V is not a polynomial"
    V_dot = sum((sp.diff(Vr, x) * f for x, f in zip([*s, *w, *z], field_, strict=True)), sp.S.Zero)
    Wp = exact_polynomial(V_dot, keep)
    if Wp is None:
        return "V_dot is not a polynomial"
    # the polynomial model and the graphs the branch and bound encloses are built apart: they must agree at the
    # true loop's points (the model's inputs computed from the inertia and the disturbance there)
    f = sp.lambdify(symbols, V_dot, "numpy")
    rng = np.random.default_rng(29)
    theta = [k for k, name in enumerate(problem.names) if name.startswith("theta")]
    dist = [problem.names.index(f"d[{k}]") for k in range(3)]
    for _ in range(SOS_AGREEMENT_POINTS):
        x = rng.uniform(problem.lo, problem.hi)
        point = np.concatenate([x[:n], loop.inputs_at(x[3:6], x[theta], x[dist])])
        a, b = float(f(*point)), float(W_function(x))
        if not abs(a - b) <= 1e-9 * (1 + abs(b)):
            return f"the polynomial V_dot disagrees with the closed loop's graphs ({a:.17g} vs {b:.17g})"
    names = [str(x) for x in keep]
    return Vp, Wp, half[half > 0], names


def sos_outcome(
    problem: CertifyProblem, candidate: Candidate, progs: LyapunovPrograms, c_bnd: float
) -> CandidateOutcome | str:
    """An ultimately bounded certificate by sum of squares (:mod:`fsmctl.proofs.certify_sos`) on
    ``{c_in <= V <= c_bnd}``, or why there is none."""
    polys = sos_polynomials(problem, candidate.expression, progs.W_function)
    if isinstance(polys, str):
        return polys
    Vp, Wp, half, names = polys
    res = sos_ultimate_bound(Vp, Wp, half, c_bnd, names)
    if isinstance(res, str):
        return res
    out = CandidateOutcome(candidate, CERTIFIED, ULTIMATELY_BOUNDED)
    out.boundary_level = c_bnd
    out.level = float(res.level)
    c_in = float_above(res.inner_level)
    out.inner_level = c_in
    rate = float_below(res.rate)
    out.sos = {
        **res.record,
        "model": problem.polynomial.how,
        "detail": res.detail,
        "rate": rate,
        "seconds": res.seconds,
    }
    out.decrease, out.reach_time = sos_decrease(rate, c_in, out.level)
    levels_report(problem, progs, out, c_in)
    return out


def _motion_mask(problem: CertifyProblem) -> np.ndarray:
    """Over the uncertainty inputs: True for those that move the equilibrium (disturbance, reference motion)."""
    return np.array([not name.startswith("theta") for name in problem.names[problem.n_state :]])


def _judge(problem: CertifyProblem, progs: LyapunovPrograms, out: CandidateOutcome, asymptotic: bool) -> None:
    """The verdict from the leaves (see the module docstring) and the levels that go with it."""
    s = out.search
    bad_lo = np.concatenate([s.positive_lo, s.undecided_lo])  # leaves where V_dot < 0 is not proved
    bad_hi = np.concatenate([s.positive_hi, s.undecided_hi])
    vlo, vhi = progs.v_bounds(bad_lo, bad_hi)
    c_bnd = out.boundary_level
    c_in: float | None = None
    if asymptotic:
        refuting = s.positive_points  # V_dot > 0 at a point other than the origin
        certified = bool(out.core.get("passed")) and bad_lo.shape[0] == 0 and c_bnd > 0
        out.level = float(min(c_bnd, vlo.min() if vlo.size else math.inf)) if out.core.get("passed") else 0.0
    else:
        # V_dot > 0 at a point where V >= min V on the boundary: no inner set inside the region can exclude it
        pv_lo, _ = progs.v_bounds(s.positive_points, s.positive_points)
        refuting = s.positive_points[pv_lo >= c_bnd]
        # the core's ball |y| <= r* (V_dot may be >= 0 there) was searched like the rest: its leaves are in bad_*
        c_all = float(vhi.max()) if vhi.size else 0.0
        if out.inner_target is not None and s.excluded_lo.shape[0]:
            c_all = max(c_all, out.inner_target)
        certified = c_all < c_bnd
        c_in, out.level = (c_all, c_bnd) if certified else split_levels(vlo, vhi, c_bnd)
        out.inner_level = c_in
    if refuting.shape[0]:
        out.verdict = COUNTEREXAMPLE
        out.counterexample = counterexample_at(problem, progs, refuting)
    elif certified:
        out.verdict = CERTIFIED
    else:
        out.verdict = INCONCLUSIVE
        out.difficulty = out.core.get("why", "") if asymptotic and not out.core.get("passed") else ""
        out.difficulty = out.difficulty or _difficulty(problem, progs, s, bool(out.core.get("semidefinite")))
    if c_in is not None or out.level > 0:
        if out.level > (c_in or 0.0):
            levels_report(problem, progs, out, c_in)


def split_levels(vlo: np.ndarray, vhi: np.ndarray, c_bnd: float) -> tuple[float | None, float]:
    """``(c_in, c_out)``: the smallest inner level with every unproved leaf either inside ``{V <= c_in}`` or above
    ``c_out > c_in`` (None when no such pair exists)."""
    if vlo.size == 0:
        return 0.0, c_bnd
    order = np.argsort(vhi)
    hi_sorted, lo_sorted = vhi[order], vlo[order]
    suffix_min = np.minimum.accumulate(lo_sorted[::-1])[::-1]
    for k in range(len(order) + 1):
        c_in = float(hi_sorted[k - 1]) if k else 0.0
        c_out = min(c_bnd, float(suffix_min[k])) if k < len(order) else c_bnd
        if c_out > c_in:
            return c_in, c_out
    return None, 0.0


def levels_report(problem: CertifyProblem, progs: LyapunovPrograms, out: CandidateOutcome, c_in: float | None) -> None:
    """Extent of ``{V <= c}`` and ``{V <= c_in}``, the decrease on the annulus and the time to cross it, into
    ``out`` (the certify run's rule, repeated by ``fsmctl certify --check``)."""
    s = out.search
    n = problem.n_state
    names = problem.names[:n]

    def extent(level: float) -> dict:
        m = sublevel_extent(progs, problem.lo, problem.hi, level, n)
        return dict(zip(names, m.tolist(), strict=True))

    out.level_extent = extent(out.level)
    if c_in is None:
        return
    vlo, _ = progs.v_bounds(s.proved_lo, s.proved_hi) if s is not None else (np.zeros(0), None)
    annulus = (vlo <= out.level) & (vlo >= c_in)
    if c_in > 0 and np.any(annulus):
        # V_dot <= -m on the leaves of {c_mid <= V <= c}: the time from {V <= c} down to c_mid is at most (c - c_mid)/m
        c_mid = 0.5 * (c_in + out.level)
        band = annulus & (vlo >= c_mid)
        if np.any(band):
            out.decrease = float(-s.proved_sup[band].max())
            if out.decrease > 0:
                out.reach_time = float((out.level - c_mid) / out.decrease)
    if problem.hi[n:].any():
        ext = extent(c_in)
        sig = max(ext[f"sigma_e[{k}]"] for k in range(3))
        om = max(ext[f"omega_e[{k}]"] for k in range(3))
        out.ultimate_bound = {
            "sigma_e_max": sig,
            "omega_e_max_rad_s": om,
            "attitude_error_max_deg": math.degrees(4 * math.atan(math.sqrt(3) * sig)),
        }


EXTENT_STEPS = 6
"""bisection steps per state input and side of :func:`sublevel_extent` (the bound is within 2^-6 of the region's
half-width of the best this route can prove)"""
EXTENT_BUDGET = Budget(max_boxes=20_000, max_seconds=60.0, batch=1024)
"""per slab of :func:`sublevel_extent` (bounded by boxes: reproducible)"""


def sublevel_extent(progs: LyapunovPrograms, lo: np.ndarray, hi: np.ndarray, level: float, n: int) -> np.ndarray:
    """``(n,)``: for each state input ``k``, a ``t_k`` with ``|x_k| <= t_k`` on ``{V <= level}`` within the state box
    ``[lo, hi]`` (full input vectors; ``V`` depends on the state alone).

    By bisection on ``t``: ``V > level`` is proved on the slabs ``x_k >= t`` and ``x_k <= -t`` of the box (a certified
    lower bound of ``min V`` there, :func:`fsmctl.enclosures.branch_bound.bound_maximum` of ``-V``)."""
    lo, hi = lo.copy(), hi.copy()
    lo[n:], hi[n:] = 0.0, 0.0
    neg, neg_grad = progs.neg_V, progs.neg_dV
    out = np.zeros(n)
    for k in range(n):
        top = max(abs(lo[k]), abs(hi[k]))

        def above(t: float, k: int = k) -> bool:
            """``V > level`` on both slabs ``|x_k| >= t``."""
            for side in (1, -1):
                slo, shi = lo.copy(), hi.copy()
                if side > 0:
                    slo[k] = max(lo[k], t)
                else:
                    shi[k] = min(hi[k], -t)
                if slo[k] > shi[k]:
                    continue
                m = bound_maximum(neg, slo, shi, gradient=neg_grad, relative_gap=1e-3, budget=EXTENT_BUDGET)
                if not -m.upper > level:
                    return False
            return True

        a, b = 0.0, top  # V > level is known beyond top (outside the box)
        for _ in range(EXTENT_STEPS):
            mid = 0.5 * (a + b)
            a, b = (a, mid) if above(mid) else (mid, b)
        out[k] = b
    return out


def counterexample_at(problem: CertifyProblem, progs: LyapunovPrograms, points: np.ndarray) -> dict:
    """The point of largest proved ``V_dot`` among ``points``, confirmed in ball arithmetic (the certify run's rule,
    repeated by ``fsmctl certify --check``)."""
    vals = progs.W.enclose(points.T.copy(), points.T.copy()).lo[0]
    k = int(np.argmax(vals))
    x = points[k]
    ball = progs.W.evaluate_ball(x.tolist(), precision=BALL_PRECISION)[0]
    v = progs.V.evaluate_ball(x.tolist(), precision=BALL_PRECISION)[0]
    return {
        "point": dict(zip(problem.names, x.tolist(), strict=True)),
        "V_dot": float(vals[k]),
        "V_dot_ball": str(ball),
        "V": float(v.mid()),
        "confirmed": bool(ball > 0),
    }


def _difficulty(problem: CertifyProblem, progs: LyapunovPrograms, s: SignSearch, screened: bool = False) -> str:
    """Where the undecided leaves are, in words."""
    if s.undecided_lo.shape[0] == 0:
        return ""
    e = progs.W.enclose(s.undecided_lo.T.copy(), s.undecided_hi.T.copy())
    switching = float(np.mean(~e.continuous))
    n = problem.n_state
    mid = 0.5 * (s.undecided_lo + s.undecided_hi)[:, :n]
    near = float(np.mean(np.all(np.abs(mid) <= 0.1 * problem.hi[:n], axis=1)))
    parts = [f"{s.undecided_lo.shape[0]} boxes undecided ({100 * s.volume['undecided']:.3g} % of the region)"]
    if switching > 0:
        parts.append(f"{100 * switching:.0f} % of them straddle a switch (sgn, a comparison) of V_dot")
    if near > 0:
        parts.append(f"{100 * near:.0f} % lie within 10 % of the region around the origin")
    if s.exhausted:
        parts.append(
            "the budget ran out"
            + (
                " (V_dot is not negative definite at the origin: only a short search for a counterexample was run)"
                if screened
                else ""
            )
        )
    return "; ".join(parts)
