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
