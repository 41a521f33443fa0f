"""The claims of Liang, Sun & Wang (2012), Section 3, and their checks.

Each :class:`Claim` has an id (shown by ``fsmctl prove --list``), the paper's
equation numbers, a title and a check.  A check returns a :class:`ClaimResult`
whose verdict is one of

``proved``
    established symbolically (SymPy, on the model of :mod:`fsmctl.symbolic`, the one ``python -m derive`` generates);
``numeric``
    only sampling could decide it; the detail says how many samples and over which ranges,
    and it is not a proof;
``erratum``
    the printed statement is false: the detail shows the counterexample or residual and
    the corrected statement, itself checked (the errata are those of :mod:`fsmctl.proofs.errata`);
``fails for this scenario``
    a scenario-dependent condition does not hold for the chosen scenario.

``unproved`` marks a check that unexpectedly did not go through (a bug or a changed model);
it makes ``fsmctl prove`` exit 1.

Symbolic checks reuse :mod:`fsmctl.symbolic` (the model, the control law) and :mod:`fsmctl.proofs.errata`, and
never re-type the model.

Size: one registry, the claims of the paper's Section 3: a :class:`Claim` per lemma, theorem and remark, each
with its short check beside it, in the paper's order; a claim is added in one place, next to its neighbours.
"""

from __future__ import annotations

import math
import multiprocessing
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np
import sympy as sp

import fsmctl.proofs.theorem1 as t1
import fsmctl.proofs.theorem2 as t2
import fsmctl.proofs.theorem2_bound as t2b
import fsmctl.proofs.theorem2_report as t2r
from fsmctl.model.scenario import Scenario
from fsmctl.parallel import resolve_workers, worker_pool

__all__ = [
    "CLAIMS",
    "ERRATUM",
    "FAILS",
    "NUMERIC",
    "PROVED",
    "UNPROVED",
    "VERDICTS",
    "Claim",
    "ClaimResult",
    "ProofContext",
    "claim_ids",
    "documented_finding_applies",
    "get_claim",
    "run_claims",
]

PROVED = "proved"
NUMERIC = "numeric"
ERRATUM = "erratum"
FAILS = "fails for this scenario"
UNPROVED = "unproved"
VERDICTS = (PROVED, NUMERIC, ERRATUM, FAILS)


@dataclass(frozen=True)
class ClaimResult:
    """Outcome of one claim: ``id``, ``equations``, ``verdict``, ``detail``, ``seconds`` (and LaTeX, data).

    Parameters
    ----------
    id : str
        The claim's id (:func:`claim_ids`).
    equations : str
        The equation numbers of Liang et al. 2012 it concerns.
    title : str
        What the claim says.
    verdict : str
        One of :data:`VERDICTS` (``proved``, ``numeric``, ``erratum``, ``fails for this scenario``) or
        ``unproved`` (an unexpected failure of the check).
    detail : str
        The steps that were checked, one per line (``[ok]``/``[FAILS]``), the counterexample of an erratum.
    seconds : float
        Time the check took.
    latex : str, optional
        Display LaTeX of the statement that was checked (corrected where the paper is wrong).
    holds : bool
        False when the outcome is a failure for the scenario or an unexpected result of the tool.
    documented : str or None
        The verdict the registry documents for this claim (:attr:`Claim.expected`); None for a claim that uses the
        scenario when the scenario is not one of the paper's cases over Theorem 2's default region (no documented
        finding: it is expected to hold).
    as_documented : bool
        The verdict is the documented one (or, without one, the claim holds).
    data : dict
        Machine-readable numbers (scenario checks).

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.proofs import ProofContext, run_claims
    >>> results = run_claims(["lemma2-sqrt-sum", "theorem1-gains"], ProofContext(fsmctl.paper_scenario()))
    >>> [(r.id, r.verdict, r.holds, r.as_documented) for r in results]
    [('lemma2-sqrt-sum', 'proved', True, True), ('theorem1-gains', 'proved', True, True)]
    >>> print(results[0].detail.splitlines()[0])
    [ok] with a_i = V_i^(1/2) >= 0 the claim is (sum a_i)^2 >= sum a_i^2 (both sides >= 0, sqrt is monotone)
    """

    id: str
    equations: str
    title: str
    verdict: str
    detail: str
    seconds: float
    latex: str | None = None
    """display LaTeX of the statement that was checked (corrected where the paper is wrong)"""
    holds: bool = True
    """False when the outcome is a failure for the scenario or an unexpected result of the tool"""
    documented: str | None = None
    """the registry's documented verdict (:attr:`Claim.expected`) where it applies, else None (expected to hold)"""
    as_documented: bool = True
    """the verdict is the documented one (without one: the claim holds)"""
    data: dict = field(default_factory=dict)
    """machine-readable numbers (scenario checks)"""

    def to_dict(self) -> dict:
        """The result as a dict of its fields (what ``fsmctl prove --json`` writes per claim)."""
        return asdict(self)


@dataclass(frozen=True)
class ProofContext:
    """What scenario-dependent checks need: the scenario and the sampling options of Theorem 2.

    Parameters
    ----------
    scenario : Scenario
        Supplies the gains, the topology (Theorem 1), the inertias, uncertainty and disturbance (Theorem 2).
    region : Region
        The ``(sigma_e, omega_e)`` box of Theorem 2's sampled requirement (:func:`delta_requirements`).
    n_random : int
        Random samples of that box added to its grid.
    seed : int
        Seed of those samples.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.proofs import ProofContext, Region
    >>> ctx = ProofContext(fsmctl.paper_scenario(), Region(sigma=0.02, omega=0.02), n_random=500)
    >>> ctx.scenario.n_agents, ctx.region.describe()
    (6, '|sigma_e,k| <= 0.02, |omega_e,k| <= 0.02 rad/s')
    """

    scenario: Scenario
    region: t2.Region = field(default_factory=t2.Region)
    n_random: int = 3000
    seed: int = 0


@dataclass
class _Outcome:
    verdict: str
    lines: list[str]
    latex: str | None = None
    holds: bool = True
    data: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Claim:
    """A checkable statement of the paper."""

    id: str
    equations: str
    title: str
    check: Callable[[ProofContext], _Outcome]
    uses_scenario: bool = False
    heavy: bool = False
    """several seconds of SymPy: run in a worker process when ``workers > 1``"""
    expected: str = PROVED
    """the documented finding (``docs/findings.md``): the verdict of the check on the paper's scenario (every
    case of Section 4, Theorem 2's default region); an ``erratum`` and a ``fails for this scenario`` are findings"""


def _mark(ok: bool) -> str:
    return "ok" if ok else "FAILS"


def _steps_outcome(steps: list[tuple[bool, str]], latex: str, extra: list[str] | None = None) -> _Outcome:
    """``proved`` when every step holds, else ``unproved`` (a step the tool expected to prove did not go through)."""
    lines = [f"[{_mark(ok)}] {text}" for ok, text in steps] + (extra or [])
    if all(ok for ok, _ in steps):
        return _Outcome(PROVED, lines, latex)
    return _Outcome(UNPROVED, [*lines, "UNEXPECTED: a step above could not be established"], latex, holds=False)


def _zero(expr) -> bool:
    if isinstance(expr, sp.MatrixBase):
        return all(_zero(x) for x in expr)
    return sp.simplify(expr) == 0


def _expand_zero(m) -> bool:
    return all(sp.expand(x) == 0 for x in sp.Matrix(m))


def _erratum(check: Callable, own_steps: list[tuple[bool, str]] | None = None, extra: list[str] | None = None):
    """Run one :mod:`fsmctl.proofs.errata` check and turn it into an ``erratum`` outcome."""
    e = check()
    lines = [
        f"as printed: {e.as_printed}",
        f"counterexample / residual: {e.residual}",
        f"correct: {e.correct}",
        f"consequence: {e.consequence}",
        f"[{_mark(e.checked)}] fsmctl.proofs.errata '{e.id}': printed form refuted and corrected form checked",
    ]
    lines += [f"[{_mark(ok)}] {text}" for ok, text in (own_steps or [])]
    lines += extra or []
    ok = e.checked and all(ok for ok, _ in (own_steps or []))
    latex = rf"\text{{printed: }} {e.as_printed_latex} \qquad \text{{correct: }} {e.correct_latex}"
    if ok:
        return _Outcome(ERRATUM, lines, latex, data={"erratum": e.id})
    return _Outcome(UNPROVED, [*lines, "UNEXPECTED: the erratum could not be confirmed"], latex, holds=False)


# ----------------------------------------------------------------------------- Lemmas 1-2


