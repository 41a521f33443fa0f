"""The runs of a law comparison (``fsmctl compare``): which law, with which settings, on which scenario.

A :class:`LawRun` is one compared run: a label, a law (a built-in name, a derivation script ``FILE.py`` or a derived
folder, as for ``[controller] law``), values of the law's parameters and overrides of the scenario's
``[controller]``.  :func:`as_runs` checks a list of them, :func:`with_and_without_limit` doubles each run with and
without a torque limit, :func:`read_runs_file` reads them from a TOML file, and :func:`run_scenario` is the scenario a
run flies.  :mod:`fsmctl.studies.compare` flies them and tabulates their metrics.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from fsmctl.errors import InputError
from fsmctl.model.laws import LawSwitchWarning, resolve_law, written_keys
from fsmctl.model.scenario import Scenario

__all__ = ["LawRun", "as_runs", "with_and_without_limit", "read_runs_file", "run_scenario"]


@dataclass(frozen=True)
class LawRun:
    """One compared run: a label, a law, its parameters and overrides of the scenario's controller.

    Parameters
    ----------
    label : str
        Name of the run in the tables and figures (unique within a comparison).
    law : str or Path
        A built-in law name (``fsmctl laws``), a derivation script ``FILE.py`` or a derived law folder.
    parameters : mapping
        Values of the law's declared parameters or preset choices by name (e.g. ``{"c1": 0.6}`` or
        ``{"surface": "tsm"}`` for ``fsm``, ``{"K": 2.0}``), each set for every agent.  Unset parameters keep the
        scenario's written values that the law declares (the rule of :meth:`fsmctl.Scenario.replace` when the law
        is switched), else the law's defaults.
    controller : mapping
        Overrides of the ``[controller]`` keys every law shares: ``torque_limit`` (N m, ``math.inf`` or ``"inf"``
        for none), ``error_model``, ``enabled``.

    Examples
    --------
    >>> LawRun("TSM", "fsm", {"surface": "tsm"}).describe()
    'fsm: surface=tsm'
    >>> LawRun.from_spec("derive/laws/pd.py").label
    'pd'
    """

    label: str
    law: str | Path = "fsm"
    parameters: Mapping[str, Any] = field(default_factory=dict)
    controller: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        if not isinstance(self.label, str) or not self.label.strip():
            raise InputError(f"run label must be a non-empty string, got {self.label!r}")
        if not isinstance(self.law, (str, Path)) or not str(self.law).strip():
            raise InputError(f"run {self.label!r}: law must be a name, a FILE.py or a folder, got {self.law!r}")
        for name in ("parameters", "controller"):
            value = getattr(self, name)
            if not isinstance(value, Mapping) or not all(isinstance(k, str) for k in value):
                raise InputError(f"run {self.label!r}: {name} must be a table of named values, got {value!r}")
            object.__setattr__(self, name, dict(value))

    @classmethod
    def from_spec(cls, spec: str | Path) -> LawRun:
        """A run of a law with the scenario's settings, labelled by the law (a script's or folder's name).

        Parameters
        ----------
        spec : str or pathlib.Path
            A built-in law name, a derivation script ``FILE.py`` or a derived law folder.

        Returns
        -------
        LawRun
            The run, without parameters or overrides.

        Examples
        --------
        >>> from fsmctl.studies import LawRun
        >>> LawRun.from_spec("fsm")
        LawRun(label='fsm', law='fsm', parameters={}, controller={})
        """
        text = str(spec).strip()
        path = Path(text)
        label = path.stem if path.suffix == ".py" else (path.name or text)
        return cls(label, text)

    def settings_text(self) -> str:
        """``key=value, ...``: the parameters, then the controller overrides (empty: the scenario's settings)."""
        items = [*self.parameters.items(), *self.controller.items()]
        return ", ".join(f"{k}={_value_text(v)}" for k, v in items)

    def describe(self) -> str:
        """``law: key=value, ...`` (see :meth:`settings_text`)."""
        text = self.settings_text()
        return f"{self.law}" + (f": {text}" if text else "")

    def to_dict(self) -> dict:
        """The run as JSON-able data (``label``, ``law``, ``parameters``, ``controller``).

        Returns
        -------
        dict
            The fields, the law as a string.
        """
        return {
            "label": self.label,
            "law": str(self.law),
            "parameters": dict(self.parameters),
            "controller": dict(self.controller),
        }


def _value_text(v: Any) -> str:
    if isinstance(v, float):
        return "inf" if math.isinf(v) and v > 0 else f"{v:g}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value_text(x) for x in v) + "]"
    return str(v)


