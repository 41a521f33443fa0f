"""Branch and bound on rigorous enclosures: prove a sign over a box, or bound a maximum.

Both searches split boxes of the input space of an :class:`~fsmctl.enclosures.intervals.IntervalFunction` and
decide each box from an enclosure of the function over it, so every statement they make holds for every point of
the boxes it names:

- :func:`prove_negative` partitions a box into leaves on which ``f < threshold`` is *proved* (the enclosure's upper
  bound is below it), leaves that contain a point where ``f > threshold`` is *proved* (a rigorous enclosure of the
  function at that point lies above it: a counterexample), leaves the caller handles by another argument
  (``exclude``) and *undecided* leaves (too small to split further, or the budget ran out).  The leaves cover the
  box exactly.
- :func:`bound_maximum` returns ``lower <= max f <= upper``: ``upper`` bounds ``f`` on every box not yet discarded,
  ``lower`` is a rigorous lower bound of ``f`` at a witness point.

The enclosure of a box is the natural interval extension intersected, where it is valid, with the mean-value form
``f(c) + sum_i [df/dx_i](X) (X_i - c_i)`` (Moore, Kearfott & Cloud 2009, ch. 6): valid when ``f`` is Lipschitz on
the box, i.e. no discontinuous operation switches inside it (``Enclosure.continuous``) and the gradient's
enclosure is finite; by Lebourg's mean-value theorem the Clarke gradient on the segment lies in the gradient's
interval enclosure.  Boxes are split in two along the input with the largest ``width x |gradient|`` (the
"smear" rule), or the largest width relative to the initial box.

Every rounding of the bookkeeping (the offsets ``X_i - c_i``, the products and the sum of the mean-value form) is
outward (:func:`numpy.nextafter`), as in the evaluator.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from fsmctl.enclosures.intervals import IntervalFunction

__all__ = [
    "EXCLUDED",
    "POSITIVE",
    "PROVED",
    "UNDECIDED",
    "Budget",
    "MaximumBound",
    "SignSearch",
    "bisection_leaves",
    "bound_maximum",
    "enclose_sharp",
    "prove_negative",
    "volume_share",
]

_INF = np.inf
PROVED, POSITIVE, UNDECIDED, EXCLUDED = -1, -2, -3, -4
"""leaf codes of :attr:`SignSearch.codes` (a code >= 0 is the input a box was split along)"""


@dataclass(frozen=True)
class Budget:
    """How much work a search may do before it stops and reports what it has.

    Parameters
    ----------
    max_boxes : int
        Boxes evaluated in all.
    max_seconds : float
        Wall-clock seconds.
    batch : int
        Boxes evaluated per NumPy pass (memory and speed; the result does not depend on it except through where a
        budget stops the search).
    """

    max_boxes: int = 200_000
    max_seconds: float = 60.0
    batch: int = 2048

    def __post_init__(self) -> None:
        if self.max_boxes < 1 or not self.max_seconds > 0 or self.batch < 1:
            raise ValueError(f"Budget: max_boxes, max_seconds and batch must be positive, got {self}")


def _down(x: np.ndarray) -> np.ndarray:
    return np.nextafter(x, -_INF)


def _up(x: np.ndarray) -> np.ndarray:
    return np.nextafter(x, _INF)


def _interval_product(alo, ahi, blo, bhi) -> tuple[np.ndarray, np.ndarray]:
    """Outward-rounded product of intervals (NaN from ``0 * inf`` taken as the sound infinite bound)."""
    with np.errstate(invalid="ignore", over="ignore"):
        p = np.stack([alo * blo, alo * bhi, ahi * blo, ahi * bhi])
    lo = np.where(np.isnan(p), -_INF, p).min(axis=0)
    hi = np.where(np.isnan(p), _INF, p).max(axis=0)
    return _down(lo), _up(hi)


def enclose_sharp(
    f: IntervalFunction,
    lo: np.ndarray,
    hi: np.ndarray,
    *,
    output: int = 0,
    gradient: IntervalFunction | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Enclosure of ``y[output]`` over boxes: the natural extension intersected with the mean-value form.

    Parameters
    ----------
    f : IntervalFunction
        The function.
    lo, hi : numpy.ndarray
        ``(n_in, N)`` box bounds.
    output : int
        Which output of ``f``.
    gradient : IntervalFunction, optional
        Outputs the ``n_in`` partial derivatives of ``y[output]`` (e.g. ``casadi.jacobian`` of it); without it the
        natural extension alone.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray, numpy.ndarray or None)
        Lower and upper bounds ``(N,)``, and the gradient's magnitude bound ``(n_in, N)`` (None without a
        gradient) for the splitting rule.

    Examples
    --------
    ``x^2 - x`` on ``[0, 1]``: the natural extension gives ``[-1, 1]``, the mean-value form about ``1/2`` gives
    ``[-1/4 - 1/2, -1/4 + 1/2]``; their intersection is ``[-0.75, 0.25]`` (the range is ``[-0.25, 0]``):

    >>> import casadi as ca, numpy as np
    >>> from fsmctl.enclosures.intervals import IntervalFunction
    >>> from fsmctl.enclosures.branch_bound import enclose_sharp
    >>> x = ca.SX.sym("x")
    >>> f = IntervalFunction(ca.Function("f", [x], [x**2 - x]))
    >>> g = IntervalFunction(ca.Function("g", [x], [ca.jacobian(x**2 - x, x)]))
    >>> low, high, _ = enclose_sharp(f, np.array([[0.0]]), np.array([[1.0]]), gradient=g)
    >>> float(low[0]), float(high[0])
    (-0.75..., 0.25...)
    """
    e = f.enclose(lo, hi)
    flo, fhi = e.lo[output].copy(), e.hi[output].copy()
    if gradient is None:
        return flo, fhi, None
    c = 0.5 * (lo + hi)  # a point of each box (rounded: still inside, and the offsets below are rounded outward)
    c = np.minimum(np.maximum(c, lo), hi)
    ec = f.enclose(c, c)
    g = gradient.enclose(lo, hi)
    mlo, mhi = ec.lo[output].copy(), ec.hi[output].copy()
    dlo, dhi = _down(lo - c), _up(hi - c)
    for i in range(lo.shape[0]):
        tlo, thi = _interval_product(g.lo[i], g.hi[i], dlo[i], dhi[i])
        mlo, mhi = _down(mlo + tlo), _up(mhi + thi)
    valid = e.continuous & np.all(np.isfinite(g.lo) & np.isfinite(g.hi), axis=0) & ~np.isnan(mlo) & ~np.isnan(mhi)
    flo = np.where(valid, np.maximum(flo, mlo), flo)
    fhi = np.where(valid, np.minimum(fhi, mhi), fhi)
    magnitude = np.maximum(np.abs(g.lo), np.abs(g.hi))
    return flo, fhi, np.where(np.isfinite(magnitude), magnitude, _INF)