def _lemma1(ctx: ProofContext) -> _Outcome:
    """Lemma 1 (eq 10): ``Omega_dot <= -lambda Omega^eps`` gives ``T <= Omega(0)^(1-eps) / (lambda (1-eps))``."""
    t = sp.Symbol("t", nonnegative=True)
    lam, om0, q = sp.symbols("lambda Omega_0 q", positive=True)  # q = 1 - eps in (0, 1)
    eps = 1 - q
    Om = sp.Function("Omega", positive=True)(t)
    slack = sp.Function("r", nonnegative=True)(t)  # Omega_dot = -lambda Omega^eps - r, r >= 0
    y = Om ** (1 - eps)
    y_dot = sp.diff(y, t).subs(sp.diff(Om, t), -lam * Om**eps - slack)
    s1 = _zero(y_dot - (-lam * (1 - eps) - (1 - eps) * Om ** (-eps) * slack))
    s2 = bool((-(1 - eps) * Om ** (-eps) * slack).is_nonpositive)
    tau = sp.Symbol("tau", nonnegative=True)
    bound = sp.integrate(-lam * (1 - eps), (tau, 0, t))
    s3 = _zero(bound + lam * q * t)
    T = sp.solve(sp.Eq(om0 ** (1 - eps) + bound, 0), t)
    T_formula = om0 ** (1 - eps) / (lam * (1 - eps))
    s4 = len(T) == 1 and _zero(T[0] - T_formula)
    # tightness: Omega(t) = b(t)^(1/(1-eps)) with b_dot = -lambda (1-eps) solves Omega_dot = -lambda Omega^eps exactly
    b = sp.Function("b", positive=True)(t)
    sol = b ** (1 / q)
    resid = (sp.diff(sol, t) + lam * sol**eps).subs(sp.diff(b, t), -lam * q)
    s5 = sp.simplify(sp.powsimp(resid, force=True)) == 0
    k = sp.Symbol("k", positive=True)
    printed = om0 ** (1 - eps) / (k - k * eps)
    s6 = _zero(printed.subs(k, lam) - T_formula)
    steps = [
        (
            s1,
            "y = Omega^(1-eps): y_dot = -lambda (1-eps) - (1-eps) Omega^(-eps) r, with Omega_dot = -lambda Omega^eps - r",
        ),
        (
            s2,
            "the slack term -(1-eps) Omega^(-eps) r is <= 0 (eps < 1, r >= 0): y_dot <= -lambda (1-eps) while Omega > 0",
        ),
        (s3, "comparison: y(t) <= y(0) - lambda (1-eps) t (integral of the bound)"),
        (s4, "y(0) - lambda (1-eps) T = 0 gives T = Omega(0)^(1-eps) / (lambda (1-eps)); Omega stays 0 afterwards"),
        (s5, "the bound is attained: Omega = (Omega(0)^(1-eps) - lambda (1-eps) t)^(1/(1-eps)) solves the equality"),
        (s6, "the printed (garbled) denominator 'k - k eps' is lambda (1 - eps): eq 10 is right"),
    ]
    return _steps_outcome(steps, r"T \le \frac{\Omega(0)^{1-\epsilon}}{\lambda(1-\epsilon)}")


def _lemma2(ctx: ProofContext) -> _Outcome:
    """Lemma 2 (eqs 11-12): ``sum_i V_i^(1/2) >= (sum_i V_i)^(1/2)`` for ``V_i >= 0``."""
    A, B, a = sp.symbols("A B a", nonnegative=True)
    step = _expand_zero(sp.Matrix([(A + a) ** 2 - (B + a**2) - (A**2 - B) - 2 * a * A]))
    small = True
    for n in range(2, 7):
        x = sp.symbols(f"x0:{n}", nonnegative=True)
        cross = 2 * sum(x[i] * x[j] for i in range(n) for j in range(i + 1, n))
        small &= sp.expand(sum(x) ** 2 - sum(v**2 for v in x) - cross) == 0
    steps = [
        (True, "with a_i = V_i^(1/2) >= 0 the claim is (sum a_i)^2 >= sum a_i^2 (both sides >= 0, sqrt is monotone)"),
        (step, "induction: (A + a)^2 - (B + a^2) = (A^2 - B) + 2 a A with A = sum_{i<=n} a_i >= 0, B = sum a_i^2"),
        (small, "check n = 2..6: (sum a_i)^2 - sum a_i^2 = 2 sum_{i<j} a_i a_j >= 0"),
    ]
    return _steps_outcome(
        steps,
        r"\sum_{i=1}^n V_i^{1/2} \ge \Big(\sum_{i=1}^n V_i\Big)^{1/2}",
        ["note: the paper says 'positive constants'; V_i >= 0 suffices (equality iff at most one V_i > 0)"],
    )


# ----------------------------------------------------------------------------- surface (13-15)


def _reaching_law(ctx: ProofContext) -> _Outcome:
    """Eqs 14-15: on ``s = 0``, ``V_dot <= -2^((alpha+1)/2) c2 V^((alpha+1)/2)``."""
    from fsmctl.symbolic.controller import sigpow

    alpha, c1, c2, p, V = sp.symbols("alpha c1 c2 p V", positive=True)
    x = sp.Symbol("x", real=True)
    term = x * sigpow(x, alpha)[0]
    s1 = all(_zero(term.subs(x, sgn * p) - p ** (1 + alpha)) for sgn in (1, -1))
    sig = sp.Matrix(sp.symbols("sigma0:3", real=True))
    sig_dot = -c1 * sig - c2 * sigpow(sig, alpha)
    vdot = (sig.T * sig_dot)[0, 0]
    s2 = _zero(vdot + c1 * (sig.T * sig)[0, 0] + c2 * sum(term.subs(x, v) for v in sig))
    # sum |x_k|^(1+alpha) >= ||x||^(1+alpha): y_k = x_k^2/||x||^2 in [0, 1], sum y_k = 1, y^(p/2) >= y for p/2 <= 1
    nrm = sp.Symbol("n", positive=True)
    y = sp.Symbol("y", positive=True)
    half = (1 + alpha) / 2
    s3 = _zero((nrm**2 * y) ** half - nrm ** (1 + alpha) * y**half)
    q = sp.Symbol("q", nonnegative=True)  # 1 - p/2 = (1 - alpha)/2 >= 0
    tt = sp.Symbol("t", nonnegative=True)  # y = exp(-t) in (0, 1]
    s4 = bool((-tt * q).is_nonpositive) and _zero(sp.exp(-tt) ** (1 - q) - sp.exp(-tt) * sp.exp(tt * q))
    xs = sp.symbols("x_0:3", real=True)
    s5 = _zero(sum(v**2 / sum(w**2 for w in xs) for v in xs) - 1)
    ce = [1, 1, 0]
    s6 = sum(abs(v) ** 3 for v in ce) < sp.sqrt(sum(v**2 for v in ce)) ** 3  # p = 3 > 2: the inequality fails
    s7 = _zero(sp.sqrt(2 * V) ** (1 + alpha) - 2**half * V**half)
    s8 = sp.simplify(half - 1 + (1 - alpha) / 2) == 0
    steps = [
        (s1, "sigma^T sig(sigma)^alpha = sum_k |sigma_k|^(1+alpha) (both sign branches)"),
        (
            s2,
            "on s = 0 (eq 14): V_dot = sigma^T sigma_dot = -c1 ||sigma||^2 - c2 sum_k |sigma_k|^(1+alpha) <= -c2 sum_k |sigma_k|^(1+alpha)",
        ),
        (s3, "|x_k|^(1+alpha) = ||x||^(1+alpha) y_k^((1+alpha)/2) with y_k = x_k^2/||x||^2"),
        (s5, "sum_k y_k = 1, so each y_k is in [0, 1]"),
        (s4, "for y = e^(-t) in (0, 1] and (1+alpha)/2 <= 1: y^((1+alpha)/2) = y e^(t(1-alpha)/2) >= y"),
        (True, "hence sum_k |x_k|^(1+alpha) >= ||x||^(1+alpha) sum_k y_k = ||x||^(1+alpha) (needs 1 + alpha <= 2)"),
        (s6, "the exponent bound matters: for 1 + alpha = 3 and x = (1, 1, 0), sum |x_k|^3 = 2 < ||x||^3 = 2.83"),
        (
            s7,
            "||sigma||^(1+alpha) = (2V)^((1+alpha)/2) = 2^((1+alpha)/2) V^((1+alpha)/2): the constant 2^((alpha+1)/2) c2 is right",
        ),
        (
            s8,
            "Lemma 1 applies with eps = (1+alpha)/2 in (3/4, 1): T <= V(0)^((1-alpha)/2) / (2^((alpha+1)/2) c2 (1-alpha)/2)",
        ),
    ]
    return _steps_outcome(
        steps,
        r"\dot V_i = -c_1\|\sigma_{ei}\|^2 - c_2\sum_k |\sigma_{ei,k}|^{1+\alpha} \le -c_2\|\sigma_{ei}\|^{1+\alpha}"
        r" \le -2^{\frac{\alpha+1}{2}} c_2\, V_i^{\frac{\alpha+1}{2}}",
        ["then sigma_e = 0 in finite time and sigma_e_dot = G omega_e = 0 with G invertible gives omega_e = 0"],
    )


# ----------------------------------------------------------------------------- model errata and closed loop


def _error_kinematics(ctx: ProofContext) -> _Outcome:
    from fsmctl.proofs.errata import erratum_error_kinematics

    return _erratum(erratum_error_kinematics)


def _lagrange_C(ctx: ProofContext) -> _Outcome:
    from fsmctl.proofs.errata import erratum_lagrange_C

    return _erratum(erratum_lagrange_C)


