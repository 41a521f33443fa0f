"""The claims of Liang, Sun & Wang (2012), Section 4, as a registry, and their grading.

Each :class:`StudyClaim` of :data:`CLAIMS` is everything ``fsmctl reproduce`` knows of one claim, in one place:
the runs of :func:`~fsmctl.studies.paper_runs.run_plan` that decide it, what must hold (its test), the numbers the
report shows (this run's value) and the explanations show, the verdict rule when it does not hold (with the
diagnostic runs that show why), and what would reproduce it (whether the explanations also search the settling
tolerance).  :func:`evaluate_claims` grades them all; :mod:`fsmctl.studies.explain` searches, for those that do not
hold, the smallest change that makes :meth:`StudyClaim.holds` pass.  Adding a claim is adding one entry to
:data:`CLAIMS` (the developer guide shows a worked example).

The form of an entry and the verdicts are in :mod:`fsmctl.studies.claim_types`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

from fsmctl.policy import SETTLING_TOLERANCES_DEG, steady_window_text
from fsmctl.studies.claim_types import (
    DIFFERS,
    IMPOSSIBLE,
    PAPER_SETTLING_TIME_S,
    REPRODUCED,
    ClaimVerdict,
    Grading,
    Outcome,
    StudyClaim,
)
from fsmctl.studies.momentum import MomentumBound
from fsmctl.studies.paper_statements import (
    CASE2_RELATIVE_ERROR,
    CASE2_TRACKING_ERROR,
    RELATIVE_ACCURACY,
    TRACKING_ACCURACY,
)
from fsmctl.studies.records import RunRecord
from fsmctl.studies.wording import duration_phrase, join_words

__all__ = [
    "PAPER_TRACKING_ACCURACY_DEG",
    "PAPER_RELATIVE_ACCURACY_DEG",
    "PAPER_CASE2_TRACKING_DEG",
    "PAPER_CASE2_RELATIVE_DEG",
    "CLAIMS",
    "claim_ids",
    "get_claim",
    "evaluate_claims",
]

# the paper's stated values (fsmctl.studies.paper_statements, their one home)
PAPER_TRACKING_ACCURACY_DEG = TRACKING_ACCURACY.value
PAPER_RELATIVE_ACCURACY_DEG = RELATIVE_ACCURACY.value
PAPER_CASE2_TRACKING_DEG = CASE2_TRACKING_ERROR.value
PAPER_CASE2_RELATIVE_DEG = CASE2_RELATIVE_ERROR.value

Runs = Mapping[str, RunRecord]


# ----------------------------------------------------------------------------- texts


def _fmt_s(x: float, horizon: float | None = None) -> str:
    if not math.isfinite(x):
        return "not within " + (f"{horizon:g} s" if horizon else "the horizon")
    return f"{x:.2f} s"


def _fmt_deg(x: float) -> str:
    if not math.isfinite(x):
        return "n/a"
    return f"{x:.3g}°" if abs(x) < 1 else f"{x:.1f}°"


def _s(x: float) -> str:
    return "–" if not math.isfinite(x) else f"{x:.2f} s"


def _d(x: float) -> str:
    return f"{x:.3g}°"


def _short_s(x: float) -> str:
    return f"{x:.1f} s" if math.isfinite(x) else "not settled"


def _saturation_text(r: RunRecord) -> str:
    """``"each agent saturated for the whole 100 s"``, ``"... for 12.0–26.7 s of 100 s"``, ``"never saturated"``."""
    phrase = duration_phrase(r.saturated_time_s, r.t_final)
    return "never saturated" if phrase == "never" else f"each agent saturated {phrase}"


def _settling_text(r: RunRecord, metric: str) -> str:
    parts = [f"{tol:g}°: {_fmt_s(r.settling(metric, tol), r.t_final)}" for tol in SETTLING_TOLERANCES_DEG]
    return ", ".join(parts)


def _inf_if_nan(x: float) -> float:
    return math.inf if not math.isfinite(x) else x


def _steady(r: RunRecord, metric: str) -> float:
    return r.aaem_steady_max_deg if metric == "aaem" else r.raem_steady_max_deg


# ----------------------------------------------------------------------------- 1. settling within 27 s


def _settling_holds(R: Runs, tol: float) -> bool:
    c1 = R["case1"]
    return c1.settling("aaem", tol) <= PAPER_SETTLING_TIME_S and c1.settling("raem", tol) <= PAPER_SETTLING_TIME_S


def _settling_value(g: Grading) -> str:
    c1 = g["case1"]
    return f"Case 1 AAEM settles at {_settling_text(c1, 'aaem')}; RAEM at {_settling_text(c1, 'raem')}"


def _settling_short(g: Grading) -> str:
    c1, tol = g["case1"], g.tolerance_deg
    t_a, t_r = c1.settling("aaem", tol), c1.settling("raem", tol)
    if not math.isfinite(t_a) and not math.isfinite(t_r):
        return f"not settled to {tol:g}° in {c1.t_final:g} s"
    return f"AAEM {_short_s(t_a)}, RAEM {_short_s(t_r)} (to {tol:g}°)"


def _settling_numbers(R: Runs, tol: float) -> str:
    c1 = R["case1"]
    return f"Case 1 settles to {tol:g}°: AAEM {_s(c1.settling('aaem', tol))}, RAEM {_s(c1.settling('raem', tol))}"


def _settling_grade(g: Grading, holds: bool) -> Outcome:
    c1, nl1, tol, T = g["case1"], g["case1_no_torque_limit"], g.tolerance_deg, PAPER_SETTLING_TIME_S
    if holds:
        t_a, t_r = c1.settling("aaem", tol), c1.settling("raem", tol)
        return Outcome(REPRODUCED, f"AAEM and RAEM stay below {tol:g}° from {max(t_a, t_r):.2f} s on")
    if g.over:
        return Outcome(
            IMPOSSIBLE,
            f"{g.bound_text}; so no controller within the paper's torque limit settles by {T:g} s. "
            f"Without the limit the same law settles at {tol:g}° in {_fmt_s(nl1.settling('aaem', tol))} "
            f"but commands up to {nl1.commanded_peak_N_m:.4g} N m",
            nl1.key,
        )
    diag = [
        (g["case1_exact_error_model"], "error_model = exact"),
        (nl1, "no torque limit"),
        (g["case1_pure_sgn"], "pure sgn"),
    ]
    fixers = [
        f"{name} ({r.key}: {_fmt_s(_inf_if_nan(r.settling('aaem', tol)))} at {tol:g}°)"
        for r, name in diag
        if r.settling("aaem", tol) <= T and r.settling("raem", tol) <= T
    ]
    reason = ("settles by 27 s with: " + "; ".join(fixers)) if fixers else "no diagnostic run settles by 27 s either"
    return Outcome(DIFFERS, reason, ", ".join(r.key for r, _ in diag))


# ----------------------------------------------------------------------------- 2-3. steady-state accuracy


def _accuracy_holds(metric: str, paper: float) -> Callable[[Runs, float], bool]:
    return lambda R, tol: _steady(R["case1"], metric) <= paper


def _accuracy_value(metric: str) -> Callable[[Grading], str]:
    def value(g: Grading) -> str:
        c1 = g["case1"]
        return f"max {metric.upper()} over the last {c1.steady_window_s:g} s of Case 1: {_fmt_deg(_steady(c1, metric))}"

    return value


def _accuracy_short(metric: str) -> Callable[[Grading], str]:
    def short(g: Grading) -> str:
        c1 = g["case1"]
        return f"{_fmt_deg(_steady(c1, metric))} (max over the last {c1.steady_window_s:g} s)"

    return short


def _accuracy_numbers(metric: str) -> Callable[[Runs, float], str]:
    def numbers(R: Runs, tol: float) -> str:
        c1 = R["case1"]
        return f"Case 1 max {metric.upper()} over the last {c1.steady_window_s:g} s: {_d(_steady(c1, metric))}"

    return numbers


def _accuracy_grade(metric: str, paper: float) -> Callable[[Grading, bool], Outcome]:
    def grade(g: Grading, holds: bool) -> Outcome:
        c1, nl1, ex1, sgn1 = g["case1"], g["case1_no_torque_limit"], g["case1_exact_error_model"], g["case1_pure_sgn"]
        window_start = c1.t_final - c1.steady_window_s
        if holds:
            return Outcome(REPRODUCED, f"{_fmt_deg(_steady(c1, metric))} <= {paper:g}°")
        worst = g.worst
        if worst.min_time_s > window_start:
            return Outcome(
                IMPOSSIBLE,
                f"the momentum bound ({worst.min_time_s:.1f} s, agent {worst.agent}) exceeds the start of the "
                f"steady window ({window_start:g} s)",
                nl1.key,
            )
        no_limit = _steady(nl1, metric)
        reason = (
            f"Case 1 does not converge with the {c1.torque_limit:g} N m limit "
            f"({_saturation_text(c1).replace('each agent', 'every agent')}). Without the limit: {_fmt_deg(no_limit)} "
            f"({'meets' if no_limit <= paper else 'misses'} {paper:g}°); exact error model: "
            f"{_fmt_deg(_steady(ex1, metric))}; pure sgn: {_fmt_deg(_steady(sgn1, metric))}. The cause is the torque "
            "limit" + ("" if no_limit <= paper else " and more (the no-limit run misses it too)")
        )
        return Outcome(DIFFERS, reason, ", ".join(r.key for r in (nl1, ex1, sgn1)))

    return grade


def _accuracy_claim(cid: str, metric: str, paper: float, fig: str, name: str) -> StudyClaim:
    return StudyClaim(
        cid,
        f"{name} accuracy better than {paper:g}° (Case 1)",
        fig,
        f"< {paper:g}°",
        ("case1",),
        holds=_accuracy_holds(metric, paper),
        value=_accuracy_value(metric),
        numbers=_accuracy_numbers(metric),
        grade=_accuracy_grade(metric, paper),
        title=f"Case 1 {name.split(' (')[0]} accuracy ({metric.upper()})",
        short=_accuracy_short(metric),
        documented=DIFFERS,
    )


# ----------------------------------------------------------------------------- 4. saturation only at the start


def _saturation_holds(R: Runs, tol: float) -> bool:
    c1 = R["case1"]
    last = c1.last_saturation_s
    return not math.isfinite(last) or (last <= PAPER_SETTLING_TIME_S and last < c1.t_final - c1.steady_window_s)


def _saturation_value(g: Grading) -> str:
    c1 = g["case1"]
    last = c1.last_saturation_s
    when = f", last at {_fmt_s(last)}" if math.isfinite(last) else ""
    return (
        f"Case 1: {_saturation_text(c1)} (torque on any axis){when}; peak commanded |u_k| "
        f"{c1.commanded_peak_N_m:.4g} N m"
    )


def _saturation_short(g: Grading) -> str:
    c1 = g["case1"]
    last = c1.last_saturation_s
    if not math.isfinite(last):
        return "never saturated"
    phrase = duration_phrase(c1.saturated_time_s, c1.t_final)
    if phrase.startswith("for the whole"):
        return f"saturated {phrase}"
    return f"saturated until {last:.1f} s (of {c1.t_final:g} s)"


def _saturation_numbers(R: Runs, tol: float) -> str:
    c1 = R["case1"]
    last = c1.last_saturation_s
    if not math.isfinite(last):
        return "Case 1 never saturated"
    return f"Case 1 last saturation at {last:.2f} s, {_saturation_text(c1)}"


def _saturation_grade(g: Grading, holds: bool) -> Outcome:
    c1, nl1 = g["case1"], g["case1_no_torque_limit"]
    if holds:
        return Outcome(REPRODUCED, "no saturation after the transient")
    if g.over:
        return Outcome(
            IMPOSSIBLE,
            f"saturating only a few times while settling within {PAPER_SETTLING_TIME_S:g} s is impossible: "
            f"{g.bound_text} even at full torque on all axes all the time. This law commands up to "
            f"{c1.commanded_peak_N_m:.4g} N m (no-limit run: {nl1.commanded_peak_N_m:.4g} N m) and stays saturated",
            nl1.key,
        )
    return Outcome(
        DIFFERS,
        f"the law commands up to {nl1.commanded_peak_N_m:.4g} N m without the limit "
        f"({nl1.commanded_peak_N_m / c1.torque_limit:.0f}x the limit): the torque limit keeps it saturated",
        nl1.key,
    )


# ----------------------------------------------------------------------------- 5. Case 2 settles much slower


def _slower_holds(R: Runs, tol: float) -> bool:
    s1, s2 = (_inf_if_nan(R[k].settling("aaem", tol)) for k in ("case1", "case2"))
    return math.isfinite(s1) and s2 >= 2 * s1


def _aaem_settling(g: Grading, *keys: str) -> list[float]:
    return [_inf_if_nan(g[k].settling("aaem", g.tolerance_deg)) for k in keys]


def _slower_value(g: Grading) -> str:
    c1, c2, nl1, nl2, long1, long2 = (
        g[k] for k in ("case1", "case2", "case1_no_torque_limit", "case2_no_torque_limit", "case1_long", "case2_long")
    )
    s1, s2, n1, n2, l1, l2 = _aaem_settling(
        g, "case1", "case2", "case1_no_torque_limit", "case2_no_torque_limit", "case1_long", "case2_long"
    )
    return (
        f"AAEM settling at {g.tolerance_deg:g}°: Case 1 {_fmt_s(s1, c1.t_final)}, Case 2 {_fmt_s(s2, c2.t_final)}; "
        f"{long1.t_final:g} s runs: Case 1 {_fmt_s(l1, long1.t_final)}, Case 2 {_fmt_s(l2, long2.t_final)}; "
        f"no torque limit: Case 1 {_fmt_s(n1, nl1.t_final)}, Case 2 {_fmt_s(n2, nl2.t_final)}"
    )


def _slower_short(g: Grading) -> str:
    s1, s2 = _aaem_settling(g, "case1", "case2")
    if math.isfinite(s1) or math.isfinite(s2):
        return f"AAEM to {g.tolerance_deg:g}°: Case 1 {_short_s(s1)}, Case 2 {_short_s(s2)}"
    l1, l2 = _aaem_settling(g, "case1_long", "case2_long")  # neither within the horizon: the order on the long runs
    return (
        f"AAEM to {g.tolerance_deg:g}° in {g['case1_long'].t_final:g} s: Case 1 {_short_s(l1)}, Case 2 {_short_s(l2)}"
    )


def _slower_numbers(R: Runs, tol: float) -> str:
    s1, s2 = R["case1"].settling("aaem", tol), R["case2"].settling("aaem", tol)
    return f"AAEM settles to {tol:g}°: Case 1 {_s(s1)}, Case 2 {_s(s2)} (horizon {R['case2'].t_final:g} s)"


def _slower_grade(g: Grading, holds: bool) -> Outcome:
    if holds:
        return Outcome(REPRODUCED, "Case 2 takes at least twice as long as Case 1")
    c1, nl2, long1 = g["case1"], g["case2_no_torque_limit"], g["case1_long"]
    n1, n2, l1, l2 = _aaem_settling(g, "case1_no_torque_limit", "case2_no_torque_limit", "case1_long", "case2_long")
    long_order = (
        "Case 2 converges first: with the limit the ordering is reversed"
        if l2 < l1
        else "Case 2 is still the slower one"
        if l1 < l2
        else "neither converges"
    )
    nolimit_order = (
        "the paper's ordering holds" if math.isfinite(n1) and n2 >= 2 * n1 else "the ordering does not hold either"
    )
    reason = (
        f"with the {c1.torque_limit:g} N m limit Case 1 itself does not settle within {c1.t_final:g} s; on the "
        f"{long1.t_final:g} s horizon {long_order}. Without the limit {nolimit_order} (Case 1 {_fmt_s(n1)}, Case 2 "
        f"{_fmt_s(n2, nl2.t_final)}): the coordination term speeds convergence only when the torque it demands is "
        "available"
    )
    runs = ("case1_long", "case2_long", "case1_no_torque_limit", "case2_no_torque_limit")
    return Outcome(DIFFERS, reason, ", ".join(g[k].key for k in runs))


# ----------------------------------------------------------------------------- 6. Case 2 accuracy


def _above_case2_levels(r: RunRecord) -> bool:
    return r.aaem_steady_max_deg > PAPER_CASE2_TRACKING_DEG and r.raem_steady_max_deg > PAPER_CASE2_RELATIVE_DEG


def _case2_runs(R: Runs, tol: float) -> tuple[RunRecord, ...]:
    """The runs the claim reads, the deciding one last: Case 2, and its long run when Case 2 has not settled within
    its horizon (and the long run is flown).  Every text of the claim quotes these runs and words their horizons and
    windows from them (under ``--fast`` Case 2 flies 10 s and its long run 30 s)."""
    c2 = R["case2"]
    return (c2,) if c2.settled(tol) or "case2_long" not in R else (c2, R["case2_long"])


def _case2_holds(R: Runs, tol: float) -> bool:
    run = _case2_runs(R, tol)[-1]
    return run.settled(tol) and _above_case2_levels(run)


def _case2_stages(R: Runs, tol: float) -> list[str] | None:
    if "case2" not in R:
        return ["case2"]
    if not R["case2"].settled(tol) and "case2_long" not in R:
        return ["case2_long"]
    return None


def _residual_text(r: RunRecord, tol: float) -> str:
    return (
        f"{r.title}, max over {steady_window_text(r.steady_window_s, r.t_final)}: "
        f"AAEM {_fmt_deg(r.aaem_steady_max_deg)}, RAEM {_fmt_deg(r.raem_steady_max_deg)}; "
        f"settled at {tol:g}°: {'yes' if r.settled(tol) else 'no'}"
    )


def _case2_value(g: Grading) -> str:
    return ". ".join(_residual_text(r, g.tolerance_deg) for r in _case2_runs(g.records, g.tolerance_deg))


def _case2_short(g: Grading) -> str:
    c2, tol = g["case2"], g.tolerance_deg
    run = _case2_runs(g.records, tol)[-1]
    if not run.settled(tol):
        return f"not settled to {tol:g}° in {run.t_final:g} s"
    errors = f"AAEM {_fmt_deg(run.aaem_steady_max_deg)}, RAEM {_fmt_deg(run.raem_steady_max_deg)}"
    return errors if run is c2 else f"{errors} (after settling, {run.t_final:g} s run)"


def _case2_numbers(R: Runs, tol: float) -> str:
    r = _case2_runs(R, tol)[-1]
    return (
        f"{r.title}: settles to {tol:g}° at {_s(r.settling('aaem', tol))}; max over the last "
        f"{r.steady_window_s:g} s: AAEM {_d(r.aaem_steady_max_deg)}, RAEM {_d(r.raem_steady_max_deg)}"
    )


def _case2_grade(g: Grading, holds: bool) -> Outcome:
    c2, long2, tol = g["case2"], g["case2_long"], g.tolerance_deg
    verdict = REPRODUCED if holds else DIFFERS
    if c2.settled(tol):
        above = _above_case2_levels(c2)
        return Outcome(
            verdict,
            "residual errors above both levels" if above else "Case 2 converges to errors below the paper's levels",
            long2.key,
        )
    if long2.settled(tol):
        reason = (
            f"the inequalities hold at {c2.t_final:g} s only because Case 2 has not converged yet; after it converges "
            f"({long2.key}, settles at {_fmt_s(_inf_if_nan(long2.settling('aaem', tol)))}) the residual errors over "
            f"its last {long2.steady_window_s:g} s are AAEM {_fmt_deg(long2.aaem_steady_max_deg)}, RAEM "
            f"{_fmt_deg(long2.raem_steady_max_deg)}, "
            + ("above" if _above_case2_levels(long2) else "below")
            + f" {PAPER_CASE2_TRACKING_DEG:g}° / {PAPER_CASE2_RELATIVE_DEG:g}°"
        )
        return Outcome(verdict, reason, long2.key)
    reason = (
        f"Case 2 does not converge within {long2.t_final:g} s; the inequalities hold only because the errors "
        "are still large"
    )
    return Outcome(verdict, reason, long2.key)


# ----------------------------------------------------------------------------- 7. Case 3 ordering

_CASE3 = ("case3a", "case3b", "case3c")
_CASE3_NO_LIMIT = ("case3a_no_torque_limit", "case3b_no_torque_limit", "case3c_no_torque_limit")


def _ordered(rs: Sequence[RunRecord]) -> bool:
    a = [r.aaem_steady_max_deg for r in rs]
    b = [r.raem_steady_max_deg for r in rs]
    return a[0] > a[1] > a[2] and b[0] > b[1] > b[2]


def _ordering_holds(R: Runs, tol: float) -> bool:
    c3 = [R[k] for k in _CASE3]
    return all(r.settled(tol) for r in c3) and _ordered(c3)


def _ordering_stages(R: Runs, tol: float) -> list[str] | bool | None:
    for k in ("case3c", "case3a", "case3b"):  # Case 3c is Case 1: usually flown already
        if k not in R:
            return [k]
        if not R[k].settled(tol):
            return False
    return None


def _ordering_table(rs: Sequence[RunRecord], tol: float) -> str:
    return "; ".join(
        f"{r.title.split(',')[0]}: AAEM {_fmt_deg(r.aaem_steady_max_deg)}, RAEM {_fmt_deg(r.raem_steady_max_deg)}"
        + ("" if r.settled(tol) else " (not settled)")
        for r in rs
    )


def _ordering_value(g: Grading) -> str:
    c3 = [g[k] for k in _CASE3]
    return f"max over the last {c3[0].steady_window_s:g} s: {_ordering_table(c3, g.tolerance_deg)}"


def _ordering_short(g: Grading) -> str:
    tol = g.tolerance_deg
    c3 = [g[k] for k in _CASE3]
    unsettled = [r.title.split(",")[0] for r in c3 if not r.settled(tol)]
    if len(unsettled) == len(c3):
        return f"none settles to {tol:g}° in {c3[0].t_final:g} s"
    if unsettled:
        return f"not settled to {tol:g}°: {join_words(unsettled)}"
    aaem = " / ".join(_fmt_deg(r.aaem_steady_max_deg) for r in c3)
    raem = " / ".join(_fmt_deg(r.raem_steady_max_deg) for r in c3)
    return f"3a / 3b / 3c: AAEM {aaem}; RAEM {raem}"


def _ordering_numbers(R: Runs, tol: float) -> str:
    return "; ".join(
        f"Case {R[k].case if k != 'case3c' else '3c'}: AAEM {_d(R[k].aaem_steady_max_deg)}, RAEM "
        f"{_d(R[k].raem_steady_max_deg)}" + ("" if R[k].settled(tol) else " (not settled)")
        for k in _CASE3
        if k in R
    )


def _ordering_grade(g: Grading, holds: bool) -> Outcome:
    if holds:
        return Outcome(REPRODUCED, "all converge; accuracy improves with the weights")
    tol = g.tolerance_deg
    c3, n3 = [g[k] for k in _CASE3], [g[k] for k in _CASE3_NO_LIMIT]
    settle_nl = [_inf_if_nan(r.settling("aaem", tol)) for r in n3]
    first = (
        "with the torque limit "
        + ("none" if not any(r.settled(tol) for r in c3) else "not all")
        + " of Cases 3a-3c converge, so accuracy cannot be ranked"
        if not all(r.settled(tol) for r in c3)
        else "all converge but the accuracy is not ordered by the weights"
    )
    reason = (
        f"{first}. Without the limit all settle (at {tol:g}° in "
        + ", ".join(_fmt_s(x) for x in settle_nl)
        + f") and the ordering {'holds' if _ordered(n3) else 'does not hold'}: {_ordering_table(n3, tol)}"
    )
    return Outcome(DIFFERS, reason, ", ".join(r.key for r in n3))


# ----------------------------------------------------------------------------- the registry

CLAIMS: tuple[StudyClaim, ...] = (
    StudyClaim(
        "settling_27s",
        "AAEM and RAEM fall to the tolerance within 27 s (Case 1)",
        "Figs 1-2",
        f"{PAPER_SETTLING_TIME_S:g} s (tolerance not stated)",
        ("case1",),
        holds=_settling_holds,
        value=_settling_value,
        numbers=_settling_numbers,
        grade=_settling_grade,
        title="Case 1 settling time",
        short=_settling_short,
        documented=IMPOSSIBLE,
        uses_tolerance=True,
    ),
    _accuracy_claim("tracking_accuracy", "aaem", PAPER_TRACKING_ACCURACY_DEG, "Fig 1 inset", "tracking (AAEM, eq 42)"),
    _accuracy_claim("relative_accuracy", "raem", PAPER_RELATIVE_ACCURACY_DEG, "Fig 2 inset", "relative (RAEM, eq 43)"),
    StudyClaim(
        "saturation_at_start",
        "torques reach the {limit:g} N m bound only a few times at the beginning (of the 27 s transient)",
        "Fig 4",
        "a few times, at the start",
        ("case1",),
        holds=_saturation_holds,
        value=_saturation_value,
        numbers=_saturation_numbers,
        grade=_saturation_grade,
        title="Case 1 torque saturation",
        short=_saturation_short,
        documented=IMPOSSIBLE,
    ),
    StudyClaim(
        "case2_slower",
        "without coordination (Case 2) the settling time increases significantly",
        "Figs 5-6",
        "much slower than Case 1",
        ("case1", "case2"),
        holds=_slower_holds,
        value=_slower_value,
        numbers=_slower_numbers,
        grade=_slower_grade,
        title="Case 2 (no coordination) settles slower",
        short=_slower_short,
        documented=DIFFERS,
        uses_tolerance=True,
    ),
    StudyClaim(
        "case2_accuracy",
        f"Case 2 errors: tracking > {PAPER_CASE2_TRACKING_DEG:g}°, relative > {PAPER_CASE2_RELATIVE_DEG:g}°",
        "Figs 5-6",
        f"> {PAPER_CASE2_TRACKING_DEG:g}° and > {PAPER_CASE2_RELATIVE_DEG:g}° (after convergence)",
        ("case2", "case2_long"),
        holds=_case2_holds,
        value=_case2_value,
        numbers=_case2_numbers,
        grade=_case2_grade,
        title="Case 2 residual errors",
        short=_case2_short,
        documented=DIFFERS,
        uses_tolerance=True,
        stages=_case2_stages,
        later=("case2", "case2_long"),
    ),
    StudyClaim(
        "case3_ordering",
        "Case 3: every weight converges; smaller weights give lower accuracy",
        "Figs 8-9",
        "accuracy 3a < 3b < 3c",
        _CASE3,
        holds=_ordering_holds,
        value=_ordering_value,
        numbers=_ordering_numbers,
        grade=_ordering_grade,
        title="Cases 3a-3c: accuracy ordered by weight",
        short=_ordering_short,
        documented=DIFFERS,
        uses_tolerance=True,
        stages=_ordering_stages,
    ),
)
"""The Section 4 claims, in the order of the paper's text."""


