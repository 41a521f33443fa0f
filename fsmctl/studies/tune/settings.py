"""A tuning study's settings, objectives, constraints and search space."""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from fsmctl.errors import InputError
from fsmctl.model.scenario import Scenario
from fsmctl.model.topology import Topology
from fsmctl.policy import TOLERANCE_DEG, TUNE_BATCH
from fsmctl.simulation.messages import message_metrics


def _peak_torque(result: Any, w: int) -> float:
    """Peak applied ``|u_ik|`` over the first ``w`` output samples (N m)."""
    return float(np.max(np.abs(np.asarray(result.u[:w], dtype=float))))


def _rms_torque(result: Any, w: int) -> float:
    """RMS of the torque vector's norm over the first ``w`` samples (trapezoid rule; N m; 0 for one sample)."""
    t = np.asarray(result.time[:w], dtype=float)
    span = float(t[-1] - t[0])
    if span <= 0:
        return 0.0
    u = np.asarray(result.u[:w], dtype=float)
    sq = np.sum(np.square(u), axis=(1, 2))
    area = float(np.sum(0.5 * (sq[1:] + sq[:-1]) * np.diff(t)))
    return math.sqrt(area / (u.shape[1] * span))


def _chattering(result: Any, w: int) -> float:
    """Total variation of u per second over the first ``w`` samples (N m/s; 0 for one sample)."""
    t = np.asarray(result.time[:w], dtype=float)
    span = float(t[-1] - t[0])
    if span <= 0:
        return 0.0
    return float(np.sum(np.abs(np.diff(np.asarray(result.u[:w], dtype=float), axis=0)))) / span


def _wheel_momentum(result: Any, w: int) -> float:
    """Peak wheel angular momentum (norm of an agent's wheel array, body frame) over the first ``w`` samples (N m s)."""
    act = result.scenario.actuator
    h = np.asarray(result.wheel_speed[:w], dtype=float) * act.per_wheel("spin_inertia")
    return float(np.max(np.linalg.norm(h @ act.spin_axes().T, axis=-1)))


def _messages(result: Any, w: int) -> float:
    """Messages sent by all agents over the first ``w`` output samples (:func:`fsmctl.simulation.message_metrics`)."""

    return message_metrics(result, w)["messages_count"]


@dataclass(frozen=True)
class Objective:
    """One objective of a tuning study (minimised): the one entry that declares and scores it.

    Parameters
    ----------
    unit : str
        Its unit (the trials table, the Pareto figure, ``tune.json``).
    description : str
        What it is (``fsmctl tune --help``, ``tune.json``).
    metric : str, optional
        The column of :func:`fsmctl.studies.compare.run_metrics` that is its value on a complete run; ``None``: the
        settling time of ``error`` to the study's tolerance (a run that never settles scores
        :func:`unsettled_score`).
    error : {"aaem", "raem"}, optional
        The error metric (eq 42 / eq 43) it is read from: a settling time (``metric`` None) or a steady maximum;
        the pruner's estimate at a checkpoint is then computed from that metric's series.
    partial : callable, optional
        ``partial(result, w)``: its value from the first ``w`` output samples of a run (the pruner's estimate at a
        checkpoint); for every objective without ``error``.
    needs_wheels : bool
        Only a scenario with reaction wheels can measure it (else :class:`~fsmctl.errors.InputError`).
    needs_control_period : bool
        Only a scenario with a control period (``simulation.control_period > 0``) can measure it: continuous control
        sends no discrete messages (else :class:`~fsmctl.errors.InputError`).

    Examples
    --------
    >>> from fsmctl.studies.tune import OBJECTIVES
    >>> o = OBJECTIVES["rms_torque"]
    >>> o.unit, o.metric, o.error is None and o.partial is not None
    ('N m', 'rms_torque_N_m', True)
    """

    unit: str
    description: str
    metric: str | None = None
    error: str | None = None
    partial: Callable[[Any, int], float] | None = None
    needs_wheels: bool = False
    needs_control_period: bool = False

    def __post_init__(self):
        if self.error not in (None, "aaem", "raem"):
            raise ValueError(f"an objective's error metric is aaem or raem, got {self.error!r}")
        if (self.error is None) == (self.partial is None):
            raise ValueError("an objective is read from an error metric (error) or has a partial score, not both")
        if self.metric is None and self.error is None:
            raise ValueError("an objective without an error metric needs its run_metrics column (metric)")


