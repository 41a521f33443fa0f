"""The paper's parameter set, declared once for every law built on its fast sliding surface.

:func:`declare_fsm_parameters` declares, on a :class:`~fsmctl.symbolic.law.LawBuilder`, the parameters of
Liang, Sun & Wang (2012), eqs 13-19 and Remarks 6-7, in this order: ``c1``, ``c2``, ``alpha`` (the surface,
eq 13), ``boundary_layer`` (Remark 7), ``epsilon`` and ``singularity_fix`` (Remark 6) and ``delta`` (eq 18);
a law that has no boundary layer or no fixed switching gain leaves those out.  The built-in laws ``fsm``,
``fsm_wheels``, ``adaptive_fsm`` and ``super_twisting`` use it, so the paper's defaults, units, ranges and meanings
are written once.  :func:`declare_paper_law` declares the whole law (``fsm``, and ``fsm_wheels``'s body torque).

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import sympy as sp

from fsmctl.symbolic.controller import computed_torque_pieces, coordination_term
from fsmctl.symbolic.law import LawBuilder
from fsmctl.symbolic.surfaces import fast_sliding_surface

__all__ = ["FsmParameters", "declare_fsm_parameters", "declare_paper_law", "declare_surface_presets", "fsm_loop_rates"]

SINGULARITY_FIXES: tuple[str, ...] = ("none", "switch", "clamp")
"""Remark 6's devices, in the order of :class:`fsmctl.symbolic.controller.SingularityFix` (the packed index)."""


@dataclass(frozen=True)
class FsmParameters:
    """The symbols :func:`declare_fsm_parameters` returns (None for a parameter the law leaves out)."""

    c1: sp.Symbol
    c2: sp.Symbol
    alpha: sp.Symbol
    boundary_layer: sp.Symbol | None
    epsilon: sp.Symbol
    singularity_fix: sp.Symbol
    delta: sp.ImmutableMatrix | None


def declare_fsm_parameters(
    b: LawBuilder,
    *,
    c1: float = 0.6,
    c2: float = 0.8,
    alpha: float = 0.7,
    boundary_layer: float | None = 0.0,
    epsilon: float = 1e-4,
    singularity_fix: str = "switch",
    delta: Sequence[float] | None = (0.005, 0.005, 0.005),
) -> FsmParameters:
    """Declare the paper's parameters on ``b`` (Liang et al. 2012, eqs 13-19, Remarks 6-7) and return their symbols.

    Parameters
    ----------
    b : LawBuilder
        The law being built.
    c1, c2 : float
        Defaults of the surface gains (1/s; the paper's 0.6 and 0.8).
    alpha : float
        Default of the exponent of ``sig(sigma_e)^alpha``, ``0.5 < alpha < 1`` (the paper scenario's 0.7).
    boundary_layer : float or None
        Default of ``phi`` of ``sat(s/phi)`` (1/s; 0: ``sgn``); None for a law without a boundary layer.
    epsilon : float
        Default half-width of the Remark 6 band (MRP units).
    singularity_fix : str
        Default Remark 6 device: ``"none"``, ``"switch"`` or ``"clamp"``.
    delta : sequence of 3 float or None
        Default switching gain of ``u^D`` per axis (1/s^2, eq 18); None for a law without a fixed gain.

    Returns
    -------
    FsmParameters
        The symbols, in the order declared.

    Raises
    ------
    LawDefinitionError
        A default outside the parameter's range, or a name the law already uses.

    Examples
    --------
    >>> from fsmctl.symbolic import LawBuilder
    >>> from fsmctl.symbolic.fsm_parameters import declare_fsm_parameters
    >>> b = LawBuilder("smc", doc="sliding mode on the paper's surface")
    >>> p = declare_fsm_parameters(b, boundary_layer=None)
    >>> p.c1, p.boundary_layer, p.delta.T
    (c1, None, Matrix([[delta[0], delta[1], delta[2]]]))
    """
    s_c1 = b.parameter("c1", c1, unit="1/s", minimum=0.0, doc="linear gain of the surface s (eq 13)")
    s_c2 = b.parameter("c2", c2, unit="1/s", minimum=0.0, doc="terminal gain of the surface (eq 13)")
    s_alpha = b.parameter(
        "alpha", alpha, minimum=0.5, maximum=1.0, exclusive_minimum=True, exclusive_maximum=True,
        doc="exponent of sig(sigma_e)^alpha (eq 13)",
    )  # fmt: skip
    s_phi = None
    if boundary_layer is not None:
        s_phi = b.parameter(
            "boundary_layer", boundary_layer, unit="1/s", minimum=0.0, doc="phi of sat(s/phi) (Remark 7); 0: sgn"
        )
    s_epsilon = b.parameter(
        "epsilon", epsilon, minimum=0.0, exclusive_minimum=True, doc="band of the Remark 6 fix (MRP units)"
    )
    s_fix = b.parameter(
        "singularity_fix", singularity_fix, choices=SINGULARITY_FIXES,
        doc="Remark 6 device near sigma_e = 0: C^1 'switch' extension, 'clamp' of the slope, or 'none'",
    )  # fmt: skip
    s_delta = None
    if delta is not None:
        s_delta = b.parameter(
            "delta", list(delta), unit="1/s^2", minimum=0.0, exclusive_minimum=True,
            doc="switching gain of u^D (eq 18), per axis; a scenario's agents may set their own",
        )  # fmt: skip
    return FsmParameters(s_c1, s_c2, s_alpha, s_phi, s_epsilon, s_fix, s_delta)


