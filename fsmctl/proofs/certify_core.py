"""The second-order argument of ``fsmctl certify`` near the origin, where ``V_dot -> 0`` defeats plain enclosures.

In the scaled state ``y = D^-1 x`` (``D`` the region's half-widths, so the region is the unit box), Taylor's theorem
with the integral remainder gives, for every admissible uncertainty::

    W(y) = W(0) + g . y + y^T ( int_0^1 (1 - t) H(t y) dt ) y,     W = V_dot,  g = grad_y W(0),  H = hess_y W.

If every matrix of the interval enclosure of ``H + 2 mu I`` is negative definite on every sub-box of a core box
``C`` (a convex set containing 0, so the segment ``[0, y]`` stays in it), the averaged matrix is too, and

    W(y) <= w0 + G |y| - mu |y|^2   on C,     w0 >= W(0),  G >= |g| (over the uncertainty),

so ``W < 0`` on ``C`` outside the ball ``|y| <= r* = (G + sqrt(G^2 + 4 mu w0)) / (2 mu)`` (``r* = 0``: everywhere but
the origin, when the origin is an equilibrium: ``w0 = G = 0``, proved in ball arithmetic).  The negative
definiteness is proved box by box (:class:`_HessianTest`): after the congruence that makes the nominal Hessian
``-I``, Weyl's inequality on the mean-value form of ``H`` (third derivatives enclosed on the box), else Gershgorin's
discs of the natural enclosure; a box that passes neither is split along the input whose term of the mean-value bound
is largest.  Uniform core boxes are tried from the smallest up, the largest that passes is kept, then grown along
each state input on its own while the test holds.  Sylvester's law of
inertia, Weyl's inequality and Gershgorin's discs are the only facts used (Horn & Johnson, Matrix Analysis, 2nd ed.,
4.5.8, 4.3.1 and 6.1.1).
"""

from __future__ import annotations

import math
import time

import casadi as ca
import numpy as np

from fsmctl.enclosures.branch_bound import Budget
from fsmctl.enclosures.intervals import IntervalFunction

__all__ = ["CORE_FRACTIONS", "HESSIAN_BUDGET", "QuadraticCore", "quadratic_core"]

CORE_FRACTIONS = (1.0, 0.5, 0.25, 0.125, 0.0625)
"""core boxes tried, as fractions of the region's half-widths (smallest first, up to the first that fails)"""
HESSIAN_BUDGET = Budget(max_boxes=10_000, max_seconds=600.0, batch=2048)
"""the box-by-box proof of negative definiteness on one core box (bounded by boxes: reproducible on re-check)"""
MIN_WIDTH = 1.0 / 64
"""a core sub-box narrower than this (in the scaled coordinates) is not split: the core fraction fails"""


class QuadraticCore(dict):
    """The outcome of :func:`quadratic_core` (a dict, for the certificate's JSON).

    Keys: ``passed``; when passed ``fractions`` (of the region's half-widths, per state input), ``fraction`` (their
    least), ``half_widths`` (of the core box, unscaled),
    ``mu``, ``w0``, ``G``, ``r_star`` (in scaled units), ``boxes``; otherwise ``why`` (and ``semidefinite`` when the
    nominal Hessian at the origin is not negative definite: ``V_dot`` does not decrease quadratically in some
    direction, so no certificate is expected near the origin).
    """


def _down(x):
    return np.nextafter(x, -np.inf)


def _up(x):
    return np.nextafter(x, np.inf)


U = 2.0**-53
"""the unit roundoff of float64"""


