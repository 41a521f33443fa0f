"""Audit of every printed equation of Sections 2-3 of Liang, Sun & Wang (2012) against the raw PDF text.

Three versions of each formula are compared:

(a) the *printed* text, quoted verbatim (whitespace-normalised) from the PDF extraction
    ``shared/seed/liang2012_acta_astronautica.txt``, with its garbling;
(b) the *transcription* in ``shared/spec/paper.md``, which restates the paper in clean notation;
(c) what fsmctl implements symbolically (:mod:`fsmctl.symbolic`).

Each :class:`AuditRow` gets one verdict (:data:`VERDICTS`).  A row is a *silent correction* when the
printed formula is wrong (notation, dimension, sign, index, ...) and ``paper.md`` states the right one
without saying that it differs; it is a *new printed error* when the print is wrong and ``paper.md``
does not address it.  Both kinds are errata that :mod:`fsmctl.proofs.errata` did not have: each has a
check here, written in the style of that module, that builds the printed form and shows that it fails
(a nonzero residual, a shape mismatch, a counterexample) and shows that the corrected form holds and
is what fsmctl uses.  ``checked`` is computed, never set to True by hand, and every check takes the
corrected form as an argument, so that passing the printed form instead makes it fail.

:func:`audit_errata` returns the new :class:`~fsmctl.proofs.errata.Erratum` objects;
:func:`audit_markdown` renders ``docs/errata-audit.md``.

Pure SymPy: no NumPy, no I/O (except ``python -m fsmctl.proofs.seed_audit [--check]``, which writes or
compares ``docs/errata-audit.md``).

Size: one audit, a row per printed equation of Sections 2-3: most of the length is the quoted print and its
transcription (data), with the few checks the rows call; splitting the table would scatter one document.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import sympy as sp

# fsmctl.symbolic first: importing fsmctl.proofs.errata on its own goes through fsmctl.symbolic's __init__
from fsmctl.symbolic.controller import (
    SingularityFix,
    closed_loop_acceleration,
    control_law_pieces,
    coordination_term,
    scalar_sliding_mode,
    sigpow,
    surface_term_slope,
    switching_function,
)
from fsmctl.symbolic.model import ErrorModel, LagrangeModel, lagrange_model
from fsmctl.symbolic.mrp import mrp_G, mrp_G_inverse, skew
from fsmctl.symbolic.symbols import matrix_symbols, symmetric_matrix_symbols, vector_symbols
from fsmctl.symbolic.theorem3 import settling_time_closed_forms

from fsmctl.proofs.errata import Erratum  # isort: skip

__all__ = [
    "ARTEFACT",
    "AUDIT",
    "AUDIT_CHECKS",
    "EXISTING",
    "NEW",
    "SAME",
    "SILENT",
    "VERDICTS",
    "AuditCheck",
    "AuditRow",
    "GainAssumption",
    "audit_errata",
    "audit_markdown",
    "erratum_E_cross",
    "erratum_delta_diag",
    "erratum_gains_nonnegative",
    "erratum_radius_symbol",
    "erratum_scalar_gains",
    "erratum_sigma_index",
    "erratum_skew_sign",
]

SAME = "same"
ARTEFACT = "extraction artefact only"
SILENT = "silent correction in paper.md"
EXISTING = "printed error already in the errata"
NEW = "new printed error"
VERDICTS = (SAME, ARTEFACT, SILENT, EXISTING, NEW)

SEED_PATH = "shared/seed/liang2012_acta_astronautica.txt"
"""Where the raw extraction lives, relative to the parent of the repository."""


@dataclass(frozen=True)
class AuditRow:
    """One printed formula of Sections 2-3 and its verdict."""

    equation: str
    """``eq N`` (optionally with the part, ``eq 9 (C)``), or a theorem, remark or section"""
    section: str
    printed: str
    """verbatim excerpt from the seed text, whitespace-normalised"""
    printed_meaning: str
    """the printed excerpt decoded with the glyph key (what the PDF shows, errors included)"""
    transcription: str
    """what paper.md says"""
    verdict: str
    """one of :data:`VERDICTS`"""
    erratum: str | None
    """existing (``fsmctl.proofs.errata``) or new (this module) erratum id"""
    note: str
    """why this verdict: artefact of the extraction or error of the print"""


# ----------------------------------------------------------------------------- helpers


def _expand_zero(m) -> bool:
    return all(sp.expand(x) == 0 for x in sp.Matrix(m))


def _shape_error(build: Callable[[], object]) -> bool:
    """True when building the expression fails because the shapes do not match."""
    try:
        build()
    except sp.ShapeError:
        return True
    return False


def _holds(test: Callable[[], bool]) -> bool:
    """Evaluate a check of a candidate form; a form that cannot even be built does not hold."""
    try:
        return bool(test())
    except (sp.ShapeError, TypeError, ValueError, IndexError):
        return False


def _free_model() -> LagrangeModel:
    """``M``, ``C``, ``E``, ``G`` as free symbols: control-law identities hold for any model."""
    return LagrangeModel(
        M=matrix_symbols("M"),
        C=matrix_symbols("C"),
        E=vector_symbols("E"),
        G=matrix_symbols("G"),
        G_inverse=matrix_symbols("Ginv"),
        G_dot=sp.ImmutableMatrix.zeros(3, 3),
        omega_r=vector_symbols("omega_d"),
        error_model=ErrorModel.PAPER,
    )


@dataclass(frozen=True)
class _LawSymbols:
    sigma: sp.ImmutableMatrix
    sigma_dot: sp.ImmutableMatrix
    s: sp.ImmutableMatrix
    delta: sp.ImmutableMatrix
    coordination: sp.ImmutableMatrix
    c1: sp.Symbol
    c2: sp.Symbol
    alpha: sp.Symbol


def _law_symbols() -> _LawSymbols:
    return _LawSymbols(
        sigma=vector_symbols("sigma_ei"),
        sigma_dot=vector_symbols("sigma_ei_dot"),
        s=vector_symbols("s_i"),
        delta=sp.ImmutableMatrix([sp.Symbol(f"delta[{k}]", positive=True) for k in range(3)]),
        coordination=vector_symbols("coordination"),
        c1=sp.Symbol("c1", positive=True),
        c2=sp.Symbol("c2", positive=True),
        alpha=sp.Symbol("alpha", positive=True),
    )


def _rate(sigma, sigma_dot, c1, c2, alpha) -> sp.Matrix:
    """``c1 sigma_dot + c2 alpha |sigma|^(alpha-1) o sigma_dot`` (the bracket of eq 17, erratum eq17-fractional-power applied)."""
    slope = sp.Matrix([surface_term_slope(x, alpha, SingularityFix.NONE) for x in sigma])
    return c1 * sp.Matrix(sigma_dot) + c2 * sp.matrix_multiply_elementwise(slope, sp.Matrix(sigma_dot))


# ----------------------------------------------------------------------------- eq 6: the skew matrix


def printed_skew(v) -> sp.Matrix:
    """Eq 6 as printed: third row ``(-(v)_2, -(v)_1, 0)``."""
    v = sp.Matrix(v)
    return sp.Matrix([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], -v[0], 0]])


def corrected_skew(v) -> sp.Matrix:
    """Eq 6 corrected: third row ``(-(v)_2, (v)_1, 0)``."""
    v = sp.Matrix(v)
    return sp.Matrix([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def _G_with(form, sigma) -> sp.Matrix:
    """Eq 5 with the skew matrix ``form``."""
    sigma = sp.Matrix(sigma)
    s2 = (sigma.T * sigma)[0, 0]
    return ((1 - s2) * sp.eye(3) + 2 * sp.Matrix(form(sigma)) + 2 * sigma * sigma.T) / 4


def _skew_ok(form) -> bool:
    v, w = sp.Matrix(vector_symbols("v")), sp.Matrix(vector_symbols("w"))
    m = sp.Matrix(form(v))
    return _expand_zero(m + m.T) and _expand_zero(m * w - v.cross(w))


def _G_orthogonal(form) -> bool:
    sigma = sp.Matrix(vector_symbols("sigma"))
    G = _G_with(form, sigma)
    s2 = (sigma.T * sigma)[0, 0]
    return _expand_zero(16 * G * G.T - (1 + s2) ** 2 * sp.eye(3))


def erratum_skew_sign(corrected: Callable = corrected_skew) -> Erratum:
    """Eq 6: the printed (3,2) entry ``-(v)_1`` makes ``v^x`` symmetric in that pair, not skew."""
    v = vector_symbols("v")
    ce_v, ce_w = sp.Matrix([1, 0, 0]), sp.Matrix([0, 1, 0])
    printed_w = printed_skew(ce_v) * ce_w
    cross = ce_v.cross(ce_w)
    printed_fails = not _skew_ok(printed_skew) and printed_w != cross and not _G_orthogonal(printed_skew)
    corrected_ok = _holds(
        lambda: (
            _skew_ok(corrected)
            and _expand_zero(sp.Matrix(corrected(v)) - skew(v))
            and _expand_zero(_G_with(corrected, vector_symbols("sigma")) - mrp_G(vector_symbols("sigma")))
            and _G_orthogonal(corrected)
        )
    )
    return Erratum(
        id="eq6-skew-sign",
        equation="6",
        as_printed="v^x = [[0, -(v)_3, (v)_2], [(v)_3, 0, -(v)_1], [-(v)_2, -(v)_1, 0]]",
        correct="v^x = [[0, -(v)_3, (v)_2], [(v)_3, 0, -(v)_1], [-(v)_2, (v)_1, 0]] (fsmctl.symbolic.mrp.skew)",
        residual=(
            f"the printed matrix P has P + P^T != 0 (entries (2,3) and (3,2) are both -(v)_1); for v = (1, 0, 0), "
            f"w = (0, 1, 0): P w = {list(printed_w)} but v x w = {list(cross)}; and G(sigma) of eq 5 built with P "
            "loses 16 G G^T = (1 + sigma^T sigma)^2 I"
        ),
        consequence=(
            "taken literally, the printed matrix is not a cross product: eqs 4, 5 and 9 built with it are not the "
            "rigid-body model (G would not even be a scaled rotation); every derivation uses the skew matrix"
        ),
        as_printed_latex=r"v^\times = \begin{bmatrix}0&-v_3&v_2\\ v_3&0&-v_1\\ -v_2&-v_1&0\end{bmatrix}",
        correct_latex=r"v^\times = \begin{bmatrix}0&-v_3&v_2\\ v_3&0&-v_1\\ -v_2&v_1&0\end{bmatrix}",
        checked=bool(printed_fails and corrected_ok),
    )


# ----------------------------------------------------------------------------- eqs 9, 29: E, E0 and Delta_d


def printed_E(J, omega_d, omega_d_dot) -> sp.Matrix:
    """``E = J omega_d_dot + omega_d J omega_d`` as printed (no cross): a 3x1 times a 3x3."""
    return sp.Matrix(J) * sp.Matrix(omega_d_dot) + sp.Matrix(omega_d) * sp.Matrix(J) * sp.Matrix(omega_d)


def corrected_E(J, omega_d, omega_d_dot) -> sp.Matrix:
    """``E = J omega_d_dot + omega_d^x J omega_d``."""
    return sp.Matrix(J) * sp.Matrix(omega_d_dot) + sp.Matrix(skew(omega_d)) * sp.Matrix(J) * sp.Matrix(omega_d)


def erratum_E_cross(corrected: Callable = corrected_E) -> Erratum:
    """Eqs 9, 29: ``omega_d J omega_d`` (in E, E0 and Delta_d) lacks the cross product: it is not defined."""
    J, dJ = symmetric_matrix_symbols("J"), symmetric_matrix_symbols("dJ")
    wd, wdd = vector_symbols("omega_d"), vector_symbols("omega_d_dot")
    sigma_e, sigma_e_dot = vector_symbols("sigma_e"), vector_symbols("sigma_e_dot")
    printed_fails = _shape_error(lambda: printed_E(J, wd, wdd))
    # the only other product of omega_d, J, omega_d without a cross, omega_d^T J omega_d, is 1x1 and cannot be added
    scalar_reading_fails = _shape_error(lambda: sp.Matrix(J) * sp.Matrix(wdd) + wd.T * J * wd)

    def holds(inertia, perturbation: bool) -> bool:
        E = sp.Matrix(corrected(inertia, wd, wdd))
        if E.shape != (3, 1):
            return False
        # eq 9 at sigma_e_dot = sigma_e_ddot = 0 (omega = omega_d, omega_dot = omega_d_dot) is G^-T E = G^-T u,
        # so E must be Euler's torque (eq 4) along the reference: J omega_d_dot + omega_d x (J omega_d)
        euler = sp.Matrix(inertia) * sp.Matrix(wdd) + sp.Matrix(wd).cross(sp.Matrix(inertia) * sp.Matrix(wd))
        model = lagrange_model(
            inertia,
            sigma_e,
            sigma_e_dot,
            wd,
            wdd,
            ErrorModel.PAPER,
            G_inverse=matrix_symbols("Ginv"),
            require_positive_definite=not perturbation,
        )
        return _expand_zero(E - euler) and _expand_zero(E - model.E)

    # E (eq 9), E0 (eq 29, at J0) and the Delta_E part of Delta_d (eq 29, at dJ; the model is linear in J)
    corrected_ok = _holds(lambda: holds(J, False) and holds(dJ, True))
    return Erratum(
        id="eq9-E-cross",
        equation="9, 29",
        as_printed="E = J omega_d_dot + omega_d J omega_d; E0 = J0 omega_d_dot + omega_d J0 omega_d; Delta_d ... - omega_d dJ omega_d + u_d",
        correct="E = J omega_d_dot + omega_d^x J omega_d (E0 and the Delta_d term likewise, with J0 and dJ)",
        residual=(
            "omega_d (3x1) times J (3x3) is undefined (ShapeError), and omega_d^T J omega_d is a scalar that cannot be "
            "added to J omega_d_dot; with the cross, E equals Euler's torque J omega_d_dot + omega_d x J omega_d along "
            "the reference (eq 9 at sigma_e_dot = sigma_e_ddot = 0)"
        ),
        consequence=(
            "the feed-forward E_i of u^F (eq 17) and the uncertainty Delta_d (eq 29) are only defined with the cross; "
            "fsmctl's lagrange_model uses it (and so does the eq29-Delta-d erratum's 'as printed' text, silently)"
        ),
        as_printed_latex=r"E = J\dot\omega_d + \omega_d J \omega_d",
        correct_latex=r"E = J\dot\omega_d + \omega_d^\times J \omega_d",
        checked=bool(printed_fails and scalar_reading_fails and corrected_ok),
    )


# ----------------------------------------------------------------------------- eq 17: the index of sigma_e_dot


def printed_feedback(model: LagrangeModel, sigma_ei, sigma_ei_dot, sigma_e_dot, c1, c2, alpha) -> sp.Matrix:
    """Eq 17 as printed: ``u^F_i = -(G_ei^T C_i sigma_e_dot + E_i) + G_ei^T M_i (...)``, ``sigma_e_dot`` without ``i``."""
    GtM = model.G.T * model.M
    return -(model.G.T * model.C * sp.Matrix(sigma_e_dot) + model.E) + GtM * _rate(
        sigma_ei, sigma_ei_dot, c1, c2, alpha
    )


def corrected_feedback(model: LagrangeModel, sigma_ei, sigma_ei_dot, sigma_e_dot, c1, c2, alpha) -> sp.Matrix:
    """Eq 17 with the agent's own rate ``sigma_ei_dot`` in the ``C_i`` term (``sigma_e_dot`` is not used)."""
    _ = sigma_e_dot
    GtM = model.G.T * model.M
    return -(model.G.T * model.C * sp.Matrix(sigma_ei_dot) + model.E) + GtM * _rate(
        sigma_ei, sigma_ei_dot, c1, c2, alpha
    )


