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
   rigorous route (the natural extension intersected with the mean-value form, combined with outward rounding);
7. every number the report derives from these: the extents of ``{V <= c}`` and the
   ultimate bound (with its attitude error), the decrease ``m`` on the annulus and the time to cross it, the sum of
   squares' decay rate, the origin's ``mu``, ``w0``, ``G`` and ``r*``, the least ``V`` on the boundary and the inner
   target, the search's volume fractions and box count, the counterexample's values, and the candidate's
   description -- each recomputed by the function the certify run uses, from the re-checked data and the file's
   levels, and compared with the file's value (:func:`compare_derived`, :data:`DERIVED_TOLERANCE`).

A derived number that is a bound (an extent or ultimate bound, a decrease or decay rate, a reach time, the origin's
constants, the boundary's least ``V``, a counterexample's lower bound of ``V_dot``) may be **weaker** than the
recomputed one (a larger extent, a smaller rate, a longer time): the file then states a weaker true statement, and
the check accepts it and says so.  One **more favourable** than the recomputed one by more than the tolerance fails.
Every other derived number must agree within the tolerance either way.  Timings (``seconds``) are measurements of
the run, not statements about the loop, and are not re-checked.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from fsmctl.enclosures.branch_bound import (
    EXCLUDED,
    POSITIVE,
    PROVED,
    UNDECIDED,
    SignSearch,
    bisection_leaves,
    enclose_sharp,
    volume_share,
)
from fsmctl.proofs.certify import (
    ASYMPTOTIC,
    BALL_PRECISION,
    BOUNDARY_BUDGET,
    CERTIFIED,
    COUNTEREXAMPLE,
    ULTIMATELY_BOUNDED,
    CandidateOutcome,
    boundary_level,
    counterexample_at,
    inner_target,
    inside_core,
    levels_report,
    lyapunov_programs,
    origin_argument,
    sos_polynomials,
)
from fsmctl.proofs.certify_problem import Candidate, CertifyProblem
from fsmctl.proofs.certify_sos import float_below, sos_decrease, verify_sos

__all__ = ["DERIVED_TOLERANCE", "EXACT", "HIGHER", "LOWER", "Derived", "compare_derived", "recheck"]

DERIVED_TOLERANCE = 1e-9
"""relative tolerance between a derived number of a certificate file and its recomputation by ``--check``: room for
floating-point differences between machines (libm, the order of sums), far below the report's printed digits (4 to 9
significant), so that a number changed by 1e-6 or more fails; a bound may also be weaker (see the module docstring)"""

LOWER, HIGHER, EXACT = "lower", "higher", "exact"
"""which way a derived number is more favourable: a bound below (``LOWER``: extents, times), a bound above
(``HIGHER``: rates, decreases), or neither (``EXACT``: agreement within :data:`DERIVED_TOLERANCE` either way)"""


@dataclass(frozen=True)
class Derived:
    """One number of the file's report recomputed at the check.

    ``field`` names it in the JSON (``outcome.reach_time``), ``file`` is the file's value and ``found`` the
    recomputed one (None: the file or the check has none), ``favourable`` which way it is more favourable
    (:data:`LOWER`, :data:`HIGHER` or :data:`EXACT`).
    """

    field: str
    file: float | str | None
    found: float | str | None
    favourable: str = EXACT


def _proved_again(progs, lo: np.ndarray, hi: np.ndarray, batch: int = 4096) -> np.ndarray:
    """``(k,)``: an upper bound of ``V_dot`` on each leaf (rows), as the search's (``< 0``: re-proved)."""
    top = np.zeros(lo.shape[0])
    for i in range(0, lo.shape[0], batch):
        _, top[i : i + batch], _ = enclose_sharp(
            progs.W, lo[i : i + batch].T.copy(), hi[i : i + batch].T.copy(), gradient=progs.dW
        )
    return top


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


Step = Callable[..., None]
"""``step(passed, text, failed=None)``: one line of the re-check (``failed``: its wording when it fails; ``passed``
None: a line that reports without deciding, marked ``--``)"""


