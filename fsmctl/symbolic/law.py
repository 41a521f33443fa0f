"""Write a control law once, in SymPy: the public API of derivation scripts.

A *law* is what one spacecraft of the formation computes.  fsmctl's engine (the compiled whole-loop
simulator, its no-compiler fallback and the python-control plug-in) flies any law through one fixed
per-agent contract, and aggregates the neighbours over the time-varying topology itself:

1. ``law_constants(params) -> constants``: once per agent and run (e.g. ``epsilon^(alpha-1)``);
2. ``law_local_<model>(t, sigma, omega, z, sigma_d, omega_d, omega_d_dot, J0, params, constants)
   -> (broadcast, cache)``: what the agent sends to its neighbours, and the intermediate results the
   torque needs (the *local stages*);
3. ``law_control_<model>(t, sigma, omega, z, sigma_d, omega_d, omega_d_dot, J0, params, constants, cache,
   k_sum, received, k_received_sum, u_max) -> (u, u_commanded, z_dot)``: the commanded body torque, the
   torque the ideal actuator applies (``min(u_max, max(-u_max, u_commanded))`` per axis,
   :func:`fsmctl.symbolic.controller.saturate`) and the derivative of the law's own states ``z``, given
   what the agent received.

What the agent receives (Liang et al. 2012, eq 19, for any broadcast ``b``), computed by the engine:
``received = sum_j k^j_ij(t) b_j`` over the links ``j -> i`` active at ``t``, ``k_sum = sum_j k^i_ij`` and
``k_received_sum = sum_j k^j_ij(t)``; so ``k_sum b_i - received`` is the paper's coordination term and
``k_received_sum b_i - received`` the usual consensus term ``sum_j a_ij(t) (b_i - b_j)``.
``<model>`` is ``paper`` or ``exact``: the error kinematics (eqs 7-8 as printed, or exact), chosen per run.

A derivation script is a Python file that defines ``law(error_model) -> Law``, built with
:class:`LawBuilder`::

    import sympy as sp
    from fsmctl.symbolic.law import LawBuilder

    def law(error_model):
        b = LawBuilder("pd", error_model, doc="MRP PD with consensus on the attitude error")
        K = b.parameter("K", 1.0, unit="N m", minimum=0.0, doc="attitude gain")
        P = b.parameter("P", 10.0, unit="N m s", minimum=0.0, doc="rate gain")
        e = b.error_state()                      # sigma_e, omega_e, omega_r, omega_r_dot (stages)
        b.broadcast("sigma_e", e.sigma_e)        # the neighbours receive sum_j k^j_ij sigma_e_j
        u = -K * e.sigma_e - P * e.omega_e - K * (b.k_sum * e.sigma_e - b.received)
        b.torque(u)
        return b.build()

``fsmctl derive FILE.py`` checks and generates it; ``fsmctl simulate --law FILE.py`` flies it.

Pure SymPy: no NumPy, no I/O.

Size: one public API, the :class:`LawBuilder` a derivation script writes against and the :class:`Law` it
builds: every declaration (parameters, states, broadcast, presets, paper theorems, loop rates) is a method of
the builder and is validated against the others when the law is built.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import sympy as sp

from fsmctl.ranges import ParameterRange
from fsmctl.symbolic.controller import saturate
from fsmctl.symbolic.functions import FunctionSpec
from fsmctl.symbolic.model import ErrorModel, reference_acceleration_in_body, reference_rate_in_body
from fsmctl.symbolic.mrp import mrp_error
from fsmctl.symbolic.symbols import DerivationInputError, symmetric_matrix_symbols, vector_symbols

__all__ = [
    "AGENT_INPUTS",
    "NEIGHBOUR_INPUTS",
    "PAPER_THEOREM_ROLES",
    "SHARED_CONTROLLER_KEYS",
    "Discontinuity",
    "ErrorState",
    "Law",
    "LawBuilder",
    "LawDefinitionError",
    "LawParameter",
    "LawState",
    "LawVariants",
    "LoopRates",
    "Lyapunov",
    "PaperTheorems",
    "PresetGroup",
    "WHEEL_INPUTS",
    "WheelInputs",
    "Trigger",
    "contract_names",
    "law_variants",
    "wheels_function_name",
]

AGENT_INPUTS: tuple[str, ...] = (
    "t",
    "sigma",
    "omega",
    "z",
    "sigma_d",
    "omega_d",
    "omega_d_dot",
    "J0",
    "params",
    "constants",
)
"""Inputs of ``law_local_*`` (and the first inputs of ``law_control_*``), in order."""
NEIGHBOUR_INPUTS: tuple[str, ...] = ("cache", "k_sum", "received", "k_received_sum", "u_max")
"""The further inputs of ``law_control_*``, in order."""
WHEEL_INPUTS: tuple[str, ...] = ("spin_axes", "wheel_speed", "spin_inertia")
"""The last inputs of ``law_wheels_*`` (after those of ``law_control_*``), in order: the ``3 x N`` spin axes (body
frame, column ``k`` the unit axis ``g_k``), the ``N`` wheel speeds relative to the hub (rad/s) and the ``N`` spin
inertias (kg m^2); see :meth:`LawBuilder.reaction_wheels`."""

SHARED_CONTROLLER_KEYS: tuple[str, ...] = ("law", "parameters", "torque_limit", "error_model", "enabled")
"""The ``[controller]`` keys every law shares: no parameter or preset group of a law may take these names."""
PAPER_THEOREM_ROLES: tuple[str, ...] = (
    "c1",
    "c2",
    "alpha",
    "boundary_layer",
    "epsilon",
    "singularity_fix",
    "delta",
)
"""The symbols of Liang et al. 2012, eqs 13-19, that :meth:`LawBuilder.paper_theorems` maps to a law's parameters."""

TRIGGER_FUNCTION = "law_trigger"
"""The generated function of :meth:`LawBuilder.trigger`:
``law_trigger(t, broadcast, broadcast_sent, params, constants) -> margin`` (the agent sends when ``margin > 0``)."""

LOOP_RATES_FUNCTION = "law_loop_rates"
"""The generated function of :meth:`LawBuilder.loop_rates`: ``law_loop_rates(params) -> (surface, layer)``."""

_U_MAX = sp.Symbol("u_max", real=True)
_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
_RESERVED = (
    set(AGENT_INPUTS)
    | set(NEIGHBOUR_INPUTS)
    | set(WHEEL_INPUTS)
    | {"u", "u_commanded", "z_dot", "broadcast", "u_wheels"}
)


class LawDefinitionError(DerivationInputError):
    """A derivation script builds a law that breaks the contract (one line, names what is wrong).

    An :class:`~fsmctl.errors.InputError`: ``fsmctl derive`` and ``fsmctl prove --law`` exit with code 2 on it.

    Examples
    --------
    >>> from fsmctl.symbolic import LawBuilder, LawDefinitionError
    >>> b = LawBuilder("pd", doc="no torque yet")
    >>> try:
    ...     b.build()
    ... except LawDefinitionError as exc:
    ...     print(exc)
    pd: no broadcast declared (what the agent sends to its neighbours)
    """


def contract_names(error_model: ErrorModel | str) -> tuple[str, str]:
    """Names of the generated ``(local, control)`` functions for an error model."""
    m = ErrorModel(error_model).value
    return f"law_local_{m}", f"law_control_{m}"


def wheels_function_name(error_model: ErrorModel | str) -> str:
    """Name of the generated per-wheel command function of a law that commands its wheels, for an error model.

    Parameters
    ----------
    error_model : ErrorModel or str
        ``"paper"`` or ``"exact"``.

    Returns
    -------
    str
        ``law_wheels_<model>`` (see :meth:`LawBuilder.wheel_torques`).

    Examples
    --------
    >>> from fsmctl.symbolic.law import wheels_function_name
    >>> wheels_function_name("exact")
    'law_wheels_exact'
    """
    return f"law_wheels_{ErrorModel(error_model).value}"


@dataclass(frozen=True)
class WheelInputs:
    """What a law that commands its reaction wheels knows about them, from :meth:`LawBuilder.reaction_wheels`.

    Inputs of the generated ``law_wheels_<model>`` only (the body torque of :meth:`LawBuilder.torque` cannot read
    them: an ideal actuator flies it without wheels).

    Parameters
    ----------
    n : int
        The number of wheels ``N``; a scenario that flies the law must have as many.
    spin_axes : sympy.ImmutableMatrix
        ``3 x N``: column ``k`` is the unit spin axis ``g_k`` of wheel ``k`` in the body frame.
    speed : sympy.ImmutableMatrix
        ``N x 1``: the wheel speeds ``Omega_k`` relative to the hub (rad/s).
    spin_inertia : sympy.ImmutableMatrix
        ``N x 1``: the spin inertias ``J_s,k`` (kg m^2).

    Examples
    --------
    >>> from fsmctl.symbolic import LawBuilder
    >>> w = LawBuilder("rw", doc="example").reaction_wheels(4)
    >>> w.n, w.spin_axes.shape, w.speed.T
    (4, (3, 4), Matrix([[wheel_speed[0], wheel_speed[1], wheel_speed[2], wheel_speed[3]]]))
    >>> w.momentum[0]
    spin_axes[0, 0]*spin_inertia[0]*wheel_speed[0] + spin_axes[0, 1]*spin_inertia[1]*wheel_speed[1] + spin_axes[0, 2]*spin_inertia[2]*wheel_speed[2] + spin_axes[0, 3]*spin_inertia[3]*wheel_speed[3]
    """

    n: int
    spin_axes: sp.ImmutableMatrix
    speed: sp.ImmutableMatrix
    spin_inertia: sp.ImmutableMatrix

    @property
    def momentum(self) -> sp.ImmutableMatrix:
        """The wheels' spin momentum relative to the hub in the body frame, ``sum_k J_s,k Omega_k g_k`` (N m s)."""
        return sp.ImmutableMatrix(self.spin_axes * sp.matrix_multiply_elementwise(self.spin_inertia, self.speed))

    @property
    def symbols(self) -> dict[str, sp.ImmutableMatrix]:
        """The inputs by name (:data:`WHEEL_INPUTS`)."""
        return dict(zip(WHEEL_INPUTS, (self.spin_axes, self.speed, self.spin_inertia), strict=True))


