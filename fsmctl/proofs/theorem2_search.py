"""The branch and bound behind :mod:`fsmctl.proofs.theorem2_bound`: certified maxima of a function's outputs over a
union of boxes.

:func:`search_maxima` is a best-first branch and bound on :class:`~fsmctl.enclosures.intervals.IntervalFunction`
enclosures (outward rounding); its enclosure of a box is the natural extension intersected with the mean-value form
about the centre and, near the Remark 6 band, about a face (:func:`_enclose_upper`); with one output a box on which
the function is monotone in an input is reduced to the face holding the maximum.  It starts from several boxes
(:func:`band_pieces`) and from witnesses found in floats (:func:`local_maxima`), and returns ``lower <= max <= upper``
per output, ``upper`` certified whatever the budget.

What :func:`fsmctl.enclosures.branch_bound.bound_maximum` would need to serve here: several start boxes, starting
witnesses, several outputs at once, an enclosure hook (the face form) and a "known Lipschitz" flag for the mean-value
form and the monotonicity test.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import casadi as ca
import numpy as np
from scipy import optimize

from fsmctl.enclosures.intervals import IntervalFunction

__all__ = [
    "BAND_SHRINK",
    "BATCH",
    "LOCAL_STARTS",
    "Maxima",
    "band_pieces",
    "local_maxima",
    "search_maxima",
    "seed_points",
]

BAND_SHRINK = 0.05
"""The pieces of the Remark 6 band: ``|sigma_e,k| <= (1 - BAND_SHRINK) epsilon`` and the two outer pieces from that
bound outwards (they overlap the band's piece at its end: the pieces cover the box).

The law recomputes ``sigma_e`` from the state (an MRP-quaternion-MRP round trip, the identity for ``|sigma| < 1``),
which interval arithmetic widens by a relative ``O(|sigma|^2)`` (below 1% on ``|sigma_e,k| <= 0.05``).  Cut 5%
inside the band, the band's piece decides the law's test ``|sigma_e,k| >= epsilon`` false (the singular branch
``|sigma_e,k|^(alpha-1)`` is dropped) and the outer pieces keep that branch away from 0: every piece is finite."""

BATCH = 2048
"""Boxes split per pass of the search (more when the queue is long: an eighth of it)."""


def band_pieces(lo: np.ndarray, hi: np.ndarray, epsilon: float | None) -> tuple[np.ndarray, np.ndarray]:
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
class Maxima:
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


def _enclose_upper(f: IntervalFunction, jac: IntervalFunction, lo, hi, lipschitz: bool, epsilon: float | None = None):
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
    """Upper bounds of the mean-value form about the faces of :func:`_enclose_upper` (inf where no ``sigma_e`` component
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


def search_maxima(
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
) -> Maxima:
    """Best-first branch and bound of the maxima of all outputs of ``f`` at once over the union of the start boxes
    ``(n, P)``.

    One queue holds every box that may still hold the maximum of some output (its upper bound exceeds that output's
    best certified value by more than the gap); each pass splits the boxes of largest relative excess, in two, along
    the input of largest ``width x |gradient|`` (gradient of the output with the largest excess).  With one output a
    box where ``f`` is monotone in an input is reduced to the face holding the maximum (:func:`_to_faces`).
    ``upper[k]`` is the largest upper bound of output ``k`` over the queue and over every box dropped (a dropped box's
    bound is kept); ``lower[k]`` the best certified value at a point: box centres and ``seeds`` ``(n, S)``.

    Parameters
    ----------
    f, jac : IntervalFunction
        The function (``m`` outputs) and its Jacobian (``m x n``, column-major).
    lo, hi : numpy.ndarray
        ``(n, P)`` start boxes (their union is searched).
    seconds, max_boxes : float, int
        Budget.
    relative_gap : float
        Stop when ``upper - lower <= relative_gap * upper`` for every output.
    lipschitz : bool
        ``f`` is known Lipschitz on every box (the mean-value form and the monotonicity test apply even where the
        evaluator flags a possible switch).
    seeds : numpy.ndarray
        ``(n, S)`` points evaluated first (witness candidates).
    epsilon : float, optional
        The Remark 6 band's half-width (the face form near ``|x_j| = epsilon``, ``j < 3``).

    Returns
    -------
    Maxima

    Examples
    --------
    ``max sin(x) cos(y)`` over ``[0, 3] x [-1, 1]`` is 1, at ``(pi/2, 0)``, searched from two halves:

    >>> import casadi as ca, numpy as np
    >>> x = ca.SX.sym("x", 2)
    >>> e = ca.sin(x[0]) * ca.cos(x[1])
    >>> f = IntervalFunction(ca.Function("f", [x], [e]))
    >>> jac = IntervalFunction(ca.Function("j", [x], [ca.jacobian(e, x)]))
    >>> lo, hi = np.array([[0.0, 1.5], [-1.0, -1.0]]), np.array([[1.5, 3.0], [1.0, 1.0]])
    >>> m = search_maxima(f, jac, lo, hi, seconds=10, max_boxes=10**5, relative_gap=1e-6, lipschitz=False,
    ...                   seeds=np.zeros((2, 1)))
    >>> bool(m.converged[0]), bool(m.lower[0] <= 1 <= m.upper[0]), bool(m.upper[0] - m.lower[0] < 1e-5)
    (True, True, True)
    """
    t0 = time.perf_counter()
    m = f.n_out
    scale = np.where(hi.max(axis=1) > lo.min(axis=1), hi.max(axis=1) - lo.min(axis=1), 1.0)
    qlo, qhi = lo.copy(), hi.copy()
    qub, glo, ghi, valid, c, at = _enclose_upper(f, jac, qlo, qhi, lipschitz, epsilon)
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
            return Maxima(upper, best, witness, boxes, converged, time.perf_counter() - t0)
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
        nub, glo, ghi, valid, c, at = _enclose_upper(f, jac, nlo, nhi, lipschitz, epsilon)
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


def seed_points(lo: np.ndarray, hi: np.ndarray, n: int = 256) -> np.ndarray:
    """``(15, 2n)`` seeded points of the box: random corners and uniform points (first witnesses of the search)."""
    rng = np.random.default_rng(0)
    x = lo[:, None] + (hi - lo)[:, None] * rng.integers(0, 2, (lo.size, n))
    return np.hstack([x, lo[:, None] + (hi - lo)[:, None] * rng.uniform(0, 1, (lo.size, n))])


LOCAL_STARTS = 3
"""Starts per output of the float local search for the first witnesses: the best seeds, and the same with every
``sigma_e`` component at 0 (the centre of the Remark 6 band, where its slope ``r1`` is largest)."""


def local_maxima(floats: ca.Function, lo: np.ndarray, hi: np.ndarray, seeds: np.ndarray) -> np.ndarray:
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
