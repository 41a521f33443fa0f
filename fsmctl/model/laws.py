"""Control laws at run time: the built-in ones, a derived folder, or a derivation script.

:func:`resolve_law` turns what a user names (``--law``, ``[controller] law = ...``) into a :class:`LawCode`:

* a built-in name (``fsmctl laws`` lists them): ``generated/laws/<name>/``;
* a folder written by ``fsmctl derive FILE.py --out DIR``: it holds ``law.json`` and the generated code, and is
  verified in full before use (every file against its sha256 in ``manifest.json``, nothing missing or added, the
  format this fsmctl writes; the built-in folders too);
* a derivation script ``FILE.py``: derived on first use into the cache (``$FSMCTL_CACHE_DIR/laws`` or
  ``~/.cache/fsmctl/laws``), keyed by the script's content and the SymPy/CasADi/fsmctl versions.

:func:`parameter_matrix` is the one place a scenario's values become a law's packed parameters
(an agent's own value, else ``[controller]``'s, else the law's declared default; then the presets the scenario
selects), checked against the law's declared ranges.

Size: one concept, a control law at run time: resolving a name, folder or script to a verified
:class:`LawCode` and reading its declarations (parameters, presets, ranges) into packed parameters; the folder
format is read and checked in one place so that every caller sees the same law.
"""

from __future__ import annotations

import functools
import glob
import hashlib
import json
import os
import secrets
import shutil
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from fsmctl.codegen.formats import LAW_FILE, LAW_FORMAT, LAW_FORMAT_OLDEST, MANIFEST_FILE, MANIFEST_FORMAT, law_format
from fsmctl.errors import InputError
from fsmctl.model.generated_paths import (
    BUILTIN_LAW_SCRIPTS_PACKAGE,
    GeneratedCodeError,
    builtin_law_scripts,
    cache_root,
    generated_dir,
)
from fsmctl.ranges import ParameterRange
from fsmctl.suggest import did_you_mean
from fsmctl.version import __version__

__all__ = [
    "LawCode",
    "LawDiscontinuity",
    "LawPaperTheorems",
    "LawParameterInfo",
    "LawPresetGroup",
    "LawTrigger",
    "LawError",
    "builtin_laws",
    "resolve_law",
    "parameter_matrix",
    "written_keys",
    "carried_keys",
    "check_written_parameters",
    "initial_law_states",
    "LawSwitchWarning",
]

CONTROLLER_KEYS = ("law", "torque_limit", "error_model", "enabled")
"""the ``[controller]`` keys every law shares (:class:`fsmctl.model.scenario.ControllerSettings`; checked there)"""
AGENT_KEYS = ("J0", "delta_J", "sigma0", "omega0", "disturbance")
"""an agent's own keys (:class:`fsmctl.model.scenario.Agent`; every other key of ``[[agents]]`` is a law parameter)"""


class LawError(InputError):
    """A law cannot be found, derived or used (an :class:`~fsmctl.errors.InputError`: exit 2 on the command line).

    Examples
    --------
    >>> from fsmctl.model import LawError, resolve_law
    >>> try:
    ...     resolve_law("no-such-law")
    ... except LawError as exc:
    ...     print(str(exc).split(":")[0])
    law 'no-such-law'
    """

    @classmethod
    def unknown(cls, text: str, names) -> LawError:
        """The error for a law that is none of the built-in ones, a script or a folder, with "did you mean".

        Parameters
        ----------
        text : str
            What was given.
        names : iterable of str
            The built-in laws' names.

        Returns
        -------
        LawError
            ``law 'fsmm': not a built-in law (the built-in laws: fsm, ...), a derivation script (.py) or a derived law
            folder; did you mean fsm?``.

        Examples
        --------
        >>> print(LawError.unknown("fsmm", ["fsm", "pid"]))
        law 'fsmm': not a built-in law (the built-in laws: fsm, pid), a derivation script (.py) or a derived law folder; did you mean fsm?
        """
        names = list(names)
        hint = did_you_mean(text, names)
        known = f"the built-in laws: {', '.join(names)}"
        return cls(
            f"law {text!r}: not a built-in law ({known}), a derivation script (.py) or a derived law folder"
            + (f"; {hint}" if hint else "")
        )


class LawSwitchWarning(UserWarning):
    """Another law is flown on a scenario: which of the keys written for its own law apply, which are ignored.

    :meth:`fsmctl.model.scenario.Scenario.replace` (``controller={"law": ...}``, ``--law`` on the command line)
    keeps the written parameters and preset choices that are the same parameter of the new law (:func:`carried_keys`:
    the same name, unit and size) and drops the others; this
    warning says so in one line.

    Examples
    --------
    >>> import warnings
    >>> import fsmctl
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     pid = fsmctl.paper_scenario("1").replace(controller={"law": "pid"})
    >>> print(caught[0].message)  # doctest: +ELLIPSIS
    law 'pid' flown instead of 'fsm': written keys applied: none; ignored (not parameters of pid of the same unit and size): alpha, ...
    """