def _closed_loop(ctx: ProofContext) -> _Outcome:
    """Eq 20 from eq 9 and eqs 16-19, for free ``M`` (invertible), ``C``, ``E`` (reuses fsmctl.proofs.identities)."""
    from fsmctl.proofs.identities import verify_closed_loop
    from fsmctl.symbolic.controller import SingularityFix

    r = verify_closed_loop(SingularityFix.NONE)
    steps = [
        (r.holds, f"{r.statement} [{r.method}]"),
        (True, "read with the elementwise power |sigma_e|^(alpha-1) o sigma_e_dot (see claim fractional-power)"),
    ]
    return _steps_outcome(
        steps,
        r"\ddot\sigma_{ei} = -\big(c_1\dot\sigma_{ei} + c_2\alpha|\sigma_{ei}|^{\alpha-1}\circ\dot\sigma_{ei}\big)"
        r" - \delta_i\circ\mathrm{sgn}(s_i) - \sum_j\big(k^i_{ij}s_i - k^j_{ij}s_j\big)",
        ["this uses the model M, C, E only through 'M invertible': it holds for the corrected C (claim lagrange-C)"],
    )


def _fractional_power(ctx: ProofContext) -> _Outcome:
    from fsmctl.proofs.errata import erratum_fractional_power
    from fsmctl.proofs.identities import verify_sigpow_derivative

    r = verify_sigpow_derivative()
    return _erratum(erratum_fractional_power, [(r.holds, r.statement)])


# ----------------------------------------------------------------------------- Theorem 1 proof (23-28)


def _vdot_i(ctx: ProofContext) -> _Outcome:
    """Eqs 23-24, step by step; the ``||delta|| ||s||`` step is the erratum ``eq24-norm-bound``."""
    from fsmctl.proofs.errata import erratum_norm_inequality
    from fsmctl.proofs.identities import model_symbols, verify_sigpow_derivative
    from fsmctl.symbolic.controller import SingularityFix, closed_loop_acceleration, switching_function

    sym = model_symbols()
    sd = closed_loop_acceleration(
        sym.sigma_e,
        sym.sigma_e_dot,
        sym.s,
        sym.c1,
        sym.c2,
        sym.alpha,
        sym.delta,
        sym.coordination,
        fix=SingularityFix.NONE,
    )
    zero = sp.zeros(3, 1)
    rate = -closed_loop_acceleration(
        sym.sigma_e, sym.sigma_e_dot, sym.s, sym.c1, sym.c2, sym.alpha, sym.delta, zero, fix=SingularityFix.NONE
    ) - sp.matrix_multiply_elementwise(sym.delta, switching_function(sym.s))
    s_dot = sd + rate  # eq 23: s_dot = sigma_ddot + c1 sigma_dot + c2 alpha |sigma|^(alpha-1) o sigma_dot
    v = sp.matrix_multiply_elementwise(sym.delta, switching_function(sym.s)) + sym.coordination
    s2 = _expand_zero(s_dot + v)
    x = sp.Symbol("x", real=True)
    s3 = sp.simplify(x * sp.sign(x) - sp.Abs(x)) == 0
    d, a = sp.symbols("d a", nonnegative=True)  # d_k - min_k delta >= 0, |s_k| >= 0
    s4 = bool((d * a).is_nonnegative)
    ab = sp.symbols("a0:3", nonnegative=True)
    s5 = sp.expand(sum(ab) ** 2 - sum(v_**2 for v_ in ab) - 2 * (ab[0] * ab[1] + ab[0] * ab[2] + ab[1] * ab[2])) == 0
    r = verify_sigpow_derivative()
    own = [
        (
            r.holds,
            "eq 23: V_i_dot = s_i^T s_i_dot with s_i_dot = sigma_ddot + c1 sigma_dot + c2 alpha|sigma|^(alpha-1) o sigma_dot",
        ),
        (s2, "substituting eq 20: s_i_dot = -delta_i o sgn(s_i) - sum_j (k^i_ij s_i - k^j_ij s_j) (identity)"),
        (s3, "-s_i^T (delta_i o sgn(s_i)) = -sum_k (delta_i)_k |(s_i)_k|: an equality (printed as '<=')"),
        (
            s4 and s5,
            "corrected next step: sum_k delta_k |s_k| >= min_k delta_k ||s||_1 >= min_k delta_k ||s||_2 "
            "((sum|s_k|)^2 = ||s||^2 + 2 sum_{k<l} |s_k||s_l|)",
        ),
    ]
    extra = [
        "[refuted] printed next step -sum_k (delta_i)_k |(s_i)_k| <= -||delta_i|| ||s_i|| (counterexample above)",
        "the same false step appears in eq 32 (Theorem 2) with delta_i - Delta_d_i; with sat(s/phi) (Remark 7) the "
        "reaching bound holds only outside the boundary layer |s_k| >= phi",
    ]
    out = _erratum(erratum_norm_inequality, own, extra)
    out.latex = (
        r"\dot V_i = -\sum_k(\delta_i)_k|(s_i)_k| - s_i^T\sum_j(k^i_{ij}s_i - k^j_{ij}s_j)"
        r" \le -\min_k(\delta_i)_k\,\|s_i\| - s_i^T\sum_j(k^i_{ij}s_i - k^j_{ij}s_j)"
        r"\quad(\text{printed: } -\|\delta_i\|\,\|s_i\|)"
    )
    return out


def _zero_sum(ctx: ProofContext) -> _Outcome:
    """Eq 26 and what it requires of eta: balanced, not symmetric."""
    ok_plain, ok_eta, ok_sym = True, True, True
    for n in range(2, 7):
        a = sp.symbols(f"a0:{n}", real=True)
        eta = sp.Matrix(n, n, lambda i, j: sp.Symbol(f"eta_{i}{j}", real=True) if i != j else 0)
        ok_plain &= sp.expand(sum(a[i] - a[j] for i in range(n) for j in range(n))) == 0
        lhs = sum(eta[i, j] * (a[i] - a[j]) for i in range(n) for j in range(n))
        r = [sum(eta[i, j] for j in range(n)) - sum(eta[j, i] for j in range(n)) for i in range(n)]
        ok_eta &= sp.expand(lhs - sum(a[i] * r[i] for i in range(n))) == 0
        symmetric = {eta[j, i]: eta[i, j] for i in range(n) for j in range(i + 1, n)}
        ok_sym &= all(sp.expand(ri.xreplace(symmetric)) == 0 for ri in r)
    cyc = sp.Matrix([[0, 1, 0], [0, 0, 1], [1, 0, 0]])  # eta_12 = eta_23 = eta_31 = 1: balanced, not symmetric
    balanced = all(sum(cyc[i, :]) == sum(cyc[:, i]) for i in range(3))
    not_sym = cyc != cyc.T
    steps = [
        (
            ok_plain,
            "sum_i sum_j (a_i - a_j) = 0 (eq 26, a_i = s_i^T s_i; checked for n = 2..6, general by swapping i, j)",
        ),
        (ok_eta, "sum_i sum_j eta_ij (a_i - a_j) = sum_i a_i r_i with r_i = sum_j eta_ij - sum_j eta_ji"),
        (
            True,
            "a linear form in a vanishes for all a iff its coefficients do: the term is zero for every s iff "
            "sum_j eta_ij = sum_j eta_ji for every i ('balanced')",
        ),
        (ok_sym, "eta_ij = eta_ji (the paper's requirement) implies balanced"),
        (balanced and not_sym, "balanced does not imply symmetric: eta_12 = eta_23 = eta_31 = 1 (a directed cycle)"),
        (True, "the identity holds at each instant, so eta may vary with t (V_dot is not differentiated again)"),
    ]
    return _steps_outcome(
        steps,
        r"\sum_i\sum_j \eta_{ij}\big(s_i^Ts_i - s_j^Ts_j\big) = \sum_i s_i^Ts_i\Big(\sum_j\eta_{ij} - \sum_j\eta_{ji}\Big)"
        r" = 0\ \ \forall s \iff \sum_j\eta_{ij} = \sum_j\eta_{ji}\ \ \forall i",
        ["the paper's statement holds; it asks for more (symmetry) than the proof needs (balance)"],
    )


def _complete_square(ctx: ProofContext) -> _Outcome:
    """Eq 27: the completed square, an identity for ``k^i - eta > 0``."""
    si, sj = sp.Matrix(sp.symbols("si0:3", real=True)), sp.Matrix(sp.symbols("sj0:3", real=True))
    r, eta, kj = sp.symbols("r eta k_j", positive=True)  # r = sqrt(k^i - eta) > 0
    ki = r**2 + eta
    lhs = (si.T * (ki * si - kj * sj))[0, 0] - eta * ((si.T * si)[0, 0] - (sj.T * sj)[0, 0])
    kappa = r * si - kj / (2 * r) * sj
    gamma = eta - kj**2 / (4 * r**2)
    s1 = sp.expand(lhs - (kappa.T * kappa)[0, 0] - gamma * (sj.T * sj)[0, 0]) == 0
    steps = [
        (
            s1,
            "s_i^T(k^i s_i - k^j s_j) - eta (s_i^T s_i - s_j^T s_j) = kappa^T kappa + gamma s_j^T s_j with "
            "kappa = sqrt(k^i - eta) s_i - k^j/(2 sqrt(k^i - eta)) s_j, gamma = eta - (k^j)^2/(4(k^i - eta))",
        ),
        (True, "summing over i, j and adding the zero term of eq 26 gives eq 27 exactly as printed"),
    ]
    return _steps_outcome(
        steps,
        r"s_i^T(k^i_{ij}s_i - k^j_{ij}s_j) - \eta_{ij}(s_i^Ts_i - s_j^Ts_j) = \kappa_{ij}^T\kappa_{ij} + \gamma_{ij}s_j^Ts_j,"
        r"\ \kappa_{ij} = \sqrt{k^i_{ij}-\eta_{ij}}\,s_i - \frac{k^j_{ij}}{2\sqrt{k^i_{ij}-\eta_{ij}}}s_j,"
        r"\ \gamma_{ij} = \eta_{ij} - \frac{(k^j_{ij})^2}{4(k^i_{ij}-\eta_{ij})}",
        ["requires k^i_ij > eta_ij (kappa divides by sqrt(k^i - eta)); see gamma-condition for the boundary"],
    )