OBJECTIVES: dict[str, Objective] = {
    "aaem_settling": Objective("s", "AAEM settling time to the tolerance", error="aaem"),
    "raem_settling": Objective("s", "RAEM settling time to the tolerance", error="raem"),
    "aaem_steady": Objective("deg", "AAEM max over the steady window", "aaem_steady_max_deg", error="aaem"),
    "raem_steady": Objective("deg", "RAEM max over the steady window", "raem_steady_max_deg", error="raem"),
    "peak_torque": Objective("N m", "peak applied |u_ik|", "peak_torque_N_m", partial=_peak_torque),
    "rms_torque": Objective("N m", "RMS torque", "rms_torque_N_m", partial=_rms_torque),
    "chattering": Objective("N m/s", "total variation of u per second", "chattering_N_m_per_s", partial=_chattering),
    "wheel_momentum": Objective(
        "N m s",
        "peak wheel angular momentum",
        "peak_wheel_momentum_N_m_s",
        partial=_wheel_momentum,
        needs_wheels=True,
    ),
    "messages": Objective(
        "1",
        "messages sent by all agents (needs a control period)",
        "messages_count",
        partial=_messages,
        needs_control_period=True,
    ),
}
"""objective name -> :class:`Objective` (unit, description, how a run is scored); all are minimised"""

CONSTRAINTS: dict[str, tuple[str, str]] = {
    "converged": ("s", "max(AAEM, RAEM settling time) - horizon"),
    "theorem1": ("1", "0 when Theorem 1 holds for the topology with the candidate's weights, else 1 + max(k^j - k^i)"),
    "theorem2": ("1/s^2", "max over agents, axes, members of (Theorem 2's required delta - delta)"),
    "torque": ("N m", "max |commanded torque| after the settling time (else the steady window) - torque limit"),
    "wheels": ("1", "peak wheel momentum / capacity - 0.99"),
}
"""constraint name -> (unit, description); feasible when the value is <= 0 (see the module docstring)"""

SIMULATED_CONSTRAINTS = ("converged", "torque", "wheels")
"""constraints measured on the runs (aggregated by the quantile); the others are proof conditions"""

PRUNERS = ("none", "median", "halving")
"""``--pruner`` choices (``auto``: ``median`` for one objective, ``none`` for several)"""

CHECKPOINTS = 10
"""a pruned run is judged every ``T / CHECKPOINTS`` of simulated time (steps 1 .. CHECKPOINTS - 1)"""

MEDIAN_STARTUP_TRIALS = 5
MEDIAN_WARMUP_STEPS = 2
HALVING_REDUCTION_FACTOR = 3

POPULATION = 24
"""population size of the NSGA-II sampler (fixed, so a resumed study proposes what an uninterrupted one would)"""

LOG_RATIO = 100.0
"""a range with ``low > 0`` and ``high / low >= LOG_RATIO`` is searched log-uniformly"""

COUPLING: dict[str, str] = {
    "k_i_scale": "factor on every link's k^i_ij (Table 2, eq 19)",
    "k_j_scale": "factor on every value of every k^j_ij(t) schedule (Table 2, eq 19)",
}
"""the coupling-weight factors that can be searched (unit 1, declared range ``0 <= x``)"""

COUPLING_RANGE = (0.1, 10.0)
"""default search range of the coupling factors (log-uniform)"""

WHEEL_CAPACITY_FRACTION = 0.99
"""the ``wheels`` constraint: every wheel's peak momentum must stay below this fraction of ``J_s max_speed``"""

