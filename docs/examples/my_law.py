"""A user's law: MRP PD with consensus on the attitude error (``my_pd``), a derivation script.

For agent i, with the error state of Liang, Sun & Wang (2012, eqs 5-8):

    u_i = -K sigma_e,i - P omega_e,i - k_c sum_j k^j_ij(t) (sigma_e,i - sigma_e,j)

The agent broadcasts sigma_e; the engine hands back received = sum_j k^j_ij(t) sigma_e,j and
k_received_sum = sum_j k^j_ij(t) (eq 19 for any broadcast), so the consensus term is
k_received_sum sigma_e,i - received.

Lyapunov function (isolated agent, J = J0, reference at rest, no disturbance; sigma_dot = G(sigma) omega and
sigma^T G(sigma) = (1 + sigma^T sigma) sigma^T / 4):
V = 2 K ln(1 + sigma^T sigma) + 1/2 omega^T J0 omega,  V_dot = K sigma^T omega + omega^T (-K sigma - P omega) = -P |omega|^2.

Derive, check and fly it:

    fsmctl derive docs/examples/my_law.py --out my_pd
    fsmctl prove --law docs/examples/my_law.py
    fsmctl simulate --scenario docs/examples/my_law.toml --out runs/my_pd
"""

import sympy as sp

from fsmctl.symbolic.law import LawBuilder


def law(error_model):
    b = LawBuilder("my_pd", error_model, doc="MRP PD with consensus on the attitude error (a user's law)")
    K = b.parameter("K", 4.0, unit="N m", minimum=0.0, exclusive_minimum=True, doc="attitude gain on sigma_e")
    P = b.parameter("P", 12.0, unit="N m s", minimum=0.0, exclusive_minimum=True, doc="rate gain on omega_e")
    kc = b.parameter("k_c", 1.0, unit="N m", minimum=0.0, doc="gain of the consensus term; 0: uncoordinated")

    e = b.error_state()  # stages sigma_e, omega_r, omega_e, omega_r_dot (eqs 5-8, either error model)
    b.broadcast("sigma_e", e.sigma_e)  # what the neighbours receive
    consensus = b.k_received_sum * e.sigma_e - b.received  # sum_j k^j_ij(t) (sigma_e,i - sigma_e,j)
    b.torque(-K * e.sigma_e - P * e.omega_e - kc * consensus)

    s, w = b.sigma, b.omega  # isolated agent, reference at rest: sigma_e = sigma, omega_e = omega
    b.lyapunov(
        2 * K * sp.log(1 + (s.T * s)[0]) + (w.T * b.J0 * w)[0] / 2,
        claimed_derivative=-P * (w.T * w)[0],
        doc="V = 2 K ln(1 + |sigma|^2) + 1/2 omega^T J0 omega: V_dot = -P |omega|^2",
    )
    return b.build()