def _gamma_condition(ctx: ProofContext) -> _Outcome:
    """``gamma_ij >= 0`` iff Theorem 1's ``k``/``eta`` conditions; the exact per-pair condition is a 2x2 PSD block."""
    from fsmctl.proofs.errata import erratum_theorem1_eta_strict

    ki, kj, eta = sp.symbols("k_i k_j eta", positive=True)
    r = sp.Symbol("r", positive=True)  # k^i - eta
    gamma = eta - kj**2 / (4 * r)
    s1 = _zero(4 * r * gamma - (4 * eta * r - kj**2))
    roots = sp.solve(sp.Eq(4 * eta * (ki - eta), kj**2), eta)
    s2 = len(roots) == 2 and _zero(sp.Add(*roots) - ki) and _zero(sp.Mul(*roots) - kj**2 / 4)
    own = [
        (
            s1,
            "for k^i > eta: 4 (k^i - eta) gamma = 4 eta (k^i - eta) - (k^j)^2, so gamma >= 0 <=> 4 eta (k^i - eta) >= "
            "(k^j)^2 (Theorem 1's condition, as printed)",
        ),
        (
            s2,
            "eta-interval: the roots of 4 eta (k^i - eta) = (k^j)^2 are (k^i -+ sqrt((k^i)^2 - (k^j)^2))/2, real iff "
            "k^i >= k^j",
        ),
    ]
    return _erratum(erratum_theorem1_eta_strict, own)


def _vdot_mu(ctx: ProofContext) -> _Outcome:
    """Eq 28 with Lemma 2; the value of ``mu`` is the erratum ``eq28-mu``."""
    from fsmctl.proofs.errata import erratum_reaching_rate

    V = sp.Symbol("V", positive=True)
    n = sp.Symbol("n", positive=True)
    s1 = _zero(sp.sqrt(2 * (n**2 / 2)) - n)
    s2 = _zero(
        2 * sp.sqrt(V) / sp.Symbol("mu", positive=True)
        - V ** sp.Rational(1, 2) / (sp.Symbol("mu", positive=True) * sp.Rational(1, 2))
    )
    own = [
        (s1, "||s_i|| = sqrt(2 V_i)"),
        (
            True,
            "V_dot <= -sum_i m_i ||s_i|| <= -min_i m_i sum_i sqrt(2 V_i) <= -sqrt(2) min_i m_i V^(1/2) (Lemma 2), "
            "m_i = min_k (delta_i)_k",
        ),
        (s2, "Lemma 1 with eps = 1/2: s = 0 is reached within T_r <= 2 V(0)^(1/2) / mu"),
    ]
    extra = []
    sc = ctx.scenario
    try:
        deltas = t2.fsm_deltas(sc)
        mu_ok = math.sqrt(2) * float(deltas.min())
        mu_printed = math.sqrt(2) * float(np.linalg.norm(deltas, axis=1).min())
        V0 = _initial_V(sc)
        extra.append(
            f"scenario {sc.label}: mu = sqrt(2) min_i min_k (delta_i)_k = {mu_ok:.4g} 1/s^2 (printed formula: "
            f"{mu_printed:.4g}); V(0) = {V0:.4g} from s_i(0) (generated sliding function), so Theorem 1 (no "
            f"uncertainty) bounds the reaching time by 2 V(0)^(1/2)/mu = {2 * math.sqrt(V0) / mu_ok:.4g} s "
            f"(printed mu: {2 * math.sqrt(V0) / mu_printed:.4g} s)"
        )
    except Exception as exc:  # pragma: no cover - informative only
        extra.append(f"(scenario value of mu not computed: {exc})")
    out = _erratum(erratum_reaching_rate, own, extra)
    out.latex = r"\dot V \le -\mu V^{1/2},\quad \mu = \sqrt2\,\min_i\min_k(\delta_i)_k\quad(\text{printed: } \min_i\sqrt2\|\delta_i\|)"
    return out


def _initial_V(sc: Scenario) -> float:
    """``V(0) = sum_i s_i(0)^T s_i(0) / 2`` with the paper's law's generated sliding variable (eq 13, 21-22)."""
    from fsmctl.model.laws import resolve_law

    law = resolve_law("fsm")
    f = law.casadi(f"law_local_{sc.controller.error_model}")  # broadcast: s (eq 13)
    const = law.casadi("law_constants")
    w = sc.reference.omega
    wd0 = w(0.0)
    wdd0 = -np.asarray(w.amplitude) * np.asarray(w.frequency) * np.sin(np.asarray(w.phase))
    V = 0.0
    for a, params in zip(sc.agents, t2.fsm_parameters(sc), strict=True):
        z = np.zeros(law.n_states)
        s = np.array(
            f(0.0, a.sigma0, a.omega0, z, sc.reference.sigma0, wd0, wdd0, a.J0_array, params, const(params))[0]
        )
        V += 0.5 * float(s.ravel() @ s.ravel())
    return V


# ----------------------------------------------------------------------------- scenario: Theorem 1


def _theorem1_gains(ctx: ProofContext) -> _Outcome:
    """Theorem 1's conditions for the scenario's gain table and time-varying, directed topology."""
    sc = ctx.scenario
    an = t1.analyze_topology(sc.topology, sc.simulation.t_final)
    lines = [
        f"scenario {sc.label}: {sc.n_agents} agents, {len(sc.topology.links)} directed links; checked every distinct "
        f"configuration of k^j(t) ({len(an.configurations)}) over {an.window}",
    ]
    groups: dict[tuple, list[str]] = {}
    for p in an.pairs:
        if p.interval is None:
            continue
        key = (
            p.k_i_ij,
            p.k_i_ji,
            p.k_j_max_ij,
            p.k_j_max_ji,
            round(p.interval[0], 12),
            round(p.interval[1], 12),
            p.eta,
        )
        groups.setdefault(key, []).append(p.label)
    for (a, b, A, B, lo, hi, eta), labels in groups.items():
        shown = ", ".join(labels[:30]) + (f", ... ({len(labels)} pairs)" if len(labels) > 30 else "")
        who = f"pair {shown}" if len(labels) == 1 else f"pairs {shown}"
        cert = f", certified eta = {eta} (exact rational check)" if eta is not None else ""
        lines.append(
            f"{who}: k^i = ({a:g}, {b:g}), max_t k^j = ({A:g}, {B:g}): constant symmetric eta_ij = eta_ji in "
            f"[{lo:.6g}, {hi:.6g}]{cert}"
        )
    prefix = "FAILS " if not an.holds else "no constant symmetric eta (a balanced or time-varying one exists, below): "
    lines += [prefix + f for f in an.failures]
    forms = [
        ("constant symmetric eta (the paper's form, non-strict)", an.symmetric_constant),
        ("time-varying symmetric eta(t)", an.symmetric_time_varying),
        ("constant balanced eta (LP)", an.balanced_constant),
        ("time-varying balanced eta(t) (LP; what the proof needs)", an.balanced_time_varying),
    ]
    lines.append("eta exists: " + "; ".join(f"{name}: {'yes' if ok else 'no'}" for name, ok in forms))
    if an.printed_strict:
        lines.append("the printed strict conditions k^i_ij > eta_ij > 0 can also be met")
    else:
        zero = [p.label for p in an.pairs if min(p.k_i_ij, p.k_i_ji) == 0]
        lines.append(
            "the printed strict conditions k^i_ij > eta_ij > 0 cannot be met"
            + (f" (k^i = 0 for pairs {', '.join(zero[:8])}{', ...' if len(zero) > 8 else ''})" if zero else "")
            + ": the scenario is outside Theorem 1 as printed (erratum thm1-eta-strict)"
            + ("; the corrected condition holds" if an.holds else "")
        )
    lines.append(
        f"exact coupling condition lambda_min(sym(L(t))) >= 0, L_ii = sum_j k^i_ij, L_ij = -k^j_ij(t): min over t = "
        f"{an.lambda_min:.6g} at t = {an.lambda_min_time:g} s ({'holds' if an.exact_holds else 'FAILS'})"
    )
    if not an.holds and an.exact_holds:
        lines.append(
            "note: Theorem 1's eta conditions fail but the exact condition holds: the coordination term "
            "is still dissipative and the convergence proof goes through without eta"
        )
    data = {
        "window": an.window,
        "configurations": len(an.configurations),
        "pairs": [
            {
                "pair": [p.i + 1, p.j + 1],
                "k_i": [p.k_i_ij, p.k_i_ji],
                "k_j_max": [p.k_j_max_ij, p.k_j_max_ji],
                "eta_interval": list(p.interval) if p.interval else None,
                "eta": float(p.eta) if p.eta is not None else None,
                "reason": p.reason,
                "fixes": list(p.fixes),
                "when": p.when,
            }
            for p in an.pairs
        ],
        "symmetric_constant": an.symmetric_constant,
        "symmetric_time_varying": an.symmetric_time_varying,
        "balanced_constant": an.balanced_constant,
        "balanced_time_varying": an.balanced_time_varying,
        "printed_strict": an.printed_strict,
        "lambda_min": an.lambda_min,
        "lambda_min_time": an.lambda_min_time,
    }
    latex = (
        r"\forall t,\ \forall (i,j):\ \begin{bmatrix}k^i_{ij}-\eta_{ij} & -k^j_{ij}(t)/2\\ -k^j_{ij}(t)/2 & \eta_{ij}\end{bmatrix}"
        r"\succeq 0,\ \ \sum_j\eta_{ij}=\sum_j\eta_{ji};\qquad \lambda_{\min}\big(\mathrm{sym}\,L(t)\big)\ge 0"
    )
    if an.holds:
        return _Outcome(PROVED, lines, latex, data=data)
    return _Outcome(FAILS, lines, latex, holds=False, data=data)