def as_runs(laws: Sequence[LawRun | str | Path] | LawRun | str | Path) -> list[LawRun]:
    """The runs of a comparison: each law spec made a :class:`LawRun`, the labels checked unique.

    Parameters
    ----------
    laws : LawRun, str, Path or a sequence of them
        The runs, or law specs (a built-in name, ``FILE.py`` or a folder: :meth:`LawRun.from_spec`).

    Returns
    -------
    list of LawRun
        The runs, in order.

    Raises
    ------
    InputError
        No run, or two runs with the same label.

    Examples
    --------
    >>> [r.label for r in as_runs(["fsm", LawRun("TSM", "fsm", {"surface": "tsm"})])]
    ['fsm', 'TSM']
    >>> as_runs(["fsm", "fsm"])
    Traceback (most recent call last):
    ...
    fsmctl.errors.InputError: two runs are labelled 'fsm': give each run its own label (a runs file)
    """
    if isinstance(laws, (str, Path, LawRun)):
        laws = [laws]
    runs = [x if isinstance(x, LawRun) else LawRun.from_spec(x) for x in laws]
    if not runs:
        raise InputError("no law to compare: give at least one law or run")
    seen: set[str] = set()
    for r in runs:
        if r.label in seen:
            raise InputError(f"two runs are labelled {r.label!r}: give each run its own label (a runs file)")
        seen.add(r.label)
    return runs


def with_and_without_limit(laws: Sequence[LawRun | str | Path], torque_limit: float) -> list[LawRun]:
    """Each run twice: with ``torque_limit`` (N m) and without a limit (the ``controller`` override set).

    Parameters
    ----------
    laws : sequence of LawRun or str
        The runs (or law specs).
    torque_limit : float
        The finite per-axis limit of the limited runs.

    Returns
    -------
    list of LawRun
        ``label (limit X N m)`` and ``label (no limit)`` for every run, in order.

    Raises
    ------
    InputError
        ``torque_limit`` is not a finite number > 0.

    Examples
    --------
    >>> [r.label for r in with_and_without_limit(["fsm"], 2.0)]
    ['fsm (limit 2 N m)', 'fsm (no limit)']
    """
    if not (isinstance(torque_limit, (int, float)) and math.isfinite(torque_limit) and torque_limit > 0):
        raise InputError(
            f"with and without the torque limit: the limit must be a finite number > 0, got {torque_limit!r} "
            "(the scenario has none: give one)"
        )
    out = []
    for r in as_runs(laws):
        for label, limit in (
            (f"{r.label} (limit {torque_limit:g} N m)", float(torque_limit)),
            (f"{r.label} (no limit)", math.inf),
        ):
            out.append(dataclasses.replace(r, label=label, controller={**r.controller, "torque_limit": limit}))
    return out


