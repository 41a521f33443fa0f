"""The text of ``fsmctl prove theorem2-delta``: Theorem 2's switching gain against its certified requirement.

Liang et al. (2012), eqs 29-33 (corrected): the reaching condition needs ``(delta_i)_k > sup (1+kappa_i)|d_i|_k``
(1/s^2) over the region; :func:`fsmctl.proofs.theorem2_bound.certified_delta_requirements` encloses that supremum
per agent and axis.  This module turns its outcome into what a reader takes in at a glance: one line with the
question and the verdict (:func:`verdict_line`), an aligned table per agent and axis (:func:`requirement_table`),
the point where the reaching condition fails (:func:`reaching_lines`), and the sampled numbers as context
(:func:`sampled_table`).

Agents and axes are numbered from 1, as in the paper.  Table rows are returned indented by
:data:`PREFORMATTED` (``fsmctl prove --report`` keeps them as a block).  Every number is also in the claim's
JSON data, at full precision.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from fsmctl.proofs import theorem2 as t2
from fsmctl.proofs import theorem2_bound as t2b
from fsmctl.proofs.rounding import round_outward

__all__ = [
    "NEGLIGIBLE",
    "PREFORMATTED",
    "SIGNIFICANT_DIGITS",
    "axis_verdict",
    "format_point",
    "reaching_lines",
    "requirement_table",
    "sampled_table",
    "search_line",
    "verdict_line",
]

SIGNIFICANT_DIGITS = 3
"""Significant digits of the numbers in the tables (the JSON data keeps full precision)."""

NEGLIGIBLE = 1e-9
"""A coordinate of a witness point smaller than this fraction of its vector's largest component is shown as ``~0``:
zero up to the floating-point rounding of the search (its exact value is said below the point and is in the JSON)."""

PREFORMATTED = "  "
"""Indent of the rows of a table in the detail of a claim (a Markdown report keeps such rows as a block)."""

UNITS = {"sigma_e": "", "omega_e": "rad/s", "omega_d": "rad/s", "u_d": "N m", "omega_d_dot": "rad/s^2"}
"""Units of the inputs :data:`fsmctl.proofs.theorem2_bound.VARIABLES` of a witness point."""

MET, MISSED, OPEN = "met", "MISSED", "open"


def _sig(x: float) -> str:
    return f"{x:.{SIGNIFICANT_DIGITS}g}" if math.isfinite(x) else "inf"


def _vector(v: Sequence[float]) -> str:
    return "(" + ", ".join(_sig(float(x)) for x in v) + ")"


def axis_verdict(axis: t2b.AxisBound, proportional: bool = True) -> str:
    """Whether the configured delta meets the certified requirement on one axis.

    Parameters
    ----------
    axis : AxisBound
        The certified interval of one agent and axis.
    proportional : bool
        ``Delta_J = kappa J0`` (the requirement is exact); otherwise its interval bounds a sufficient condition
        and a delta below it refutes nothing.

    Returns
    -------
    str
        ``met`` (delta above the upper bound), ``MISSED`` (below the lower bound) or ``open`` (inside).

    Examples
    --------
    >>> from fsmctl.proofs.theorem2_bound import AxisBound
    >>> a = AxisBound(axis=1, configured=0.005, upper=1.85, lower=0.3, witness=(), converged=False, boxes=1,
    ...               seconds=0.1)
    >>> axis_verdict(a), axis_verdict(a, proportional=False)
    ('MISSED', 'open')
    """
    if axis.configured > axis.upper:
        return MET
    if proportional and axis.configured < axis.lower:
        return MISSED
    return OPEN


def _counts(cert: t2b.Theorem2Bound) -> dict[str, int]:
    counts = {MET: 0, MISSED: 0, OPEN: 0}
    for g in cert.groups:
        for a in g.axes:
            counts[axis_verdict(a, g.kappa is not None)] += len(g.agents)
    return counts


def verdict_line(cert: t2b.Theorem2Bound) -> str:
    """The question ``fsmctl prove theorem2-delta`` answers and its answer, in one line.

    Parameters
    ----------
    cert : Theorem2Bound
        :func:`~fsmctl.proofs.theorem2_bound.certified_delta_requirements`'s outcome.

    Returns
    -------
    str
        ``does delta_i exceed ...? PROVED|REFUTED|OPEN: ...`` counting the axes (of every agent) by verdict.

    Examples
    --------
    >>> from fsmctl.proofs.theorem2 import Region
    >>> from fsmctl.proofs.theorem2_bound import AgentBound, AxisBound, Theorem2Bound, PROVE_BUDGET
    >>> axes = tuple(AxisBound(k, 0.005, 1.85, 0.3, (), False, 1, 0.1) for k in (1, 2, 3))
    >>> cert = Theorem2Bound(Region(), (AgentBound((1, 2), 0.3, axes),), None, "", PROVE_BUDGET, 1.0)
    >>> verdict_line(cert)
    "does delta_i exceed Theorem 2's certified requirement on every axis? REFUTED: below it on 6 of 6 axes"
    """
    c = _counts(cert)
    n = sum(c.values())
    head = "does delta_i exceed Theorem 2's certified requirement on every axis? "
    if cert.verdict == "proved":
        return head + f"PROVED: above it on {n} of {n} axes"
    if cert.verdict == "refuted":
        return head + f"REFUTED: below it on {c[MISSED]} of {n} axes"
    parts = [f"{label} on {c[key]}" for key, label in ((MET, "above"), (MISSED, "below"), (OPEN, "inside"))]
    return head + f"OPEN: {', '.join(parts)} of {n} axes (inside: delta within the certified interval)"


def _agents_label(agents: Sequence[int]) -> str:
    """``1``, ``1, 3``, ``2-5`` (a run of three or more)."""
    a = sorted(agents)
    if len(a) >= 3 and a == list(range(a[0], a[-1] + 1)):
        return f"{a[0]}-{a[-1]}"
    return ", ".join(str(x) for x in a)


def _columns(rows: list[list[str]], right: frozenset[int] = frozenset()) -> list[str]:
    """Rows of cells, aligned (columns in ``right`` to the right), each indented by :data:`PREFORMATTED`."""
    widths = [max(len(r[j]) for r in rows) for j in range(len(rows[0]))]
    out = []
    for r in rows:
        cells = [c.rjust(w) if j in right else c.ljust(w) for j, (c, w) in enumerate(zip(r, widths, strict=True))]
        out.append(PREFORMATTED + "  ".join(cells).rstrip())
    return out


def requirement_table(cert: t2b.Theorem2Bound) -> list[str]:
    """An aligned table: agent, axis, configured delta, certified requirement ``[lower, upper]``, verdict (1/s^2).

    Parameters
    ----------
    cert : Theorem2Bound
        :func:`~fsmctl.proofs.theorem2_bound.certified_delta_requirements`'s outcome.

    Returns
    -------
    list of str
        A header and one row per agent (or group of identical agents, e.g. ``1-3``) and axis, each indented by
        :data:`PREFORMATTED`; the interval rounded outward to :data:`SIGNIFICANT_DIGITS` digits
        (:func:`fsmctl.proofs.rounding.round_outward`), the verdict :func:`axis_verdict` with its reason.

    Examples
    --------
    >>> from fsmctl.proofs.theorem2 import Region
    >>> from fsmctl.proofs.theorem2_bound import AgentBound, AxisBound, Theorem2Bound, PROVE_BUDGET
    >>> axes = (AxisBound(1, 0.005, 1.8461, 0.30032, (), False, 1, 0.1),
    ...         AxisBound(2, 0.005, 0.0042, 0.0011, (), True, 1, 0.1))
    >>> cert = Theorem2Bound(Region(), (AgentBound((1, 2, 3), 0.3, axes),), None, "", PROVE_BUDGET, 1.0)
    >>> print("\\n".join(requirement_table(cert)))
      agent  axis  delta (1/s^2)  required [lower, upper] (1/s^2)  verdict
      1-3       1  0.005          [0.3, 1.85]                      MISSED: delta < lower
                2  0.005          [0.0011, 0.0042]                 met: delta > upper
    """
    reasons = {MET: "met: delta > upper", MISSED: "MISSED: delta < lower", OPEN: "open: lower <= delta <= upper"}
    rows = [["agent", "axis", "delta (1/s^2)", "required [lower, upper] (1/s^2)", "verdict"]]
    for g in cert.groups:
        for j, a in enumerate(g.axes):
            interval = f"[{round_outward(a.lower, 'down', SIGNIFICANT_DIGITS)}, {round_outward(a.upper, 'up', SIGNIFICANT_DIGITS)}]"
            verdict = reasons[axis_verdict(a, g.kappa is not None)]
            rows.append([_agents_label(g.agents) if j == 0 else "", str(a.axis), _sig(a.configured), interval, verdict])
    return _columns(rows, right=frozenset({1}))


def search_line(cert: t2b.Theorem2Bound) -> str:
    """How the intervals of :func:`requirement_table` were certified: method, boxes and time, convergence."""
    axes = [a for g in cert.groups for a in g.axes]
    converged = sum(a.converged for a in axes)
    per = ", ".join(f"{_agents_label(g.agents)}: {g.axes[0].boxes}" for g in cert.groups)
    return (
        f"certified by interval arithmetic with outward rounding, branch and bound: {cert.boxes} boxes in "
        f"{cert.seconds:.1f} s (per agent {per}); each sigma_e,k range cut at the Remark 6 band, the affine u_d and "
        f"omega_d_dot maximised exactly; lower bounds certified at a witness point; {converged} of {len(axes)} "
        f"intervals reached the relative gap {t2b.RELATIVE_GAP:g} within the budget (a longer one narrows the others)"
    )


def format_point(values: Sequence[float]) -> tuple[str, list[tuple[int, float]]]:
    """A vector of a witness point, its negligible coordinates shown as ``~0``.

    Parameters
    ----------
    values : sequence of float
        The coordinates.

    Returns
    -------
    (str, list of (int, float))
        ``(a, b, c)`` with :data:`SIGNIFICANT_DIGITS` digits, and the 1-based positions and exact values of the
        coordinates shown as ``~0`` (below :data:`NEGLIGIBLE` times the largest one, or below 1e-300 when all are:
        zero up to the search's rounding).

    Examples
    --------
    >>> format_point([8.48e-16, -0.05, 0.05])
    ('(~0, -0.05, 0.05)', [(1, 8.48e-16)])
    >>> format_point([0.0, 0.0, 0.0])
    ('(0, 0, 0)', [])
    """
    v = [float(x) for x in values]
    scale = max((abs(x) for x in v), default=0.0)
    tiny = [(k + 1, x) for k, x in enumerate(v) if x != 0 and abs(x) < NEGLIGIBLE * scale]
    small = {k for k, _ in tiny}
    text = "(" + ", ".join("~0" if k + 1 in small else _sig(x) for k, x in enumerate(v)) + ")"
    return text, tiny


def reaching_lines(cert: t2b.Theorem2Bound) -> list[str]:
    """Whether the reaching condition fails, and where: the point one input per row, with units.

    Parameters
    ----------
    cert : Theorem2Bound
        :func:`~fsmctl.proofs.theorem2_bound.certified_delta_requirements`'s outcome.

    Returns
    -------
    list of str
        Without a refuting point, one line (:attr:`~fsmctl.proofs.theorem2_bound.Theorem2Bound.reaching_note`);
        with one, a line saying so, the point (rows indented by :data:`PREFORMATTED`), what ``~0`` stands for,
        and the ball-arithmetic values of ``s``, ``s_dot`` and ``s^T s_dot``.
    """
    p = cert.reaching
    if p is None:
        return [f"reaching condition: {cert.reaching_note}"]
    x = np.asarray(p.point, float)
    names = t2b.VARIABLES
    width = max(len(n) for n in names)
    rows, tiny = [], []
    for i, name in enumerate(names):
        text, small = format_point(x[3 * i : 3 * i + 3])
        rows.append(f"{PREFORMATTED}{name:{width}} = {text}{(' ' + UNITS[name]) if UNITS[name] else ''}")
        tiny += [f"{name},{k} = {v:.3g}" for k, v in small]
    out = [
        f"reaching condition REFUTED for agent {p.agent} (full law with the configured delta, no coordination): "
        f"V = s^T s/2 increases at the point ({p.how})",
        *rows,
    ]
    if tiny:
        out.append(
            f"~0: zero up to the search's floating-point rounding ({', '.join(tiny)}); ball arithmetic ran at the "
            "exact point (the JSON's reaching_refuted_at.point)"
        )
    out.append(
        f"there ball arithmetic proves s_{p.axis} s_dot_{p.axis} > 0 and s^T s_dot = {p.s_dot_s} > 0; "
        f"s = ({', '.join(p.s)}), s_dot = ({', '.join(p.s_dot)})"
    )
    return out


def sampled_table(res: t2.Theorem2Numeric) -> list[str]:
    """The sampled requirement per agent (a lower estimate, context for the certified one), 1/s^2 per axis.

    Parameters
    ----------
    res : Theorem2Numeric
        :func:`~fsmctl.proofs.theorem2.delta_requirements`'s outcome.

    Returns
    -------
    list of str
        A header and one row per agent (indented by :data:`PREFORMATTED`): the requirement over the region, its
        maximum along the reference trajectory (the scenario's actual signals) and at the reference under the bound
        boxes, each ``(axis 1, axis 2, axis 3)``.
    """
    rows = [["agent", "over the region", "on the reference trajectory", "at the reference, bound boxes"]]
    rows += [
        [str(a.agent), _vector(a.region), _vector(a.reference_trajectory), _vector(a.reference_bound)]
        for a in res.agents
    ]
    return _columns(rows)