def _split_dimension(lo, hi, scale, splittable, magnitude) -> np.ndarray:
    """The input to halve per box: largest ``width x |gradient|`` (or relative width without a gradient)."""
    width = (hi - lo) / scale[:, None]
    width = np.where(splittable[:, None], width, -1.0)
    if magnitude is not None:
        score = width * np.where(np.isfinite(magnitude), magnitude, 1e300) * scale[:, None]
        score = np.where(splittable[:, None] & (width > 0), score, -1.0)
        # a box whose smear is zero everywhere still splits its widest input
        use = score.max(axis=0) > 0
        return np.where(use, score.argmax(axis=0), width.argmax(axis=0))
    return width.argmax(axis=0)


def _halve(lo, hi, dims) -> tuple[np.ndarray, np.ndarray]:
    """Both halves of each box along ``dims``: ``(n, 2N)`` arrays (first halves, then second halves)."""
    n = lo.shape[1]
    cols = np.arange(n)
    mid = 0.5 * (lo[dims, cols] + hi[dims, cols])
    lo2, hi2 = np.concatenate([lo, lo], axis=1), np.concatenate([hi, hi], axis=1)
    hi2[dims, cols] = mid
    lo2[dims, n + cols] = mid
    return lo2, hi2


@dataclass
class SignSearch:
    """Outcome of :func:`prove_negative`: a partition of the box into leaves, by what is known on each.

    Every array of boxes is ``(k, n_in)`` (lower and upper corners row by row).
    """

    proved_lo: np.ndarray
    proved_hi: np.ndarray
    proved_sup: np.ndarray
    """``(k,)``: a certified upper bound of ``f`` on each proved leaf (below the threshold)"""
    positive_lo: np.ndarray
    positive_hi: np.ndarray
    positive_points: np.ndarray
    """``(m, n_in)``: a point of each such leaf where ``f > threshold`` is proved"""
    positive_values: np.ndarray
    """``(m,)``: a rigorous lower bound of ``f`` at that point"""
    undecided_lo: np.ndarray
    undecided_hi: np.ndarray
    excluded_lo: np.ndarray
    excluded_hi: np.ndarray
    boxes: int
    seconds: float
    exhausted: bool
    """the budget ran out before every leaf was decided"""
    volume: dict[str, float] = field(default_factory=dict)
    """fraction of the box's volume (over the inputs it spans) that is proved, positive, undecided, excluded"""
    codes: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int8))
    """the bisection tree: per box in processing order, the input it was split along (>= 0) or its leaf kind
    (:data:`PROVED`, :data:`POSITIVE`, :data:`UNDECIDED`, :data:`EXCLUDED`); :func:`bisection_leaves` rebuilds
    the leaves from it"""
    batch: int = 0
    """boxes per pass (the processing order depends on it)"""