def recheck(problem: CertifyProblem, V, d: dict, *, arb_sample: int | None, seed: int) -> tuple[bool, list[str]]:
    """Re-prove a certificate's statements (see the module docstring); ``(ok, one line per step)``."""
    progs = lyapunov_programs(problem, V)
    out, verdict = d["outcome"], d["verdict"]
    lines: list[str] = []
    ok = True

    def step(passed: bool | None, text: str, failed: str | None = None) -> None:
        nonlocal ok
        if passed is None:
            lines.append(f"[--] {text}")
            return
        ok = ok and passed
        lines.append(f"[{'ok' if passed else 'FAILS'}] {text if passed or failed is None else failed}")

    candidate = _candidate(d["candidate"], V)
    derived = [Derived("candidate.describe", d["candidate"].get("describe"), candidate.describe())]
    if verdict == COUNTEREXAMPLE:
        derived += _recheck_counterexample(problem, progs, out, step)
    elif verdict != CERTIFIED:
        lines.append(f"the certificate is {verdict}: nothing is claimed to re-check")
        return True, lines
    elif out.get("sos"):
        derived += _recheck_sos(problem, progs, candidate, out, step)
    else:
        found = _recheck_search(problem, progs, candidate, d, step, arb_sample=arb_sample, seed=seed)
        if found is None:
            return ok, lines
        derived += found
    for passed, text in compare_derived(derived):
        step(passed, text)
    return ok, lines


def _candidate(record: dict, V) -> Candidate:
    """The candidate as the file records it, with ``V`` as re-read from its exact tree."""
    P = record.get("P")
    return Candidate(
        record.get("kind", ""), V, epsilon=record.get("epsilon"), P=None if P is None else tuple(map(tuple, P)),
        note=record.get("note", ""),
    )  # fmt: skip


def _recheck_counterexample(problem: CertifyProblem, progs, out: dict, step: Step) -> list[Derived]:
    """A counterexample's ``V_dot > 0`` in ball arithmetic, and its values recomputed at its point."""
    c = out["counterexample"]
    x = np.array([[c["point"][name] for name in problem.names]], float)
    again = counterexample_at(problem, progs, x)
    step(
        again["confirmed"],
        f"V_dot > 0 at the counterexample in ball arithmetic: {again['V_dot_ball']}",
        f"V_dot > 0 at the counterexample is not confirmed in ball arithmetic: {again['V_dot_ball']}",
    )
    return [
        Derived("outcome.counterexample.V_dot", c.get("V_dot"), again["V_dot"], HIGHER),
        Derived("outcome.counterexample.V_dot_ball", c.get("V_dot_ball"), again["V_dot_ball"]),
        Derived("outcome.counterexample.V", c.get("V"), again["V"]),
    ]


def _recheck_search(
    problem: CertifyProblem, progs, candidate: Candidate, d: dict, step: Step, *, arb_sample: int | None, seed: int
) -> list[Derived] | None:
    """A certificate of the branch and bound: its leaves, levels and core re-proved, and its derived numbers
    recomputed (None when the bisection tree does not rebuild)."""
    out = d["outcome"]
    tree = d.get("tree") or {}
    try:
        leaves = bisection_leaves(problem.lo, problem.hi, tree["codes"], tree["batch"])
    except (KeyError, ValueError) as exc:
        step(False, f"the bisection tree does not partition the region: {exc}")
        return None
    boxes = int(tree["codes"].size)
    step(
        True,
        f"{boxes} box{'es' * (boxes != 1)} of the recorded bisection rebuilt: a partition of the region x uncertainty",
    )
    plo, phi = leaves[PROVED]
    top = _proved_again(progs, plo, phi)
    good = top < 0
    step(
        bool(good.all()), f"V_dot < 0 re-proved on {int(good.sum())} of {good.size} leaves (outward-rounded intervals)"
    )
    c_bnd = boundary_level(problem, progs, BOUNDARY_BUDGET)
    _step_level(step, out["level"], c_bnd)
    olo = np.concatenate([leaves[POSITIVE][0], leaves[UNDECIDED][0]])
    ohi = np.concatenate([leaves[POSITIVE][1], leaves[UNDECIDED][1]])
    core, derived = _recheck_core(problem, progs, out, step)
    if leaves[EXCLUDED][0].shape[0]:
        _recheck_excluded(problem, progs, out, core, leaves, step)
    asymptotic = d["kind"] == ASYMPTOTIC
    if asymptotic:
        unproved = int(olo.shape[0])
        step(
            unproved == 0,
            "every leaf outside the core is proved"
            if unproved == 0
            else f"{unproved} lea{'ves' if unproved != 1 else 'f'} outside the core not proved",
        )
    else:
        _step_inner(step, progs, olo, ohi, out["inner_level"], out["level"])
    scale = np.where(problem.hi > problem.lo, problem.hi - problem.lo, 1.0)
    confirmed, sampled = _recheck_arb(progs, plo, phi, arb_sample, seed, scale)
    # midpoint-radius balls enclose long graphs more widely than endpoint intervals: a leaf the ball route cannot
    # confirm within ARB_SPLIT_DEPTH halvings is reported, not counted against the certificate, which rests on the
    # outward-rounded route re-run above on every leaf
    step(
        True if confirmed == sampled else None,
        f"ball arithmetic (python-flint arb) confirms V_dot < 0 on {confirmed} of {sampled} sampled leaves"
        + ("" if confirmed == sampled else " (the others: wider in ball arithmetic than their margin, not a failure)"),
    )
    search = SignSearch(
        plo, phi, top, *leaves[POSITIVE], np.zeros((0, problem.lo.size)), np.zeros(0), *leaves[UNDECIDED],
        *leaves[EXCLUDED], boxes=0, seconds=0.0, exhausted=False,
    )  # fmt: skip
    target = inner_target(c_bnd, asymptotic)
    derived += [
        Derived("outcome.boundary_level", out.get("boundary_level"), c_bnd, HIGHER),
        Derived("outcome.inner_target", out.get("inner_target"), target),
    ]
    derived += _search_numbers(problem, out, tree, leaves)
    return derived + _level_numbers(problem, progs, candidate, d, None if asymptotic else out["inner_level"], search)


