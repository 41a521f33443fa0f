"""The form of a study claim: :class:`StudyClaim` (one entry of :data:`fsmctl.studies.claims.CLAIMS`), what it reads
(:class:`Grading`), its verdict (:class:`Outcome`, :class:`ClaimVerdict`, one of :data:`VERDICTS`).

Verdicts:

``reproduced``
    this run shows what the paper states;
``differs``
    it does not, and the reason (with the diagnostic run that shows it) is given;
``impossible (bound)``
    no controller respecting the paper's torque limit can do what the paper states
    (:func:`~fsmctl.studies.momentum.angular_momentum_bound`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property

from fsmctl.policy import SETTLING_TOLERANCES_DEG
from fsmctl.studies.momentum import MomentumBound
from fsmctl.studies.paper_statements import SETTLING_TIME
from fsmctl.studies.records import RunRecord

__all__ = [
    "REPRODUCED",
    "DIFFERS",
    "IMPOSSIBLE",
    "VERDICTS",
    "PAPER_SETTLING_TIME_S",
    "ClaimVerdict",
    "Grading",
    "Outcome",
    "StudyClaim",
]

REPRODUCED = "reproduced"
DIFFERS = "differs"
IMPOSSIBLE = "impossible (bound)"
VERDICTS = (REPRODUCED, DIFFERS, IMPOSSIBLE)

PAPER_SETTLING_TIME_S = SETTLING_TIME.value
"""The paper's settling time (s, :data:`fsmctl.studies.paper_statements.SETTLING_TIME`): the claims and the momentum
bound compare with it."""

Runs = Mapping[str, RunRecord]


@dataclass
class ClaimVerdict:
    """One Section 4 claim: the paper's value, this run's value and the verdict (one of :data:`VERDICTS`).

    Parameters
    ----------
    id : str
        The claim's id (:func:`fsmctl.studies.claims.claim_ids`).
    title : str
        The claim in a few words (the report's summary table).
    claim : str
        What the paper states.
    figures : str
        The paper's figures that show it.
    paper_value : str
        The paper's number.
    this_run_short : str
        This reproduction's number in a few words (the report's summary table).
    this_run_value : str
        This reproduction's numbers in full.
    verdict : str
        ``"reproduced"``, ``"differs"`` or ``"impossible (bound)"``.
    reason : str
        Why, when not reproduced.
    diagnostic_runs : str
        The runs of :func:`~fsmctl.studies.paper_runs.run_plan` that show the reason.
    documented : str
        The verdict documented for the paper's own scenario at its full horizon (:attr:`StudyClaim.documented`).

    Examples
    --------
    >>> c = ClaimVerdict("settling_27s", "Case 1 settling time", "settles in 27 s", "Figs 1-2", "27 s",
    ...                  "not settled to 1° in 100 s", "not settled", IMPOSSIBLE, "the torque limit",
    ...                  "case1_no_torque_limit")
    >>> c.verdict in VERDICTS
    True
    """

    id: str
    title: str
    claim: str
    figures: str
    paper_value: str
    this_run_short: str
    """this run's number in a few words (the report's summary table)"""
    this_run_value: str
    verdict: str
    reason: str
    diagnostic_runs: str
    documented: str = ""
    """the verdict documented for the paper's scenario at its full horizon (:attr:`StudyClaim.documented`)"""


@dataclass(frozen=True)
class Outcome:
    """A claim's verdict with its reason and the diagnostic runs that show it.

    Parameters
    ----------
    verdict : str
        One of :data:`VERDICTS`.
    reason : str
        Why.
    diagnostic_runs : str
        Run keys, comma-separated ("" when none).

    Examples
    --------
    >>> Outcome(REPRODUCED, "no saturation after the transient").diagnostic_runs
    ''
    """

    verdict: str
    reason: str
    diagnostic_runs: str = ""


@dataclass(frozen=True)
class Grading:
    """What a verdict reads: every run of the plan, the momentum bound of Case 1 and the settling tolerance.

    Parameters
    ----------
    records : mapping run key -> RunRecord
        The runs of :func:`~fsmctl.studies.paper_runs.run_plan`.
    bounds : sequence of MomentumBound
        :func:`~fsmctl.studies.momentum.angular_momentum_bound` of Case 1.
    tolerance_deg : float
        The tolerance behind "settles" (deg).

    Examples
    --------
    >>> from fsmctl.studies.momentum import MomentumBound
    >>> g = Grading({}, [MomentumBound(i, 2.0, 1.0, 1.0, 1.0, t, t, 0.01) for i, t in ((1, 30.0), (2, 20.0))])
    >>> g.worst.agent, [b.agent for b in g.over]
    (1, [1])
    """

    records: Runs
    bounds: Sequence[MomentumBound]
    tolerance_deg: float = SETTLING_TOLERANCES_DEG[0]

    @property
    def worst(self) -> MomentumBound:
        """MomentumBound: The agent of the largest bound."""
        return max(self.bounds, key=lambda b: b.min_time_s)

    @property
    def over(self) -> list[MomentumBound]:
        """list of MomentumBound: The agents whose bound exceeds the paper's settling time."""
        return [b for b in self.bounds if b.min_time_s > PAPER_SETTLING_TIME_S]

    @cached_property
    def bound_text(self) -> str:
        """str: The bound's argument, for the reasons of an ``impossible (bound)`` verdict."""
        return (
            f"removing each spacecraft's angular momentum relative to the reference with |u_k| <= "
            f"{self.worst.torque_limit_N_m:g} N m "
            f"per axis (|dH/dt| <= sqrt(3) u_max + |d|, J = J0 + ΔJ) takes at least "
            + ", ".join(f"{b.min_time_s:.1f} s (agent {b.agent})" for b in self.over)
            + f" > {PAPER_SETTLING_TIME_S:g} s"
        )

    def __getitem__(self, key: str) -> RunRecord:
        return self.records[key]