STUDY_NAME = "fsmctl-tune"
STUDY_FILE = "study.log"


# ----------------------------------------------------------------------------- settings


def _names(value: Any) -> tuple[str, ...]:
    if isinstance(value, str):
        return tuple(x.strip() for x in value.split(",") if x.strip())
    return tuple(value)


@dataclass(frozen=True)
class TuneSettings:
    """What to tune, how hard, and how candidates are scored (see the module docstring).

    Parameters
    ----------
    scenario : str, optional
        A built-in scenario name (default ``"paper"``) or a scenario file.
    case : str or None, optional
        The scenario's case; None: its first.
    law : str, optional
        The law to tune: a built-in name (default ``"fsm"``), a derivation script or a derived folder.
    budget : int, optional
        Number of trials in all (a resumed study continues to it).
    seed : int, optional
        Seed of the sampler and of the ensemble.
    ensemble : int, optional
        1 flies the scenario itself; ``M > 1`` flies ``M`` Monte Carlo members per candidate.
    quantile : float, optional
        Aggregate over the ensemble: 1.0 the worst member, 0.5 the median.
    objectives : tuple of str or str, optional
        Names of :data:`OBJECTIVES` to minimise (a comma-separated string is split).
    tolerance_deg : float, optional
        The settling tolerance of AAEM and RAEM (eqs 42-43), deg.
    t_final : float or None, optional
        The horizon (s); None: the scenario's.
    parameters : tuple of str, optional
        Names to search; empty: every tunable numeric parameter of the law (and the coupling factors for ``fsm``).
    ranges : tuple of (str, float, float) or Mapping, optional
        ``(name, low, high)`` triples (or ``name -> (low, high)``) overriding the declared ranges.
    batch : int, optional
        Trials asked, evaluated (in parallel) and told together (the results do not depend on the workers).
    pruner : str, optional
        One of :data:`PRUNERS` or ``"auto"`` (resolved here: ``median`` for one objective, ``none`` for several).
    constraints : tuple of str, optional
        Names of :data:`CONSTRAINTS`; empty: every one that can be evaluated (:func:`available_constraints`).

    Examples
    --------
    >>> from fsmctl.studies import TuneSettings
    >>> s = TuneSettings(objectives="aaem_settling,peak_torque", ranges={"c1": (0.1, 2.0)})
    >>> s.objectives, s.ranges, s.pruner
    (('aaem_settling', 'peak_torque'), (('c1', 0.1, 2.0),), 'none')
    >>> try:
    ...     TuneSettings(budget=0).validate()
    ... except ValueError as exc:
    ...     print(exc)
    tune: budget must be a whole number of trials >= 1, got 0
    """

    scenario: str = "paper"
    case: str | None = None
    law: str = "fsm"
    budget: int = 50
    seed: int = 0
    ensemble: int = 1
    quantile: float = 1.0
    objectives: tuple[str, ...] = ("aaem_settling", "peak_torque")
    tolerance_deg: float = TOLERANCE_DEG
    t_final: float | None = None
    parameters: tuple[str, ...] = ()
    ranges: tuple[tuple[str, float, float], ...] = ()
    batch: int = TUNE_BATCH
    pruner: str = "auto"
    constraints: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if isinstance(self.objectives, str):
            object.__setattr__(self, "objectives", tuple(x.strip() for x in self.objectives.split(",")))
        else:
            object.__setattr__(self, "objectives", tuple(self.objectives))
        object.__setattr__(self, "parameters", _names(self.parameters))
        object.__setattr__(self, "constraints", _names(self.constraints))
        ranges = self.ranges
        if isinstance(ranges, Mapping):
            ranges = tuple((k, *v) if isinstance(v, (list, tuple)) else (k, v) for k, v in ranges.items())
        object.__setattr__(self, "ranges", tuple(tuple(r) for r in ranges))
        object.__setattr__(self, "scenario", str(self.scenario))
        object.__setattr__(self, "law", str(self.law))
        if self.pruner == "auto":
            object.__setattr__(self, "pruner", "median" if len(self.objectives) == 1 else "none")

    def validate(self) -> None:
        """Raise :class:`~fsmctl.errors.InputError` (one line naming the setting) on a bad setting, an unknown law or
        parameter, or a range that cannot be searched.

        Raises
        ------
        fsmctl.errors.InputError
            The first bad setting found.
        """

        def whole(v: Any) -> bool:
            return isinstance(v, (int, np.integer)) and not isinstance(v, bool)

        def real(v: Any) -> bool:
            return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)

        if not self.objectives:
            raise InputError(f"tune: objectives: give at least one of {', '.join(OBJECTIVES)}")
        for name in self.objectives:
            if name not in OBJECTIVES:
                raise InputError(f"tune: unknown objective {name!r} (known: {', '.join(OBJECTIVES)})")
        if len(set(self.objectives)) != len(self.objectives):
            raise InputError(f"tune: objectives: each may be named once, got {','.join(self.objectives)}")
        if not whole(self.budget) or self.budget < 1:
            raise InputError(f"tune: budget must be a whole number of trials >= 1, got {self.budget!r}")
        if not whole(self.seed) or self.seed < 0:
            raise InputError(f"tune: seed must be a whole number >= 0, got {self.seed!r}")
        if not whole(self.ensemble) or self.ensemble < 1:
            raise InputError(f"tune: ensemble must be a whole number of members >= 1, got {self.ensemble!r}")
        if not real(self.quantile) or not 0 <= self.quantile <= 1:
            raise InputError(f"tune: quantile must be in [0, 1] (1 = worst case, 0.5 = median), got {self.quantile!r}")
        if not real(self.tolerance_deg) or not (math.isfinite(self.tolerance_deg) and self.tolerance_deg > 0):
            raise InputError(f"tune: tolerance_deg must be a finite number > 0, got {self.tolerance_deg!r}")
        if self.t_final is not None and not (real(self.t_final) and math.isfinite(self.t_final) and self.t_final > 0):
            raise InputError(f"tune: t_final must be a finite number > 0 (s), got {self.t_final!r}")
        if not whole(self.batch) or self.batch < 1:
            raise InputError(f"tune: batch must be a whole number of trials >= 1, got {self.batch!r}")
        if self.pruner not in PRUNERS:
            raise InputError(f"tune: unknown pruner {self.pruner!r} (known: auto, {', '.join(PRUNERS)})")
        if self.pruner != "none" and len(self.objectives) > 1:
            raise InputError(
                f"tune: pruner {self.pruner} judges one objective, got {len(self.objectives)} "
                f"({','.join(self.objectives)}); use pruner none with several objectives"
            )
        for name in self.constraints:
            if name not in CONSTRAINTS:
                raise InputError(f"tune: unknown constraint {name!r} (known: {', '.join(CONSTRAINTS)})")
        if len(set(self.constraints)) != len(self.constraints):
            raise InputError(f"tune: constraints: each may be named once, got {','.join(self.constraints)}")
        search_space(self)

    def identity(self) -> dict:
        """Everything that determines the trials except the budget (a resumed study must match it).

        Returns
        -------
        dict
            The settings as JSON-able data, without ``budget``.
        """
        out = asdict(self)
        out.pop("budget")
        return _ranges_in_order(json.loads(json.dumps(out)))