@dataclass(frozen=True)
class LawParameter(ParameterRange):
    """A named parameter of a law: its default, unit, admissible range and meaning.

    ``choices`` makes it an option: the scenario gives one of the strings, the generated code receives
    its index (``choices[k] -> k``).  ``size > 1`` makes it a vector (e.g. ``delta``, 3 components).
    """

    name: str
    default: tuple[float, ...]
    unit: str = "1"
    minimum: float | None = None
    maximum: float | None = None
    exclusive_minimum: bool = False
    exclusive_maximum: bool = False
    doc: str = ""
    choices: tuple[str, ...] = ()
    tunable: bool = True

    def to_dict(self) -> dict:
        """The parameter as a JSON-able dict, as written to ``law.json``."""
        return {
            "name": self.name,
            "default": list(self.default) if self.size > 1 else self.default[0],
            "size": self.size,
            "unit": self.unit,
            "minimum": self.minimum,
            "maximum": self.maximum,
            "exclusive_minimum": self.exclusive_minimum,
            "exclusive_maximum": self.exclusive_maximum,
            "choices": list(self.choices),
            "tunable": self.tunable,
            "doc": self.doc,
        }


@dataclass(frozen=True)
class LawState:
    """A state of the law (integral term, adaptive gain, observer), integrated together with the plant."""

    name: str
    initial: tuple[float, ...]
    unit: str = ""
    doc: str = ""

    @property
    def size(self) -> int:
        """Number of components."""
        return len(self.initial)

    def to_dict(self) -> dict:
        """The state as a JSON-able dict (``name``, ``size``, ``initial``, ``unit``, ``doc``), as in ``law.json``."""
        return {"name": self.name, "size": self.size, "initial": list(self.initial), "unit": self.unit, "doc": self.doc}


@dataclass(frozen=True)
class Lyapunov:
    """A Lyapunov candidate declared by a law, for ``fsmctl prove --law``.

    ``V`` is written in the agent's symbols (``sigma``, ``omega``, ``z``, the parameters, ``J0``);
    the proof check evaluates its derivative along the isolated agent's closed loop (``J = J0``, no
    disturbance, no neighbours, the reference at rest, so ``sigma_e = sigma`` and ``omega_e = omega``).
    ``claimed_derivative``, if given, is what ``V_dot`` should simplify to (e.g. ``-omega^T P omega``); it
    must be manifestly non-positive for the check to call it a proof.  ``region`` bounds the numeric
    evidence when no symbolic proof is found: ``{"sigma": 1.0, "omega": 0.5, "z": 1.0}`` (norm bounds).
    """

    V: sp.Expr
    claimed_derivative: sp.Expr | None = None
    region: tuple[tuple[str, float], ...] = (("sigma", 1.0), ("omega", 0.5), ("z", 1.0))
    doc: str = ""


@dataclass(frozen=True)
class Discontinuity:
    """Where a law's closed-loop right-hand side is discontinuous, declared with :meth:`LawBuilder.discontinuous`.

    Parameters
    ----------
    where : str
        In words (e.g. ``"sgn(s) of the switching term u^D (eq 18)"``).
    smoothed_by : str or None
        The scalar parameter that removes the discontinuity when it is > 0 (e.g. the boundary layer ``phi`` of
        ``sat(s/phi)``, Remark 7); None when no parameter does.
    """

    where: str
    smoothed_by: str | None = None


@dataclass(frozen=True)
class PresetGroup:
    """A named group of parameter presets, declared with :meth:`LawBuilder.preset_group`.

    A scenario selects one option with one ``[controller]`` key named like the group.

    Parameters
    ----------
    name : str
        The group's name (the ``[controller]`` key).
    default : str
        The option that applies when the scenario names none (it changes no parameter's default).
    options : tuple of (str, tuple of (str, tuple of float))
        Each option's name and the packed values it gives to parameters, by name.
    doc : str
        What the group chooses.
    """

    name: str
    default: str
    options: tuple[tuple[str, tuple[tuple[str, tuple[float, ...]], ...]], ...]
    doc: str = ""

    def to_dict(self) -> dict:
        """The group as a JSON-able dict, as written to ``law.json``."""
        return {
            "name": self.name,
            "default": self.default,
            "doc": self.doc,
            "options": {option: {name: list(values) for name, values in sets} for option, sets in self.options},
        }


@dataclass(frozen=True)
class LoopRates:
    """Bounds on the closed loop's fastest rates (1/s) in the law's parameters, from :meth:`LawBuilder.loop_rates`.

    Generated as ``law_loop_rates(params) -> (surface, layer)``; ``fsmctl.simulation.step_size_report`` evaluates
    it per agent and takes the largest value.

    Parameters
    ----------
    surface : sympy.Expr
        The rate at which the error decays on the law's surface (or the law's own loop rate).
    layer : sympy.Expr
        The further rate of the switching term where it is linear (e.g. ``delta/phi`` inside a boundary layer).
    doc : str
        How the bounds are obtained (the report names them).
    """

    surface: sp.Expr
    layer: sp.Expr
    doc: str = ""


@dataclass(frozen=True)
class Trigger:
    """When an agent sends its broadcast (event-triggered communication), from :meth:`LawBuilder.trigger`.

    Generated as ``law_trigger(t, broadcast, broadcast_sent, params, constants) -> margin`` with
    ``margin = lhs - rhs`` of the declared ``lhs > rhs``: at each check instant the agent sends (and its neighbours
    then hold the value it sent) when ``margin > 0``.

    Parameters
    ----------
    margin : sympy.Expr
        ``lhs - rhs``, in ``t``, the broadcast symbols ``broadcast[k]``, the last sent value ``broadcast_sent[k]``,
        the parameters and the constants.
    condition : str
        The declared condition, as text (``law.json`` and ``fsmctl laws`` show it).
    period : float or None
        Seconds between checks (a multiple of the run's control period), or None: at every control instant.
    doc : str
        What the rule is (a citation).
    """

    margin: sp.Expr
    condition: str
    period: float | None = None
    doc: str = ""


@dataclass(frozen=True)
class PaperTheorems:
    """The declaration that a law *is* Liang et al. 2012's eqs 13-19, from :meth:`LawBuilder.paper_theorems`.

    Theorems 1-2 of the paper then apply to it (Theorem 1 constrains the coupling weights of eq 19, Theorem 2
    the switching gain ``delta``), and ``fsmctl prove --law`` checks the claim: the closed loop must be eq 20.

    Parameters
    ----------
    parameters : tuple of (str, str)
        ``(role, parameter name)`` for each of :data:`PAPER_THEOREM_ROLES`.
    """

    parameters: tuple[tuple[str, str], ...]

    def parameter(self, role: str) -> str:
        """The name of the law's parameter that plays ``role`` (one of :data:`PAPER_THEOREM_ROLES`).

        Raises
        ------
        KeyError
            ``role`` is not one of the paper's symbols.
        """
        return dict(self.parameters)[role]


@dataclass(frozen=True)
class ErrorState:
    """The error state of an agent, as stage symbols (Liang et al. 2012, eqs 5-8).

    What :meth:`LawBuilder.error_state` returns: each field is a column of stage symbols that the generated
    code computes once per evaluation.

    Parameters
    ----------
    sigma_e : sympy.ImmutableMatrix
        The attitude error (MRP of the body relative to the reference, shadow set).
    omega_e : sympy.ImmutableMatrix
        The rate error ``omega - omega_r`` (eq 8; rad/s).
    omega_r : sympy.ImmutableMatrix
        The reference rate in the body frame: ``omega_d`` (paper) or ``C(sigma_e) omega_d`` (exact).
    omega_r_dot : sympy.ImmutableMatrix
        Its body-frame time derivative (rad/s^2).

    Examples
    --------
    >>> from fsmctl.symbolic import LawBuilder
    >>> e = LawBuilder("pd", "exact", doc="example").error_state()
    >>> e.sigma_e.T, e.omega_e.T
    (Matrix([[sigma_e[0], sigma_e[1], sigma_e[2]]]), Matrix([[omega_e[0], omega_e[1], omega_e[2]]]))
    """

    sigma_e: sp.ImmutableMatrix
    omega_e: sp.ImmutableMatrix
    omega_r: sp.ImmutableMatrix
    omega_r_dot: sp.ImmutableMatrix