@dataclass(frozen=True)
class LawParameterInfo(ParameterRange):
    """A law parameter as declared by its derivation script (read from the law folder's ``law.json``).

    Parameters
    ----------
    name : str
        The parameter's name, as a scenario's ``[controller]`` sets it.
    default : tuple of float
        Its default value (one number per component; an option's index).
    unit : str
        Its unit (``"1"`` for none).
    minimum, maximum : float or None
        The bounds of its range (None: unbounded).
    exclusive_minimum, exclusive_maximum : bool
        Whether the bounds themselves are excluded.
    choices : tuple of str
        The options of an option parameter (empty for a number).
    tunable : bool
        Whether ``fsmctl tune`` may search it.
    doc : str
        One line saying what it is (with the paper's equation).

    Examples
    --------
    >>> from fsmctl.model import resolve_law
    >>> c1 = resolve_law("fsm").parameter("c1")
    >>> c1.default, c1.unit, c1.range_text()
    ((0.6,), '1/s', '0 <= x')
    >>> c1.values(0.9, "controller.c1")
    (0.9,)
    """

    name: str
    default: tuple[float, ...]
    unit: str
    minimum: float | None
    maximum: float | None
    exclusive_minimum: bool
    exclusive_maximum: bool
    choices: tuple[str, ...]
    tunable: bool
    doc: str

    def values(self, value, where: str) -> tuple[float, ...]:
        """A scenario value for this parameter, checked and packed (an option becomes its index).

        Parameters
        ----------
        value : float, sequence of float or str
            The value as the scenario gives it (a number, ``size`` numbers, or an option's name); a number for a
            vector parameter sets every component.
        where : str
            Where it comes from (e.g. ``"controller.c1"``), for error messages.

        Returns
        -------
        tuple of float
            ``size`` numbers, as packed into the law's parameter vector.

        Raises
        ------
        LawError
            Not a number, the wrong count, outside the declared range, or an unknown option.
        """
        if self.choices:
            if not isinstance(value, str) or value.lower() not in self.choices:
                raise LawError(f"{where}: must be one of {', '.join(self.choices)}, got {value!r}")
            return (float(self.choices.index(value.lower())),)
        items = list(value) if isinstance(value, (list, tuple, np.ndarray)) else [value] * self.size
        if self.size == 1 and len(items) == 1 and isinstance(value, (list, tuple, np.ndarray)):
            raise LawError(f"{where}: expected a number, got a list")
        if len(items) != self.size:
            raise LawError(f"{where}: expected {self.size} numbers, got {len(items)}")
        out = []
        for v in items:
            if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
                raise LawError(f"{where}: expected a number, got {v!r}")
            why = self.problem(float(v))
            if why:
                raise LawError(f"{where}: {why}")
            out.append(float(v))
        return tuple(out)


@dataclass(frozen=True)
class LawDiscontinuity:
    """Where a law's closed loop is discontinuous, as its script declares it (``LawBuilder.discontinuous``).

    Parameters
    ----------
    where : str
        Where, in words (e.g. ``"sgn(s) of the switching term u^D (eq 18)"``).
    smoothed_by : str or None
        The parameter whose positive value makes the law continuous (e.g. ``boundary_layer``), or None.
    column : int or None
        That parameter's column in the packed parameters.

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.model import resolve_law
    >>> d = resolve_law("fsm").discontinuity
    >>> d.smoothed_by, d.discontinuous(np.array([0.6, 0.8, 0.7, 0.0, 1e-4, 1.0, 0.005, 0.005, 0.005]))
    ('boundary_layer', True)
    """

    where: str
    smoothed_by: str | None
    column: int | None

    def discontinuous(self, params) -> bool:
        """Whether the law flown with ``params`` is discontinuous (for any agent).

        Parameters
        ----------
        params : array_like
            A packed parameter row ``(n_params,)`` or one row per agent ``(n_agents, n_params)``.

        Returns
        -------
        bool
            True unless the smoothing parameter is > 0 for every agent (always True without one).
        """
        if self.column is None:
            return True
        values = np.atleast_2d(np.asarray(params, dtype=float))[:, self.column]
        return bool(np.any(values <= 0.0))


@dataclass(frozen=True)
class LawPresetGroup:
    """A named group of parameter presets a law declares (``LawBuilder.preset_group``), selected by one key.

    Parameters
    ----------
    name : str
        The group's name: the ``[controller]`` key that selects an option.
    default : str
        The option that applies when a scenario selects none (it changes no parameter's default).
    options : mapping of str to mapping of str to tuple of float
        Each option's packed values by parameter name.
    doc : str
        What the group chooses.

    Examples
    --------
    >>> from fsmctl.model import resolve_law
    >>> g = resolve_law("fsm").preset_group("surface")
    >>> g.default, dict(g.options["tsm"])
    ('fsm', {'c1': (0.0,)})
    """

    name: str
    default: str
    options: Mapping[str, Mapping[str, tuple[float, ...]]]
    doc: str


@dataclass(frozen=True)
class LawPaperTheorems:
    """The declaration that a law is Liang et al. 2012's eqs 13-19 (``LawBuilder.paper_theorems``).

    Theorems 1-2 of the paper then apply to it: Theorem 1 constrains the coupling weights (eq 19), Theorem 2 the
    switching gain; ``fsmctl prove --law`` verifies the declaration (the closed loop is eq 20).

    Parameters
    ----------
    parameters : mapping of str to str
        The law's parameter name for each of the paper's symbols (``c1``, ``c2``, ``alpha``, ``boundary_layer``,
        ``epsilon``, ``singularity_fix``, ``delta``).

    Examples
    --------
    >>> from fsmctl.model import resolve_law
    >>> resolve_law("fsm").paper_theorems.parameters["delta"], resolve_law("pid").paper_theorems
    ('delta', None)
    """

    parameters: Mapping[str, str]


@dataclass(frozen=True)
class LawTrigger:
    """When an agent of an event-triggered law sends its broadcast (``LawBuilder.trigger``), as ``law.json`` says.

    The engine evaluates the generated ``law_trigger(t, broadcast, broadcast_sent, params, constants)`` at each
    check instant and the agent sends when it is > 0 (see ``docs/guide/event-triggered.md``).

    Parameters
    ----------
    condition : str
        The declared condition (``lhs > rhs``), as text.
    period : float or None
        Seconds between checks (a multiple of the control period), or None: every control instant.
    doc : str
        What the rule is (a citation).

    Examples
    --------
    >>> from fsmctl.model import resolve_law
    >>> resolve_law("fsm_event").trigger.period, resolve_law("fsm").trigger
    (None, None)
    """

    condition: str
    period: float | None
    doc: str

    def check_every(self, control_period: float) -> int:
        """The checks' spacing in control instants: 1 without a declared period, else ``period / control_period``.

        Parameters
        ----------
        control_period : float
            The run's control period, s (> 0).

        Returns
        -------
        int
            Control instants between checks (>= 1).

        Raises
        ------
        LawError
            No control period, or a declared period that is not a whole multiple of it.

        Examples
        --------
        >>> from fsmctl.model.laws import LawTrigger
        >>> LawTrigger("|s - s_sent| > c0", 0.5, "").check_every(0.1)
        5
        >>> LawTrigger("|s - s_sent| > c0", 0.25, "").check_every(0.1)
        Traceback (most recent call last):
        ...
        fsmctl.model.laws.LawError: the law's trigger is checked every 0.25 s, which is not a multiple of simulation.control_period = 0.1 s
        """
        if not control_period > 0:
            raise LawError(
                "an event-triggered law (a law with a trigger) needs a control period: set "
                "simulation.control_period > 0 (e.g. 0.1 for 10 Hz control; the trigger is checked at the control "
                "instants)"
            )
        if self.period is None:
            return 1
        m = round(self.period / control_period)
        if m < 1 or abs(m * control_period - self.period) > 1e-9 * self.period:
            raise LawError(
                f"the law's trigger is checked every {self.period:g} s, which is not a multiple of "
                f"simulation.control_period = {control_period:g} s"
            )
        return m


