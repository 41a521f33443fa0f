"""The paper's FSM law with the error MRP *not* switched to the shadow set (for ``fsmctl reproduce``'s explanations).

A copy of ``derive/laws/fsm.py`` (Liang, Sun & Wang 2012, eqs 13, 16-19, Remarks 6-7) whose error MRP is the
direct MRP composition ``sigma_e = sigma (x) sigma_d^-1`` (:func:`fsmctl.symbolic.mrp.mrp_compose` of
``sigma`` and ``-sigma_d``) instead of :func:`fsmctl.symbolic.mrp.mrp_error`, which returns the shadow-set
member (``|sigma_e| <= 1``, principal angle <= 180 deg).  Unswitched, ``|sigma_e|`` may exceed 1 (principal
angle ``4 atan|sigma_e|`` up to 360 deg), and the law then drives the error to zero along the long rotation.
The plant's own MRPs are still switched after every step (the engine's rule), so ``sigma_e`` jumps to its
shadow whenever ``sigma`` or ``sigma_d`` is switched.

``SHADOW_SWITCH`` is the only difference from the built-in law: with ``SHADOW_SWITCH = True`` this script
builds the error state with the standard :meth:`fsmctl.symbolic.law.LawBuilder.error_state` and flies
bit-identically to the built-in ``fsm`` law (``tests/test_explain.py``).

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

from fsmctl.symbolic.controller import computed_torque_pieces, coordination_term
from fsmctl.symbolic.law import ErrorState, Law, LawBuilder
from fsmctl.symbolic.model import reference_acceleration_in_body, reference_rate_in_body
from fsmctl.symbolic.mrp import mrp_compose
from fsmctl.symbolic.surfaces import fast_sliding_surface

SHADOW_SWITCH = False
"""False: the error MRP is the unswitched composition; True: the standard (shadow-set) error state."""

REFERENCE = "Liang, Sun & Wang, Acta Astronautica 81 (2012) 445-455, eqs 13, 16-19, Remarks 6-7"


class _ErrorStateBuilder(LawBuilder):
    """A :class:`LawBuilder` whose error state follows :data:`SHADOW_SWITCH`."""

    _unswitched: ErrorState | None = None

    def error_state(self) -> ErrorState:
        """The error state (Liang et al. 2012, eqs 5-8); unswitched ``sigma_e`` unless :data:`SHADOW_SWITCH`."""
        if SHADOW_SWITCH:
            return super().error_state()
        if self._unswitched is None:
            se = self.stage("sigma_e", mrp_compose(self.sigma, -self.sigma_d))
            wr = self.stage("omega_r", reference_rate_in_body(self.error_model, se, self.omega_d))
            we = self.stage("omega_e", self.omega - wr)
            wrd = self.stage(
                "omega_r_dot", reference_acceleration_in_body(self.error_model, se, we, self.omega_d, self.omega_d_dot)
            )
            self._unswitched = ErrorState(se, we, wr, wrd)
        return self._unswitched


def law(error_model) -> Law:
    """The FSM law of ``derive/laws/fsm.py`` with the error state of :data:`SHADOW_SWITCH`."""
    b = _ErrorStateBuilder(
        "fsm_shadow" if SHADOW_SWITCH else "fsm_unswitched",
        error_model,
        doc="fast sliding mode with neighbour coordination (the paper's law)"
        + ("" if SHADOW_SWITCH else ", error MRP not switched to the shadow set"),
        reference=REFERENCE,
    )
    c1 = b.parameter("c1", 0.6, unit="1/s", minimum=0.0, doc="linear gain of the surface s (eq 13)")
    c2 = b.parameter("c2", 0.8, unit="1/s", minimum=0.0, doc="terminal gain of the surface (eq 13)")
    alpha = b.parameter(
        "alpha", 0.7, minimum=0.5, maximum=1.0, exclusive_minimum=True, exclusive_maximum=True,
        doc="exponent of sig(sigma_e)^alpha (eq 13)",
    )  # fmt: skip
    phi = b.parameter("boundary_layer", 0.0, unit="1/s", minimum=0.0, doc="phi of sat(s/phi) (Remark 7); 0: sgn")
    epsilon = b.parameter(
        "epsilon", 1e-4, minimum=0.0, exclusive_minimum=True, doc="band of the Remark 6 fix (MRP units)"
    )
    fix = b.parameter(
        "singularity_fix", "switch", choices=("none", "switch", "clamp"),
        doc="Remark 6 device near sigma_e = 0: C^1 'switch' extension, 'clamp' of the slope, or 'none'",
    )  # fmt: skip
    delta = b.parameter(
        "delta", [0.005, 0.005, 0.005], unit="1/s^2", minimum=0.0, exclusive_minimum=True,
        doc="switching gain of u^D (eq 18), per axis; a scenario's agents may set their own",
    )  # fmt: skip
    surface = fast_sliding_surface(b, c1, c2, alpha, epsilon, fix)
    e, s = surface.error, surface.s
    b.broadcast("s", s, unit="1/s")

    pieces = computed_torque_pieces(
        b.J0, e.sigma_e, e.omega_e, e.omega_r, e.omega_r_dot, s, c1, c2, alpha, delta,
        coordination_term(s, b.k_sum, b.received), boundary_layer=phi, fix=fix, epsilon=epsilon,
    )  # fmt: skip
    u = surface.with_shared_slope(pieces.u, "FSM torque")  # every fractional power comes from the shared slope
    b.torque(u)
    return b.build()
