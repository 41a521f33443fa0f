"""Rigorous quadratic building blocks of ``fsmctl certify``: a verified common quadratic Lyapunov function, and
the negative (positive) definiteness of a symmetric interval matrix.

Common quadratic Lyapunov function (:func:`quadratic_lyapunov`)
    For the linear systems ``x' = A_i x`` (the closed loop's Jacobians at the origin, at the vertices or samples
    of the uncertainty set) a symmetric ``P`` with

    * ``P - I`` positive semidefinite, ``P`` positive definite, and
    * ``-(A_i^T P + P A_i) - 2 a P`` positive definite for every ``i`` (some ``a >= 0``)

    makes ``V = x^T P x`` a Lyapunov function of each of them: ``V' = x^T (A_i^T P + P A_i) x < -2 a V`` for
    ``x != 0``, so ``V(x(t)) <= exp(-2 a t) V(x(0))``.  Both conditions are affine in ``A``, so they hold for
    every ``A`` in the convex hull of the ``A_i`` as well (Boyd et al. 1994, section 5.1): given the vertices of
    a polytopic uncertainty set the certificate covers the whole set; given samples, only the samples.

    ``P`` is found by a semidefinite program (cvxpy; Clarabel, SCS as the fallback): the largest decay ``a`` the
    linear matrix inequalities admit by bisection, then :data:`DECAY_FRACTION` of it with the condition number of
    ``P`` minimised (``I <= P <= t I``, minimise ``t``) and a margin of :data:`LMI_MARGIN` (relative to
    ``t max_i ||A_i||_2``) in the decay inequalities.  The solver's ``P`` is then rounded to
    :data:`ROUND_BITS` significant bits (a matrix of exact dyadic rationals), and the two conditions are
    checked for that rounded ``P`` **in exact rational arithmetic** (the ``A_i`` and ``a`` taken as the exact
    rationals their floats are).  Only this exact check sets ``verified``; the floating point SDP solve is the
    search, never the proof.  When the decay inequality fails the exact check, ``a = 0`` (plain negative
    definiteness of ``A_i^T P + P A_i``) is checked instead.

Symmetric interval matrices (:func:`interval_matrix_negative_definite`)
    Every symmetric ``M`` with ``lo <= M <= hi`` entrywise is ``M = C + E`` with the midpoint ``C = (lo + hi)/2``
    and ``|E| <= R = (hi - lo)/2`` entrywise (``lo`` and ``hi`` first intersected with their transposes: a
    symmetric ``M`` meets both bounds).  ``E`` is symmetric, so ``||E||_2 = rho(E) <= rho(|E|) <= rho(R)`` (the
    spectral radius is monotone on nonnegative matrices, Perron-Frobenius), and Weyl's inequality gives
    ``lambda_max(M) <= lambda_max(C) + rho(R)``.  So every such ``M`` is negative definite when ``-C - r I`` is
    positive definite for a rational ``r >= rho(R)`` (Rohn 1994, Theorem 4's sufficient condition).  ``r`` is
    the smallest of three sound bounds, each exact: a floating point estimate of ``rho(R) = lambda_max(R)``
    rounded up and proved an upper bound by the exact positive definiteness of ``r I - R``; the largest row
    sum ``||R||_inf``; and ``||R||_F`` rounded up through an integer square root.  All of it is rational
    arithmetic on the exact values of the input floats; a non-finite entry gives ``False``.

Exact positive definiteness (:func:`positive_definite_exact`)
    Sylvester's criterion: a symmetric matrix is positive definite if and only if all its leading principal
    minors are positive.  The rational matrix is scaled to an integer one by the (positive) common denominator
    of its entries, and the Bareiss fraction-free elimination gives the leading principal minors as its pivots,
    in integer arithmetic with exact divisions.

References
----------
S. Boyd, L. El Ghaoui, E. Feron, V. Balakrishnan, *Linear Matrix Inequalities in System and Control Theory*,
SIAM, 1994 (chapter 5: quadratic stability of polytopic systems).

J. Rohn, "Positive definiteness and stability of interval matrices", *SIAM J. Matrix Anal. Appl.* 15(1),
175-184, 1994.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction

import cvxpy as cp
import flint
import numpy as np

__all__ = [
    "QuadraticLyapunov",
    "quadratic_lyapunov",
    "invariant_ellipsoid",
    "round_dyadic",
    "ELLIPSOID_RATES",
    "positive_definite_exact",
    "interval_matrix_negative_definite",
    "interval_matrix_positive_definite",
    "ROUND_BITS",
    "LMI_MARGIN",
    "DECAY_FRACTION",
    "BISECTION_STEPS",
    "FALLBACK_SOLVER",
]

ROUND_BITS = 24
"""Significant bits kept when the solver's ``P`` is rounded (relative to its largest entry) before the exact
check: few enough for small exact rationals, many enough that the rounding stays far inside :data:`LMI_MARGIN`."""

LMI_MARGIN = 1e-4
"""Margin of the decay inequalities in the SDP, relative to ``t max_i ||A_i||_2`` (``t`` bounds ``P``): it absorbs
the rounding of ``P`` to :data:`ROUND_BITS` bits (at most about ``4 n 2^-ROUND_BITS`` of that scale) and the
solver's tolerance, so the rounded ``P`` passes the exact check."""