@dataclass(frozen=True)
class LawCode:
    """A law's generated code and what the runtime needs to know about it (read from a law folder's ``law.json``).

    Parameters
    ----------
    name : str
        The law's name (``fsm`` is Liang et al. 2012's fast-sliding-mode law, eqs 13-20).
    folder : pathlib.Path
        The law folder (``law.json``, ``manifest.json``, generated C and CasADi functions).
    doc : str
        What the law is.
    reference : str
        Where it comes from (a paper), possibly empty.
    source : str
        The derivation script it was generated from, as ``law.json`` records it (a built-in law's is a path of the
        source tree, which is not installed): :meth:`script` says where it is.
    parameters : tuple of LawParameterInfo
        The declared parameters, in packing order.
    states : tuple of dict
        The law's own states (``name``, ``size``, ``initial``), e.g. an integrator's.
    broadcast_name, broadcast_unit : str
        What each agent sends its neighbours (the sliding variable ``s`` for the paper's law) and its unit.
    n_broadcast, n_constants, n_cache : int
        Sizes of the broadcast vector, the law's precomputed constants and its per-step cache.
    has_lyapunov : bool
        Whether the law declares a Lyapunov function (checked by ``fsmctl prove --law``).
    discontinuity : LawDiscontinuity or None
        Where its closed loop is discontinuous, unless a parameter smooths it; None for a continuous law.
    presets : tuple of LawPresetGroup
        Its named parameter presets (e.g. the ``surface`` of the paper's law, Sec. 3.3).
    loop_rates_doc : str or None
        How its declared loop-rate bounds come about (:meth:`loop_rates`); None if it declares none.
    paper_theorems : LawPaperTheorems or None
        Whether it is the paper's eqs 13-19, so that Theorems 1-2 apply (and with which parameters).
    n_wheels : int
        The number of reaction wheels the law commands itself (``law_wheels_<model>``,
        :meth:`fsmctl.symbolic.law.LawBuilder.wheel_torques`); 0 when the engine distributes its body torque.
    trigger : LawTrigger or None
        When an agent sends its broadcast (event-triggered communication); None: at every control evaluation.

    Examples
    --------
    >>> from fsmctl.model import resolve_law
    >>> pid = resolve_law("pid")
    >>> [p.name for p in pid.parameters], pid.n_params, pid.state_labels()
    (['K', 'P', 'Ki', 'k_coupling'], 4, ['int_sigma[0]', 'int_sigma[1]', 'int_sigma[2]'])
    >>> pid.builtin
    True
    """

    name: str
    folder: Path
    doc: str
    reference: str
    source: str
    parameters: tuple[LawParameterInfo, ...]
    states: tuple[dict, ...]
    broadcast_name: str
    broadcast_unit: str
    n_broadcast: int
    n_constants: int
    n_cache: int
    has_lyapunov: bool
    discontinuity: LawDiscontinuity | None = None
    presets: tuple[LawPresetGroup, ...] = ()
    loop_rates_doc: str | None = None
    paper_theorems: LawPaperTheorems | None = None
    n_wheels: int = 0
    trigger: LawTrigger | None = None

    @property
    def n_params(self) -> int:
        """The length of the packed parameter vector (the sum of the parameters' sizes)."""
        return sum(p.size for p in self.parameters)

    @property
    def n_states(self) -> int:
        """The number of the law's own state components (0 for a static law)."""
        return sum(int(s["size"]) for s in self.states)

    @property
    def builtin(self) -> bool:
        """Whether this is one of the built-in laws of ``generated/laws/``."""
        return self.folder.parent == (generated_dir() / "laws").resolve()

    def script(self, *, portable: bool = False) -> str:
        """Where the law's derivation script is for the user of this installation: what every output names.

        :attr:`source` is what ``law.json`` records. A built-in law's is a path of the source tree
        (``derive/laws/fsm.py``, part of the generated code ``python -m derive --check`` compares), and ``derive/``
        is not installed: its script is the package data ``fsmctl._builtin_laws``
        (:func:`~fsmctl.model.generated_paths.builtin_law_scripts`). A derived law's folder knows its script by
        the name it was derived from (``fsmctl derive my_law.py``), which is what is named.

        Parameters
        ----------
        portable : bool, optional
            False (default): a built-in law's installed script as an absolute path, a file to open (what the
            terminal shows). True: the same text on every machine, for what is written to files (result files,
            run records, exported libraries, reports): the script as the package resource it is,
            ``fsm.py in fsmctl._builtin_laws`` (no path: an editable install keeps it in the source tree's
            ``derive/laws/``, another installation in its site-packages; ``fsmctl laws NAME`` shows where).

        Returns
        -------
        str
            The script ("" when ``law.json`` names none).

        Examples
        --------
        >>> from pathlib import Path
        >>> from fsmctl.model import resolve_law
        >>> fsm = resolve_law("fsm")
        >>> fsm.source, fsm.script(portable=True), Path(fsm.script()).is_file()
        ('derive/laws/fsm.py', 'fsm.py in fsmctl._builtin_laws', True)
        >>> Path(resolve_law("pid").script()).name
        'pd.py'
        """
        if not self.source or not self.builtin:
            return self.source
        name = Path(self.source).name
        if portable:
            return f"{name} in {BUILTIN_LAW_SCRIPTS_PACKAGE}"
        return str(builtin_law_scripts() / name)

    def parameter(self, name: str) -> LawParameterInfo:
        """A declared parameter by name.

        Parameters
        ----------
        name : str
            The parameter's name.

        Returns
        -------
        LawParameterInfo
            Its declaration.

        Raises
        ------
        KeyError
            The law declares no such parameter.
        """
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(name)

    def preset_group(self, name: str) -> LawPresetGroup:
        """A declared preset group by name.

        Parameters
        ----------
        name : str
            The group's name (its ``[controller]`` key).

        Returns
        -------
        LawPresetGroup
            Its declaration.

        Raises
        ------
        KeyError
            The law declares no such group.
        """
        for g in self.presets:
            if g.name == name:
                return g
        raise KeyError(name)

    def loop_rates(self, params) -> tuple[float, float] | None:
        """The law's declared loop-rate bounds ``(surface, layer)`` (1/s), the largest over agents, or None.

        Evaluates the generated ``law_loop_rates(params)`` for each row.

        Parameters
        ----------
        params : array_like
            A packed parameter row ``(n_params,)`` or one row per agent ``(n_agents, n_params)``.

        Returns
        -------
        tuple of float or None
            ``(surface, layer)``, or None when the law declares no loop rates.

        Examples
        --------
        >>> import numpy as np
        >>> from fsmctl.model import resolve_law
        >>> row = np.array([0.6, 0.8, 0.7, 0.01, 1e-4, 1.0, 0.005, 0.004, 0.003])
        >>> [round(v, 3) for v in resolve_law("fsm").loop_rates(row)], resolve_law("pid").loop_rates(row[:4])
        ([17.083, 0.5], None)
        """
        if self.loop_rates_doc is None:
            return None
        rates = self.casadi("law_loop_rates")
        rows = np.atleast_2d(np.asarray(params, dtype=float))
        values = [[float(v) for v in rates(row)] for row in rows]
        return max(v[0] for v in values), max(v[1] for v in values)

    def state_labels(self) -> list[str]:
        """One label per law state component: ``name`` for a scalar, ``name[k]`` for a vector.

        Returns
        -------
        list of str
            ``n_states`` labels.
        """
        out = []
        for s in self.states:
            out += [f"{s['name']}[{k}]" for k in range(int(s["size"]))] if int(s["size"]) > 1 else [s["name"]]
        return out

    def casadi(self, name: str):
        """One of the law's generated functions (compiled if possible, else CasADi's virtual machine).

        Parameters
        ----------
        name : str
            The function's name (``law_constants``, ``law_local_paper``, ...; see the folder's ``manifest.json``).

        Returns
        -------
        casadi.Function
            The function.
        """
        from fsmctl.model.generated_code import law_casadi_function

        return law_casadi_function(self.folder, name)