def fsm_loop_rates(p: FsmParameters) -> dict[str, sp.Expr]:
    """The paper's loop rates (1/s) in its parameters, for :meth:`~fsmctl.symbolic.law.LawBuilder.loop_rates`.

    * ``surface = c1 + c2 r1``: ``sigma_e`` decays on the surface (eq 13) at ``c1 + c2 d sig(x)^alpha/dx``, whose
      slope is largest in the Remark 6 band: ``r1 = (2 - alpha) epsilon^(alpha-1)`` for ``switch``,
      ``alpha epsilon^(alpha-1)`` for ``clamp`` and, since the printed law (``none``) is unbounded as
      ``sigma_e -> 0``, also that band-edge value for ``none`` (an underestimate);
    * ``layer = max_k delta_k / phi``: inside the boundary layer ``sat(s/phi)`` (Remark 7) ``s`` decays at
      ``delta/phi`` (0 for ``sgn``, which has no time constant; 0 for a law without ``phi`` or ``delta``).

    Parameters
    ----------
    p : FsmParameters
        The symbols :func:`declare_fsm_parameters` returned.

    Returns
    -------
    dict
        ``{"surface": expr, "layer": expr, "doc": str}``: the keyword arguments of ``loop_rates``.

    Examples
    --------
    >>> from fsmctl.symbolic import LawBuilder
    >>> p = declare_fsm_parameters(LawBuilder("smc", doc="sliding mode"))
    >>> rates = fsm_loop_rates(p)
    >>> float(rates["surface"].subs({p.c1: 0.6, p.c2: 0.8, p.alpha: 0.5, p.epsilon: 0.01, p.singularity_fix: 1}))
    12.6
    """
    band_power = p.epsilon ** (p.alpha - 1)
    slope = sp.Piecewise(
        ((2 - p.alpha) * band_power, sp.Eq(p.singularity_fix, SINGULARITY_FIXES.index("switch"))),
        (p.alpha * band_power, True),
    )
    layer = sp.Integer(0)
    if p.boundary_layer is not None and p.delta is not None:
        layer = sp.Piecewise((sp.Max(*p.delta) / p.boundary_layer, p.boundary_layer > 0), (0, True))
    return {
        "surface": p.c1 + p.c2 * slope,
        "layer": layer,
        "doc": "surface c1 + c2 r1, r1 = the slope of the Remark 6 term at sigma_e = 0 (eq 13); boundary layer "
        "max delta_k/phi (Remark 7)",
    }


