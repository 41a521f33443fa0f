"""MRP PD/PID feedback with an optional consensus term: the classical baseline (law name ``pid``).

The nonlinear integral feedback of Schaub & Junkins, *Analytical Mechanics of Space Systems* (AIAA,
doi:10.2514/4.105210, Ch. 8: MRP feedback, nonlinear integral feedback eq 8.104 and the RW-free form of
Example 8.14, as Basilisk cites them) in the form Basilisk's ``mrpFeedback`` module implements it
(AVSLab/basilisk, ``src/fswAlgorithms/attControl/mrpFeedback``: ``mrpFeedback.rst`` eqs ``eq:Lr``,
``eq:zKi``, ``eq:V``, ``eq:V_dot4`` and ``mrpFeedback.c``, ``controlLawType = 0``, no reaction wheels, no
known torque ``L``), with ``B`` the body, ``R`` the reference:

    u = -K sigma_e - P omega_e - P Ki z + (omega_r - Ki z) x (J0 omega) + J0 omega_r_dot
        - k_coupling (k_received_sum sigma_e - received),
    z = int_sigma + J0 omega_e,        d/dt int_sigma = K sigma_e,   int_sigma(0) = 0,

where ``omega = omega_e + omega_r`` and ``omega_r_dot`` is the *body-frame* derivative of the reference rate
``omega_r``: Basilisk's ``J0 (domega_RN_B - omega_BN_B x omega_RN_B)`` with the inertial derivative; the
exact error model (:meth:`LawBuilder.error_state`) gives exactly that, the paper's error model its eq 8
approximation ``omega_d_dot``.  ``int_sigma = K int sigma_e dt`` is Basilisk's ``int_sigma`` and
``z = K int sigma_e dt + J0 (omega_e - omega_e(0))`` its ``eq:zKi`` with ``omega_e(0) = 0`` as Basilisk
hard-codes it.

Two deliberate differences from Basilisk:

* the sign of ``Ki z`` in the gyroscopic term.  Basilisk's ``eq:Lr`` and its code (``controlLawType = 0``)
  use ``+ (omega_r + Ki z) x (J0 omega)``; its own proof (``eq:V_dot3``: "making use of
  alpha = omega_r - K_I z") and Schaub & Junkins need ``omega_r - Ki z``, for which
  ``d/dt V = -(omega_e + Ki z)^T P (omega_e + Ki z)`` (``eq:V_dot4``).  With ``+`` the cross term
  ``(omega_e + Ki z)^T ((omega_e - Ki z) x J0 omega)`` does not vanish and ``V`` is not monotone (checked
  numerically: it increases at times for ``Ki > 0``).  For ``Ki = 0`` both are the same law.
* no integral limit.  Basilisk clips each component of ``int_sigma`` at ``integralLimit``; here there is no
  clip (the law's Lyapunov function holds for every admissible parameter).  A parameter default of ``inf``
  ("no limit") cannot be declared (parameter values must be finite), and a sentinel ``0 = no limit`` would
  invert Basilisk's meaning of ``integralLimit = 0``.  The torque itself is still limited per axis at
  ``u_max`` by the engine.  With ``Ki = 0`` the state ``int_sigma`` is still integrated (it does not act on
  the torque) and is reported in ``result.z``.

Units: ``Ki`` multiplies the angular momentum ``z`` (N m s) into a rate (``omega_r - Ki z``), so it is in
``1/(kg m^2)``, not ``1/s``.

Coordination: the agent broadcasts ``sigma_e``; ``k_received_sum sigma_e - received =
sum_j k^j_ij(t) (sigma_e,i - sigma_e,j)`` (what the engine aggregates, Liang et al. 2012 eq 19 in consensus
form), weighted by ``k_coupling`` (default 0: the uncoordinated baseline).

Lyapunov function (isolated agent, ``J = J0``, reference at rest, no disturbance; Schaub & Junkins
Ch. 8, Basilisk ``eq:V``):

    V = 2 K ln(1 + sigma^T sigma) + 1/2 omega^T J0 omega + 1/2 Ki z^T z,   z = int_sigma + J0 omega,
    d/dt V = -P (omega + Ki z)^T (omega + Ki z) <= 0;

for the PD case ``Ki = 0`` this is ``V = 2 K ln(1 + sigma^T sigma) + 1/2 omega^T J0 omega``,
``d/dt V = -P omega^T omega`` (``d/dt 2K ln(1 + sigma^T sigma) = K sigma^T omega`` because
``sigma^T G(sigma) = (1 + sigma^T sigma)/4 sigma^T``).

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

import sympy as sp

from fsmctl.symbolic.law import Law, LawBuilder
from fsmctl.symbolic.mrp import skew

REFERENCE = (
    "Schaub & Junkins, Analytical Mechanics of Space Systems (AIAA, doi:10.2514/4.105210), Ch. 8 nonlinear "
    "integral feedback (eq 8.104, Example 8.14); "
    "Basilisk mrpFeedback (AVSLab/basilisk src/fswAlgorithms/attControl/mrpFeedback, controlLawType 0, no RWs)"
)


def law(error_model) -> Law:
    b = LawBuilder(
        "pid",
        error_model,
        doc="MRP PD/PID feedback (Schaub & Junkins; Basilisk mrpFeedback) with an optional consensus term",
        reference=REFERENCE,
    )
    K = b.parameter(
        "K", 20.0, unit="N m", minimum=0.0, exclusive_minimum=True,
        doc=(
            "attitude gain on sigma_e. Default: linearised about sigma_e = 0 each axis is "
            "sigma_ddot + (P/J) sigma_dot + K/(4J) sigma = 0; for the paper's mean principal inertia "
            "J = 153 kg m^2 (80..240) K = 20 gives omega_n = sqrt(K/(4J)) = 0.18 rad/s"
        ),
    )  # fmt: skip
    P = b.parameter(
        "P", 40.0, unit="N m s", minimum=0.0, exclusive_minimum=True,
        doc=(
            "rate gain on omega_e. Default: damping zeta = P/sqrt(K J) = 0.72 and 2 % settling time "
            "8 J/P = 31 s for J = 153 kg m^2 (zeta 0.58..1.0 over the paper's inertias 80..240 kg m^2), "
            "the paper's ~30 s transient"
        ),
    )  # fmt: skip
    Ki = b.parameter(
        "Ki", 0.0, unit="1/(kg m^2)", minimum=0.0,
        doc=(
            "integral gain on z = K int sigma_e dt + J0 omega_e; 0: pure PD (default, the classical baseline). "
            "Ki J0 adds to the rate damping (P Ki J0 omega_e), so Ki J << 1 keeps the PD tuning: "
            "e.g. 5e-4 (Ki J ~ 0.08) removes the steady error of a constant disturbance"
        ),
    )  # fmt: skip
    kc = b.parameter(
        "k_coupling", 0.0, unit="N m", minimum=0.0,
        doc=(
            "gain of the consensus term -k_coupling sum_j k^j_ij(t) (sigma_e,i - sigma_e,j); default 0: the "
            "uncoordinated baseline. With the paper's weights (k^j = 5, up to 5 links) 0.1..0.5 adds "
            "2.5..12.5 N m per unit MRP disagreement, comparable to K"
        ),
    )  # fmt: skip

    e = b.error_state()
    b.broadcast("sigma_e", e.sigma_e)

    int_sigma = b.state(
        "int_sigma", 3, initial=0.0, unit="N m s",
        doc="K times the integral of sigma_e (Basilisk's int_sigma); z = int_sigma + J0 omega_e",
    )  # fmt: skip
    b.derivative(int_sigma, K * e.sigma_e)

    z = b.stage("z_integral", int_sigma + b.J0 * e.omega_e)
    omega = e.omega_e + e.omega_r
    u = (
        -K * e.sigma_e
        - P * e.omega_e
        - P * Ki * z
        + skew(e.omega_r - Ki * z) * (b.J0 * omega)
        + b.J0 * e.omega_r_dot
        - kc * (b.k_received_sum * e.sigma_e - b.received)
    )
    b.torque(u)

    # Lyapunov function of the isolated agent (sigma_e = sigma, omega_e = omega, omega_r = 0, J = J0)
    sigma, w = b.sigma, b.omega
    z_iso = int_sigma + b.J0 * w
    V = 2 * K * sp.log(1 + (sigma.T * sigma)[0, 0]) + (w.T * b.J0 * w)[0, 0] / 2 + Ki * (z_iso.T * z_iso)[0, 0] / 2
    y = w + Ki * z_iso
    b.lyapunov(
        V,
        claimed_derivative=-P * sum(yk**2 for yk in y),
        region={"sigma": 1.0, "omega": 0.5, "z": 10.0},
        doc=(
            "V = 2K ln(1 + sigma^T sigma) + 1/2 omega^T J0 omega + 1/2 Ki z^T z, z = int_sigma + J0 omega "
            "(Schaub & Junkins Ch. 8; Basilisk mrpFeedback eq:V): V_dot = -P |omega + Ki z|^2; "
            "PD (Ki = 0): V = 2K ln(1 + sigma^T sigma) + 1/2 omega^T J0 omega, V_dot = -P omega^T omega"
        ),
    )
    return b.build()
