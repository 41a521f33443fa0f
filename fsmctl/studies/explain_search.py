"""The best-first search of an explanation: the smallest change of the settings that makes a check pass.

For one check (:class:`~fsmctl.studies.explain_runs.Check`), an :class:`Axis` is one line of the search (one setting
varied, other changes held); a :class:`CheckSearch` walks its axes level by level (:data:`LEVELS`, then
:data:`PAIR_LEVELS` for pairs), bisects the bracket around a reproducing grid value to the setting's resolution, then
tries the grid values beyond it.  :func:`drive` advances many searches together, round by round.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from fsmctl.studies.explain_runs import CandidateRuns, Check
from fsmctl.studies.explain_settings import SETTING_ORDER, Candidate, Setting, number_text

__all__ = [
    "PAIRED_CHOICES",
    "LEVELS",
    "PAIR_LEVELS",
    "Axis",
    "CheckSearch",
    "statement",
    "rank",
    "searched_ranges",
    "single_axes",
    "pair_axes",
    "drive",
]

_ORDER = {n: i for i, n in enumerate(SETTING_ORDER)}


PAIRED_CHOICES = ("error_model", "error_mrp")
"""The discrete choices held in pairs: the two modelling choices (the integrator and step change no single claim)."""
LEVELS = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0)
"""Distance levels of the best-first search of single changes (a discrete choice is at 1)."""
PAIR_LEVELS = (1.2, 1.4, 1.6, 1.8, 2.0)
"""Distance levels of pairs (a discrete choice, 1, plus the other change)."""


class Axis:
    """One line of the search for one check: one setting varied, ``fixed`` changes held.

    Grid values are tried in order of distance; a reproducing grid value brackets a threshold with the nearest tried
    value towards the default (which fails), and the bracket is bisected to the setting's resolution.

    Parameters
    ----------
    check : Check
        The check searched.
    setting : Setting
        The setting varied.
    by_name : mapping name -> Setting
        Every setting.
    fixed : Candidate
        The changes held (empty: a single change).

    Examples
    --------
    See :func:`statement`.
    """

    def __init__(self, check: Check, setting: Setting, by_name: Mapping[str, Setting], fixed: Candidate):
        self.check, self.setting, self.by_name, self.fixed = check, setting, by_name, fixed
        self.base_d = sum(by_name[n].distance(v) for n, v in fixed.changes)
        self.trials: dict[Any, bool] = {}
        self.brackets: dict[bool, list[Any]] = {}  # side (value > default) -> [fails, holds]

    def candidate(self, value: Any) -> Candidate:
        changes = dict(self.fixed.changes)
        changes[self.setting.name] = value
        return Candidate(tuple(sorted(changes.items(), key=lambda kv: _ORDER.get(kv[0], 99))))

    def d(self, value: Any) -> float:
        return self.base_d + self.setting.distance(value)

    def _side(self, value: Any) -> bool:
        return bool(self.setting.continuous and value > float(self.setting.default))

    def _sides(self) -> list[bool]:
        return sorted({self._side(v) for v in self.setting.grid})

    def _side_lower(self, side: bool) -> float:
        """No untried threshold on ``side`` (without a bracket) is nearer than this."""
        if not self.setting.continuous:
            return min((self.d(v) for v in self.setting.grid if v not in self.trials), default=math.inf)
        return max((self.d(v) for v in self.trials if self._side(v) == side), default=self.base_d)

    def untried(self, level: float, bound: float = math.inf) -> list[Any]:
        """Grid values within ``level`` not tried yet, on sides without a bracket that could still beat ``bound``."""
        return [
            v
            for v in self.setting.grid
            if v not in self.trials
            and self.d(v) <= level + 1e-12
            and self._side(v) not in self.brackets
            and self._side_lower(self._side(v)) < bound
        ]

    def record(self, value: Any, ok: bool) -> None:
        """The verdict at ``value``: a grid value opens a bracket on its side; a bisection point narrows it."""
        self.trials[value] = ok
        side = self._side(value)
        if side in self.brackets:
            b = self.brackets[side]
            if b[0] != value and b[1] != value and min(b, key=float) < value < max(b, key=float):
                b[1 if ok else 0] = value
            return
        if ok and self.setting.continuous:
            tried = [v for v in self.trials if self._side(v) == side and self.d(v) < self.d(value)]
            inner = max(tried, key=self.d) if tried else self.setting.default
            self.brackets[side] = [inner, value]

    def upper(self) -> float:
        """Distance of the nearest reproducing value found (inf if none)."""
        hits = [self.d(b[1]) for b in self.brackets.values()]
        if not self.setting.continuous:
            hits += [self.d(v) for v, ok in self.trials.items() if ok]
        return min(hits, default=math.inf)

    def frontier(self) -> float:
        """No untried threshold of this axis is nearer than this."""
        if not self.setting.continuous:
            return min((self.d(v) for v in self.setting.grid if v not in self.trials), default=math.inf)
        out = math.inf
        for side in self._sides():
            if side in self.brackets:  # a bisected bracket is known to the resolution: its threshold is the value
                fails, holds = self.brackets[side]
                out = min(out, self.d(holds if self.resolved(holds) else fails))
                continue
            if any(self._side(v) == side and v not in self.trials for v in self.setting.grid):
                out = min(out, self._side_lower(side))
        return out

    def open_bracket(self, bound: float) -> Any | None:
        """The next bisection point of a bracket that could still beat ``bound``, or None."""
        s = self.setting
        for side in sorted(self.brackets, key=lambda k: self.d(self.brackets[k][1])):
            fails, holds = self.brackets[side]
            if self.d(fails) >= bound:
                continue
            mid = s.midpoint(fails, holds)
            if not s.resolved(fails, holds) and mid not in (fails, holds) and mid not in self.trials:
                return mid
        return None

    def best(self) -> Any | None:
        """The reproducing value of least distance."""
        if self.setting.continuous:
            if not self.brackets:
                return None
            return min((b[1] for b in self.brackets.values()), key=self.d)
        hits = [v for v, ok in self.trials.items() if ok]
        return min(hits, key=lambda v: (self.d(v), str(v))) if hits else None

    def bracket_of(self, value: Any) -> list[Any]:
        return self.brackets[self._side(value)]

    def resolved(self, value: Any) -> bool:
        fails, holds = self.bracket_of(value)
        return self.setting.resolved(fails, holds) or self.setting.midpoint(fails, holds) in (fails, holds)


class CheckSearch:
    """Best-first search of one check over its axes: grid levels by distance, bisection, then the values beyond.

    The search stops when the nearest reproducing change found is no farther than any change not yet tried could
    be (its bracket bisected to the resolution), then tries the grid values beyond it on its axis (to say whether
    the claim keeps holding, ">= threshold").

    Parameters
    ----------
    check : Check
        The check.
    axes : sequence of Axis
        Its axes (:func:`single_axes`).
    levels : sequence of float
        The distance levels (:data:`LEVELS`).
    """

    def __init__(self, check: Check, axes: Sequence[Axis], levels: Sequence[float]):
        self.check = check
        self.axes = list(axes)
        self.levels = list(levels)
        self.level = 0.0
        self.pending: list[tuple[Axis, Any]] = []
        self.phase = "search"
        self.best: Axis | None = None
        self.capped = False

    @property
    def done(self) -> bool:
        return self.phase == "done"

    def extend(self, axes: Sequence[Axis], levels: Sequence[float]) -> None:
        """Continue with more axes (pairs) on further levels."""
        self.axes += list(axes)
        self.levels = list(levels)
        self.phase = "search"

    def wanted(self, runner: CandidateRuns) -> list[tuple[Candidate, str]]:
        """Runs of the pending values: stage by stage on the grid, all at once for a bisection point."""
        out = []
        for axis, v in self.pending:
            cand = axis.candidate(v)
            needed = runner.needed(self.check, cand)
            if needed and v not in axis.setting.grid:
                needed = [k for k in self.check.runs if (cand.simulated(), k) not in runner.runs]
            out += [(cand, k) for k in needed]
        return out

    def advance(self, runner: CandidateRuns, level_cap: float = math.inf) -> None:
        """Judge the pending values whose runs are in; choose what to try next (no level above ``level_cap``)."""
        while not self.done:
            for axis, v in list(self.pending):
                cand = axis.candidate(v)
                if runner.needed(self.check, cand):
                    continue
                self.pending.remove((axis, v))
                axis.record(v, runner.judge(self.check, cand))
            if self.pending:
                return
            if self.phase == "beyond":
                self.phase = "done"
                return
            upper = min((a.upper() for a in self.axes), default=math.inf)
            self.pending = [(a, m) for a in self.axes if (m := a.open_bracket(upper)) is not None]
            if self.pending:
                continue
            lower = min((a.frontier() for a in self.axes), default=math.inf)
            if upper > lower:  # a nearer change may hide in the next level
                nxt = [lv for lv in self.levels if self.level + 1e-12 < lv <= level_cap + 1e-12]
                while nxt and not self.pending:
                    self.level = nxt.pop(0)
                    self.pending = [(a, v) for a in self.axes for v in a.untried(self.level, upper)]
                if self.pending:
                    continue
                if any(a.untried(math.inf) for a in self.axes):
                    self.capped = True  # levels left that the cap (the pair budget) does not allow
            if upper == math.inf:
                self.phase = "done"
                return
            self.best = min((a for a in self.axes if a.best() is not None), key=rank)
            b = self.best.best()
            side = self.best._side(b)
            s = self.best.setting
            beyond = sorted(
                (v for v in s.grid if s.continuous and self.best._side(v) == side and self.best.d(v) > self.best.d(b)),
                key=self.best.d,
            )
            self.pending = [(self.best, v) for v in beyond if v not in self.best.trials]
            self.phase = "beyond"


def statement(axis: Axis) -> str:
    """What reproduces the check on this axis: ``"torque limit >= 47.7 N m (bisected to 0.1 N m; 47.6 N m does not)"``.

    Parameters
    ----------
    axis : Axis
        A searched axis with a reproducing value (:meth:`Axis.best`).

    Returns
    -------
    str
        The threshold and how it was found, or the discrete choice.

    Examples
    --------
    A threshold found between 47.6 and 47.7 N m (the verdicts recorded by hand here; the search flies them):

    >>> import fsmctl
    >>> from fsmctl.studies.claims import get_claim
    >>> from fsmctl.studies.explain_runs import Check
    >>> from fsmctl.studies.explain_settings import search_settings
    >>> by_name = {s.name: s for s in search_settings(fsmctl.paper_scenario("1"))}
    >>> check = Check("settling_27s", "settles in 27 s", get_claim("settling_27s"))
    >>> axis = Axis(check, by_name["torque_limit"], by_name, Candidate())
    >>> for value, ok in ((20.0, False), (50.0, True), (47.6, False), (47.7, True)):
    ...     axis.record(value, ok)
    >>> statement(axis)
    'torque limit >= 47.7 N m (bisected to 0.1 N m; 47.6 N m does not; the values beyond were not all tried)'
    """
    s, v = axis.setting, axis.best()
    fixed = axis.fixed.text(axis.by_name) + " and " if axis.fixed.changes else ""
    if not s.continuous:
        return fixed + s.value_text(v)
    unit = f" {s.unit}" if s.unit else ""
    fails, holds = axis.bracket_of(v)
    if not axis.resolved(v):
        return (
            f"{fixed}{s.label} between {number_text(fails)} and {number_text(holds)}{unit} (grid bracket, not bisected)"
        )
    side = axis._side(v)
    beyond = [g for g in s.grid if axis._side(g) == side and axis.d(g) > axis.d(v)]
    failing = [g for g in beyond if axis.trials.get(g) is False]
    note = f"bisected to {s.resolution_text()}; {number_text(fails)}{unit} does not"
    if failing:
        return (
            f"{fixed}{s.label} = {number_text(v)}{unit} (the threshold nearest the default, {note}; fails again at "
            f"{', '.join(number_text(g) for g in failing)}{unit})"
        )
    untried = [g for g in beyond if g not in axis.trials]
    if untried:
        note += "; the values beyond were not all tried"
    return f"{fixed}{s.label} {'>=' if side else '<='} {number_text(v)}{unit} ({note})"


def rank(axis: Axis) -> tuple:
    """The order of reproducing axes: single changes first, then by distance, by setting, by the changes held.

    Parameters
    ----------
    axis : Axis
        An axis with a reproducing value.

    Returns
    -------
    tuple
        The sort key.
    """
    return (len(axis.fixed.changes), axis.d(axis.best()), _ORDER[axis.setting.name], axis.fixed.changes)


def searched_ranges(settings: Sequence[Setting], check: Check) -> list[str]:
    """What is searched for a check: each setting's range (the tolerance only for a check that reads it).

    Parameters
    ----------
    settings : sequence of Setting
        The settings searched.
    check : Check
        The check.

    Returns
    -------
    list of str
        :meth:`Setting.range_text` of each.
    """
    return [s.range_text() for s in settings if not s.grading or check.uses_tolerance]


def single_axes(check: Check, settings: Sequence[Setting], by_name: Mapping[str, Setting]) -> list[Axis]:
    """The axes of single changes for a check: every setting (the tolerance only if it reads one), or only the
    setting the check requires.

    Parameters
    ----------
    check : Check
        The check.
    settings : sequence of Setting
        The settings searched.
    by_name : mapping name -> Setting
        Every setting.

    Returns
    -------
    list of Axis
        One per setting varied.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.studies.explain_runs import Check
    >>> from fsmctl.studies.explain_settings import search_settings
    >>> from fsmctl.studies.figure_checks import get_figure_check
    >>> settings = search_settings(fsmctl.paper_scenario("1"))
    >>> by_name = {s.name: s for s in settings}
    >>> fig3 = get_figure_check("fig3_axis")
    >>> [a.setting.name for a in single_axes(Check(fig3.id, fig3.text, fig3), settings, by_name)]
    ['error_mrp']
    """
    req = check.requires
    if req:
        return [Axis(check, by_name[req[0]], by_name, Candidate())] if req[0] in {s.name for s in settings} else []
    return [Axis(check, s, by_name, Candidate()) for s in settings if not s.grading or check.uses_tolerance]


def pair_axes(check: Check, settings: Sequence[Setting], by_name: Mapping[str, Setting]) -> list[Axis]:
    """The axes of pairs: a discrete choice of :data:`PAIRED_CHOICES` held, every other setting varied.

    Parameters
    ----------
    check : Check
        The check.
    settings : sequence of Setting
        The settings searched.
    by_name : mapping name -> Setting
        Every setting.

    Returns
    -------
    list of Axis
        One per (choice held, setting varied); two discrete choices are paired once.
    """
    req = check.requires
    out = []
    for held in settings:
        if held.name not in PAIRED_CHOICES or (req and held.name != req[0]):
            continue
        for value in held.grid if not req else (req[1],):
            for other in settings:
                if other.name == held.name or (other.grading and not check.uses_tolerance):
                    continue
                if not other.continuous and not req and _ORDER[other.name] < _ORDER[held.name]:
                    continue  # the pair (other, held) is tried with other held
                out.append(Axis(check, other, by_name, Candidate(((held.name, value),))))
    return out


def drive(searches: Sequence[CheckSearch], runner: CandidateRuns, budget: int | None = None) -> int:
    """Advance the searches round by round (each round's runs go to the pool together).

    Parameters
    ----------
    searches : sequence of CheckSearch
        The searches.
    runner : CandidateRuns
        Flies the runs.
    budget : int, optional
        No search starts a new distance level once that many runs have been flown.

    Returns
    -------
    int
        The runs flown.
    """
    start = runner.simulated
    while True:
        cap = math.inf
        if budget is not None and runner.simulated - start >= budget:
            cap = -math.inf
        for s in searches:
            s.advance(runner, cap)
        wanted = [w for s in searches if not s.done for w in s.wanted(runner)]
        if not wanted:
            if all(s.done for s in searches):
                return runner.simulated - start
            continue
        runner.run(wanted)