def _manifest(folder: Path) -> dict:
    """A law folder's parsed ``manifest.json``, checked for the fields the verification reads."""
    path = folder / MANIFEST_FILE
    if not path.is_file():
        raise LawError(
            f"{path}: missing; the folder is incomplete: derive it again (`fsmctl derive FILE.py --out DIR`)"
        )
    try:
        manifest = json.loads(path.read_text("utf-8"))
    except (OSError, ValueError) as exc:
        raise LawError(f"{path}: cannot be read ({exc}); derive the folder again") from exc
    listed = manifest.get("sha256") if isinstance(manifest, dict) else None
    if not isinstance(listed, dict) or not all(
        isinstance(k, str) and isinstance(v, str) and len(v) == 64 for k, v in listed.items()
    ):
        raise LawError(f"{path}: corrupt (no sha256 table of the folder's files); derive the folder again")
    _check_format(path, manifest.get("format"), MANIFEST_FORMAT)
    return manifest


def _check_format(path: Path, number: Any, expected: int, oldest: int | None = None) -> None:
    """Refuse a file whose format number is not one this fsmctl reads, ``oldest`` (default ``expected``) to
    ``expected`` (older, newer or none)."""
    oldest = expected if oldest is None else oldest
    if isinstance(number, int) and not isinstance(number, bool) and oldest <= number <= expected:
        return
    again = "derive the law again with this fsmctl (`fsmctl derive FILE.py --out DIR`)"
    if isinstance(number, int) and not isinstance(number, bool) and number > expected:
        raise LawError(
            f"{path}: format {number} is newer than this fsmctl {__version__} reads (format {expected}): "
            f"{again}, or upgrade fsmctl"
        )
    what = f"format {number}" if isinstance(number, int) and not isinstance(number, bool) else "no format number"
    raise LawError(f"{path}: {what}, older than this fsmctl {__version__} reads (format {oldest}): {again}")


def _verify_files(folder: Path, listed: Mapping[str, str]) -> None:
    """Every file of the folder is listed in its manifest with its sha256, and every listed file is there."""
    present = {
        p.relative_to(folder).as_posix() for p in folder.rglob("*") if not p.is_dir() and p.name != MANIFEST_FILE
    }
    for rel in sorted(listed):
        path = folder / rel
        if rel not in present:
            raise LawError(f"{path}: missing (listed in {MANIFEST_FILE}); the folder is incomplete: derive it again")
        if hashlib.sha256(path.read_bytes()).hexdigest() != listed[rel]:
            raise LawError(
                f"{path}: does not match its sha256 in {MANIFEST_FILE} (edited or copied from another law?); "
                "derive the folder again"
            )
    extra = sorted(present - set(listed))
    if extra:
        raise LawError(
            f"{folder / extra[0]}: not listed in {MANIFEST_FILE} (a file added to the law folder); remove it or "
            "derive the folder again"
        )