def _ranges_in_order(identity: dict) -> dict:
    """``identity`` with its ``ranges`` sorted by parameter name: their order means nothing (the search space
    follows the law's declarations), so ``--range c1=... --range c2=...`` and the reverse are the same study."""
    ranges = identity.get("ranges")
    if isinstance(ranges, list) and all(isinstance(r, list) and r for r in ranges):
        identity = {**identity, "ranges": sorted(ranges, key=lambda r: str(r[0]))}
    return identity


def identity_changes(recorded: dict, identity: dict) -> dict[str, tuple[Any, Any]]:
    """The settings in which a study's ``identity`` differs from the one ``recorded`` in its journal.

    The ranges are compared in any order (a journal written before they were sorted records them as given).

    Parameters
    ----------
    recorded : dict
        The journal's :meth:`TuneSettings.identity`.
    identity : dict
        This run's.

    Returns
    -------
    dict
        ``name -> (recorded value, this run's)`` for each setting that differs, by name; empty for the same study.

    Examples
    --------
    >>> from fsmctl.studies.tune.settings import TuneSettings, identity_changes
    >>> a = TuneSettings(ranges={"c1": (0.1, 2.0), "c2": (0.1, 2.0)}).identity()
    >>> b = TuneSettings(ranges={"c2": (0.1, 2.0), "c1": (0.1, 2.0)}).identity()
    >>> identity_changes(a, b)
    {}
    >>> identity_changes(a, TuneSettings(seed=5, ranges={"c1": (0.1, 3.0)}).identity())["seed"]
    (0, 5)
    """
    old, new = _ranges_in_order(recorded), _ranges_in_order(identity)
    return {k: (old.get(k), new.get(k)) for k in sorted(set(old) | set(new)) if old.get(k) != new.get(k)}


