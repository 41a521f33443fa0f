"""The paper's fast-sliding-mode law with adaptive switching gains (law name ``adaptive_fsm``).

Liang, Sun & Wang (2012) switch with a fixed gain ``delta`` (eq 18), and Theorem 2 needs
``delta_k > |(M0^-1 G^-T Delta_d)_k|``: a bound on the lumped uncertainty (inertia error ``Delta J`` and
disturbance ``d``) that is unknown in practice, state dependent, and not checked by the paper; for the
paper's own scenario the requirement holds near the reference but not off it (it grows to ~0.3 s^-2 at
``|sigma_e,k|, |omega_e,k| <= 0.05``, against ``delta = 0.005``; ``fsmctl prove theorem2-delta``).  The proof
therefore rests on an assumption the designer cannot verify, and a conservative ``delta`` costs torque
and chattering.  Here the gain is estimated on line instead, so no bound is needed in advance:

    s = G(sigma_e) omega_e + c1 sigma_e + c2 sig(sigma_e)^alpha                          (eq 13, Remark 6)
    u = -u^F - J0 G^-1 (delta_hat o sat(s/phi)) - J0 G^-1 (k_sum s - received)          (eqs 16-19)
    d/dt delta_hat_k = gamma |s_k| sgn(|s_k| - adaptation_band)                        (Plestan et al. 2010)

projected onto ``[DELTA_FLOOR, delta_max]`` (the rate is set to 0 where it would leave the interval) with
``delta_hat_k(0) = DELTA_FLOOR = 1e-4 s^-2``.  Outside the band ``|s_k| > adaptation_band`` the gain grows
(the reaching condition does not hold yet); inside it decreases, so the gain settles where the uncertainty
actually is instead of winding up (the pure law ``gamma |s_k|`` of Huang, Kuo & Chang 2008 only grows, and
grows without bound under measurement noise or with a boundary layer, where ``s`` never reaches 0).
Boundedness: the band (Plestan et al. 2010 prove the gain bounded and ``|s_k|`` ultimately below a bound of
the order of the band), and the projection: the floor keeps ``delta_hat > 0`` (the switching term never
vanishes), the cap ``delta_max`` stops the gain winding up while the actuator saturates (``s`` cannot be
driven down then, whatever the gain).

What the adaptation buys, in the proof: with an unknown constant ``delta*_k`` exceeding the uncertainty
bound, ``V = 1/2 s^T s + 1/(2 gamma) sum_k (delta_hat_k - delta*_k)^2`` gives
``V_dot <= -sum_k (delta*_k - |rho_k|) |s_k|`` outside the band (Huang et al. 2008): ``delta*`` only has to
*exist*, the controller never uses it.  The coordination term adds ``-s^T L s``-type terms as in the paper's
Theorem 2.  Inside the band only ultimate boundedness of ``s`` is claimed.

References: F. Plestan, Y. Shtessel, V. Bregeault & A. Poznyak, "New methodologies for adaptive sliding mode
control", Int. J. Control 83(9) (2010) 1907-1919; Y.-J. Huang, T.-C. Kuo & S.-H. Chang, "Adaptive
sliding-mode control for nonlinear systems with uncertain parameters", IEEE Trans. SMC-B 38(2) (2008)
534-539; Y. Shtessel, C. Edwards, L. Fridman & A. Levant, *Sliding Mode Control and Observation*
(Birkhaeuser 2014; gain adaptation); Liang, Sun & Wang, Acta Astronautica 81 (2012) 445-455.

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

import sympy as sp

from fsmctl.symbolic.controller import (
    computed_torque_pieces,
    coordination_term,
)
from fsmctl.symbolic.fsm_parameters import declare_fsm_parameters, declare_surface_presets
from fsmctl.symbolic.law import Law, LawBuilder
from fsmctl.symbolic.surfaces import fast_sliding_surface

REFERENCE = (
    "Liang, Sun & Wang, Acta Astronautica 81 (2012) 445-455, eqs 13, 16-19, Remarks 6-7; gain adaptation: "
    "Plestan, Shtessel, Bregeault & Poznyak, Int. J. Control 83 (2010) 1907-1919"
)

DELTA_FLOOR = 1e-4
"""s^-2: initial value and lower bound of delta_hat (below the paper scenario's Theorem 2 requirement at the
reference, 4e-4..1.4e-3, so the adaptation has to do the work)."""


def law(error_model) -> Law:
    b = LawBuilder(
        "adaptive_fsm",
        error_model,
        doc="the paper's fast sliding mode with adaptive switching gains (Plestan et al. 2010) and coordination",
        reference=REFERENCE,
    )
    p = declare_fsm_parameters(b, delta=None)
    c1, c2, alpha, phi, epsilon, fix = p.c1, p.c2, p.alpha, p.boundary_layer, p.epsilon, p.singularity_fix
    declare_surface_presets(b, p)
    gamma = b.parameter(
        "gamma", 0.01, unit="1/s", minimum=0.0, exclusive_minimum=True,
        doc=(
            "adaptation rate of d/dt delta_hat_k = gamma |s_k| sgn(|s_k| - band). Default 0.01: delta_hat gains "
            "the paper's hand-tuned 0.005 s^-2 after int |s_k| dt = 0.5, i.e. within the first seconds of "
            "the ~30 s transient (|s_k| ~ 0.1..0.5 1/s), while the decrease inside the band (<= gamma band "
            "= 1e-5 s^-3) is slow enough not to undo it between disturbance peaks"
        ),
    )  # fmt: skip
    band = b.parameter(
        "adaptation_band", 1e-3, unit="1/s", minimum=0.0, exclusive_minimum=True,
        doc=(
            "|s_k| below which delta_hat_k decreases. Default 1e-3 = the paper scenario's boundary layer phi: "
            "|s_k| <= 1e-3 on the FSM surface means |sigma_e,k| <~ 7e-5 (0.03 deg, the paper's finest "
            "tolerance), and with phi <= band the gain settles at or above the uncertainty"
        ),
    )  # fmt: skip
    delta_max = b.parameter(
        "delta_max", 0.05, unit="1/s^2", minimum=DELTA_FLOOR, exclusive_minimum=True,
        doc=(
            "cap of delta_hat (projection). Default 0.05 = 10x the paper scenario's delta: 4 J0 delta_max = "
            "16..48 N m, far beyond the 2 N m actuator, so it only stops wind-up during saturation"
        ),
    )  # fmt: skip
    surface = fast_sliding_surface(b, c1, c2, alpha, epsilon, fix)
    e, s = surface.error, surface.s
    b.broadcast("s", s, unit="1/s")

    delta_hat = b.state(
        "delta_hat", 3, initial=DELTA_FLOOR, unit="1/s^2",
        doc="adaptive switching gain per axis (replaces eq 18's delta)",
    )  # fmt: skip
    rates = []
    for sk, dk in zip(s, delta_hat, strict=True):
        grow, shrink = sp.Abs(sk) > band, sp.Abs(sk) < band
        rates.append(
            sp.Piecewise(
                (0, sp.And(grow, dk >= delta_max)),
                (0, sp.And(shrink, dk <= DELTA_FLOOR)),
                (gamma * sp.Abs(sk) * sp.sign(sp.Abs(sk) - band), True),
            )
        )
    b.derivative(delta_hat, rates)
    b.discontinuous(
        "sgn(|s_k| - adaptation_band) of the gain adaptation d/dt delta_hat (and sgn(s) of the switching term, "
        "eq 18, with boundary_layer = 0)"
    )

    pieces = computed_torque_pieces(
        b.J0, e.sigma_e, e.omega_e, e.omega_r, e.omega_r_dot, s, c1, c2, alpha, delta_hat,
        coordination_term(s, b.k_sum, b.received), boundary_layer=phi, fix=fix, epsilon=epsilon,
    )  # fmt: skip
    b.torque(surface.with_shared_slope(pieces.u, "adaptive FSM torque"))
    return b.build()