def _verified_metadata(folder: Path) -> tuple[dict, dict]:
    """``(law.json, manifest.json)`` of a law folder verified in full: every file against the manifest's sha256."""
    if not (folder / LAW_FILE).is_file():
        raise LawError(f"{folder}: not a law folder (no {LAW_FILE}; write one with `fsmctl derive FILE.py --out DIR`)")
    manifest = _manifest(folder)
    try:
        _verify_files(folder, manifest["sha256"])
        meta = json.loads((folder / LAW_FILE).read_text("utf-8"))
    except (OSError, ValueError) as exc:
        if isinstance(exc, LawError):
            raise
        raise LawError(f"{folder}: cannot be read ({exc})") from exc
    if not isinstance(meta, dict):
        raise LawError(f"{folder / LAW_FILE}: not a law description (a JSON object); derive the folder again")
    _check_format(folder / LAW_FILE, meta.get("format"), LAW_FORMAT, LAW_FORMAT_OLDEST)
    if meta.get("format") != law_format(meta):  # e.g. wheel outputs in a format-1 folder: an older fsmctl ignores them
        raise LawError(
            f"{folder / LAW_FILE}: format {meta.get('format')} does not describe this law (format {law_format(meta)} "
            "does); derive the folder again"
        )
    return meta, manifest


def _signature(manifest: dict, function: str, inputs: bool) -> dict[str, int]:
    """The number of values of each input (or output) of a generated function, from the manifest."""
    for f in manifest.get("functions", []):
        if f["name"] == function:
            return {io["name"]: int(np.prod(io["shape"])) for io in f["inputs" if inputs else "outputs"]}
    raise KeyError(f"function {function}")


def _check_sizes(law: LawCode, manifest: dict) -> None:
    """The sizes ``law.json`` declares are those of the generated functions (what the engine will call)."""
    local = _signature(manifest, "law_local_paper", inputs=False)
    control = _signature(manifest, "law_control_paper", inputs=True)
    declared = {
        "broadcast size": (law.n_broadcast, local["broadcast"]),
        "cache size": (law.n_cache, local["cache"]),
        "parameter count": (law.n_params, control["params"]),
        "constant count": (law.n_constants, control["constants"]),
        "state count": (law.n_states, control["z"]),
    }
    if law.n_wheels:  # law_wheels_<model>: the control inputs, then the wheels' (fsmctl.symbolic.law.WHEEL_INPUTS)
        for model in ("paper", "exact"):
            wheels_in = _signature(manifest, f"law_wheels_{model}", inputs=True)
            wheels_out = _signature(manifest, f"law_wheels_{model}", inputs=False)
            declared[f"wheel count ({model})"] = (law.n_wheels, wheels_out["u_wheels"])
            declared[f"wheel speeds ({model})"] = (law.n_wheels, wheels_in["wheel_speed"])
            declared[f"spin axes ({model})"] = (3 * law.n_wheels, wheels_in["spin_axes"])
    for what, (said, generated) in declared.items():
        if said != generated:
            raise LawError(
                f"{law.folder / LAW_FILE}: {what} {said} is not the generated functions' {generated}; derive the "
                "folder again"
            )


def _read_law(folder: Path) -> LawCode:
    """A law folder verified in full (:func:`_verified_metadata`), read into a :class:`LawCode`."""
    meta, manifest = _verified_metadata(folder)
    try:
        law = _law_code(folder, meta)
        _check_sizes(law, manifest)
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        if isinstance(exc, LawError):
            raise
        what = f"no entry {exc}" if isinstance(exc, KeyError) else f"an entry cannot be read ({exc})"
        raise LawError(
            f"{folder / LAW_FILE}: {what}: written by another fsmctl version?; derive the folder again"
        ) from exc
    return law


def _law_code(folder: Path, meta: dict) -> LawCode:
    params = tuple(
        LawParameterInfo(
            p["name"],
            tuple(float(v) for v in (p["default"] if isinstance(p["default"], list) else [p["default"]])),
            p["unit"],
            p["minimum"],
            p["maximum"],
            p["exclusive_minimum"],
            p["exclusive_maximum"],
            tuple(p["choices"]),
            p["tunable"],
            p["doc"],
        )
        for p in meta["parameters"]
    )
    return LawCode(
        name=meta["name"],
        folder=folder.resolve(),
        doc=meta["doc"],
        reference=meta.get("reference", ""),
        source=meta.get("source", ""),
        parameters=params,
        states=tuple(meta["states"]),
        broadcast_name=meta["broadcast"]["name"],
        broadcast_unit=meta["broadcast"].get("unit", "1"),
        n_broadcast=int(meta["broadcast"]["size"]),
        n_constants=sum(int(c["size"]) for c in meta["constants"]),
        n_cache=sum(int(c["size"]) for c in meta["cache"]),
        has_lyapunov=meta.get("lyapunov") is not None,
        discontinuity=_read_discontinuity(meta.get("discontinuity"), params),
        presets=tuple(
            LawPresetGroup(
                g["name"],
                g["default"],
                MappingProxyType(
                    {
                        option: MappingProxyType({k: tuple(float(x) for x in v) for k, v in sets.items()})
                        for option, sets in g["options"].items()
                    }
                ),
                g.get("doc", ""),
            )
            for g in meta.get("presets", [])
        ),
        loop_rates_doc=None if meta.get("loop_rates") is None else meta["loop_rates"].get("doc", ""),
        n_wheels=0 if meta.get("wheels") is None else int(meta["wheels"]["count"]),
        paper_theorems=None
        if meta.get("paper_theorems") is None
        else LawPaperTheorems(MappingProxyType(dict(meta["paper_theorems"]))),
        trigger=None
        if meta.get("trigger") is None
        else LawTrigger(
            str(meta["trigger"]["condition"]),
            None if meta["trigger"]["period"] is None else float(meta["trigger"]["period"]),
            str(meta["trigger"].get("doc", "")),
        ),
    )