def _closed_loop_residual(form) -> sp.Matrix:
    """``G^T`` times eq 9 minus the law (16-19) built with ``u^F = form(...)``, with ``sigma_ei_ddot`` from eq 20.

    It vanishes iff the law with that ``u^F`` yields the closed loop (20).  ``sigma_e_dot`` is a separate
    vector: the rate the printed ``C_i sigma_e_dot`` refers to when it is not agent i's.
    """
    L, model = _law_symbols(), _free_model()
    other = vector_symbols("sigma_e_dot")
    pieces = control_law_pieces(
        model, L.sigma, L.sigma_dot, L.s, L.c1, L.c2, L.alpha, L.delta, L.coordination, fix=SingularityFix.NONE
    )
    u_F = sp.Matrix(form(model, L.sigma, L.sigma_dot, other, L.c1, L.c2, L.alpha))
    u = -u_F - pieces.u_D - pieces.u_C
    sigma_ddot = closed_loop_acceleration(
        L.sigma, L.sigma_dot, L.s, L.c1, L.c2, L.alpha, L.delta, L.coordination, fix=SingularityFix.NONE
    )
    return model.G.T * (model.M * sigma_ddot + model.C * L.sigma_dot) + model.E - u


def erratum_sigma_index(corrected: Callable = corrected_feedback) -> Erratum:
    """Eq 17: ``G_ei^T C_i sigma_e_dot`` must use agent i's rate ``sigma_ei_dot``."""
    L, model = _law_symbols(), _free_model()
    other = vector_symbols("sigma_e_dot")
    residual = _closed_loop_residual(printed_feedback)
    expected = model.G.T * model.C * (L.sigma_dot - other)
    printed_fails = not _expand_zero(residual) and _expand_zero(residual - expected)

    def holds() -> bool:
        u_F = sp.Matrix(corrected(model, L.sigma, L.sigma_dot, other, L.c1, L.c2, L.alpha))
        fsmctl = control_law_pieces(
            model, L.sigma, L.sigma_dot, L.s, L.c1, L.c2, L.alpha, L.delta, L.coordination, fix=SingularityFix.NONE
        ).u_F
        return _expand_zero(_closed_loop_residual(corrected)) and _expand_zero(u_F - fsmctl)

    return Erratum(
        id="eq17-sigma-index",
        equation="17",
        as_printed="u^F_i = -(G_ei^T C_i sigma_e_dot + E_i) + G_ei^T M_i (c1 sigma_ei_dot + ...)",
        correct="u^F_i = -(G_ei^T C_i sigma_ei_dot + E_i) + G_ei^T M_i (c1 sigma_ei_dot + ...)",
        residual=(
            "G_ei^T (eq 9 of agent i) - u_i with sigma_ei_ddot from eq 20 leaves G_ei^T C_i (sigma_ei_dot - sigma_e_dot), "
            "nonzero unless the rate in the C_i term is agent i's own"
        ),
        consequence=(
            "with any rate other than sigma_ei_dot the feedback does not cancel C_i sigma_ei_dot and eq 20 does not "
            "follow from eqs 9, 16-19; fsmctl's control_law_pieces uses sigma_ei_dot"
        ),
        as_printed_latex=r"u^F_i = -\big(G_{ei}^T C_i\dot\sigma_e + E_i\big) + G_{ei}^T M_i(\dots)",
        correct_latex=r"u^F_i = -\big(G_{ei}^T C_i\dot\sigma_{ei} + E_i\big) + G_{ei}^T M_i(\dots)",
        checked=bool(printed_fails and _holds(holds)),
    )


# ----------------------------------------------------------------------------- eqs 18, 20, 30: q_i = G^T M delta_i


def printed_switching_torque(GtM, delta, s) -> sp.Matrix:
    """Eq 18 as printed: ``u^D_i = q_i sgn(s_i)`` with ``q_i = G_ei^T M_i delta_i`` (a 3-vector times a 3-vector)."""
    q = sp.Matrix(GtM) * sp.Matrix(delta)
    return q * sp.Matrix(switching_function(s))


def elementwise_switching_torque(GtM, delta, s) -> sp.Matrix:
    """The only product of the printed 3-vectors that is a 3-vector: ``q_i o sgn(s_i)``, ``q_i = G^T M delta_i``."""
    return sp.matrix_multiply_elementwise(sp.Matrix(GtM) * sp.Matrix(delta), sp.Matrix(switching_function(s)))


def corrected_switching_torque(GtM, delta, s) -> sp.Matrix:
    """``u^D_i = G_ei^T M_i diag(delta_i) sgn(s_i)``, i.e. ``G^T M (delta_i o sgn(s_i))``."""
    return sp.Matrix(GtM) * sp.diag(*list(delta)) * sp.Matrix(switching_function(s))


