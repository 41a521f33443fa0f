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
    an inner sublevel set ``{V <= c_in}``, whose extent is the certified ultimate error bound.  The largest
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

Candidates, in order: the law's declared ``V`` (:meth:`fsmctl.symbolic.law.LawBuilder.lyapunov`); when its
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

from fsmctl.enclosures.branch_bound import Budget, SignSearch, bound_maximum, enclose_sharp, prove_negative
from fsmctl.enclosures.intervals import IntervalFunction
from fsmctl.proofs.certify_core import CORE_FRACTIONS, QuadraticCore, quadratic_core
from fsmctl.proofs.certify_problem import (
    Candidate,
    CertifyProblem,
    candidate_expression,
)
from fsmctl.proofs.quadratic_forms import quadratic_lyapunov
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
    "inside_core",
    "lyapunov_programs",
    "origin_argument",
    "split_levels",
]

CERTIFIED, COUNTEREXAMPLE, INCONCLUSIVE = "certified", "counterexample", "inconclusive"
ASYMPTOTIC, ULTIMATELY_BOUNDED = "asymptotic", "ultimately bounded"

EPSILON_GRID = tuple(10.0 ** (k / 4) for k in range(-16, 5))
"""cross-term weights screened (1e-4 ... 10): the nominal Hessians at the origin pick the best"""
SCREEN_FRACTION = 0.1
"""share of the budget spent looking for a counterexample when the origin's argument fails (no certificate is
possible then)"""
BOUNDARY_BUDGET = Budget(max_boxes=20_000, max_seconds=3600.0, batch=4096)
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
    notes: list[str] = field(default_factory=list)
    difficulty: str = ""
    seconds: float = 0.0


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
    quad = _quadratic_candidate(problem, law, params, J0, inertia_vertices, notes)
    if quad is not None:
        out.append(quad)
    return out, notes


def _quadratic_candidate(problem, law, params, J0, vertices, notes) -> Candidate | None:
    xs = problem.x[: problem.n_state]
    A = ca.Function("A", [problem.x], [ca.jacobian(problem.field, xs)])
    mats = []
    for v in vertices:
        x0 = np.concatenate([np.zeros(problem.n_state), v])
        m = np.array(A(x0), float)
        if not np.all(np.isfinite(m)):
            notes.append("the closed loop has no linearisation at the origin (a switching or fractional-power term)")
            return None
        mats.append(m)
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
    return LyapunovPrograms(*progs, fW, fV(problem.x))


def origin_argument(problem: CertifyProblem, progs: LyapunovPrograms, fractions=CORE_FRACTIONS) -> QuadraticCore:
    """The second-order argument near the origin (:func:`fsmctl.proofs.certify_core.quadratic_core`)."""
    return quadratic_core(
        problem.x, progs.W_function(problem.x), problem.n_state, problem.lo, problem.hi, fractions=fractions,
        precision=BALL_PRECISION,
    )  # fmt: skip