@dataclass(frozen=True)
class StudyClaim:
    """One claim of the paper's Section 4: which runs decide it, what holds, its numbers, its verdict rule.

    Parameters
    ----------
    id : str
        Identifier (``settling_27s``).
    text : str
        What the paper states; ``{limit}`` stands for Case 1's torque limit (N m).
    figures : str
        The paper's figures that show it.
    paper_value : str
        The paper's number.
    runs : tuple of str
        The runs of :func:`~fsmctl.studies.paper_runs.run_plan` whose results decide it (:meth:`holds`).
    holds : callable
        ``holds(records, tolerance_deg) -> bool``: the ``reproduced`` test.
    value : callable
        ``value(grading) -> str``: this run's numbers in full (the report's evidence): those of every run the verdict
        reads (a longer run too when it reads one), each worded from its own record (its horizon and window:
        ``--fast`` flies 10 s and the long runs 30 s).
    numbers : callable
        ``numbers(records, tolerance_deg) -> str``: the numbers an explanation shows (default and evidence run).
    grade : callable
        ``grade(grading, holds) -> Outcome``: the verdict rule, with the reason and the diagnostic runs.
    title : str
        The claim in a few words, for the report's summary table (``"Case 1 settling time"``).
    short : callable
        ``short(grading) -> str``: this run's number in a few words, for the summary table (tens of characters).
    documented : str
        The verdict documented for the paper's own scenario at its full horizon (``docs/findings.md``): what
        ``fsmctl reproduce`` expects, so that its exit code says whether a run found what the documentation says.
    uses_tolerance : bool
        What would reproduce it: whether the test reads a settling tolerance, so that the explanations also search
        the tolerance (a grading setting, no new runs).
    stages : callable, optional
        ``stages(records, tolerance_deg) -> list of str, bool or None``: the runs still needed before deciding
        (in the order to fly them), or an early verdict, or None (decide by :meth:`holds`); default: every run of
        ``runs``.
    later : tuple of (str, str), optional
        ``(run, longer run)``: the longer run is flown and read only when ``run`` has not settled.
    requires : tuple of (str, str), optional
        What would reproduce it, if only one setting's value can (as
        :attr:`fsmctl.studies.figure_checks.FigureCheck.requires`); None: every setting is searched.
    why : str
        Why only ``requires`` can.

    Examples
    --------
    >>> from fsmctl.studies.claims import get_claim
    >>> claim = get_claim("tracking_accuracy")
    >>> claim.runs, claim.uses_tolerance, claim.figures
    (('case1',), False, 'Fig 1 inset')
    """

    id: str
    text: str
    figures: str
    paper_value: str
    runs: tuple[str, ...]
    holds: Callable[[Runs, float], bool]
    value: Callable[[Grading], str]
    numbers: Callable[[Runs, float], str]
    grade: Callable[[Grading, bool], Outcome]
    title: str
    short: Callable[[Grading], str]
    documented: str
    uses_tolerance: bool = False
    stages: Callable[[Runs, float], list[str] | bool | None] | None = None
    later: tuple[str, str] | None = None
    requires: tuple[str, str] | None = None
    why: str = ""

    def verdict(self, grading: Grading) -> ClaimVerdict:
        """Grade the claim.

        Parameters
        ----------
        grading : Grading
            The runs, bounds and tolerance.

        Returns
        -------
        ClaimVerdict
            The row of the claims table.
        """
        outcome = self.grade(grading, self.holds(grading.records, grading.tolerance_deg))
        limit = grading["case1"].torque_limit
        return ClaimVerdict(
            self.id,
            self.title,
            self.text.format(limit=limit),
            self.figures,
            self.paper_value,
            self.short(grading),
            self.value(grading),
            outcome.verdict,
            outcome.reason,
            outcome.diagnostic_runs,
            self.documented,
        )

    def decide(self, records: Runs, tolerance_deg: float) -> bool | list[str]:
        """Whether the claim holds on the runs flown so far, or the runs still needed.

        Parameters
        ----------
        records : mapping run key -> RunRecord
            The runs flown so far (a claim that already fails on its first runs does not need the others).
        tolerance_deg : float
            The tolerance behind "settles" (deg).

        Returns
        -------
        bool or list of str
            The verdict, or the run keys to fly next.
        """
        if self.stages is not None:
            early = self.stages(records, tolerance_deg)
            if early is not None:
                return early
        else:
            missing = [k for k in self.runs if k not in records]
            if missing:
                return missing
        return self.holds(records, tolerance_deg)