def claim_ids() -> list[str]:
    """The ids of :data:`CLAIMS`, in the order of the paper's text.

    Returns
    -------
    list of str
        The claim ids.

    Examples
    --------
    >>> claim_ids()[:3]
    ['settling_27s', 'tracking_accuracy', 'relative_accuracy']
    """
    return [c.id for c in CLAIMS]


def get_claim(claim_id: str) -> StudyClaim:
    """The claim of :data:`CLAIMS` with this id.

    Parameters
    ----------
    claim_id : str
        One of :func:`claim_ids`.

    Returns
    -------
    StudyClaim
        The registry entry.

    Raises
    ------
    KeyError
        If there is no such claim.

    Examples
    --------
    Case 1 flown for 2 s: its steady AAEM is far above the paper's 0.03 deg.

    >>> from fsmctl import simulate
    >>> from fsmctl.studies.paper_runs import run_plan, run_record, run_scenario
    >>> spec = run_plan()[0]
    >>> scenario = run_scenario("paper", spec, fast=True).replace(simulation={"t_final": 2.0})
    >>> records = {"case1": run_record(spec, scenario, simulate(scenario, progress=False))}
    >>> get_claim("tracking_accuracy").holds(records, 1.0), records["case1"].aaem_steady_max_deg > 0.03
    (False, True)
    """
    for c in CLAIMS:
        if c.id == claim_id:
            return c
    raise KeyError(f"unknown claim {claim_id!r} (claims: {', '.join(claim_ids())})")