# ----------------------------------------------------------------------------- Theorem 2


def _theorem2_condition(ctx: ProofContext) -> _Outcome:
    """Eqs 29-33: the exact Delta_d, why the printed condition is circular, and the correct sufficient condition."""
    from fsmctl.proofs.errata import erratum_uncertainty_term

    steps = t2_symbolic_steps()
    out = _erratum(erratum_uncertainty_term, steps)
    out.latex = (
        r"\dot s_i = -P_i\big(\delta_i\circ\mathrm{sgn}(s_i) + \textstyle\sum_j(k^i_{ij}s_i - k^j_{ij}s_j)\big) + P_iw_{0i}"
        r" + (P_i - I)a_{eq,i},\ P_i = G J_i^{-1}J_{0i}G^{-1};\ \ \Delta J_i = \kappa_iJ_{0i}:\ "
        r"(\delta_i)_k > \big|w_{0i} - \kappa_i a_{eq,i}\big|_k"
    )
    return out


def t2_symbolic_steps() -> list[tuple[bool, str]]:
    """The symbolic steps of the corrected Theorem 2 (Liang et al. 2012, eqs 29-33; see :mod:`fsmctl.proofs.theorem2`).

    Returns
    -------
    list of (bool, str)
        Each step and whether SymPy established it: ``Delta_d`` depends on ``sigma_e_ddot``; the printed
        condition is circular; ``s_dot = -P v + P w0 + (P - I) a_eq``; ``P = I/(1+kappa)`` for
        ``Delta_J = kappa J0``; the resulting condition; ``a_eq`` unbounded without the Remark 6 fix.
    """
    from fsmctl.proofs.identities import model_symbols
    from fsmctl.symbolic.controller import (
        SingularityFix,
        closed_loop_acceleration,
        computed_torque_pieces,
        surface_term_slope,
        switching_function,
    )
    from fsmctl.symbolic.model import lagrange_uncertainty
    from fsmctl.symbolic.mrp import mrp_G, mrp_G_dot, mrp_G_inverse, skew
    from fsmctl.symbolic.symbols import symmetric_matrix_symbols, vector_symbols

    sym = model_symbols()
    J0 = sym.J
    dJ = symmetric_matrix_symbols("dJ")
    # (a) Delta_d depends on sigma_e_ddot: d Delta_d / d sigma_e_ddot = -Delta_J G^-1 (at a sample attitude)
    sig = sp.Matrix([sp.Rational(1, 10), -sp.Rational(1, 5), sp.Rational(1, 10)])
    dd = lagrange_uncertainty(
        J0, dJ, sig, sym.sigma_e_dot, sym.sigma_e_ddot, sym.omega_d, sym.omega_d_dot, vector_symbols("u_d")
    )
    jac = dd.jacobian(sym.sigma_e_ddot)
    a_ok = _expand_zero(jac + dJ * mrp_G_inverse(sig))
    # (b) at sigma_e = 0 and Delta_J = kappa J0: M0^-1 G^-T (-Delta_J G^-1) = -kappa I, i.e. M0 (-kappa I) = G^-T (-kappa J0) G^-1
    kappa = sp.Symbol("kappa", real=True)
    Gi0 = mrp_G_inverse(sp.zeros(3, 1))
    M0 = Gi0.T * J0 * Gi0
    b_ok = _expand_zero(M0 * (-kappa) - Gi0.T * (-(kappa * J0)) * Gi0)
    # (c) sliding dynamics with the true inertia (inverse-free form, opaque G^-1)
    Gi = sym.G_inverse
    se, we = sym.sigma_e, sym.omega_e
    wr, wr_dot, ud = vector_symbols("omega_r"), vector_symbols("omega_r_dot"), vector_symbols("u_d")
    J = J0 + dJ
    pieces = computed_torque_pieces(
        J0,
        se,
        we,
        wr,
        wr_dot,
        sym.s,
        sym.c1,
        sym.c2,
        sym.alpha,
        sym.delta,
        sym.coordination,
        fix=SingularityFix.NONE,
        G_inverse=Gi,
    )
    sed = mrp_G(se) * we
    v = sp.matrix_multiply_elementwise(sym.delta, switching_function(sym.s)) + sym.coordination
    rate = (
        -closed_loop_acceleration(
            se, sed, sym.s, sym.c1, sym.c2, sym.alpha, sym.delta, sym.coordination, fix=SingularityFix.NONE
        )
        - v
    )
    a_eq = -(mrp_G_dot(se, sed) * we + rate)
    w = we + wr
    lhs = -skew(w) * J * w + pieces.u + ud - J * wr_dot  # = J (omega_dot - omega_r_dot) by Euler's equation (4)
    rhs = ud - skew(w) * dJ * w - dJ * wr_dot + J0 * Gi * (a_eq - v)
    c_ok = _expand_zero(_opaque(lhs - rhs))
    # (d) proportional uncertainty: J^-1 J0 = I/(1+kappa), and (1+kappa) s_dot = -v + w0 - kappa a_eq
    d_ok = all(sp.cancel(x) == 0 for x in (J0 + kappa * J0) / (1 + kappa) - J0)
    P = 1 / (1 + kappa)
    vv, w0, aa = sp.symbols("v w0 a_eq", real=True)
    e_ok = sp.cancel((1 + kappa) * (-P * vv + P * w0 + (P - 1) * aa) - (-vv + w0 - kappa * aa)) == 0
    # (e) a_eq is unbounded near sigma_e,k = 0 off the surface without the Remark 6 fix, bounded with 'switch'
    x, q, vel = sp.Symbol("x", positive=True), sp.Symbol("q", positive=True), sp.Symbol("v", positive=True)
    f_ok = sp.limit(x ** (-q) * vel, x, 0, "+") is sp.oo
    alpha, eps = sp.Symbol("alpha", positive=True), sp.Symbol("epsilon", positive=True)
    bound = surface_term_slope(sp.Integer(0), alpha, SingularityFix.SWITCH, eps)
    g_ok = _zero(bound - (2 - alpha) * eps ** (alpha - 1))
    return [
        (
            a_ok,
            "exact Delta_d (fsmctl.symbolic.model.lagrange_uncertainty): d Delta_d / d sigma_e_ddot = -Delta_J G^-1 != 0, "
            "so Delta_d depends on sigma_e_ddot, i.e. on the control",
        ),
        (
            b_ok,
            "at sigma_e = 0, Delta_J = kappa J0: M0^-1 G^-T Delta_d contains -kappa sigma_e_ddot; by eq 30 "
            "sigma_e_ddot contains -delta_i o sgn(s_i) and the neighbours' s_j: the printed condition "
            "delta_i > |M0^-1 G^-T Delta_d_i| has delta_i and s_j on both sides (circular)",
        ),
        (
            c_ok,
            "true inertia J = J0 + Delta_J, law built on J0 (eqs 16-19): J (omega_e_dot) = w + J0 G^-1 (a_eq - v), "
            "w = u_d - omega^x Delta_J omega - Delta_J omega_r_dot, a_eq = -(G_dot omega_e + c1 sigma_e_dot + "
            "c2 alpha|sigma_e|^(alpha-1) o sigma_e_dot), v = delta o sgn(s) + coordination; hence "
            "s_dot = -P v + P w0 + (P - I) a_eq with P = G J^-1 J0 G^-1, w0 = G J0^-1 w",
        ),
        (d_ok, "Delta_J = kappa J0 (the paper's 0.3 J0): J^-1 J0 = I/(1+kappa), so P = I/(1+kappa) (a scalar)"),
        (
            e_ok,
            "then (1+kappa) s_dot = -(delta o sgn(s) + coordination) + w0 - kappa a_eq: sufficient condition "
            "(delta_i)_k > sup |w0_i - kappa_i a_eq,i|_k (the coordination term keeps the factor 1/(1+kappa) and "
            "stays dissipative under Theorem 1), mu = sqrt(2) min_i min_k (delta_i - sup|w0_i - kappa a_eq,i|)_k/(1+kappa_i)",
        ),
        (
            f_ok,
            "a_eq contains c2 alpha |sigma_e,k|^(alpha-1) sigma_e_dot,k -> infinity as sigma_e,k -> 0 with "
            "sigma_e_dot,k != 0: no finite delta satisfies the condition near sigma_e,k = 0 off the surface",
        ),
        (
            g_ok,
            "with the Remark 6 'switch' fix the slope is bounded by (2 - alpha) epsilon^(alpha-1) (its value at 0), "
            "so the requirement is finite (see theorem2-delta for the numbers)",
        ),
    ]