def erratum_delta_diag(corrected: Callable = corrected_switching_torque) -> Erratum:
    """Eqs 18, 20, 30: ``q_i = G^T M delta_i`` is a vector, so ``q_i sgn(s_i)`` and ``delta_i sgn(s_i)`` are undefined."""
    L, model = _law_symbols(), _free_model()
    GtM = model.G.T * model.M
    printed_fails = _shape_error(lambda: printed_switching_torque(GtM, L.delta, L.s))
    closed_loop_printed_fails = _shape_error(lambda: L.delta * switching_function(L.s))  # eq 20's delta_i sgn(s_i)
    # the elementwise reading of the printed q_i is a different torque: counterexample at sigma_e = 0 (G^-1 = 4 I)
    J0 = sp.Matrix([[2, 1, 0], [1, 3, 0], [0, 0, 4]])
    zero = sp.zeros(3, 1)
    Gi0 = mrp_G_inverse(zero)
    GtM0 = mrp_G(zero).T * (Gi0.T * J0 * Gi0)
    d0, s0 = sp.Matrix([1, 2, 3]), sp.Matrix([1, -1, 1])
    elementwise = elementwise_switching_torque(GtM0, d0, s0)
    reference = GtM0 * sp.matrix_multiply_elementwise(d0, sp.Matrix(switching_function(s0)))
    elementwise_fails = elementwise != reference

    def holds() -> bool:
        u_D = sp.Matrix(corrected(GtM, L.delta, L.s))
        fsmctl = control_law_pieces(
            model, L.sigma, L.sigma_dot, L.s, L.c1, L.c2, L.alpha, L.delta, L.coordination, fix=SingularityFix.NONE
        ).u_D
        # what eq 20 needs: G^-T u^D = M (delta o sgn(s)), and then s^T (delta o sgn(s)) = sum_k delta_k |s_k| (eq 24)
        sgn = sp.Matrix(switching_function(L.s))
        in_loop = _expand_zero(u_D - GtM * sp.matrix_multiply_elementwise(L.delta, sgn))
        power = (L.s.T * sp.matrix_multiply_elementwise(L.delta, sgn))[0, 0]
        dissipation = sp.expand(power - sum(L.delta[k] * L.s[k] * sp.sign(L.s[k]) for k in range(3))) == 0 and all(
            sp.simplify(x * sp.sign(x) - sp.Abs(x)) == 0 for x in L.s
        )
        sd = closed_loop_acceleration(
            L.sigma, L.sigma_dot, L.s, L.c1, L.c2, L.alpha, L.delta, L.coordination, fix=SingularityFix.NONE
        )
        loop_term = _expand_zero(sd.jacobian(L.delta) + sp.diag(*list(sgn)))
        return (
            _expand_zero(u_D - fsmctl)
            and in_loop
            and dissipation
            and loop_term
            and _holds(lambda: sp.Matrix(corrected(GtM0, d0, s0)) == reference)
        )

    return Erratum(
        id="eq18-delta-diag",
        equation="18, 20, 30",
        as_printed="u^D_i = q_i sgn(s_i), q_i = G_ei^T M_i delta_i; eqs 20, 30: ... - delta_i sgn(s_i) ...",
        correct="q_i = G_ei^T M_i diag(delta_i), u^D_i = G_ei^T M_i (delta_i o sgn(s_i)); eqs 20, 30: - delta_i o sgn(s_i)",
        residual=(
            "q_i = G^T M delta_i is 3x1 and so is sgn(s_i): their product is undefined (ShapeError), as is eq 20's "
            "delta_i sgn(s_i); the elementwise reading q_i o sgn(s_i) is another torque: at sigma_e = 0, "
            f"J0 = [[2,1,0],[1,3,0],[0,0,4]], delta = (1,2,3), s = (1,-1,1) it gives {list(elementwise)} instead of "
            f"{list(reference)}"
        ),
        consequence=(
            "(delta_i)_k > 0 per axis (eq 18) and the sum over k in eq 24 fix the meaning: diag(delta_i), elementwise "
            "in the closed loop; fsmctl's control_law_pieces and closed_loop_acceleration use it"
        ),
        as_printed_latex=r"u^D_i = q_i\,\mathrm{sgn}(s_i),\ q_i = G_{ei}^T M_i \delta_i",
        correct_latex=r"u^D_i = G_{ei}^T M_i\,\mathrm{diag}(\delta_i)\,\mathrm{sgn}(s_i) = G_{ei}^T M_i(\delta_i\circ\mathrm{sgn}(s_i))",
        checked=bool(printed_fails and closed_loop_printed_fails and elementwise_fails and _holds(holds)),
    )


# ----------------------------------------------------------------------------- eq 19: the weights


@dataclass(frozen=True)
class GainAssumption:
    """What eq 19 assumes of the weights ``k^i_ij``, ``k^j_ij``."""

    strictly_positive: bool
    constant: bool

    def admits(self, values: Sequence) -> bool:
        """Whether a weight taking these values over time satisfies the assumption."""
        vals = [sp.sympify(v) for v in values]
        signs = all(bool(v > 0) if self.strictly_positive else bool(v >= 0) for v in vals)
        return signs and (len(set(vals)) == 1 if self.constant else True)


PRINTED_GAINS = GainAssumption(strictly_positive=True, constant=True)
"""Eq 19 as printed: 'k^i_ij and k^j_ij are positive constants'."""
CORRECTED_GAINS = GainAssumption(strictly_positive=False, constant=False)
"""What the paper uses and fsmctl implements: ``k >= 0``, ``k^j_ij`` may switch with time."""


def erratum_gains_nonnegative(corrected: GainAssumption = CORRECTED_GAINS) -> Erratum:
    """Eq 19: 'positive constants' excludes the paper's own weights (zero, switching); k >= 0, time-varying is meant."""
    t = sp.Symbol("t", real=True)
    schedule = sp.Piecewise((5, sp.Mod(t, 8) <= sp.Rational(13, 2)), (0, True))  # Table 2: k^2_12(t)
    table2 = sorted({schedule.subs(t, v) for v in (0, 3, 6, sp.Rational(27, 4), 7, sp.Rational(15, 2))})
    case2, case1_ki = [0], [8]  # Case 2: k^i = k^j = 0; Case 1: k^i_ij = 8
    printed_fails = not PRINTED_GAINS.admits(table2) and not PRINTED_GAINS.admits(case2)

    def holds() -> bool:
        examples = corrected.admits(table2) and corrected.admits(case2) and corrected.admits(case1_ki)
        # the proof needs neither constancy nor positivity: V_dot = sum s_i^T s_i_dot has no k_dot (eqs 21-25) ...
        si, sj = sp.Function("s_i")(t), sp.Function("s_j")(t)
        ki, kj = sp.Function("k_i")(t), sp.Function("k_j")(t)
        V = (si**2 + sj**2) / 2
        V_dot = sp.diff(V, t).subs({sp.Derivative(si, t): -(ki * si - kj * sj), sp.Derivative(sj, t): 0})
        no_k_dot = not V_dot.atoms(sp.Derivative)
        # ... and a pair without a link (k^j = 0) has a PSD block [[k^i - eta, 0], [0, eta]] for eta in [0, k^i]
        k, eta = sp.symbols("k eta", nonnegative=True)
        block = sp.Matrix([[k - eta, 0], [0, eta]]).subs(eta, k / 2)
        psd = block.is_positive_semidefinite
        # fsmctl's coordination term takes the weights as they are at time t, zero included
        s_i, s_j = vector_symbols("s_i"), vector_symbols("s_j")
        term = coordination_term(s_i, ki, kj * s_j)
        fsmctl_ok = _expand_zero(term - (ki * s_i - kj * s_j)) and _expand_zero(
            coordination_term(s_i, 0, 0 * s_j) - sp.zeros(3, 1)
        )
        return bool(examples and no_k_dot and psd and fsmctl_ok)

    return Erratum(
        id="eq19-gains-nonnegative",
        equation="19; Remark 2; Section 4",
        as_printed="where k^i_ij and k^j_ij are positive constants",
        correct="k^i_ij >= 0 and k^j_ij(t) >= 0, k^j_ij possibly switching with t (k^j_ij = 0: no link j -> i)",
        residual=(
            f"the paper's own weights violate it: Table 2's k^2_12(t) takes the values {table2} (not positive, not "
            "constant), Case 2 sets k^i_ij = k^j_ij = 0, and Remark 2 reads k^j_ij = 0 as 'no information transmission'"
        ),
        consequence=(
            "as printed, eq 19 (and with it Theorem 1) would not cover the directed, switching topologies the paper "
            "claims and simulates; the proof only uses the weights at each instant (no k_dot enters V_dot), so k >= 0 "
            "and time variation are fine. See also thm1-eta-strict for the eta conditions"
        ),
        as_printed_latex=r"k^i_{ij},\ k^j_{ij} > 0\ \text{constant}",
        correct_latex=r"k^i_{ij} \ge 0,\ k^j_{ij}(t) \ge 0\ \text{(piecewise constant in } t)",
        checked=bool(printed_fails and _holds(holds)),
    )


# ----------------------------------------------------------------------------- Section 3.3: scalar forms


def printed_scalar_surface(x, x_dot, c1, c2, alpha) -> sp.Expr:
    """Section 3.3 as printed: ``s = x_dot + a x + b sig(x)^a``, with one glyph for the gain ``a`` and the exponent."""
    _ = (c1, c2)
    b = sp.Symbol("b", positive=True)
    return x_dot + alpha * x + b * sigpow(x, alpha)[0]


def corrected_scalar_surface(x, x_dot, c1, c2, alpha) -> sp.Expr:
    """``s = x_dot + c1 x + c2 sig(x)^alpha`` (eq 13 in scalar form; TSM: c1 = 0, LSM: c2 = 0)."""
    return x_dot + c1 * x + c2 * sigpow(x, alpha)[0]


def erratum_scalar_gains(corrected: Callable = corrected_scalar_surface) -> Erratum:
    """Section 3.3: the scalar sliding modes are printed with gains ``a, b`` but used with ``c1, c2``."""
    forms = settling_time_closed_forms()
    c1, c2, alpha, x0, T34 = forms.c1, forms.c2, forms.alpha, forms.x0, forms.T_fsm
    x = sp.Symbol("x", real=True)
    xd = sp.Symbol("x_dot", real=True)

    def sliding_dynamics(form, g1, g2, a=alpha) -> sp.Expr:
        sol = sp.solve(sp.Eq(form(x, xd, g1, g2, a), 0), xd)
        return sol[0] if len(sol) == 1 else sp.nan

    def agrees(form) -> bool:
        # 'we have that -x_dot = c1 x + c2 sig(x)^a, -x_dot = c2 sig(x)^a and -x_dot = c1 x' (FSM, TSM, LSM)
        modes = ((c1, c2), (0, c2), (c1, 0))
        same = all(
            sp.simplify(sliding_dynamics(form, g1, g2) - scalar_sliding_mode(x, g1, g2, alpha)) == 0 for g1, g2 in modes
        )
        # eq 34 is the integral of dt = -dx / x_dot from tau to |x0|: dT/dx0 = -1/x_dot(x0), x0 > 0
        rate = sliding_dynamics(form, c1, c2).subs(x, x0)
        return same and sp.simplify(sp.diff(T34, x0) + 1 / rate) == 0

    printed_fails = not agrees(printed_scalar_surface)
    p, a = sp.Symbol("p", positive=True), sp.Symbol("alpha", positive=True)  # the branch x = p > 0 (odd in x)
    gap = sliding_dynamics(printed_scalar_surface, c1, c2, a) - scalar_sliding_mode(x, c1, c2, a)
    residual = sp.collect(sp.expand(gap.subs(x, p)), [p, p**a])
    return Erratum(
        id="sec33-scalar-gains",
        equation="Section 3.3 (scalar FSM, TSM, LSM; eqs 34-36)",
        as_printed="s = x_dot + a x + b sig(x)^a (FSM), s = x_dot + b sig(x)^a (TSM), s = x_dot + a x (LSM)",
        correct="s = x_dot + c1 x + c2 sig(x)^alpha (FSM), c1 = 0 (TSM), c2 = 0 (LSM), as the next sentence and eqs 34-41 use",
        residual=(
            f"on s = 0 the printed FSM gives x_dot - (-c1 x - c2 sig(x)^alpha) = {residual} at x = p > 0 (the gain "
            "glyph 'a' read as the exponent, as the extraction shows it), not the "
            "'-x_dot = c1 x + c2 sig(x)^a' that the paper integrates into eq 34"
        ),
        consequence=(
            "the scalar forms never define a = c1, b = c2, and if 'a' is the exponent the linear gain would be tied "
            "to alpha; Theorem 3 is about c1, c2, alpha independent, as fsmctl's scalar_sliding_mode implements"
        ),
        as_printed_latex=r"s = \dot x + a x + b\,\mathrm{sig}(x)^a",
        correct_latex=r"s = \dot x + c_1 x + c_2\,\mathrm{sig}(x)^\alpha",
        checked=bool(printed_fails and _holds(lambda: agrees(corrected))),
    )


# ----------------------------------------------------------------------------- Section 3.3: the neighbourhood


def printed_radius(tau, mu):
    """Section 3.3 as printed: the target set is ``Z = {x : |x| <= mu}``, ``mu > 0``."""
    _ = tau
    return mu