@dataclass(frozen=True)
class Law:
    """A control law, checked and split into the engine's contract (see :mod:`fsmctl.symbolic.law`).

    Build one with :meth:`LawBuilder.build` (never by hand); :meth:`constants_spec`, :meth:`local_spec` and
    :meth:`control_spec` are what :mod:`fsmctl.codegen` generates, :meth:`metadata` what ``law.json`` holds.

    Parameters
    ----------
    name, doc, reference : str
        The law's name, one-line description and citation.
    error_model : ErrorModel
        The error kinematics it was built for (Liang et al. 2012, eqs 7-8 as printed, or exact).
    parameters : tuple of LawParameter
        The named parameters, in the order of the ``params`` input.
    states : tuple of LawState
        The law's own states, in the order of ``z``.
    broadcast_name : str
        The name of what the agent sends to its neighbours.
    symbols : mapping of str to sympy.ImmutableMatrix
        The contract's input symbols by name (``t``, ``sigma``, ..., ``k_received_sum``, ``u_max``).
    constants, local_stages, control_stages : tuple of (str, Matrix, Matrix)
        ``(name, symbols, expression)`` of the per-agent constants, the stages evaluated with the broadcast and
        those evaluated with the torque (they read what the agent receives).
    cache : tuple of (str, Matrix)
        The local stages the control side reads, in order, as ``(name, symbols)``.
    broadcast : sympy.ImmutableMatrix
        What the agent sends (in stage and input symbols).
    torque : sympy.ImmutableMatrix
        The commanded torque (3 components, N m).
    state_derivative : sympy.ImmutableMatrix
        ``z_dot``.
    lyapunov : Lyapunov or None
        The declared Lyapunov candidate, for ``fsmctl prove --law``.
    batched : bool
        Whether the SIMD kernels are generated (:mod:`fsmctl.codegen.batched`).
    broadcast_unit : str
        The unit of the broadcast.
    discontinuity : Discontinuity or None
        Where the closed loop is discontinuous (:meth:`LawBuilder.discontinuous`); None for a continuous law.
    presets : tuple of PresetGroup
        The named parameter presets (:meth:`LawBuilder.preset_group`).
    loop_rates : LoopRates or None
        Closed-form bounds on the loop's rates (:meth:`LawBuilder.loop_rates`).
    paper_theorems : PaperTheorems or None
        Whether the law is the paper's eqs 13-19, with which parameters (:meth:`LawBuilder.paper_theorems`).
    wheel_stages : tuple of (str, Matrix, Matrix)
        The stages that read the wheels' inputs (evaluated with the wheel commands only).
    wheel_torques : sympy.ImmutableMatrix or None
        The per-wheel motor torque commands (:meth:`LawBuilder.wheel_torques`; N m); None when the law leaves its
        body torque to the engine's minimum-norm distribution.
    trigger : Trigger or None
        When the agent sends its broadcast (:meth:`LawBuilder.trigger`); None: at every control evaluation.

    Examples
    --------
    An MRP PD law with a consensus term (the README's ``pd.py``):

    >>> from fsmctl.symbolic import LawBuilder
    >>> b = LawBuilder("pd", "paper", doc="MRP PD with consensus on the attitude error")
    >>> K = b.parameter("K", 20.0, unit="N m", minimum=0.0, doc="attitude gain")
    >>> P = b.parameter("P", 40.0, unit="N m s", minimum=0.0, doc="rate gain")
    >>> e = b.error_state()
    >>> b.broadcast("sigma_e", e.sigma_e)
    >>> b.torque(-K * e.sigma_e - P * e.omega_e - K * (b.k_received_sum * e.sigma_e - b.received))
    >>> law = b.build()
    >>> law.n_params, law.n_broadcast, law.n_states, [name for name, _ in law.cache]
    (2, 3, 0, ['sigma_e', 'omega_e'])

    At rest on the reference only the neighbours' term acts (eq 19 for the broadcast ``sigma_e``):

    >>> at_rest = {x: 0 for x in (*b.sigma, *b.omega, *b.sigma_d, *b.omega_d, *b.omega_d_dot)}
    >>> law.expanded(law.torque).subs(at_rest).T
    Matrix([[K*received[0], K*received[1], K*received[2]]])
    """

    name: str
    doc: str
    reference: str
    error_model: ErrorModel
    parameters: tuple[LawParameter, ...]
    states: tuple[LawState, ...]
    broadcast_name: str
    symbols: Mapping[str, sp.ImmutableMatrix]
    """the contract's input symbols by name (``t``, ``sigma``, ..., ``k_received_sum``)"""
    constants: tuple[tuple[str, sp.ImmutableMatrix, sp.ImmutableMatrix], ...]
    local_stages: tuple[tuple[str, sp.ImmutableMatrix, sp.ImmutableMatrix], ...]
    control_stages: tuple[tuple[str, sp.ImmutableMatrix, sp.ImmutableMatrix], ...]
    cache: tuple[tuple[str, sp.ImmutableMatrix], ...]
    """local stages the control side reads, in order, as ``(name, symbols)``"""
    broadcast: sp.ImmutableMatrix
    torque: sp.ImmutableMatrix
    state_derivative: sp.ImmutableMatrix
    lyapunov: Lyapunov | None = None
    batched: bool = True
    broadcast_unit: str = "1"
    discontinuity: Discontinuity | None = None
    presets: tuple[PresetGroup, ...] = ()
    loop_rates: LoopRates | None = None
    paper_theorems: PaperTheorems | None = None
    wheel_stages: tuple[tuple[str, sp.ImmutableMatrix, sp.ImmutableMatrix], ...] = ()
    wheel_torques: sp.ImmutableMatrix | None = None
    trigger: Trigger | None = None

    # -- sizes -------------------------------------------------------------------------------------
    @property
    def n_params(self) -> int:
        """Length of the ``params`` input (vector parameters count each component)."""
        return sum(p.size for p in self.parameters)

    @property
    def n_states(self) -> int:
        """Length of the law state ``z``."""
        return sum(s.size for s in self.states)

    @property
    def n_broadcast(self) -> int:
        """Length of the broadcast."""
        return self.broadcast.rows

    @property
    def n_constants(self) -> int:
        """Length of the ``constants`` vector (``law_constants``)."""
        return sum(m.rows for _, m, _ in self.constants)

    @property
    def n_cache(self) -> int:
        """Length of the ``cache`` vector passed from ``law_local_*`` to ``law_control_*``."""
        return sum(len(m) for _, m in self.cache)

    @property
    def n_wheels(self) -> int:
        """The number of wheels the law commands (:meth:`LawBuilder.wheel_torques`); 0 when it commands none."""
        return 0 if self.wheel_torques is None else self.wheel_torques.rows

    def parameter(self, name: str) -> LawParameter:
        """The parameter declared as ``name``.

        Parameters
        ----------
        name : str
            Its name.

        Returns
        -------
        LawParameter
            Its default, unit, range and meaning.

        Raises
        ------
        KeyError
            The law has no such parameter.
        """
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(name)

    # -- symbols -----------------------------------------------------------------------------------
    def parameter_symbols(self) -> dict[str, sp.Expr | sp.ImmutableMatrix]:
        """Each parameter's symbol (a scalar) or column of symbols (a vector), by name.

        Returns
        -------
        dict
            ``{name: symbol or column}`` in declaration order.
        """
        out, k = {}, 0
        params = self.symbols["params"]
        for p in self.parameters:
            out[p.name] = params[k] if p.size == 1 else sp.ImmutableMatrix(params[k : k + p.size, 0])
            k += p.size
        return out

    def state_symbols(self) -> dict[str, sp.ImmutableMatrix]:
        """Each law state's column of symbols (slices of ``z``), by name.

        Returns
        -------
        dict
            ``{name: column}`` in declaration order.
        """
        out, k = {}, 0
        z = self.symbols["z"]
        for s in self.states:
            out[s.name] = sp.ImmutableMatrix(z[k : k + s.size, 0])
            k += s.size
        return out

    def expanded(self, expr) -> sp.ImmutableMatrix:
        """``expr`` with every stage and constant symbol replaced by its definition (in agent inputs only).

        Parameters
        ----------
        expr : Expr or Matrix
            An expression in the law's symbols (e.g. :attr:`torque`).

        Returns
        -------
        sympy.ImmutableMatrix
            A column in the contract's inputs only (a scalar becomes a 1x1 matrix).
        """
        expr = sp.ImmutableMatrix(expr) if isinstance(expr, sp.MatrixBase) else sp.ImmutableMatrix([expr])
        for _, syms, value in reversed((*self.constants, *self.local_stages, *self.control_stages, *self.wheel_stages)):
            expr = expr.xreplace(dict(zip(syms, value, strict=True)))
        return expr

    # -- generated functions -----------------------------------------------------------------------
    def _inputs(self, names: Iterable[str]) -> tuple[tuple[str, sp.ImmutableMatrix], ...]:
        return tuple((n, self.symbols[n]) for n in names)

    def constants_spec(self) -> FunctionSpec:
        """The generated function ``law_constants(params) -> constants``.

        Returns
        -------
        FunctionSpec
            What :func:`fsmctl.codegen.build_functions` translates.
        """
        values = [v for _, _, v in self.constants]
        out = sp.ImmutableMatrix.vstack(*values) if values else sp.ImmutableMatrix.zeros(0, 1)
        return FunctionSpec(
            name="law_constants",
            doc=f"{self.name}: per-agent constants {[n for n, _, _ in self.constants]} of the parameters",
            inputs=self._inputs(("params",)),
            outputs=(("constants", out),),
        )

    def local_spec(self) -> FunctionSpec:
        """The generated function ``law_local_<model>(t, sigma, ..., constants) -> (broadcast, cache)``.

        Returns
        -------
        FunctionSpec
            What :func:`fsmctl.codegen.build_functions` translates.
        """
        local, _ = contract_names(self.error_model)
        cache = [s for _, s in self.cache]
        return FunctionSpec(
            name=local,
            doc=(
                f"{self.name} ({self.error_model.value} error kinematics): what the agent broadcasts "
                f"({self.broadcast_name}) and the cached stages {[n for n, _ in self.cache]}"
            ),
            inputs=self._inputs(AGENT_INPUTS),
            stages=tuple((s, v) for _, s, v in self.local_stages),
            outputs=(
                ("broadcast", self.broadcast),
                ("cache", sp.ImmutableMatrix.vstack(*cache) if cache else sp.ImmutableMatrix.zeros(0, 1)),
            ),
            batched=self.batched,
        )

    def control_spec(self) -> FunctionSpec:
        """The generated function ``law_control_<model>(..., cache, k_sum, received, k_received_sum, u_max)``.

        Its outputs are ``u`` (saturated at ``u_max`` per axis), ``u_commanded`` and ``z_dot``.

        Returns
        -------
        FunctionSpec
            What :func:`fsmctl.codegen.build_functions` translates.
        """
        _, control = contract_names(self.error_model)
        return FunctionSpec(
            name=control,
            doc=(
                f"{self.name} ({self.error_model.value} error kinematics): applied torque u (the ideal actuator's "
                "per-axis limit u_max), commanded torque u_commanded and the law-state derivative z_dot, given "
                "what the agent received"
            ),
            inputs=self._inputs(AGENT_INPUTS + NEIGHBOUR_INPUTS),
            stages=tuple((s, v) for _, s, v in self.control_stages),
            outputs=(
                ("u", saturate(self.torque, self.symbols["u_max"][0])),
                ("u_commanded", self.torque),
                ("z_dot", self.state_derivative),
            ),
            batched=self.batched,
        )

    def wheels_spec(self) -> FunctionSpec | None:
        """The generated function ``law_wheels_<model>(..., u_max, spin_axes, wheel_speed, spin_inertia) -> u_wheels``.

        The inputs of ``law_control_<model>`` followed by :data:`WHEEL_INPUTS`; the output is the ``N`` per-wheel
        motor torque commands of :meth:`LawBuilder.wheel_torques`.  None when the law commands no wheels.

        Returns
        -------
        FunctionSpec or None
            What :func:`fsmctl.codegen.build_functions` translates.
        """
        if self.wheel_torques is None:
            return None
        return FunctionSpec(
            name=wheels_function_name(self.error_model),
            doc=(
                f"{self.name} ({self.error_model.value} error kinematics): the motor torque commands u_wheels of its "
                f"{self.n_wheels} reaction wheels (N m, positive spins a wheel up along its axis), given what the "
                "agent received and the wheels' axes, speeds and spin inertias"
            ),
            inputs=self._inputs(AGENT_INPUTS + NEIGHBOUR_INPUTS + WHEEL_INPUTS),
            stages=tuple((s, v) for _, s, v in (*self.control_stages, *self.wheel_stages)),
            outputs=(("u_wheels", self.wheel_torques),),
        )

    def loop_rates_spec(self) -> FunctionSpec | None:
        """The generated function ``law_loop_rates(params) -> (surface, layer)``, or None if none is declared.

        Returns
        -------
        FunctionSpec or None
            What :func:`fsmctl.codegen.build_functions` translates.
        """
        if self.loop_rates is None:
            return None
        return FunctionSpec(
            name=LOOP_RATES_FUNCTION,
            doc=f"{self.name}: bounds on the closed loop's rates (1/s): {self.loop_rates.doc}",
            inputs=self._inputs(("params",)),
            outputs=(
                ("surface", sp.ImmutableMatrix([self.loop_rates.surface])),
                ("layer", sp.ImmutableMatrix([self.loop_rates.layer])),
            ),
        )

    def trigger_spec(self) -> FunctionSpec | None:
        """The generated function ``law_trigger(t, broadcast, broadcast_sent, params, constants) -> margin``, or None
        if the law declares no trigger (:meth:`LawBuilder.trigger`).

        Returns
        -------
        FunctionSpec or None
            What :func:`fsmctl.codegen.build_functions` translates.
        """
        if self.trigger is None:
            return None
        return FunctionSpec(
            name=TRIGGER_FUNCTION,
            doc=f"{self.name}: event trigger, the agent sends its broadcast when margin > 0: {self.trigger.condition}",
            inputs=(
                ("t", self.symbols["t"]),
                ("broadcast", _broadcast_symbols(self.n_broadcast)),
                ("broadcast_sent", _sent_symbols(self.n_broadcast)),
                ("params", self.symbols["params"]),
                ("constants", self.symbols["constants"]),
            ),
            outputs=(("margin", sp.ImmutableMatrix([self.trigger.margin])),),
        )

    def metadata(self) -> dict:
        """What the runtime needs to know about the law (written to ``law.json``).

        Returns
        -------
        dict
            JSON-able: name, doc, reference, parameters, states, broadcast, constants, cache, lyapunov, and the
            declarations discontinuity, presets, loop_rates and paper_theorems; ``wheels`` (``count``, the
            ``function`` prefix, ``unit``) only for a law that commands its wheels; ``trigger`` (the generated
            function, the condition, the check period and its doc) only when the law declares one, so that the
            ``law.json`` of a law without either is what it was before they existed.
        """
        return {
            "name": self.name,
            "doc": self.doc,
            "reference": self.reference,
            "parameters": [p.to_dict() for p in self.parameters],
            "states": [s.to_dict() for s in self.states],
            "broadcast": {"name": self.broadcast_name, "size": self.n_broadcast, "unit": self.broadcast_unit},
            "constants": [{"name": n, "size": m.rows} for n, m, _ in self.constants],
            "cache": [{"name": n, "size": len(m)} for n, m in self.cache],
            "lyapunov": None if self.lyapunov is None else {"doc": self.lyapunov.doc},
            "discontinuity": None
            if self.discontinuity is None
            else {"where": self.discontinuity.where, "smoothed_by": self.discontinuity.smoothed_by},
            "presets": [g.to_dict() for g in self.presets],
            "loop_rates": None
            if self.loop_rates is None
            else {"function": LOOP_RATES_FUNCTION, "doc": self.loop_rates.doc},
            "paper_theorems": None if self.paper_theorems is None else dict(self.paper_theorems.parameters),
            **(
                {}  # a law without wheel outputs: law.json as before wheel outputs existed (format 1)
                if self.wheel_torques is None
                else {"wheels": {"count": self.n_wheels, "function": "law_wheels", "unit": "N m"}}
            ),
            **(
                {}
                if self.trigger is None
                else {
                    "trigger": {
                        "function": TRIGGER_FUNCTION,
                        "condition": self.trigger.condition,
                        "period": self.trigger.period,
                        "doc": self.trigger.doc,
                    }
                }
            ),
        }