DECAY_FRACTION = 0.5
"""Fraction of the largest decay the bisection finds that the final ``P`` is solved for: the rest of the decay
buys a better conditioned ``P`` and room for the rounding."""

BISECTION_STEPS = 8
"""Bisection steps on the decay ``a`` over ``[0, -max_i max Re lambda(A_i)]`` (relative precision ``2^-8``: ample,
as only :data:`DECAY_FRACTION` of the result is used; each step is one SDP solve)."""

FALLBACK_SOLVER = "SCS"
"""The SDP solver tried when the requested one is missing or fails (error or an unusable status)."""

ELLIPSOID_RATES = tuple(10.0 ** (k / 4) for k in range(-8, 5))
"""S-procedure rates ``alpha`` tried by :func:`invariant_ellipsoid` (0.01 ... 10): its LMI is linear for each"""

_SCS_OPTIONS = {"eps_abs": 1e-8, "eps_rel": 1e-8, "max_iters": 20_000}
_FEASIBLE = {cp.OPTIMAL, cp.OPTIMAL_INACCURATE}
_INFEASIBLE = {cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE}


@dataclass(frozen=True)
class QuadraticLyapunov:
    """A common quadratic Lyapunov function ``V = x^T P x`` and what was proved about it.

    Attributes
    ----------
    P : numpy.ndarray
        ``(n, n)`` symmetric float64 matrix; its entries are the exact dyadic rationals that were checked (the
        zero matrix when the SDP found nothing).
    decay : float
        ``a`` with ``A_i^T P + P A_i + 2 a P`` negative definite for every ``A_i``, checked exactly (``0.0``
        when only ``A_i^T P + P A_i`` negative definite was proved, or nothing was).
    verified : bool
        The exact rational checks passed: ``P`` positive definite and the decay inequality for every ``A_i``.
    solver : str
        The solver that produced ``P`` and its status, e.g. ``"CLARABEL optimal"``.
    detail : str
        One line: what was solved and what was checked.
    """

    P: np.ndarray
    decay: float
    verified: bool
    solver: str
    detail: str


# --- exact positive definiteness ---------------------------------------------------------------------------------


def _as_fraction(value: object) -> Fraction | None:
    """The exact rational value of a float, int or Fraction entry (``None`` if it is not finite)."""
    if isinstance(value, Fraction):
        return value
    if isinstance(value, (int, np.integer)):
        return Fraction(int(value))
    x = float(value)  # type: ignore[arg-type]
    if not math.isfinite(x):
        return None
    return Fraction(x)


def _fraction_matrix(M: Sequence[Sequence[object]] | np.ndarray, name: str) -> list[list[Fraction]] | None:
    """``M`` as a square list of lists of Fractions (``None`` if an entry is not finite); ValueError if not square."""
    rows = [list(row) for row in M]
    n = len(rows)
    if n == 0 or any(len(row) != n for row in rows):
        raise ValueError(f"{name} must be a non-empty square matrix, got row lengths {[len(r) for r in rows]}")
    out = [[_as_fraction(v) for v in row] for row in rows]
    if any(v is None for row in out for v in row):
        return None
    return out  # type: ignore[return-value]