def corrected_radius(tau, mu):
    """The radius eqs 34-41 and Theorem 3 use: ``Z = {x : |x| <= tau}``."""
    _ = mu
    return tau


def erratum_radius_symbol(corrected: Callable = corrected_radius) -> Erratum:
    """Section 3.3: the target set is defined with radius ``mu``, but every settling time uses ``tau``."""
    forms = settling_time_closed_forms()
    tau, x0 = forms.tau, forms.x0
    mu = sp.Symbol("mu", positive=True)

    def reaches_boundary(form) -> bool:
        # each settling time (eqs 34-36) is the time to reach the boundary of Z: zero when x(0) is on it
        r = form(tau, mu)
        return all(sp.simplify(T.subs(x0, r)) == 0 for T in (forms.T_fsm, forms.T_tsm, forms.T_lsm))

    left = sp.simplify(forms.T_fsm.subs(x0, mu))
    printed_fails = not reaches_boundary(printed_radius) and left != 0
    return Erratum(
        id="sec33-radius-symbol",
        equation="Section 3.3 (Z; eqs 34-41, Theorem 3, Remark 8)",
        as_printed="Z = {x : |x| <= mu}, where mu > 0; eqs 34-41 and Theorem 3 then use tau",
        correct="Z = {x : |x| <= tau}, tau > 0 (mu is already the reaching rate of eqs 28, 33)",
        residual=f"eq 34 at |x(0)| = mu (on the boundary of the printed Z) is {left}, not 0",
        consequence=(
            "the settling times are the times to reach |x| = tau; with the printed Z, 'outside Z' (Theorem 3) and "
            "'|x(0)| > tau' are different conditions. fsmctl's theorem3 closed forms and measurements use tau"
        ),
        as_printed_latex=r"Z = \{x : |x| \le \mu\},\ \mu > 0",
        correct_latex=r"Z = \{x : |x| \le \tau\},\ \tau > 0",
        checked=bool(printed_fails and _holds(lambda: reaches_boundary(corrected))),
    )


# ----------------------------------------------------------------------------- registry


@dataclass(frozen=True)
class AuditCheck:
    """A new erratum's check and the printed form(s) that must make it fail when passed as the correction."""

    id: str
    check: Callable[..., Erratum]
    printed_forms: tuple


AUDIT_CHECKS: tuple[AuditCheck, ...] = (
    AuditCheck("eq6-skew-sign", erratum_skew_sign, (printed_skew,)),
    AuditCheck("eq9-E-cross", erratum_E_cross, (printed_E,)),
    AuditCheck("eq17-sigma-index", erratum_sigma_index, (printed_feedback,)),
    AuditCheck("eq18-delta-diag", erratum_delta_diag, (printed_switching_torque, elementwise_switching_torque)),
    AuditCheck("eq19-gains-nonnegative", erratum_gains_nonnegative, (PRINTED_GAINS,)),
    AuditCheck("sec33-scalar-gains", erratum_scalar_gains, (printed_scalar_surface,)),
    AuditCheck("sec33-radius-symbol", erratum_radius_symbol, (printed_radius,)),
)


def audit_errata() -> list[Erratum]:
    """The errata this audit found that :mod:`fsmctl.proofs.errata` does not have, each one checked."""
    return [c.check() for c in AUDIT_CHECKS]


# ----------------------------------------------------------------------------- the audit table

