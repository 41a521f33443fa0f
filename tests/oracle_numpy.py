"""Independent NumPy test oracle for Liang, Sun & Wang (2012), Acta Astronautica 81, 445-455.

This module is an INDEPENDENT transcription written from the paper restatement
(``/work/shared/spec/paper.md``, raw text in ``/work/shared/seed/``) and from textbook
rigid-body / MRP facts (Schaub & Junkins).  It does not import, and must never be imported by,
the ``fsmctl`` package; its only purpose is to be compared against it in the tests.

Conventions
-----------
* All vectors are float64 arrays of shape (3,), matrices (3, 3).
* ``skew(v) @ w == np.cross(v, w)`` (eq 6, with the sign pattern that makes it skew-symmetric).
* MRP sigma = n tan(theta/4) (eq 2); ``mrp_to_dcm(sigma)`` is the direction-cosine matrix [BN]
  that maps N-frame components to B-frame components (Schaub & Junkins):
  C = I + (8 (sigma^x)^2 - 4 (1 - sigma'sigma) sigma^x) / (1 + sigma'sigma)^2.  It is built here
  through the Euler parameters (q0 = (1-|s|^2)/(1+|s|^2), q = 2 s/(1+|s|^2)).
* Kinematics sigma_dot = G(sigma) omega with omega the body rate in body components (eqs 3, 5);
  DCM kinematics C_dot = -omega^x C.
* Euler: J omega_dot = -omega^x J omega + tau (eq 4).
* Attitude error sigma_e: DCM(sigma_e) = DCM(sigma) DCM(sigma_d)^T = [BD] (body relative to the
  desired frame), returned on the |sigma_e| <= 1 branch.
* Error models: ``"paper"`` uses eqs 7-8 as printed (omega_r = omega_d, omega_e = omega - omega_d);
  ``"exact"`` uses omega_r = [BD] omega_d (omega_d in desired-frame components), omega_e = omega - omega_r,
  whose body-frame derivative is d/dt omega_r = [BD] omega_d_dot + omega_r x omega_e.
* ``sigpow(x, a) = sgn(x)|x|^a`` elementwise (eq 1).
* Table 2 agents are 1-based: ``k_j(i, j, t)`` is the weight k^j_ij with which agent i receives s_j.

Places where the printed paper did not check out
------------------------------------------------
1. Eq 9, C: the printed C = -M Gdot G^-1 - G^-T (J G^-1 sigma_dot)^x G^-1 + G^-T omega_d^x J G^-1
   omits the cross-coupling term omega_e x J omega_d; the correct (paper error model) C has
   + G^-T (omega_d^x J - (J omega_d)^x) G^-1 as its last term (see ``lagrange_M_C_E``).  The printed
   C is exact only when omega_d = 0 or omega_e is parallel to J omega_d.  C0 in eq 29 repeats it.
2. Eq 29, Delta d: as extracted, the inertia-error terms already carry a G_e^-T although Delta d is
   multiplied by G_e^-T again in (29) (units/scaling inconsistent with the trailing -DeltaJ omega_d_dot
   - omega_d^x DeltaJ omega_d + u_d); it inherits the missing term of item 1; and it contains sigma_e_ddot,
   so the robustness condition of Theorem 2 on delta depends on the control itself (algebraic loop).
   The consistent statement is Delta d = u_d - (DeltaJ omega_dot + omega x DeltaJ omega) in body terms.
3. Eq 24 (and eq 32): -sum_k (delta_i)_k |s_i|_k <= -||delta_i|| ||s_i|| is the wrong direction
   (Cauchy-Schwarz gives sum_k delta_k |s_k| <= ||delta|| ||s||).  A valid bound is
   -sum_k delta_k |s_k| <= -min_k(delta_k) ||s||, so mu in eq 28 (and 33) should use min_k (delta_i)_k, not
   ||delta_i|| (||delta_i - Delta d_i|| likewise).  Finite-time reaching still holds with that mu.
4. Eqs 7-8: omega_e = omega - omega_d drops the rotation of omega_d into the body frame
   (exact: omega - R(sigma_e) omega_d); it is exact only at sigma_e = 0 or when omega_d lies along the Euler
   axis of sigma_e.  A controller that inverts the paper model does not produce the closed loop (20) on
   the true rigid body when omega_d != 0.
5. Eq 17: the term printed ``c2 alpha sigma_e^(alpha-1) sigma_e_dot`` must be read elementwise with
   |sigma_e|^(alpha-1) (the derivative of sig(sigma_e)^alpha); a literal sigma^(alpha-1) is undefined for
   negative components.  Same in (20), (23), (30), (31).
6. Eq 6, as extracted: the (3,2) entry reads -(v)_1 instead of +(v)_1, which is not skew-symmetric
   (typo or extraction artefact); the standard cross-product matrix is used here.
7. Eq 19 / Theorem 1 call k^i_ij, k^j_ij "positive constants", but Table 2 makes k^j_ij time-varying and
   switching to 0, and Case 2 sets k^i_ij = 0, which violates k^i_ij > eta_ij > 0 of Theorem 1 (the proof
   still works without the coordination term, since the delta term alone gives the reaching law).
8. Eq 15: the Lyapunov candidate is printed as "V_dot_i = 1/2 sigma' sigma" (should be V_i, and it clashes
   with V_i = 1/2 s's of eq 22); the bound itself checks out since sum |x_k|^(1+alpha) >= ||x||^(1+alpha)
   for 1 + alpha <= 2.
9. Table 2, as extracted: row 4 column 3 is labelled k^4_43 instead of k^3_43 (superscript typo).
10. Metrics (42)-(43): theta "from eq 2" (4 atan|sigma|) exceeds pi when |sigma_e| > 1 is not shadow-switched;
   with a principal angle in [0, pi] (used here) AAEM and RAEM cannot exceed 180 deg, so the figure axes
   running to ~300 deg (AAEM) and ~200 deg (theta_i) suggest either padded axes or an unswitched MRP.  With
   the Table 1 data: theta_e(0) = 132.0, 163.7, 152.1, 112.7, 146.2, 83.6 deg, AAEM(0) = 134.4 deg,
   RAEM(0) = 114.1 deg; the unswitched MRP composition formula instead gives theta_1 = 228.0 and
   theta_4 = 247.3 deg, AAEM(0) = 178.6 deg.
Checked and found consistent: eq 5, eq 10 (Lemma 1), eq 12, eq 15 bound, eq 20 from (16)-(19) with
(9), eqs 26-27 (completing the square, needs eta_ij = eta_ji), eqs 34-41 (Theorem 3), Remark 6 limit.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

__all__ = [
    "aaem_deg",
    "closed_loop_eq20",
    "control_by_dynamic_inversion",
    "control_law_eqs_16_19",
    "dcm_to_mrp",
    "error_rates",
    "event_triggered_clock_links",
    "event_triggered_pd_formation",
    "k_j_exact",
    "lagrange_M_C_E",
    "mrp_G",
    "mrp_G_dot",
    "mrp_G_inv",
    "mrp_error",
    "mrp_shadow",
    "mrp_to_dcm",
    "paper_scenario",
    "plant_rhs",
    "principal_angle",
    "raem_deg",
    "relative_angle_matrix",
    "settling_time_fsm",
    "settling_time_lsm",
    "settling_time_tsm",
    "sigpow",
    "skew",
    "sliding_variable",
]


def _v(x) -> np.ndarray:
    a = np.asarray(x, dtype=np.float64).reshape(3)
    return a


# ----------------------------------------------------------------------------------------------
# Basic algebra and MRP kinematics
# ----------------------------------------------------------------------------------------------
def skew(v) -> np.ndarray:
    """Cross-product matrix v^x, such that skew(v) @ w == np.cross(v, w)."""
    v1, v2, v3 = _v(v)
    return np.array([[0.0, -v3, v2], [v3, 0.0, -v1], [-v2, v1, 0.0]], dtype=np.float64)


def mrp_G(sigma) -> np.ndarray:
    """G(sigma) = 1/4 [(1 - s's) I + 2 s^x + 2 s s'] (eq 5)."""
    s = _v(sigma)
    return 0.25 * ((1.0 - s @ s) * np.eye(3) + 2.0 * skew(s) + 2.0 * np.outer(s, s))


def mrp_G_inv(sigma) -> np.ndarray:
    """Numerical inverse of G(sigma) (np.linalg.inv, deliberately not the closed form)."""
    return np.linalg.inv(mrp_G(sigma))


def mrp_G_dot(sigma, sigma_dot) -> np.ndarray:
    """Time derivative of G(sigma(t)) along sigma_dot (differentiating eq 5 term by term)."""
    s = _v(sigma)
    sd = _v(sigma_dot)
    return 0.25 * (-2.0 * (s @ sd) * np.eye(3) + 2.0 * skew(sd) + 2.0 * (np.outer(sd, s) + np.outer(s, sd)))


def mrp_to_dcm(sigma) -> np.ndarray:
    """DCM [BN] of the MRP sigma, built through Euler parameters (no closed-form MRP formula)."""
    s = _v(sigma)
    n2 = s @ s
    b0 = (1.0 - n2) / (1.0 + n2)
    b1, b2, b3 = 2.0 * s / (1.0 + n2)
    return np.array(
        [
            [b0 * b0 + b1 * b1 - b2 * b2 - b3 * b3, 2.0 * (b1 * b2 + b0 * b3), 2.0 * (b1 * b3 - b0 * b2)],
            [2.0 * (b1 * b2 - b0 * b3), b0 * b0 - b1 * b1 + b2 * b2 - b3 * b3, 2.0 * (b2 * b3 + b0 * b1)],
            [2.0 * (b1 * b3 + b0 * b2), 2.0 * (b2 * b3 - b0 * b1), b0 * b0 - b1 * b1 - b2 * b2 + b3 * b3],
        ],
        dtype=np.float64,
    )


def _dcm_to_quaternion(C) -> np.ndarray:
    """Shepperd's method: Euler parameters (b0, b1, b2, b3) with b0 >= 0."""
    C = np.asarray(C, dtype=np.float64).reshape(3, 3)
    tr = np.trace(C)
    sq = np.array(
        [
            (1.0 + tr) / 4.0,
            (1.0 + 2.0 * C[0, 0] - tr) / 4.0,
            (1.0 + 2.0 * C[1, 1] - tr) / 4.0,
            (1.0 + 2.0 * C[2, 2] - tr) / 4.0,
        ]
    )
    k = int(np.argmax(sq))
    b = np.empty(4)
    bk = np.sqrt(max(sq[k], 0.0))
    b[k] = bk
    # products b_i b_j from the off-diagonal entries
    p01 = (C[1, 2] - C[2, 1]) / 4.0
    p02 = (C[2, 0] - C[0, 2]) / 4.0
    p03 = (C[0, 1] - C[1, 0]) / 4.0
    p12 = (C[0, 1] + C[1, 0]) / 4.0
    p13 = (C[2, 0] + C[0, 2]) / 4.0
    p23 = (C[1, 2] + C[2, 1]) / 4.0
    if k == 0:
        b[1], b[2], b[3] = p01 / bk, p02 / bk, p03 / bk
    elif k == 1:
        b[0], b[2], b[3] = p01 / bk, p12 / bk, p13 / bk
    elif k == 2:
        b[0], b[1], b[3] = p02 / bk, p12 / bk, p23 / bk
    else:
        b[0], b[1], b[2] = p03 / bk, p13 / bk, p23 / bk
    if b[0] < 0.0:
        b = -b
    return b / np.linalg.norm(b)


def dcm_to_mrp(C) -> np.ndarray:
    """MRP with |sigma| <= 1 of the DCM C (quaternion with q0 >= 0, then sigma = q / (1 + q0))."""
    b = _dcm_to_quaternion(C)
    return b[1:] / (1.0 + b[0])


def mrp_error(sigma, sigma_d) -> np.ndarray:
    """sigma_e with DCM(sigma_e) = DCM(sigma) DCM(sigma_d)^T (body relative to desired), |sigma_e| <= 1."""
    return dcm_to_mrp(mrp_to_dcm(sigma) @ mrp_to_dcm(sigma_d).T)


def mrp_shadow(sigma) -> np.ndarray:
    """Shadow-set switch: -sigma/|sigma|^2 if |sigma| > 1, else sigma (copy)."""
    s = _v(sigma).copy()
    n2 = s @ s
    if n2 > 1.0:
        return -s / n2
    return s


def principal_angle(sigma) -> float:
    """Euler principal angle in [0, pi] from the DCM trace: arccos((tr C - 1)/2), argument clipped."""
    C = mrp_to_dcm(sigma)
    return float(np.arccos(np.clip((np.trace(C) - 1.0) / 2.0, -1.0, 1.0)))


# ----------------------------------------------------------------------------------------------
# Plant and error kinematics
# ----------------------------------------------------------------------------------------------
def plant_rhs(sigma, omega, tau, J) -> tuple[np.ndarray, np.ndarray]:
    """(sigma_dot, omega_dot) of eqs 3-4: sigma_dot = G omega, J omega_dot = -omega x J omega + tau."""
    s = _v(sigma)
    w = _v(omega)
    J = np.asarray(J, dtype=np.float64).reshape(3, 3)
    sigma_dot = mrp_G(s) @ w
    omega_dot = np.linalg.solve(J, -np.cross(w, J @ w) + _v(tau))
    return sigma_dot, omega_dot


def error_rates(sigma, omega, sigma_d, omega_d, error_model: str = "paper"):
    """(sigma_e, omega_e, omega_r) for ``error_model`` "paper" (eqs 7-8 as printed) or "exact"."""
    sigma_e = mrp_error(sigma, sigma_d)
    w = _v(omega)
    wd = _v(omega_d)
    if error_model == "paper":
        omega_r = wd.copy()
    elif error_model == "exact":
        omega_r = mrp_to_dcm(sigma_e) @ wd
    else:
        raise ValueError(f"unknown error_model {error_model!r}")
    return sigma_e, w - omega_r, omega_r


# ----------------------------------------------------------------------------------------------
# Sliding surface and Lagrange-like model
# ----------------------------------------------------------------------------------------------
def sigpow(x, a) -> np.ndarray:
    """sig(x)^a = sgn(x) |x|^a elementwise (eq 1)."""
    x = np.asarray(x, dtype=np.float64)
    return np.sign(x) * np.abs(x) ** a


def sliding_variable(sigma_e, sigma_e_dot, c1, c2, alpha) -> np.ndarray:
    """s = sigma_e_dot + c1 sigma_e + c2 sig(sigma_e)^alpha (eq 13), no regularisation."""
    se = _v(sigma_e)
    return _v(sigma_e_dot) + c1 * se + c2 * sigpow(se, alpha)


def lagrange_M_C_E(J, sigma_e, sigma_e_dot, omega_d, omega_d_dot, variant: str = "euler"):
    """(M, C, E) of the Lagrange-like model (9) for the PAPER error model (omega = G^-1 sigma_e_dot + omega_d).

    M = G^-T J G^-1, E = J omega_d_dot + omega_d^x J omega_d, G = G(sigma_e), G^-1 by np.linalg.inv.

    ``variant="printed"``: C exactly as printed under eq 9,
        C = -M Gdot G^-1 - G^-T (J G^-1 sigma_e_dot)^x G^-1 + G^-T omega_d^x J G^-1.
    ``variant="euler"``: the C derived here from Euler's equation (4).  With omega_e = G^-1 sigma_e_dot,
        omega_dot = -G^-1 Gdot G^-1 sigma_e_dot + G^-1 sigma_e_ddot + omega_d_dot, and
        omega x J omega = omega_e x J omega_e + omega_e x J omega_d + omega_d x J omega_e + omega_d x J omega_d,
        premultiplying J omega_dot + omega x J omega = u by G^-T gives M sigma_e_ddot + C sigma_e_dot + G^-T E
        = G^-T u with
        C = -M Gdot G^-1 - G^-T (J G^-1 sigma_e_dot)^x G^-1 + G^-T (omega_d^x J - (J omega_d)^x) G^-1,
        using omega_e x J omega_e = -(J omega_e)^x omega_e and omega_e x J omega_d = -(J omega_d)^x omega_e.

    Finding: the printed C lacks the term -G^-T (J omega_d)^x G^-1, i.e. the cross-coupling
    omega_e x J omega_d of the gyroscopic torque.  C_printed sigma_e_dot - C_euler sigma_e_dot
    = G^-T ((J omega_d) x omega_e), which vanishes only if omega_d = 0 or omega_e || J omega_d.
    """
    J = np.asarray(J, dtype=np.float64).reshape(3, 3)
    se = _v(sigma_e)
    sed = _v(sigma_e_dot)
    wd = _v(omega_d)
    wdd = _v(omega_d_dot)
    Gi = mrp_G_inv(se)
    GiT = Gi.T
    Gd = mrp_G_dot(se, sed)
    M = GiT @ J @ Gi
    E = J @ wdd + np.cross(wd, J @ wd)
    C = -M @ Gd @ Gi - GiT @ skew(J @ Gi @ sed) @ Gi + GiT @ skew(wd) @ J @ Gi
    if variant == "euler":
        C = C - GiT @ skew(J @ wd) @ Gi
    elif variant != "printed":
        raise ValueError(f"unknown variant {variant!r}")
    return M, C, E


# ----------------------------------------------------------------------------------------------
# Control law
# ----------------------------------------------------------------------------------------------
def control_law_eqs_16_19(
    J0, sigma, omega, sigma_d, omega_d, omega_d_dot, c1, c2, alpha, delta, coordination, variant: str = "euler"
) -> dict[str, np.ndarray]:
    """Eqs 16-19 literally, with the paper error model (7-8) and J0 in M, C, E.

    u = -uF - uD - uC,
    uF = -(G_e^T C sigma_e_dot + E) + G_e^T M (c1 sigma_e_dot + c2 alpha |sigma_e|^(alpha-1) o sigma_e_dot),
    uD = G_e^T M diag(delta) sgn(s), uC = G_e^T M coordination,
    where coordination = sum_j (k^i_ij s_i - k^j_ij s_j) is supplied by the caller.
    Returns dict with keys u, uF, uD, uC.
    """
    sigma_e, omega_e, _ = error_rates(sigma, omega, sigma_d, omega_d, "paper")
    G = mrp_G(sigma_e)
    sed = G @ omega_e
    M, C, E = lagrange_M_C_E(J0, sigma_e, sed, omega_d, omega_d_dot, variant)
    s = sliding_variable(sigma_e, sed, c1, c2, alpha)
    dvec = np.broadcast_to(np.asarray(delta, dtype=np.float64), (3,))
    GtM = G.T @ M
    uF = -(G.T @ C @ sed + E) + GtM @ (c1 * sed + c2 * alpha * np.abs(sigma_e) ** (alpha - 1.0) * sed)
    uD = GtM @ np.diag(dvec) @ np.sign(s)
    uC = GtM @ _v(coordination)
    return {"u": -uF - uD - uC, "uF": uF, "uD": uD, "uC": uC}


def closed_loop_eq20(sigma_e, sigma_e_dot, c1, c2, alpha, delta, coordination) -> np.ndarray:
    """sigma_e_ddot = -(c1 sed + c2 alpha |se|^(alpha-1) o sed) - delta o sgn(s) - coordination (eq 20)."""
    se = _v(sigma_e)
    sed = _v(sigma_e_dot)
    dvec = np.broadcast_to(np.asarray(delta, dtype=np.float64), (3,))
    s = sliding_variable(se, sed, c1, c2, alpha)
    return -(c1 * sed + c2 * alpha * np.abs(se) ** (alpha - 1.0) * sed) - dvec * np.sign(s) - _v(coordination)


def control_by_dynamic_inversion(
    J0, sigma, omega, sigma_d, omega_d, omega_d_dot, c1, c2, alpha, delta, coordination, error_model: str = "paper"
) -> np.ndarray:
    """Torque that makes the chosen error model follow eq 20, without M, C or E.

    sigma_e_ddot target from (20); omega_e_dot = G^-1 (sigma_e_ddot - Gdot omega_e);
    omega_dot = omega_e_dot + d/dt(omega_r) (body frame): omega_d_dot ("paper") or
    R omega_d_dot + omega_r x omega_e ("exact"); u = J0 omega_dot + omega x J0 omega (eq 4).
    """
    J0 = np.asarray(J0, dtype=np.float64).reshape(3, 3)
    w = _v(omega)
    sigma_e, omega_e, omega_r = error_rates(sigma, omega, sigma_d, omega_d, error_model)
    G = mrp_G(sigma_e)
    sed = G @ omega_e
    sedd = closed_loop_eq20(sigma_e, sed, c1, c2, alpha, delta, coordination)
    omega_e_dot = np.linalg.solve(G, sedd - mrp_G_dot(sigma_e, sed) @ omega_e)
    if error_model == "paper":
        omega_r_dot = _v(omega_d_dot)
    else:
        omega_r_dot = mrp_to_dcm(sigma_e) @ _v(omega_d_dot) + np.cross(omega_r, omega_e)
    omega_dot = omega_e_dot + omega_r_dot
    return J0 @ omega_dot + np.cross(w, J0 @ w)


# ----------------------------------------------------------------------------------------------
# Theorem 3 settling times and metrics
# ----------------------------------------------------------------------------------------------
def settling_time_fsm(c1, c2, alpha, x0, tau) -> float:
    """Eq 34: time for x_dot = -c1 x - c2 sig(x)^alpha to go from |x0| to tau."""
    a = 1.0 - alpha
    return float(np.log((c1 * abs(x0) ** a + c2) / (c1 * tau**a + c2)) / (c1 * a))


def settling_time_tsm(c1, c2, alpha, x0, tau) -> float:
    """Eq 35: time for x_dot = -c2 sig(x)^alpha (c1 unused, kept for a uniform signature)."""
    a = 1.0 - alpha
    return float((abs(x0) ** a - tau**a) / (c2 * a))


def settling_time_lsm(c1, c2, alpha, x0, tau) -> float:
    """Eq 36: time for x_dot = -c1 x (c2, alpha unused, kept for a uniform signature)."""
    return float(np.log(abs(x0) / tau) / c1)


def aaem_deg(theta_e) -> float:
    """Eq 42: (180/pi) sqrt(mean_i theta_ei^2), theta in rad (the paper's 1/6 is 1/n)."""
    th = np.asarray(theta_e, dtype=np.float64).ravel()
    return float(np.degrees(np.sqrt(np.mean(th**2))))


def raem_deg(theta_pairs) -> float:
    """Eq 43: (180/pi) sqrt(sum_{i != j} theta_ij^2 / (n(n-1))), theta_pairs an (n, n) matrix in rad.

    The diagonal is ignored (the paper's 1/30 is 1/(n(n-1)) for n = 6).
    """
    th = np.asarray(theta_pairs, dtype=np.float64)
    n = th.shape[0]
    if th.shape != (n, n):
        raise ValueError("theta_pairs must be an (n, n) matrix")
    off = ~np.eye(n, dtype=bool)
    return float(np.degrees(np.sqrt(np.sum(th[off] ** 2) / (n * (n - 1)))))


def relative_angle_matrix(sigmas) -> np.ndarray:
    """theta_ij = principal angle of DCM(sigma_i) DCM(sigma_j)^T, for use with ``raem_deg``."""
    sig = [np.asarray(s, dtype=np.float64) for s in sigmas]
    n = len(sig)
    out = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            if i != j:
                out[i, j] = principal_angle(mrp_error(sig[i], sig[j]))
    return out


# ----------------------------------------------------------------------------------------------
# Section 4 scenario
# ----------------------------------------------------------------------------------------------
_PHASES = np.array(
    [
        [np.nan, 0.0, 1.0, 2.8, 3.3, 4.8],
        [1.5, np.nan, 0.5, 2.5, 3.2, 2.6],
        [0.9, 4.9, np.nan, 5.6, 2.1, 3.6],
        [3.7, 6.0, 5.0, np.nan, 4.1, 2.0],
        [2.4, 1.7, 0.9, 1.3, np.nan, 6.2],
        [1.9, 0.2, 4.8, 1.1, 5.3, np.nan],
    ]
)


def _k_base(t: float) -> float:
    """Table 2 base switching weight k(t) = 5 if mod(t, 8) <= 6.5 else 0."""
    return 5.0 if float(np.mod(t, 8.0)) <= 6.5 else 0.0


def k_j_exact(i: int, j: int, t: float, on: float = 5.0) -> float:
    """Table 2's k^j_ij(t) = k(t + phi_ij), k(t) = on if mod(t, 8) <= 6.5 else 0, in exact rational arithmetic at
    the double ``t`` and the printed decimal phase (1-based agents; 0 without a link).  Unlike ``k_j`` of
    :func:`paper_scenario` (float ``np.mod``), it is right within an ulp of a switching instant."""
    if not (1 <= i <= 6 and 1 <= j <= 6):
        raise ValueError("agent indices are 1-based, 1..6")
    if i == j:
        return 0.0
    tau = Fraction(float(t)) + Fraction(repr(float(_PHASES[i - 1, j - 1])))
    return float(on) if tau % 8 <= Fraction(13, 2) else 0.0


def paper_scenario() -> dict:
    """Section 4 data.  Agents are 1-based in ``disturbance`` and ``k_j``; lists are 0-based."""
    J0 = [
        np.array([[100, 1, 2], [1, 150, 1], [2, 1, 200]], dtype=np.float64),
        np.array([[120, 1.5, 1], [1.5, 160, 1], [1, 1, 190]], dtype=np.float64),
        np.array([[80, 0.5, 2], [0.5, 180, 0], [2, 0, 180]], dtype=np.float64),
        np.array([[110, 1, 0], [1, 130, 0.5], [0, 0.5, 240]], dtype=np.float64),
        np.array([[100, 1, 0.5], [1, 140, 1.5], [0.5, 1.5, 220]], dtype=np.float64),
        np.array([[90, 1, 1], [1, 170, 0], [1, 0, 200]], dtype=np.float64),
    ]
    sigma0 = [
        np.array([0.3, 0.2, -0.3]),
        np.array([0.1, 0.3, 0.2]),
        np.array([-0.3, 0.2, -0.1]),
        np.array([0.4, 0.4, -0.2]),
        np.array([-0.1, 0.3, 0.2]),
        np.array([-0.2, -0.1, 0.1]),
    ]
    omega0 = [
        np.array([0.35, -0.13, 0.27]),
        np.array([0.52, -0.26, 0.33]),
        np.array([-0.26, 0.22, -0.13]),
        np.array([-0.45, 0.33, -0.15]),
        np.array([0.12, -0.34, -0.28]),
        np.array([-0.36, 0.17, 0.41]),
    ]

    def omega_d(t: float) -> np.ndarray:
        return np.array([0.1 * np.cos(t / 40.0), -0.1 * np.sin(t / 50.0), -0.1 * np.cos(t / 60.0)])

    def omega_d_dot(t: float) -> np.ndarray:
        return np.array([-0.1 / 40.0 * np.sin(t / 40.0), -0.1 / 50.0 * np.cos(t / 50.0), 0.1 / 60.0 * np.sin(t / 60.0)])

    def disturbance(i: int, t: float) -> np.ndarray:
        if not 1 <= i <= 6:
            raise ValueError("agent index i is 1-based, 1..6")
        return np.array([0.2 * np.cos(i + 0.1 * t), -0.24 * np.sin(i + 0.15 * t), 0.22 * np.cos(i + 0.12 * t)])

    def k_j(i: int, j: int, t: float) -> float:
        if not (1 <= i <= 6 and 1 <= j <= 6):
            raise ValueError("agent indices are 1-based, 1..6")
        if i == j:
            return 0.0
        return _k_base(t + _PHASES[i - 1, j - 1])

    return {
        "n_agents": 6,
        "J0": J0,
        "delta_J": [0.3 * J for J in J0],
        "sigma0": sigma0,
        "omega0": omega0,
        "sigma_d0": np.array([-0.3, -0.4, 0.4]),
        "c1": 0.6,
        "c2": 0.8,
        "k_i": 8.0,
        "k_j_on": 5.0,
        "torque_limit": 2.0,
        "omega_d": omega_d,
        "omega_d_dot": omega_d_dot,
        "disturbance": disturbance,
        "k_j": k_j,
        "k_base": _k_base,
        "phases": _PHASES.copy(),
        "case3_weights": [(2.0, 0.6), (4.0, 2.8), (8.0, 5.0)],
        "t_final": 100.0,
    }


# ----------------------------------------------------------------------------------------------
# Event-triggered communication (issue 28): the rule, transcribed from its statement
# ----------------------------------------------------------------------------------------------
# At every check instant (a control instant q with q % check_every == 0) agent j compares its current broadcast
# b_j(t_q) with the last value it sent; it sends when the trigger holds, and always at the first instant.  Its
# neighbours use the last value they received (held between messages).  A message sent at instant q_s on a link
# with a delay of d instants arrives at q_s + d unless the packet of that arrival instant is lost; before the first
# arrival a link holds the first value sent.


def event_triggered_clock_links(times, senders, gap, delay, lost, check_every=1):
    """The clock probe over event-triggered links: each agent broadcasts its clock t and sends when
    ``t - t_sent > gap``.

    ``times`` (Q,) control instants, ``senders`` (L,) the sending agent of each link (0-based), ``delay`` (L,) in
    instants, ``lost`` (Q, L) bool.  Returns ``(held, sent, delivered)``: ``held`` (Q, L) the clock value each link
    holds after the arrivals of each instant, ``sent`` (Q, n) whether each agent sent, ``delivered`` (L,) the messages
    that arrived on each link.
    """
    times = np.asarray(times, dtype=np.float64)
    senders = np.asarray(senders)
    n = int(senders.max()) + 1 if senders.size else 0
    Q, L = times.size, senders.size
    sent = np.zeros((Q, n), dtype=bool)
    last = np.full(n, np.nan)
    for q in range(Q):
        if q % check_every:
            continue
        for j in range(n):
            if q == 0 or times[q] - last[j] > gap:
                sent[q, j] = True
                last[j] = times[q]
    held = np.zeros((Q, L))
    delivered = np.zeros(L, dtype=np.int64)
    for e in range(L):
        value = times[0]  # the first value sent (instant 0), held before any arrival
        for q in range(Q):
            origin = q - int(delay[e])
            if origin >= 0 and sent[origin, senders[e]] and not lost[q, e]:
                value = times[origin]
                delivered[e] += 1
            held[q, e] = value
    return held, sent, delivered


def event_triggered_pd_formation(
    J, sigma0, omega0, senders, receivers, k_j, *, K, P, c0, c1, lam, dt, hold, n_steps, check_every=1
):
    """A formation of rigid bodies (eqs 3-4) flying ``u_i = -K se_i - P we_i - K sum_j k_ij (se_i - se_j,held)`` with
    the reference at rest (so ``se = sigma``, ``we = omega``, eqs 5-8), a zero-order hold of ``hold`` RK4 steps of
    ``dt``, and event-triggered broadcasting of ``se`` (``|se - se_sent| > c0 + c1 exp(-lam t)``) over ideal links of
    constant weights ``k_j`` (``receivers[e]`` receives from ``senders[e]``).  MRPs are switched to the shadow set
    after every step.

    Returns a dict of arrays at the control instants: ``t`` (Q,), ``sigma``, ``omega`` (Q, n, 3), ``sent`` (Q, n)
    bool, and ``delivered`` (L,) messages per link.
    """
    n = len(J)
    J = [np.asarray(Ji, dtype=np.float64) for Ji in J]
    sig = np.array([mrp_shadow(s) for s in sigma0], dtype=np.float64)
    om = np.array(omega0, dtype=np.float64)
    held = np.zeros((n, 3))
    sent_at = []
    delivered = np.zeros(len(senders), dtype=np.int64)
    out_t, out_s, out_w = [], [], []
    u = np.zeros((n, 3))
    for k in range(n_steps + 1):
        t = k * dt
        if k % hold == 0:
            q = k // hold
            se = np.array([mrp_error(sig[i], np.zeros(3)) for i in range(n)])
            fired = np.zeros(n, dtype=bool)
            if q % check_every == 0:
                for i in range(n):
                    if q == 0 or np.linalg.norm(se[i] - held[i]) > c0 + c1 * np.exp(-lam * t):
                        fired[i] = True
                        held[i] = se[i]
                for e, j in enumerate(senders):
                    delivered[e] += fired[j]
            sent_at.append(fired)
            for i in range(n):
                coupling = np.zeros(3)
                for e in range(len(senders)):
                    if receivers[e] == i:
                        coupling += k_j[e] * (se[i] - held[senders[e]])
                u[i] = -K * se[i] - P * om[i] - K * coupling
            out_t.append(t)
            out_s.append(sig.copy())
            out_w.append(om.copy())
        if k == n_steps:
            break

        def rhs(s, w):
            ds, dw = np.empty_like(s), np.empty_like(w)
            for i in range(n):
                ds[i], dw[i] = plant_rhs(s[i], w[i], u[i], J[i])
            return ds, dw

        a_s, a_w = rhs(sig, om)
        b_s, b_w = rhs(sig + 0.5 * dt * a_s, om + 0.5 * dt * a_w)
        c_s, c_w = rhs(sig + 0.5 * dt * b_s, om + 0.5 * dt * b_w)
        d_s, d_w = rhs(sig + dt * c_s, om + dt * c_w)
        sig = sig + dt / 6.0 * (a_s + 2.0 * b_s + 2.0 * c_s + d_s)
        om = om + dt / 6.0 * (a_w + 2.0 * b_w + 2.0 * c_w + d_w)
        sig = np.array([mrp_shadow(s) for s in sig])
    return {
        "t": np.array(out_t),
        "sigma": np.array(out_s),
        "omega": np.array(out_w),
        "sent": np.array(sent_at),
        "delivered": delivered,
    }
