"""``fsmctl certify``'s quadratic building blocks (:mod:`fsmctl.proofs.quadratic_forms`) against independent oracles.

* :func:`quadratic_lyapunov`: on a 2x2 system, the 6x6 MRP PD loop and the vertices of its uncertain inertia,
  ``P`` and the decay inequalities are checked with NumPy's ``eigvalsh`` at a margin, on random convex
  combinations of the vertices, and along exact solutions ``expm(A t) x0`` (``V`` must fall at least as fast as
  ``exp(-2 a t)``); the decay is bounded by the analytic ``-max Re lambda(A)``; unstable systems and an
  unattainable decay give ``verified=False``.
* :func:`positive_definite_exact`: against ``eigvalsh`` on random integer and rational matrices away from the
  boundary, and on exact edge cases no floating point check can decide.
* :func:`interval_matrix_negative_definite`: whenever it says ``True``, random matrices inside the interval and
  (for orders 2 and 3) all its vertices are negative definite by ``eigvalsh``; it must say ``True`` when the
  midpoint-radius bound holds with a margin in floating point; known ``False`` cases.
"""

from __future__ import annotations

import itertools
from fractions import Fraction

import hypothesis.extra.numpy as hnp
import numpy as np
import pytest
import scipy.linalg
from hypothesis import assume, event, given, settings
from hypothesis import strategies as st

from fsmctl.proofs import quadratic_forms
from fsmctl.proofs.quadratic_forms import (
    ROUND_BITS,
    interval_matrix_negative_definite,
    interval_matrix_positive_definite,
    positive_definite_exact,
    quadratic_lyapunov,
)

RNG_SEED = 29
J0 = np.diag([1.0, 1.2, 0.9])


def mrp_pd_loop(J: np.ndarray, K: float = 2.0, P: float = 3.0) -> np.ndarray:
    """The MRP PD loop linearised at the origin: ``sigma' = omega / 4``, ``J omega' = -K sigma - P omega``."""
    J_inv = np.linalg.inv(J)
    return np.block([[np.zeros((3, 3)), np.eye(3) / 4], [-K * J_inv, -P * J_inv]])


def spectral_abscissa(A: np.ndarray) -> float:
    return float(np.max(np.linalg.eigvals(A).real))


def assert_lyapunov(A: np.ndarray, P: np.ndarray, a: float) -> None:
    """NumPy oracle: ``P >= I`` (up to rounding), ``A^T P + P A + 2 a P < 0`` with room to spare."""
    assert np.array_equal(P, P.T)
    assert np.linalg.eigvalsh(P).min() > 1 - 1e-3
    Q = A.T @ P + P @ A + 2 * a * P
    assert np.linalg.eigvalsh(Q).max() < -1e-7 * np.linalg.norm(P, 2) * np.linalg.norm(A, 2)


def assert_decays_along_solutions(A: np.ndarray, P: np.ndarray, a: float, seed: int) -> None:
    """Exact solutions ``x(t) = expm(A t) x0``: ``V(x(t)) <= exp(-2 a t) V(x0)``."""
    rng = np.random.default_rng(seed)
    for x0 in rng.standard_normal((5, A.shape[0])):
        V0 = x0 @ P @ x0
        for t in (0.1, 0.5, 1.0, 3.0, 10.0):
            x = scipy.linalg.expm(A * t) @ x0
            assert x @ P @ x <= np.exp(-2 * a * t) * V0 * (1 + 1e-9)


# --- quadratic_lyapunov ------------------------------------------------------------------------------------------


def test_stable_2x2():
    A = np.array([[0.0, 1.0], [-2.0, -3.0]])  # eigenvalues -1, -2
    result = quadratic_lyapunov([A])
    assert result.verified, result.detail
    assert 0.25 < result.decay <= -spectral_abscissa(A)  # a decay beyond -max Re lambda is impossible
    assert result.solver.startswith("CLARABEL")
    assert_lyapunov(A, result.P, result.decay)
    assert_decays_along_solutions(A, result.P, result.decay, RNG_SEED)
    # P was rounded to ROUND_BITS significant bits of its largest entry: its entries are small dyadics
    scale = 2.0 ** (ROUND_BITS - np.frexp(np.abs(result.P).max())[1])
    assert np.array_equal(np.round(result.P * scale), result.P * scale)