def _opaque(m: sp.MatrixBase) -> sp.Matrix:
    """Replace non-polynomial atoms (sign, Abs, Piecewise, Min/Max, symbolic powers) by fresh symbols."""
    mapping: dict = {}

    def visit(e):
        if isinstance(e, (sp.Piecewise, sp.sign, sp.Abs, sp.Min, sp.Max)) or (
            isinstance(e, sp.Pow) and not e.exp.is_Integer
        ):
            return mapping.setdefault(e, sp.Symbol(f"_op{len(mapping)}"))
        if e.args:
            return e.func(*[visit(a) for a in e.args])
        return e

    return sp.Matrix(m).applyfunc(visit)


def _fsm_values(sc: Scenario) -> dict:
    """The paper's law's scalar parameters for the first agent, by name (:func:`theorem2.fsm_parameters`)."""
    from fsmctl.model.laws import resolve_law

    row, out, k = t2.fsm_parameters(sc)[0], {}, 0
    for info in resolve_law("fsm").parameters:
        v = row[k : k + info.size]
        out[info.name] = info.choices[int(v[0])] if info.choices else float(v[0]) if info.size == 1 else tuple(v)
        k += info.size
    return out


def _theorem2_delta(ctx: ProofContext) -> _Outcome:
    """The delta_i Theorem 2 (corrected) needs for the scenario, certified by interval branch and bound, vs the
    configured delta_i; the reaching condition refuted at a point when the requirement is."""
    sc = ctx.scenario
    res = t2.delta_requirements(sc, ctx.region, n_random=ctx.n_random, seed=ctx.seed)
    cert = t2b.certified_delta_requirements(sc, ctx.region)
    lines = [
        t2r.verdict_line(cert),
        f"scenario {sc.label}; region {ctx.region.describe()} around the reference sigma_e = 0, omega_e = 0, times the "
        "bound boxes of omega_d, u_d and omega_d_dot",
        "requirement (1/s^2): (delta_i)_k > sup (1+kappa_i) |d_i|_k, d_i = s_i_dot at delta = 0 without coordination "
        "(automatic differentiation of the paper's law's generated law_local_*, law_control_* and the model's "
        "plant_rhs along the rigid-body motion); certified [lower, upper] per agent and axis, rounded outward:",
        *t2r.requirement_table(cert),
        t2r.search_line(cert),
        *t2r.reaching_lines(cert),
        "the guarantee also needs the trajectory to stay in the region, which is not checked",
        f"coupling: {res.coupling}",
    ]
    if res.agents:
        lines.append(f"{res.agents[0].note}")
    lines.append(_slope_line(sc))
    if res.largest_scale is not None:
        f = res.largest_scale
        lines.append(
            f"sampled: the configured delta meets the requirement only on a box about {f:.3g} times the region "
            f"(|sigma_e,k| <= {f * ctx.region.sigma:.3g}, |omega_e,k| <= {f * ctx.region.omega:.3g} rad/s; bisection on "
            "the grid)"
        )
    lines.append(
        f"sampled requirement (context, a lower estimate; 1/s^2 per axis; on the reference trajectory: the actual "
        f"signals, max over t in [0, {sc.simulation.t_final:g}] s, {res.trajectory_samples} times): {res.description}"
    )
    lines += t2r.sampled_table(res)
    data = {
        "region": {"sigma": ctx.region.sigma, "omega": ctx.region.omega},
        "samples_per_agent": res.samples,
        "trajectory_times": res.trajectory_samples,
        "largest_scale": res.largest_scale,
        "certified": _certified_data(cert),
        "agents": [
            {
                "agent": a.agent,
                "configured": list(a.configured),
                "region": _finite(a.region),
                "reference_trajectory": list(a.reference_trajectory),
                "reference_bound": _finite(a.reference_bound),
                "kappa": a.kappa,
                "ok": a.ok,
            }
            for a in res.agents
        ],
    }
    latex = (
        r"(\delta_i)_k > \sup_{\text{region}}\,(1+\kappa_i)\big|\dot s_i\big|_{\delta=0,\ \text{no coordination}}"
        r" = \sup\big|w_{0i} - \kappa_i a_{eq,i}\big|_k"
    )
    if cert.verdict == "proved":
        return _Outcome(PROVED, lines, latex, data=data)
    if cert.verdict == "refuted":
        return _Outcome(FAILS, lines, latex, holds=False, data=data)
    return _Outcome(NUMERIC, lines, latex, holds=res.ok, data=data)


def _certified_data(cert: t2b.Theorem2Bound) -> dict:
    p = cert.reaching
    return {
        "verdict": cert.verdict,
        "boxes": cert.boxes,
        "seconds": cert.seconds,
        "groups": [
            {
                "agents": list(g.agents),
                "verdict": g.verdict,
                "kappa": g.kappa,
                "axes": [
                    {
                        "axis": a.axis,
                        "configured": a.configured,
                        "lower": a.lower,
                        "upper": a.upper if math.isfinite(a.upper) else None,
                        "witness": list(a.witness),
                        "converged": a.converged,
                        "boxes": a.boxes,
                    }
                    for a in g.axes
                ],
            }
            for g in cert.groups
        ],
        "reaching_refuted_at": None
        if p is None
        else {"agent": p.agent, "axis": p.axis, "point": list(p.point), "s_dot_s": p.s_dot_s},
    }


def _slope_line(sc: Scenario) -> str:
    c = sc.controller
    p = _fsm_values(sc)
    fix, alpha, epsilon = p["singularity_fix"], p["alpha"], p["epsilon"]
    if fix == "switch":
        slope = (2 - alpha) * epsilon ** (alpha - 1)
        return (
            f"why it grows off the reference: a_eq contains c2 slope_k sigma_e_dot,k with the Remark 6 slope up to "
            f"(2 - alpha) epsilon^(alpha-1) = {slope:.4g} near sigma_e,k = 0 (c2 slope = {p['c2'] * slope:.4g} 1/s)"
            + (
                "; with error_model = paper the rotation G(sigma_e)(R(sigma_e) - I) omega_d that eqs 7-8 drop enters "
                "s_dot through the same slope"
                if c.error_model == "paper"
                else ""
            )
        )
    return (
        f"singularity_fix = {fix}: the surface keeps sig(sigma_e)^alpha, whose slope is unbounded at "
        "sigma_e,k = 0, so s_dot (and the requirement) is unbounded wherever omega_e != 0 there (Remark 6)"
    )


def _finite(v) -> list:
    return [x if math.isfinite(x) else None for x in v]


# ----------------------------------------------------------------------------- Theorem 3


def _fsm_closed_forms():
    from fsmctl.symbolic.theorem3 import settling_time_closed_forms

    return tuple(settling_time_closed_forms())


def _theorem3_closed_forms(ctx: ProofContext) -> _Outcome:
    """Eqs 34-36 derived by integrating the three scalar sliding modes (dsolve)."""
    t, c1, c2, tau, x0, _, alpha, T34, T35, T36 = _fsm_closed_forms()
    x = sp.Symbol("x", positive=True)
    y = sp.Function("y")
    # FSM: y = x^(1-alpha) linearises x_dot = -c1 x - c2 x^alpha (x > 0; x < 0 by symmetry)
    sub_ok = _zero((1 - alpha) * x ** (-alpha) * (-c1 * x - c2 * x**alpha) + (1 - alpha) * (c1 * x ** (1 - alpha) + c2))
    sol = sp.dsolve(sp.Eq(y(t).diff(t), -(1 - alpha) * (c1 * y(t) + c2)), y(t), ics={y(0): x0 ** (1 - alpha)})
    T = sp.solve(sp.Eq(sol.rhs, tau ** (1 - alpha)), t)
    fsm_ok = len(T) == 1 and _zero(sp.expand_log(T[0] - T34, force=True))
    integral_ok = _zero(sp.diff(T34, x0) - 1 / (c1 * x0 + c2 * x0**alpha)) and _zero(T34.subs(x0, tau))
    # TSM: c1 = 0
    sol_t = sp.dsolve(sp.Eq(y(t).diff(t), -(1 - alpha) * c2), y(t), ics={y(0): x0 ** (1 - alpha)})
    Tt = sp.solve(sp.Eq(sol_t.rhs, tau ** (1 - alpha)), t)
    tsm_ok = len(Tt) == 1 and _zero(Tt[0] - T35)
    # LSM: c2 = 0
    z = sp.Function("z")
    sol_l = sp.dsolve(sp.Eq(z(t).diff(t), -c1 * z(t)), z(t), ics={z(0): x0})
    Tl = sp.solve(sp.Eq(sol_l.rhs, tau), t)
    lsm_ok = len(Tl) == 1 and _zero(sp.expand_log(Tl[0] - T36, force=True))
    steps = [
        (
            sub_ok,
            "FSM, x > 0 (x < 0 by symmetry): y = x^(1-alpha) turns x_dot = -c1 x - c2 x^alpha into "
            "y_dot = -(1-alpha)(c1 y + c2)",
        ),
        (
            fsm_ok,
            "dsolve + solve y(T) = tau^(1-alpha): T_fsm = ln((c1|x0|^(1-alpha) + c2)/(c1 tau^(1-alpha) + c2)) / "
            "(c1 (1-alpha)) = eq 34",
        ),
        (
            integral_ok,
            "cross-check: dT_fsm/dx0 = 1/(c1 x0 + c2 x0^alpha) and T_fsm(tau) = 0, i.e. "
            "T_fsm = integral_tau^x0 dx/(c1 x + c2 x^alpha)",
        ),
        (tsm_ok, "TSM (c1 = 0): T_tsm = (|x0|^(1-alpha) - tau^(1-alpha)) / (c2 (1-alpha)) = eq 35"),
        (lsm_ok, "LSM (c2 = 0): x = x0 e^(-c1 t), T_lsm = ln(|x0|/tau)/c1 = eq 36"),
    ]
    return _steps_outcome(
        steps,
        r"T_{fsm} = \frac{1}{c_1(1-\alpha)}\ln\frac{c_1|x_0|^{1-\alpha}+c_2}{c_1\tau^{1-\alpha}+c_2},\ "
        r"T_{tsm} = \frac{|x_0|^{1-\alpha}-\tau^{1-\alpha}}{c_2(1-\alpha)},\ T_{lsm} = \frac1{c_1}\ln\frac{|x_0|}{\tau}",
    )