AUDIT: tuple[AuditRow, ...] = (
    AuditRow(
        equation="eq 1",
        section="2.1",
        printed="sigðvÞa ¼ ½sgnðvÞ19ðvÞ19a,. . .,sgnðvÞm9ðvÞm9 a�T : ð1Þ",
        printed_meaning="sig(v)^a = [sgn(v)_1 |(v)_1|^a, ..., sgn(v)_m |(v)_m|^a]^T",
        transcription="sig(v)^a = [sgn(v_1)|v_1|^a, …]ᵀ elementwise (1)",
        verdict=SAME,
        erratum=None,
        note=(
            "glyphs only: 9 = |, ½ = [, the closing bracket is an unmapped glyph (�). The extraction renders Latin a "
            "and α alike, so the exponent may be a or α; either way it is fsmctl's sigpow. The definition of the "
            "components just before, '(v_k) represents the kth component', writes (v_k) for (v)_k: harmless"
        ),
    ),
    AuditRow(
        equation="Sec. 2.1 (norm)",
        section="2.1",
        printed="We use JnJ to represent the Euclidean norm of the vectorv",
        printed_meaning="‖•‖ represents the Euclidean norm of the vector v",
        transcription="‖v‖ Euclidean norm",
        verdict=ARTEFACT,
        erratum=None,
        note=(
            "J is the glyph of ‖ and n that of a bullet/asterisk (the corresponding-author star is extracted as "
            "'Liang n'): the print reads ‖•‖, the extraction makes it look like the norm of an undefined n"
        ),
    ),
    AuditRow(
        equation="eq 2",
        section="2.2",
        printed="r¼ nUtanðy=4Þ, ð2Þ where n is the Euler axis, y is the Euler angle.",
        printed_meaning="σ = n·tan(θ/4), n Euler axis, θ Euler angle; singular at θ = ±2π (printed '72p')",
        transcription="MRP σ = n·tan(θ/4) (2); singular at θ = ±2π",
        verdict=SAME,
        erratum=None,
        note="glyphs only: r = σ (bold), U = ·, y = θ, 7 = ±, p = π; fsmctl: mrp_principal_angle = 4 atan(‖σ‖)",
    ),
    AuditRow(
        equation="eq 3",
        section="2.2",
        printed="_s ¼ GðrÞx, ð3Þ",
        printed_meaning="σ̇ = G(σ) ω (the left σ in a different glyph, 's', from the bold σ 'r')",
        transcription="σ̇ = G(σ)ω (3)",
        verdict=ARTEFACT,
        erratum=None,
        note=(
            "the left-hand side is extracted as '_s' (a dotted s) while σ is 'r' everywhere else, and s is later the "
            "sliding variable. 's' is the plain Symbol-font σ and 'r' the bold one in this extraction, so the print "
            "most likely shows a non-bold σ̇: a typographic inconsistency, not a different formula (only the PDF can "
            "confirm). fsmctl: mrp_kinematics"
        ),
    ),
    AuditRow(
        equation="eq 4",
        section="2.2",
        printed="J _x ¼�x�Jxþu ð4Þ",
        printed_meaning="J ω̇ = −ω^× J ω + u",
        transcription="J ω̇ = −ω^× J ω + u (4)",
        verdict=SAME,
        erratum=None,
        note="glyphs only: x = ω, '_' = dot accent, the first � a minus and the second the superscript ×",
    ),
    AuditRow(
        equation="eq 5",
        section="2.2",
        printed="GðrÞ ¼1 4ð1�rTrÞIþ 1 2r�þ 1 2rrT , ð5Þ",
        printed_meaning="G(σ) = ¼(1 − σᵀσ)I + ½σ^× + ½σσᵀ",
        transcription="G(σ) = ¼[(1 − σᵀσ)I + 2σ^× + 2σσᵀ] (5)",
        verdict=ARTEFACT,
        erratum=None,
        note="the fraction bars of 1/4 and 1/2 are lost ('1 4', '1 2'); the formula is fsmctl's mrp_G",
    ),
    AuditRow(
        equation="eq 6",
        section="2.2",
        printed="n� ¼ 0 �ðnÞ3 ðnÞ2 ðnÞ3 0 �ðnÞ1 �ðnÞ2 �ðnÞ1 0 264 375 ð6Þ",
        printed_meaning="•^× = [[0, −(•)_3, (•)_2], [(•)_3, 0, −(•)_1], [−(•)_2, −(•)_1, 0]]",
        transcription="v^× is the skew matrix of v (6)",
        verdict=SILENT,
        erratum="eq6-skew-sign",
        note=(
            "the (3,2) entry carries a sign glyph: −(•)_1, where the skew matrix has +(•)_1. The extraction writes "
            "'+' as þ and gives unsigned entries no glyph (e.g. '(•)_3' at (2,1)); � stands for any unmapped glyph "
            "(minus, ×, ≡, ⊂, a big bracket), but none belongs at (3,2), so the print has a wrong sign there, not the "
            "extraction. '264 375' are the bracket pieces. paper.md and fsmctl's skew use the correct matrix without "
            "remark"
        ),
    ),
    AuditRow(
        equation="eq 7",
        section="2.2",
        printed="_re ¼Gexe, ð7Þ",
        printed_meaning="σ̇_e = G_e ω_e, G_e = G(σ_e)",
        transcription="σ̇_e = G_e ω_e with G_e = G(σ_e) (7); 'this drops the rotation of ω_d into the body frame'",
        verdict=EXISTING,
        erratum="eq7-8-error-rate",
        note="the formula is extracted faithfully; with eq 8 it is not the rate of the relative attitude (existing erratum); paper.md says so",
    ),
    AuditRow(
        equation="eq 8",
        section="2.2",
        printed="xe ¼x�xd, ð8Þ",
        printed_meaning="ω_e = ω − ω_d",
        transcription="ω_e = ω − ω_d (8) (exact: ω_e = ω − R(σ_e) ω_d)",
        verdict=EXISTING,
        erratum="eq7-8-error-rate",
        note="extracted faithfully; ω_d must be rotated into the body frame (existing erratum); fsmctl has both models",
    ),
    AuditRow(
        equation="eq 9",
        section="2.3",
        printed="M €reþC _reþG�Te E¼G�T e u, ð9Þ",
        printed_meaning="M σ̈_e + C σ̇_e + G_e^{−T} E = G_e^{−T} u",
        transcription="M σ̈_e + C σ̇_e + G_e^{−T} E = G_e^{−T} u (9)",
        verdict=SAME,
        erratum=None,
        note="glyphs only: € = double dot, �T = superscript −T; fsmctl: lagrange_model (proved equal to Euler's equation)",
    ),
    AuditRow(
        equation="eq 9 (M)",
        section="2.3",
        printed="M ¼G�Te JG�1 e",
        printed_meaning="M = G_e^{−T} J G_e^{−1}",
        transcription="M = G_e^{−T} J G_e^{−1}",
        verdict=SAME,
        erratum=None,
        note="glyphs only",
    ),
    AuditRow(
        equation="eq 9 (C)",
        section="2.3",
        printed="C ¼�M _GeG�1e �G�T e ðJG�1e _reÞ �G�1e þ G�Te xd �JG�1e",
        printed_meaning="C = −M Ġ_e G_e^{−1} − G_e^{−T}(J G_e^{−1} σ̇_e)^× G_e^{−1} + G_e^{−T} ω_d^× J G_e^{−1}",
        transcription="as printed, C = −M Ġ_e G_e^{−1} − G_e^{−T}(J G_e^{−1} σ̇_e)^× G_e^{−1} + G_e^{−T} ω_d^× J G_e^{−1}",
        verdict=EXISTING,
        erratum="eq9-C",
        note="extracted faithfully (both × survive as �); the term −G^{−T}(Jω_d)^×G^{−1} is missing (existing erratum); paper.md flags it 'as printed'",
    ),
    AuditRow(
        equation="eq 9 (E)",
        section="2.3",
        printed="E¼ J _xdþxd Jxd.",
        printed_meaning="E = J ω̇_d + ω_d J ω_d (no cross product)",
        transcription="E = J ω̇_d + ω_d^× J ω_d",
        verdict=SILENT,
        erratum="eq9-E-cross",
        note=(
            "in Sections 2-3 all ten other superscript × (eqs 4, 5, 6 twice, C twice, C0 twice, Δd twice) are "
            "extracted as �, but the three occurrences of ω_d J ω_d (E, E0, and the Δd term) have none: the × is "
            "most likely missing in the print itself. paper.md's preamble blames dropped × on the extraction, yet "
            "this is the only place in Sections 2-3 where one is missing. If the PDF shows a ×, this row is an "
            "extraction artefact; the check shows the cross is the only well-formed reading either way"
        ),
    ),
    AuditRow(
        equation="Lemma 1 (hypothesis)",
        section="2.4",
        printed="If there are real numbers k 2 Rþ and e 2 ð0,1Þ such that _OþkOe is a negative semi-definite function on U , then O� 0 is achieved in finite time",
        printed_meaning="if λ ∈ R+ and ε ∈ (0,1) with Ω̇ + λΩ^ε negative semi-definite on U, then Ω ≡ 0 in finite time",
        transcription="if Ω̇ + λΩ^ε ≤ 0 with λ > 0, ε ∈ (0,1), then Ω reaches 0 in finite time",
        verdict=SAME,
        erratum=None,
        note="glyphs only: k = λ, e = ε, O = Ω, 2 = ∈, � = ≡; proved by claim lemma1-settling-time",
    ),
    AuditRow(
        equation="eq 10",
        section="2.4",
        printed="TrOð0Þ1�e ðk�keÞ, ð10Þ",
        printed_meaning="T ≤ Ω(0)^{1−ε} / (λ − λε)",
        transcription="T ≤ Ω(0)^{1−ε} / (λ(1−ε)) (10; 'the printed form is garbled')",
        verdict=ARTEFACT,
        erratum=None,
        note=(
            "the fraction bar is lost (r = ≤ here). With it restored the print reads Ω(0)^{1−ε}/(λ − λε) = "
            "Ω(0)^{1−ε}/(λ(1−ε)) (claim lemma1-settling-time checks the denominator): right"
        ),
    ),
    AuditRow(
        equation="eq 11",
        section="2.4",
        printed="For positive constants Vi , if Vi satisfies that ViZ0, i¼ 1,2,:::,n, ð11Þ",
        printed_meaning="for positive constants V_i, if V_i ≥ 0, i = 1..n",
        transcription="for V_i ≥ 0 (11–12)",
        verdict=SAME,
        erratum=None,
        note=(
            "Z = ≥. The wording 'positive constants' is narrower than (11) and than its use (V_i(t) at each "
            "instant, possibly 0), but the lemma holds for V_i ≥ 0 (claim lemma2-sqrt-sum): not an error"
        ),
    ),
    AuditRow(
        equation="eq 12",
        section="2.4",
        printed="Xn i ¼ 1 Vi1=2 Z Xn i ¼ 1 Vi !1=2 : ð12Þ",
        printed_meaning="Σ_{i=1}^n V_i^{1/2} ≥ (Σ_{i=1}^n V_i)^{1/2}",
        transcription="Σ V_i^{1/2} ≥ (Σ V_i)^{1/2}",
        verdict=ARTEFACT,
        erratum=None,
        note="X = Σ; the big parentheses around the second sum are lost except the closing '!'; proved by claim lemma2-sqrt-sum",
    ),
    AuditRow(
        equation="eq 13",
        section="3.1",
        printed="si ¼ _reiþc1reiþc2sigðreiÞa, ð13Þ where rei is the absolute attitude error of the ith space-craft, c1and c2 are positive constants, a satisfies that0:5oao1.",
        printed_meaning="s_i = σ̇_ei + c1 σ_ei + c2 sig(σ_ei)^α, c1, c2 > 0, 0.5 < α < 1",
        transcription="s_i = σ̇_ei + c1 σ_ei + c2 sig(σ_ei)^α, c1, c2 > 0, 0.5 < α < 1 (13)",
        verdict=SAME,
        erratum=None,
        note="glyphs only: o = <; fsmctl: sliding_variable (and check_alpha enforces 0.5 < α < 1)",
    ),
    AuditRow(
        equation="eq 14",
        section="3.1",
        printed="_rei ¼�c1rei�c2sigðreiÞa: ð14Þ",
        printed_meaning="σ̇_ei = −c1 σ_ei − c2 sig(σ_ei)^α",
        transcription="σ̇_ei = −c1 σ_ei − c2 sig(σ_ei)^α (14)",
        verdict=SAME,
        erratum=None,
        note="glyphs only; fsmctl: scalar_sliding_mode per component",
    ),
    AuditRow(
        equation="eq 15",
        section="3.1",
        printed="Considering the positive scalar function_V i ¼ 12 rT eirei andcomputing the derivative of _V i yields __V i ¼ rT ei_rei ¼�c1reiTrei�c2 X3 k ¼ 1 9ðreiÞk91þa r�c2JreiJ1þa r�_c_V i ðaþ1Þ=2, ð15Þ where _c ¼ 2ðaþ1Þ=2c2.",
        printed_meaning=(
            "V̂_i = ½σ_eiᵀσ_ei; d/dt V̂_i = σ_eiᵀσ̇_ei = −c1 σ_eiᵀσ_ei − c2 Σ_k |(σ_ei)_k|^{1+α} ≤ −c2‖σ_ei‖^{1+α} "
            "≤ −ĉ V̂_i^{(α+1)/2}, ĉ = 2^{(α+1)/2} c2 (accents over V and c)"
        ),
        transcription="with V̇_i = ½σ_eiᵀσ_ei (15): d/dt V ≤ −c2‖σ_ei‖^{1+α} ≤ −2^{(α+1)/2} c2 V^{(α+1)/2}",
        verdict=ARTEFACT,
        erratum=None,
        note=(
            "'_' is the extraction's mark for any accent: the function is '_V i' (one accent) and its derivative "
            "'__V i' (a dot over that accent), and the constant '_c' = 2^{(α+1)/2}c2 is not a derivative either, so "
            "the accent on V is a hat or bar, not a dot; '12' is ½ without its bar. paper.md transcribes it as "
            "'V̇_i = ½σᵀσ', a slip of the transcription, not of the paper. The chain is right (claim reaching-law)"
        ),
    ),
    AuditRow(
        equation="eq 16",
        section="3.1",
        printed="ui ¼�uFi �uD i �uCi , i¼ 1,2,. . .,n, ð16Þ",
        printed_meaning="u_i = −u^F_i − u^D_i − u^C_i",
        transcription="u_i = −u_i^F − u_i^D − u_i^C (16)",
        verdict=SAME,
        erratum=None,
        note="glyphs only; fsmctl: ControlLawPieces.u",
    ),
    AuditRow(
        equation="eq 17 (C_i term)",
        section="3.1",
        printed="uFi ¼�ðG TeiCi _reþEiÞ",
        printed_meaning="u^F_i = −(G_eiᵀ C_i σ̇_e + E_i) + ...",
        transcription="u^F_i = −(G_eiᵀ C_i σ̇_ei + E_i) + ... (17)",
        verdict=SILENT,
        erratum="eq17-sigma-index",
        note=(
            "the rate in the C_i term is printed without the agent index ('_re'), while both other rates of eq 17 "
            "keep it ('_rei'), as do C_i, E_i, M_i: the extraction does not drop subscripts here, the print does. "
            "paper.md writes σ̇_ei without remark, and fsmctl uses σ̇_ei"
        ),
    ),
    AuditRow(
        equation="eq 17 (rate term)",
        section="3.1",
        printed="GT eiMiðc1 _reiþc2ara�1ei _reiÞ, ð17Þ",
        printed_meaning="+ G_eiᵀ M_i (c1 σ̇_ei + c2 α σ_ei^{α−1} σ̇_ei)",
        transcription="+ G_eiᵀ M_i (c1 σ̇_ei + c2 α |σ_ei|^{α−1} ∘ σ̇_ei), 'the last term elementwise (it is d/dt of sig(σ_ei)^α)'",
        verdict=EXISTING,
        erratum="eq17-fractional-power",
        note="extracted faithfully ('ara�1ei' = α σ_ei^{α−1}); a vector to a real power (existing erratum); paper.md states the elementwise form",
    ),
    AuditRow(
        equation="eq 18",
        section="3.1",
        printed="uDi ¼ qisgn ðsiÞ, ð18Þ H. Liang et al. / Acta Astronautica 81 (2012) 445–455448 where qi ¼GTeiMidi with ðdiÞk40,k¼ 1,2,3,",
        printed_meaning="u^D_i = q_i sgn(s_i), q_i = G_eiᵀ M_i δ_i with (δ_i)_k > 0, k = 1, 2, 3",
        transcription="u^D_i = q_i sgn(s_i), q_i = G_eiᵀ M_i diag(δ_i), (δ_i)_k > 0 (18)",
        verdict=SILENT,
        erratum="eq18-delta-diag",
        note=(
            "δ_i is a 3-vector ('(δ_i)_k > 0, k = 1, 2, 3'), so the printed q_i is a vector and q_i sgn(s_i) a "
            "product of two vectors: a dimension error of the print (the running header in the excerpt is the page "
            "break). paper.md writes diag(δ_i) without remark; fsmctl uses G^T M (δ_i ∘ sgn(s_i))"
        ),
    ),
    AuditRow(
        equation="eq 19",
        section="3.1",
        printed="uCi ¼ GT eiMi Xn j ¼ 1 ðkiijsi�kj ijsjÞ, ð19Þ",
        printed_meaning="u^C_i = G_eiᵀ M_i Σ_{j=1}^n (k^i_ij s_i − k^j_ij s_j)",
        transcription="u^C_i = G_eiᵀ M_i Σ_j (k^i_ij s_i − k^j_ij s_j) (19)",
        verdict=SAME,
        erratum=None,
        note="glyphs only ('kiij' = k^i_ij); the j = i term is (k^i_ii − k^i_ii)s_i = 0. fsmctl: coordination_term",
    ),
    AuditRow(
        equation="eq 19 (weights)",
        section="3.1",
        printed="where kiij and kj ij are positive constants.",
        printed_meaning="k^i_ij and k^j_ij are positive constants",
        transcription="k^i_ij, k^j_ij ≥ 0 (19); Section 4: k^j_ij(t) switching between 5 and 0",
        verdict=SILENT,
        erratum="eq19-gains-nonnegative",
        note=(
            "the paper contradicts it itself: Remark 2 ('when k^j_ij = 0, it means no information transmission'; "
            "the topology may be 'time-varying'), Table 2 (k^j_ij(t) ∈ {0, 5}) and Case 2 (k^i = k^j = 0). "
            "paper.md states ≥ 0 and time-varying weights without remark, as fsmctl implements them"
        ),
    ),
    AuditRow(
        equation="Theorem 1 (conditions)",
        section="3.1",
        printed="if the following inequalities hold kiij4Zij and 4Zijðk iij�ZijÞZðk jijÞ 2 where Zij40 is a constant",
        printed_meaning="k^i_ij > η_ij and 4η_ij(k^i_ij − η_ij) ≥ (k^j_ij)², η_ij > 0 a constant",
        transcription="k^i_ij > η_ij and 4η_ij(k^i_ij − η_ij) ≥ (k^j_ij)², η_ij = η_ji > 0",
        verdict=EXISTING,
        erratum="thm1-eta-strict",
        note="glyphs only (4 = >, Z = η or ≥); the strict, constant, symmetric η excludes pairs without a link (existing erratum). Theorem 2 repeats the conditions",
    ),
    AuditRow(
        equation="eq 20 (rate term)",
        section="3.1",
        printed="€rei ¼�ðc1 _reiþc2ara�1ei _reiÞ",
        printed_meaning="σ̈_ei = −(c1 σ̇_ei + c2 α σ_ei^{α−1} σ̇_ei) ...",
        transcription="σ̈_ei = −(c1 σ̇_ei + c2 α|σ_ei|^{α−1}∘σ̇_ei) ... (20)",
        verdict=EXISTING,
        erratum="eq17-fractional-power",
        note="same term as eq 17 (existing erratum); the substitution of eqs 16-19 into eq 9 is otherwise right (identity closed-loop)",
    ),
    AuditRow(
        equation="eq 20 (switching term)",
        section="3.1",
        printed="�disgnðsiÞ�Xn j ¼ 1 ðkiijsi�kj ijsjÞ: ð20Þ",
        printed_meaning="... − δ_i sgn(s_i) − Σ_j (k^i_ij s_i − k^j_ij s_j)",
        transcription="... − δ_i∘sgn(s_i) − Σ_j (k^i_ij s_i − k^j_ij s_j) (20)",
        verdict=SILENT,
        erratum="eq18-delta-diag",
        note="δ_i sgn(s_i) multiplies two 3-vectors (printed, not extracted: eq 30 repeats it); paper.md writes ∘ without remark",
    ),
    AuditRow(
        equation="eq 21",
        section="3.1",
        printed="V ¼Xn i ¼ 1 Vi ð21Þ",
        printed_meaning="V = Σ_{i=1}^n V_i",
        transcription="V = Σ ½ s_iᵀs_i (21–22)",
        verdict=SAME,
        erratum=None,
        note="glyphs only",
    ),
    AuditRow(
        equation="eq 22",
        section="3.1",
        printed="Vi ¼1 2sT i si: ð22Þ",
        printed_meaning="V_i = ½ s_iᵀ s_i",
        transcription="V = Σ ½ s_iᵀs_i (21–22)",
        verdict=ARTEFACT,
        erratum=None,
        note="the fraction bar of ½ is lost ('1 2')",
    ),
    AuditRow(
        equation="eq 23",
        section="3.1",
        printed="_V i ¼ sTi_s i ¼ sTi ð €reiþc1 _reiþc2ara�1 ei_reiÞ: ð23Þ",
        printed_meaning="V̇_i = s_iᵀṡ_i = s_iᵀ(σ̈_ei + c1 σ̇_ei + c2 α σ_ei^{α−1} σ̇_ei)",
        transcription="(not restated; the proof of Theorem 1 is summarised)",
        verdict=EXISTING,
        erratum="eq17-fractional-power",
        note="ṡ_i needs d/dt sig(σ_ei)^α = α|σ_ei|^{α−1}∘σ̇_ei (existing erratum lists eq 23)",
    ),
    AuditRow(
        equation="eq 24",
        section="3.1",
        printed="r�X3 k ¼ 1 ðdiÞkð9si9Þk�siTXn j ¼ 1 ðkiijsi�kj ijsjÞ r�JdiJ JsiJ�siTXn j ¼ 1 ðkiijsi�kj ijsjÞ: ð24Þ",
        printed_meaning="≤ −Σ_k (δ_i)_k (|s_i|)_k − s_iᵀΣ_j(...) ≤ −‖δ_i‖ ‖s_i‖ − s_iᵀΣ_j(...)",
        transcription="(not restated; μ of eq 28 'as printed')",
        verdict=EXISTING,
        erratum="eq24-norm-bound",
        note=(
            "the last step is false (Cauchy-Schwarz the wrong way; existing erratum). The first '≤' is in fact an "
            "equality (harmless), and the line before it has δ_i sgn(s_i) (eq18-delta-diag)"
        ),
    ),
    AuditRow(
        equation="eq 25",
        section="3.1",
        printed="_V ¼Xn i ¼ 1 _V i r�Xn i ¼ 1 JdiJ JsiJ�Xn i ¼ 1 Xn j ¼ 1 siT ðki ijsi�kjijsjÞ: ð25Þ",
        printed_meaning="V̇ = Σ V̇_i ≤ −Σ‖δ_i‖‖s_i‖ − Σ_iΣ_j s_iᵀ(k^i_ij s_i − k^j_ij s_j)",
        transcription="(not restated)",
        verdict=EXISTING,
        erratum="eq24-norm-bound",
        note="sums eq 24 and carries its false bound (existing erratum lists eq 25)",
    ),
    AuditRow(
        equation="eq 26",
        section="3.1",
        printed="Xn i ¼ 1 Xn j ¼ 1 ðsiT si�sj T sjÞ ¼ 0: ð26Þ",
        printed_meaning="Σ_iΣ_j (s_iᵀs_i − s_jᵀs_j) = 0",
        transcription="adds the zero term Σ_iΣ_j η_ij(s_iᵀs_i − s_jᵀs_j) (26)",
        verdict=SAME,
        erratum=None,
        note="glyphs only; true (claim zero-sum)",
    ),
    AuditRow(
        equation="eq 26 (η-weighted)",
        section="3.1",
        printed="Then, we have thatPn i ¼ 1 Pnj ¼ 1 Zijðsi T si�sjT sjÞ ¼ 0 with Zij ¼ Zji40.",
        printed_meaning="Σ_iΣ_j η_ij(s_iᵀs_i − s_jᵀs_j) = 0 with η_ij = η_ji > 0",
        transcription="Σ_iΣ_j η_ij(s_iᵀs_i − s_jᵀs_j) (26), η_ij = η_ji > 0",
        verdict=SAME,
        erratum=None,
        note="true for symmetric η; balanced η suffices (claim zero-sum): more than needed, not an error",
    ),
    AuditRow(
        equation="eq 27",
        section="3.1",
        printed="¼�Xn i ¼ 1 :di: :si:�Xn i ¼ 1 Xn j ¼ 1 ðkijTkijþgijsj T sjÞ ð27Þ",
        printed_meaning="= −Σ_i ‖δ_i‖ ‖s_i‖ − Σ_iΣ_j (κ_ijᵀκ_ij + γ_ij s_jᵀs_j)",
        transcription="completes the square (27)",
        verdict=EXISTING,
        erratum="eq24-norm-bound",
        note="':' is ‖ in another font; the completion is right, the −‖δ_i‖‖s_i‖ carried from eq 24 is not (existing erratum lists 27)",
    ),
    AuditRow(
        equation="eq 27 (κ, γ)",
        section="3.1",
        printed="where kij¼ ffiffiffiffiffiffiffiffiffiffiffiffiffiki ij�Zij qsi� kj ij=2ffiffiffiffiffiffiffiffiffiffiffiffiffiffiki ij�Zij q� �sj and gij¼Zij� ððkjijÞ 2= 4ðkiij�ZijÞÞZ0:",
        printed_meaning="κ_ij = √(k^i_ij − η_ij) s_i − (k^j_ij / (2√(k^i_ij − η_ij))) s_j, γ_ij = η_ij − (k^j_ij)²/(4(k^i_ij − η_ij)) ≥ 0",
        transcription="κ_ij = √(k^i_ij − η_ij) s_i − k^j_ij/(2√(k^i_ij − η_ij)) s_j, γ_ij = η_ij − (k^j_ij)²/(4(k^i_ij − η_ij)) ≥ 0",
        verdict=ARTEFACT,
        erratum=None,
        note="the radicals come out as 'ffiffi…q' and the big parentheses as '� �'; the identity holds (claim complete-square)",
    ),
    AuditRow(
        equation="eq 28",
        section="3.1",
        printed="_V r�mV1=2ð28Þ with m¼minðffiffiffi2p JdiJÞ40,i¼ 1,2,. . .,n.",
        printed_meaning="V̇ ≤ −μ V^{1/2}, μ = min(√2 ‖δ_i‖) > 0",
        transcription="V̇ ≤ −μV^{1/2} (28), μ = min √2‖δ_i‖",
        verdict=EXISTING,
        erratum="eq28-mu",
        note="m = μ; the value of μ follows from the false step of eq 24 (existing erratum); paper.md copies it",
    ),
    AuditRow(
        equation="Theorem 1 (sliding phase)",
        section="3.1",
        printed="choosing the Lyapunov function_V i ¼ ð1=2ÞrT eirei.",
        printed_meaning="V̂_i = (1/2) σ_eiᵀσ_ei (the accented V of eq 15)",
        transcription="(not restated)",
        verdict=ARTEFACT,
        erratum=None,
        note="the same accent as in eq 15: a hat or bar, not a time derivative",
    ),
    AuditRow(
        equation="eq 29",
        section="3.2",
        printed="M0 €reþC0 _reþG�Te E0 ¼G�T e uþG�Te Dd, ð29Þ",
        printed_meaning="M0 σ̈_e + C0 σ̇_e + G_e^{−T} E0 = G_e^{−T} u + G_e^{−T} Δd",
        transcription="with uncertainty J = J0 + ΔJ and disturbance u_d (29)",
        verdict=SAME,
        erratum=None,
        note="glyphs only (D = Δ); fsmctl: lagrange_uncertainty gives the exact Δd",
    ),
    AuditRow(
        equation="eq 29 (C0)",
        section="3.2",
        printed="C0 ¼�M0_GeG�1 e �G�Te ðJ0G�1 e _re�G�1 e þG�Te xd �J0G�1e",
        printed_meaning="C0 = −M0 Ġ_e G_e^{−1} − G_e^{−T}(J0 G_e^{−1} σ̇_e^× G_e^{−1} + G_e^{−T} ω_d^× J0 G_e^{−1}",
        transcription="(not restated: 'same, with J0 in the controller')",
        verdict=EXISTING,
        erratum="eq9-C",
        note=(
            "eq 9's C with J0, missing the same −G^{−T}(J0ω_d)^×G^{−1} term (existing erratum lists eq 29). The "
            "closing parenthesis before ^× is absent from the extraction (present in eq 9): print or extraction, the "
            "text cannot tell; the meaning is eq 9's"
        ),
    ),
    AuditRow(
        equation="eq 29 (E0)",
        section="3.2",
        printed="E0 ¼ J0 _xdþxdJ0xd",
        printed_meaning="E0 = J0 ω̇_d + ω_d J0 ω_d (no cross product)",
        transcription="(not restated; eq 9's E is given as J ω̇_d + ω_d^× J ω_d)",
        verdict=SILENT,
        erratum="eq9-E-cross",
        note="the same missing × as in eq 9's E (see there for why it is most likely printed so)",
    ),
    AuditRow(
        equation="eq 29 (Δd)",
        section="3.2",
        printed="Ddðre, _re, _xd,xd,DJ,udÞ ¼�G�Te DJG�1 e þG�Te DJG�1 e_Ge G�1e þG�T e ðDJG�1e _reÞ �G�1e �G�T e xd�DJG�1 e �DJ _xd�xdDJxdþ ud:",
        printed_meaning=(
            "Δd(σ_e, σ̇_e, ω̇_d, ω_d, ΔJ, u_d) = −G^{−T}ΔJG^{−1} + G^{−T}ΔJG^{−1}Ġ_eG^{−1} + G^{−T}(ΔJG^{−1}σ̇_e)^×G^{−1} "
            "− G^{−T}ω_d^×ΔJG^{−1} − ΔJω̇_d − ω_dΔJω_d + u_d"
        ),
        transcription="Δd_i collecting the ΔJ terms and u_d",
        verdict=EXISTING,
        erratum="eq29-Delta-d",
        note=(
            "matrices added to vectors, σ̈_e and σ̇_e missing (existing erratum); its ω_d ΔJ ω_d term also lacks the × "
            "(eq9-E-cross), which the existing erratum's 'as printed' text and lagrange_uncertainty_as_printed insert"
        ),
    ),
    AuditRow(
        equation="Sec. 3.2 (bounds)",
        section="3.2",
        printed="DJ irDJi and 9ðudiÞk9r ðtÞk,k¼ 1,2,3 with ðtÞk40.",
        printed_meaning="ΔJ_i ≤ ΔJ̄_i and |(u_di)_k| ≤ (τ)_k, (τ)_k > 0",
        transcription="(not restated)",
        verdict=ARTEFACT,
        erratum=None,
        note="the bar over the bound ΔJ̄_i is lost, so the extraction reads 'ΔJ_i ≤ ΔJ_i'; r = ≤, t = τ (here a torque bound, unrelated to Section 3.3's τ)",
    ),
    AuditRow(
        equation="Theorem 2 (condition)",
        section="3.2",
        printed="ðdiÞk4ðDdiÞk ¼ ð9M0i �1G�Tei Ddi9Þk,k¼ 1,2,3",
        printed_meaning="(δ_i)_k > (Δδ_i)_k = (|M0i^{−1} G_ei^{−T} Δd_i|)_k",
        transcription="(δ_i)_k > |M0i^{−1} G_ei^{−T} Δd_i|_k (30–33)",
        verdict=EXISTING,
        erratum="eq29-Delta-d",
        note="extracted faithfully; Δd depends on σ̈_e, hence on δ_i itself: the condition is circular (existing erratum)",
    ),
    AuditRow(
        equation="eq 30",
        section="3.2",
        printed="€rei ¼�ðc1 _reiþc2ara�1ei _reiÞ�di sgnðsiÞ�Xn j ¼ 1 ðkiijsi�kj ijsjÞ þM0i�1G�T ei Ddi: ð30Þ",
        printed_meaning="σ̈_ei = −(c1σ̇_ei + c2ασ_ei^{α−1}σ̇_ei) − δ_i sgn(s_i) − Σ_j(...) + M0i^{−1}G_ei^{−T}Δd_i",
        transcription="(not restated)",
        verdict=EXISTING,
        erratum="eq29-Delta-d",
        note=(
            "the substitution is right, but Δd_i contains σ̈_ei, so eq 30 is implicit (existing erratum); it repeats "
            "eq 20's α σ^{α−1} (eq17-fractional-power) and δ_i sgn(s_i) (eq18-delta-diag)"
        ),
    ),
    AuditRow(
        equation="eq 31",
        section="3.2",
        printed="_V i ¼ sTi_s i ¼ sTi ð €reiþc1 _reiþc2ara�1 ei _reiÞ: ð31Þ",
        printed_meaning="V̇_i = s_iᵀṡ_i = s_iᵀ(σ̈_ei + c1σ̇_ei + c2ασ_ei^{α−1}σ̇_ei)",
        transcription="(not restated)",
        verdict=EXISTING,
        erratum="eq17-fractional-power",
        note="eq 23 again",
    ),
    AuditRow(
        equation="eq 32",
        section="3.2",
        printed="r�X3 k ¼ 1 ðdi�DdiÞkð si �� ��Þk�siTXn j ¼ 1 ðkiijsi�kj ijsjÞ r�Jdi�DdiJ JsiJ�siTXn j ¼ 1 ðkiijsi�kj ijsjÞ: ð32Þ",
        printed_meaning="≤ −Σ_k (δ_i − Δδ_i)_k (|s_i|)_k − s_iᵀΣ_j(...) ≤ −‖δ_i − Δδ_i‖ ‖s_i‖ − s_iᵀΣ_j(...)",
        transcription="(not restated)",
        verdict=EXISTING,
        erratum="eq24-norm-bound",
        note=(
            "the first step is right (s_iᵀw ≤ Σ_k (Δδ_i)_k |s_ik|); the second is eq 24's false norm bound (the "
            "erratum lists 24, 25, 27; claim vdot-i notes that it recurs here). '�� ��' is a pair of big bars"
        ),
    ),
    AuditRow(
        equation="eq 33",
        section="3.2",
        printed="_V r�mV1=2, ð33Þ where m ¼minðffiffiffi2pÞJdi�DdiJ40, i¼ 1,2,. . .,n.",
        printed_meaning="V̇ ≤ −μ V^{1/2}, μ = min(√2) ‖δ_i − Δδ_i‖ > 0",
        transcription="(not restated)",
        verdict=EXISTING,
        erratum="eq28-mu",
        note="the printed parenthesis closes after √2 (min(√2)‖·‖; in eq 28 it encloses the norm): a typo, subsumed by the existing erratum, which replaces μ",
    ),
    AuditRow(
        equation="Remark 2",
        section="3.2",
        printed="for any kj ij, there always exists properconstants Zij and ki ij4Zij such that the inequality4Zijðk iij�ZijÞZðk jijÞ 2 holds.",
        printed_meaning="for any k^j_ij there exist constants η_ij and k^i_ij > η_ij with 4η_ij(k^i_ij − η_ij) ≥ (k^j_ij)²",
        transcription="Remarks: 2 (k^j_ij encodes the possibly directed, time-varying topology)",
        verdict=EXISTING,
        erratum="thm1-eta-strict",
        note="true pair by pair, but a constant symmetric η for switching k^j and unlinked pairs is what fails (existing erratum lists Remark 2)",
    ),
    AuditRow(
        equation="Remark 4",
        section="3.2",
        printed="then the control objective can easily be obtained if kiijZkj ij holds which is a more loose condition to be satisfied. The proof is similar with the proof of Theorem1 by choosing the parameter Zij ¼ ki ij=2.",
        printed_meaning="k^i_ij ≥ k^j_ij suffices (η_ij = k^i_ij/2), 'a more loose condition'",
        transcription="4 (undirected case: k^i_ij ≥ k^j_ij suffices with η = k^i/2)",
        verdict=EXISTING,
        erratum="remark4-looser",
        note="extracted faithfully; the condition is the same as Theorem 1's, not looser (existing erratum)",
    ),
    AuditRow(
        equation="Remark 6",
        section="3.2",
        printed="because c2ara�1 ei_rei ¼ �c1c2araei�c2 2ar2a�1ei ¼ 0 when rei ¼ 0",
        printed_meaning="c2 α σ_ei^{α−1} σ̇_ei = −c1c2 α σ_ei^α − c2² α σ_ei^{2α−1} = 0 when σ_ei = 0",
        transcription="6 (α|σ|^{α−1} is singular at σ_e = 0 before s = 0; needs a fix)",
        verdict=EXISTING,
        erratum="eq17-fractional-power",
        note="right once the powers are elementwise sig(·) (existing erratum; claim remark6-singular-term)",
    ),
    AuditRow(
        equation="Sec. 3.3 (scalar forms)",
        section="3.3",
        printed="The scalar form of the FSM is s¼ _xþaxþb sigðxÞa; thescalar form of TSM is s¼ _xþb sigðxÞa; and the scalar formof LSM is s¼ _xþax.",
        printed_meaning="FSM: s = ẋ + a x + b sig(x)^a; TSM: s = ẋ + b sig(x)^a; LSM: s = ẋ + a x",
        transcription="FSM ẋ = −c1x − c2 sig(x)^α, TSM ẋ = −c2 sig(x)^α, LSM ẋ = −c1x (the printed s-forms are not restated)",
        verdict=NEW,
        erratum="sec33-scalar-gains",
        note=(
            "the gains are a, b here and c1, c2 in the next sentence ('−ẋ = c1x + c2 sig(x)^a, ...') and eqs 34-41, "
            "with no a = c1, b = c2. The extraction renders α and Latin a alike, so whether the print also uses the "
            "exponent's letter for the linear gain cannot be told from the text; the undefined switch is in the "
            "print either way. paper.md does not mention the s-forms"
        ),
    ),
    AuditRow(
        equation="Sec. 3.3 (target set Z)",
        section="3.3",
        printed="described as Z ¼ fx : 9x9rmg, where m40.",
        printed_meaning="Z = {x : |x| ≤ μ}, where μ > 0",
        transcription="settling time to |x| ≤ τ on each scalar sliding mode",
        verdict=SILENT,
        erratum="sec33-radius-symbol",
        note=(
            "m (μ) and t (τ) are distinct glyphs throughout (m in eqs 28, 33; t in eqs 34-41 and Remark 8), so the "
            "print defines Z with μ, which already names the reaching rate, and then uses τ. paper.md uses τ without "
            "remark"
        ),
    ),
    AuditRow(
        equation="eq 34",
        section="3.3",
        printed="Tf sm ¼1 c1ð1�aÞln c19xð0Þ91�aþc2 c1t1�aþc2 !ð34Þ",
        printed_meaning="T_fsm = 1/(c1(1−α)) · ln((c1|x(0)|^{1−α} + c2)/(c1 τ^{1−α} + c2))",
        transcription="T_fsm = 1/(c1(1−α)) · ln((c1|x0|^{1−α} + c2)/(c1 τ^{1−α} + c2)) (34)",
        verdict=ARTEFACT,
        erratum=None,
        note="fraction bars and the opening big parenthesis are lost ('!' is the closing one); right (claim theorem3-closed-forms)",
    ),
    AuditRow(
        equation="eq 35",
        section="3.3",
        printed="Ttsm ¼1 c2ð1�aÞð9xð0Þ91�a �t1�aÞ ð35Þ",
        printed_meaning="T_tsm = (|x(0)|^{1−α} − τ^{1−α}) / (c2(1−α))",
        transcription="T_tsm = (|x0|^{1−α} − τ^{1−α}) / (c2(1−α)) (35)",
        verdict=ARTEFACT,
        erratum=None,
        note="fraction bar lost; right (claim theorem3-closed-forms)",
    ),
    AuditRow(
        equation="eq 36",
        section="3.3",
        printed="Tlsm ¼1 c1ln 9xð0Þ9t � �ð36Þ",
        printed_meaning="T_lsm = (1/c1) ln(|x(0)|/τ)",
        transcription="T_lsm = ln(|x0|/τ)/c1 (36)",
        verdict=ARTEFACT,
        erratum=None,
        note="fraction bars lost, '� �' are the big parentheses; right (claim theorem3-closed-forms)",
    ),
    AuditRow(
        equation="Theorem 3",
        section="3.3",
        printed="If the system state on the sliding surface is outside Z such that 9xð0Þ94t, then the convergence rate of FSM is better than that of either LSM or TSM, in other words, Tf smoTtsm and Tf smoTlsm.",
        printed_meaning="if |x(0)| > τ (outside Z), then T_fsm < T_tsm and T_fsm < T_lsm",
        transcription="for |x0| > τ > 0, T_fsm < T_tsm and T_fsm < T_lsm (37–41)",
        verdict=SAME,
        erratum=None,
        note="glyphs only (o = <, 4 = >); 'outside Z' is '|x(0)| > τ' only with sec33-radius-symbol's correction",
    ),
    AuditRow(
        equation="eq 37",
        section="3.3",
        printed="Since xð0Þ994t40 and ao1, we know that9xð0Þ91�a 4t1�a. Therefore, we have 1oc19x 0ð Þ91�a þc2 c1t1�aþc2o c19xð0Þ91�a c1t1�a ¼9xð0Þ9t � �1�a : ð37Þ",
        printed_meaning="|x(0)| > τ > 0, α < 1 ⇒ 1 < (c1|x(0)|^{1−α} + c2)/(c1τ^{1−α} + c2) < c1|x(0)|^{1−α}/(c1τ^{1−α}) = (|x(0)|/τ)^{1−α}",
        transcription="(proof summarised: T_fsm < T_lsm, 37–38)",
        verdict=ARTEFACT,
        erratum=None,
        note="'xð0Þ99' and 'x 0ð Þ' are |x(0)| with displaced bars and parentheses, fraction bars lost; right (claim theorem3-fsm-vs-lsm)",
    ),
    AuditRow(
        equation="eq 38",
        section="3.3",
        printed="o1 c1ð1�aÞln 9xð0Þ9t � �1�a ¼1 c1ln 9xð0Þ9t � �¼ Tlsm: ð38Þ",
        printed_meaning="T_fsm < 1/(c1(1−α)) ln((|x(0)|/τ)^{1−α}) = (1/c1) ln(|x(0)|/τ) = T_lsm",
        transcription="(proof summarised)",
        verdict=ARTEFACT,
        erratum=None,
        note="fraction bars lost; right (claim theorem3-fsm-vs-lsm)",
    ),
    AuditRow(
        equation="eq 39",
        section="3.3",
        printed="dTtsm d9xð0Þ9¼ 1 c29xð0Þ9�a: ð39Þ",
        printed_meaning="dT_tsm/d|x(0)| = (1/c2) |x(0)|^{−α}",
        transcription="(proof summarised)",
        verdict=ARTEFACT,
        erratum=None,
        note=(
            "read linearly, '1 c2 |x(0)|^{−α}' could be 1/(c2|x(0)|^{−α}) = |x(0)|^α/c2, which is wrong; but the "
            "extraction puts factors on the fraction's baseline next to the denominator (as '¼' next to 'd|x(0)|'), "
            "and eq 41's comparison is true only for (1/c2)|x(0)|^{−α}, the derivative of eq 35 (claim "
            "theorem3-fsm-vs-tsm)"
        ),
    ),
    AuditRow(
        equation="eq 40",
        section="3.3",
        printed="dTf sm d9xð0Þ9¼ 9xð0Þ9�a c19xð0Þ91�aþc2 : ð40Þ",
        printed_meaning="dT_fsm/d|x(0)| = |x(0)|^{−α} / (c1|x(0)|^{1−α} + c2)",
        transcription="(proof summarised)",
        verdict=ARTEFACT,
        erratum=None,
        note="fraction bars lost; right (claim theorem3-fsm-vs-tsm)",
    ),
    AuditRow(
        equation="eq 41",
        section="3.3",
        printed="dTf sm d9xð0Þ9¼ xð0Þ99�a c19xð0Þ91�aþc2 o1 c29xð0Þ9�a ¼ dTtsm d9xð0Þ9: ð41Þ",
        printed_meaning="dT_fsm/d|x(0)| = |x(0)|^{−α}/(c1|x(0)|^{1−α} + c2) < (1/c2)|x(0)|^{−α} = dT_tsm/d|x(0)|",
        transcription="(proof summarised: T_fsm < T_tsm, 39–41)",
        verdict=ARTEFACT,
        erratum=None,
        note="'xð0Þ99' is |x(0)| with a displaced bar; with T_fsm = T_tsm = 0 at |x(0)| = τ the claim follows (claim theorem3-fsm-vs-tsm)",
    ),
)