def test_mrp_pd_loop_6x6():
    A = mrp_pd_loop(J0)
    result = quadratic_lyapunov([A])
    assert result.verified, result.detail
    assert 0 < result.decay <= -spectral_abscissa(A)
    assert result.decay > 0.25 * -spectral_abscissa(A)
    assert np.linalg.cond(result.P) < 100
    assert_lyapunov(A, result.P, result.decay)
    assert_decays_along_solutions(A, result.P, result.decay, RNG_SEED + 1)


def test_uncertain_inertia_vertices_and_their_hull():
    vertices = [mrp_pd_loop(J0 * s) for s in (0.9, 1.1)]
    vertices += [mrp_pd_loop(np.diag(d) @ J0) for d in [(0.9, 1.1, 1.0), (1.1, 0.9, 0.9), (1.0, 1.1, 0.9)]]
    result = quadratic_lyapunov(vertices)
    assert result.verified, result.detail
    assert 0 < result.decay <= min(-spectral_abscissa(A) for A in vertices)
    for A in vertices:
        assert_lyapunov(A, result.P, result.decay)
    rng = np.random.default_rng(RNG_SEED)
    for weights in rng.dirichlet(np.ones(len(vertices)), size=20):  # the LMIs are affine in A: the hull is covered
        A = sum(w * V for w, V in zip(weights, vertices, strict=True))
        assert_lyapunov(A, result.P, result.decay)
    assert_decays_along_solutions(vertices[0], result.P, result.decay, RNG_SEED + 2)


def test_fixed_decay():
    A = mrp_pd_loop(J0)
    result = quadratic_lyapunov([A], decay=0.05)
    assert result.verified and result.decay == 0.05
    assert_lyapunov(A, result.P, 0.05)
    too_fast = quadratic_lyapunov([A], decay=1.1 * -spectral_abscissa(A))  # beyond -max Re lambda: impossible
    assert not too_fast.verified and too_fast.decay == 0.0


@pytest.mark.parametrize(
    "jacobians",
    [
        [np.array([[0.1, 0.0], [0.0, -1.0]])],  # an unstable mode
        [np.array([[0.0, 1.0], [-1.0, 0.0]])],  # a centre: no strict Lyapunov function
        [mrp_pd_loop(J0), mrp_pd_loop(J0, K=-0.5)],  # one stable vertex, one unstable
    ],
    ids=["unstable", "centre", "one-vertex-unstable"],
)
def test_unstable_is_not_verified(jacobians):
    result = quadratic_lyapunov(jacobians)
    assert not result.verified
    assert result.decay == 0.0
    assert result.detail


def test_no_common_quadratic_lyapunov_function():
    # each is stable (a double eigenvalue -1), but a common P would serve their mean as well (the LMIs are affine
    # in A), and the mean [[-1, 5], [5, -1]] has the eigenvalue 4
    A1 = np.array([[-1.0, 10.0], [0.0, -1.0]])
    A2 = np.array([[-1.0, 0.0], [10.0, -1.0]])
    assert spectral_abscissa((A1 + A2) / 2) > 0
    result = quadratic_lyapunov([A1, A2])
    assert not result.verified


def test_fallback_when_the_solver_is_missing():
    A = np.array([[0.0, 1.0], [-2.0, -3.0]])
    result = quadratic_lyapunov([A], solver="NO_SUCH_SOLVER")
    assert result.verified and result.solver.startswith("SCS")
    assert_lyapunov(A, result.P, result.decay)


@pytest.mark.parametrize(
    ("jacobians", "decay"),
    [
        ([], None),
        ([np.zeros((2, 3))], None),
        ([np.eye(2), np.eye(3)], None),
        ([np.array([[np.nan, 0.0], [0.0, -1.0]])], None),
        ([-np.eye(2)], -0.1),
        ([-np.eye(2)], float("inf")),
    ],
)
def test_bad_input_raises(jacobians, decay):
    with pytest.raises(ValueError):
        quadratic_lyapunov(jacobians, decay=decay)


# --- positive_definite_exact -------------------------------------------------------------------------------------


