"""The paper's FSM law with the error MRP *not* switched to the shadow set (for ``fsmctl reproduce``'s explanations).

The law of ``derive/laws/fsm.py`` (Liang, Sun & Wang 2012, eqs 13, 16-19, Remarks 6-7; declared by
:func:`fsmctl.symbolic.fsm_parameters.declare_paper_law`, without the claim that Theorems 1-2 cover it) whose error
MRP is the
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

from fsmctl.symbolic.fsm_parameters import declare_paper_law
from fsmctl.symbolic.law import ErrorState, Law, LawBuilder
from fsmctl.symbolic.model import reference_acceleration_in_body, reference_rate_in_body
from fsmctl.symbolic.mrp import mrp_compose

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
    b.torque(declare_paper_law(b, theorems=False))  # the paper's law on this builder's error state
    return b.build()
