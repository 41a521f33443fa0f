"""Typed, validated formation scenarios, loadable from TOML (Liang et al. 2012, Section 4).

A :class:`Scenario` fixes everything a run needs: the agents (nominal inertia
``J0``, perturbation ``delta_J``, initial attitude and rate, switching gain
``delta``, disturbance torque), the reference (``sigma_d(0)`` and a sinusoidal
``omega_d(t)``), the communication topology (:class:`~fsmctl.topology.Topology`),
the controller settings and the numerical settings.  Named *cases* are partial
overrides of the base scenario (the paper's Cases 1, 2, 3a-3c).

Every value is checked on construction; a malformed file raises
:class:`ScenarioError` with the key path of the offending entry, never a
traceback from deep inside NumPy.

Units: inertia kg m^2, angles rad, rates rad/s, torques N m, time s.
"""

from __future__ import annotations

import copy
import math
import tomllib
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from .topology import Topology, TopologyError

__all__ = [
    "ScenarioError",
    "InertiaWarning",
    "Sinusoid",
    "Agent",
    "Reference",
    "ControllerSettings",
    "SimulationSettings",
    "Scenario",
    "load_scenario",
    "paper_scenario",
    "scenario_from_dict",
    "BUILTIN_SCENARIOS",
]

BUILTIN_SCENARIOS = ("paper",)
SINGULARITY_FIXES = {"none": 0, "switch": 1, "clamp": 2}
ERROR_MODELS = ("paper", "exact")
SURFACES = ("fsm", "tsm", "lsm")
INTEGRATORS = ("rk4", "dopri45")


class ScenarioError(ValueError):
    """A scenario (file or object) is malformed; the message names the key path."""


class InertiaWarning(UserWarning):
    """An inertia matrix is positive definite but not physically realizable (J1 + J2 < J3)."""


# ----------------------------------------------------------------------------- helpers