def evaluate_claims(records: Mapping[str, RunRecord], bounds: Sequence[MomentumBound]) -> list[ClaimVerdict]:
    """Grade the Section 4 claims of Liang et al. (2012) against the runs of the plan.

    Parameters
    ----------
    records : mapping run key -> RunRecord
        Every run of :func:`~fsmctl.studies.paper_runs.run_plan`.
    bounds : sequence of MomentumBound
        :func:`~fsmctl.studies.momentum.angular_momentum_bound` of the Case 1 scenario.

    Returns
    -------
    list of ClaimVerdict
        One per claim of :data:`CLAIMS`, in the order of the paper's text; every verdict is one of
        :data:`~fsmctl.studies.claim_types.VERDICTS`.

    Examples
    --------
    The verdicts on 1 s runs (the reproduction flies 100 s): the 27 s settling is impossible whatever the
    horizon, by the angular-momentum bound.

    >>> from fsmctl import paper_scenario
    >>> from fsmctl.studies.momentum import angular_momentum_bound
    >>> records = one_second_records()  # conftest.py: the plan's runs, 1 s each (shared)
    >>> claims = evaluate_claims(records, angular_momentum_bound(paper_scenario("1")))
    >>> [c.id for c in claims] == claim_ids()
    True
    >>> claims[0].id, claims[0].verdict
    ('settling_27s', 'impossible (bound)')
    """
    grading = Grading(records, bounds)
    return [claim.verdict(grading) for claim in CLAIMS]
