"""The paper's fast-sliding-mode law (Liang, Sun & Wang 2012, eqs 13, 16-19, Remarks 6-7).

Written with the public law API, as a user would: the sliding variable ``s`` (eq 13) is what an agent
broadcasts, and the torque is eq 16 in computed-torque form (``fsmctl.symbolic.controller``; the form that
``fsmctl.proofs.identities`` proves equal to eqs 17-19) with the coordination term of eq 19,
``sum_j (k^i_ij s_i - k^j_ij s_j) = k_sum s_i - received``.  The TSM and LSM surfaces of Section 3.3 are
``c1 = 0`` and ``c2 = 0``.  The powers ``|sigma_e,k|^alpha`` are computed once and shared by the surface and
the eq 17 slope (the generated code has three ``pow`` calls per agent instead of nine).

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

from fsmctl.symbolic.controller import (
    computed_torque_pieces,
    coordination_term,
)
from fsmctl.symbolic.fsm_parameters import declare_fsm_parameters, declare_surface_presets, fsm_loop_rates
from fsmctl.symbolic.law import Law, LawBuilder
from fsmctl.symbolic.surfaces import fast_sliding_surface

REFERENCE = "Liang, Sun & Wang, Acta Astronautica 81 (2012) 445-455, eqs 13, 16-19, Remarks 6-7"


def law(error_model) -> Law:
    b = LawBuilder(
        "fsm",
        error_model,
        doc="fast sliding mode with neighbour coordination (the paper's law; TSM with c1 = 0, LSM with c2 = 0)",
        reference=REFERENCE,
    )
    b.torque(declare_fsm(b))
    return b.build()


def declare_fsm(b: LawBuilder):
    """Declare the paper's law on ``b`` (parameters, theorems, discontinuity, loop rates, presets, broadcast ``s``)
    and return its body torque (eq 16 with the coordination term of eq 19), for ``b.torque``."""
    p = declare_fsm_parameters(b)
    c1, c2, alpha, phi, epsilon, fix, delta = (
        p.c1, p.c2, p.alpha, p.boundary_layer, p.epsilon, p.singularity_fix, p.delta
    )  # fmt: skip
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