def _broadcast_symbols(n: int) -> sp.ImmutableMatrix:
    """The current broadcast as an input of ``law_trigger``: ``broadcast[k]``."""
    return vector_symbols("broadcast", n)


def _sent_symbols(n: int) -> sp.ImmutableMatrix:
    """The last value the agent sent, an input of ``law_trigger``: ``broadcast_sent[k]``."""
    return vector_symbols("broadcast_sent", n)


def _matrix(value, what: str) -> sp.ImmutableMatrix:
    if isinstance(value, sp.MatrixBase):
        m = sp.ImmutableMatrix(value)
        if m.cols != 1 and m.rows == 1:
            m = m.T
        if m.cols != 1:
            raise LawDefinitionError(f"{what}: expected a scalar or a column vector, got shape {m.shape}")
        return m
    if isinstance(value, (list, tuple)):
        return sp.ImmutableMatrix([sp.sympify(v) for v in value])
    try:
        return sp.ImmutableMatrix([sp.sympify(value)])
    except (sp.SympifyError, TypeError) as exc:
        raise LawDefinitionError(f"{what}: not a SymPy expression: {value!r}") from exc


def _floats(value, what: str) -> tuple[float, ...]:
    items = list(value) if isinstance(value, (list, tuple)) else [value]
    out = []
    for v in items:
        if isinstance(v, bool) or not isinstance(v, (int, float, sp.Number)):
            raise LawDefinitionError(f"{what}: expected numbers, got {v!r}")
        out.append(float(v))
    return tuple(out)