def _theorem3_lsm(ctx: ProofContext) -> _Outcome:
    """Eqs 37-38: ``T_fsm < T_lsm`` for ``|x0| > tau > 0`` (same c1)."""
    _, c1, c2, tau, x0, _, alpha, _, _, T36 = _fsm_closed_forms()
    b, h = sp.symbols("b h", positive=True)  # b = tau^(1-alpha), a = x0^(1-alpha) = b + h > b
    a = b + h
    s1 = bool(sp.expand((c1 * a + c2) - (c1 * b + c2)).is_positive)
    s2 = bool(sp.expand(a * (c1 * b + c2) - b * (c1 * a + c2)).is_positive)
    s3 = _zero(sp.expand_log(sp.log((x0 / tau) ** (1 - alpha)) / (c1 * (1 - alpha)) - T36, force=True))
    steps = [
        (True, "x0 > tau > 0 and 1 - alpha > 0 give a = x0^(1-alpha) > b = tau^(1-alpha) > 0"),
        (s1, "(c1 a + c2) - (c1 b + c2) = c1 (a - b) > 0: the ratio of eq 37 exceeds 1"),
        (
            s2,
            "a (c1 b + c2) - b (c1 a + c2) = c2 (a - b) > 0: (c1 a + c2)/(c1 b + c2) < a/b = (x0/tau)^(1-alpha) (eq 37)",
        ),
        (
            s3,
            "ln is increasing and c1 (1-alpha) > 0: T_fsm < ln((x0/tau)^(1-alpha))/(c1 (1-alpha)) = ln(x0/tau)/c1 = T_lsm "
            "(eq 38)",
        ),
    ]
    return _steps_outcome(steps, r"|x_0| > \tau > 0 \implies T_{fsm} < T_{lsm}")


def _theorem3_tsm(ctx: ProofContext) -> _Outcome:
    """Eqs 39-41: ``T_fsm < T_tsm`` for ``|x0| > tau > 0`` (same c2)."""
    _, c1, c2, tau, x0, _, alpha, T34, T35, _ = _fsm_closed_forms()
    d35, d34 = sp.diff(T35, x0), sp.diff(T34, x0)
    s39 = _zero(d35 - x0 ** (-alpha) / c2)
    s40 = _zero(d34 - x0 ** (-alpha) / (c1 * x0 ** (1 - alpha) + c2))
    gap = sp.simplify(d35 - d34)
    s41 = _zero(gap - c1 * x0 ** (1 - 2 * alpha) / (c2 * (c1 * x0 ** (1 - alpha) + c2))) and bool(gap.is_positive)
    s0 = _zero((T35 - T34).subs(x0, tau))
    steps = [
        (s39, "dT_tsm/d|x0| = |x0|^(-alpha)/c2 (eq 39)"),
        (s40, "dT_fsm/d|x0| = |x0|^(-alpha)/(c1 |x0|^(1-alpha) + c2) (eq 40)"),
        (s41, "their difference is c1 |x0|^(1-2 alpha)/(c2 (c1 |x0|^(1-alpha) + c2)) > 0 (eq 41)"),
        (s0, "T_tsm - T_fsm = 0 at |x0| = tau; with a positive derivative it is > 0 for every |x0| > tau"),
    ]
    return _steps_outcome(steps, r"|x_0| > \tau > 0 \implies T_{fsm} < T_{tsm}")


# ----------------------------------------------------------------------------- Remarks


def _remark4(ctx: ProofContext) -> _Outcome:
    from fsmctl.proofs.errata import erratum_remark4_looser

    extra = []
    topo = ctx.scenario.topology
    Ki, Kj = topo.k_i_matrix(), topo.k_j_max_matrix()
    n = topo.n_agents
    sym_ki = all(Ki[i, j] == Ki[j, i] for i in range(n) for j in range(n))
    if sym_ki:
        ok = all(Ki[i, j] >= Kj[i, j] for i in range(n) for j in range(n) if i != j)
        extra.append(
            f"scenario {ctx.scenario.label}: k^i_ij = k^i_ji for all pairs; k^i_ij >= max_t k^j_ij(t) "
            f"{'holds' if ok else 'does NOT hold'} for every pair, so eta = k^i/2 "
            f"{'works' if ok else 'does not work'} (directed, time-varying k^j included)"
        )
    else:
        extra.append(
            f"scenario {ctx.scenario.label}: k^i is not symmetric; Remark 4 does not apply (see theorem1-gains)"
        )
    out = _erratum(erratum_remark4_looser, [(True, "Remark 4's sufficiency (eta = k^i/2, k^i >= k^j) holds")], extra)
    return out


def _remark6(ctx: ProofContext) -> _Outcome:
    """Remark 6: on the surface the singular term equals -c1 c2 alpha sig^alpha - c2^2 alpha sig^(2 alpha - 1)."""
    from fsmctl.symbolic.controller import sigpow

    c1, c2, p, alpha = sp.symbols("c1 c2 p alpha", positive=True)
    x = sp.Symbol("x", real=True)
    x_dot = -c1 * x - c2 * sigpow(x, alpha)[0]
    term = c2 * alpha * sp.Abs(x) ** (alpha - 1) * x_dot
    target = -c1 * c2 * alpha * sigpow(x, alpha)[0] - c2**2 * alpha * sigpow(x, 2 * alpha - 1)[0]
    s1 = all(_zero((term - target).subs(x, sgn * p)) for sgn in (1, -1))
    q = sp.Symbol("q", positive=True)

    def limits(a):  # limits as p -> 0+ of the two powers of the term on s = 0 (x = p > 0 branch)
        return sp.limit(p**a, p, 0, "+"), sp.limit(p ** sp.simplify(2 * a - 1), p, 0, "+")

    s2 = limits(sp.Rational(1, 2) + q) == (0, 0)  # any alpha = 1/2 + q > 1/2: the term -> 0
    lim_half = limits(sp.Rational(1, 2))
    s3 = lim_half == (0, 1) and _zero(-c1 * c2 * sp.Rational(1, 2) * lim_half[0] - c2**2 / 2 * lim_half[1] + c2**2 / 2)
    s4 = limits(1 / (2 * (1 + q)))[1] is sp.oo  # any alpha = 1/(2(1+q)) in (0, 1/2): sig^(2 alpha - 1) blows up
    v = sp.Symbol("v", positive=True)
    s5 = sp.limit(c2 * alpha * p ** (-q) * v, p, 0, "+") is sp.oo
    steps = [
        (
            s1,
            "on s = 0, sigma_dot = -c1 sigma - c2 sig(sigma)^alpha gives c2 alpha |sigma|^(alpha-1) sigma_dot = "
            "-c1 c2 alpha sig(sigma)^alpha - c2^2 alpha sig(sigma)^(2 alpha - 1) (both sign branches)",
        ),
        (s2, "alpha in (1/2, 1): 2 alpha - 1 > 0, the term -> 0 as sigma -> 0: no singularity on the surface"),
        (s3, "alpha = 1/2: the term -> -c2^2/2 sgn(sigma) (a jump of c2^2 across sigma = 0)"),
        (s4, "alpha < 1/2: sig(sigma)^(2 alpha - 1) blows up as sigma -> 0"),
        (
            s5,
            "off the surface (sigma_dot != 0 at sigma = 0) alpha |sigma|^(alpha-1) sigma_dot is unbounded: the Remark 6 "
            "fix is needed before s = 0 (fsmctl uses singularity_fix = switch/clamp)",
        ),
    ]
    return _steps_outcome(
        steps,
        r"s=0:\ c_2\alpha|\sigma|^{\alpha-1}\circ\dot\sigma = -c_1c_2\alpha\,\mathrm{sig}(\sigma)^\alpha"
        r" - c_2^2\alpha\,\mathrm{sig}(\sigma)^{2\alpha-1}\xrightarrow[\sigma\to0]{}0 \iff \alpha > \tfrac12",
    )