@dataclass(frozen=True)
class SearchParameter:
    """One searched parameter: ``[low, high]`` in ``unit``, log-uniform or uniform; ``size`` components set alike.

    Parameters
    ----------
    name : str
        The law parameter (or coupling factor) searched.
    unit : str
        Its unit.
    low, high : float
        The searched range.
    log : bool
        Searched log-uniformly (``low > 0`` and ``high / low >= 100``), else uniformly.
    size : int
        Number of components, all set to the searched value (``delta``: one value per axis).
    coupling : bool, optional
        A factor on the topology's weights (:data:`COUPLING`) rather than a law parameter.

    Examples
    --------
    >>> from fsmctl.studies import SearchParameter
    >>> delta = SearchParameter("delta", "1/s^2", 1e-4, 1e-1, log=True, size=3)
    >>> delta.column, delta.scenario_value(0.01)
    ('delta [1/s^2]', [0.01, 0.01, 0.01])
    """

    name: str
    unit: str
    low: float
    high: float
    log: bool
    size: int
    coupling: bool = False

    def quantity(self, value: float) -> str:
        """``value`` with the parameter's unit, as ``fsmctl tune`` prints it (no unit when dimensionless).

        Parameters
        ----------
        value : float
            A value of the parameter.

        Returns
        -------
        str
            ``"0.5 1/s"``; ``"0.5"`` for a parameter of unit ``"1"`` or ``""``.

        Examples
        --------
        >>> from fsmctl.studies import SearchParameter
        >>> SearchParameter("c1", "1/s", 0.1, 2.0, False, 1).quantity(0.5)
        '0.5 1/s'
        >>> SearchParameter("alpha", "1", 0.5, 1.0, False, 1).quantity(0.534771)
        '0.534771'
        """
        return f"{value:.6g}" + (f" {self.unit}" if self.unit not in DIMENSIONLESS else "")

    @property
    def column(self) -> str:
        """``name [unit]``: the parameter's column in ``trials.csv``."""
        return f"{self.name} [{self.unit}]"

    def scenario_value(self, value: float) -> float | list[float]:
        """The searched value as a scenario sets it: a number, or ``size`` equal numbers.

        Parameters
        ----------
        value : float
            The searched value.

        Returns
        -------
        float or list of float
            ``value`` for a scalar parameter, ``[value] * size`` for a vector.
        """
        return float(value) if self.size == 1 else [float(value)] * self.size


DIMENSIONLESS = ("1", "")
"""Units of a dimensionless parameter: printed without a unit (``alpha=0.53``, not ``alpha=0.53 1``)."""


