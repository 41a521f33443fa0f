"""The second-order argument of ``fsmctl certify`` near the origin, where ``V_dot -> 0`` defeats plain enclosures.

In the scaled state ``y = D^-1 x`` (``D`` the region's half-widths, so the region is the unit box), Taylor's theorem
with the integral remainder gives, for every admissible uncertainty::

    W(y) = W(0) + g . y + y^T ( int_0^1 (1 - t) H(t y) dt ) y,     W = V_dot,  g = grad_y W(0),  H = hess_y W.

If every matrix of the interval enclosure of ``H + 2 mu I`` is negative definite on every sub-box of a core box
``C`` (a convex set containing 0, so the segment ``[0, y]`` stays in it), the averaged matrix is too, and

    W(y) <= w0 + G |y| - mu |y|^2   on C,     w0 >= W(0),  G >= |g| (over the uncertainty),

so ``W < 0`` on ``C`` outside the ball ``|y| <= r* = (G + sqrt(G^2 + 4 mu w0)) / (2 mu)`` (``r* = 0``: everywhere but
the origin, when the origin is an equilibrium: ``w0 = G = 0``, proved in ball arithmetic).  The negative
definiteness is proved box by box: Gershgorin's discs with outward rounding for many boxes at once, then the exact
midpoint-radius test (:func:`fsmctl.proofs.quadratic_forms.interval_matrix_negative_definite`) for the boxes where
the discs are too coarse; a box that passes neither is split.  Gershgorin's discs, Weyl's inequality and Rohn's
midpoint-radius bound are the only facts used (Horn & Johnson, Matrix Analysis, 6.1 and 4.3; Rohn 1994).
"""

from __future__ import annotations

import math
import time

import casadi as ca
import numpy as np

from fsmctl.enclosures.branch_bound import Budget
from fsmctl.enclosures.intervals import IntervalFunction
from fsmctl.proofs.quadratic_forms import interval_matrix_negative_definite

__all__ = ["CORE_FRACTIONS", "HESSIAN_BUDGET", "QuadraticCore", "quadratic_core"]

CORE_FRACTIONS = (1.0, 0.5, 0.25, 0.125, 0.0625)
"""core boxes tried, as fractions of the region's half-widths (largest first)"""
HESSIAN_BUDGET = Budget(max_boxes=20_000, max_seconds=600.0, batch=2048)
"""the box-by-box proof of negative definiteness on one core box (bounded by boxes: reproducible on re-check)"""
MIN_WIDTH = 1.0 / 64
"""a core sub-box narrower than this (in the scaled coordinates) is not split: the core fraction fails"""
UNCERTAINTY_SPLIT_WEIGHT = 0.25
"""an uncertainty input is split only when it is this many times wider (relative to its range) than every state
input: the Hessian depends on the uncertainty mildly and on the state strongly"""
EXACT_PER_BATCH = 256
"""boxes of a batch checked with the exact midpoint-radius test when Gershgorin's discs fail"""


class QuadraticCore(dict):
    """The outcome of :func:`quadratic_core` (a dict, for the certificate's JSON).

    Keys: ``passed``; when passed ``fraction`` (of the region), ``half_widths`` (of the core box, unscaled),
    ``mu``, ``w0``, ``G``, ``r_star`` (in scaled units), ``boxes``; otherwise ``why``.
    """


def _down(x):
    return np.nextafter(x, -np.inf)


def _up(x):
    return np.nextafter(x, np.inf)