def _read_discontinuity(entry: dict | None, params: tuple[LawParameterInfo, ...]) -> LawDiscontinuity | None:
    if entry is None:
        return None
    name, column, k = entry.get("smoothed_by"), None, 0
    for p in params:
        if p.name == name:
            column = k
        k += p.size
    if name is not None and column is None:
        raise LawError(f"law.json: discontinuity smoothed by {name!r}, which is not a parameter of the law")
    return LawDiscontinuity(entry["where"], name, column)


def builtin_laws() -> dict[str, LawCode]:
    """The built-in laws by name: those that declare they are the paper's law first, then by name.

    A law that declares ``LawBuilder.paper_theorems`` (:attr:`LawCode.paper_theorems`) is listed before the
    others; within each group the laws are ordered by name.

    Returns
    -------
    dict of str to LawCode
        ``{name: law}`` for every law folder of ``generated/laws/``.

    Examples
    --------
    >>> from fsmctl.model import builtin_laws
    >>> list(builtin_laws())
    ['fsm', 'fsm_wheels', 'adaptive_fsm', 'fsm_event', 'pid', 'super_twisting']
    """
    return dict(_builtin_laws())


@functools.cache
def _builtin_laws() -> dict[str, LawCode]:
    """The built-in laws, read and verified once per session (package data; :func:`resolve_law.cache_clear` reads
    them again)."""
    root = generated_dir() / "laws"
    laws = [_read_law(p) for p in sorted(root.iterdir()) if (p / LAW_FILE).is_file()]
    return {law.name: law for law in sorted(laws, key=lambda law: (law.paper_theorems is None, law.name))}


def _law_cache_root() -> Path:
    return cache_root() / "laws"


def _script_key(path: Path) -> str:
    import casadi
    import sympy

    h = hashlib.sha256(path.read_bytes())
    h.update(f"fsmctl {__version__} sympy {sympy.__version__} casadi {casadi.__version__}".encode())
    for p in sorted((Path(__file__).resolve().parents[1] / "symbolic").glob("*.py")) + sorted(
        (Path(__file__).resolve().parents[1] / "codegen").glob("*.py")
    ):
        h.update(p.read_bytes())  # the symbolic API and the generator determine the generated code
    return h.hexdigest()[:24]