def volume_share(lo: np.ndarray, hi: np.ndarray, scale: np.ndarray, spanned: np.ndarray) -> float:
    """The boxes' ``(N, n)`` rows' total volume as a share of a box of widths ``scale``, over the inputs ``spanned``
    (those of positive width): a search's ``volume`` fractions.

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.enclosures.branch_bound import volume_share
    >>> volume_share(np.array([[0.0, 0.0]]), np.array([[0.5, 0.5]]), np.array([1.0, 1.0]), np.array([True, True]))
    0.25
    """
    if lo.shape[0] == 0:
        return 0.0
    w = (hi - lo)[:, spanned] / scale[spanned]
    return float(np.prod(w, axis=1).sum())


def prove_negative(
    f: IntervalFunction,
    lo: np.ndarray,
    hi: np.ndarray,
    *,
    output: int = 0,
    gradient: IntervalFunction | None = None,
    threshold: float = 0.0,
    budget: Budget = Budget(),
    splittable: np.ndarray | None = None,
    min_width: float = 1e-4,
    exclude: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
    progress: Callable[[int, float], None] | None = None,
    stop_on_positive: bool = False,
) -> SignSearch:
    """Prove ``f(x) < threshold`` on a box by splitting it, or find points where ``f(x) > threshold``.

    Parameters
    ----------
    f : IntervalFunction
        The function; ``y[output]`` is judged.
    lo, hi : array_like
        ``(n_in,)`` corners of the box; inputs with ``lo == hi`` are fixed.
    output : int
        Which output.
    gradient : IntervalFunction, optional
        The partial derivatives of ``y[output]`` for the mean-value form (see :func:`enclose_sharp`).
    threshold : float
        What ``f`` must stay below (strictly).
    budget : Budget
        When to stop.
    splittable : array_like of bool, optional
        ``(n_in,)``: inputs that may be split (default: every input of positive width).
    min_width : float
        A leaf whose every splittable input is narrower than this fraction of the box's width there is left
        undecided rather than split.
    exclude : callable, optional
        ``exclude(lo, hi) -> (N,) bool`` on ``(n_in, N)`` boxes: True for a box that lies inside a set the caller
        proves by another argument (a leaf, not split further).
    progress : callable, optional
        ``progress(boxes_evaluated, fraction_decided)`` after each batch.
    stop_on_positive : bool
        Stop after the first batch that proves ``f > threshold`` somewhere (the boxes left are undecided).

    Returns
    -------
    SignSearch
        The leaves by kind, the effort and the volume fractions.

    Examples
    --------
    ``x^2 + y^2 - 1 < 0`` holds on ``[-0.5, 0.5]^2`` and fails at the corner region of ``[-1, 1]^2``:

    >>> import casadi as ca, numpy as np
    >>> from fsmctl.enclosures.intervals import IntervalFunction
    >>> from fsmctl.enclosures.branch_bound import prove_negative
    >>> x = ca.SX.sym("x", 2)
    >>> f = IntervalFunction(ca.Function("f", [x], [ca.sumsqr(x) - 1]))
    >>> s = prove_negative(f, [-0.5, -0.5], [0.5, 0.5])
    >>> s.volume["proved"], len(s.positive_points)
    (1.0, 0)
    >>> s = prove_negative(f, [-1, -1], [1, 1], min_width=0.01)
    >>> bool(len(s.positive_points) > 0), bool((s.positive_values > 0).all())
    (True, True)
    """
    lo0, hi0 = np.asarray(lo, float).ravel(), np.asarray(hi, float).ravel()
    n = lo0.size
    if n != f.n_in or hi0.size != n or np.any(~(lo0 <= hi0)) or not np.all(np.isfinite(lo0) & np.isfinite(hi0)):
        raise ValueError(f"prove_negative: need finite lo <= hi of length {f.n_in}")
    width0 = hi0 - lo0
    spanned = width0 > 0
    can = spanned.copy() if splittable is None else (np.asarray(splittable, bool).ravel() & spanned)
    scale = np.where(spanned, width0, 1.0)
    t0 = time.perf_counter()
    queue_lo, queue_hi = lo0[:, None].copy(), hi0[:, None].copy()
    kinds: dict[str, list] = {k: [] for k in ("proved", "positive", "undecided", "excluded")}
    codes: list[np.ndarray] = []  # the bisection tree, box by box in processing order (see bisection_leaves)
    boxes, exhausted = 0, False
    while queue_lo.shape[1]:
        if boxes >= budget.max_boxes or time.perf_counter() - t0 > budget.max_seconds:
            kinds["undecided"].append((queue_lo, queue_hi))
            codes.append(np.full(queue_lo.shape[1], UNDECIDED, np.int8))
            exhausted = True
            break
        take = min(budget.batch, queue_lo.shape[1])
        blo, bhi = queue_lo[:, :take], queue_hi[:, :take]
        queue_lo, queue_hi = queue_lo[:, take:], queue_hi[:, take:]
        code, idx = np.full(take, UNDECIDED, np.int8), np.arange(take)
        boxes += take
        if exclude is not None:
            out = np.asarray(exclude(blo, bhi), bool)
            kinds["excluded"].append((blo[:, out], bhi[:, out]))
            code[idx[out]] = EXCLUDED
            blo, bhi, idx = blo[:, ~out], bhi[:, ~out], idx[~out]
        _, fhi, mag = enclose_sharp(f, blo, bhi, output=output, gradient=gradient)
        proved = fhi < threshold
        kinds["proved"].append((blo[:, proved], bhi[:, proved], fhi[proved]))
        code[idx[proved]] = PROVED
        blo, bhi, idx = blo[:, ~proved], bhi[:, ~proved], idx[~proved]
        mag = None if mag is None else mag[:, ~proved]
        c = np.minimum(np.maximum(0.5 * (blo + bhi), blo), bhi)
        at = f.enclose(c, c).lo[output]
        positive = at > threshold
        kinds["positive"].append((blo[:, positive], bhi[:, positive], c[:, positive], at[positive]))
        code[idx[positive]] = POSITIVE
        keep = ~positive
        blo, bhi, idx, mag = blo[:, keep], bhi[:, keep], idx[keep], None if mag is None else mag[:, keep]
        small = np.all(np.where(can[:, None], (bhi - blo) <= min_width * scale[:, None], True), axis=0)
        kinds["undecided"].append((blo[:, small], bhi[:, small]))
        blo, bhi, idx, mag = blo[:, ~small], bhi[:, ~small], idx[~small], None if mag is None else mag[:, ~small]
        if blo.shape[1]:
            dims = _split_dimension(blo, bhi, scale, can, mag)
            code[idx] = dims
            nlo, nhi = _halve(blo, bhi, dims)
            queue_lo, queue_hi = np.concatenate([queue_lo, nlo], axis=1), np.concatenate([queue_hi, nhi], axis=1)
        codes.append(code)
        if stop_on_positive and positive.any() and queue_lo.shape[1]:
            kinds["undecided"].append((queue_lo, queue_hi))
            codes.append(np.full(queue_lo.shape[1], UNDECIDED, np.int8))
            break
        if progress is not None:
            pending = volume_share(queue_lo.T, queue_hi.T, scale, spanned)
            progress(boxes, 1.0 - pending)
    search = _sign_search(kinds, n, boxes, time.perf_counter() - t0, exhausted, scale, spanned)
    search.codes = np.concatenate(codes) if codes else np.zeros(0, np.int8)
    search.batch = budget.batch
    return search