def _step_level(step: Step, level: float, c_bnd: float) -> None:
    step(
        level <= c_bnd,
        f"level c = {level:.9g} <= min V on the region's boundary ({c_bnd:.9g})",
        f"the file's level c = {level:.9g} exceeds min V on the region's boundary ({c_bnd:.9g}): {{V <= c}} is not "
        "proved to lie in the region",
    )


def _step_inner(step: Step, progs, olo: np.ndarray, ohi: np.ndarray, c_in: float, level: float) -> None:
    """Ultimately bounded: every leaf not proved lies in ``{V <= c_in}``, and ``c_in < c``."""
    _, vhi = progs.v_bounds(olo, ohi)
    top = float(vhi.max()) if vhi.size else 0.0
    step(
        top <= c_in and c_in < level,
        f"every leaf not proved lies in {{V <= c_in = {c_in:.9g}}} and c_in < c",
        f"the file's c_in = {c_in:.9g} (c = {level:.9g}): the leaves not proved reach V = {top:.9g}"
        + ("" if c_in < level else "; c_in >= c"),
    )


def _recheck_core(problem: CertifyProblem, progs, out: dict, step: Step) -> tuple[dict, list[Derived]]:
    """The origin's argument re-proved on the file's core box (when the file states it): the re-proved core (to
    judge the leaves left to it) and its constants against the file's."""
    core = out.get("core") or {}
    if not core.get("passed"):
        return {}, []
    box = np.asarray(core.get("fractions") or [core["fraction"]] * problem.n_state)
    again = origin_argument(problem, progs, box=box)
    step(
        bool(again.get("passed")),
        "the origin's argument (ball arithmetic at 0, Hessian on the core box) holds",
        f"the origin's argument fails on the file's core box: {again.get('why', '')}",
    )
    if not again.get("passed"):
        return {}, []
    derived = [
        Derived("outcome.core.mu", core.get("mu"), again["mu"], HIGHER),
        Derived("outcome.core.w0", core.get("w0"), again["w0"], LOWER),
        Derived("outcome.core.G", core.get("G"), again["G"], LOWER),
        Derived("outcome.core.r_star", core.get("r_star"), again["r_star"], LOWER),
    ]
    for k, (a, b) in enumerate(zip(core.get("half_widths", []), again["half_widths"], strict=False)):
        derived.append(Derived(f"outcome.core.half_widths[{k}]", a, b))
    return again, derived


def _recheck_excluded(problem, progs, out: dict, core: dict, leaves, step: Step) -> None:
    """The leaves the search left out: inside the re-proved core where the origin's argument proves ``V_dot < 0``,
    or (ultimately bounded) where ``V <= c_in`` is proved, so that they belong to the inner set."""
    xlo, xhi = leaves[EXCLUDED]
    ok = np.zeros(xlo.shape[0], bool)
    if core.get("passed"):
        ok |= inside_core(problem, core, progs)(xlo.T.copy(), xhi.T.copy())
    in_core = int(ok.sum())
    c_in = out.get("inner_level")
    if c_in is not None and not ok.all():
        _, vhi = progs.v_bounds(xlo[~ok], xhi[~ok])
        ok[~ok] = vhi <= c_in
    inner = f", {xlo.shape[0] - in_core} in {{V <= c_in}}" if c_in is not None else ""
    step(
        bool(ok.all()),
        f"{in_core} leaves proved by the origin's argument{inner}, of {xlo.shape[0]} left out",
        f"{int((~ok).sum())} of the {xlo.shape[0]} leaves left out lie neither in the re-proved core"
        + (" nor in {V <= c_in}" if c_in is not None else ""),
    )