def _vec3(value, where: str) -> tuple[float, float, float]:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ScenarioError(f"{where}: expected 3 numbers, got {value!r}") from None
    if a.shape != (3,):
        raise ScenarioError(f"{where}: expected 3 numbers, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ScenarioError(f"{where}: values must be finite, got {a.tolist()}")
    return tuple(float(x) for x in a)


def _mat3(value, where: str) -> tuple[tuple[float, ...], ...]:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ScenarioError(f"{where}: expected a 3x3 matrix, got {value!r}") from None
    if a.shape != (3, 3):
        raise ScenarioError(f"{where}: expected a 3x3 matrix, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ScenarioError(f"{where}: values must be finite")
    return tuple(tuple(float(x) for x in row) for row in a)


def _number(value, where: str, *, positive=False, nonnegative=False, allow_inf=False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        if isinstance(value, str) and allow_inf and value.strip().lower() in ("inf", "infinity", "none"):
            return math.inf
        raise ScenarioError(f"{where}: expected a number, got {value!r}")
    x = float(value)
    if math.isnan(x) or (math.isinf(x) and not allow_inf):
        raise ScenarioError(f"{where}: must be finite, got {x}")
    if positive and not x > 0:
        raise ScenarioError(f"{where}: must be > 0, got {x}")
    if nonnegative and not x >= 0:
        raise ScenarioError(f"{where}: must be >= 0, got {x}")
    return x


def _choice(value, options, where: str) -> str:
    if not isinstance(value, str) or value.lower() not in options:
        raise ScenarioError(f"{where}: must be one of {list(options)}, got {value!r}")
    return value.lower()


def _check_keys(d: Mapping, known: Sequence[str], where: str) -> None:
    if not isinstance(d, Mapping):
        raise ScenarioError(f"{where}: expected a table, got {type(d).__name__}")
    unknown = sorted(set(d) - set(known))
    if unknown:
        raise ScenarioError(f"{where}: unknown key(s) {unknown} (known: {sorted(known)})")


def check_inertia(J, where: str, *, physical: bool = True) -> None:
    """Raise :class:`ScenarioError` unless ``J`` is symmetric positive definite (and physically realizable)."""
    a = np.asarray(J, dtype=float)
    scale = max(1.0, float(np.max(np.abs(a))))
    if np.max(np.abs(a - a.T)) > 1e-9 * scale:
        i, j = np.unravel_index(np.argmax(np.abs(a - a.T)), a.shape)
        raise ScenarioError(f"{where}: not symmetric ({where}[{i}][{j}] = {a[i, j]}, {where}[{j}][{i}] = {a[j, i]})")
    eig = np.linalg.eigvalsh(0.5 * (a + a.T))
    if eig[0] <= 0:
        raise ScenarioError(f"{where}: not positive definite (eigenvalues {np.round(eig, 6).tolist()})")
    # A flat plate has J1 + J2 = J3; violations below 1e-3 relative are rounding of such bodies
    # (the paper's J0_4 is one: 1.9e-5) and are reported by `fsmctl reproduce`, not warned about.
    if physical and eig[0] + eig[1] < eig[2] * (1 - 1e-3):
        warnings.warn(
            f"{where}: principal moments {np.round(eig, 6).tolist()} violate the triangle inequality "
            f"J1 + J2 >= J3 of a rigid body by {eig[2] - eig[0] - eig[1]:.3g} kg m^2 (not physically realizable; "
            "simulated as given)",
            InertiaWarning,
            stacklevel=3,
        )


# ----------------------------------------------------------------------------- data classes


@dataclass(frozen=True)
class Sinusoid:
    """``v_k(t) = amplitude_k cos(frequency_k t + phase_k) + offset_k``, k = 1..3."""

    amplitude: tuple[float, float, float] = (0.0, 0.0, 0.0)
    frequency: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """rad/s"""
    phase: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """rad"""
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def params(self) -> np.ndarray:
        """Packed ``[amplitude, frequency, phase, offset]`` (the generated code's layout)."""
        return np.array([*self.amplitude, *self.frequency, *self.phase, *self.offset], dtype=float)

    def __call__(self, t) -> np.ndarray:
        """Values at time(s) ``t``: shape ``(..., 3)``.

        Evaluated by the generated ``disturbance_torque`` function (the same sinusoid layout), so the
        formula exists once, in ``derive/``.
        """
        from .casadi_eval import evaluate_mapped
        from .generated_code import casadi_function

        t = np.asarray(t, dtype=float)
        flat = t.reshape(-1)
        if flat.size == 0:
            return np.zeros((*t.shape, 3))
        (values,) = evaluate_mapped(
            casadi_function("disturbance_torque"), flat.size, [flat, self.params()], shared=(1,)
        )
        values = np.ascontiguousarray(values.T).T  # (m, 3) view of a (3, m) array, the layout callers always had
        return values.reshape(*t.shape, 3)

    def bound(self) -> np.ndarray:
        """Componentwise bound ``|amplitude| + |offset|`` on ``|v_k(t)|``."""
        return np.abs(self.amplitude) + np.abs(self.offset)

    def rate_bound(self) -> np.ndarray:
        """Componentwise bound ``|amplitude frequency|`` on ``|dv_k/dt|``."""
        return np.abs(np.asarray(self.amplitude) * np.asarray(self.frequency))

    @classmethod
    def from_mapping(cls, d: Mapping, where: str) -> Sinusoid:
        """From a table with ``amplitude``, ``frequency``, ``phase``, ``offset``, optional ``kind = ["cos"|"sin", ...]``.

        A ``sin`` component ``a sin(w t + p)`` is stored as ``a cos(w t + p - pi/2)``.
        """
        _check_keys(d, ("amplitude", "frequency", "phase", "offset", "kind"), where)
        zero = (0.0, 0.0, 0.0)
        amp = _vec3(d.get("amplitude", zero), f"{where}.amplitude")
        freq = _vec3(d.get("frequency", zero), f"{where}.frequency")
        phase = list(_vec3(d.get("phase", zero), f"{where}.phase"))
        off = _vec3(d.get("offset", zero), f"{where}.offset")
        kind = d.get("kind", ["cos", "cos", "cos"])
        if not isinstance(kind, Sequence) or isinstance(kind, str) or len(kind) != 3:
            raise ScenarioError(f"{where}.kind: expected three of 'cos'/'sin', got {kind!r}")
        for k, kd in enumerate(kind):
            if _choice(kd, ("cos", "sin"), f"{where}.kind[{k}]") == "sin":
                phase[k] -= math.pi / 2
        return cls(amp, freq, tuple(phase), off)


@dataclass(frozen=True)
class Agent:
    """One spacecraft: inertia, initial state, switching gain and disturbance."""

    J0: tuple[tuple[float, ...], ...]
    """nominal inertia (kg m^2), used by the controller"""
    delta_J: tuple[tuple[float, ...], ...]
    """inertia perturbation: the plant has J = J0 + delta_J (eq 29)"""
    sigma0: tuple[float, float, float]
    omega0: tuple[float, float, float]
    """rad/s, body frame"""
    delta: tuple[float, float, float]
    """switching gain delta_i of eq 18 (1/s^2)"""
    disturbance: Sinusoid = field(default_factory=Sinusoid)
    """disturbance torque d_i(t) (N m)"""

    @property
    def J0_array(self) -> np.ndarray:
        return np.array(self.J0)

    @property
    def J_true(self) -> np.ndarray:
        return np.array(self.J0) + np.array(self.delta_J)


@dataclass(frozen=True)
class Reference:
    """Reference attitude ``sigma_d(0)`` and rate ``omega_d(t)`` (Sec. 4)."""

    sigma0: tuple[float, float, float]
    omega: Sinusoid


@dataclass(frozen=True)
class ControllerSettings:
    """Gains and numerical devices of the FSM law (eqs 13-19, Remarks 6-7)."""

    c1: float
    c2: float
    alpha: float
    boundary_layer: float = 0.0
    """phi of sat(s/phi) (Remark 7); 0 means sgn"""
    singularity_fix: str = "switch"
    """Remark 6: 'switch', 'clamp' or 'none'"""
    epsilon: float = 1e-4
    """band of the Remark 6 fix (MRP units)"""
    torque_limit: float = math.inf
    """per-component torque bound (N m)"""
    error_model: str = "paper"
    """controller's error kinematics: 'paper' (eqs 7-8) or 'exact'"""
    surface: str = "fsm"
    """'fsm' (eq 13), 'tsm' (c1 -> 0) or 'lsm' (c2 -> 0), Sec. 3.3"""
    enabled: bool = True
    """False: the torque is not applied (u = 0, open loop): the law is still evaluated and its command is
    reported as ``u_unsaturated``; for torque-free (``J omega_dot = -omega^x J omega + d``) and
    disturbance-only runs, e.g. the conservation checks of the plant"""

    @property
    def effective_torque_limit(self) -> float:
        """Per-component bound the plant sees: ``torque_limit``, or 0 when the controller is disabled."""
        return self.torque_limit if self.enabled else 0.0

    def gains_vector(self) -> np.ndarray:
        """``[c1, c2, alpha, boundary_layer, epsilon, fix_mode]`` with the surface applied."""
        c1 = 0.0 if self.surface == "tsm" else self.c1
        c2 = 0.0 if self.surface == "lsm" else self.c2
        return np.array(
            [c1, c2, self.alpha, self.boundary_layer, self.epsilon, SINGULARITY_FIXES[self.singularity_fix]], float
        )


@dataclass(frozen=True)
class SimulationSettings:
    """Horizon, integrator, step and output grid."""

    t_final: float = 100.0
    dt: float = 1e-3
    integrator: str = "rk4"
    """'rk4' (fixed step, default: sgn defeats adaptive steps) or 'dopri45' (adaptive)"""
    output_interval: float = 0.01
    control_period: float = 0.0
    """0: continuous control; > 0: zero-order hold with this period"""
    rtol: float = 1e-8
    atol: float = 1e-10

    @property
    def n_steps(self) -> int:
        return round(self.t_final / self.dt)

    @property
    def output_every(self) -> int:
        return max(1, round(self.output_interval / self.dt))

    @property
    def hold_steps(self) -> int:
        return round(self.control_period / self.dt) if self.control_period > 0 else 0


@dataclass(frozen=True)
class Scenario:
    """A complete formation scenario (one case)."""

    name: str
    agents: tuple[Agent, ...]
    reference: Reference
    topology: Topology
    controller: ControllerSettings
    simulation: SimulationSettings
    case: str | None = None
    description: str = ""
    choices: tuple[tuple[str, str], ...] = ()
    """what the source leaves open, and why each value was chosen (printed with every result)"""
    cases: tuple[str, ...] = ()
    """names of the cases defined by the source file"""
    source: dict = field(default_factory=dict, compare=False, repr=False)
    """the merged raw mapping this scenario was built from"""

    def __post_init__(self):
        validate(self)

    @property
    def n_agents(self) -> int:
        return len(self.agents)

    @property
    def label(self) -> str:
        return f"{self.name}" + (f" case {self.case}" if self.case else "")

    def with_case(self, case: str) -> Scenario:
        """The scenario with the named case's overrides applied to the base."""
        if case not in self.cases:
            raise ScenarioError(f"scenario {self.name!r} has no case {case!r} (cases: {list(self.cases)})")
        return scenario_from_dict(self.source, case=case)

    def replace(self, **sections: Mapping[str, Any]) -> Scenario:
        """A validated copy with fields of ``controller``, ``simulation`` or ``reference`` replaced.

        Example: ``scenario.replace(controller={"boundary_layer": 0.0}, simulation={"t_final": 10})``.
        """
        changes = {}
        for section, values in sections.items():
            if section not in ("controller", "simulation", "reference"):
                raise ScenarioError(f"replace: cannot replace section {section!r}")
            current = getattr(self, section)
            try:
                changes[section] = replace(current, **dict(values))
            except TypeError as exc:
                raise ScenarioError(f"replace({section}=...): {exc}") from None
        return replace(self, **changes)

    def with_agents(self, agents: Sequence[Agent]) -> Scenario:
        return replace(self, agents=tuple(agents))

    def with_topology(self, topology: Topology) -> Scenario:
        return replace(self, topology=topology)

    def describe(self) -> list[str]:
        """Human-readable lines: settings and the documented choices."""
        c, s = self.controller, self.simulation
        lines = [
            f"scenario {self.label}: {self.n_agents} agents, {len(self.topology.links)} links",
            f"  controller: surface={c.surface} c1={c.c1} c2={c.c2} alpha={c.alpha} boundary_layer={c.boundary_layer} "
            f"singularity_fix={c.singularity_fix} epsilon={c.epsilon} torque_limit={c.torque_limit} "
            f"error_model={c.error_model}" + ("" if c.enabled else " enabled=False (open loop, u = 0)"),
            f"  delta_i: {sorted({a.delta for a in self.agents})}",
            f"  simulation: t_final={s.t_final} s, dt={s.dt} s, integrator={s.integrator}, "
            f"output_interval={s.output_interval} s, control_period={s.control_period} s",
        ]
        lines += [f"  choice {k}: {v}" for k, v in self.choices]
        return lines


def validate(s: Scenario) -> None:
    """Cross-field checks of a :class:`Scenario`; raises :class:`ScenarioError`."""
    if not s.agents:
        raise ScenarioError("agents: at least one agent is required")
    if s.topology.n_agents != len(s.agents):
        raise ScenarioError(f"topology: describes {s.topology.n_agents} agents but the scenario has {len(s.agents)}")
    for i, a in enumerate(s.agents):
        w = f"agents[{i + 1}]"
        check_inertia(a.J0, f"{w}.J0")
        check_inertia(a.J_true, f"{w}.J0 + delta_J")
        _vec3(a.sigma0, f"{w}.sigma0")
        _vec3(a.omega0, f"{w}.omega0")
        if not all(d > 0 and math.isfinite(d) for d in a.delta):
            raise ScenarioError(f"{w}.delta: every component must be > 0 (eq 18), got {list(a.delta)}")
    c = s.controller
    _choice(c.surface, SURFACES, "controller.surface")
    _choice(c.error_model, ERROR_MODELS, "controller.error_model")
    _choice(c.singularity_fix, tuple(SINGULARITY_FIXES), "controller.singularity_fix")
    if c.surface in ("fsm", "lsm") and not c.c1 > 0:
        raise ScenarioError(f"controller.c1: must be > 0 for the {c.surface} surface, got {c.c1}")
    if c.surface in ("fsm", "tsm") and not c.c2 > 0:
        raise ScenarioError(f"controller.c2: must be > 0 for the {c.surface} surface, got {c.c2}")
    if not (0.5 < c.alpha < 1):
        raise ScenarioError(f"controller.alpha: must satisfy 0.5 < alpha < 1 (eq 13), got {c.alpha}")
    if not c.boundary_layer >= 0 or not math.isfinite(c.boundary_layer):
        raise ScenarioError(f"controller.boundary_layer: must be >= 0 (0 = sgn), got {c.boundary_layer}")
    if not c.epsilon > 0:
        raise ScenarioError(f"controller.epsilon: must be > 0, got {c.epsilon}")
    if not c.torque_limit > 0:
        raise ScenarioError(f"controller.torque_limit: must be > 0 (or inf), got {c.torque_limit}")
    if not isinstance(c.enabled, (bool, np.bool_)):
        raise ScenarioError(f"controller.enabled: expected true or false, got {c.enabled!r}")
    m = s.simulation
    _choice(m.integrator, INTEGRATORS, "simulation.integrator")
    for name in ("t_final", "dt", "output_interval", "rtol", "atol"):
        if not getattr(m, name) > 0 or not math.isfinite(getattr(m, name)):
            raise ScenarioError(f"simulation.{name}: must be > 0, got {getattr(m, name)}")
    if m.dt > m.t_final:
        raise ScenarioError(f"simulation.dt = {m.dt} exceeds t_final = {m.t_final}")
    for name in ("t_final", "output_interval") + (("control_period",) if m.control_period > 0 else ()):
        ratio = getattr(m, name) / m.dt
        if abs(ratio - round(ratio)) > 1e-9 * max(1.0, ratio):  # float rounding only (0.1 / 0.001 = 99.999...)
            raise ScenarioError(f"simulation.{name} = {getattr(m, name)} must be a multiple of dt = {m.dt}")
    if m.control_period < 0:
        raise ScenarioError(f"simulation.control_period: must be >= 0, got {m.control_period}")
    _vec3(s.reference.sigma0, "reference.sigma0")


# ----------------------------------------------------------------------------- parsing


def _deep_merge(base: dict, over: Mapping) -> dict:
    out = copy.deepcopy(base)
    for k, v in over.items():
        if isinstance(v, Mapping) and isinstance(out.get(k), Mapping):
            out[k] = _deep_merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


TOP_KEYS = ("name", "description", "simulation", "controller", "reference", "agents", "topology", "cases", "choices")


def _parse_agent(d: Mapping, i: int, defaults: Mapping) -> Agent:
    w = f"agents[{i + 1}]"
    _check_keys(d, ("J0", "delta_J", "sigma0", "omega0", "delta", "disturbance"), w)
    for key in ("J0", "sigma0", "omega0"):
        if key not in d:
            raise ScenarioError(f"{w}.{key}: missing")
    J0 = _mat3(d["J0"], f"{w}.J0")
    dJ_spec = d.get("delta_J", defaults.get("delta_J", {"scale": 0.0}))
    if isinstance(dJ_spec, Mapping):
        _check_keys(dJ_spec, ("scale",), f"{w}.delta_J")
        scale = _number(dJ_spec.get("scale", 0.0), f"{w}.delta_J.scale")
        delta_J = tuple(tuple(scale * x for x in row) for row in J0)
    else:
        delta_J = _mat3(dJ_spec, f"{w}.delta_J")
    delta = d.get("delta", defaults.get("delta"))
    if delta is None:
        raise ScenarioError(f"{w}.delta: missing (set controller.delta for all agents or delta per agent)")
    if isinstance(delta, (int, float)) and not isinstance(delta, bool):
        delta = [delta] * 3
    delta = _vec3(delta, f"{w}.delta")
    dist = d.get("disturbance", defaults.get("disturbance"))
    disturbance = Sinusoid() if dist is None else Sinusoid.from_mapping(dist, f"{w}.disturbance")
    return Agent(
        J0=J0,
        delta_J=delta_J,
        sigma0=_vec3(d["sigma0"], f"{w}.sigma0"),
        omega0=_vec3(d["omega0"], f"{w}.omega0"),
        delta=delta,
        disturbance=disturbance,
    )


def _parse_controller(d: Mapping) -> tuple[ControllerSettings, dict]:
    w = "controller"
    known = (
        "c1",
        "c2",
        "alpha",
        "boundary_layer",
        "singularity_fix",
        "epsilon",
        "torque_limit",
        "error_model",
        "surface",
        "enabled",
        "delta",
        "delta_J",
        "disturbance",
    )
    _check_keys(d, known, w)
    for key in ("c1", "c2", "alpha"):
        if key not in d:
            raise ScenarioError(f"{w}.{key}: missing")
    settings = ControllerSettings(
        c1=_number(d["c1"], f"{w}.c1", nonnegative=True),
        c2=_number(d["c2"], f"{w}.c2", nonnegative=True),
        alpha=_number(d["alpha"], f"{w}.alpha"),
        boundary_layer=_number(d.get("boundary_layer", 0.0), f"{w}.boundary_layer", nonnegative=True),
        singularity_fix=_choice(d.get("singularity_fix", "switch"), tuple(SINGULARITY_FIXES), f"{w}.singularity_fix"),
        epsilon=_number(d.get("epsilon", 1e-4), f"{w}.epsilon", positive=True),
        torque_limit=_number(d.get("torque_limit", math.inf), f"{w}.torque_limit", positive=True, allow_inf=True),
        error_model=_choice(d.get("error_model", "paper"), ERROR_MODELS, f"{w}.error_model"),
        surface=_choice(d.get("surface", "fsm"), SURFACES, f"{w}.surface"),
        enabled=d.get("enabled", True),
    )
    agent_defaults = {k: d[k] for k in ("delta", "delta_J", "disturbance") if k in d}
    return settings, agent_defaults


def _parse_simulation(d: Mapping) -> SimulationSettings:
    w = "simulation"
    _check_keys(d, ("t_final", "dt", "integrator", "output_interval", "control_period", "rtol", "atol"), w)
    base = SimulationSettings()
    return SimulationSettings(
        t_final=_number(d.get("t_final", base.t_final), f"{w}.t_final", positive=True),
        dt=_number(d.get("dt", base.dt), f"{w}.dt", positive=True),
        integrator=_choice(d.get("integrator", base.integrator), INTEGRATORS, f"{w}.integrator"),
        output_interval=_number(d.get("output_interval", base.output_interval), f"{w}.output_interval", positive=True),
        control_period=_number(d.get("control_period", 0.0), f"{w}.control_period", nonnegative=True),
        rtol=_number(d.get("rtol", base.rtol), f"{w}.rtol", positive=True),
        atol=_number(d.get("atol", base.atol), f"{w}.atol", positive=True),
    )


def scenario_from_dict(data: Mapping, case: str | None = None, *, where: str = "scenario") -> Scenario:
    """Build a validated :class:`Scenario` from a mapping (a parsed TOML file), optionally applying a case."""
    _check_keys(data, TOP_KEYS, where)
    cases = data.get("cases", {})
    if not isinstance(cases, Mapping):
        raise ScenarioError(f"{where}.cases: expected a table of named cases")
    merged = dict(data)
    if case is not None:
        case = str(case)
        if case not in cases:
            raise ScenarioError(f"{where}: no case {case!r} (cases: {list(cases)})")
        override = cases[case]
        if not isinstance(override, Mapping):
            raise ScenarioError(f"{where}.cases.{case}: expected a table")
        override = {k: v for k, v in override.items() if k != "description"}
        _check_keys(override, TOP_KEYS, f"{where}.cases.{case}")
        if "agents" in override:
            raise ScenarioError(
                f"{where}.cases.{case}: cases cannot replace the agent list (override controller.* instead)"
            )
        merged = _deep_merge(merged, override)
    for key in ("controller", "reference", "agents", "topology"):
        if key not in merged:
            raise ScenarioError(f"{where}.{key}: missing")
    controller, agent_defaults = _parse_controller(merged["controller"])
    simulation = _parse_simulation(merged.get("simulation", {}))
    ref = merged["reference"]
    _check_keys(ref, ("sigma0", "omega"), "reference")
    if "sigma0" not in ref or "omega" not in ref:
        raise ScenarioError("reference: needs sigma0 and omega")
    reference = Reference(
        _vec3(ref["sigma0"], "reference.sigma0"), Sinusoid.from_mapping(ref["omega"], "reference.omega")
    )
    agents_raw = merged["agents"]
    if not isinstance(agents_raw, Sequence) or isinstance(agents_raw, (str, bytes)) or not agents_raw:
        raise ScenarioError("agents: expected a non-empty array of tables ([[agents]])")
    agents = tuple(_parse_agent(a, i, agent_defaults) for i, a in enumerate(agents_raw))
    try:
        topology = Topology.from_mapping(merged["topology"], len(agents), where="topology")
    except TopologyError as exc:
        raise ScenarioError(str(exc)) from None
    choices = merged.get("choices", {})
    if not isinstance(choices, Mapping) or not all(isinstance(v, str) for v in choices.values()):
        raise ScenarioError("choices: expected a table of strings")
    name = merged.get("name", "scenario")
    if not isinstance(name, str):
        raise ScenarioError("name: expected a string")
    description = merged.get("description", "")
    if case is not None and isinstance(cases[case], Mapping) and "description" in cases[case]:
        description = f"{description} / case {case}: {cases[case]['description']}".strip(" /")
    return Scenario(
        name=name,
        agents=agents,
        reference=reference,
        topology=topology,
        controller=controller,
        simulation=simulation,
        case=case,
        description=str(description),
        choices=tuple((str(k), v) for k, v in choices.items()),
        cases=tuple(str(k) for k in cases),
        source=dict(data),
    )


def _read_toml(path: Path) -> dict:
    try:
        text = path.read_text()
    except OSError as exc:
        raise ScenarioError(f"cannot read scenario file {path}: {exc.strerror or exc}") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: not valid TOML ({exc})") from None


def load_scenario(source: str | Path = "paper", case: str | None = None) -> Scenario:
    """Load a built-in scenario by name (``"paper"``) or a TOML file, optionally selecting a case.

    Without ``case`` a file that defines cases gets its first one (for the paper: Case 1).
    """
    if isinstance(source, str) and source in BUILTIN_SCENARIOS:
        data = tomllib.loads(resources.files("fsmctl").joinpath("scenarios", f"{source}.toml").read_text())
        where = f"built-in scenario {source!r}"
    else:
        path = Path(source)
        data = _read_toml(path)
        where = str(path)
    if case is None and isinstance(data.get("cases"), Mapping) and data["cases"]:
        case = next(iter(data["cases"]))
    try:
        return scenario_from_dict(data, case=case, where=where)
    except ScenarioError as exc:
        msg = str(exc)
        raise ScenarioError(msg if msg.startswith(where) else f"{where}: {msg}") from None


def paper_scenario(case: str = "1") -> Scenario:
    """The built-in Section 4 scenario (Liang et al. 2012) for Case ``"1"``, ``"2"``, ``"3a"``, ``"3b"`` or ``"3c"``."""
    return load_scenario("paper", case=str(case))
