"""Re-checking a certificate file (``fsmctl certify --check``), independently of the search that wrote it.

:func:`recheck` is given the closed loop rebuilt from the file's recorded inputs and the candidate ``V`` parsed
from the file's exact expression; it re-proves what the certificate states from the recorded leaves alone:

1. ``V_dot < 0`` on every proved leaf (outward-rounded intervals, the mean-value form as in the search);
2. the leaves (proved, core, and the rest) tile the region x uncertainty box (:func:`tiles_region`);
3. for an asymptotic certificate, the origin's second-order argument on the recorded core box, and that every
   core leaf lies in it;
4. the level ``c``: no larger than ``V``'s certified minimum on the region's boundary and, for an asymptotic
   certificate, than ``V`` on the leaves not proved; for an ultimately bounded one, every leaf not proved lies in
   ``{V <= c_in}``;
5. a counterexample's ``V_dot > 0`` in 256-bit ball arithmetic;
6. a sample of the proved leaves (or all of them) re-proved in python-flint's ball arithmetic, the formally
   rigorous route (the natural extension intersected with the mean-value form, combined with outward rounding).
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

from fsmctl.enclosures.branch_bound import enclose_sharp
from fsmctl.proofs.certify import (
    ASYMPTOTIC,
    BALL_PRECISION,
    BOUNDARY_BUDGET,
    CERTIFIED,
    COUNTEREXAMPLE,
    boundary_level,
    lyapunov_programs,
    origin_argument,
)
from fsmctl.proofs.certify_problem import CertifyProblem

__all__ = ["recheck", "tiles_region"]


def tiles_region(lo: np.ndarray, hi: np.ndarray, root_lo: np.ndarray, root_hi: np.ndarray) -> tuple[bool, str]:
    """Whether boxes (rows) tile the root box: inside it, interiors pairwise disjoint, volumes summing exactly.

    The volumes are summed as exact fractions (the leaves of a bisection have dyadic widths); disjointness is
    checked pair by pair (in chunks).  Disjoint interiors whose volumes add up to the box's cover it (the
    uncovered part would be open and of measure zero, hence empty).

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.proofs.certify_check import tiles_region
    >>> tiles_region(np.array([[0.0, 0], [0.5, 0]]), np.array([[0.5, 1], [1, 1]]), np.zeros(2), np.ones(2))
    (True, '2 boxes tile the region')
    >>> tiles_region(np.array([[0.0, 0], [0.4, 0]]), np.array([[0.6, 1], [1, 1]]), np.zeros(2), np.ones(2))[0]
    False
    """
    span = root_hi > root_lo
    if lo.shape[0] == 0:
        return False, "no boxes"
    if np.any(lo < root_lo) or np.any(hi > root_hi) or np.any(lo > hi):
        return False, "a box leaves the region"
    if np.any(lo[:, ~span] != root_lo[~span]) or np.any(hi[:, ~span] != root_hi[~span]):
        return False, "a box leaves the region"
    root = math.prod(Fraction(float(b)) - Fraction(float(a)) for a, b in zip(root_lo[span], root_hi[span], strict=True))
    total = Fraction(0)
    for a, b in zip(lo[:, span], hi[:, span], strict=True):
        total += math.prod(Fraction(float(y)) - Fraction(float(x)) for x, y in zip(a, b, strict=True))
    if total != root:
        return False, f"the boxes' volumes sum to {float(total / root):.17g} of the region's"
    n = lo.shape[0]
    L, H = lo[:, span], hi[:, span]
    chunk = max(1, 2_000_000 // max(n, 1))
    for i in range(0, n, chunk):
        a_lo, a_hi = L[i : i + chunk, None, :], H[i : i + chunk, None, :]
        overlap = np.all((a_lo < H[None, :, :]) & (L[None, :, :] < a_hi), axis=2)
        idx = np.arange(i, min(i + chunk, n))
        overlap[np.arange(len(idx)), idx] = False
        if overlap.any():
            return False, "two boxes overlap"
    return True, f"{n} boxes tile the region"


def _proved_again(progs, lo: np.ndarray, hi: np.ndarray, batch: int = 4096) -> np.ndarray:
    """``(k,)`` bool: ``V_dot < 0`` re-proved on each leaf (rows)."""
    ok = np.zeros(lo.shape[0], bool)
    for i in range(0, lo.shape[0], batch):
        _, top, _ = enclose_sharp(progs.W, lo[i : i + batch].T.copy(), hi[i : i + batch].T.copy(), gradient=progs.dW)
        ok[i : i + batch] = top < 0
    return ok


def _arb_upper(progs, lo: np.ndarray, hi: np.ndarray) -> float:
    """Upper bound of ``V_dot`` on one box in ball arithmetic: natural extension and mean-value form."""
    _, natural = progs.W.enclose_arb(lo, hi, precision=BALL_PRECISION)
    c = np.minimum(np.maximum(0.5 * (lo + hi), lo), hi)
    _, at_c = progs.W.enclose_arb(c, c, precision=BALL_PRECISION)
    g_lo, g_hi = progs.dW.enclose_arb(lo, hi, precision=BALL_PRECISION)
    mv = float(at_c[0])
    for i in range(lo.size):
        d = [float(lo[i] - c[i]), float(hi[i] - c[i])]
        d = [math.nextafter(d[0], -math.inf), math.nextafter(d[1], math.inf)]
        products = [a * b for a in (float(g_lo[i]), float(g_hi[i])) for b in d if not (a == 0 or b == 0)] or [0.0]
        mv = math.nextafter(mv + max(products), math.inf)
    if not math.isfinite(mv):
        return float(natural[0])
    return min(float(natural[0]), mv)


def recheck(problem: CertifyProblem, V, d: dict, *, arb_sample: int | None, seed: int) -> tuple[bool, list[str]]:
    """Re-prove a certificate's statements (see the module docstring); ``(ok, one line per step)``."""
    progs = lyapunov_programs(problem, V)
    leaves, out, verdict = d["leaves"], d["outcome"], d["verdict"]
    lines: list[str] = []
    ok = True

    def step(passed: bool, text: str) -> None:
        nonlocal ok
        ok = ok and passed
        lines.append(f"[{'ok' if passed else 'FAILS'}] {text}")

    if verdict == COUNTEREXAMPLE:
        c = out["counterexample"]
        x = [c["point"][name] for name in problem.names]
        ball = progs.W.evaluate_ball(x, precision=BALL_PRECISION)[0]
        step(bool(ball > 0), f"V_dot > 0 at the counterexample in ball arithmetic: {ball}")
        return ok, lines
    if verdict != CERTIFIED:
        lines.append(f"the certificate is {verdict}: nothing is claimed to re-check")
        return True, lines
    plo, phi = leaves["proved_lo"], leaves["proved_hi"]
    good = _proved_again(progs, plo, phi)
    step(
        bool(good.all()), f"V_dot < 0 re-proved on {int(good.sum())} of {good.size} leaves (outward-rounded intervals)"
    )
    parts = [(plo, phi), (leaves["excluded_lo"], leaves["excluded_hi"]), (leaves["other_lo"], leaves["other_hi"])]
    all_lo = np.concatenate([p[0] for p in parts])
    all_hi = np.concatenate([p[1] for p in parts])
    tiled, why = tiles_region(all_lo, all_hi, problem.lo, problem.hi)
    step(tiled, why)
    c_bnd = boundary_level(problem, progs, BOUNDARY_BUDGET)
    level = out["level"]
    step(level <= c_bnd, f"level c = {level:.9g} <= min V on the region's boundary ({c_bnd:.9g})")
    olo, ohi = leaves["other_lo"], leaves["other_hi"]
    _, vhi = progs.v_bounds(olo, ohi)
    if d["kind"] == ASYMPTOTIC:
        _recheck_core(problem, progs, out, leaves, step)
        step(olo.shape[0] == 0, f"{olo.shape[0]} leaves outside the core are not proved")
    else:
        c_in = out["inner_level"]
        inside = bool(np.all(vhi <= c_in)) if vhi.size else True
        step(inside and c_in < level, f"every leaf not proved lies in {{V <= c_in = {c_in:.9g}}} and c_in < c")
    _recheck_arb(progs, plo, phi, arb_sample, seed, step)
    return ok, lines


def _recheck_core(problem, progs, out, leaves, step) -> None:
    core = out["core"]
    again = origin_argument(problem, progs, fractions=(core["fraction"],))
    step(bool(again.get("passed")), "the origin's argument (ball arithmetic at 0, Hessian on the core box) holds")
    half = np.asarray(core["half_widths"])
    n = problem.n_state
    xlo, xhi = leaves["excluded_lo"], leaves["excluded_hi"]
    inside = bool(np.all((xlo[:, :n] >= -half) & (xhi[:, :n] <= half))) if xlo.size else True
    step(inside, f"{xlo.shape[0]} core leaves lie in the core box")


def _recheck_arb(progs, plo, phi, arb_sample, seed, step) -> None:
    k = plo.shape[0]
    if k == 0:
        return
    rows = np.arange(k)
    if arb_sample is not None and arb_sample < k:
        rows = np.sort(np.random.default_rng(seed).choice(k, size=arb_sample, replace=False))
    tops = [_arb_upper(progs, plo[r], phi[r]) for r in rows]
    bad = sum(1 for t in tops if not t < 0)
    step(bad == 0, f"V_dot < 0 re-proved in ball arithmetic on {len(rows) - bad} of {len(rows)} sampled leaves")
