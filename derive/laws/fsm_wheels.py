"""The paper's law flown through its reaction wheels, with the wheels' momentum managed by null motion.

The body torque is the paper's fast-sliding-mode law (``derive/laws/fsm.py``: Liang, Sun & Wang 2012, eqs 13,
16-19), so on an ideal actuator this law flies exactly as ``fsm``.  On reaction wheels it commands each wheel's
motor torque itself (:meth:`~fsmctl.symbolic.law.LawBuilder.wheel_torques`) instead of leaving the minimum-norm
distribution to the engine:

    u_w = -P (u_a + G v) + v,    v = -k_h J_s (Omega - Omega_bias),    P = G^T (G G^T)^-1 = pinv(G),

with ``G`` the ``3 x N`` spin axes, ``u_a = sat(u, u_max)`` the body torque the ideal actuator would apply (what the
engine's distribution realises) and ``J_s (Omega - Omega_bias)`` the per-wheel momentum away from its bias.  Since
``G P = I``, the body feels ``-G u_w = u_a`` whatever ``v``: the extra term is ``(I - P G) v``, its projection on the
null space of ``G`` (every array of more than 3 wheels has one; a pyramid of 4 a 1-dimensional one), which moves
momentum between the wheels without touching the body (null motion; Schaub & Junkins, *Analytical Mechanics of
Space Systems*, Sec. 4.5.4 and Ch. 8, RW null motion).  Along the null space the wheels' momentum then decays toward
the bias at the rate ``k_h`` (equal spin inertias); the part of ``Omega - Omega_bias`` in the range of ``G^T`` is the
body's momentum, which only an external torque changes.  With ``k_h = 0`` the commands are the engine's
minimum-norm distribution (to round-off: ``P`` here is a closed form, the engine's ``pinv`` an SVD).

Typical use: keep the wheels away from zero speed (stiction, Coulomb friction: a bias along the null space, e.g.
``Omega_bias = b (1, -1, 1, -1)`` for the default pyramid) or spin them down after a manoeuvre.

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

import sympy as sp

from fsmctl.symbolic.controller import saturate
from fsmctl.symbolic.fsm_parameters import declare_paper_law
from fsmctl.symbolic.law import Law, LawBuilder

REFERENCE = "Liang, Sun & Wang, Acta Astronautica 81 (2012) 445-455, eqs 13, 16-19, Remarks 6-7"
N_WHEELS = 4
"""The wheels the law commands (the scenario's actuator must have as many; 4: the default pyramid)."""


def law(error_model) -> Law:
    b = LawBuilder(
        "fsm_wheels",
        error_model,
        doc=(
            "the paper's fast sliding mode (as fsm) commanding 4 reaction wheels, their momentum driven toward a "
            "bias by null motion (no change of the body torque)"
        ),
        reference=REFERENCE + "; null motion: Schaub & Junkins, Analytical Mechanics of Space Systems, Sec. 4.5.4",
    )
    u = declare_paper_law(b)  # the paper's law, as derive/laws/fsm.py declares it
    b.torque(u)
    k_h = b.parameter(
        "momentum_gain", 0.05, unit="1/s", minimum=0.0,
        doc="k_h: rate at which null motion drives the wheels' momentum toward the bias (0: minimum norm)",
    )  # fmt: skip
    bias = b.parameter(
        "speed_bias", [0.0] * N_WHEELS, unit="rad/s",
        doc="Omega_bias: the wheel speeds null motion drives toward (only their null-space part is reachable)",
    )  # fmt: skip
    w = b.reaction_wheels(N_WHEELS)
    G = w.spin_axes
    M = G * G.T  # 3 x 3, symmetric, invertible for axes that span the body
    m = b.stage("axes_gram", [M[0, 0], M[0, 1], M[0, 2], M[1, 1], M[1, 2], M[2, 2]])
    gram = sp.Matrix([[m[0], m[1], m[2]], [m[1], m[3], m[4]], [m[2], m[4], m[5]]])
    inverse = b.stage("axes_gram_inverse", list(gram.adjugate() / gram.det()))
    P = G.T * sp.Matrix(3, 3, list(inverse))  # pinv(G), N x 3
    v = b.stage("null_target", -k_h * sp.matrix_multiply_elementwise(w.spin_inertia, w.speed - bias))
    u_applied = saturate(u, b.u_max)
    b.wheel_torques(-P * (u_applied + G * v) + v)
    return b.build()