def _ranges(settings: TuneSettings) -> dict[str, tuple[float, float]]:
    out: dict[str, tuple[float, float]] = {}
    for item in settings.ranges:
        if len(item) != 3 or not isinstance(item[0], str):
            raise InputError(f"tune: a range is (name, low, high), got {item!r}")
        name, low, high = item
        try:
            low, high = float(low), float(high)
        except (TypeError, ValueError):
            raise InputError(f"tune: range of {name}: low and high must be numbers, got {item[1:]!r}") from None
        if not (math.isfinite(low) and math.isfinite(high) and low < high):
            raise InputError(f"tune: range of {name}: need finite low < high, got {low:g}, {high:g}")
        if name in out:
            raise InputError(f"tune: range of {name} given twice")
        out[name] = (low, high)
    return out


def _has_coupling(topology: Topology) -> bool:
    return any(link.k_i != 0 or link.k_j.max != 0 for link in topology.links)


def search_space(settings: TuneSettings, base: Scenario | None = None) -> list[SearchParameter]:
    """The searched parameters of ``settings.law`` with their ranges (see the module docstring).

    Parameters
    ----------
    settings : TuneSettings
        The law, ``parameters`` and ``ranges``.
    base : Scenario, optional
        The tuned scenario: without non-zero coupling weights the coupling factors are not searched by default.

    Returns
    -------
    list of SearchParameter
        In the order given (default: the law's declaration order, then :data:`COUPLING`).

    Raises
    ------
    InputError
        Unknown law or parameter, a parameter with options or not tunable, an override outside the declared range,
        or a side left unbounded by both the law and ``ranges`` (every such parameter named in one message).

    Examples
    --------
    >>> from fsmctl.studies import TuneSettings, search_space
    >>> space = search_space(TuneSettings(parameters=("c1", "delta"), ranges={"c1": (0.1, 2.0), "delta": (1e-4, 0.1)}))
    >>> [(p.name, p.unit, p.low, p.high, p.log, p.size) for p in space]
    [('c1', '1/s', 0.1, 2.0, False, 1), ('delta', '1/s^2', 0.0001, 0.1, True, 3)]
    """
    from fsmctl.model.laws import resolve_law

    law = resolve_law(settings.law)
    declared = {p.name: p for p in law.parameters}
    given = _ranges(settings)
    names = list(settings.parameters)
    if not names:
        names = [p.name for p in law.parameters if p.tunable and not p.choices]
        if law.paper_theorems is not None and (base is None or _has_coupling(base.topology)):
            names += list(COUPLING)
    if len(set(names)) != len(names):
        raise InputError(f"tune: parameters: each may be named once, got {','.join(names)}")
    if not names:
        raise InputError(f"tune: the law {law.name!r} declares no tunable numeric parameter")
    for name in [*names, *given]:
        if name not in declared and name not in COUPLING:
            raise InputError(
                f"tune: the law {law.name!r} has no parameter {name!r} (its parameters: {', '.join(declared)}; "
                f"coupling factors: {', '.join(COUPLING)})"
            )
    for name in names:  # a parameter that cannot be searched at all first: the ranges' complaints would follow from it
        p = declared.get(name)
        if p is not None and p.choices:
            raise InputError(f"tune: {name} has named options ({p.range_text()}), which are not searched")
        if p is not None and not p.tunable:
            raise InputError(f"tune: the law {law.name!r} declares {name} not tunable")
    extra = sorted(set(given) - set(names))
    if extra:
        raise InputError(
            f"tune: a range is given for {extra[0]!r}, which is not searched (parameters: {', '.join(names)})"
        )
    out = []
    unbounded = []  # (name, declared range) of the parameters whose range is missing: named together
    for name in names:
        if name in COUPLING:
            low, high = given.get(name, COUPLING_RANGE)
            if low < 0:
                raise InputError(f"tune: range of {name}: must be >= 0, got {low:g} (declared range: 0 <= x)")
            out.append(SearchParameter(name, "1", low, high, low > 0 and high / low >= LOG_RATIO, 1, True))
            continue
        p = declared[name]
        if name in given:
            low, high = given[name]
            for v in (low, high):
                why = p.problem(v)
                if why:
                    raise InputError(f"tune: range of {name}: {why} (declared range: {p.range_text()})")
        else:
            if p.minimum is None or p.maximum is None:
                side = "upper" if p.maximum is None else "lower"
                unbounded.append((name, f"no {side} bound: {p.range_text()}"))
                continue
            low = float(np.nextafter(p.minimum, math.inf)) if p.exclusive_minimum else float(p.minimum)
            high = float(np.nextafter(p.maximum, -math.inf)) if p.exclusive_maximum else float(p.maximum)
            if not low < high:
                raise InputError(f"tune: {name}: the declared range {p.range_text()} is a single value")
        log = low > 0 and high / low >= LOG_RATIO
        out.append(SearchParameter(name, p.unit, low, high, log, p.size))
    if unbounded:
        missing = ", ".join(f"{name} ({why})" for name, why in unbounded)
        options = " ".join(f"--range {name}=LOW,HIGH" for name, _ in unbounded)
        them = "their ranges" if len(unbounded) > 1 else "its range"
        raise InputError(f"tune: no declared range to search for {missing}; give {them}: {options}")
    return out