def read_runs_file(path: str | Path) -> list[LawRun]:
    """The runs of a TOML file: a list of ``[[run]]`` tables with ``label``, ``law``, ``parameters``, ``controller``.

    Only ``law`` is required (the label defaults to the law's name).  A relative law path is taken relative to
    the file's folder when it exists there, else to the current directory::

        [[run]]
        label = "FSM"
        law = "fsm"

        [[run]]
        label = "FSM, no limit"
        law = "fsm"
        controller = { torque_limit = "inf" }

        [[run]]
        label = "PD"
        law = "pd.py"
        parameters = { K = 2.0, P = 10.0 }

    Parameters
    ----------
    path : str or pathlib.Path
        The TOML file.

    Returns
    -------
    list of LawRun
        The runs, in the file's order.

    Raises
    ------
    InputError
        Unreadable file, not TOML, or a run that is not as above (one line naming the run and key).

    Examples
    --------
    >>> import pathlib
    >>> p = pathlib.Path("runs.toml")
    >>> _ = p.write_text('[[run]]\\nlaw = "fsm"\\n[[run]]\\nlabel = "TSM"\\nlaw = "fsm"\\nparameters = {surface = "tsm"}\\n')
    >>> [(r.label, r.parameters) for r in read_runs_file(p)]
    [('fsm', {}), ('TSM', {'surface': 'tsm'})]
    """
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text("utf-8"))
    except FileNotFoundError:
        raise InputError(f"cannot read runs file {path}: no such file") from None
    except (OSError, UnicodeError) as exc:
        raise InputError(f"cannot read runs file {path}: {getattr(exc, 'strerror', None) or exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"runs file {path}: not valid TOML ({exc})") from None
    unknown = sorted(set(data) - {"run"})
    if unknown:
        raise InputError(f"runs file {path}: unknown key {unknown[0]!r} (expected [[run]] tables)")
    items = data.get("run")
    if not isinstance(items, list) or not items or not all(isinstance(d, dict) for d in items):
        raise InputError(f"runs file {path}: expected one or more [[run]] tables")
    runs = []
    for k, d in enumerate(items, start=1):
        where = f"runs file {path}, run {k}"
        bad = sorted(set(d) - {"label", "law", "parameters", "controller"})
        if bad:
            raise InputError(f"{where}: unknown key {bad[0]!r} (known: label, law, parameters, controller)")
        law = d.get("law")
        if not isinstance(law, str) or not law.strip():
            raise InputError(f"{where}: 'law' must be a law name, FILE.py or folder")
        local = path.parent / law
        if not Path(law).is_absolute() and (local.is_file() or local.is_dir()):
            law = str(local)
        label = d.get("label", LawRun.from_spec(law).label)
        try:
            runs.append(LawRun(label, law, d.get("parameters", {}), d.get("controller", {})))
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None
    return runs


def run_scenario(scenario: Scenario, run: LawRun) -> Scenario:
    """The scenario a run flies: ``scenario.replace(controller={"law": ..., ...})``, validated.

    The scenario's ``[controller]`` parameters that the run's law does not declare are dropped (they belong to
    the scenario's own law); the run's ``parameters`` and ``controller`` overrides are applied on top.

    Parameters
    ----------
    scenario : Scenario
        The compared scenario.
    run : LawRun
        The run.

    Returns
    -------
    Scenario
        The scenario with the run's law, parameters and overrides.

    Raises
    ------
    InputError
        Unknown law (:class:`fsmctl.model.laws.LawError`), a parameter the law does not declare, or a value out
        of range (the message starts with the run's label).

    Examples
    --------
    >>> import fsmctl
    >>> s = run_scenario(fsmctl.paper_scenario("1"), LawRun("TSM", "fsm", {"surface": "tsm"}, {"torque_limit": "inf"}))
    >>> s.controller.parameters["surface"], s.controller.torque_limit
    ('tsm', inf)
    """
    where = f"run {run.label!r}"
    try:
        law = resolve_law(run.law)
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None
    declared = written_keys(law)
    fixed = {"law", "parameters"}
    known_controller = sorted(f.name for f in dataclasses.fields(type(scenario.controller)) if f.name not in fixed)
    for key in run.controller:
        if key not in known_controller:
            raise InputError(f"{where}: controller has no setting {key!r} (known: {', '.join(known_controller)})")
    for key in run.parameters:
        if key not in declared:
            names = ", ".join(p.name for p in law.parameters) or "none"
            raise InputError(f"{where}: the law {law.name!r} has no parameter {key!r} (its parameters: {names})")
    with warnings.catch_warnings():  # the documented rule: the written keys the run's law declares carry over
        warnings.simplefilter("ignore", LawSwitchWarning)
        try:
            base = scenario.replace(controller={"law": str(run.law)})
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None
    # a run's parameter is every agent's: the agents' own values of it give way
    agents = [{k: None for k in run.parameters if k in a.parameters} for a in base.agents]
    sections: dict[str, Any] = {"controller": {**run.parameters, **run.controller}}
    if any(agents):
        sections["agents"] = agents
    try:
        return base.replace(**sections)
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None
