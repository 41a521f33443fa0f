"""Super-twisting (second-order) sliding mode on the paper's fast sliding surface (law name ``super_twisting``).

The surface is the paper's (Liang, Sun & Wang 2012, eq 13, with the Remark 6 fix exactly as the ``fsm`` law):

    s = G(sigma_e) omega_e + c1 sigma_e + c2 sig(sigma_e)^alpha,

and the torque is eq 16 in computed-torque form (:func:`fsmctl.symbolic.controller.computed_torque_pieces`),
with the discontinuous reaching term ``delta o sgn(s)`` of eq 18 replaced by the super-twisting algorithm
(Levant 1993) per axis ``k``:

    u = -u^F + J0 G^-1 (v - (k_sum s - received)),
    v_k = -k1 |s_k|^(1/2) sgn(s_k) + w_k,        d/dt w_k = -k2 sgn(s_k),   w(0) = 0,

so that the nominal closed loop (``J = J0``, no disturbance) is ``s_dot = v - (k_sum s - received)``: the
super-twisting dynamics plus the paper's coordination term of eq 19
(``sum_j (k^i_ij s_i - k^j_ij s_j) = k_sum s_i - received``).  The torque is continuous in time (``w`` is the
integral of the switching), which is the point of the algorithm: no boundary layer (Remark 7) is needed to
avoid chattering, and ``s`` and ``s_dot`` reach 0 in finite time.

Sufficient conditions (isolated agent, a matched perturbation ``s_dot = v + rho(t)`` with
``|d rho/dt| <= L`` per axis):

* Levant (1993; 1998): ``k2 > L`` and ``k1^2 >= 4 L (k2 + L) / (k2 - L)``;
* Moreno & Osorio (2012, their sufficient condition with ``delta1 = 0``, ``delta2 = L``): ``k1 > 0`` and
  ``k2 > 3 L + 2 L^2 / k1^2``, from the strict Lyapunov function below.

The defaults (k1 = 0.1 s^-3/2, k2 = 0.005 s^-3) satisfy both for ``L = 1e-3 s^-3``, a design value about
ten times the rate of the paper scenario's disturbance seen on the surface (``G J^-1 d ~ d/(4J)``: 0.24 N m
at 0.15 rad/s over ``4 J >= 320 kg m^2`` gives ~1e-4 s^-3); the inertia error's share (``Delta J = 0.3 J0``)
grows with the rates, so near the reference only: no gain makes the condition global.

Lyapunov function (Moreno & Osorio 2012; per axis, nominal, isolated agent, reference at rest, ``J = J0``):

    V = sum_k 2 k2 |s_k| + 1/2 w_k^2 + 1/2 (k1 |s_k|^(1/2) sgn(s_k) - w_k)^2,
    d/dt V = -sum_k k1 / (2 |s_k|^(1/2)) (2 k2 |s_k| + (k1 |s_k|^(1/2) sgn(s_k) - w_k)^2)   (s_k != 0),

valid with ``singularity_fix`` = ``switch`` or ``none`` (the surface's slope is then its exact derivative),
not ``clamp``.

References: A. Levant, "Sliding order and sliding accuracy in sliding mode control", Int. J. Control 58(6)
(1993) 1247-1263; A. Levant, "Robust exact differentiation via sliding mode technique", Automatica 34(3)
(1998) 379-384; J. A. Moreno & M. Osorio, "Strict Lyapunov functions for the super-twisting algorithm",
IEEE Trans. Automatic Control 57(4) (2012) 1035-1040; Liang, Sun & Wang, Acta Astronautica 81 (2012)
445-455 (the surface, eqs 13, 16-19, Remark 6).

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

import sympy as sp

from fsmctl.symbolic.controller import (
    computed_torque_pieces,
    coordination_term,
    sliding_variable,
)
from fsmctl.symbolic.fsm_parameters import declare_fsm_parameters, declare_surface_presets
from fsmctl.symbolic.law import Law, LawBuilder
from fsmctl.symbolic.mrp import mrp_G, mrp_G_inverse
from fsmctl.symbolic.surfaces import fast_sliding_surface

REFERENCE = (
    "Levant, Int. J. Control 58 (1993) 1247-1263; Moreno & Osorio, IEEE TAC 57 (2012) 1035-1040; "
    "surface: Liang, Sun & Wang, Acta Astronautica 81 (2012) 445-455, eqs 13, 16-19, Remark 6"
)


def law(error_model) -> Law:
    b = LawBuilder(
        "super_twisting",
        error_model,
        doc="super-twisting sliding mode on the paper's fast sliding surface, with neighbour coordination (eq 19)",
        reference=REFERENCE,
    )
    p = declare_fsm_parameters(b, boundary_layer=None, delta=None)
    c1, c2, alpha, epsilon, fix = p.c1, p.c2, p.alpha, p.epsilon, p.singularity_fix
    declare_surface_presets(b, p)
    k1 = b.parameter(
        "k1", 0.1, unit="1/s^(3/2)", minimum=0.0, exclusive_minimum=True,
        doc=(
            "gain of -k1 |s|^(1/2) sgn(s). Default 0.1: with k2 = 0.005 it meets Levant's k1^2 >= "
            "4L(k2+L)/(k2-L) (0.01 >= 0.006) and Moreno-Osorio's k2 > 3L + 2L^2/k1^2 for L = 1e-3 s^-3, and "
            "reaches s = 0 from |s| = 0.5 1/s in ~2|s|^(1/2)/k1 = 14 s (unsaturated)"
        ),
    )  # fmt: skip
    k2 = b.parameter(
        "k2", 0.005, unit="1/s^3", minimum=0.0, exclusive_minimum=True,
        doc=(
            "gain of w_dot = -k2 sgn(s); must exceed the bound L on the derivative of the perturbation of "
            "s_dot. Default 0.005 = 5 L for L = 1e-3 s^-3 (10x the paper scenario's disturbance rate on the "
            "surface); the same number as the paper scenario's delta"
        ),
    )  # fmt: skip

    surface = fast_sliding_surface(b, c1, c2, alpha, epsilon, fix)
    e, s = surface.error, surface.s
    b.broadcast("s", s, unit="1/s")

    w = b.state("w", 3, initial=0.0, unit="1/s^2", doc="integral term of the super-twisting algorithm")
    b.discontinuous("sgn(s) of the super-twisting integral term d/dt w = -k2 sgn(s)")
    b.derivative(w, -k2 * s.applyfunc(sp.sign))
    v = b.stage("v", [-k1 * sp.sqrt(sp.Abs(sk)) * sp.sign(sk) + wk for sk, wk in zip(s, w, strict=True)])

    # u^F of eq 17 (the delta and coordination pieces are not used: the reaching term is v)
    pieces = computed_torque_pieces(
        b.J0, e.sigma_e, e.omega_e, e.omega_r, e.omega_r_dot, s, c1, c2, alpha, [1, 1, 1],
        coordination_term(s, b.k_sum, b.received), fix=fix, epsilon=epsilon,
    )  # fmt: skip
    u_F = surface.with_shared_slope(pieces.u_F, "super-twisting torque")
    u = -u_F + b.J0 * mrp_G_inverse(e.sigma_e) * (v - coordination_term(s, b.k_sum, b.received))
    b.torque(u)

    # Moreno & Osorio (2012) for the isolated agent at rest: sigma_e = sigma, omega_e = omega, w = z
    s_iso = sliding_variable(b.sigma, mrp_G(b.sigma) * b.omega, c1, c2, alpha, fix, epsilon)
    V, V_dot = 0, 0
    for sk, wk in zip(s_iso, w, strict=True):
        phi = sp.sqrt(sp.Abs(sk)) * sp.sign(sk)
        V += 2 * k2 * sp.Abs(sk) + wk**2 / 2 + (k1 * phi - wk) ** 2 / 2
        V_dot += -k1 / (2 * sp.sqrt(sp.Abs(sk))) * (2 * k2 * sp.Abs(sk) + (k1 * phi - wk) ** 2)
    b.lyapunov(
        V,
        claimed_derivative=V_dot,
        region={"sigma": 0.5, "omega": 0.2, "z": 0.05},
        doc=(
            "Moreno & Osorio (2012): V = sum_k 2 k2 |s_k| + w_k^2/2 + (k1 |s_k|^(1/2) sgn s_k - w_k)^2/2, "
            "V_dot = -sum_k k1/(2|s_k|^(1/2)) (2 k2 |s_k| + (k1 |s_k|^(1/2) sgn s_k - w_k)^2) for s_k != 0 "
            "(nominal, singularity_fix switch or none)"
        ),
    )
    return b.build()