def _leading_minors_positive(N: list[list[int]]) -> bool:
    """Sylvester's criterion on a symmetric integer matrix: FLINT's fraction-free LU (Bareiss), whose pivots are
    the leading principal minors; a row exchange means a zero leading minor (not positive definite)."""
    P, _, _, U = flint.fmpz_mat(N).fflu()
    return bool(P.is_one()) and all(U[k, k] > 0 for k in range(len(N)))


def _positive_definite_fractions(F: list[list[Fraction]]) -> bool:
    """Positive definiteness of an exactly symmetric Fraction matrix (integer scaling, then Sylvester)."""
    denominator = math.lcm(*(v.denominator for row in F for v in row))
    return _leading_minors_positive([[v.numerator * (denominator // v.denominator) for v in row] for row in F])


def positive_definite_exact(M: Sequence[Sequence[Fraction | float | int]] | np.ndarray) -> bool:
    """Whether a symmetric matrix is positive definite, decided in exact rational arithmetic.

    Floats are taken as the exact dyadic rationals they are; Sylvester's criterion (all leading principal minors
    positive) is evaluated by fraction-free Bareiss elimination (FLINT's ``fmpz_mat.fflu``) on the integer matrix
    scaled by the common denominator.

    Parameters
    ----------
    M : sequence of sequences of Fraction, float or int, or numpy.ndarray
        A square matrix, exactly symmetric.

    Returns
    -------
    bool
        ``True`` if ``M`` is positive definite; ``False`` otherwise, also when an entry is not finite.

    Raises
    ------
    ValueError
        If ``M`` is empty, not square, or not exactly symmetric.

    Examples
    --------
    >>> from fractions import Fraction
    >>> positive_definite_exact([[2, 1], [1, 2]])
    True
    >>> positive_definite_exact([[1, 1], [1, 1]])  # singular: positive semidefinite only
    False
    >>> positive_definite_exact([[Fraction(1, 3), 0.5], [0.5, Fraction(3, 4) + Fraction(1, 10**30)]])
    True
    """
    F = _fraction_matrix(M, "M")
    if F is None:
        return False
    n = len(F)
    if any(F[i][j] != F[j][i] for i in range(n) for j in range(i + 1, n)):
        raise ValueError("M must be exactly symmetric")
    return _positive_definite_fractions(F)


# --- symmetric interval matrices ---------------------------------------------------------------------------------


def _interval_bounds(lo: np.ndarray, hi: np.ndarray) -> tuple[list[list[Fraction]], list[list[Fraction]]] | None:
    """Exact ``lo``, ``hi`` intersected with their transposes (``None`` if an entry is not finite)."""
    lo_a, hi_a = np.asarray(lo), np.asarray(hi)
    if lo_a.ndim != 2 or lo_a.shape != hi_a.shape or lo_a.shape[0] != lo_a.shape[1] or lo_a.shape[0] == 0:
        raise ValueError(f"lo and hi must be non-empty square matrices of one shape, got {lo_a.shape} and {hi_a.shape}")
    L, H = _fraction_matrix(lo_a.tolist(), "lo"), _fraction_matrix(hi_a.tolist(), "hi")
    if L is None or H is None:
        return None
    n = len(L)
    L = [[max(L[i][j], L[j][i]) for j in range(n)] for i in range(n)]
    H = [[min(H[i][j], H[j][i]) for j in range(n)] for i in range(n)]
    if any(L[i][j] > H[i][j] for i in range(n) for j in range(n)):
        raise ValueError("lo <= M <= hi holds for no symmetric M (lo > hi somewhere, after symmetrisation)")
    return L, H


def _spectral_radius_bound(R: list[list[Fraction]]) -> Fraction:
    """A rational ``r >= rho(R)`` for a symmetric nonnegative ``R``: the least of three sound bounds."""
    n = len(R)
    bounds = [max(sum(row) for row in R)]  # ||R||_inf >= rho(R)
    square_sum = sum(v * v for row in R for v in row)
    scale = 1 << 60  # ||R||_F <= ceil(sqrt(square_sum * scale^2)) / scale
    scaled = square_sum * scale * scale
    bounds.append(Fraction(math.isqrt(math.ceil(scaled)) + 1, scale))
    estimate = float(np.linalg.eigvalsh(np.array([[float(v) for v in row] for row in R]))[-1])
    if math.isfinite(estimate) and estimate > 0:
        guess = Fraction(estimate * (1 + 2**-30) + 2**-1000)
        shifted = [[(guess if i == j else 0) - R[i][j] for j in range(n)] for i in range(n)]
        if _positive_definite_fractions(shifted):  # guess I - R > 0: lambda_max(R) = rho(R) < guess
            bounds.append(guess)
    return min(bounds)


def interval_matrix_negative_definite(lo: np.ndarray, hi: np.ndarray) -> bool:
    """Whether every symmetric matrix ``M`` with ``lo <= M <= hi`` entrywise is negative definite (rigorous).

    Sufficient condition, checked exactly: ``-C - r I`` positive definite, with the midpoint
    ``C = (lo + hi) / 2``, the radius ``R = (hi - lo) / 2`` and a rational ``r >= rho(R)`` (see the module
    docstring).  ``True`` is a proof; ``False`` means not proved (or not true).

    Parameters
    ----------
    lo, hi : numpy.ndarray
        ``(n, n)`` entrywise bounds (floats, ints or Fractions; taken as exact rationals).  Only symmetric ``M``
        count, so the bounds are intersected with their transposes first.

    Returns
    -------
    bool
        ``True`` only if every such ``M`` is negative definite; ``False`` also for a non-finite entry.

    Raises
    ------
    ValueError
        If ``lo`` and ``hi`` are not square matrices of one shape, or no symmetric ``M`` lies between them.

    Examples
    --------
    >>> import numpy as np
    >>> C = np.array([[-2.0, 0.5], [0.5, -1.0]])
    >>> interval_matrix_negative_definite(C - 0.1, C + 0.1)
    True
    >>> interval_matrix_negative_definite(C - 0.5, C + 0.5)  # contains [[-1.5, 1], [1, -0.5]], indefinite
    False
    """
    bounds = _interval_bounds(lo, hi)
    if bounds is None:
        return False
    L, H = bounds
    n = len(L)
    R = [[(H[i][j] - L[i][j]) / 2 for j in range(n)] for i in range(n)]
    r = _spectral_radius_bound(R)
    shifted = [[-(H[i][j] + L[i][j]) / 2 - (r if i == j else 0) for j in range(n)] for i in range(n)]
    return _positive_definite_fractions(shifted)


def interval_matrix_positive_definite(lo: np.ndarray, hi: np.ndarray) -> bool:
    """Whether every symmetric matrix ``M`` with ``lo <= M <= hi`` entrywise is positive definite (rigorous).

    The negative definiteness of ``-M`` over ``-hi <= -M <= -lo``: see :func:`interval_matrix_negative_definite`.

    Parameters
    ----------
    lo, hi : numpy.ndarray
        ``(n, n)`` entrywise bounds.

    Returns
    -------
    bool
        ``True`` only if every such ``M`` is positive definite.

    Examples
    --------
    >>> import numpy as np
    >>> interval_matrix_positive_definite(np.eye(2) * 0.9, np.eye(2) * 1.1 + 0.05)
    True
    """
    lo_a, hi_a = np.asarray(lo), np.asarray(hi)
    return interval_matrix_negative_definite(-hi_a, -lo_a)


# --- common quadratic Lyapunov function --------------------------------------------------------------------------


def _check_jacobians(jacobians: Sequence[np.ndarray]) -> list[np.ndarray]:
    """The Jacobians as finite float arrays of one square shape (ValueError otherwise)."""
    A = [np.asarray(J, dtype=float) for J in jacobians]
    if not A:
        raise ValueError("jacobians must hold at least one matrix")
    shape = A[0].shape
    if len(shape) != 2 or shape[0] != shape[1] or shape[0] == 0:
        raise ValueError(f"jacobians must be non-empty square matrices, got shape {shape}")
    for i, Ai in enumerate(A):
        if Ai.shape != shape:
            raise ValueError(f"jacobians[{i}] has shape {Ai.shape}, jacobians[0] has {shape}")
        if not np.all(np.isfinite(Ai)):
            raise ValueError(f"jacobians[{i}] has a non-finite entry")
    return A


class _LyapunovSDP:
    """The parametrised SDP: minimise ``t`` s.t. ``I <= P <= t I``, ``A_i^T P + P A_i + 2 a P + m t I <= 0``."""

    def __init__(self, A: list[np.ndarray], solver: str):
        n = A[0].shape[0]
        eye = np.eye(n)
        self.P = cp.Variable((n, n), symmetric=True)
        self.t = cp.Variable()
        self.a = cp.Parameter(nonneg=True)
        margin = LMI_MARGIN * max(max(np.linalg.norm(Ai, 2) for Ai in A), 1e-300)
        constraints = [self.P >> eye, self.P << self.t * eye]
        constraints += [Ai.T @ self.P + self.P @ Ai + 2 * self.a * self.P + margin * self.t * eye << 0 for Ai in A]
        self.problem = cp.Problem(cp.Minimize(self.t), constraints)
        installed = set(cp.installed_solvers())
        self.solvers = [name for name in dict.fromkeys([solver, FALLBACK_SOLVER]) if name in installed]

    def solve(self, a: float, *, fallback: bool = True) -> tuple[np.ndarray | None, str]:
        """``P`` at decay ``a`` (``None`` if infeasible or every solver failed) and ``"SOLVER status"``.

        Without ``fallback`` only the first solver runs (the bisection: a failure near the boundary of feasibility
        counts as infeasible, which only makes the search conservative).
        """
        self.a.value = a
        label = "no SDP solver installed"
        for name in self.solvers if fallback else self.solvers[:1]:
            options = _SCS_OPTIONS if name == "SCS" else {}
            try:
                with warnings.catch_warnings():  # "may be inaccurate": the status says so, the exact check decides
                    warnings.simplefilter("ignore", UserWarning)
                    self.problem.solve(solver=name, **options)
            except (cp.SolverError, ValueError) as exc:
                label = f"{name} failed ({type(exc).__name__})"
                continue
            label = f"{name} {self.problem.status}"
            if self.problem.status in _FEASIBLE and self.P.value is not None:
                return np.array(self.P.value, dtype=float), label
            if self.problem.status in _INFEASIBLE:
                return None, label
        return None, label


def round_dyadic(P: np.ndarray, bits: int = ROUND_BITS) -> np.ndarray:
    """``P`` symmetrised and rounded to ``bits`` significant bits of its largest entry: exact dyadic rationals (a zero
    matrix stays zero).

    Examples
    --------
    >>> import numpy as np
    >>> round_dyadic(np.array([[1.0, 1 / 3], [0.0, 2.0]]), bits=4).tolist()
    [[1.0, 0.25], [0.25, 2.0]]
    """
    S = (P + P.T) / 2
    top = float(np.max(np.abs(S))) or 1.0
    quantum = math.ldexp(1.0, math.frexp(top)[1] - bits)
    return np.round(S / quantum) * quantum


def _integer_matrix(X: np.ndarray) -> tuple[np.ndarray, int]:
    """``X = N / 2^s`` exactly: the integer object array ``N`` and ``s``."""
    F = [[Fraction(float(v)) for v in row] for row in X]
    s = max(v.denominator.bit_length() - 1 for row in F for v in row)
    return np.array([[int(v * (1 << s)) for v in row] for row in F], dtype=object), s


def _decay_certified(A: list[np.ndarray], P: np.ndarray, a: float) -> bool:
    """Exactly: ``P`` positive definite and ``-(A_i^T P + P A_i) - 2 a P`` positive definite for every ``A_i``."""
    NP, _ = _integer_matrix(P)  # the scale 2^-s of P does not change the signs of the minors
    if not _leading_minors_positive(NP.tolist()):
        return False
    fa = Fraction(a)
    Na, sa = fa.numerator, fa.denominator.bit_length() - 1
    for Ai in A:
        NA, sA = _integer_matrix(Ai)
        # times 2^(sA + sP + sa): -(NA^T NP + NP NA) 2^sa - 2 Na NP 2^sA
        lyap = NA.T.dot(NP)
        S = -(lyap + lyap.T) * (1 << sa) - NP * (2 * Na * (1 << sA))
        if not _leading_minors_positive(S.tolist()):
            return False
    return True


def _largest_decay(sdp: _LyapunovSDP, A: list[np.ndarray]) -> tuple[float, np.ndarray | None, str]:
    """Bisection for the largest feasible decay: ``(a, P at a, label)``; ``P`` is ``None`` if ``a = 0`` fails."""
    P, label = sdp.solve(0.0)
    if P is None:
        return 0.0, None, label
    upper = min(-float(np.max(np.linalg.eigvals(Ai).real)) for Ai in A)
    lower = 0.0
    for _ in range(BISECTION_STEPS):
        if upper <= lower:
            break
        middle = (lower + upper) / 2
        candidate, _ = sdp.solve(middle, fallback=False)
        if candidate is None:
            upper = middle
        else:
            lower = middle
    return lower, P, label


def quadratic_lyapunov(
    jacobians: Sequence[np.ndarray], *, decay: float | None = None, solver: str = "CLARABEL"
) -> QuadraticLyapunov:
    """A common quadratic Lyapunov function ``V = x^T P x`` of ``x' = A_i x``, verified in exact arithmetic.

    An SDP (cvxpy) finds ``P`` (``P >= I``, ``A_i^T P + P A_i <= -2 a P`` with a margin, condition number
    minimised); ``P`` is rounded to :data:`ROUND_BITS` significant bits and the inequalities are checked for the
    rounded ``P`` in exact rational arithmetic.  See the module docstring for why this is sound.

    Parameters
    ----------
    jacobians : sequence of numpy.ndarray
        The ``(n, n)`` matrices ``A_i`` (the closed loop's Jacobians at the origin at the vertices or samples of
        the uncertainty set).  With the vertices of a polytope, the certificate holds on its convex hull.
    decay : float, optional
        The decay ``a >= 0`` to certify.  By default the largest decay the SDP admits is found by bisection and
        :data:`DECAY_FRACTION` of it is used.
    solver : str, default "CLARABEL"
        The cvxpy SDP solver; :data:`FALLBACK_SOLVER` is tried when it is missing or fails.

    Returns
    -------
    QuadraticLyapunov
        ``verified`` is ``True`` only if the exact checks passed for every ``A_i``; an infeasible SDP (e.g. an
        unstable ``A_i``) gives ``verified=False`` and ``P`` zero, never an exception.

    Raises
    ------
    ValueError
        If ``jacobians`` is empty, its matrices are not square, of different shapes or not finite, or ``decay``
        is negative or not finite.

    Examples
    --------
    >>> import numpy as np
    >>> A = np.array([[0.0, 1.0], [-2.0, -3.0]])  # eigenvalues -1 and -2
    >>> result = quadratic_lyapunov([A, 1.1 * A])
    >>> result.verified, result.decay > 0.25
    (True, True)
    >>> quadratic_lyapunov([np.array([[0.1, 0.0], [0.0, -1.0]])]).verified
    False
    """
    A = _check_jacobians(jacobians)
    if decay is not None and not (math.isfinite(decay) and decay >= 0):
        raise ValueError(f"decay must be a finite number >= 0, got {decay}")
    n = A[0].shape[0]
    sdp = _LyapunovSDP(A, solver)
    if decay is None:
        largest, P, label = _largest_decay(sdp, A)
        target = DECAY_FRACTION * largest
        if P is not None and target > 0:
            P_target, target_label = sdp.solve(target)
            if P_target is None:
                target = 0.0
            else:
                P, label = P_target, target_label
        what = f"SDP for {len(A)} Jacobian(s) of order {n}, decay {DECAY_FRACTION} x the bisected {largest:.6g}"
    else:
        target = float(decay)
        P, label = sdp.solve(target)
        what = f"SDP for {len(A)} Jacobian(s) of order {n} at decay {target:.6g}"
    if P is None:
        return QuadraticLyapunov(np.zeros((n, n)), 0.0, False, label, f"{what}: infeasible or failed ({label})")
    return _verify(A, round_dyadic(P), target, label, what)


def _verify(A: list[np.ndarray], P: np.ndarray, target: float, label: str, what: str) -> QuadraticLyapunov:
    """The exact checks of a rounded ``P``: at ``target``, else at decay 0."""
    checked = f"P rounded to {ROUND_BITS} bits, checked exactly"
    if _decay_certified(A, P, target):
        return QuadraticLyapunov(P, target, True, label, f"{what}; {checked}: P > 0, A^T P + P A + 2 a P < 0")
    if target > 0 and _decay_certified(A, P, 0.0):
        return QuadraticLyapunov(P, 0.0, True, label, f"{what}; {checked}: P > 0, A^T P + P A < 0 (decay not)")
    return QuadraticLyapunov(P, 0.0, False, label, f"{what}; {checked}: failed")


def invariant_ellipsoid(
    jacobians: Sequence[np.ndarray],
    inputs: Sequence[np.ndarray],
    bounds: Sequence[float],
    half_widths: Sequence[float],
    *,
    solver: str = "CLARABEL",
) -> tuple[np.ndarray, float] | None:
    """An attracting invariant ellipsoid of ``x' = A_i x + B_i w``, ``|w_k| <= bounds_k``, small in the box ``|x_k| <=
    half_widths_k``: the search for a quadratic candidate shaped by a bounded disturbance.

    With ``Q = P^-1``, the LMI ``[[A Q + Q A^T + alpha Q, B W], [W B^T, -diag(l)]] <= 0``, ``sum l <= alpha``
    (``W = diag(bounds)``) gives ``V_dot <= -alpha (V - 1)`` for ``V = x^T P x`` and every admissible ``w`` (the
    S-procedure, Boyd et al. 1994, section 6.1.3): ``{V <= 1}`` attracts and is invariant.  Minimising ``t`` with
    ``Q_kk <= t h_k^2`` (over a grid of ``alpha``, :data:`ELLIPSOID_RATES`) makes it small relative to the box, so
    that ``{V <= 1}`` sits well inside ``{V <= c}``, ``c`` the least ``V`` on the box's boundary (``c >= 1/t``).

    Only a search: the nonlinear closed loop is certified (or not) with this ``P`` afterwards.

    Parameters
    ----------
    jacobians, inputs : sequence of numpy.ndarray
        ``A_i`` ``(n, n)`` and ``B_i`` ``(n, m)``, e.g. at the vertices of an uncertainty set.
    bounds : sequence of float
        ``(m,)``: ``|w_k| <= bounds_k``.
    half_widths : sequence of float
        ``(n,)``: the box.
    solver : str
        The cvxpy SDP solver.

    Returns
    -------
    (numpy.ndarray, float) or None
        ``P`` (symmetric, rounded to :data:`ROUND_BITS` bits and positive definite, checked exactly) and the rate
        ``alpha``; None when no rate gives a feasible LMI.

    Examples
    --------
    ``x' = -x + w``, ``|w| <= 1/2`` in ``|x| <= 2``: the smallest attracting interval is ``|x| <= 1/2``:

    >>> import numpy as np
    >>> P, alpha = invariant_ellipsoid([np.array([[-1.0]])], [np.array([[1.0]])], [0.5], [2.0])
    >>> bool(abs(1 / np.sqrt(P[0, 0]) - 0.5) < 0.05)
    True
    """
    A = _check_jacobians(jacobians)
    n = A[0].shape[0]
    B = [np.asarray(b, dtype=float).reshape(n, -1) for b in inputs]
    W = np.diag(np.asarray(bounds, dtype=float))
    h = np.asarray(half_widths, dtype=float)
    best: tuple[float, float, np.ndarray] | None = None
    for alpha in ELLIPSOID_RATES:
        Q, lam, t = cp.Variable((n, n), symmetric=True), cp.Variable(W.shape[0], nonneg=True), cp.Variable()
        constraints = [Q >> 1e-9 * np.eye(n), cp.sum(lam) <= alpha, cp.diag(Q) <= t * h**2]
        for Ai, Bi in zip(A, B, strict=True):
            BW = Bi @ W
            M = cp.bmat([[Ai @ Q + Q @ Ai.T + alpha * Q, BW], [BW.T, -cp.diag(lam)]])
            constraints.append(0.5 * (M + M.T) << 0)
        problem = cp.Problem(cp.Minimize(t), constraints)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)
                problem.solve(solver=solver)
        except (cp.SolverError, ValueError):
            continue
        if problem.status in _FEASIBLE and Q.value is not None and (best is None or t.value < best[0]):
            best = (float(t.value), alpha, np.array(Q.value, float))
    if best is None:
        return None
    try:
        P = round_dyadic(np.linalg.inv(0.5 * (best[2] + best[2].T)))
    except np.linalg.LinAlgError:
        return None
    if not positive_definite_exact(P):
        return None
    return P, best[1]