# ----------------------------------------------------------------------------- Markdown


_GLYPHS = (
    ("¼", "="),
    ("þ", "+"),
    ("�", "any unmapped glyph: minus, superscript × or −1, ≡, ⊂, a big bracket"),
    ("ð Þ", "( )"),
    ("9", "| (absolute value)"),
    ("J, :", "‖ (norm)"),
    ("r", "σ (bold), or ≤"),
    ("s", "s, or the plain σ"),
    ("x", "ω"),
    ("a", "α (and Latin a)"),
    ("Z", "η, or ≥"),
    ("4, o", "> and <"),
    ("d, D", "δ (and d), Δ"),
    ("k, g, m, t, y, p, O, e", "κ/λ/k, γ, μ, τ, θ, π, Ω, ε"),
    ("2, 7, U, n", "∈, ±, ·, a bullet or star"),
    ("_ , €", "an accent (dot, hat, bar) over the next letter; a double dot"),
    ("X, S, P", "Σ"),
    ("ffiffi…p, ffiffi…q", "a radical sign"),
)


def _cell(text: str, code: bool = False) -> str:
    if code:
        return "`" + text.replace("|", "\\|") + "`"
    out = text.replace("\\", "\\\\")
    for ch in "|*_`<":
        out = out.replace(ch, "\\" + ch)
    return out