def _gershgorin_negative(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """``(N,)`` bool: every matrix in each ``(n, n, N)`` interval matrix is negative definite by Gershgorin.

    Row ``i``: ``H_ii + sum_j!=i |H_ij| < 0`` with the upper bound ``hi_ii`` and ``max(|lo_ij|, |hi_ij|)``, summed
    with upward rounding.
    """
    n = lo.shape[0]
    mag = np.maximum(np.abs(lo), np.abs(hi))
    ok = np.ones(lo.shape[2], bool)
    for i in range(n):
        total = hi[i, i].copy()
        for j in range(n):
            if j != i:
                total = _up(total + mag[i, j])
        ok &= total < 0
    return ok & np.all(np.isfinite(lo) & np.isfinite(hi), axis=(0, 1))


def _scaled_hessians(H: IntervalFunction, lo, hi, n: int, scale: np.ndarray, mu: float):
    """Enclosures of ``D H D + 2 mu I`` on boxes (columns), symmetrised by intersection, and their continuity."""
    e = H.enclose(lo, hi)
    N = lo.shape[1]
    hlo = e.lo.reshape(n, n, N, order="F")
    hhi = e.hi.reshape(n, n, N, order="F")
    hlo = np.maximum(hlo, hlo.transpose(1, 0, 2))  # H is symmetric: both enclosures hold
    hhi = np.minimum(hhi, hhi.transpose(1, 0, 2))
    s = np.outer(scale, scale)[:, :, None]
    with np.errstate(invalid="ignore"):
        a, b = hlo * s, hhi * s
    hlo, hhi = _down(np.minimum(a, b)), _up(np.maximum(a, b))
    idx = np.arange(n)
    hlo[idx, idx] = _down(hlo[idx, idx] + 2 * mu)
    hhi[idx, idx] = _up(hhi[idx, idx] + 2 * mu)
    bad = np.isnan(hlo) | np.isnan(hhi)
    hlo, hhi = np.where(bad, -np.inf, hlo), np.where(bad, np.inf, hhi)
    return hlo, hhi, e.continuous


def _negative_definite_on(H, lo0, hi0, n, scale, mu, budget: Budget) -> tuple[bool, int]:
    """Whether ``D H D + 2 mu I`` is negative definite on every sub-box of ``[lo0, hi0]`` (split as needed)."""
    width0 = np.where(hi0 > lo0, hi0 - lo0, 1.0)
    weight = np.where(np.arange(lo0.size) < n, 1.0, UNCERTAINTY_SPLIT_WEIGHT)
    queue_lo, queue_hi = lo0[:, None].copy(), hi0[:, None].copy()
    boxes, t0 = 0, time.perf_counter()
    while queue_lo.shape[1]:
        if boxes >= budget.max_boxes or time.perf_counter() - t0 > budget.max_seconds:
            return False, boxes
        take = min(budget.batch, queue_lo.shape[1])
        blo, bhi = queue_lo[:, :take], queue_hi[:, :take]
        queue_lo, queue_hi = queue_lo[:, take:], queue_hi[:, take:]
        boxes += take
        hlo, hhi, continuous = _scaled_hessians(H, blo, bhi, n, scale, mu)
        ok = _gershgorin_negative(hlo, hhi) & continuous
        for k in np.flatnonzero(~ok & continuous)[:EXACT_PER_BATCH]:
            if np.all(np.isfinite(hlo[:, :, k])) and np.all(np.isfinite(hhi[:, :, k])):
                ok[k] = interval_matrix_negative_definite(hlo[:, :, k], hhi[:, :, k])
        blo, bhi = blo[:, ~ok], bhi[:, ~ok]
        if blo.shape[1] == 0:
            continue
        rel = (bhi - blo) / width0[:, None]
        if np.any(rel.max(axis=0) <= MIN_WIDTH):
            return False, boxes
        dims = (rel * weight[:, None]).argmax(axis=0)
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
    precision : int
        Bits of the ball arithmetic at the origin.

    Returns
    -------
    QuadraticCore
    """
    xs = x[:n]
    H = IntervalFunction(ca.Function("H", [x], [ca.hessian(W, xs)[0]]))
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
        return QuadraticCore(passed=False, why="the Hessian of V_dot at the origin is not negative definite")
    t0, total = time.perf_counter(), 0
    for frac in fractions:
        for mu in (-top / 16,):
            clo, chi = lo.copy(), hi.copy()
            clo[:n], chi[:n] = lo[:n] * frac, hi[:n] * frac
            ok, boxes = _negative_definite_on(H, clo, chi, n, scale, mu, budget)
            total += boxes
            if ok:
                r = (g0 + math.sqrt(g0 * g0 + 4 * mu * w0)) / (2 * mu) if (g0 or w0) else 0.0
                return QuadraticCore(
                    passed=True, fraction=frac, half_widths=(scale * frac).tolist(), mu=mu, w0=w0, G=g0,
                    r_star=_up(r * (1 + 1e-12)) if r > 0 else 0.0, boxes=total, seconds=time.perf_counter() - t0,
                )  # fmt: skip
    return QuadraticCore(
        passed=False, why="the Hessian of V_dot is not negative definite on any core box tried", boxes=total
    )