class _HessianTest:
    """Negative definiteness of ``D H D + 2 mu I`` on boxes, proved with the congruence ``T`` (Sylvester's law of
    inertia: ``T^T M T`` is negative definite iff ``M`` is, for any invertible ``T``) that makes the nominal Hessian
    ``-I``, so that Gershgorin's discs are sharp near it.

    Two bounds, a box passing either is proved:

    - *mean value* (Weyl): ``H(x) in H(c) + sum_k (x_k - c_k) dH/dx_k (X)``, so
      ``lambda_max(T^T M(x) T) <= lambda_max(T^T M(c) T) + sum_k r_k rho(T^T dH/dx_k(X) T)``; the first term by
      Gershgorin's discs, each ``rho`` by the infinity norm, the interval matrices in midpoint-radius form
      (``T^T [m +- r] T`` is inside ``T^T m T +- |T|^T r |T|``).  Valid where ``H`` is Lipschitz on the box (the
      evaluator proves no switch of ``dH`` flips there and the enclosure is finite).  The terms ``r_k rho_k`` say which
      input to split;
    - *natural*: Gershgorin's discs of ``T^T [H(X) + 2 mu I] T`` (only ``H`` continuous on the box).

    The float products are enclosed with the a priori bound ``|fl(sum) - sum| <= gamma_k sum |terms|``,
    ``gamma_k = k u / (1 - k u)`` (Higham, Accuracy and Stability of Numerical Algorithms, 2nd ed., eq 3.5), taken
    with twice the number of terms.
    """

    def __init__(
        self, x: ca.SX, W: ca.SX, n: int, lo: np.ndarray, hi: np.ndarray, scale: np.ndarray, mu: float, h0: np.ndarray
    ):
        """``h0``: the scaled Hessian at the nominal point (``(n, n)``), for the congruence."""
        self.n, self.mu = n, mu
        self.vary = np.flatnonzero(hi > lo)
        D = ca.diag(ca.DM(scale))
        Hs = ca.vec(D @ ca.hessian(W, x[:n])[0] @ D)
        self.H = IntervalFunction(ca.Function("hessian_scaled", [x], [Hs]))
        xv = ca.vertcat(*[x[int(k)] for k in self.vary]) if self.vary.size else ca.SX(0, 1)
        self.dH = IntervalFunction(ca.Function("hessian_scaled_jacobian", [x], [ca.jacobian(Hs, xv)]))
        lam, Q = np.linalg.eigh(0.5 * (h0 + h0.T))
        self.T = Q / np.sqrt(np.abs(lam))  # any invertible T is sound; this one makes T^T H0 T = -I
        self.absT = np.abs(self.T)
        self.gamma = 2 * (2 * n * n + 2) * U / (1 - 2 * (2 * n * n + 2) * U)

    def _congruence(self, mid: np.ndarray, rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``T^T [mid +- rad] T`` as midpoint and radius (``(n, n, N)``), the products' rounding in the radius."""
        T, A, g = self.T, self.absT, self.gamma
        m = np.einsum("ki,kln,lj->ijn", T, mid, T)
        r = np.einsum("ki,kln,lj->ijn", A, rad + g * np.abs(mid), A) * (1 + 2 * g)
        return m, r

    def _top(self, m: np.ndarray, r: np.ndarray) -> np.ndarray:
        """Gershgorin's upper bound of the largest eigenvalue of every symmetric matrix in ``m +- r``."""
        off = np.abs(m) + r
        idx = np.arange(self.n)
        diag = m[idx, idx] + r[idx, idx]
        rows = off.sum(axis=1) - off[idx, idx]
        return (diag + rows + self.gamma * (np.abs(diag) + rows)).max(axis=0)

    def _rho(self, m: np.ndarray, r: np.ndarray) -> np.ndarray:
        """The infinity norm (a bound of the spectral radius) of every matrix in ``m +- r``."""
        rows = (np.abs(m) + r).sum(axis=1)
        return (rows * (1 + self.gamma)).max(axis=0)

    def _matrices(self, lo: np.ndarray, hi: np.ndarray, shift: float) -> tuple[np.ndarray, np.ndarray]:
        N, n = lo.shape[-1], self.n
        L, H = lo.reshape(n, n, N, order="F"), hi.reshape(n, n, N, order="F")
        L, H = np.maximum(L, L.transpose(1, 0, 2)), np.minimum(H, H.transpose(1, 0, 2))  # H is symmetric
        mid = 0.5 * (L + H)
        rad = _up(_up(0.5 * (H - L)) + U * np.abs(mid))
        return mid + shift * np.eye(n)[:, :, None], rad

    def __call__(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(proved (N,), contributions (len(vary), N))`` on boxes (columns)."""
        N = lo.shape[1]
        c = np.minimum(np.maximum(0.5 * (lo + hi), lo), hi)
        ec = self.H.enclose(c, c)
        top = self._top(*self._congruence(*self._matrices(ec.lo, ec.hi, 2 * self.mu)))
        g = self.dH.enclose(lo, hi)
        nv = self.vary.size
        glo = g.lo.reshape(self.n * self.n, nv, N, order="F")
        ghi = g.hi.reshape(self.n * self.n, nv, N, order="F")
        contrib = np.zeros((nv, N))
        with np.errstate(invalid="ignore", over="ignore"):
            for a, k in enumerate(self.vary):
                r = _up(np.maximum(hi[k] - c[k], c[k] - lo[k]))
                contrib[a] = self._rho(*self._congruence(*self._matrices(glo[:, a], ghi[:, a], 0.0))) * r
            total = top + contrib.sum(axis=0)
            total = total + self.gamma * (np.abs(top) + contrib.sum(axis=0))
        valid = g.continuous & np.all(np.isfinite(glo) & np.isfinite(ghi), axis=(0, 1))
        proved = valid & np.isfinite(total) & (total < 0)
        rest = ~proved
        if rest.any():
            e = self.H.enclose(lo[:, rest], hi[:, rest])
            with np.errstate(invalid="ignore", over="ignore"):
                natural = self._top(*self._congruence(*self._matrices(e.lo, e.hi, 2 * self.mu)))
            proved[rest] = e.continuous & np.isfinite(natural) & (natural < 0)
        contrib = np.where(np.isfinite(contrib), contrib, np.inf)
        return proved, contrib


def _negative_definite_on(test: _HessianTest, lo0, hi0, budget: Budget) -> tuple[bool, int]:
    """Whether ``D H D + 2 mu I`` is negative definite on every sub-box of ``[lo0, hi0]`` (split as needed: the
    input with the largest term of the mean-value bound, else the widest relative to its range)."""
    width0 = np.where(hi0 > lo0, hi0 - lo0, 1.0)
    queue_lo, queue_hi = lo0[:, None].copy(), hi0[:, None].copy()
    boxes, t0 = 0, time.perf_counter()
    while queue_lo.shape[1]:
        if boxes >= budget.max_boxes or time.perf_counter() - t0 > budget.max_seconds:
            return False, boxes
        take = min(budget.batch, queue_lo.shape[1])
        blo, bhi = queue_lo[:, :take], queue_hi[:, :take]
        queue_lo, queue_hi = queue_lo[:, take:], queue_hi[:, take:]
        boxes += take
        ok, contrib = test(blo, bhi)
        blo, bhi, contrib = blo[:, ~ok], bhi[:, ~ok], contrib[:, ~ok]
        if blo.shape[1] == 0:
            continue
        rel = (bhi - blo) / width0[:, None]
        if np.any(rel.max(axis=0) <= MIN_WIDTH):
            return False, boxes
        smear = np.where(np.isfinite(contrib).all(axis=0), contrib.argmax(axis=0), -1)
        widest = rel.argmax(axis=0)
        dims = np.where(smear >= 0, test.vary[np.maximum(smear, 0)], widest)
        cols = np.arange(blo.shape[1])
        mid = 0.5 * (blo[dims, cols] + bhi[dims, cols])
        lo2, hi2 = np.concatenate([blo, blo], axis=1), np.concatenate([bhi, bhi], axis=1)
        hi2[dims, cols] = mid
        lo2[dims, blo.shape[1] + cols] = mid
        queue_lo, queue_hi = np.concatenate([queue_lo, lo2], axis=1), np.concatenate([queue_hi, hi2], axis=1)
    return True, boxes


def _origin_values(W: IntervalFunction, G: IntervalFunction, lo, hi, n, scale, precision) -> tuple[float, float]:
    """``w0 >= W(0)`` and ``G >= |grad_y W(0)|`` over the uncertainty, in ball arithmetic."""
    lo, hi = lo.copy(), hi.copy()
    lo[:n], hi[:n] = 0.0, 0.0
    _, w_hi = W.enclose_arb(lo, hi, precision=precision)
    g_lo, g_hi = G.enclose_arb(lo, hi, precision=precision)
    g = np.maximum(np.abs(g_lo), np.abs(g_hi)) * scale
    norm = 0.0 if not np.any(g) else _up(float(np.sqrt(_up(np.sum(_up(g * g))))))
    return max(float(w_hi[0]), 0.0), norm


def quadratic_core(
    x: ca.SX,
    W: ca.SX,
    n: int,
    lo: np.ndarray,
    hi: np.ndarray,
    *,
    fractions=CORE_FRACTIONS,
    budget: Budget = HESSIAN_BUDGET,
    precision: int = 256,
    box: np.ndarray | None = None,
) -> QuadraticCore:
    """The largest core box on which the second-order argument holds (see the module docstring).

    Parameters
    ----------
    x : casadi.SX
        The input vector (state first).
    W : casadi.SX
        ``V_dot`` as an expression of ``x``.
    n : int
        The state's length.
    lo, hi : numpy.ndarray
        The region x uncertainty box.
    fractions : sequence of float
        Core boxes tried (fractions of the region's state half-widths).
    budget : Budget
        Per core box.
    box : numpy.ndarray, optional
        ``(n,)`` fractions of the region's half-widths per state input: test exactly this core box (a re-check)
        instead of searching the largest.
    precision : int
        Bits of the ball arithmetic at the origin.

    Returns
    -------
    QuadraticCore
    """
    xs = x[:n]
    G = IntervalFunction(ca.Function("G", [x], [ca.gradient(W, xs)]))
    Wf = IntervalFunction(ca.Function("W", [x], [W]))
    scale = np.maximum(np.abs(lo[:n]), np.abs(hi[:n]))
    w0, g0 = _origin_values(Wf, G, lo, hi, n, scale, precision)
    nominal = 0.5 * (lo + hi)
    h0 = np.array(ca.Function("H0", [x], [ca.hessian(W, xs)[0]])(nominal), float) * np.outer(scale, scale)
    if not np.all(np.isfinite(h0)):
        return QuadraticCore(passed=False, why="V_dot has no Hessian at the origin (a switching or fractional term)")
    top = float(np.linalg.eigvalsh(0.5 * (h0 + h0.T)).max())
    if top >= 0:
        return QuadraticCore(
            passed=False, why="the Hessian of V_dot at the origin is not negative definite", semidefinite=True
        )
    mu = -top / 16
    test = _HessianTest(x, W, n, lo, hi, scale, mu, h0)
    t0, total = time.perf_counter(), 0
    if box is not None:  # the re-check: exactly this core box
        f = np.asarray(box, float)
        ok, total = _negative_definite_on(test, *_core_box(lo, hi, n, f), budget)
    else:
        f, total = _largest_core(test, lo, hi, n, fractions, budget)
        ok = f is not None
    if ok:
        r = (g0 + math.sqrt(g0 * g0 + 4 * mu * w0)) / (2 * mu) if (g0 or w0) else 0.0
        return QuadraticCore(
            passed=True, fraction=float(f.min()), fractions=f.tolist(), half_widths=(scale * f).tolist(), mu=mu,
            w0=w0, G=g0, r_star=_up(r * (1 + 1e-12)) if r > 0 else 0.0, boxes=total,
            seconds=time.perf_counter() - t0,
        )  # fmt: skip
    return QuadraticCore(
        passed=False, why="the Hessian of V_dot is not negative definite on any core box tried", boxes=total
    )


GROWTH_SHARE = 8
"""a core box grown along one state input gets ``1 / GROWTH_SHARE`` of the budget (most such attempts fail)"""


def _core_box(lo: np.ndarray, hi: np.ndarray, n: int, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    clo, chi = lo.copy(), hi.copy()
    clo[:n], chi[:n] = lo[:n] * f, hi[:n] * f
    return clo, chi


def _largest_core(test, lo, hi, n: int, fractions, budget: Budget) -> tuple[np.ndarray | None, int]:
    """The uniform fractions from the smallest up (the largest that passes), then each state input's fraction
    doubled (up to 1) while the test still holds: ``(per-input fractions or None, boxes)``."""
    best, total = None, 0
    for frac in sorted(fractions):
        ok, boxes = _negative_definite_on(test, *_core_box(lo, hi, n, np.full(n, frac)), budget)
        total += boxes
        if not ok:
            break
        best = frac
    if best is None:
        return None, total
    f = np.full(n, float(best))
    small = Budget(max_boxes=budget.max_boxes // GROWTH_SHARE, max_seconds=budget.max_seconds, batch=budget.batch)
    for k in range(n):
        while f[k] < 1:
            g = f.copy()
            g[k] = min(1.0, 2 * f[k])
            ok, boxes = _negative_definite_on(test, *_core_box(lo, hi, n, g), small)
            total += boxes
            if not ok:
                break
            f = g
    return f, total