def declare_surface_presets(b: LawBuilder, p: FsmParameters) -> None:
    """Declare the preset group ``surface`` of Sec. 3.3: ``fsm`` (eq 13, the default), ``tsm`` and ``lsm``.

    ``surface = "tsm"`` under ``[controller]`` gives the terminal sliding surface (``c1 = 0``), ``"lsm"`` the
    linear one (``c2 = 0``); ``"fsm"`` changes nothing.

    Parameters
    ----------
    b : LawBuilder
        The law being built.
    p : FsmParameters
        The symbols :func:`declare_fsm_parameters` returned.

    Examples
    --------
    >>> from fsmctl.symbolic import LawBuilder
    >>> b = LawBuilder("smc", doc="sliding mode")
    >>> declare_surface_presets(b, declare_fsm_parameters(b))
    """
    b.preset_group(
        "surface", default="fsm", options={"fsm": {}, "tsm": {p.c1: 0.0}, "lsm": {p.c2: 0.0}},
        doc="the sliding surface of Sec. 3.3: fsm (eq 13), tsm (terminal: c1 = 0) or lsm (linear: c2 = 0)",
    )  # fmt: skip


def declare_paper_law(b: LawBuilder, *, theorems: bool = True) -> sp.ImmutableMatrix:
    """Declare the paper's law on ``b`` and return its body torque, for ``b.torque`` (Liang et al. 2012, eqs 13-19).

    Declares, in this order: the parameters (:func:`declare_fsm_parameters`, the paper's defaults), the claim that
    the law is eqs 13-19 (``paper_theorems``; not with ``theorems=False``, for a variant the theorems do not cover), the discontinuity ``sgn(s)`` smoothed by ``boundary_layer``, the loop
    rates (:func:`fsm_loop_rates`), the ``surface`` presets (:func:`declare_surface_presets`) and the broadcast
    ``s`` (eq 13, 1/s).  The torque is eq 16 in computed-torque form with the coordination term of eq 19, every
    fractional power from the surface's shared slope.  The built-in ``fsm`` is this law; ``fsm_wheels`` flies the
    same body torque through its wheels, ``fsm_event`` broadcasts ``s`` on a trigger (``theorems=False``: the
    theorems assume continuous coordination), and the explainer's unswitched variant builds it on another error
    state.

    Parameters
    ----------
    b : LawBuilder
        The law being built (nothing declared yet).
    theorems : bool
        Declare ``paper_theorems`` (Theorems 1-2 apply to the law as the paper flies it).

    Returns
    -------
    sympy.ImmutableMatrix
        The commanded body torque (3 components, N m).

    Examples
    --------
    >>> from fsmctl.symbolic import LawBuilder
    >>> from fsmctl.symbolic.fsm_parameters import declare_paper_law
    >>> b = LawBuilder("fsm_copy", doc="the paper's law")
    >>> b.torque(declare_paper_law(b))
    >>> law = b.build()
    >>> law.broadcast_name, law.n_params, law.paper_theorems.parameter("delta")
    ('s', 9, 'delta')
    """
    p = declare_fsm_parameters(b)
    c1, c2, alpha, phi, epsilon, fix, delta = (
        p.c1, p.c2, p.alpha, p.boundary_layer, p.epsilon, p.singularity_fix, p.delta
    )  # fmt: skip
    if theorems:
        b.paper_theorems(
            c1=c1, c2=c2, alpha=alpha, boundary_layer=phi, epsilon=epsilon, singularity_fix=fix, delta=delta
        )  # fmt: skip
    b.discontinuous("sgn(s) of the switching term u^D (eq 18)", smoothed_by=phi)
    b.loop_rates(**fsm_loop_rates(p))
    declare_surface_presets(b, p)
    surface = fast_sliding_surface(b, c1, c2, alpha, epsilon, fix)
    e, s = surface.error, surface.s
    b.broadcast("s", s, unit="1/s")
    pieces = computed_torque_pieces(
        b.J0, e.sigma_e, e.omega_e, e.omega_r, e.omega_r_dot, s, c1, c2, alpha, delta,
        coordination_term(s, b.k_sum, b.received), boundary_layer=phi, fix=fix, epsilon=epsilon,
    )  # fmt: skip
    return surface.with_shared_slope(pieces.u, "FSM torque")  # every fractional power comes from the shared slope