def _erratum_summaries() -> dict[str, tuple[str, str, str]]:
    """Short (equations, as printed, correct) of each new erratum, for the Markdown table."""
    return {
        "eq6-skew-sign": ("6", "third row (−v₂, −v₁, 0)", "third row (−v₂, v₁, 0): the skew matrix of v"),
        "eq9-E-cross": ("9, 29", "E = Jω̇_d + ω_d J ω_d (also E0, Δd)", "E = Jω̇_d + ω_d^× J ω_d"),
        "eq17-sigma-index": ("17", "G_eiᵀ C_i σ̇_e", "G_eiᵀ C_i σ̇_ei"),
        "eq18-delta-diag": (
            "18, 20, 30",
            "q_i = G_eiᵀ M_i δ_i, u^D_i = q_i sgn(s_i); δ_i sgn(s_i)",
            "q_i = G_eiᵀ M_i diag(δ_i); δ_i ∘ sgn(s_i)",
        ),
        "eq19-gains-nonnegative": (
            "19; Remark 2; Sec. 4",
            "k^i_ij, k^j_ij positive constants",
            "k^i_ij ≥ 0, k^j_ij(t) ≥ 0, switching in t",
        ),
        "sec33-scalar-gains": (
            "Sec. 3.3, 34-36",
            "s = ẋ + a x + b sig(x)^a (a, b undefined)",
            "s = ẋ + c1 x + c2 sig(x)^α",
        ),
        "sec33-radius-symbol": ("Sec. 3.3, 34-41", "Z = {|x| ≤ μ}, μ > 0", "Z = {|x| ≤ τ}, τ > 0"),
    }