def _search_numbers(problem: CertifyProblem, out: dict, tree: dict, leaves: dict) -> list[Derived]:
    """The search's statistics the report prints, from the rebuilt leaves: the volume fractions (each leaf's share
    of the region x uncertainty, over the inputs of positive width) and, for a search that was not cut short, its
    box count."""
    width = problem.hi - problem.lo
    spanned = width > 0
    volume = out.get("volume") or {}
    derived = []
    for kind, name in ((PROVED, "proved"), (POSITIVE, "positive"), (UNDECIDED, "undecided"), (EXCLUDED, "excluded")):
        lo, hi = leaves.get(kind, (np.zeros((0, width.size)),) * 2)
        derived.append(Derived(f"outcome.volume.{name}", volume.get(name), volume_share(lo, hi, width, spanned)))
    if not out.get("exhausted"):
        derived.append(Derived("outcome.boxes", out.get("boxes"), int(tree["codes"].size)))
    return derived


def _level_numbers(
    problem: CertifyProblem, progs, candidate: Candidate, d: dict, c_in: float | None, search: SignSearch | None
) -> list[Derived]:
    """The extents of ``{V <= c}``, the ultimate bound, the decrease and the reach time, recomputed from the file's
    (re-checked) levels by the certify run's own rule (``fsmctl.proofs.certify``'s levels report) on the re-proved
    leaves (``search``; None for a sum-of-squares certificate, whose decrease follows from its rate)."""
    out = d["outcome"]
    again = CandidateOutcome(candidate, CERTIFIED, d["kind"], level=out["level"], inner_level=c_in)
    again.search = search
    levels_report(problem, progs, again, c_in)
    derived = _dict_numbers("outcome.level_extent", out.get("level_extent"), again.level_extent, LOWER)
    derived += _dict_numbers("outcome.ultimate_bound", out.get("ultimate_bound"), again.ultimate_bound, LOWER)
    decrease, reach_time = again.decrease, again.reach_time
    if out.get("sos"):
        rate = float_below(Fraction(out["sos"]["lambda"]))
        derived.append(Derived("outcome.sos.rate", out["sos"].get("rate"), rate, HIGHER))
        decrease, reach_time = sos_decrease(rate, out["inner_level"], out["level"])
    derived.append(Derived("outcome.decrease", out.get("decrease"), decrease, HIGHER))
    derived.append(Derived("outcome.reach_time", out.get("reach_time"), reach_time, LOWER))
    return derived


def _dict_numbers(name: str, stated: dict | None, found: dict | None, favourable: str) -> list[Derived]:
    stated, found = stated or {}, found or {}
    return [Derived(f"{name}.{k}", stated.get(k), found.get(k), favourable) for k in {**stated, **found}]


def compare_derived(derived: list[Derived], tolerance: float = DERIVED_TOLERANCE) -> list[tuple[bool, str]]:
    """``(passed, line)`` per judgement of the file's derived numbers against their recomputation: one line for all
    that agree, one per weaker bound (accepted), one per disagreement (naming the field, the file's value and the
    recomputed one).

    A number agrees when ``|file - found| <= tolerance max(|file|, |found|)`` (text: when equal); a bound that is
    weaker than the recomputed one (:class:`Derived`'s ``favourable``) is accepted as a weaker true statement; a
    number the file states and the check cannot derive fails; one the file leaves out is not a statement.

    Parameters
    ----------
    derived : list of Derived
        The numbers.
    tolerance : float
        Relative.

    Returns
    -------
    list of (bool, str)

    Examples
    --------
    >>> from fsmctl.proofs.certify_check import HIGHER, LOWER, Derived, compare_derived
    >>> for passed, line in compare_derived([Derived("outcome.reach_time", 8.7, 8.8324, LOWER),
    ...                                      Derived("outcome.decrease", 3.0, 3.5098, HIGHER),
    ...                                      Derived("outcome.level", 1.0, 1.0 + 1e-12)]):
    ...     print(passed, line)
    True 1 derived number re-derived from the re-checked data agrees with the file (within 1e-09 relative): outcome.level
    False outcome.reach_time: the file states 8.7, re-derived 8.8324 (more favourable than proved)
    True outcome.decrease: the file states 3, weaker than the re-derived 3.5098 (accepted: a weaker true statement)
    """
    agree: list[str] = []
    lines: list[tuple[bool, str]] = []
    for x in derived:
        verdict = _judge_one(x, tolerance)
        if verdict == "agrees":
            agree.append(x.field)
        elif verdict == "weaker":
            lines.append(
                (True, f"{x.field}: the file states {_show(x.file)}, weaker than the re-derived {_show(x.found)} "
                 "(accepted: a weaker true statement)")
            )  # fmt: skip
        elif verdict != "absent":
            lines.append(
                (False, f"{x.field}: the file states {_show(x.file)}, re-derived {_show(x.found)} ({verdict})")
            )
    if agree:
        many = (
            "numbers re-derived from the re-checked data agree"
            if len(agree) > 1
            else "number re-derived from the re-checked data agrees"
        )
        lines.insert(
            0, (True, f"{len(agree)} derived {many} with the file (within {tolerance:g} relative): {', '.join(agree)}")
        )
    return lines