def _stack(parts: list, n: int, matrices: int, vectors: int) -> list[np.ndarray]:
    """Concatenate the per-batch pieces of one leaf kind: ``matrices`` arrays of boxes as columns (returned as
    ``(k, n)`` rows), then ``vectors`` arrays of one value per box."""
    out = []
    for i in range(matrices + vectors):
        pieces = [p[i] for p in parts]
        if i < matrices:
            out.append(np.concatenate(pieces, axis=1).T.copy() if pieces else np.zeros((0, n)))
        else:
            out.append(np.concatenate(pieces) if pieces else np.zeros(0))
    return out


def _sign_search(kinds, n, boxes, seconds, exhausted, scale, spanned) -> SignSearch:
    plo, phi, psup = _stack(kinds["proved"], n, 2, 1)
    qlo, qhi, qpt, qval = _stack(kinds["positive"], n, 3, 1)
    ulo, uhi = _stack(kinds["undecided"], n, 2, 0)
    xlo, xhi = _stack(kinds["excluded"], n, 2, 0)
    volume = {
        "proved": volume_share(plo, phi, scale, spanned),
        "positive": volume_share(qlo, qhi, scale, spanned),
        "undecided": volume_share(ulo, uhi, scale, spanned),
        "excluded": volume_share(xlo, xhi, scale, spanned),
    }
    return SignSearch(plo, phi, psup, qlo, qhi, qpt, qval, ulo, uhi, xlo, xhi, boxes, seconds, exhausted, volume)


