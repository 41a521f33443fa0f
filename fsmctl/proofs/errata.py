"""Machine-readable errata of Liang, Sun & Wang (2012), each one checked here.

Every :class:`Erratum` is produced by a function that (a) evaluates the printed
formula and shows that it fails (a nonzero residual or a counterexample) and
(b) checks the corrected statement.  ``checked`` is True only when both hold,
so a stale entry cannot survive a change to the model.

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass

import sympy as sp

from fsmctl.proofs.identities import lagrange_residual_of_printed_C, model_symbols
from fsmctl.symbolic.model import (
    ErrorModel,
    lagrange_C_as_printed,
    lagrange_model,
    lagrange_uncertainty_as_printed,
)
from fsmctl.symbolic.mrp import mrp_G, mrp_G_inverse, mrp_to_dcm, skew
from fsmctl.symbolic.symbols import symmetric_matrix_symbols, vector_symbols

__all__ = [
    "Erratum",
    "all_errata",
    "errata",
    "ERRATA_CHECKS",
    "erratum_error_kinematics",
    "erratum_lagrange_C",
    "erratum_fractional_power",
    "erratum_norm_inequality",
    "erratum_reaching_rate",
    "erratum_uncertainty_term",
    "erratum_theorem1_eta_strict",
    "erratum_remark4_looser",
]


@dataclass(frozen=True)
class Erratum:
    """One printed formula of the paper (Liang et al. 2012) that is false, with its correction.

    Parameters
    ----------
    id : str
        Short id (e.g. ``eq9-C``).
    equation : str
        The equation numbers concerned.
    as_printed, correct : str
        The printed and the corrected statement (plain text).
    residual : str
        What the printed form leaves over (or a counterexample), as text.
    consequence : str
        What the error changes for a user of the paper.
    as_printed_latex, correct_latex : str
        The same statements in LaTeX.
    checked : bool
        Whether SymPy confirmed both that the printed form is false and that the correction holds.

    Examples
    --------
    The Coriolis-like matrix ``C`` of eq 9 lacks a term:

    >>> from fsmctl.proofs.errata import erratum_lagrange_C
    >>> e = erratum_lagrange_C()
    >>> e.id, e.equation, e.checked
    ('eq9-C', '9, 29', True)
    >>> print(e.residual)
    (C_printed - C) sigma_e_dot = G^-T (J omega_d) x omega_e, omega_e = G^-1 sigma_e_dot
    """

    id: str
    equation: str
    as_printed: str
    correct: str
    residual: str
    """What the printed form leaves over (or a counterexample), as text."""
    consequence: str
    as_printed_latex: str
    correct_latex: str
    checked: bool

    def to_dict(self) -> dict:
        """The erratum as a dict of its fields (what ``errata.json`` holds per erratum)."""
        return asdict(self)


def _expand_zero(m) -> bool:
    return all(sp.expand(x) == 0 for x in sp.Matrix(m))


def _cancel_zero(m) -> bool:
    return all(sp.cancel(sp.together(x)) == 0 for x in sp.Matrix(m))


def erratum_lagrange_C() -> Erratum:
    """Eq 9 (and C0 of eq 29): the printed C omits ``-G^-T (J omega_d)^x G^-1``."""
    sym = model_symbols()
    residual = lagrange_residual_of_printed_C()
    compact = sym.G_inverse.T * skew(sym.J * sym.omega_d) * (sym.G_inverse * sym.sigma_e_dot)
    matches = _expand_zero(residual - compact)
    nonzero = not _expand_zero(residual)
    # The corrected C is the one proved by verify_lagrange_form; re-check the difference of the matrices.
    model = lagrange_model(
        sym.J, sym.sigma_e, sym.sigma_e_dot, sym.omega_d, sym.omega_d_dot, ErrorModel.PAPER, G_inverse=sym.G_inverse
    )
    printed = lagrange_C_as_printed(sym.J, sym.sigma_e, sym.sigma_e_dot, sym.omega_d, G_inverse=sym.G_inverse)
    correction = _expand_zero(model.C - printed + sym.G_inverse.T * skew(sym.J * sym.omega_d) * sym.G_inverse)
    return Erratum(
        id="eq9-C",
        equation="9, 29",
        as_printed="C = -M G_dot G^-1 - G^-T (J G^-1 sigma_e_dot)^x G^-1 + G^-T omega_d^x J G^-1",
        correct="C = -M G_dot G^-1 - G^-T (J G^-1 sigma_e_dot)^x G^-1 + G^-T (omega_d^x J - (J omega_d)^x) G^-1",
        residual="(C_printed - C) sigma_e_dot = G^-T (J omega_d) x omega_e, omega_e = G^-1 sigma_e_dot",
        consequence=(
            "with the printed C, eq 9 is not Euler's equation: it misses the gyroscopic coupling "
            "omega_e x J omega_d; a controller built on it leaves that torque uncompensated (same for C0 of eq 29)"
        ),
        as_printed_latex=r"C = -M\dot G_e G_e^{-1} - G_e^{-T}(J G_e^{-1}\dot\sigma_e)^\times G_e^{-1} + G_e^{-T}\omega_d^\times J G_e^{-1}",
        correct_latex=(
            r"C = -M\dot G_e G_e^{-1} - G_e^{-T}(J G_e^{-1}\dot\sigma_e)^\times G_e^{-1} "
            r"+ G_e^{-T}\left(\omega_d^\times J - (J\omega_d)^\times\right) G_e^{-1}"
        ),
        checked=matches and nonzero and correction,
    )


def erratum_error_kinematics() -> Erratum:
    """Eqs 7-8: ``omega_e = omega - omega_d`` is not the rate of the relative attitude ``sigma_e``."""
    sigma = vector_symbols("sigma_e")
    omega_d = vector_symbols("omega_d")
    R = mrp_to_dcm(sigma)
    # Exact: R_e = R_B R_d^T gives d/dt R_e = -(omega - R_e omega_d)^x R_e because R a^x R^T = (R a)^x, R R^T = I.
    orthogonal = _cancel_zero(R * R.T - sp.eye(3))
    a = vector_symbols("a")
    similarity = _cancel_zero(R * skew(a) * R.T - skew(R * a))
    # Counterexample: sigma_e = (1/10, 0, 0), omega_d = (0, 1/10, 0).
    ce = {
        sigma[0]: sp.Rational(1, 10),
        sigma[1]: 0,
        sigma[2]: 0,
        omega_d[0]: 0,
        omega_d[1]: sp.Rational(1, 10),
        omega_d[2]: 0,
    }
    gap = (mrp_G(sigma) * (sp.eye(3) - R) * omega_d).xreplace(ce)
    nonzero = any(x != 0 for x in gap)
    return Erratum(
        id="eq7-8-error-rate",
        equation="7, 8",
        as_printed="sigma_e_dot = G(sigma_e) omega_e with omega_e = omega - omega_d",
        correct="sigma_e_dot = G(sigma_e) omega_e with omega_e = omega - R(sigma_e) omega_d, R(sigma_e) = [B R]",
        residual=(
            "sigma_e_dot(printed) - sigma_e_dot(exact) = G(sigma_e)(R(sigma_e) - I) omega_d; "
            f"at sigma_e = (0.1, 0, 0), omega_d = (0, 0.1, 0): {[sp.nsimplify(x) for x in -gap]}"
        ),
        consequence=(
            "the paper's Lagrange model (9) and closed loop (20) describe an approximate error system; "
            "the error O(|sigma_e| |omega_d|) vanishes at sigma_e = 0, so convergence claims survive near the "
            "reference but the transient differs. fsmctl derives both ('paper' and 'exact')."
        ),
        as_printed_latex=r"\omega_e = \omega - \omega_d",
        correct_latex=r"\omega_e = \omega - R(\sigma_e)\,\omega_d",
        checked=orthogonal and similarity and nonzero,
    )


def erratum_uncertainty_term() -> Erratum:
    """Eq 29: the printed ``Delta_d`` adds 3x3 matrices to 3-vectors and omits ``sigma_e_ddot``, ``sigma_e_dot``."""
    sym = model_symbols()
    dJ = symmetric_matrix_symbols("dJ")
    terms = lagrange_uncertainty_as_printed(
        sym.J, dJ, sym.sigma_e, sym.sigma_e_dot, sym.omega_d, sym.omega_d_dot, vector_symbols("u_d")
    )
    shapes = [t.shape for t in terms]
    ill_formed = len(set(shapes)) > 1

    # Correct form: M, C, E are linear in J (so Delta_M etc. are the model at dJ), and G^-T G^T = I.
    def at(J):
        return lagrange_model(
            J,
            sym.sigma_e,
            sym.sigma_e_dot,
            sym.omega_d,
            sym.omega_d_dot,
            G_inverse=sym.G_inverse,
            require_positive_definite=False,
        )

    full, nominal, pert = at(sym.J + dJ), at(sym.J), at(dJ)
    linear = all(_expand_zero(getattr(full, k) - getattr(nominal, k) - getattr(pert, k)) for k in ("M", "C", "E"))
    x = vector_symbols("x")
    inverse = _cancel_zero(mrp_G_inverse(sym.sigma_e).T * mrp_G(sym.sigma_e).T * x - x)
    return Erratum(
        id="eq29-Delta-d",
        equation="29, 30",
        as_printed=(
            "Delta_d = -G^-T dJ G^-1 + G^-T dJ G^-1 G_dot G^-1 + G^-T (dJ G^-1 sigma_e_dot)^x G^-1 "
            "- G^-T omega_d^x dJ G^-1 - dJ omega_d_dot - omega_d^x dJ omega_d + u_d"
        ),
        correct=(
            "Delta_d = u_d - dJ G^-1 sigma_e_ddot - G^T Delta_C sigma_e_dot - Delta_E, with Delta_C, Delta_E the "
            "model's C, E evaluated at dJ (M, C, E are linear in J)"
        ),
        residual=f"the printed terms have shapes {shapes}: their sum is undefined",
        consequence=(
            "Delta_d depends on sigma_e_ddot, i.e. on the control (including delta o sgn(s) and the coordination "
            "term): Theorem 2's condition delta > |M0^-1 G^-T Delta_d| is implicit in delta and, through "
            "alpha|sigma_e|^(alpha-1), unbounded near sigma_e = 0 off the surface"
        ),
        as_printed_latex=(
            r"\Delta d = -G_e^{-T}\Delta J G_e^{-1} + G_e^{-T}\Delta J G_e^{-1}\dot G_e G_e^{-1} + \dots + u_d"
        ),
        correct_latex=r"\Delta d = u_d - \Delta J G_e^{-1}\ddot\sigma_e - G_e^{T}\Delta C\,\dot\sigma_e - \Delta E",
        checked=ill_formed and linear and inverse,
    )


def erratum_fractional_power() -> Erratum:
    """Eqs 17, 20, 23: ``alpha sigma_e^(alpha-1) sigma_e_dot`` must be elementwise ``alpha |sigma_e|^(alpha-1) o sigma_e_dot``."""
    alpha = sp.Rational(7, 10)
    x = sp.Rational(-1, 10)
    printed = sp.N(x ** (alpha - 1))
    complex_value = not printed.is_real
    t = sp.Symbol("t", real=True)
    p = sp.Function("p", positive=True)(t)
    correct_ok = sp.simplify(sp.diff(-(p**alpha), t) - alpha * p ** (alpha - 1) * sp.diff(-p, t)) == 0
    return Erratum(
        id="eq17-fractional-power",
        equation="17, 20, 23",
        as_printed="c2 alpha sigma_e^(alpha-1) sigma_e_dot",
        correct="c2 alpha |sigma_e|^(alpha-1) o sigma_e_dot (elementwise), the time derivative of c2 sig(sigma_e)^alpha",
        residual=f"for a component sigma_e = -0.1 and alpha = 0.7 the printed power is {printed} (not real)",
        consequence="implemented elementwise with |.|; the derivative identity is proved on both sign branches",
        as_printed_latex=r"c_2\alpha\,\sigma_e^{\alpha-1}\dot\sigma_e",
        correct_latex=r"c_2\alpha\,|\sigma_e|^{\alpha-1}\circ\dot\sigma_e",
        checked=complex_value and correct_ok,
    )


def erratum_norm_inequality() -> Erratum:
    """Eq 24: ``-sum_k delta_k |s_k| <= -||delta|| ||s||`` is false (Cauchy-Schwarz goes the other way)."""
    delta = sp.Matrix([1, 2, 3])
    s = sp.Matrix([1, 0, 0])
    lhs = sum(d * abs(x) for d, x in zip(delta, s, strict=True))
    rhs = delta.norm() * s.norm()
    false_printed = lhs < rhs  # printed claims lhs >= rhs
    # Corrected: sum_k delta_k |s_k| >= min_k delta_k * ||s||_1 >= min_k delta_k * ||s||_2 (checked on the counterexample
    # and proved in general by the proof-check: each |s_k| >= 0 and ||s||_1 >= ||s||_2).
    correct_holds = lhs >= min(delta) * s.norm()
    return Erratum(
        id="eq24-norm-bound",
        equation="24, 25, 27, 32",
        as_printed="-sum_k (delta_i)_k |(s_i)_k| <= -||delta_i|| ||s_i||",
        correct="-sum_k (delta_i)_k |(s_i)_k| <= -min_k (delta_i)_k ||s_i||",
        residual=f"delta = (1, 2, 3), s = (1, 0, 0): sum delta_k|s_k| = {lhs} < ||delta|| ||s|| = {sp.nsimplify(rhs)}",
        consequence="the reaching rate is governed by the smallest component of delta_i, not by its norm",
        as_printed_latex=r"-\sum_k (\delta_i)_k |(s_i)_k| \le -\|\delta_i\|\,\|s_i\|",
        correct_latex=r"-\sum_k (\delta_i)_k |(s_i)_k| \le -\min_k(\delta_i)_k\,\|s_i\|",
        checked=bool(false_printed and correct_holds),
    )


def erratum_reaching_rate() -> Erratum:
    """Eqs 28, 33: ``mu = min_i sqrt(2) ||delta_i||`` must be ``sqrt(2) min_i min_k (delta_i)_k``."""
    delta = sp.Matrix([1, 2, 3])
    printed = sp.sqrt(2) * delta.norm()
    correct = sp.sqrt(2) * min(delta)
    return Erratum(
        id="eq28-mu",
        equation="28, 33",
        as_printed="V_dot <= -mu V^(1/2), mu = min_i sqrt(2) ||delta_i|| (eq 33: ||delta_i - Delta_d_i||)",
        correct="V_dot <= -mu V^(1/2), mu = sqrt(2) min_i min_k (delta_i)_k (eq 33: min_k (delta_i - |M0^-1 G^-T Delta_d_i|)_k)",
        residual=f"for delta_i = (1, 2, 3) the printed mu is {sp.nsimplify(printed)} = {sp.N(printed, 4)}, the valid one {correct}",
        consequence="the printed reaching-time bound 2 V(0)^(1/2) / mu is too small by up to a factor sqrt(3) max/min",
        as_printed_latex=r"\mu = \min_i \sqrt2\,\|\delta_i\|",
        correct_latex=r"\mu = \sqrt2\,\min_i\min_k(\delta_i)_k",
        checked=bool(printed > correct),
    )


def _coupling_block(ki, kj, eta) -> sp.Matrix:
    """``[[k^i - eta, -k^j/2], [-k^j/2, eta]]``: the quadratic form of one ordered pair in eqs 25-27."""
    return sp.Matrix([[ki - eta, -kj / 2], [-kj / 2, eta]])


def erratum_theorem1_eta_strict() -> Erratum:
    """Theorem 1 (eqs 26-27): ``k^i_ij > eta_ij > 0``, ``eta_ij = eta_ji`` constant is more than the proof needs.

    The double sums of eqs 25-27 run over all ``j``, so pairs without a link (``k^i = k^j = 0``) must
    satisfy the conditions too, and the strict inequalities cannot hold there.
    """
    ki, kj, eta = sp.symbols("k_i k_j eta", nonnegative=True)
    s_i, s_j = vector_symbols("s_i"), vector_symbols("s_j")
    B = _coupling_block(ki, kj, eta)
    # the pair's term of eq 27 is the quadratic form of B (per axis): B >= 0 <=> it is >= 0 for all s
    term = (s_i.T * (ki * s_i - kj * s_j))[0, 0] - eta * ((s_i.T * s_i)[0, 0] - (s_j.T * s_j)[0, 0])
    form = sum((sp.Matrix([s_i[k], s_j[k]]).T * B * sp.Matrix([s_i[k], s_j[k]]))[0, 0] for k in range(3))
    block_ok = sp.expand(term - form) == 0
    # det B = (k^i - eta) gamma: for k^i > eta, B >= 0 <=> gamma >= 0 <=> 4 eta (k^i - eta) >= (k^j)^2
    gamma = eta - kj**2 / (4 * (ki - eta))
    det_ok = sp.simplify(B.det() - (ki - eta) * gamma) == 0
    # max_eta 4 eta (k^i - eta) = (k^i)^2 at eta = k^i/2: some eta exists iff k^i >= k^j
    f = 4 * eta * (ki - eta)
    max_ok = (
        sp.solve(sp.diff(f, eta), eta) == [ki / 2]
        and sp.diff(f, eta, 2) < 0
        and sp.expand(f.subs(eta, ki / 2)) == ki**2
    )
    # counterexample: k^i = k^j = 0 (no link; the paper's Case 2): B = 0 >= 0 with eta = 0, but k^i > eta > 0 is empty
    e = sp.Symbol("e", real=True)
    no_strict = sp.reduce_inequalities([e > 0, e < 0], e) is sp.false
    zero_ok = B.subs({ki: 0, kj: 0, eta: 0}).is_positive_semidefinite
    return Erratum(
        id="thm1-eta-strict",
        equation="Theorem 1, 25-27; Remarks 2, 5",
        as_printed="k^i_ij > eta_ij and 4 eta_ij (k^i_ij - eta_ij) >= (k^j_ij)^2 with eta_ij = eta_ji > 0 constant, for all i, j",
        correct=(
            "for every ordered pair [[k^i_ij - eta_ij, -k^j_ij/2], [-k^j_ij/2, eta_ij]] >= 0, i.e. 0 <= eta_ij <= k^i_ij and "
            "4 eta_ij (k^i_ij - eta_ij) >= (k^j_ij)^2 (some eta exists iff k^i_ij >= k^j_ij), with eta balanced "
            "(sum_j eta_ij = sum_j eta_ji for every i, eq 26) and allowed to change with t"
        ),
        residual=(
            "k^i_ij = k^j_ij = 0 (no link, e.g. the paper's Case 2): the pair's term of eq 27 is 0 and the block is "
            "PSD with eta = 0, but k^i_ij > eta_ij > 0 has no solution"
        ),
        consequence=(
            "the sums of eqs 25-27 run over all j, so as printed Theorem 1 only covers formations in which every "
            "agent weights every other one (k^i_ij > 0 for all i != j), not 'arbitrary topologies'; the paper's own "
            "Case 2 and any sparse graph are outside it, although the corrected (non-strict) condition covers them"
        ),
        as_printed_latex=r"k^i_{ij} > \eta_{ij},\ 4\eta_{ij}(k^i_{ij}-\eta_{ij}) \ge (k^j_{ij})^2,\ \eta_{ij}=\eta_{ji}>0",
        correct_latex=(
            r"\begin{bmatrix}k^i_{ij}-\eta_{ij} & -k^j_{ij}/2\\ -k^j_{ij}/2 & \eta_{ij}\end{bmatrix}\succeq 0,\quad "
            r"\textstyle\sum_j \eta_{ij} = \sum_j \eta_{ji}"
        ),
        checked=bool(block_ok and det_ok and max_ok and no_strict and zero_ok),
    )


def erratum_remark4_looser() -> Erratum:
    """Remark 4: ``k^i_ij >= k^j_ij`` (with ``eta = k^i/2``) is not a looser condition than Theorem 1's."""
    k, kj = sp.symbols("k k_j", nonnegative=True)
    eta = sp.Symbol("eta", nonnegative=True)
    B_half = _coupling_block(k, kj, k / 2)
    eig_ok = set(B_half.eigenvals()) == {k / 2 - kj / 2, k / 2 + kj / 2}  # PSD <=> k >= k_j
    # Theorem 1's conditions are feasible for some eta iff max_eta 4 eta (k - eta) = k^2 >= k_j^2, the same set
    f = 4 * eta * (k - eta)
    same_set = sp.solve(sp.diff(f, eta), eta) == [k / 2] and sp.expand(f.subs(eta, k / 2) - k**2) == 0
    strict_ok = sp.simplify(f.subs(eta, k / 2) - k**2) == 0  # eta = k/2 also meets k > eta > 0 whenever k > 0
    return Erratum(
        id="remark4-looser",
        equation="Remark 4",
        as_printed=(
            "for an undirected topology k^i_ij >= k^j_ij suffices (eta_ij = k^i_ij/2), 'a more loose condition' than "
            "Theorem 1's"
        ),
        correct=(
            "with eta = k^i/2 the pair's block has eigenvalues (k^i +- k^j)/2, so it holds iff k^i >= k^j; Theorem 1's "
            "conditions are satisfiable iff k^i >= k^j as well (max_eta 4 eta (k^i - eta) = (k^i)^2): the same "
            "condition, not a looser one, and only k^i_ij = k^i_ji (not undirected k^j) is used"
        ),
        residual=(
            "{(k^i, k^j): exists eta, k^i > eta > 0, 4 eta (k^i - eta) >= (k^j)^2} = {k^i >= k^j, k^i > 0}; the only "
            "extra case of Remark 4, k^i = k^j = 0, is the one Theorem 1's strict inequalities exclude by mistake"
        ),
        consequence="Remark 4 adds nothing to (the corrected) Theorem 1; directed and time-varying k^j are covered alike",
        as_printed_latex=r"k^i_{ij} \ge k^j_{ij}\ \text{(undirected, } \eta_{ij} = k^i_{ij}/2\text{) is looser}",
        correct_latex=(
            r"\exists\eta:\ 4\eta(k^i-\eta)\ge (k^j)^2,\ 0\le\eta\le k^i \iff k^i \ge k^j "
            r"\iff \begin{bmatrix}k^i/2 & -k^j/2\\ -k^j/2 & k^i/2\end{bmatrix}\succeq 0"
        ),
        checked=bool(eig_ok and same_set and strict_ok),
    )