def _range_words(p: SearchParameter, settings: TuneSettings) -> str:
    """Where a searched parameter's range comes from."""
    if p.name in {item[0] for item in settings.ranges}:
        return "range given"
    return "default range of the coupling factors" if p.coupling else "the law's declared range"


def search_space_lines(settings: TuneSettings, space: list[SearchParameter], *, done: bool = False) -> list[str]:
    """What a study searches and why, as ``fsmctl tune`` states it first: one summary line, then one per parameter.

    The summary names every searched parameter and why it is searched: named in ``settings.parameters``, or (when
    none are named) the law's tunable parameters and, for the paper's law on a scenario with coupling weights, the
    coupling factors (:func:`search_space`).  Each parameter's line gives its range, where that range comes from
    (given, the law's declared one, the coupling factors' default) and how it is sampled.

    Parameters
    ----------
    settings : TuneSettings
        The study's settings.
    space : list of SearchParameter
        Its search space (:func:`search_space` of ``settings``).
    done : bool
        As a finished study's summary states it (:meth:`TuneResult.to_text`): "searched", without the advice to
        name the parameters (given once, before the study runs).

    Returns
    -------
    list of str
        The summary line, then one indented line per parameter.

    Examples
    --------
    >>> from fsmctl.studies import TuneSettings, search_space
    >>> from fsmctl.studies.tune import search_space_lines
    >>> s = TuneSettings(parameters=("c1", "alpha"), ranges={"c1": (0.01, 2.0)})
    >>> print("\\n".join(search_space_lines(s, search_space(s))))
    searching 2 parameters: c1, alpha (named by --parameters)
      c1: 0.01 .. 2 1/s, log-uniform (range given)
      alpha: 0.5 .. 1, uniform (the law's declared range)
    """
    n = len(space)
    names = [p.name for p in space]
    verb = "searched" if done else "searching"
    if settings.parameters:
        head = f"{verb} {n} parameter{'s' * (n != 1)}: {', '.join(names)} (named by --parameters)"
    else:
        law = [p.name for p in space if not p.coupling]
        coupling = [p.name for p in space if p.coupling]
        head = (
            f"{verb} {n} parameter{'s' * (n != 1)}: {', '.join(law)} (every tunable parameter {settings.law} declares)"
        )
        if coupling:
            head += (
                f", {', '.join(coupling)} (factors on the coupling weights: {settings.law} declares it is the paper's "
                "law and the scenario has coupling weights)"
            )
        if not done:
            head += "; --parameters not given: name the ones to search with --parameters"
    lines = [head]
    for p in space:
        sampled = "log-uniform" if p.log else "uniform"
        alike = f", one value for all {p.size} components" if p.size > 1 else ""
        span = f"{p.low:.6g} .. {p.quantity(p.high)}"
        lines.append(f"  {p.name}: {span}, {sampled}{alike} ({_range_words(p, settings)})")
    return lines