@settings(max_examples=150, deadline=None, derandomize=True)
@given(
    hnp.arrays(np.int64, hnp.array_shapes(min_dims=2, max_dims=2, min_side=1, max_side=6), elements=st.integers(-9, 9)),
    st.integers(1, 7),
)
def test_positive_definite_exact_agrees_with_eigvalsh(X, denominator):
    n = min(X.shape)
    X = X[:n, :n]
    M = X + X.T + np.diag(np.abs(X).sum(axis=1) // 2)  # often positive definite, often not
    eigenvalues = np.linalg.eigvalsh(M.astype(float))
    assume(np.abs(eigenvalues).min() > 1e-6 * max(1.0, np.abs(eigenvalues).max()))
    expected = bool(eigenvalues.min() > 0)
    assert positive_definite_exact(M.tolist()) is expected
    assert positive_definite_exact(M.astype(float)) is expected
    assert positive_definite_exact([[Fraction(int(v), denominator) for v in row] for row in M]) is expected


def test_positive_definite_exact_edge_cases():
    tiny = Fraction(1, 10**40)
    assert not positive_definite_exact([[1, 2], [2, 4]])  # singular, positive semidefinite
    v = [Fraction(1, 3), Fraction(-2, 7), Fraction(5, 11)]
    rank_one = [[a * b for b in v] for a in v]
    assert not positive_definite_exact(rank_one)
    assert positive_definite_exact(
        [[r + (tiny if i == j else 0) for j, r in enumerate(row)] for i, row in enumerate(rank_one)]
    )
    assert positive_definite_exact([[1 + tiny, 1], [1, 1 + tiny]])  # eigenvalues 2 + tiny and tiny
    assert not positive_definite_exact([[1 - tiny, 1], [1, 1 - tiny]])  # eigenvalue -tiny
    assert not positive_definite_exact([[0]])
    assert positive_definite_exact([[tiny]])
    assert not positive_definite_exact([[1, 0, 0], [0, 0, 0], [0, 0, 1]])
    assert not positive_definite_exact([[0, 1], [1, 0]])
    assert not positive_definite_exact(-np.eye(3))
    assert positive_definite_exact(np.eye(3) * 5e-324)  # the smallest subnormal is still positive
    assert not positive_definite_exact([[float("nan"), 0.0], [0.0, 1.0]])
    assert not positive_definite_exact([[float("inf"), 0.0], [0.0, 1.0]])
    with pytest.raises(ValueError, match="symmetric"):
        positive_definite_exact([[2.0, 1.0], [1.0 + 2**-52, 2.0]])
    with pytest.raises(ValueError, match="square"):
        positive_definite_exact([[1.0, 0.0]])
    with pytest.raises(ValueError, match="square"):
        positive_definite_exact([])


# --- interval matrices -------------------------------------------------------------------------------------------


def sample_symmetric(lo: np.ndarray, hi: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """Random symmetric matrices with ``lo <= M <= hi`` (upper triangle drawn, mirrored), the bounds included."""
    n = lo.shape[0]
    U = rng.uniform(size=(count, n, n))
    U[: count // 4] = np.round(U[: count // 4])  # a quarter on the vertices
    M = lo + U * (hi - lo)
    upper = np.triu(M)
    return upper + np.transpose(np.triu(M, 1), (0, 2, 1))


def vertices(lo: np.ndarray, hi: np.ndarray) -> list[np.ndarray]:
    n = lo.shape[0]
    pairs = [(i, j) for i in range(n) for j in range(i, n)]
    out = []
    for choice in itertools.product((0, 1), repeat=len(pairs)):
        M = np.empty((n, n))
        for (i, j), c in zip(pairs, choice, strict=True):
            M[i, j] = M[j, i] = hi[i, j] if c else lo[i, j]
        out.append(M)
    return out


@st.composite
def symmetric_intervals(draw):
    n = draw(st.integers(2, 4))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    B = rng.standard_normal((n, n))
    shift = draw(st.floats(-1.0, 3.0))
    C = -(B @ B.T) / n - shift * np.eye(n)
    radius_scale = draw(st.sampled_from([0.0, 0.01, 0.1, 0.3, 1.0]))
    R = np.abs(rng.standard_normal((n, n))) * radius_scale
    R = (R + R.T) / 2
    return C - R, C + R


@settings(max_examples=120, deadline=None, derandomize=True)
@given(symmetric_intervals())
def test_interval_negative_definite_is_sound_and_not_vacuous(bounds):
    lo, hi = bounds
    verdict = interval_matrix_negative_definite(lo, hi)
    event(f"verdict {verdict}")
    C, R = (lo + hi) / 2, (hi - lo) / 2
    if np.linalg.eigvalsh(C).max() + np.linalg.eigvalsh(R).max() < -1e-6:
        assert verdict  # the midpoint-radius bound holds with a margin: the exact check must find it
    if not verdict:
        return
    rng = np.random.default_rng(RNG_SEED)
    inside = list(sample_symmetric(lo, hi, 200, rng))
    if lo.shape[0] <= 3:
        inside += vertices(lo, hi)
    assert max(np.linalg.eigvalsh(M).max() for M in inside) < 0
    assert interval_matrix_positive_definite(-hi, -lo)


def test_interval_known_false():
    singular = np.array([[-1.0, 1.0], [1.0, -1.0]])
    assert not interval_matrix_negative_definite(singular, singular)  # a singular matrix, exactly
    # contains the singular matrix at off-diagonal 1
    assert not interval_matrix_negative_definite(
        np.array([[-1.0, 0.0], [0.0, -1.0]]), np.array([[-1.0, 2.0], [2.0, -1.0]])
    )
    lo, hi = -np.eye(3) - 0.01, -np.eye(3) + 0.01
    assert interval_matrix_negative_definite(lo, hi)
    hi_positive = hi.copy()
    hi_positive[1, 1] = 0.5  # contains a matrix with a positive diagonal entry
    assert not interval_matrix_negative_definite(lo, hi_positive)
    hi_nan = hi.copy()
    hi_nan[0, 2] = np.nan
    assert not interval_matrix_negative_definite(lo, hi_nan)
    lo_inf = lo.copy()
    lo_inf[0, 0] = -np.inf
    assert not interval_matrix_negative_definite(lo_inf, hi)


def test_interval_exact_boundary():
    # -I + E with |E_01| <= r: eigenvalues -1 +- |E_01|, negative definite exactly when r < 1
    below = 1 - 2.0**-50
    assert interval_matrix_negative_definite(
        -np.eye(2) - [[0, below], [below, 0]], -np.eye(2) + [[0, below], [below, 0]]
    )
    assert not interval_matrix_negative_definite(-np.eye(2) - [[0, 1], [1, 0]], -np.eye(2) + [[0, 1], [1, 0]])


def test_interval_only_symmetric_members_count():
    lo, hi = -np.eye(2) - 0.1, -np.eye(2) + 0.1
    lo_asym = lo.copy()
    lo_asym[0, 1] = -5.0  # lo[1, 0] = -1.1 still bounds every symmetric member's off-diagonal
    assert interval_matrix_negative_definite(lo_asym, hi)
    with pytest.raises(ValueError, match="no symmetric"):
        interval_matrix_negative_definite(hi, lo)
    with pytest.raises(ValueError, match="square"):
        interval_matrix_negative_definite(np.zeros((2, 3)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="square"):
        interval_matrix_negative_definite(np.zeros((2, 2)), np.zeros((3, 3)))


def test_interval_positive_definite():
    lo, hi = np.eye(3) * 0.9 - 0.05, np.eye(3) * 1.1 + 0.05
    assert interval_matrix_positive_definite(lo, hi)
    inside = list(sample_symmetric(lo, hi, 100, np.random.default_rng(RNG_SEED))) + vertices(lo, hi)
    assert min(np.linalg.eigvalsh(M).min() for M in inside) > 0
    assert not interval_matrix_positive_definite(lo - 0.5, hi)


def test_only_the_exact_check_decides(monkeypatch):
    """White-box: the SDP is replaced by one returning a chosen ``P``; the exact check must judge it."""
    A = np.array([[-1.0, 10.0], [0.0, -1.0]])  # stable, but A + A^T has the eigenvalue 8: P = I is no certificate
    chosen = {"P": np.eye(2)}
    monkeypatch.setattr(quadratic_forms._LyapunovSDP, "solve", lambda self, a, fallback=True: (chosen["P"], "fake"))
    result = quadratic_lyapunov([A], decay=0.1)
    assert not result.verified and result.decay == 0.0
    # a true certificate of A for decay 0 (x^T P x with P = diag(1, 100) : A^T P + P A = [[-2, 10], [10, -200]] < 0)
    # but not for decay 0.99: -(A^T P + P A) - 2 (0.99) P = [[0.02, -10], [-10, 2]] has determinant -99.96
    chosen["P"] = np.diag([1.0, 100.0])
    result = quadratic_lyapunov([A], decay=0.99)
    assert result.verified and result.decay == 0.0
    result = quadratic_lyapunov([A], decay=0.25)  # [[1.5, -10], [-10, 150]]: determinant 125 > 0
    assert result.verified and result.decay == 0.25
    chosen["P"] = np.diag([1.0, -1.0])  # not positive definite
    assert not quadratic_lyapunov([-np.eye(2)], decay=0.0).verified