ERRATA_CHECKS: tuple[Callable[[], Erratum], ...] = (
    erratum_error_kinematics,
    erratum_lagrange_C,
    erratum_fractional_power,
    erratum_norm_inequality,
    erratum_reaching_rate,
    erratum_uncertainty_term,
    erratum_theorem1_eta_strict,
    erratum_remark4_looser,
)


def errata() -> list[Erratum]:
    """Run every errata check and return the list, in equation order.

    Each check (:data:`ERRATA_CHECKS`) confirms symbolically that a printed formula of Liang et al. 2012 is
    false and that its correction holds.  These are the errata found while proving Section 3; every erratum of
    the paper (these, then those of the re-audit against the printed text) is :func:`all_errata`.  Running
    all of them takes a few seconds of SymPy.

    Returns
    -------
    list of Erratum
        Eqs 7-8 (error kinematics), 9 (``C``), 17/20/23 (the fractional power), 24 (a norm bound), 28 (``mu``),
        29-30 (``Delta_d``), Theorem 1 (strict ``eta``) and Remark 4.

    Examples
    --------
    ``errata()`` is ``[check() for check in ERRATA_CHECKS]``; one check:

    >>> from fsmctl.proofs.errata import ERRATA_CHECKS
    >>> len(ERRATA_CHECKS), ERRATA_CHECKS[2].__name__
    (8, 'erratum_fractional_power')
    >>> e = ERRATA_CHECKS[2]()
    >>> e.equation, e.checked
    ('17, 20, 23', True)
    """
    return [check() for check in ERRATA_CHECKS]


def all_errata() -> list[Erratum]:
    """Every erratum of Liang et al. 2012 that fsmctl knows, each one checked: the one registry of the errata.

    :func:`errata` (found while proving Section 3: :data:`ERRATA_CHECKS`), then
    :func:`fsmctl.proofs.seed_audit.audit_errata` (found by the re-audit of every printed equation against the
    printed text: :data:`fsmctl.proofs.seed_audit.AUDIT_CHECKS`).  ``python -m derive`` writes this list to
    ``generated/errata.json``; ``fsmctl prove`` reports it, each erratum with its equations.

    Returns
    -------
    list of Erratum
        The errata of the proofs in equation order, then those of the re-audit in the audit's order; ids unique.

    Examples
    --------
    >>> from fsmctl.proofs.errata import all_errata
    >>> found = all_errata()
    >>> len(found), all(e.checked for e in found)
    (15, True)
    >>> [(e.id, e.equation) for e in found if e.id == "eq18-delta-diag"]
    [('eq18-delta-diag', '18, 20, 30')]
    """
    from fsmctl.proofs.seed_audit import audit_errata  # seed_audit imports Erratum from this module

    return errata() + audit_errata()