def inside_core(problem: CertifyProblem, core: dict) -> Callable | None:
    if not core.get("passed"):
        return None
    n = problem.n_state
    half = np.asarray(core["half_widths"])[:, None]

    def inside(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        return np.all((lo[:n] >= -half) & (hi[:n] <= half), axis=0)

    return inside


def boundary_level(problem: CertifyProblem, progs: LyapunovPrograms, budget: Budget) -> float:
    """A certified lower bound of ``V`` on the boundary of the state region (its faces, by :func:`bound_maximum`)."""
    n = problem.n_state
    neg = IntervalFunction(ca.Function("negV", [problem.x], [-progs.V_sx]))
    best = math.inf
    for k in range(n):
        for side in (problem.lo[k], problem.hi[k]):
            lo, hi = problem.lo.copy(), problem.hi.copy()
            lo[n:], hi[n:] = 0.0, 0.0  # V does not depend on the uncertainty
            lo[k] = hi[k] = side
            m = bound_maximum(neg, lo, hi, relative_gap=1e-3, budget=budget)
            best = min(best, -m.upper)
    return best


def certify_candidate(
    problem: CertifyProblem,
    candidate: Candidate,
    settings: SearchSettings,
    *,
    progress: Callable[[int, float], None] | None = None,
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

    Returns
    -------
    CandidateOutcome
    """
    t0 = time.perf_counter()
    progs = lyapunov_programs(problem, candidate.expression)
    asymptotic = not np.any(problem.hi[problem.n_state :][_motion_mask(problem)] > 0)
    core = origin_argument(problem, progs)
    if asymptotic and core.get("passed") and core["r_star"] > 0:  # pragma: no cover - w0 = G = 0 at an equilibrium
        core = QuadraticCore(passed=False, why="V_dot(0) = 0 and grad V_dot(0) = 0 could not be proved")
    if core.get("passed") and core["r_star"] >= core["fraction"]:
        core = QuadraticCore(passed=False, why=f"the ball where V_dot may be >= 0 (radius {core['r_star']:.3g} of "
                             f"the region) is not inside the core box ({core['fraction']:g} of the region)")  # fmt: skip
    # without the origin's argument an asymptotic certificate is out of reach: search only for a counterexample
    seconds = settings.max_seconds * (SCREEN_FRACTION if asymptotic and not core.get("passed") else 1.0)
    search = prove_negative(
        progs.W, problem.lo, problem.hi, gradient=progs.dW, budget=settings.budget(seconds),
        min_width=settings.min_width, exclude=inside_core(problem, core), progress=progress,
        stop_on_positive=asymptotic,  # any point with V_dot > 0 refutes an asymptotic claim
    )  # fmt: skip
    out = CandidateOutcome(candidate, INCONCLUSIVE, ASYMPTOTIC if asymptotic else ULTIMATELY_BOUNDED, core=core)
    out.search = search
    out.boundary_level = boundary_level(problem, progs, BOUNDARY_BUDGET)
    _judge(problem, progs, out, asymptotic)
    out.seconds = time.perf_counter() - t0
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
        c_all = float(vhi.max()) if vhi.size else 0.0
        if out.core.get("passed"):  # V_dot < 0 on the core outside the ball |y| <= r*: the ball joins the inner set
            c_all = max(c_all, _ball_level(problem, progs, out.core["r_star"]))
        certified = c_all < c_bnd
        c_in, out.level = (c_all, c_bnd) if certified else split_levels(vlo, vhi, c_bnd)
        out.inner_level = c_in
    if refuting.shape[0]:
        out.verdict = COUNTEREXAMPLE
        out.counterexample = _counterexample(problem, progs, refuting)
    elif certified:
        out.verdict = CERTIFIED
    else:
        out.verdict = INCONCLUSIVE
        out.difficulty = out.core.get("why", "") if asymptotic and not out.core.get("passed") else ""
        out.difficulty = out.difficulty or _difficulty(problem, progs, s)
    if c_in is not None or out.level > 0:
        if out.level > (c_in or 0.0):
            _levels_report(problem, progs, out, c_in)


def _ball_level(problem: CertifyProblem, progs: LyapunovPrograms, r_star: float) -> float:
    """A certified upper bound of ``V`` on the box ``|y_k| <= r*`` (scaled state) that holds the ball of the core."""
    n = problem.n_state
    scale = np.maximum(np.abs(problem.lo[:n]), np.abs(problem.hi[:n]))
    lo, hi = np.zeros(problem.lo.size), np.zeros(problem.lo.size)
    lo[:n], hi[:n] = -r_star * scale, r_star * scale
    f = IntervalFunction(ca.Function("V", [problem.x], [progs.V_sx]))
    return bound_maximum(f, lo, hi, relative_gap=1e-3, budget=BOUNDARY_BUDGET).upper


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


def _levels_report(problem: CertifyProblem, progs: LyapunovPrograms, out: CandidateOutcome, c_in: float | None) -> None:
    """Extent of ``{V <= c}`` and ``{V <= c_in}``, the decrease on the annulus and the time to cross it."""
    s = out.search
    n = problem.n_state
    lo, hi = s.proved_lo, s.proved_hi
    vlo, _ = progs.v_bounds(lo, hi)
    names = problem.names[:n]

    def extent(level: float) -> dict:
        rows = vlo <= level
        parts = [np.abs(lo[rows, :n]), np.abs(hi[rows, :n])]
        if s.excluded_lo.shape[0]:
            parts += [np.abs(s.excluded_lo[:, :n]), np.abs(s.excluded_hi[:, :n])]
        if c_in is not None and level == c_in:
            blo = np.concatenate([s.positive_lo, s.undecided_lo])
            bhi = np.concatenate([s.positive_hi, s.undecided_hi])
            parts += [np.abs(blo[:, :n]), np.abs(bhi[:, :n])]
        m = np.max(np.concatenate(parts), axis=0) if any(p.size for p in parts) else np.zeros(n)
        return dict(zip(names, m.tolist(), strict=True))

    out.level_extent = extent(out.level)
    annulus = (vlo <= out.level) & (vlo >= (c_in or 0.0))
    if c_in is not None and c_in > 0 and np.any(annulus):
        # V_dot <= -m on the leaves of {c_mid <= V <= c}: the time from {V <= c} down to c_mid is at most (c - c_mid)/m
        c_mid = 0.5 * (c_in + out.level)
        band = annulus & (vlo >= c_mid)
        if np.any(band):
            out.decrease = float(-s.proved_sup[band].max())
            if out.decrease > 0:
                out.reach_time = float((out.level - c_mid) / out.decrease)
    if c_in is not None and problem.hi[n:].any():
        ext = extent(c_in)
        sig = max(ext[f"sigma_e[{k}]"] for k in range(3))
        om = max(ext[f"omega_e[{k}]"] for k in range(3))
        out.ultimate_bound = {
            "sigma_e_max": sig,
            "omega_e_max_rad_s": om,
            "attitude_error_max_deg": math.degrees(4 * math.atan(math.sqrt(3) * sig)),
        }


def _counterexample(problem: CertifyProblem, progs: LyapunovPrograms, points: np.ndarray) -> dict:
    """The point of largest proved ``V_dot`` among ``points``, confirmed in ball arithmetic."""
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


def _difficulty(problem: CertifyProblem, progs: LyapunovPrograms, s: SignSearch) -> str:
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
        parts.append("the budget ran out")
    return "; ".join(parts)