def bisection_leaves(lo, hi, codes: np.ndarray, batch: int) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """The leaves of a :func:`prove_negative` search rebuilt from its codes: a partition of the box by construction.

    The boxes are split at the same midpoints, in the same order, as in the search, so the leaves are the
    search's, bit for bit.

    Parameters
    ----------
    lo, hi : array_like
        The root box ``(n_in,)``.
    codes : numpy.ndarray
        :attr:`SignSearch.codes`.
    batch : int
        :attr:`SignSearch.batch`.

    Returns
    -------
    dict
        ``{kind: (lo, hi)}`` for each leaf code, boxes as rows ``(k, n_in)`` in processing order.

    Raises
    ------
    ValueError
        Codes that do not describe a complete bisection of the box.

    Examples
    --------
    >>> import casadi as ca, numpy as np
    >>> from fsmctl.enclosures.intervals import IntervalFunction
    >>> from fsmctl.enclosures.branch_bound import PROVED, bisection_leaves, prove_negative
    >>> x = ca.SX.sym("x", 2)
    >>> f = IntervalFunction(ca.Function("f", [x], [ca.sumsqr(x) - 1]))
    >>> s = prove_negative(f, [-0.6, -0.6], [0.6, 0.6])
    >>> leaves = bisection_leaves([-0.6, -0.6], [0.6, 0.6], s.codes, s.batch)
    >>> bool(np.array_equal(leaves[PROVED][0], s.proved_lo))
    True
    """
    lo0, hi0 = np.asarray(lo, float).ravel(), np.asarray(hi, float).ravel()
    n = lo0.size
    codes = np.asarray(codes)
    qlo, qhi = lo0[:, None].copy(), hi0[:, None].copy()
    parts: dict[int, list] = {k: [] for k in (PROVED, POSITIVE, UNDECIDED, EXCLUDED)}
    p = 0
    while qlo.shape[1]:
        take = min(batch, qlo.shape[1])
        code = codes[p : p + take]
        if code.size != take:
            raise ValueError("the codes end before the bisection does")
        p += take
        blo, bhi = qlo[:, :take], qhi[:, :take]
        qlo, qhi = qlo[:, take:], qhi[:, take:]
        for kind in parts:
            parts[kind].append((blo[:, code == kind], bhi[:, code == kind]))
        split = code >= 0
        if np.any(code[split] >= n) or np.any(~split & ~np.isin(code, list(parts))):
            raise ValueError("a code names no input and no leaf kind")
        if split.any():
            nlo, nhi = _halve(blo[:, split], bhi[:, split], code[split].astype(int))
            qlo, qhi = np.concatenate([qlo, nlo], axis=1), np.concatenate([qhi, nhi], axis=1)
    if p != codes.size:
        raise ValueError("codes are left after the bisection ends")
    out = {}
    for kind, pieces in parts.items():
        los = [a for a, _ in pieces if a.shape[1]]
        his = [b for _, b in pieces if b.shape[1]]
        out[kind] = (
            np.concatenate(los, axis=1).T.copy() if los else np.zeros((0, n)),
            np.concatenate(his, axis=1).T.copy() if his else np.zeros((0, n)),
        )
    return out


@dataclass(frozen=True)
class MaximumBound:
    """``lower <= max f <= upper`` over a box, from :func:`bound_maximum`."""

    upper: float
    """certified: ``f(x) <= upper`` for every ``x`` in the box"""
    lower: float
    """certified: ``f(witness) >= lower``"""
    witness: np.ndarray
    """``(n_in,)``: a point of the box"""
    boxes: int
    converged: bool
    """``upper - lower`` met the requested gap"""
    seconds: float