def available_constraints(law: str, base: Scenario) -> dict[str, str]:
    """Every constraint of :data:`CONSTRAINTS` with why it cannot be evaluated for ``law`` on ``base`` ("" = it can).

    Parameters
    ----------
    law : str
        A law spec (built-in name, script or folder).
    base : Scenario
        The tuned scenario (its torque limit and actuators).

    Returns
    -------
    dict
        Constraint name -> reason it cannot be evaluated, or "" when it can.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.studies import available_constraints
    >>> available_constraints("fsm", fsmctl.paper_scenario("1"))["wheels"]
    'paper case 1 has no reaction wheels with a finite max_speed'
    >>> available_constraints("pid", fsmctl.paper_scenario("1"))["torque"]
    ''
    """
    from fsmctl.model.laws import resolve_law

    law_code = resolve_law(law)
    paper = law_code.paper_theorems is not None  # the law declares it is eqs 13-19 (LawBuilder.paper_theorems)
    act = base.actuator
    limit = base.controller.torque_limit
    why_not = "is a condition of the paper's law (eqs 13-19), and the law {!r} does not declare it is that law"
    return {
        "converged": "",
        "theorem1": "" if paper else "Theorem 1 " + why_not.format(law_code.name),
        "theorem2": "" if paper else "Theorem 2 " + why_not.format(law_code.name),
        "torque": "" if math.isfinite(limit) else f"{base.label} has no torque limit (controller.torque_limit = inf)",
        "wheels": ""
        if act.enabled and bool(np.isfinite(act.per_wheel("max_speed")).any())
        else f"{base.label} has no reaction wheels with a finite max_speed",
    }


def unsettled_score(t_final: float, steady_max_deg: float, tolerance_deg: float) -> float:
    """The score of a metric that never settles within the horizon ``t_final`` (see the module docstring).

    Parameters
    ----------
    t_final : float
        The horizon (s).
    steady_max_deg : float
        The metric's maximum over the steady window (deg); NaN counts as a full decade above.
    tolerance_deg : float
        The settling tolerance (deg).

    Returns
    -------
    float
        ``t_final * (2 + min(1, max(0, log10(steady_max_deg / tolerance_deg))))`` (s).

    Examples
    --------
    >>> unsettled_score(10.0, 1.0, 1.0), unsettled_score(10.0, 100.0, 1.0), unsettled_score(10.0, float("nan"), 1.0)
    (20.0, 30.0, 30.0)
    """
    ratio = steady_max_deg / tolerance_deg
    decades = 1.0 if not math.isfinite(ratio) else min(1.0, max(0.0, math.log10(max(ratio, 1e-300))))
    return float(t_final) * (2.0 + decades)


def progress_score(t_final: float, steady_max_deg: float, tolerance_deg: float) -> float:
    """The intermediate value of a settling objective not yet settled at a checkpoint: ``t_final * (2 + d)``.

    ``d = max(0, log10(steady_max / tolerance_deg))``, with ``steady_max`` the steady error so far, estimates the
    never-settles score (:func:`unsettled_score`) the run would get if it stayed where it is; ``d`` is not capped at
    one, so the pruner can tell a run 10 times above the tolerance from one 1000 times above.  As a converging run's
    error falls, so does its value (Optuna's pruners compare each trial's best value so far).  NaN (a diverged run)
    stays NaN, which Optuna's pruners prune.

    Parameters
    ----------
    t_final : float
        The horizon (s).
    steady_max_deg : float
        The metric's maximum over the steady part of the run so far (deg).
    tolerance_deg : float
        The settling tolerance (deg).

    Returns
    -------
    float
        Seconds (NaN for a NaN error).

    Examples
    --------
    >>> progress_score(10.0, 1.0, 1.0), progress_score(10.0, 1000.0, 1.0)
    (20.0, 50.0)
    """
    ratio = steady_max_deg / tolerance_deg
    if math.isnan(ratio):
        return math.nan
    return float(t_final) * (2.0 + max(0.0, math.log10(max(ratio, 1e-300))))