def audit_markdown() -> str:
    """``docs/errata-audit.md``: introduction, counts, the new errata and the audit table, from :data:`AUDIT`."""
    counts = Counter(r.verdict for r in AUDIT)
    summaries = _erratum_summaries()
    lines = [
        "# Seed audit: Sections 2–3 of Liang, Sun & Wang (2012) against the raw PDF text",
        "",
        "<!-- Generated from fsmctl/proofs/seed_audit.py by `python -m fsmctl.proofs.seed_audit`; do not edit. -->",
        "",
        "Every printed formula of Sections 2 and 3 (equations 1–41, the definitions of sig(x)^α, G(σ), M, C, E,",
        "the control law, the Lyapunov functions, the conditions on k and η, and Theorem 3's settling times) is",
        "compared in three versions: the **printed** text, quoted verbatim from a plain-text extraction of the",
        "published PDF (whitespace-normalised, garbling included); its **transcription** into clean notation",
        '(called "paper.md" below); and what fsmctl implements symbolically (`fsmctl.symbolic`). Neither text is',
        "part of the repository (the paper is under copyright): every quote needed is in the table below, and",
        "`tests/test_seed_audit.py` checks the quotes against the extraction on machines that have it.",
        "",
        "Verdicts:",
        "",
        f"- **{SAME}**: with the glyph key below, the printed text reads as the transcription;",
        f"- **{ARTEFACT}**: the extraction also lost or displaced layout (fraction bars, radicals, accents, big",
        "  delimiters), so a literal reading differs, but the printed formula is the transcription's;",
        f"- **{SILENT}**: the print is wrong (notation, dimension, sign, index) and paper.md states the right",
        "  form without saying so;",
        f"- **{EXISTING}**: the print is wrong and `fsmctl/proofs/errata.py` already has it;",
        f"- **{NEW}**: the print is wrong and paper.md does not address it.",
        "",
        f"Rows marked *{SILENT}* or *{NEW}* are new errata: each one is checked with SymPy in",
        "`fsmctl.proofs.seed_audit` (the printed form fails, the corrected form holds and is what fsmctl uses).",
        "Where the text alone cannot decide between a printing and an extraction error, the note says so.",
        "",
        "Glyph key of the extraction:",
        "",
        "| glyph | stands for |",
        "|---|---|",
        *[f"| {_cell(g, code=True)} | {_cell(m)} |" for g, m in _GLYPHS],
        "",
        "## Counts",
        "",
        "| verdict | rows |",
        "|---|---|",
        *[f"| {v} | {counts.get(v, 0)} |" for v in VERDICTS],
        f"| total | {len(AUDIT)} |",
        "",
        "## New errata",
        "",
        "| id | equations | as printed | correct |",
        "|---|---|---|---|",
        *[
            f"| `{c.id}` | {_cell(summaries[c.id][0])} | {_cell(summaries[c.id][1])} | {_cell(summaries[c.id][2])} |"
            for c in AUDIT_CHECKS
        ],
        "",
        "## Audit table",
        "",
        "| # | equation | printed (raw extraction) | printed, decoded | paper.md | verdict | erratum |",
        "|---|---|---|---|---|---|---|",
    ]
    for n, r in enumerate(AUDIT, 1):
        lines.append(
            f"| {n} | {_cell(r.equation)} | {_cell(r.printed, code=True)} | {_cell(r.printed_meaning)} | "
            f"{_cell(r.transcription)} | {r.verdict} | {f'`{r.erratum}`' if r.erratum else ''} |"
        )
    lines += ["", "## Notes", ""]
    for n, r in enumerate(AUDIT, 1):
        lines.append(f"{n}. **{_cell(r.equation)}** (Sec. {r.section}): {_cell(r.note)}")
    lines.append("")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    """Write ``docs/errata-audit.md`` from :func:`audit_markdown`, or with ``--check`` compare it (exit 1 if stale)."""
    import argparse
    from pathlib import Path

    parser = argparse.ArgumentParser(prog="python -m fsmctl.proofs.seed_audit", description=main.__doc__)
    parser.add_argument("--check", action="store_true", help="do not write; exit 1 if the file differs")
    args = parser.parse_args(argv)
    path = Path(__file__).resolve().parents[2] / "docs" / "errata-audit.md"
    text = audit_markdown()
    if args.check:
        current = path.read_text(encoding="utf-8") if path.exists() else None
        if current != text:
            print(f"{path} is stale: run python -m fsmctl.proofs.seed_audit")
            return 1
        print(f"{path} is up to date")
        return 0
    path.write_text(text, encoding="utf-8")
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