def bound_maximum(
    f: IntervalFunction,
    lo: np.ndarray,
    hi: np.ndarray,
    *,
    output: int = 0,
    gradient: IntervalFunction | None = None,
    relative_gap: float = 1e-3,
    absolute_gap: float = 0.0,
    budget: Budget = Budget(),
) -> MaximumBound:
    """Certified bounds on the maximum of ``y[output]`` over a box (best-first branch and bound).

    Parameters
    ----------
    f : IntervalFunction
        The function.
    lo, hi : array_like
        ``(n_in,)`` corners; inputs with ``lo == hi`` are fixed.
    output : int
        Which output.
    gradient : IntervalFunction, optional
        Partial derivatives of ``y[output]`` for the mean-value form.
    relative_gap, absolute_gap : float
        Stop when ``upper - lower <= max(absolute_gap, relative_gap * |upper|)``.
    budget : Budget
        Otherwise stop here (the bounds stay certified, only wider).

    Returns
    -------
    MaximumBound

    Examples
    --------
    ``max sin(x) cos(y)`` on ``[0, 3] x [-1, 1]`` is 1 (at ``x = pi/2, y = 0``):

    >>> import casadi as ca, numpy as np
    >>> from fsmctl.enclosures.intervals import IntervalFunction
    >>> from fsmctl.enclosures.branch_bound import bound_maximum
    >>> x = ca.SX.sym("x", 2)
    >>> f = IntervalFunction(ca.Function("f", [x], [ca.sin(x[0]) * ca.cos(x[1])]))
    >>> m = bound_maximum(f, [0, -1], [3, 1], relative_gap=1e-6)
    >>> m.converged, m.lower <= 1 <= m.upper, m.upper - m.lower < 1e-5
    (True, True, True)
    """
    lo0, hi0 = np.asarray(lo, float).ravel(), np.asarray(hi, float).ravel()
    n = lo0.size
    if n != f.n_in or hi0.size != n or np.any(~(lo0 <= hi0)) or not np.all(np.isfinite(lo0) & np.isfinite(hi0)):
        raise ValueError(f"bound_maximum: need finite lo <= hi of length {f.n_in}")
    spanned = hi0 > lo0
    scale = np.where(spanned, hi0 - lo0, 1.0)
    t0 = time.perf_counter()
    qlo, qhi = lo0[:, None].copy(), hi0[:, None].copy()
    _, qub, qmag = enclose_sharp(f, qlo, qhi, output=output, gradient=gradient)
    c = 0.5 * (lo0 + hi0)
    best = float(f.enclose(c[:, None], c[:, None]).lo[output, 0])
    witness, boxes = c, 1
    best = -_INF if np.isnan(best) else best
    while True:
        upper = max(best, float(qub.max())) if qub.size else best
        gap = max(absolute_gap, relative_gap * abs(upper))
        if math.isfinite(upper) and upper - best <= gap:
            return MaximumBound(upper, best, witness, boxes, True, time.perf_counter() - t0)
        if boxes >= budget.max_boxes or time.perf_counter() - t0 > budget.max_seconds or not spanned.any():
            return MaximumBound(upper, best, witness, boxes, False, time.perf_counter() - t0)
        take = min(budget.batch, qub.size)
        order = np.argpartition(-qub, take - 1)[:take] if take < qub.size else np.arange(qub.size)
        rest = np.ones(qub.size, bool)
        rest[order] = False
        blo, bhi = qlo[:, order], qhi[:, order]
        dims = _split_dimension(blo, bhi, scale, spanned, None if qmag is None else qmag[:, order])
        nlo, nhi = _halve(blo, bhi, dims)
        _, nub, nmag = enclose_sharp(f, nlo, nhi, output=output, gradient=gradient)
        cc = np.minimum(np.maximum(0.5 * (nlo + nhi), nlo), nhi)
        at = f.enclose(cc, cc).lo[output]
        at = np.where(np.isnan(at), -_INF, at)
        boxes += nlo.shape[1]
        k = int(at.argmax())
        if at[k] > best:
            best, witness = float(at[k]), cc[:, k].copy()
        keep = nub > best
        qlo = np.concatenate([qlo[:, rest], nlo[:, keep]], axis=1)
        qhi = np.concatenate([qhi[:, rest], nhi[:, keep]], axis=1)
        qub = np.concatenate([qub[rest], nub[keep]])
        if qmag is not None:
            qmag = np.concatenate([qmag[:, rest], nmag[:, keep]], axis=1)
