"""The paper's fast-sliding-mode law (Liang, Sun & Wang 2012, eqs 13, 16-19, Remarks 6-7).

Written with the public law API, as a user would, in :func:`fsmctl.symbolic.fsm_parameters.declare_paper_law`
(shared with ``fsm_wheels``, which flies the same body torque through its wheels): the sliding variable ``s``
(eq 13) is what an agent broadcasts, and the torque is eq 16 in computed-torque form (``fsmctl.symbolic.controller``; the form that
``fsmctl.proofs.identities`` proves equal to eqs 17-19) with the coordination term of eq 19,
``sum_j (k^i_ij s_i - k^j_ij s_j) = k_sum s_i - received``.  The TSM and LSM surfaces of Section 3.3 are
``c1 = 0`` and ``c2 = 0``.  The powers ``|sigma_e,k|^alpha`` are computed once and shared by the surface and
the eq 17 slope (the generated code has three ``pow`` calls per agent instead of nine).

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

from fsmctl.symbolic.fsm_parameters import declare_paper_law
from fsmctl.symbolic.law import Law, LawBuilder

REFERENCE = "Liang, Sun & Wang, Acta Astronautica 81 (2012) 445-455, eqs 13, 16-19, Remarks 6-7"


def law(error_model) -> Law:
    b = LawBuilder(
        "fsm",
        error_model,
        doc="fast sliding mode with neighbour coordination (the paper's law; TSM with c1 = 0, LSM with c2 = 0)",
        reference=REFERENCE,
    )
    b.torque(declare_paper_law(b))  # parameters, theorems, presets, broadcast s (eq 13); torque eq 16 + eq 19
    return b.build()