def derive_script(path: Path, out: Path | None = None) -> Path:
    """Derive a script into ``out`` (default: the law cache, reused while the script is unchanged).

    The folder is written beside ``out`` under a temporary name, then put in place by renames: ``out`` is at
    every moment the previous complete folder or the complete new one.  An existing ``out`` is renamed aside
    (``.<name>.old-*``), the new folder renamed in, and the old one deleted; an interruption between the two
    renames puts the old folder back, and a process killed right there leaves it aside, where the next use of
    ``out`` (:func:`resolve_law` or this function) restores it.  A cached folder that fails the verification
    of :func:`resolve_law` (edited, incomplete) is derived again.

    Parameters
    ----------
    path : pathlib.Path
        The derivation script.
    out : pathlib.Path or None, optional
        The law folder to write; None for the cache (``$FSMCTL_CACHE_DIR/laws/<key>``).

    Returns
    -------
    pathlib.Path
        The law folder.

    Raises
    ------
    LawError
        ``out`` exists and is not a law folder.
    fsmctl.symbolic.law.LawDefinitionError
        The script does not derive (:func:`fsmctl.codegen.laws.load_derivation_script`).
    """
    from fsmctl.codegen.laws import load_derivation_script, write_law

    path = Path(path)
    if out is None:
        target = _law_cache_root() / _script_key(path)
        if _verifies(target):
            return target
    else:
        target = Path(out)
        _restore_aside(target)
        if target.is_dir() and not (target / LAW_FILE).is_file() and any(target.iterdir()):
            raise LawError(f"{target}: exists and is not a law folder; choose another --out")
    variants = load_derivation_script(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.new-", dir=target.parent))
    try:
        write_law(tmp, variants, source=path.name, generator=f"fsmctl derive {path.name}")
        if out is None:  # the cache: another process may derive the same script at the same time
            try:
                os.rename(tmp, target)  # refused when the folder is there (and not empty)
            except OSError:
                if not _verifies(target):  # not another process's complete copy: a damaged one, replaced
                    _put_in_place(tmp, target)
        else:
            _put_in_place(tmp, target)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return target


def _verifies(folder: Path) -> bool:
    """Whether ``folder`` is a complete law folder that passes the verification of :func:`resolve_law`."""
    try:
        _read_law(folder)
    except LawError:
        return False
    return True


def _asides(target: Path) -> list[Path]:
    """The previous folders of ``target`` renamed aside by :func:`_put_in_place`, oldest first."""
    if not target.parent.is_dir():
        return []
    found = [p for p in target.parent.glob(f".{glob.escape(target.name)}.old-*") if p.is_dir()]
    return sorted(found, key=lambda p: p.stat().st_mtime)


def _put_in_place(new: Path, target: Path) -> None:
    """Rename the complete folder ``new`` to ``target``; an existing ``target`` is renamed aside, then deleted."""
    if not target.exists():
        os.rename(new, target)
        return
    aside = target.parent / f".{target.name}.old-{os.getpid()}-{secrets.token_hex(4)}"
    os.rename(target, aside)
    try:
        os.rename(new, target)
    except BaseException:  # Ctrl-C or a failure between the two renames: the old folder goes back
        os.rename(aside, target)
        raise
    shutil.rmtree(aside, ignore_errors=True)


def _restore_aside(target: Path) -> None:
    """Finish a replacement a killed process left half done: restore the folder set aside, delete older ones."""
    asides = _asides(target)
    if asides and not target.exists():
        os.rename(asides.pop(), target)
    for aside in asides:
        shutil.rmtree(aside, ignore_errors=True)


_STAMPED_BY_CONTENT = ("law.json", "manifest.json")
"""Files of a law folder whose content (not only time and size) is part of its stamp: a derive rewrites the manifest,
which holds the sha256 of every other file."""


def _stamp(text: str, cwd: str) -> tuple:
    """What changes when a law's files change: name, modification time and size of every file of a folder, or of a
    script (empty for a built-in name or a missing path), and the content of a script and of a folder's law.json
    and manifest.json (a file rewritten within one tick of the file system's clock keeps its time, and an edit
    such as 4.0 -> 5.0 its size).  Part of the cache key of :func:`_resolve`, so that a law folder derived again
    or edited, or a script edited, within one session is read (and verified) again."""
    if text in _builtin_laws():
        return ()
    path = Path(text).expanduser()
    path = path if path.is_absolute() else Path(cwd) / path
    try:
        if not path.is_dir():
            st = path.stat()
            return ((str(path), st.st_mtime_ns, st.st_size, hashlib.sha256(path.read_bytes()).hexdigest()),)
        out, folders = [], [str(path)]
        while folders:
            with os.scandir(folders.pop()) as entries:
                for entry in entries:
                    if entry.is_dir(follow_symlinks=False):
                        folders.append(entry.path)
                    else:
                        st = entry.stat()
                        content = ""
                        if entry.name in _STAMPED_BY_CONTENT:
                            content = hashlib.sha256(Path(entry.path).read_bytes()).hexdigest()
                        out.append((entry.path, st.st_mtime_ns, st.st_size, content))
        return tuple(sorted(out))
    except OSError:
        return ()


@functools.lru_cache(maxsize=256)
def _resolve(text: str, cwd: str, stamp: tuple) -> LawCode:
    laws = _builtin_laws()
    if text in laws:
        return laws[text]
    path = Path(text).expanduser()
    if not path.is_absolute():
        path = Path(cwd) / path
    if not path.exists():
        _restore_aside(path)  # a replacement by `fsmctl derive --out` killed between its two renames
    if path.is_dir():
        return _read_law(path)
    if path.suffix == ".py":
        if not path.is_file():
            raise LawError(f"law {text!r}: no such derivation script ({path})")
        return _read_law(derive_script(path))
    raise LawError.unknown(text, laws)


def resolve_law(law: str | Path | LawCode | None) -> LawCode:
    """The :class:`LawCode` of a built-in name, a derived folder or a derivation script (see the module docstring).

    Parameters
    ----------
    law : str, pathlib.Path, LawCode or None
        A built-in name (``fsmctl laws`` lists them), a folder written by ``fsmctl derive FILE.py --out DIR``, a
        derivation script ``FILE.py`` (derived on first use into the cache), a :class:`LawCode` (returned as is),
        or None for the paper's law ``fsm``.  Relative paths are relative to the working folder.

    Returns
    -------
    LawCode
        The law.

    Raises
    ------
    LawError
        Unknown name or missing path, or a law folder that fails its verification (a file edited, missing or added
        since it was derived, a corrupt ``manifest.json``, another format): one line naming the file.
    fsmctl.symbolic.law.LawDefinitionError
        A script that does not import or breaks the law contract (both are :class:`~fsmctl.errors.InputError`).

    Examples
    --------
    >>> from fsmctl.model import resolve_law
    >>> law = resolve_law(None)
    >>> law.name, [p.name for p in law.parameters]
    ('fsm', ['c1', 'c2', 'alpha', 'boundary_layer', 'epsilon', 'singularity_fix', 'delta'])
    """
    if isinstance(law, LawCode):
        return law
    text = "fsm" if law is None else str(law)
    try:
        cwd = os.getcwd()
        return _resolve(text, cwd, _stamp(text, cwd))
    except GeneratedCodeError as exc:
        raise LawError(str(exc)) from exc
    except OSError as exc:
        raise LawError(f"law {text!r}: {exc}") from exc


def _cache_clear() -> None:
    """Forget every law read (the built-in ones too): the next :func:`resolve_law` reads the files again."""
    _resolve.cache_clear()
    _builtin_laws.cache_clear()


resolve_law.cache_clear = _cache_clear  # type: ignore[attr-defined]


def written_keys(law: LawCode) -> tuple[str, ...]:
    """The keys a scenario may write for ``law``: its parameters' names, then its preset groups' names.

    Parameters
    ----------
    law : LawCode
        The law.

    Returns
    -------
    tuple of str
        The names, in declaration order.

    Examples
    --------
    >>> from fsmctl.model import resolve_law
    >>> from fsmctl.model.laws import written_keys
    >>> written_keys(resolve_law("pid"))
    ('K', 'P', 'Ki', 'k_coupling')
    """
    return tuple(p.name for p in law.parameters) + tuple(g.name for g in law.presets)


def _check_written(law: LawCode, written, where: str, own: str, own_keys: Sequence[str]) -> None:
    unknown = [k for k in written if k not in written_keys(law)]
    if unknown:
        names = ", ".join(p.name for p in law.parameters) or "none"
        groups = "".join(f"; preset {g.name} = {' | '.join(g.options)}" for g in law.presets)
        hint = did_you_mean(unknown[0], (*written_keys(law), *own_keys))  # fsmctl.suggest: the one rule
        raise LawError(
            f"{where}.{unknown[0]}: unknown key: the law {law.name!r} has no parameter {unknown[0]!r}"
            f"{': ' + hint if hint else ''} (its parameters: {names}{groups}) and {own} {', '.join(own_keys)}"
        )


def carried_keys(old: LawCode, new: LawCode) -> tuple[str, ...]:
    """The keys written for ``old`` that carry over when ``new`` is flown instead: the same parameter in both.

    The same parameter is the same name with the same unit, number of components and options (a preset group: the
    same name and options).  A key of another meaning under the same name (a PD gain called ``epsilon`` in N m, where
    the paper's law has a band in MRP units) does not carry over; :meth:`fsmctl.model.scenario.Scenario.replace`
    drops it and says so.

    Parameters
    ----------
    old, new : LawCode
        The law the keys were written for and the law flown instead.

    Returns
    -------
    tuple of str
        The names, in ``new``'s declaration order.

    Examples
    --------
    >>> from fsmctl.model import resolve_law
    >>> from fsmctl.model.laws import carried_keys
    >>> carried_keys(resolve_law("fsm"), resolve_law("super_twisting"))
    ('c1', 'c2', 'alpha', 'epsilon', 'singularity_fix', 'surface')
    """
    mine = {p.name: (p.unit, p.size, p.choices) for p in old.parameters}
    groups = {g.name: tuple(g.options) for g in old.presets}
    return tuple(p.name for p in new.parameters if mine.get(p.name) == (p.unit, p.size, p.choices)) + tuple(
        g.name for g in new.presets if groups.get(g.name) == tuple(g.options)
    )


def check_written_parameters(law: LawCode, written, where: str = "controller") -> None:
    """Check a ``[controller]`` table's written law parameters against ``law``: keys, sizes, ranges, presets.

    The check of :func:`parameter_matrix` for the values every agent shares, run when a
    :class:`~fsmctl.model.scenario.ControllerSettings` is built (before any agent is known).

    Parameters
    ----------
    law : LawCode
        The law.
    written : mapping
        The written values by name.
    where : str
        The table's name in messages.

    Raises
    ------
    LawError
        A key the law does not declare, a value of the wrong size or outside its range, or an unknown preset.

    Examples
    --------
    >>> from fsmctl.model import resolve_law
    >>> from fsmctl.model.laws import check_written_parameters
    >>> try:
    ...     check_written_parameters(resolve_law("pid"), {"K": -1.0})
    ... except LawError as exc:
    ...     print(exc)
    controller.K: must be > 0, got -1
    """
    _check_written(law, written, where, "[controller]'s own keys are", CONTROLLER_KEYS)
    for p in law.parameters:
        if p.name in written:
            p.values(written[p.name], f"{where}.{p.name}")
    for group in law.presets:
        if group.name in written:
            _preset_option(group, written[group.name], f"{where}.{group.name}")


def _preset_option(group: LawPresetGroup, option: Any, where: str) -> Mapping[str, tuple[float, ...]]:
    """The packed values a written preset choice fixes (case-insensitive), or a :class:`LawError` naming the options."""
    key = option.lower() if isinstance(option, str) else option
    if key not in group.options:
        raise LawError(f"{where}: must be one of {', '.join(group.options)}, got {option!r}")
    return group.options[key]


def _preset_values(law: LawCode, controller, agent, where: str) -> dict[str, tuple[float, ...]]:
    """The packed values the selected presets fix (an agent's choice before ``[controller]``'s, else the default)."""
    out: dict[str, tuple[float, ...]] = {}
    for group in law.presets:
        if group.name in agent.parameters:
            option, at = agent.parameters[group.name], f"{where}.{group.name}"
        else:
            option, at = controller.parameters.get(group.name, group.default), f"controller.{group.name}"
        out.update(_preset_option(group, option, at))
    return out


def parameter_matrix(law: LawCode, scenario) -> np.ndarray:
    """The law's packed parameters for every agent, ``(n_agents, n_params)``: the one place they are resolved.

    The rule, for each agent and each parameter the law declares: the agent's own value (``[[agents]]``), else
    ``[controller]``'s, else **the law's declared default**; then the presets the scenario selects (a preset group
    such as the paper's ``surface``, declared by the law) fix their parameters.  Every value is checked against the
    declared range; a number given for a vector parameter sets every component.  A written key the law does not
    declare is an error naming the law and its parameters (:meth:`fsmctl.model.scenario.Scenario.replace` drops the
    keys of another law when the law is switched, and says which).

    Parameters
    ----------
    law : LawCode
        The law.
    scenario : Scenario
        The scenario whose ``[controller]`` and agents give the values.

    Returns
    -------
    numpy.ndarray
        ``(n_agents, law.n_params)``, one packed parameter vector per agent.

    Raises
    ------
    LawError
        A value outside its range, of the wrong size, an unknown preset, or a key the law does not declare.

    Examples
    --------
    Case 1 of the paper (Liang et al. 2012, Table 1): ``c1, c2, alpha, boundary_layer, epsilon, singularity_fix``
    then the agent's ``delta`` (3 components):

    >>> from fsmctl import paper_scenario
    >>> from fsmctl.model import parameter_matrix, resolve_law
    >>> P = parameter_matrix(resolve_law("fsm"), paper_scenario("1"))
    >>> P.shape, P[0, :3].tolist()
    ((6, 9), [0.6, 0.8, 0.7])

    The terminal sliding surface of Sec. 3.3 is the ``fsm`` law's preset ``surface = "tsm"`` (``c1 = 0``):

    >>> parameter_matrix(resolve_law("fsm"), paper_scenario("1").replace(controller={"surface": "tsm"}))[0, :2]
    array([0. , 0.8])
    """
    c = scenario.controller
    _check_written(law, c.parameters, "controller", "[controller]'s own keys are", CONTROLLER_KEYS)
    rows = []
    for index, agent in enumerate(scenario.agents, start=1):
        where = f"agents[{index}]"
        _check_written(law, agent.parameters, where, "an agent's own keys are", AGENT_KEYS)
        fixed = _preset_values(law, c, agent, where)
        row: list[float] = []
        for p in law.parameters:
            if p.name in fixed:
                row.extend(fixed[p.name])
            elif p.name in agent.parameters:
                row.extend(p.values(agent.parameters[p.name], f"{where}.{p.name}"))
            elif p.name in c.parameters:
                row.extend(p.values(c.parameters[p.name], f"controller.{p.name}"))
            else:
                row.extend(p.default)
        rows.append(row)
    return np.array(rows, dtype=float).reshape(len(scenario.agents), law.n_params)


def initial_law_states(law: LawCode) -> np.ndarray:
    """The law states' declared initial values, ``(n_states,)``.

    Parameters
    ----------
    law : LawCode
        The law.

    Returns
    -------
    numpy.ndarray
        The initial values, in the order of :meth:`LawCode.state_labels`.

    Examples
    --------
    >>> from fsmctl.model import resolve_law
    >>> from fsmctl.model.laws import initial_law_states
    >>> initial_law_states(resolve_law("pid"))
    array([0., 0., 0.])
    """
    return np.array([v for s in law.states for v in s["initial"]], dtype=float)