# ----------------------------------------------------------------------------- registry

CLAIMS: tuple[Claim, ...] = (
    Claim("lemma1-settling-time", "10", "Lemma 1: finite-time bound T <= Omega(0)^(1-eps)/(lambda(1-eps))", _lemma1),
    Claim("lemma2-sqrt-sum", "11-12", "Lemma 2: sum V_i^(1/2) >= (sum V_i)^(1/2)", _lemma2),
    Claim(
        "reaching-law", "13-15", "sliding surface: V_dot <= -2^((alpha+1)/2) c2 V^((alpha+1)/2) on s = 0", _reaching_law
    ),
    Claim(
        "error-kinematics",
        "7-8",
        "error kinematics sigma_e_dot = G(sigma_e)(omega - omega_d)",
        _error_kinematics,
        heavy=True,
        expected=ERRATUM,
    ),
    Claim("lagrange-C", "9", "Coriolis-like matrix C of the Lagrange-like model", _lagrange_C, expected=ERRATUM),
    Claim("closed-loop", "9, 16-20", "closed loop (20) from the law (16-19) and the model (9)", _closed_loop),
    Claim(
        "fractional-power",
        "17, 20, 23",
        "the term c2 alpha sigma^(alpha-1) sigma_dot",
        _fractional_power,
        expected=ERRATUM,
    ),
    Claim("vdot-i", "23-24", "V_i_dot and each inequality step of eq 24", _vdot_i, expected=ERRATUM),
    Claim("zero-sum", "26", "the zero term sum eta_ij (s_i^T s_i - s_j^T s_j) and what it requires of eta", _zero_sum),
    Claim("complete-square", "27", "completing the square: kappa_ij, gamma_ij", _complete_square),
    Claim(
        "gamma-condition",
        "27, Theorem 1",
        "gamma_ij >= 0 <=> Theorem 1's k/eta conditions",
        _gamma_condition,
        expected=ERRATUM,
    ),
    Claim("vdot-mu", "28", "V_dot <= -mu V^(1/2) and the value of mu", _vdot_mu, uses_scenario=True, expected=ERRATUM),
    Claim(
        "theorem1-gains",
        "Theorem 1, 25-27",
        "Theorem 1's conditions for the scenario's gains and topology",
        _theorem1_gains,
        uses_scenario=True,
    ),
    Claim(
        "theorem2-condition",
        "29-33",
        "Theorem 2: the exact Delta_d and the delta condition",
        _theorem2_condition,
        heavy=True,
        expected=ERRATUM,
    ),
    Claim(
        "theorem2-delta",
        "29-33",
        "Theorem 2: the delta_i the scenario needs vs the configured delta_i",
        _theorem2_delta,
        uses_scenario=True,
        expected=FAILS,
    ),
    Claim("theorem3-closed-forms", "34-36", "settling times of FSM, TSM, LSM by integration", _theorem3_closed_forms),
    Claim("theorem3-fsm-vs-lsm", "37-38", "T_fsm < T_lsm for |x0| > tau > 0", _theorem3_lsm),
    Claim("theorem3-fsm-vs-tsm", "39-41", "T_fsm < T_tsm for |x0| > tau > 0", _theorem3_tsm),
    Claim(
        "remark4-undirected",
        "Remark 4",
        "undirected topology: k^i >= k^j with eta = k^i/2",
        _remark4,
        uses_scenario=True,
        expected=ERRATUM,
    ),
    Claim("remark6-singular-term", "Remark 6", "the singular term vanishes on the surface, for which alpha", _remark6),
)


def claim_ids() -> list[str]:
    """Ids of every claim of Liang et al. 2012, Section 3 (eqs 7-41, Remarks 4 and 6), in the paper's order.

    Returns
    -------
    list of str
        The ids accepted by ``fsmctl prove CLAIM_ID...``.

    Examples
    --------
    >>> from fsmctl.proofs import claim_ids
    >>> ids = claim_ids()
    >>> len(ids), ids[:3]
    (20, ['lemma1-settling-time', 'lemma2-sqrt-sum', 'reaching-law'])
    """
    return [c.id for c in CLAIMS]


def get_claim(claim_id: str) -> Claim:
    """The claim with this id (Liang et al. 2012, Section 3).

    Parameters
    ----------
    claim_id : str
        One of :func:`claim_ids`.

    Returns
    -------
    Claim
        Raises KeyError for an unknown id.
    """
    for c in CLAIMS:
        if c.id == claim_id:
            return c
    raise KeyError(claim_id)


def documented_finding_applies(ctx: ProofContext) -> bool:
    """Whether the registry's documented verdicts (:attr:`Claim.expected`) apply to the claims that use the scenario.

    They do for the paper's scenario (any case of Section 4, as :func:`fsmctl.model.scenario.load_scenario` gives it)
    over Theorem 2's default region; for any other scenario or region there is no documented finding and such a
    claim is expected to hold.

    Parameters
    ----------
    ctx : ProofContext
        The scenario and the sampling options.

    Returns
    -------
    bool
        True for the paper's scenario (unchanged) and the default region.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.proofs import ProofContext, Region
    >>> from fsmctl.proofs.claims import documented_finding_applies
    >>> documented_finding_applies(ProofContext(fsmctl.paper_scenario("2")))
    True
    >>> documented_finding_applies(ProofContext(fsmctl.paper_scenario("1"), Region(sigma=0.0, omega=0.0)))
    False
    """
    from fsmctl.model.scenario import load_scenario

    sc = ctx.scenario
    if ctx.region != t2.Region() or sc.case is None or sc.case not in load_scenario("paper").cases:
        return False
    return sc == load_scenario("paper", case=sc.case)


def _run(claims: list[Claim], ctx: ProofContext) -> list[ClaimResult]:
    out = []
    applies = documented_finding_applies(ctx)
    for c in claims:
        t0 = time.perf_counter()
        o = c.check(ctx)
        documented = c.expected if applies or not c.uses_scenario else None
        out.append(
            ClaimResult(
                id=c.id,
                equations=c.equations,
                title=c.title,
                verdict=o.verdict,
                detail="\n".join(o.lines),
                seconds=time.perf_counter() - t0,
                latex=o.latex,
                holds=o.holds,
                documented=documented,
                as_documented=o.verdict == documented if documented is not None else o.holds,
                data=o.data,
            )
        )
    return out


def _run_ids(ids: list[str], ctx: ProofContext) -> list[ClaimResult]:
    return _run([get_claim(i) for i in ids], ctx)


def run_claims(ids: list[str] | None, ctx: ProofContext, *, workers: int | None = None) -> list[ClaimResult]:
    """Check the given claims (all when ``ids`` is empty or None) and time each one.

    Parameters
    ----------
    ids : list of str or None
        Claim ids (see :func:`claim_ids`); unknown ids raise KeyError.
    ctx : ProofContext
        The scenario and the sampling options.
    workers : int, optional
        With ``workers > 1`` (and the ``fork`` start method available) the heavy symbolic
        claims run in one worker process while the others run here; 1 runs them all here.  Default: one per CPU,
        at most one per group of claims that can run at once (:func:`fsmctl.policy.default_workers` of the number
        of groups: 2 when heavy and light claims are asked for).  The results do not depend on it.

    Returns
    -------
    list of ClaimResult
        In the order of ``ids`` (or of :data:`CLAIMS`).

    Raises
    ------
    KeyError
        An unknown claim id.
    fsmctl.errors.InputError
        ``workers`` is neither ``None`` nor a whole number >= 1.

    Examples
    --------
    Lemma 2 (eqs 11-12) and Theorem 1's conditions (eqs 25-27) for the paper's six-spacecraft formation:

    >>> import fsmctl
    >>> from fsmctl.proofs import ProofContext, run_claims
    >>> results = run_claims(["lemma2-sqrt-sum", "theorem1-gains"], ProofContext(fsmctl.paper_scenario()))
    >>> [(r.id, r.verdict) for r in results]
    [('lemma2-sqrt-sum', 'proved'), ('theorem1-gains', 'proved')]
    >>> print(results[1].detail.splitlines()[2])
    eta exists: constant symmetric eta (the paper's form, non-strict): yes; time-varying symmetric eta(t): yes; ...
    """
    claims = [get_claim(i) for i in ids] if ids else list(CLAIMS)
    heavy = [c for c in claims if c.heavy]
    light = [c for c in claims if not c.heavy]
    workers = resolve_workers(workers, 2 if heavy and light else 1, "run_claims")
    results: dict[str, ClaimResult] = {}
    if workers > 1 and heavy and light:
        try:
            mp_ctx = multiprocessing.get_context("fork")  # the worker starts from this process's loaded modules
        except ValueError:
            mp_ctx = None
        if mp_ctx is not None:
            try:  # the heavy claims in a worker that dies with this process, the light ones here meanwhile
                with worker_pool(1, mp_ctx) as pool:
                    future = pool.submit(_run_ids, [c.id for c in heavy], ctx)
                    results.update((r.id, r) for r in _run(light, ctx))
                    results.update((r.id, r) for r in future.result())
            except Exception:  # a broken worker: fall back to running everything here
                results.clear()
    for r in _run([c for c in claims if c.id not in results], ctx):
        results[r.id] = r
    return [results[c.id] for c in claims]
