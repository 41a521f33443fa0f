"""Re-checking a certificate file (``fsmctl certify --check``), independently of the search that wrote it.

:func:`recheck` is given the closed loop rebuilt from the file's recorded inputs and the candidate ``V`` parsed
from the file's exact expression; it re-proves what the certificate states from the recorded bisection alone:

1. ``V_dot < 0`` on every proved leaf (outward-rounded intervals, the mean-value form as in the search);
2. the leaves are rebuilt from the recorded bisection tree of the region x uncertainty box
   (:func:`fsmctl.enclosures.branch_bound.bisection_leaves`), a partition of the box by construction;
3. for an asymptotic certificate, the origin's second-order argument on the recorded core box, and that every
   core leaf lies in it;
4. the level ``c``: no larger than ``V``'s certified minimum on the region's boundary and, for an asymptotic
   certificate, than ``V`` on the leaves not proved; for an ultimately bounded one, every leaf not proved lies in
   ``{V <= c_in}``;
5. a counterexample's ``V_dot > 0`` in 256-bit ball arithmetic;
   (an ultimately bounded certificate by sum of squares instead: its Putinar identity re-checked in exact rational
   arithmetic from the law's equations, and its level against ``V`` on the region's boundary;)
6. a sample of the proved leaves (or all of them) re-proved in python-flint's ball arithmetic, the formally
   rigorous route (the natural extension intersected with the mean-value form, combined with outward rounding).
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

from fsmctl.enclosures.branch_bound import EXCLUDED, POSITIVE, PROVED, UNDECIDED, bisection_leaves, enclose_sharp
from fsmctl.proofs.certify import (
    ASYMPTOTIC,
    BALL_PRECISION,
    BOUNDARY_BUDGET,
    CERTIFIED,
    COUNTEREXAMPLE,
    boundary_level,
    inside_core,
    lyapunov_programs,
    origin_argument,
    sos_polynomials,
    sublevel_extent,
)
from fsmctl.proofs.certify_problem import CertifyProblem
from fsmctl.proofs.certify_sos import verify_sos

__all__ = ["recheck"]


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


ARB_SPLIT_DEPTH = 12
"""ball arithmetic (midpoint-radius) encloses wider than outward-rounded intervals on long graphs: a sampled leaf is
re-proved in it by halving it up to this many times (every piece proved: the leaf is)"""


def _arb_proves(progs, lo: np.ndarray, hi: np.ndarray, scale: np.ndarray, depth: int) -> bool:
    """``V_dot < 0`` on the box in ball arithmetic, halving the widest input (relative to the region) as needed."""
    if _arb_upper(progs, lo, hi) < 0:
        return True
    if depth == 0:
        return False
    k = int(np.argmax((hi - lo) / scale))
    mid = 0.5 * (lo[k] + hi[k])
    left_hi, right_lo = hi.copy(), lo.copy()
    left_hi[k], right_lo[k] = mid, mid
    return _arb_proves(progs, lo, left_hi, scale, depth - 1) and _arb_proves(progs, right_lo, hi, scale, depth - 1)


def recheck(problem: CertifyProblem, V, d: dict, *, arb_sample: int | None, seed: int) -> tuple[bool, list[str]]:
    """Re-prove a certificate's statements (see the module docstring); ``(ok, one line per step)``."""
    progs = lyapunov_programs(problem, V)
    out, verdict = d["outcome"], d["verdict"]
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
    if out.get("sos"):
        _recheck_sos(problem, progs, V, out, step)
        return ok, lines
    tree = d.get("tree") or {}
    try:
        leaves = bisection_leaves(problem.lo, problem.hi, tree["codes"], tree["batch"])
    except (KeyError, ValueError) as exc:
        step(False, f"the bisection tree does not partition the region: {exc}")
        return ok, lines
    step(True, f"{tree['codes'].size} boxes of the recorded bisection rebuilt: a partition of the region x uncertainty")
    plo, phi = leaves[PROVED]
    good = _proved_again(progs, plo, phi)
    step(
        bool(good.all()), f"V_dot < 0 re-proved on {int(good.sum())} of {good.size} leaves (outward-rounded intervals)"
    )
    c_bnd = boundary_level(problem, progs, BOUNDARY_BUDGET)
    level = out["level"]
    step(level <= c_bnd, f"level c = {level:.9g} <= min V on the region's boundary ({c_bnd:.9g})")
    olo = np.concatenate([leaves[POSITIVE][0], leaves[UNDECIDED][0]])
    ohi = np.concatenate([leaves[POSITIVE][1], leaves[UNDECIDED][1]])
    _, vhi = progs.v_bounds(olo, ohi)
    if leaves[EXCLUDED][0].shape[0]:
        _recheck_excluded(problem, progs, out, leaves, step)
    if d["kind"] == ASYMPTOTIC:
        step(olo.shape[0] == 0, f"{olo.shape[0]} leaves outside the core are not proved")
    else:
        c_in = out["inner_level"]
        inside = bool(np.all(vhi <= c_in)) if vhi.size else True
        step(inside and c_in < level, f"every leaf not proved lies in {{V <= c_in = {c_in:.9g}}} and c_in < c")
    scale = np.where(problem.hi > problem.lo, problem.hi - problem.lo, 1.0)
    confirmed, sampled = _recheck_arb(progs, plo, phi, arb_sample, seed, scale)
    # midpoint-radius balls enclose long graphs more widely than endpoint intervals: a leaf the ball route cannot
    # confirm within ARB_SPLIT_DEPTH halvings is reported, not counted against the certificate, which rests on the
    # outward-rounded route re-run above on every leaf
    mark = "ok" if confirmed == sampled else "--"
    lines.append(
        f"[{mark}] ball arithmetic (python-flint arb) confirms V_dot < 0 on {confirmed} of {sampled} sampled leaves"
        + ("" if confirmed == sampled else " (the others: wider in ball arithmetic than their margin, not a failure)")
    )
    return ok, lines