def _judge_one(x: Derived, tolerance: float) -> str:
    """``agrees``, ``weaker``, ``absent`` (the file does not state it), or why it fails."""
    if x.file is None:
        return "absent"
    if x.found is None:
        return "the re-checked data give no such number"
    if isinstance(x.found, str) or isinstance(x.file, str):
        return "agrees" if x.file == x.found else "differs"
    if isinstance(x.file, bool) or not isinstance(x.file, (int, float)):
        return "not a number"
    a, b = float(x.file), float(x.found)
    if a == b or abs(a - b) <= tolerance * max(abs(a), abs(b)):
        return "agrees"
    if (x.favourable == LOWER and a > b) or (x.favourable == HIGHER and a < b):
        return "weaker"
    if x.favourable == EXACT:
        return f"differs by more than {tolerance:g} relative"
    return "more favourable than proved"


def _show(v) -> str:
    return "none" if v is None else repr(v) if isinstance(v, str) else f"{v:.9g}"


def _recheck_arb(progs, plo, phi, arb_sample, seed, scale) -> tuple[int, int]:
    """``(confirmed, sampled)``: sampled proved leaves on which ball arithmetic confirms ``V_dot < 0``."""
    k = plo.shape[0]
    rows = np.arange(k)
    if arb_sample is not None and arb_sample < k:
        rows = np.sort(np.random.default_rng(seed).choice(k, size=arb_sample, replace=False))
    bad = sum(1 for r in rows if not _arb_proves(progs, plo[r], phi[r], scale, ARB_SPLIT_DEPTH))
    return len(rows) - bad, len(rows)


def _recheck_sos(problem: CertifyProblem, progs, candidate: Candidate, out: dict, step: Step) -> list[Derived]:
    """An ultimately bounded certificate by sum of squares: the identity re-checked exactly from the law's equations
    (:func:`fsmctl.proofs.certify_sos.verify_sos`), its levels against the file's and ``V`` on the boundary, and the
    derived numbers recomputed."""
    polys = sos_polynomials(problem, candidate.expression, progs.W_function)
    if isinstance(polys, str):
        step(False, f"the sum-of-squares question cannot be rebuilt: {polys}")
        return []
    Vp, Wp, half, names = polys
    record = out["sos"]
    step(
        names == record["variables"],
        f"the identity's variables are the closed loop's ({', '.join(names)})",
        f"the identity's variables ({', '.join(record['variables'])}) are not the closed loop's ({', '.join(names)})",
    )
    good, text = verify_sos(Vp, Wp, half, record)
    step(good, text)
    c_in, c = Fraction(record["inner_level"]), Fraction(record["level"])
    step(
        float(c_in) <= out["inner_level"] and Fraction(out["level"]) <= c,
        f"the file's levels c_in = {out['inner_level']:.9g}, c = {out['level']:.9g} are the identity's",
        f"the file's levels c_in = {out['inner_level']:.9g}, c = {out['level']:.9g} are not within the identity's "
        f"(c_in = {float(c_in):.9g}, c = {float(c):.9g})",
    )
    c_bnd = boundary_level(problem, progs, BOUNDARY_BUDGET)
    _step_level(step, float(c), c_bnd)
    derived = [Derived("outcome.boundary_level", out.get("boundary_level"), c_bnd, HIGHER)]
    return derived + _level_numbers(
        problem, progs, candidate, {"outcome": out, "kind": ULTIMATELY_BOUNDED}, out["inner_level"], None
    )