class LawBuilder:
    """Build a :class:`Law` step by step (see the module docstring for an example).

    Parameters
    ----------
    name : str
        The law's name (letters, digits, ``_``): what ``fsmctl laws`` lists and ``--law`` selects.
    error_model : ErrorModel or str
        ``"paper"`` (eqs 7-8 as printed: ``omega_r = omega_d``) or ``"exact"`` (``omega_r = C omega_d``);
        a derivation script's ``law(error_model)`` receives it and passes it on.
    doc : str
        One line saying what the law is.
    reference : str
        Where it comes from (a citation).

    Attributes
    ----------
    t : Symbol
        time, s
    sigma, omega : Matrix
        the agent's attitude (MRP, body to inertial) and body rate (rad/s), as it measures them
    sigma_d, omega_d, omega_d_dot : Matrix
        the reference attitude (MRP of the reference frame R), its angular velocity and the time derivative of
        that (rad/s, rad/s^2), in R-frame components as printed in Section 4: ``sigma_d_dot = G(sigma_d) omega_d``.
        The law sees the reference rate in the body frame through :meth:`error_state`:
        ``omega_r = C(sigma_e) omega_d`` (exact; ``C(sigma_e) = [B R]``, :func:`~fsmctl.symbolic.mrp_to_dcm`)
        or ``omega_r = omega_d`` (paper, eqs 7-8 as printed), and ``omega_e = omega - omega_r``; the time
        derivative of ``omega_r``'s body-frame components is
        ``omega_r_dot = C(sigma_e) omega_d_dot + omega_r^x omega_e`` (exact, from ``C_dot = -omega_e^x C``)
        or ``omega_r_dot = omega_d_dot`` (paper)
    J0 : Matrix
        the nominal inertia the controller knows (kg m^2, symmetric)

    Raises
    ------
    LawDefinitionError
        A malformed name or an unknown error model.

    Examples
    --------
    A PI law on the attitude error with one law state ``xi`` (``xi_dot = sigma_e``) and a consensus term;
    the stages and the cache are found by :meth:`build`:

    >>> from fsmctl.symbolic import LawBuilder
    >>> b = LawBuilder("pi", "exact", doc="MRP PI with consensus")
    >>> K = b.parameter("K", 2.0, unit="N m", minimum=0.0, doc="attitude gain")
    >>> P = b.parameter("P", 8.0, unit="N m s", minimum=0.0, doc="rate gain")
    >>> xi = b.state("xi", 3, unit="s", doc="integral of sigma_e")
    >>> e = b.error_state()
    >>> b.derivative(xi, e.sigma_e)
    >>> b.broadcast("sigma_e", e.sigma_e)
    >>> b.torque(-K * (e.sigma_e + xi / 10) - P * e.omega_e - K * (b.k_received_sum * e.sigma_e - b.received))
    >>> law = b.build()
    >>> law.local_spec().name, law.control_spec().name, law.n_states
    ('law_local_exact', 'law_control_exact', 3)
    >>> law.parameter("P").unit, law.parameter("P").default
    ('N m s', (8.0,))
    """

    def __init__(self, name: str, error_model: ErrorModel | str = ErrorModel.PAPER, *, doc: str, reference: str = ""):
        if not isinstance(name, str) or not _NAME.match(name):
            raise LawDefinitionError(f"law name must be letters, digits and _ (starting with a letter), got {name!r}")
        try:
            self.error_model = ErrorModel(error_model)
        except ValueError:
            raise LawDefinitionError(f"error_model must be 'paper' or 'exact', got {error_model!r}") from None
        self.name, self.doc, self.reference = name, str(doc), str(reference)
        self.t = sp.Symbol("t", real=True)
        self.sigma, self.omega = vector_symbols("sigma"), vector_symbols("omega")
        self.sigma_d, self.omega_d = vector_symbols("sigma_d"), vector_symbols("omega_d")
        self.omega_d_dot = vector_symbols("omega_d_dot")
        self.J0 = symmetric_matrix_symbols("J0")
        self._parameters: list[LawParameter] = []
        self._param_symbols: list[sp.Symbol] = []
        self._states: list[LawState] = []
        self._state_symbols: list[sp.Symbol] = []
        self._derivatives: dict[str, sp.ImmutableMatrix] = {}
        self._constants: list[tuple[str, sp.ImmutableMatrix, sp.ImmutableMatrix]] = []
        self._stages: list[tuple[str, sp.ImmutableMatrix, sp.ImmutableMatrix]] = []
        self._names: set[str] = set()
        self._broadcast: tuple[str, sp.ImmutableMatrix] | None = None
        self._broadcast_unit = "1"
        self._neighbour: dict[str, sp.ImmutableMatrix] = {}
        self._torque: sp.ImmutableMatrix | None = None
        self._error: ErrorState | None = None
        self._lyapunov: Lyapunov | None = None
        self._discontinuity: Discontinuity | None = None
        self._presets: list[PresetGroup] = []
        self._loop_rates: LoopRates | None = None
        self._paper_theorems: PaperTheorems | None = None
        self._wheels: WheelInputs | None = None
        self._wheel_torques: sp.ImmutableMatrix | None = None
        self._trigger: Trigger | None = None
        self.batched = True

    # -- declarations -----------------------------------------------------------------------------
    def _claim(self, name: str, what: str) -> None:
        if not isinstance(name, str) or not _NAME.match(name):
            raise LawDefinitionError(f"{self.name}: {what} name must be letters, digits and _, got {name!r}")
        if name in _RESERVED:
            raise LawDefinitionError(
                f"{self.name}: the name {name!r} is reserved: the contract's inputs and outputs are "
                f"{', '.join(sorted(_RESERVED))}"
            )
        if name in self._names:
            raise LawDefinitionError(f"{self.name}: the name {name!r} is already used by another declaration")
        self._names.add(name)

    def parameter(
        self,
        name: str,
        default,
        *,
        unit: str = "1",
        minimum: float | None = None,
        maximum: float | None = None,
        exclusive_minimum: bool = False,
        exclusive_maximum: bool = False,
        doc: str = "",
        choices: Sequence[str] = (),
        tunable: bool = True,
    ):
        """Declare a named parameter; returns its symbol (a column of symbols for a vector default).

        A scenario sets it by name under ``[controller]``; ``choices`` makes it an option whose symbol
        takes the index of the chosen string.

        Parameters
        ----------
        name : str
            Letters, digits and ``_``; unique in the law and not a reserved name (see :meth:`state`).
        default : float, sequence of float or str
            The default value (a sequence makes a vector parameter, e.g. ``delta``); one of ``choices`` for an
            option.
        unit : str
            The unit (``fsmctl laws`` prints it).
        minimum, maximum : float, optional
            The admissible range, checked for every value a scenario gives.
        exclusive_minimum, exclusive_maximum : bool
            Whether the bounds themselves are excluded.
        doc : str
            What the parameter means.
        choices : sequence of str
            Makes the parameter an option; its symbol takes the index of the chosen string.
        tunable : bool
            Whether ``fsmctl tune`` may vary it (options never are).

        Returns
        -------
        sympy.Symbol or sympy.ImmutableMatrix
            The symbol, or a column of symbols ``name[k]`` for a vector.

        Raises
        ------
        LawDefinitionError
            A bad or duplicate name, a non-numeric default, or a default outside its range or choices.
        """
        self._claim(name, "parameter")
        if name in SHARED_CONTROLLER_KEYS or name in {g.name for g in self._presets}:
            raise LawDefinitionError(
                f"{self.name}: parameter {name!r} clashes with "
                + ("a preset group" if name not in SHARED_CONTROLLER_KEYS else "a [controller] key every law shares")
            )
        if choices:
            choices = tuple(str(c) for c in choices)
            if default not in choices:
                raise LawDefinitionError(f"{self.name}: parameter {name}: default {default!r} is not in {choices}")
            values = (float(choices.index(default)),)
            minimum, maximum, tunable = 0.0, float(len(choices) - 1), False
        else:
            values = _floats(default, f"{self.name}: parameter {name} default")
        p = LawParameter(
            name, values, str(unit), None if minimum is None else float(minimum),
            None if maximum is None else float(maximum), bool(exclusive_minimum), bool(exclusive_maximum),
            str(doc), tuple(choices), bool(tunable),
        )  # fmt: skip
        if not choices:
            for v in values:
                if (why := p.problem(v)) is not None:
                    raise LawDefinitionError(f"{self.name}: parameter {name}: default {why}")
        self._parameters.append(p)
        symbols = [sp.Symbol(name if p.size == 1 else f"{name}[{k}]", real=True) for k in range(p.size)]
        self._param_symbols.extend(symbols)
        return symbols[0] if p.size == 1 else sp.ImmutableMatrix(symbols)

    def state(self, name: str, size: int = 3, *, initial=0.0, unit: str = "", doc: str = "") -> sp.ImmutableMatrix:
        """Declare a law state of ``size`` components (integrated with the plant); returns its symbols.

        Names must be unique within the law and not one of the contract's reserved names (``t``, ``sigma``,
        ``omega``, ``z``, ``sigma_d``, ``omega_d``, ``omega_d_dot``, ``J0``, ``params``, ``constants``, ``cache``,
        ``k_sum``, ``received``, ``k_received_sum``, ``u_max``, ``u``, ``u_commanded``, ``z_dot``, ``broadcast``).

        Give its derivative with :meth:`derivative`.

        Parameters
        ----------
        name : str
            The state's name.
        size : int
            Number of components (positive).
        initial : float or sequence of float
            The initial value: a number (every component) or ``size`` numbers.
        unit : str
            Its unit.
        doc : str
            What it is.

        Returns
        -------
        sympy.ImmutableMatrix
            The column of symbols ``name[k]`` (a slice of ``z``).

        Raises
        ------
        LawDefinitionError
            A bad or duplicate name, a bad size or initial value.
        """
        self._claim(name, "state")
        if isinstance(size, bool) or not isinstance(size, int) or size < 1:
            raise LawDefinitionError(f"{self.name}: state {name}: size must be a positive integer, got {size!r}")
        init = _floats(initial, f"{self.name}: state {name} initial value")
        if len(init) == 1:
            init = init * size
        if len(init) != size:
            raise LawDefinitionError(f"{self.name}: state {name}: {len(init)} initial values for size {size}")
        self._states.append(LawState(name, init, str(unit), str(doc)))
        symbols = [sp.Symbol(f"{name}[{k}]", real=True) for k in range(size)]
        self._state_symbols.extend(symbols)
        return sp.ImmutableMatrix(symbols)

    def constant(self, name: str, expr):
        """A per-agent constant computed once per run from the parameters only; returns its symbol(s).

        Parameters
        ----------
        name : str
            The constant's name.
        expr : Expr, Matrix or sequence
            Its value, in parameter symbols only (e.g. ``epsilon**(alpha - 1)``).

        Returns
        -------
        sympy.Symbol or sympy.ImmutableMatrix
            The symbol standing for it (a column for a matrix value).

        Raises
        ------
        LawDefinitionError
            A bad name, or ``expr`` depends on anything but the parameters.
        """
        self._claim(name, "constant")
        value = _matrix(expr, f"{self.name}: constant {name}")
        allowed = set(self._param_symbols)
        extra = value.free_symbols - allowed
        if extra:
            raise LawDefinitionError(
                f"{self.name}: constant {name} may depend on parameters only, not {sorted(map(str, extra))}"
            )
        symbols = self._symbols(name, value.rows)
        self._constants.append((name, symbols, value))
        return symbols[0] if value.rows == 1 and not isinstance(expr, sp.MatrixBase) else symbols

    def stage(self, name: str, expr):
        """An intermediate result (a scalar or a column vector), computed once per evaluation; returns symbols
        standing for it (write a matrix as its columns, or keep it inline in the expressions that use it).

        Stages that do not depend on what the agent receives are evaluated with the broadcast (and the
        ones the torque reads are passed on in ``cache``); the others with the torque.

        Parameters
        ----------
        name : str
            The stage's name.
        expr : Expr, Matrix or sequence
            Its value (a scalar or a column), in the law's inputs and earlier stages.

        Returns
        -------
        sympy.Symbol or sympy.ImmutableMatrix
            The symbol (scalar) or column of symbols ``name[k]`` standing for it.

        Raises
        ------
        LawDefinitionError
            A bad or duplicate name, or a value that is not a scalar or a column.
        """
        self._claim(name, "stage")
        value = _matrix(expr, f"{self.name}: stage {name}")
        symbols = self._symbols(name, value.rows)
        self._stages.append((name, symbols, value))
        return symbols[0] if value.rows == 1 and not isinstance(expr, (sp.MatrixBase, list, tuple)) else symbols

    def _symbols(self, name: str, n: int) -> sp.ImmutableMatrix:
        # plain symbols (not Dummy): generated code must not depend on how many Dummies exist (byte-reproducible);
        # the names are unique because every declared name is (see _claim)
        return sp.ImmutableMatrix([sp.Symbol(f"{name}[{k}]" if n > 1 else name, real=True) for k in range(n)])

    def error_state(self) -> ErrorState:
        """The error state of the law's error model, as stages (Liang et al. 2012, eqs 5-8).

        ``sigma_e = sigma (x) sigma_d^-1`` in the shadow set, ``omega_r`` the reference rate in the body
        frame (``omega_d`` in the paper's model, ``C(sigma_e) omega_d`` in the exact one),
        ``omega_e = omega - omega_r`` and ``omega_r_dot`` its body-frame derivative.  Called twice, it
        returns the same stages.

        Returns
        -------
        ErrorState
            The stage symbols ``sigma_e``, ``omega_e``, ``omega_r``, ``omega_r_dot``.
        """
        if self._error is None:
            se = self.stage("sigma_e", mrp_error(self.sigma, self.sigma_d))
            wr = self.stage("omega_r", reference_rate_in_body(self.error_model, se, self.omega_d))
            we = self.stage("omega_e", self.omega - wr)
            wrd = self.stage(
                "omega_r_dot", reference_acceleration_in_body(self.error_model, se, we, self.omega_d, self.omega_d_dot)
            )
            self._error = ErrorState(se, we, wr, wrd)
        return self._error

    def broadcast(self, name: str, expr, *, unit: str = "1") -> None:
        """Declare what the agent sends to its neighbours (a vector; e.g. the sliding variable ``s``, unit 1/s).

        Afterwards :attr:`received`, :attr:`k_sum` and :attr:`k_received_sum` are available.

        Parameters
        ----------
        name : str
            What the broadcast is called (e.g. ``"s"``, ``"sigma_e"``).
        expr : Expr, Matrix or sequence
            Its value; it must not depend on what the agent receives.
        unit : str
            Its unit.

        Raises
        ------
        LawDefinitionError
            A second broadcast, a bad name, or a value that is not a column.
        """
        if self._broadcast is not None:
            raise LawDefinitionError(f"{self.name}: broadcast is declared twice")
        if not isinstance(name, str) or not _NAME.match(name):
            raise LawDefinitionError(f"{self.name}: broadcast name must be letters, digits and _, got {name!r}")
        value = _matrix(expr, f"{self.name}: broadcast {name}")
        self._broadcast = (name, value)
        self._broadcast_unit = str(unit)
        self._neighbour = {
            "k_sum": sp.ImmutableMatrix([sp.Symbol("k_sum", real=True)]),
            "received": vector_symbols("received", value.rows),
            "k_received_sum": sp.ImmutableMatrix([sp.Symbol("k_received_sum", real=True)]),
        }

    def _neighbour_symbol(self, key: str):
        if self._broadcast is None:
            raise LawDefinitionError(f"{self.name}: declare the broadcast before using what the agent receives")
        return self._neighbour[key]

    @property
    def received(self) -> sp.ImmutableMatrix:
        """``sum_j k^j_ij(t) b_j``: the weighted sum of the neighbours' broadcasts (eq 19)."""
        return self._neighbour_symbol("received")

    @property
    def k_sum(self) -> sp.Symbol:
        """``sum_j k^i_ij``: the agent's own constant weights of its incoming links (eq 19)."""
        return self._neighbour_symbol("k_sum")[0]

    @property
    def k_received_sum(self) -> sp.Symbol:
        """``sum_j k^j_ij(t)``: the total weight of what the agent receives at ``t``."""
        return self._neighbour_symbol("k_received_sum")[0]

    @property
    def u_max(self) -> sp.Symbol:
        """The ideal actuator's per-axis torque limit (N m, the scenario's ``torque_limit``), for :meth:`wheel_torques`.

        ``saturate(u, b.u_max)`` (:func:`fsmctl.symbolic.saturate`) is the body torque the ideal actuator applies and
        the engine's minimum-norm distribution realises; a law that commands its wheels reads it to do the same.

        Raises
        ------
        LawDefinitionError
            No :meth:`reaction_wheels` declared (only the wheel commands may read the limit).
        """
        if self._wheels is None:
            raise LawDefinitionError(f"{self.name}: u_max is read by wheel_torques() only: declare reaction_wheels()")
        return _U_MAX

    @property
    def broadcast_now(self) -> sp.ImmutableMatrix:
        """The agent's current broadcast as symbols ``broadcast[k]``, for :meth:`trigger` (the declared broadcast
        expression may be used instead: the trigger replaces it by these)."""
        self._neighbour_symbol("k_sum")  # the broadcast must be declared
        return _broadcast_symbols(self._broadcast[1].rows)

    @property
    def broadcast_sent(self) -> sp.ImmutableMatrix:
        """The last broadcast the agent sent, symbols ``broadcast_sent[k]``, for :meth:`trigger`."""
        if self._broadcast is None:
            raise LawDefinitionError(f"{self.name}: declare the broadcast before using the last value sent")
        return _sent_symbols(self._broadcast[1].rows)

    def trigger(self, condition, *, period: float | None = None, doc: str = "") -> None:
        """Declare when the agent sends its broadcast (event-triggered communication).

        At each check instant the engine evaluates ``condition`` with the agent's current broadcast and the last
        value it sent; when it holds, the agent sends (its neighbours then aggregate that value until its next
        message).  At the first instant every agent sends.  A law without a trigger broadcasts at every control
        evaluation.  A run of a law with a trigger needs a control period (``simulation.control_period > 0``):
        the trigger is checked at the control instants (or every ``period`` seconds), never inside a step.

        Parameters
        ----------
        condition : sympy relational
            A strict inequality ``lhs > rhs`` (or ``lhs < rhs``) in the broadcast (the expression declared with
            :meth:`broadcast`, or :attr:`broadcast_now`), the last value sent (:attr:`broadcast_sent`), the time
            :attr:`t`, the parameters and the constants; e.g. ``(s - b.broadcast_sent).norm() > c0 + c1 *
            sp.exp(-lam * b.t)`` (Seyboth, Dimarogonas & Johansson, Automatica 49 (2013) 245-252).  Generated as
            ``law_trigger(t, broadcast, broadcast_sent, params, constants) -> lhs - rhs``; the agent sends when it
            is > 0.
        period : float, optional
            Seconds between checks: a multiple of the run's control period (checked before a run); None (default)
            checks at every control instant.
        doc : str
            What the rule is (a citation).

        Raises
        ------
        LawDefinitionError
            Before :meth:`broadcast`, a second declaration, a condition that is not a strict inequality, one that
            depends on what the agent receives or on anything but the inputs above, or a bad period.

        Examples
        --------
        >>> import sympy as sp
        >>> from fsmctl.symbolic import LawBuilder
        >>> b = LawBuilder("pd_event", doc="PD, event-triggered consensus")
        >>> c0 = b.parameter("c0", 0.01, minimum=0.0, doc="threshold floor")
        >>> e = b.error_state()
        >>> b.broadcast("sigma_e", e.sigma_e)
        >>> b.trigger((e.sigma_e - b.broadcast_sent).norm() > c0, doc="relative threshold")
        >>> b.torque(-e.sigma_e - e.omega_e - (b.k_received_sum * e.sigma_e - b.received))
        >>> law = b.build()
        >>> law.trigger.margin
        -c0 + sqrt((-broadcast[0] + broadcast_sent[0])**2 + (-broadcast[1] + broadcast_sent[1])**2 + (-broadcast[2] + broadcast_sent[2])**2)
        >>> b.trigger(c0 >= 0)
        Traceback (most recent call last):
        ...
        fsmctl.symbolic.law.LawDefinitionError: pd_event: trigger() is declared twice
        """
        if self._broadcast is None:
            raise LawDefinitionError(f"{self.name}: trigger(): declare the broadcast before its trigger")
        if self._trigger is not None:
            raise LawDefinitionError(f"{self.name}: trigger() is declared twice")
        if isinstance(condition, sp.StrictGreaterThan):
            margin = condition.lhs - condition.rhs
        elif isinstance(condition, sp.StrictLessThan):
            margin = condition.rhs - condition.lhs
        else:
            got = type(condition).__name__ if isinstance(condition, sp.Basic) else repr(condition)
            raise LawDefinitionError(
                f"{self.name}: trigger(): the condition must be a strict inequality lhs > rhs in SymPy symbols (the "
                f"agent sends when it holds), got {got}"
            )
        bvalue = self._broadcast[1]
        now, sent = _broadcast_symbols(bvalue.rows), _sent_symbols(bvalue.rows)
        margin = sp.sympify(margin).xreplace(dict(zip(bvalue, now, strict=True)))
        if isinstance(margin, sp.MatrixBase) or not isinstance(margin, sp.Expr):
            raise LawDefinitionError(f"{self.name}: trigger(): lhs and rhs must be scalars")
        free = margin.free_symbols
        neighbour = set().union(*(m.free_symbols for m in self._neighbour.values()))
        if free & neighbour:
            raise LawDefinitionError(
                f"{self.name}: trigger(): the condition must not depend on what the agent receives "
                f"({sorted(map(str, free & neighbour))})"
            )
        const_syms = {s for _, m, _ in self._constants for s in m}
        allowed = {self.t, *now, *sent, *self._param_symbols, *const_syms}
        extra = free - allowed
        if extra:
            raise LawDefinitionError(
                f"{self.name}: trigger(): the condition may depend on the broadcast, the last value sent "
                f"(broadcast_sent), t, the parameters and the constants only, not {sorted(map(str, extra))}"
            )
        if period is not None:
            if isinstance(period, bool) or not isinstance(period, (int, float)) or not 0 < period < float("inf"):
                raise LawDefinitionError(
                    f"{self.name}: trigger(period=...): seconds between checks (> 0) or None, got {period!r}"
                )
            period = float(period)
        self._trigger = Trigger(margin, str(condition), period, str(doc))

    def torque(self, u) -> None:
        """Declare the commanded body torque (3 components, N m), before the actuator's limit.

        Parameters
        ----------
        u : Matrix or sequence
            The torque, in the law's inputs, stages and what the agent receives.

        Raises
        ------
        LawDefinitionError
            A second torque, or not 3 components.
        """
        if self._torque is not None:
            raise LawDefinitionError(f"{self.name}: torque is declared twice")
        u = _matrix(u, f"{self.name}: torque")
        if u.shape != (3, 1):
            raise LawDefinitionError(f"{self.name}: torque must have 3 components, got {u.rows}")
        self._torque = u

    def reaction_wheels(self, n: int) -> WheelInputs:
        """Declare that the law commands ``n`` reaction wheels itself; returns the symbols of what it knows of them.

        The spin axes, wheel speeds and spin inertias are inputs of the generated ``law_wheels_<model>`` only, the
        function of :meth:`wheel_torques`; the body torque (:meth:`torque`), the broadcast and the law states cannot
        read them, so that the law still flies on an ideal torque source.  A scenario that flies the law on reaction
        wheels must have ``n`` of them (checked before the run); on an ideal actuator the wheel commands are not
        used and the actuator applies the body torque.

        Parameters
        ----------
        n : int
            The number of wheels (positive), e.g. 4 for a pyramid.

        Returns
        -------
        WheelInputs
            ``spin_axes`` (``3 x n``, column ``k`` the unit axis ``g_k`` in the body frame), ``speed`` (``n``,
            ``Omega_k`` relative to the hub, rad/s), ``spin_inertia`` (``n``, kg m^2) and ``momentum``
            (``sum_k J_s,k Omega_k g_k``).

        Raises
        ------
        LawDefinitionError
            A second declaration, or ``n`` not a positive integer.

        Examples
        --------
        Null motion that spins the wheels down without changing the body torque (``pinv(G) = G^T (G G^T)^-1``):

        >>> import sympy as sp
        >>> from fsmctl.symbolic import LawBuilder
        >>> b = LawBuilder("pd_rw", "exact", doc="PD, wheel momentum managed by null motion")
        >>> K = b.parameter("K", 1.0, unit="N m", minimum=0.0, doc="attitude gain")
        >>> k_h = b.parameter("k_h", 0.1, unit="1/s", minimum=0.0, doc="momentum gain")
        >>> e = b.error_state()
        >>> b.broadcast("sigma_e", e.sigma_e)
        >>> u = -K * e.sigma_e - 4 * K * e.omega_e
        >>> b.torque(u)
        >>> w = b.reaction_wheels(4)
        >>> G = w.spin_axes
        >>> P = b.stage("P", list(G.T * (G * G.T).inv(method="ADJ")))  # the 4 x 3 pseudo-inverse, row-major
        >>> pinv = sp.Matrix(4, 3, list(P))
        >>> v = -k_h * sp.matrix_multiply_elementwise(w.spin_inertia, w.speed)
        >>> b.wheel_torques(-pinv * (u + G * v) + v)
        >>> law = b.build()
        >>> law.n_wheels, law.wheels_spec().name, [name for name, _ in law.wheels_spec().outputs]
        (4, 'law_wheels_exact', ['u_wheels'])
        """
        if self._wheels is not None:
            raise LawDefinitionError(f"{self.name}: reaction_wheels() is declared twice")
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise LawDefinitionError(f"{self.name}: reaction_wheels(n): n must be a positive integer, got {n!r}")
        axes = sp.ImmutableMatrix(3, n, lambda r, k: sp.Symbol(f"spin_axes[{r}, {k}]", real=True))
        self._wheels = WheelInputs(n, axes, vector_symbols("wheel_speed", n), vector_symbols("spin_inertia", n))
        return self._wheels

    def wheel_torques(self, u_wheels) -> None:
        """Declare the motor torque command of each wheel of :meth:`reaction_wheels` (N m), before the wheels' limits.

        Wheel ``k``'s motor torque ``u_k > 0`` spins it up along its axis ``g_k``; the body feels
        ``-sum_k g_k u_k``.  On reaction wheels the engine flies these commands instead of the minimum-norm
        distribution ``-pinv(G) u`` of the body torque; the same torque limit then applies (all commands divided by
        one factor when one exceeds its ``max_torque``), and the speed limit and friction as for any command.  The
        body torque of :meth:`torque` stays what the ideal actuator flies and what results record as
        ``u_commanded``; the law is responsible for their agreement (``-G u_wheels`` equal to the limited body
        torque, plus any null motion ``G v = 0``).

        Parameters
        ----------
        u_wheels : Matrix or sequence
            ``N`` commands, in the law's inputs, stages, what the agent receives and the wheel symbols.

        Raises
        ------
        LawDefinitionError
            No :meth:`reaction_wheels` declared before, a second declaration, or not ``N`` components.

        Examples
        --------
        See :meth:`reaction_wheels`.
        """
        if self._wheels is None:
            raise LawDefinitionError(
                f"{self.name}: wheel_torques() needs reaction_wheels(n) first (the number of wheels and their symbols)"
            )
        if self._wheel_torques is not None:
            raise LawDefinitionError(f"{self.name}: wheel_torques() is declared twice")
        value = _matrix(u_wheels, f"{self.name}: wheel_torques")
        if value.rows != self._wheels.n:
            raise LawDefinitionError(
                f"{self.name}: wheel_torques() has {value.rows} components, reaction_wheels() declared {self._wheels.n}"
            )
        self._wheel_torques = value

    def derivative(self, state: sp.ImmutableMatrix, expr) -> None:
        """Declare the time derivative of a law state declared with :meth:`state`.

        Parameters
        ----------
        state : Matrix
            The column :meth:`state` returned.
        expr : Expr, Matrix or sequence
            Its derivative (as many components as the state).

        Raises
        ------
        LawDefinitionError
            ``state`` is not a declared state, a size mismatch, or a derivative given twice.
        """
        state = sp.ImmutableMatrix(state)
        for s in self._states:
            k = self._state_offset(s.name)
            if tuple(state) == tuple(self._state_symbols[k : k + s.size]):
                value = _matrix(expr, f"{self.name}: derivative of {s.name}")
                if value.rows != s.size:
                    raise LawDefinitionError(
                        f"{self.name}: derivative of {s.name} has {value.rows} components, the state {s.size}"
                    )
                if s.name in self._derivatives:
                    raise LawDefinitionError(f"{self.name}: derivative of {s.name} is given twice")
                self._derivatives[s.name] = value
                return
        raise LawDefinitionError(f"{self.name}: derivative(): the first argument must be a state from state()")

    def _state_offset(self, name: str) -> int:
        k = 0
        for s in self._states:
            if s.name == name:
                return k
            k += s.size
        raise KeyError(name)

    def lyapunov(self, V, *, claimed_derivative=None, region: Mapping[str, float] | None = None, doc: str = "") -> None:
        """Declare a Lyapunov candidate for ``fsmctl prove --law`` (see :class:`Lyapunov`).

        Parameters
        ----------
        V : Expr
            The candidate, in ``sigma``, ``omega``, ``z``, the parameters and ``J0``.
        claimed_derivative : Expr, optional
            What ``V_dot`` along the isolated agent's closed loop should simplify to.
        region : mapping of str to float, optional
            Norm bounds ``{"sigma": ..., "omega": ..., "z": ...}`` of the numeric evidence.
        doc : str
            What the candidate is (a citation).

        Raises
        ------
        LawDefinitionError
            A region key other than ``sigma``, ``omega``, ``z`` or a non-positive bound.
        """
        region = dict(region or {"sigma": 1.0, "omega": 0.5, "z": 1.0})
        for key, bound in region.items():
            if key not in ("sigma", "omega", "z") or not (isinstance(bound, (int, float)) and bound > 0):
                raise LawDefinitionError(f"{self.name}: lyapunov region: {key}={bound!r} (keys sigma, omega, z; > 0)")
        self._lyapunov = Lyapunov(
            sp.sympify(V),
            None if claimed_derivative is None else sp.sympify(claimed_derivative),
            tuple(sorted((k, float(v)) for k, v in region.items())),
            str(doc),
        )

    # -- what the engine and the tools need to know ------------------------------------------------
    def _declared_parameter(self, value, what: str) -> LawParameter:
        """The declared parameter that ``value`` (its name, its symbol or its column of symbols) stands for."""
        k = 0
        for p in self._parameters:
            symbols = tuple(self._param_symbols[k : k + p.size])
            k += p.size
            if isinstance(value, str):
                if value == p.name:
                    return p
            elif isinstance(value, sp.MatrixBase):
                if tuple(value) == symbols:
                    return p
            elif p.size == 1 and value == symbols[0]:
                return p
        raise LawDefinitionError(f"{self.name}: {what}: {value!r} is not a parameter declared with parameter()")

    def _parameter_expression(self, expr, what: str) -> sp.Expr:
        value = _matrix(expr, f"{self.name}: {what}")
        if value.rows != 1:
            raise LawDefinitionError(f"{self.name}: {what} must be a scalar, got {value.rows} components")
        extra = value.free_symbols - set(self._param_symbols)
        if extra:
            raise LawDefinitionError(
                f"{self.name}: {what} may depend on parameters only, not {sorted(map(str, extra))}"
            )
        return value[0]

    def discontinuous(self, where: str, *, smoothed_by=None) -> None:
        """Declare that the closed loop's right-hand side is discontinuous (e.g. ``sgn(s)``), unless a parameter is > 0.

        An adaptive integrator (``integrator = "dopri45"``) then warns when the flown parameters leave it
        discontinuous: its step size collapses near the switching surface.

        Parameters
        ----------
        where : str
            Where, in words (the warning quotes it), e.g. ``"sgn(s) of the switching term u^D (eq 18)"``.
        smoothed_by : str, Symbol or None
            The scalar numeric parameter (its name or the symbol :meth:`parameter` returned, range ``0 <= x``)
            whose positive value makes the law continuous (e.g. a boundary layer, Remark 7); None when no parameter
            does.

        Raises
        ------
        LawDefinitionError
            A second declaration, an empty ``where``, or ``smoothed_by`` that is no scalar numeric parameter of
            range ``0 <= x``.

        Examples
        --------
        >>> from fsmctl.symbolic import LawBuilder
        >>> b = LawBuilder("smc", doc="sliding mode")
        >>> phi = b.parameter("phi", 0.0, minimum=0.0, doc="boundary layer")
        >>> b.discontinuous("sgn(s)", smoothed_by=phi)
        """
        if self._discontinuity is not None:
            raise LawDefinitionError(f"{self.name}: discontinuous() is declared twice")
        if not isinstance(where, str) or not where.strip():
            raise LawDefinitionError(f"{self.name}: discontinuous(): say where, in words (e.g. 'sgn(s)')")
        name = None
        if smoothed_by is not None:
            p = self._declared_parameter(smoothed_by, "discontinuous(smoothed_by=...)")
            if p.size != 1 or p.choices or p.minimum != 0 or p.problem(0.0) is not None:
                raise LawDefinitionError(
                    f"{self.name}: discontinuous(smoothed_by={p.name}): must be a scalar numeric parameter whose "
                    f"range is 0 <= x (0: discontinuous, > 0: smoothed), got range {p.range_text()}"
                )
            name = p.name
        self._discontinuity = Discontinuity(where.strip(), name)

    def preset_group(self, name: str, *, default: str, options: Mapping[str, Mapping], doc: str = "") -> None:
        """Declare a named group of parameter presets that a scenario selects with one ``[controller]`` key.

        E.g. the paper's surfaces (Sec. 3.3): ``surface = "tsm"`` sets ``c1 = 0``, ``"lsm"`` sets ``c2 = 0``.

        Parameters
        ----------
        name : str
            The group's name, the ``[controller]`` key; not a parameter's name nor a key every law shares
            (:data:`SHARED_CONTROLLER_KEYS`).
        default : str
            The option that applies when the scenario selects none; it must not change any parameter's default.
        options : mapping of str to mapping
            Each option's name and the values it sets, by parameter (its name or its symbol): a number, ``size``
            numbers, or one of an option parameter's choices.
        doc : str
            What the group chooses.

        Raises
        ------
        LawDefinitionError
            A bad or clashing name, a default that is no option or changes a default, an option that names an
            undeclared parameter or a value outside its declared range.

        Examples
        --------
        >>> from fsmctl.symbolic import LawBuilder
        >>> b = LawBuilder("smc", doc="sliding mode")
        >>> c1 = b.parameter("c1", 0.6, minimum=0.0)
        >>> c2 = b.parameter("c2", 0.8, minimum=0.0)
        >>> b.preset_group("surface", default="fsm", options={"fsm": {}, "tsm": {c1: 0}, "lsm": {"c2": 0}})
        """
        if not isinstance(name, str) or not _NAME.match(name):
            raise LawDefinitionError(f"{self.name}: preset group name must be letters, digits and _, got {name!r}")
        if name in SHARED_CONTROLLER_KEYS:
            raise LawDefinitionError(
                f"{self.name}: preset group {name!r} clashes with a [controller] key every law shares "
                f"({', '.join(SHARED_CONTROLLER_KEYS)})"
            )
        if name in {p.name for p in self._parameters}:
            raise LawDefinitionError(f"{self.name}: preset group {name!r} clashes with the parameter of that name")
        if name in {g.name for g in self._presets}:
            raise LawDefinitionError(f"{self.name}: preset group {name!r} is declared twice")
        if not isinstance(options, Mapping) or not options:
            raise LawDefinitionError(f"{self.name}: preset group {name}: options must be a non-empty mapping")
        packed = []
        for option, sets in options.items():
            if not isinstance(option, str) or not _NAME.match(option):
                raise LawDefinitionError(
                    f"{self.name}: preset group {name}: option names are letters, digits and _, got {option!r}"
                )
            if not isinstance(sets, Mapping):
                raise LawDefinitionError(
                    f"{self.name}: preset group {name}: option {option} must map parameters to values"
                )
            values = {}
            for key, value in sets.items():
                p = self._declared_parameter(key, f"preset {name}={option}")
                where = f"{self.name}: preset {name}={option}: {p.name}"
                if p.name in values:
                    raise LawDefinitionError(f"{where} is set twice")
                if p.choices:
                    if value not in p.choices:
                        raise LawDefinitionError(f"{where}: {value!r} is not one of {p.choices}")
                    values[p.name] = (float(p.choices.index(value)),)
                    continue
                numbers = _floats(value, where)
                if len(numbers) == 1 and p.size > 1:
                    numbers = numbers * p.size
                if len(numbers) != p.size:
                    raise LawDefinitionError(f"{where}: {len(numbers)} numbers for a parameter of size {p.size}")
                for v in numbers:
                    if (why := p.problem(v)) is not None:
                        raise LawDefinitionError(f"{where}: {why}")
                values[p.name] = numbers
            packed.append((option, tuple(values.items())))
        if default not in options:
            raise LawDefinitionError(
                f"{self.name}: preset group {name}: default {default!r} is not one of its options {list(options)}"
            )
        for pname, values in dict(packed)[default]:
            if values != self._declared_parameter(pname, "preset").default:
                raise LawDefinitionError(
                    f"{self.name}: preset group {name}: the default option {default} changes the default of {pname} "
                    "(a parameter no one sets takes its declared default)"
                )
        self._presets.append(PresetGroup(name, default, tuple(packed), str(doc)))

    def loop_rates(self, *, surface, layer=0, doc: str = "") -> None:
        """Declare bounds on the closed loop's fastest rates (1/s), in the parameters only.

        ``fsmctl.simulation.step_size_report`` judges the RK4 step with them (evaluated per agent, the largest
        taken); a law that declares none is judged by a finite-difference linearisation at the initial state.

        Parameters
        ----------
        surface : Expr
            The rate of the law's own loop (e.g. ``c1 + c2 r1`` on the paper's surface).
        layer : Expr
            The further rate of the switching term where it is linear (e.g. ``max_k delta_k / phi``), 0 if none.
        doc : str
            How the bounds come about (the step-size report names them).

        Raises
        ------
        LawDefinitionError
            A second declaration, or an expression that is not a scalar in the parameters.

        Examples
        --------
        >>> from fsmctl.symbolic import LawBuilder
        >>> b = LawBuilder("pd", doc="PD")
        >>> K = b.parameter("K", 2.0, minimum=0.0)
        >>> b.loop_rates(surface=K, doc="the attitude gain K")
        """
        if self._loop_rates is not None:
            raise LawDefinitionError(f"{self.name}: loop_rates() is declared twice")
        self._loop_rates = LoopRates(
            self._parameter_expression(surface, "loop_rates(surface=...)"),
            self._parameter_expression(layer, "loop_rates(layer=...)"),
            str(doc),
        )

    def paper_theorems(self, **parameters) -> None:
        """Declare that this law is Liang et al. 2012's eqs 13-19 with these parameters, so Theorems 1-2 apply.

        Theorem 1 then constrains the coupling weights of eq 19 and Theorem 2 the switching gain; the tools
        that check them (``fsmctl prove``, ``fsmctl montecarlo``, ``fsmctl tune``) read the parameters named
        here, and ``fsmctl prove --law`` checks the claim: the isolated agent's closed loop must be eq 20 and the
        broadcast eq 13 (``closed-loop-eq20``), else the check fails.

        Parameters
        ----------
        **parameters
            One parameter (the symbol :meth:`parameter` returned) for each of :data:`PAPER_THEOREM_ROLES`:
            ``c1``, ``c2``, ``alpha``, ``boundary_layer``, ``epsilon`` (scalars), ``singularity_fix`` (an option
            with the choices none, switch, clamp) and ``delta`` (3 components).

        Raises
        ------
        LawDefinitionError
            A second declaration, a missing or unknown role, or a parameter of the wrong kind.
        """
        if self._paper_theorems is not None:
            raise LawDefinitionError(f"{self.name}: paper_theorems() is declared twice")
        given, wanted = set(parameters), set(PAPER_THEOREM_ROLES)
        if given != wanted:
            missing, unknown = sorted(wanted - given), sorted(given - wanted)
            raise LawDefinitionError(
                f"{self.name}: paper_theorems(): "
                + "; ".join(
                    ([f"missing {', '.join(missing)}"] if missing else [])
                    + ([f"unknown {', '.join(unknown)}"] if unknown else [])
                )
                + f" (it takes {', '.join(PAPER_THEOREM_ROLES)})"
            )
        names = []
        for role in PAPER_THEOREM_ROLES:
            p = self._declared_parameter(parameters[role], f"paper_theorems({role}=...)")
            if role == "singularity_fix":
                ok = p.choices == ("none", "switch", "clamp")
                kind = "an option with the choices none, switch, clamp"
            elif role == "delta":
                ok, kind = p.size == 3 and not p.choices, "a numeric parameter of 3 components"
            else:
                ok, kind = p.size == 1 and not p.choices, "a scalar numeric parameter"
            if not ok:
                raise LawDefinitionError(f"{self.name}: paper_theorems({role}={p.name}): must be {kind}")
            names.append((role, p.name))
        self._paper_theorems = PaperTheorems(tuple(names))

    # -- build --------------------------------------------------------------------------------------
    def build(self) -> Law:
        """Check the law against the contract and split it into the generated functions.

        Returns
        -------
        Law
            The checked law; its stages are split into those evaluated with the broadcast and those that read
            what the agent receives.

        Raises
        ------
        LawDefinitionError
            No broadcast or torque, a state without a derivative, a symbol that is no input of the law, or a
            broadcast that depends on what the agent receives.
        """
        if self._broadcast is None:
            raise LawDefinitionError(f"{self.name}: no broadcast declared (what the agent sends to its neighbours)")
        if self._torque is None:
            raise LawDefinitionError(f"{self.name}: no torque declared")
        if self._wheels is not None and self._wheel_torques is None:
            raise LawDefinitionError(
                f"{self.name}: reaction_wheels({self._wheels.n}) is declared but no wheel_torques() (the commands)"
            )
        missing = [s.name for s in self._states if s.name not in self._derivatives]
        if missing:
            raise LawDefinitionError(f"{self.name}: states without a derivative: {missing}")
        n_params = len(self._param_symbols)
        symbols = {
            "t": sp.ImmutableMatrix([self.t]),
            "sigma": self.sigma,
            "omega": self.omega,
            "z": sp.ImmutableMatrix(self._state_symbols) if self._state_symbols else sp.ImmutableMatrix.zeros(0, 1),
            "sigma_d": self.sigma_d,
            "omega_d": self.omega_d,
            "omega_d_dot": self.omega_d_dot,
            "J0": self.J0,
            "params": sp.ImmutableMatrix(self._param_symbols) if n_params else sp.ImmutableMatrix.zeros(0, 1),
        }
        const_syms = [s for _, m, _ in self._constants for s in m]
        symbols["constants"] = sp.ImmutableMatrix(const_syms) if const_syms else sp.ImmutableMatrix.zeros(0, 1)
        agent = set().union(*(m.free_symbols for m in symbols.values()))
        neighbour = set().union(*(m.free_symbols for m in self._neighbour.values()))
        wheel_inputs = set()
        if self._wheels is not None:  # the wheels' inputs, and the ideal actuator's limit (b.u_max)
            wheel_inputs = set().union(*(m.free_symbols for m in self._wheels.symbols.values()), {_U_MAX})
        # split the stages: a stage is on the control side if it reads a neighbour input or a control stage, on the
        # wheels' side (law_wheels_* only) if it reads a wheel input or a wheel stage
        local, control, control_syms = [], [], set(neighbour)
        wheel, wheel_syms = [], set(wheel_inputs)
        known = set(agent)
        for name, syms, value in self._stages:
            free = value.free_symbols
            unknown = free - known - neighbour - set(self._param_symbols) - wheel_syms
            if unknown:
                raise LawDefinitionError(
                    f"{self.name}: stage {name} uses symbols that are no input of the law: {sorted(map(str, unknown))}"
                )
            if free & wheel_syms:
                wheel.append((name, syms, value))
                wheel_syms |= set(syms)
                continue
            (control if free & control_syms else local).append((name, syms, value))
            if free & control_syms:
                control_syms |= set(syms)
            known |= set(syms)
        bname, bvalue = self._broadcast
        outputs = {"broadcast": bvalue, "torque": self._torque}
        derivative = (
            sp.ImmutableMatrix.vstack(*(self._derivatives[s.name] for s in self._states))
            if self._states
            else sp.ImmutableMatrix.zeros(0, 1)
        )
        outputs["state derivative"] = derivative
        for what, value in outputs.items():
            if value.free_symbols & wheel_syms:
                raise LawDefinitionError(
                    f"{self.name}: {what} reads the wheels (reaction_wheels()); only wheel_torques() may (an ideal "
                    "actuator flies the law without wheels)"
                )
            unknown = value.free_symbols - known - neighbour
            if unknown:
                raise LawDefinitionError(
                    f"{self.name}: {what} uses symbols that are no input of the law: {sorted(map(str, unknown))}"
                )
        if bvalue.free_symbols & control_syms:
            raise LawDefinitionError(f"{self.name}: the broadcast must not depend on what the agent receives")
        if self._wheel_torques is not None:
            unknown = self._wheel_torques.free_symbols - known - neighbour - wheel_syms
            if unknown:
                raise LawDefinitionError(
                    f"{self.name}: wheel_torques uses symbols that are no input of the law: {sorted(map(str, unknown))}"
                )
        # the local stages the control side (and the wheels' side) reads
        needed = set().union(self._torque.free_symbols, derivative.free_symbols)
        if self._wheel_torques is not None:
            needed |= self._wheel_torques.free_symbols
        for _, _, value in (*control, *wheel):
            needed |= value.free_symbols
        cache = tuple((name, syms) for name, syms, _ in local if set(syms) & needed)
        symbols["cache"] = (
            sp.ImmutableMatrix([s for _, m in cache for s in m]) if cache else sp.ImmutableMatrix.zeros(0, 1)
        )
        symbols.update(self._neighbour)
        symbols["u_max"] = sp.ImmutableMatrix([_U_MAX])
        if self._wheels is not None:
            symbols.update(self._wheels.symbols)
        return Law(
            name=self.name,
            doc=self.doc,
            reference=self.reference,
            error_model=self.error_model,
            parameters=tuple(self._parameters),
            states=tuple(self._states),
            broadcast_name=bname,
            symbols=symbols,
            constants=tuple(self._constants),
            local_stages=tuple(local),
            control_stages=tuple(control),
            cache=cache,
            broadcast=bvalue,
            torque=self._torque,
            state_derivative=derivative,
            lyapunov=self._lyapunov,
            batched=self.batched,
            broadcast_unit=self._broadcast_unit,
            discontinuity=self._discontinuity,
            presets=tuple(self._presets),
            loop_rates=self._loop_rates,
            paper_theorems=self._paper_theorems,
            wheel_stages=tuple(wheel),
            wheel_torques=self._wheel_torques,
            trigger=self._trigger,
        )