def _recheck_excluded(problem, progs, out, leaves, step) -> None:
    """The leaves the search left out: inside the core where the origin's argument proves ``V_dot < 0``, or (ultimately
    bounded) where ``V <= c_in`` is proved, so that they belong to the inner set."""
    core = out["core"]
    xlo, xhi = leaves[EXCLUDED]
    ok = np.zeros(xlo.shape[0], bool)
    if core.get("passed"):
        again = origin_argument(
            problem, progs, box=np.asarray(core.get("fractions") or [core["fraction"]] * problem.n_state)
        )
        step(
            bool(again.get("passed")) and again["r_star"] <= core["r_star"],
            "the origin's argument (ball arithmetic at 0, Hessian on the core box) holds"
            + (f", V_dot < 0 outside |y| <= {core['r_star']:.4g}" if core["r_star"] else ""),
        )
        ok |= inside_core(problem, core, progs)(xlo.T.copy(), xhi.T.copy())
    in_core = int(ok.sum())
    c_in = out.get("inner_level")
    if c_in is not None and not ok.all():
        _, vhi = progs.v_bounds(xlo[~ok], xhi[~ok])
        ok[~ok] = vhi <= c_in
    inner = f", {xlo.shape[0] - in_core} in {{V <= c_in}}" if c_in is not None else ""
    step(bool(ok.all()), f"{in_core} leaves proved by the origin's argument{inner}, of {xlo.shape[0]} left out")


def _recheck_arb(progs, plo, phi, arb_sample, seed, scale) -> tuple[int, int]:
    """``(confirmed, sampled)``: sampled proved leaves on which ball arithmetic confirms ``V_dot < 0``."""
    k = plo.shape[0]
    rows = np.arange(k)
    if arb_sample is not None and arb_sample < k:
        rows = np.sort(np.random.default_rng(seed).choice(k, size=arb_sample, replace=False))
    bad = sum(1 for r in rows if not _arb_proves(progs, plo[r], phi[r], scale, ARB_SPLIT_DEPTH))
    return len(rows) - bad, len(rows)


def _recheck_sos(problem: CertifyProblem, progs, V, out: dict, step) -> None:
    """An ultimately bounded certificate by sum of squares: the identity re-checked exactly from the law's equations
    (:func:`fsmctl.proofs.certify_sos.verify_sos`), its levels against the file's and ``V`` on the boundary."""
    polys = sos_polynomials(problem, V, progs.W_function)
    if isinstance(polys, str):
        step(False, f"the sum-of-squares question cannot be rebuilt: {polys}")
        return
    Vp, Wp, half, names = polys
    record = out["sos"]
    step(names == record["variables"], f"the identity's variables are the closed loop's ({', '.join(names)})")
    good, text = verify_sos(Vp, Wp, half, record)
    step(good, text)
    c_in, c = Fraction(record["inner_level"]), Fraction(record["level"])
    step(
        float(c_in) <= out["inner_level"] and Fraction(out["level"]) <= c,
        f"the file's levels c_in = {out['inner_level']:.9g}, c = {out['level']:.9g} are the identity's",
    )
    c_bnd = boundary_level(problem, progs, BOUNDARY_BUDGET)
    step(c <= Fraction(c_bnd), f"level c = {float(c):.9g} <= min V on the region's boundary ({c_bnd:.9g})")
    n = problem.n_state
    ext = sublevel_extent(progs, problem.lo, problem.hi, out["inner_level"], n)
    ub = out.get("ultimate_bound") or {}
    sig, om = float(np.max(ext[:3])), float(np.max(ext[3:6]))
    step(
        ub.get("sigma_e_max", -1.0) >= sig and ub.get("omega_e_max_rad_s", -1.0) >= om,
        f"the ultimate bound: {{V <= c_in}} lies in |sigma_e,k| <= {sig:.4g}, |omega_e,k| <= {om:.4g} rad/s "
        "(re-proved; the file's bound is no smaller)",
    )
