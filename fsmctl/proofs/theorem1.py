"""Theorem 1 for a concrete topology: do the ``k^i``/``k^j``/``eta`` conditions hold for all t?

Liang et al. 2012 (Theorem 1, eqs 25-27) need, for every ordered pair ``(i, j)``,
``gamma_ij = eta_ij - (k^j_ij)^2 / (4 (k^i_ij - eta_ij)) >= 0``.  What the proof
truly requires (see :mod:`fsmctl.proofs.claims`, claims ``zero-sum`` and
``gamma-condition``) is:

* per ordered pair the 2x2 matrix ``[[k^i_ij - eta_ij, -k^j_ij/2], [-k^j_ij/2, eta_ij]]``
  is positive semidefinite, i.e. ``0 <= eta_ij <= k^i_ij`` and
  ``4 eta_ij (k^i_ij - eta_ij) >= (k^j_ij)^2``: ``eta_ij`` in the closed interval
  ``[(k^i - sqrt(k^i^2 - k^j^2))/2, (k^i + sqrt(k^i^2 - k^j^2))/2]``, non-empty iff ``k^i >= k^j``;
* ``eta`` *balanced*, ``sum_j eta_ij = sum_j eta_ji`` for every i (eq 26), which
  symmetric ``eta`` (the paper's ``eta_ij = eta_ji``) is a special case of;
* nothing about time: eq 26 is an identity at each instant, so ``eta`` may
  change whenever the topology does.

The exact requirement behind all of it is that the coordination term of
``V_dot`` is non-positive: ``lambda_min(sym(L(t))) >= 0`` with
``L_ii = sum_j k^i_ij`` and ``L_ij = -k^j_ij(t)``.

Piecewise-constant schedules make this a finite problem: every distinct
configuration of ``k^j(t)`` is visited at the midpoints between consecutive
switching times of one common period (or of the scenario horizon when the
schedules are not periodic with a common period).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from fsmctl.model.topology import Topology

__all__ = [
    "Configuration",
    "PairResult",
    "Theorem1Analysis",
    "analyze_topology",
    "configurations",
    "eta_interval",
    "scaled_coupling_lambda_min",
]

_TOL = 1e-12


def eta_interval(k_i: float, k_j: float) -> tuple[float, float] | None:
    """Closed interval of ``eta`` with ``[[k_i - eta, -k_j/2], [-k_j/2, eta]] >= 0`` (Liang et al. 2012, eq 27), or None.

    Parameters
    ----------
    k_i, k_j : float
        The weights ``k^i_ij >= 0`` and ``k^j_ij >= 0`` of one ordered pair at one time.

    Returns
    -------
    tuple of float or None
        ``(lo, hi)`` with ``lo = (k_i - sqrt(k_i^2 - k_j^2))/2`` and ``hi = (k_i + sqrt(k_i^2 - k_j^2))/2``;
        None when ``k_i < k_j`` (no ``eta`` makes ``gamma_ij >= 0``).

    Examples
    --------
    The paper's gains ``k^i = 8``, ``k^j = 5`` (Section 4): ``(8 -+ sqrt(39))/2``; Remark 4's ``eta = k^i/2 = 4``
    lies inside.  With ``k^i < k^j`` no ``eta`` exists:

    >>> from fsmctl.proofs import eta_interval
    >>> lo, hi = eta_interval(8.0, 5.0)
    >>> round(lo, 4), round(hi, 4)
    (0.8775, 7.1225)
    >>> print(eta_interval(4.0, 5.0))
    None
    """
    if k_i < k_j - _TOL * max(1.0, k_i):
        return None
    disc = math.sqrt(max(k_i * k_i - k_j * k_j, 0.0))
    return (0.5 * (k_i - disc), 0.5 * (k_i + disc))


def _intersect(a: tuple[float, float] | None, b: tuple[float, float] | None) -> tuple[float, float] | None:
    if a is None or b is None:
        return None
    lo, hi = max(a[0], b[0]), min(a[1], b[1])
    return (lo, hi) if lo <= hi + _TOL * max(1.0, abs(hi)) else None


@dataclass(frozen=True)
class Configuration:
    """One distinct value of the matrix ``K_j(t) = [k^j_ij(t)]`` and the time segments where it holds.

    Kept as the weights of the topology's links (``weights[e] = k^j`` of ``links[e]``, receiver ``receivers[e]``,
    sender ``senders[e]``); :attr:`k_j` builds the dense matrix on demand.  A topology whose links switch at
    phases of their own has about two configurations per link and period (a Monte Carlo run's topology), so
    dense matrices would take O(links n^2) memory: 1.3 GB for a 200-agent ring.
    """

    weights: np.ndarray
    segments: tuple[tuple[float, float], ...]
    """``[t_start, t_end)`` segments (s) within the analysed window"""
    receivers: np.ndarray
    senders: np.ndarray
    n_agents: int

    @property
    def k_j(self) -> np.ndarray:
        """``K_j[i, j] = k^j_ij`` of this configuration, ``(n_agents, n_agents)``, zero where there is no link."""
        K = np.zeros((self.n_agents, self.n_agents))
        K[self.receivers, self.senders] = self.weights
        return K

    @property
    def t(self) -> float:
        """A representative time (the first segment's midpoint; its start for an unbounded segment)."""
        a, b = self.segments[0]
        return a if math.isinf(b) else 0.5 * (a + b)


@dataclass(frozen=True)
class PairResult:
    """The unordered pair ``{i, j}`` (0-based, ``i < j``) and its constant symmetric ``eta`` interval."""

    i: int
    j: int
    k_i_ij: float
    k_i_ji: float
    k_j_max_ij: float
    k_j_max_ji: float
    interval: tuple[float, float] | None
    """feasible constant ``eta_ij = eta_ji`` (intersection over t of both directions' intervals)"""
    printed_ok: bool
    """the printed strict conditions ``k^i > eta > 0`` can also be met"""
    time_varying_ok: bool
    """a symmetric ``eta(t)`` exists at every configuration"""
    eta: Fraction | None = None
    """certified value (exact rational check of both directions at their largest ``k^j``)"""
    reason: str = ""
    fixes: tuple[str, ...] = ()
    when: str = ""

    @property
    def label(self) -> str:
        return f"{self.i + 1}-{self.j + 1}"


@dataclass(frozen=True)
class Theorem1Analysis:
    """Outcome of :func:`analyze_topology`."""

    window: str
    configurations: tuple[Configuration, ...]
    pairs: tuple[PairResult, ...]
    symmetric_constant: bool
    symmetric_time_varying: bool
    balanced_constant: bool
    balanced_time_varying: bool
    printed_strict: bool
    lambda_min: float
    lambda_min_time: float
    failures: tuple[str, ...] = field(default=())

    @property
    def holds(self) -> bool:
        """Theorem 1's conditions in the form the proof needs (balanced, time-varying, non-strict ``eta``)."""
        return self.balanced_time_varying

    @property
    def exact_holds(self) -> bool:
        """``sym(L(t)) >= 0`` at every configuration: the coordination term never increases ``V``."""
        return self.lambda_min >= -1e-9


def _common_period(topology: Topology) -> float | None:
    periods = []
    for link in topology.links:
        sched = link.k_j
        if sched.period is None:
            if len(set(sched.values)) > 1:
                return None  # a non-periodic schedule that changes: no common period
            continue
        periods.append(Fraction(sched.period).limit_denominator(10**6))
    if not periods:
        return 0.0  # all constant
    den = math.lcm(*(p.denominator for p in periods))
    nums = [int(p * den) for p in periods]
    period = Fraction(math.lcm(*nums), den)
    if period > 1e4 * max(periods):
        return None
    return float(period)


def configurations(topology: Topology, t_final: float) -> tuple[tuple[Configuration, ...], str]:
    """Every distinct ``K_j(t)`` of a piecewise-constant topology, with the window that was searched.

    Parameters
    ----------
    topology : Topology
        The directed, time-varying graph of eq 19.
    t_final : float
        The scenario horizon, used when the schedules have no common period.

    Returns
    -------
    tuple
        The configurations (in order of first appearance) and a sentence naming the window.
    """
    period = _common_period(topology)
    if period == 0.0:
        t0, t1 = 0.0, 1.0
        window = "all t (every k^j_ij is constant)"
    elif period is not None:
        t0, t1 = 0.0, period
        window = (
            f"one common period [0, {period:g}) s of the schedules (the sequence of configurations repeats, "
            "so this covers every t)"
        )
    else:
        t0, t1 = 0.0, float(t_final)
        window = f"the scenario horizon [0, {t_final:g}] s (the schedules have no common period)"
    cuts = np.concatenate(([t0], topology.switching_times(t0, t1), [t1]))
    cuts = np.unique(cuts)
    # K_j at every segment midpoint (and, for non-periodic schedules, after the horizon) in one call
    probes = 0.5 * (cuts[:-1] + cuts[1:])
    if period is None:
        probes = np.append(probes, t1 + 1.0)
    # every link's k^j at every probe (the values Topology.k_j_matrices scatters into its matrices)
    links = topology.links
    Ws = np.zeros((len(probes), len(links)))
    for e, link in enumerate(links):
        Ws[:, e] = link.k_j_at(probes)
    found: dict[bytes, list] = {}
    order: list[bytes] = []
    for k, (a, b) in enumerate(itertools.pairwise(cuts)):
        key = Ws[k].tobytes()
        if key not in found:
            found[key] = [Ws[k].copy(), []]
            order.append(key)
        found[key][1].append((float(a), float(b)))
    if period is None:
        # after the horizon the last configuration persists for non-periodic schedules
        key = Ws[-1].tobytes()
        if key not in found:
            found[key] = [Ws[-1].copy(), [(t1, math.inf)]]
            order.append(key)
    if period == 0.0:
        found[order[0]][1] = [(0.0, math.inf)]
    receivers = np.array([link.receiver for link in links], dtype=np.intp)
    senders = np.array([link.sender for link in links], dtype=np.intp)
    n = topology.n_agents
    confs = tuple(Configuration(found[k][0], tuple(found[k][1]), receivers, senders, n) for k in order)
    return confs, window


def _segments_text(segments, limit: int = 3) -> str:
    if segments and segments[0] == (0.0, math.inf):
        return "all t"
    parts = [f"[{a:g}, {b:g})" for a, b in segments[:limit]]
    more = f" and {len(segments) - limit} more" if len(segments) > limit else ""
    return "t in " + ", ".join(parts) + more + " s"


def _pair_feasible(a: float, A: float, b: float, B: float) -> bool:
    return _intersect(eta_interval(a, A), eta_interval(b, B)) is not None


def _pair_feasible_in(vary: int, a: float, A: float, b: float, B: float):
    """``x -> _pair_feasible`` with argument ``vary`` (0: a, 1: A, 2: b, 3: B) replaced by ``x``.

    The interval of the direction that does not change is computed once, not at every bisection step.
    """
    if vary < 2:
        fixed = eta_interval(b, B)
        if vary == 0:
            return lambda x: _intersect(eta_interval(x, A), fixed) is not None
        return lambda x: _intersect(eta_interval(a, x), fixed) is not None
    fixed = eta_interval(a, A)
    if vary == 2:
        return lambda x: _intersect(fixed, eta_interval(x, B)) is not None
    return lambda x: _intersect(fixed, eta_interval(b, x)) is not None


def _bisect(pred, lo: float, hi: float, want_low: bool, iters: int = 60) -> float:
    """Smallest (``want_low``) or largest value in ``[lo, hi]`` where the monotone ``pred`` holds."""
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        ok = pred(mid)
        if want_low:
            hi, lo = (mid, lo) if ok else (hi, mid)
        else:
            lo, hi = (mid, hi) if ok else (lo, mid)
    return hi if want_low else lo


def _fixes(i: int, j: int, a: float, A: float, b: float, B: float) -> tuple[str, ...]:
    """Smallest single-parameter changes that make the pair's constant symmetric ``eta`` feasible."""
    out = []
    big = 4.0 * max(a, A, b, B, 1.0) + 1.0
    ij, ji = f"{i + 1}{j + 1}", f"{j + 1}{i + 1}"
    if _pair_feasible(big, A, b, B):
        v = _bisect(_pair_feasible_in(0, a, A, b, B), a, big, want_low=True)
        out.append(f"raise k^i_{ij} to >= {_up(v)}")
    if _pair_feasible(a, A, big, B):
        v = _bisect(_pair_feasible_in(2, a, A, b, B), b, big, want_low=True)
        out.append(f"raise k^i_{ji} to >= {_up(v)}")
    if A > 0 and _pair_feasible(a, 0.0, b, B):
        v = _bisect(_pair_feasible_in(1, a, A, b, B), 0.0, A, want_low=False)
        out.append(f"lower max_t k^j_{ij}(t) to <= {_down(v)}")
    if B > 0 and _pair_feasible(a, A, b, 0.0):
        v = _bisect(_pair_feasible_in(3, a, A, b, B), 0.0, B, want_low=False)
        out.append(f"lower max_t k^j_{ji}(t) to <= {_down(v)}")
    if not out:
        # both directions need a change: raise both k^i (each at least to its k^j), or lower both k^j
        a2, b2 = max(a, A), max(b, B)
        if not _pair_feasible(a2, A, b2, B):
            if _pair_feasible(big, A, b2, B):
                a2 = _bisect(_pair_feasible_in(0, a2, A, b2, B), a2, big, want_low=True)
            else:
                b2 = _bisect(_pair_feasible_in(2, a2, A, b2, B), b2, big, want_low=True)
        out.append(f"raise k^i_{ij} to >= {_up(a2)} and k^i_{ji} to >= {_up(b2)}")
        A2, B2 = min(A, a), min(B, b)
        if _pair_feasible(a, A2, b, B2):
            out.append(f"lower max_t k^j_{ij}(t) to <= {_down(A2)} and max_t k^j_{ji}(t) to <= {_down(B2)}")
    return tuple(out)


def _fmt4(x: float) -> str:
    return f"{x:.4f}".rstrip("0").rstrip(".")


def _up(x: float) -> str:
    """``x`` rounded up to 4 decimals (a safe lower bound to suggest)."""
    return _fmt4(math.ceil(x * 1e4 - 1e-9) / 1e4)


def _down(x: float) -> str:
    """``x`` rounded down to 4 decimals (a safe upper bound to suggest)."""
    return _fmt4(math.floor(x * 1e4 + 1e-9) / 1e4)


def _certify(eta: float, pairs: list[tuple[float, float]]) -> Fraction | None:
    """Exact rational check of ``0 <= eta <= k^i`` and ``4 eta (k^i - eta) >= (k^j)^2`` for each ``(k^i, k^j)``."""
    e = Fraction(eta)
    for ki, kj in pairs:
        Ki, Kj = Fraction(ki), Fraction(kj)
        if not (0 <= e <= Ki and 4 * e * (Ki - e) >= Kj * Kj):
            return None
    return e


def _choose_eta(interval: tuple[float, float], pairs: list[tuple[float, float]]) -> Fraction | None:
    lo, hi = interval
    for candidate in (0.5 * (lo + hi), lo, hi, float(Fraction(0.5 * (lo + hi)).limit_denominator(10**6))):
        cert = _certify(candidate, pairs)
        if cert is not None:
            return cert
    return None


def _balanced_feasible(bounds: dict[tuple[int, int], tuple[float, float] | None], n: int) -> bool:
    """Is there ``eta_ij`` in the given bounds with ``sum_j eta_ij = sum_j eta_ji`` for every i (eq 26)?"""
    if any(b is None for b in bounds.values()):
        return False
    keys = [k for k, b in bounds.items() if b[1] > 0]
    if not keys:
        return True  # every eta is forced to 0: balanced
    lo_total = sum(bounds[k][0] for k in keys)
    if lo_total == 0:
        return True  # eta = 0 everywhere is admissible
    from scipy.optimize import linprog

    A = np.zeros((n, len(keys)))
    for col, (i, j) in enumerate(keys):
        A[i, col] += 1.0
        A[j, col] -= 1.0
    res = linprog(np.zeros(len(keys)), A_eq=A, b_eq=np.zeros(n), bounds=[bounds[k] for k in keys], method="highs")
    return bool(res.status == 0)


_LAMBDA_BLOCK_DOUBLES = 2**16
"""Doubles of the stacked Laplacians :func:`_lambda_min` holds at once (512 kB, a few times that with its
temporaries): a small formation's configurations in one LAPACK call (1820 of 6 agents), a large one's a few at a
time (never one n x n matrix per configuration at once)."""


def _lambda_min(Ki: np.ndarray, confs: Sequence[Configuration]) -> tuple[float, float]:
    """``min_t lambda_min(sym(L(t)))`` over the configurations and a time where it occurs (the first configuration
    attaining it); ``(inf, 0)`` without configurations, 0 for an empty formation."""
    n = Ki.shape[0]
    lam, lam_t = math.inf, 0.0
    if not confs:
        return lam, lam_t
    if n == 0:
        return 0.0, confs[0].t
    degree = np.diag(Ki.sum(axis=1))
    block = max(1, _LAMBDA_BLOCK_DOUBLES // (n * n))
    for start in range(0, len(confs), block):
        chunk = confs[start : start + block]
        L = degree - np.stack([c.k_j for c in chunk])  # L(t) of these configurations
        ev = np.linalg.eigvalsh(0.5 * (L + L.transpose(0, 2, 1)))[:, 0]  # the matrices one by one, as LAPACK is
        k = int(np.argmin(np.where(np.isnan(ev), np.inf, ev)))  # the first of the smallest (a NaN never is)
        if ev[k] < lam:
            lam, lam_t = float(ev[k]), chunk[k].t
    return lam, lam_t


def _failed_pair(
    i: int,
    j: int,
    gains: tuple[float, float, float, float],
    intervals: tuple[tuple[float, float] | None, tuple[float, float] | None],
    tv_ok: bool,
    when_max: Callable[[int, int], str],
) -> tuple[PairResult, str]:
    """The pair ``{i, j}`` without a constant symmetric ``eta`` (``gains``: ``k^i_ij, max_t k^j_ij, k^i_ji,
    max_t k^j_ji``; ``intervals``: each direction's ``eta`` interval or None): its result and its failure line (the
    reason, when the weights that cause it hold, the smallest fixes)."""
    a, A, b, B = gains
    I_ij, I_ji = intervals
    if I_ij is None or I_ji is None:
        bad = [(i, j, a, A)] if I_ij is None else []
        bad += [(j, i, b, B)] if I_ji is None else []
        reason = "; ".join(
            f"k^i_{p + 1}{q + 1} = {ki:g} < max_t k^j_{p + 1}{q + 1}(t) = {kj:g}: no eta_{p + 1}{q + 1} gives "
            f"gamma_{p + 1}{q + 1} >= 0 (needs k^i >= k^j)"
            for p, q, ki, kj in bad
        )
        when = "; ".join(f"k^j_{p + 1}{q + 1} = {kj:g} at {when_max(p, q)}" for p, q, _, kj in bad)
    else:
        reason = (
            f"eta_{i + 1}{j + 1} must lie in [{I_ij[0]:.4g}, {I_ij[1]:.4g}] (k^i_{i + 1}{j + 1} = {a:g}, "
            f"k^j = {A:g}) and eta_{j + 1}{i + 1} in [{I_ji[0]:.4g}, {I_ji[1]:.4g}] (k^i_{j + 1}{i + 1} = {b:g}, "
            f"k^j = {B:g}): disjoint, so no symmetric eta_ij = eta_ji"
        )
        when = f"k^j_{i + 1}{j + 1} = {A:g} at {when_max(i, j)}; k^j_{j + 1}{i + 1} = {B:g} at {when_max(j, i)}"
    fixes = _fixes(i, j, a, A, b, B)
    pr = PairResult(i, j, a, b, A, B, None, False, tv_ok, None, reason, fixes, when)
    return pr, f"pair {pr.label}: {reason}; {when}; smallest fix: " + (" or ".join(fixes) if fixes else "none found")


def analyze_topology(topology: Topology, t_final: float, *, explain: bool = True) -> Theorem1Analysis:
    """Check Theorem 1's conditions (Liang et al. 2012, Theorem 1, eqs 25-27) for every configuration of a topology.

    Parameters
    ----------
    topology : Topology
        Gain table ``k^i_ij`` and schedules ``k^j_ij(t)``.
    t_final : float
        Scenario horizon (used only when the schedules have no common period).
    explain : bool
        Also the pairs and the failure lines (what reports print).  False: only the verdicts and
        ``lambda_min`` (what a Monte Carlo run's record or a tuning constraint needs; ``pairs`` and ``failures``
        are then empty, never partly filled), about twice as fast.

    Returns
    -------
    Theorem1Analysis
        Per unordered pair the feasible constant symmetric ``eta`` interval (or the reason it
        fails, when, and the smallest single-parameter fix), whether symmetric / balanced,
        constant / time-varying ``eta`` exist, whether the printed strict conditions can
        hold, and ``min_t lambda_min(sym(L(t)))``.

    Examples
    --------
    A bidirectional ring of three with ``k^i = 8`` and constant ``k^j = 5``: every pair admits
    ``eta`` in ``[0.8775, 7.1225]`` and ``sym(L) = 16 I - 5 A`` (``A`` the triangle's adjacency, eigenvalues
    2, -1, -1) has ``lambda_min = 16 - 10 = 6``.  With ``k^j = 9 > k^i`` the conditions fail, and
    ``lambda_min = 16 - 18 = -2``:

    >>> from fsmctl.model.topology import ring
    >>> from fsmctl.proofs import analyze_topology
    >>> a = analyze_topology(ring(3, 8.0, 5.0), t_final=10.0)
    >>> a.holds, [round(x, 4) for x in a.pairs[0].interval], round(a.lambda_min, 9)
    (True, [0.8775, 7.1225], 6.0)
    >>> b = analyze_topology(ring(3, 8.0, 9.0), t_final=10.0)
    >>> b.holds, round(b.lambda_min, 9)
    (False, -2.0)
    >>> print(b.failures[0])
    pair 1-2: k^i_12 = 8 < max_t k^j_12(t) = 9: no eta_12 gives gamma_12 >= 0 (needs k^i >= k^j); ...
    >>> quick = analyze_topology(ring(3, 8.0, 9.0), t_final=10.0, explain=False)
    >>> quick.holds, quick.lambda_min == b.lambda_min, quick.failures
    (False, True, ())
    """
    n = topology.n_agents
    Ki = topology.k_i_matrix()
    confs, window = configurations(topology, t_final)
    # the links' weights in every configuration, (configurations, links): O(links) per configuration, never
    # one n x n matrix per configuration (see Configuration)
    W = np.stack([c.weights for c in confs]) if confs else np.zeros((0, len(topology.links)))
    column = {(link.receiver, link.sender): e for e, link in enumerate(topology.links)}
    Kj_max = np.zeros((n, n))
    if confs:
        for (r, sdr), e in column.items():
            Kj_max[r, sdr] = W[:, e].max()

    def weights_of(i: int, j: int) -> list[float]:
        """k^j_ij in every configuration (Python floats; 0 without a link)."""
        e = column.get((i, j))
        return W[:, e].tolist() if e is not None else [0.0] * len(confs)

    def when_max(i: int, j: int) -> str:
        for c, w in zip(confs, weights_of(i, j), strict=True):
            if w == Kj_max[i, j]:
                return _segments_text(c.segments)
        return ""

    pairs: list[PairResult] = []
    failures: list[str] = []
    checks: list[tuple[bool, bool, bool]] = []  # per pair: symmetric constant eta, time-varying, printed strict
    verdicts: dict[tuple, tuple] = {}  # a pair's checks depend on its weights only: unlinked pairs share one
    for i in range(n):
        for j in range(i + 1, n):
            a, A, b, B = (float(x) for x in (Ki[i, j], Kj_max[i, j], Ki[j, i], Kj_max[j, i]))
            if (i, j) in column or (j, i) in column:  # the distinct (k^j_ij, k^j_ji) over the configurations, in order
                distinct = tuple(dict.fromkeys(zip(weights_of(i, j), weights_of(j, i), strict=True)))
            else:
                distinct = ((0.0, 0.0),) if confs else ()
            key = (a, A, b, B, distinct)
            if key not in verdicts:
                I_ij, I_ji = eta_interval(a, A), eta_interval(b, B)
                interval = _intersect(I_ij, I_ji)
                tv_ok = all(_intersect(eta_interval(a, kij), eta_interval(b, kji)) is not None for kij, kji in distinct)
                printed_ok = bool(
                    interval is not None and interval[1] > 0 and min(a, b) > 0 and interval[0] < min(a, b)
                )
                eta = _choose_eta(interval, [(a, A), (b, B)]) if interval is not None and explain else None
                verdicts[key] = (I_ij, I_ji, interval, tv_ok, printed_ok, eta)
            I_ij, I_ji, interval, tv_ok, printed_ok, eta = verdicts[key]
            checks.append((interval is not None, tv_ok, printed_ok))
            if not explain:
                continue
            if interval is not None:
                pairs.append(PairResult(i, j, a, b, A, B, interval, printed_ok, tv_ok, eta))
                continue
            pr, failure = _failed_pair(i, j, (a, A, b, B), (I_ij, I_ji), tv_ok, when_max)
            pairs.append(pr)
            failures.append(failure)

    symmetric_constant = all(c[0] for c in checks)
    symmetric_tv = all(c[1] for c in checks)
    printed_strict = all(c[2] for c in checks)

    def ordered_bounds(Kj):
        return {(i, j): eta_interval(Ki[i, j], Kj[i, j]) for i in range(n) for j in range(n) if i != j}

    balanced_constant = symmetric_constant or _balanced_feasible(ordered_bounds(Kj_max), n)
    balanced_tv = balanced_constant or symmetric_tv or all(_balanced_feasible(ordered_bounds(c.k_j), n) for c in confs)

    lam, lam_t = _lambda_min(Ki, confs)
    return Theorem1Analysis(
        window=window,
        configurations=confs,
        pairs=tuple(pairs),
        symmetric_constant=symmetric_constant,
        symmetric_time_varying=symmetric_tv,
        balanced_constant=balanced_constant,
        balanced_time_varying=balanced_tv,
        printed_strict=printed_strict,
        lambda_min=lam if math.isfinite(lam) else 0.0,
        lambda_min_time=lam_t,
        failures=tuple(failures),
    )


def scaled_coupling_lambda_min(topology: Topology, weights: np.ndarray, t_final: float) -> tuple[float, float]:
    """Coupling condition of Theorem 2 with agent-dependent factors (Liang et al. 2012, eqs 25, 30-33).

    With ``Delta_J_i = kappa_i J0_i`` the coordination term of ``V_dot`` is ``-S^T (D L(t) x I) S`` with
    ``D = diag(1/(1+kappa_i))``.

    Parameters
    ----------
    topology : Topology
        Gains and schedules.
    weights : array_like
        The diagonal of ``D``.
    t_final : float
        Scenario horizon (used when the schedules have no common period).

    Returns
    -------
    tuple of float
        ``min_t lambda_min(sym(D L(t)))`` and a time where it is attained.
    """
    Ki = topology.k_i_matrix()
    confs, _ = configurations(topology, t_final)
    D = np.diag(np.asarray(weights, dtype=float))
    lam, lam_t = math.inf, 0.0
    for c in confs:
        L = D @ (np.diag(Ki.sum(axis=1)) - c.k_j)
        ev = float(np.linalg.eigvalsh(0.5 * (L + L.T))[0])
        if ev < lam:
            lam, lam_t = ev, c.t
    return lam, lam_t