@dataclass(frozen=True)
class LawVariants:
    """A law derived for both error models (what a derivation script's ``law(error_model)`` yields)."""

    paper: Law
    exact: Law
    extra: tuple[FunctionSpec, ...] = field(default=())

    @property
    def name(self) -> str:
        return self.paper.name

    def __iter__(self):
        return iter((self.paper, self.exact))


def law_variants(build, extra: Sequence[FunctionSpec] = ()) -> LawVariants:
    """Call a derivation script's ``law(error_model)`` for both error models and check they agree."""
    laws = []
    for model in (ErrorModel.PAPER, ErrorModel.EXACT):
        law = build(model)
        if not isinstance(law, Law):
            raise LawDefinitionError(
                f"law({model.value!r}) must return LawBuilder(...).build(), got {type(law).__name__}"
            )
        if law.error_model is not model:
            raise LawDefinitionError(f"law({model.value!r}) built a law for the {law.error_model.value} error model")
        laws.append(law)
    a, b = laws
    for what in (
        "name", "parameters", "states", "broadcast_name", "n_broadcast", "n_constants",
        "discontinuity", "presets", "loop_rates", "paper_theorems", "n_wheels", "trigger",
    ):  # fmt: skip
        if getattr(a, what) != getattr(b, what):
            raise LawDefinitionError(f"{a.name}: the paper and exact variants differ in {what}")
    return LawVariants(a, b, tuple(extra))
