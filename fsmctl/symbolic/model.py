"""Spacecraft attitude model and its Lagrange-like form (Liang et al. 2012, eqs 3-9, 29).

Two error models are derived side by side:

``paper``
    The paper's error kinematics (eqs 7-8): ``sigma_e_dot = G(sigma_e) omega_e``
    with ``omega_e = omega - omega_d``.  This drops the rotation of the reference
    rate into the body frame.
``exact``
    ``omega_e = omega - R(sigma_e) omega_d`` with ``R = [B R]`` the DCM of the
    error, and ``d/dt R = -omega_e^x R``.  This is the rigid-body truth.

Both are written with the same structure: the reference rate seen in the body
frame is ``omega_r = omega_d`` (paper) or ``R omega_d`` (exact), and its body-frame
derivative is ``omega_r_dot = omega_d_dot`` (paper) or
``R omega_d_dot + omega_r^x omega_e`` (exact).

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import sympy as sp

from fsmctl.symbolic.mrp import mrp_G, mrp_G_dot, mrp_G_inverse, mrp_to_dcm, skew
from fsmctl.symbolic.symbols import DerivationInputError, as_symmetric_matrix3, as_vector3

__all__ = [
    "ErrorModel",
    "LagrangeModel",
    "euler_rotational_dynamics",
    "plant_rhs",
    "error_angular_velocity",
    "reference_rate_in_body",
    "reference_acceleration_in_body",
    "lagrange_model",
    "lagrange_C_as_printed",
    "lagrange_uncertainty_as_printed",
    "lagrange_uncertainty",
]


class ErrorModel(str, Enum):  # noqa: UP042 (str() of the member is part of the generated names)
    """Which error kinematics the Lagrange-like model is derived for (Liang et al. 2012, eqs 7-8).

    ``PAPER`` (``"paper"``): eqs 7-8 as printed, ``omega_e = omega - omega_d`` (the reference rate is not
    rotated into the body frame); ``EXACT`` (``"exact"``): ``omega_e = omega - C(sigma_e) omega_d``.
    Every function that takes an error model also accepts these strings.

    Examples
    --------
    >>> from fsmctl.symbolic.model import ErrorModel
    >>> ErrorModel.parse("exact") is ErrorModel.EXACT, ErrorModel.PAPER.value
    (True, 'paper')
    """

    PAPER = "paper"
    EXACT = "exact"

    @classmethod
    def parse(cls, value: str | ErrorModel) -> ErrorModel:
        """The member for ``value`` (``"paper"``, ``"exact"`` or a member).

        Parameters
        ----------
        value : str or ErrorModel
            What to parse.

        Returns
        -------
        ErrorModel
            The member.

        Raises
        ------
        fsmctl.symbolic.symbols.DerivationInputError
            ``value`` names no error model.
        """
        try:
            return cls(value)
        except ValueError:
            raise DerivationInputError(f"error model must be one of {[m.value for m in cls]}, got {value!r}") from None


@dataclass(frozen=True)
class LagrangeModel:
    """``M sigma_e_ddot + C sigma_e_dot + G^-T E = G^-T u`` (eq 9) and the pieces it is built from."""

    M: sp.ImmutableMatrix
    C: sp.ImmutableMatrix
    E: sp.ImmutableMatrix
    G: sp.ImmutableMatrix
    G_inverse: sp.ImmutableMatrix
    G_dot: sp.ImmutableMatrix
    omega_r: sp.ImmutableMatrix
    """Reference rate in the body frame (``omega_d`` or ``R omega_d``)."""
    error_model: ErrorModel


def euler_rotational_dynamics(J, omega, torque) -> sp.ImmutableMatrix:
    """``omega_dot = J^-1 (-omega^x J omega + torque)`` (eq 4), with ``J^-1 = adj(J)/det(J)``."""
    J = as_symmetric_matrix3(J, "J")
    omega = as_vector3(omega, "omega")
    torque = as_vector3(torque, "torque")
    return sp.ImmutableMatrix(J.adjugate() * (-skew(omega) * J * omega + torque) / J.det())


def plant_rhs(J, sigma, omega, torque) -> tuple[sp.ImmutableMatrix, sp.ImmutableMatrix]:
    """Rigid-body attitude motion: ``(sigma_dot, omega_dot)`` from eqs 3-4.

    ``torque`` is everything applied to the body (control plus disturbance).
    """
    sigma = as_vector3(sigma, "sigma")
    return sp.ImmutableMatrix(mrp_G(sigma) * as_vector3(omega, "omega")), euler_rotational_dynamics(J, omega, torque)


def _dcm(sigma_e, dcm) -> sp.ImmutableMatrix:
    return mrp_to_dcm(as_vector3(sigma_e, "sigma_e")) if dcm is None else sp.ImmutableMatrix(dcm)


def reference_rate_in_body(error_model, sigma_e, omega_d, *, dcm=None) -> sp.ImmutableMatrix:
    """``omega_r``: the desired rate as seen in the body frame (eq 8 vs. exact).

    ``dcm`` may replace ``R(sigma_e)`` by an opaque matrix in proofs.
    """
    model = ErrorModel.parse(error_model)
    omega_d = as_vector3(omega_d, "omega_d")
    if model is ErrorModel.PAPER:
        return omega_d
    return sp.ImmutableMatrix(_dcm(sigma_e, dcm) * omega_d)


def error_angular_velocity(error_model, sigma_e, omega, omega_d, *, dcm=None) -> sp.ImmutableMatrix:
    """``omega_e = omega - omega_d`` (eq 8, paper) or ``omega - R(sigma_e) omega_d`` (exact)."""
    return sp.ImmutableMatrix(
        as_vector3(omega, "omega") - reference_rate_in_body(error_model, sigma_e, omega_d, dcm=dcm)
    )


def reference_acceleration_in_body(
    error_model, sigma_e, omega_e, omega_d, omega_d_dot, *, dcm=None
) -> sp.ImmutableMatrix:
    """Body-frame derivative of ``omega_r``: ``omega_d_dot`` (paper) or ``R omega_d_dot + omega_r^x omega_e`` (exact).

    The exact form uses ``d/dt R = -omega_e^x R`` (proved in
    :func:`fsmctl.proofs.identities.verify_dcm_kinematics`).
    """
    model = ErrorModel.parse(error_model)
    omega_d_dot = as_vector3(omega_d_dot, "omega_d_dot")
    if model is ErrorModel.PAPER:
        return omega_d_dot
    R = _dcm(sigma_e, dcm)
    omega_r = R * as_vector3(omega_d, "omega_d")
    return sp.ImmutableMatrix(R * omega_d_dot + skew(omega_r) * as_vector3(omega_e, "omega_e"))


def lagrange_model(
    J,
    sigma_e,
    sigma_e_dot,
    omega_d,
    omega_d_dot,
    error_model: str | ErrorModel = ErrorModel.PAPER,
    *,
    G_inverse=None,
    dcm=None,
    require_positive_definite: bool = True,
) -> LagrangeModel:
    """Lagrange-like model ``M sigma_e_ddot + C sigma_e_dot + G^-T E = G^-T u`` (Liang et al. 2012, eq 9), corrected.

    ``M = G^-T J G^-1``;
    ``C = -M G_dot G^-1 - G^-T (J G^-1 sigma_e_dot)^x G^-1 + G^-T (omega_r^x J - (J omega_r)^x + chi J omega_r^x) G^-1``;
    ``E = J omega_r_dot|_(omega_e=0) + omega_r^x J omega_r``,
    where ``chi = 0`` (paper) or 1 (exact).  The printed ``C`` lacks the
    ``-(J omega_d)^x`` term: see :func:`lagrange_C_as_printed` and the errata (:func:`fsmctl.proofs.errata`).

    Parameters
    ----------
    J : 3x3 matrix
        The inertia (kg m^2), symmetric; positive definite unless ``require_positive_definite=False``.
    sigma_e, sigma_e_dot : sequence or Matrix
        The attitude error (MRP) and its time derivative.
    omega_d, omega_d_dot : sequence or Matrix
        The reference rate and angular acceleration (rad/s, rad/s^2).
    error_model : ErrorModel or str
        ``"paper"`` (eqs 7-8 as printed) or ``"exact"``.
    G_inverse, dcm : Matrix, optional
        Opaque matrices of symbols standing for ``G(sigma_e)^-1`` and ``C(sigma_e)``, so that identities can
        be proved without expanding the closed forms.
    require_positive_definite : bool
        The model is linear in ``J``; pass False to evaluate it at an (indefinite) inertia perturbation
        ``Delta_J`` (Theorem 2, eqs 29-33).

    Returns
    -------
    LagrangeModel
        ``M``, ``C``, ``E`` and the pieces ``G``, ``G_inverse``, ``G_dot``, ``omega_r`` they are built from.

    Raises
    ------
    fsmctl.symbolic.symbols.DerivationInputError
        Malformed inputs (shapes, a non-symmetric or non-positive-definite ``J``, an unknown error model).

    Examples
    --------
    At ``sigma_e = 0`` the kinematic matrix is ``G = I/4``, so ``M = 16 J``; with a reference at rest
    ``C`` and ``E`` vanish:

    >>> import sympy as sp
    >>> from fsmctl.symbolic import lagrange_model
    >>> J = sp.Matrix([[100, 1, 2], [1, 150, 1], [2, 1, 200]])  # J0 of agent 1, Section 4
    >>> m = lagrange_model(J, [0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0])
    >>> m.M == 16 * J, m.C == sp.zeros(3), m.E == sp.zeros(3, 1)
    (True, True, True)

    With a rotating reference ``E = J omega_d_dot + omega_d^x J omega_d`` (eq 9):

    >>> from fsmctl.symbolic import skew, vector_symbols
    >>> wd, wdd = vector_symbols("omega_d"), vector_symbols("omega_d_dot")
    >>> m = lagrange_model(J, [0, 0, 0], [0, 0, 0], wd, wdd)
    >>> sp.expand(m.E - (J * wdd + skew(wd) * J * wd)) == sp.zeros(3, 1)
    True
    """
    model = ErrorModel.parse(error_model)
    J = as_symmetric_matrix3(J, "J", positive_definite=require_positive_definite)
    sigma_e = as_vector3(sigma_e, "sigma_e")
    sigma_e_dot = as_vector3(sigma_e_dot, "sigma_e_dot")
    omega_d = as_vector3(omega_d, "omega_d")
    omega_d_dot = as_vector3(omega_d_dot, "omega_d_dot")
    G = mrp_G(sigma_e)
    Gi = mrp_G_inverse(sigma_e) if G_inverse is None else sp.ImmutableMatrix(G_inverse)
    Gd = mrp_G_dot(sigma_e, sigma_e_dot)
    M = Gi.T * J * Gi
    omega_r = reference_rate_in_body(model, sigma_e, omega_d, dcm=dcm)
    chi = 1 if model is ErrorModel.EXACT else 0
    C = (
        -M * Gd * Gi
        - Gi.T * skew(J * Gi * sigma_e_dot) * Gi
        + Gi.T * (skew(omega_r) * J - skew(J * omega_r) + chi * J * skew(omega_r)) * Gi
    )
    omega_r_dot_feedforward = reference_acceleration_in_body(
        model, sigma_e, sp.zeros(3, 1), omega_d, omega_d_dot, dcm=dcm
    )
    E = J * omega_r_dot_feedforward + skew(omega_r) * J * omega_r
    return LagrangeModel(
        M=sp.ImmutableMatrix(M),
        C=sp.ImmutableMatrix(C),
        E=sp.ImmutableMatrix(E),
        G=G,
        G_inverse=Gi,
        G_dot=Gd,
        omega_r=omega_r,
        error_model=model,
    )


def lagrange_C_as_printed(J, sigma_e, sigma_e_dot, omega_d, *, G_inverse=None) -> sp.ImmutableMatrix:
    """``C`` exactly as printed under eq 9 (and as ``C0`` under eq 29).

    ``C = -M G_dot G^-1 - G^-T (J G^-1 sigma_e_dot)^x G^-1 + G^-T omega_d^x J G^-1``.
    """
    J = as_symmetric_matrix3(J, "J")
    sigma_e = as_vector3(sigma_e, "sigma_e")
    sigma_e_dot = as_vector3(sigma_e_dot, "sigma_e_dot")
    omega_d = as_vector3(omega_d, "omega_d")
    Gi = mrp_G_inverse(sigma_e) if G_inverse is None else sp.ImmutableMatrix(G_inverse)
    Gd = mrp_G_dot(sigma_e, sigma_e_dot)
    M = Gi.T * J * Gi
    return sp.ImmutableMatrix(-M * Gd * Gi - Gi.T * skew(J * Gi * sigma_e_dot) * Gi + Gi.T * skew(omega_d) * J * Gi)


def lagrange_uncertainty(
    J0, delta_J, sigma_e, sigma_e_dot, sigma_e_ddot, omega_d, omega_d_dot, u_d, error_model=ErrorModel.PAPER
) -> sp.ImmutableMatrix:
    """Exact lumped uncertainty ``Delta_d`` of eq 29.

    With ``J = J0 + Delta_J`` the true model is ``M sigma_e_ddot + C sigma_e_dot + G^-T E = G^-T (u + u_d)``.
    Rewriting it around the nominal ``(M0, C0, E0)`` as in eq 29,
    ``M0 sigma_e_ddot + C0 sigma_e_dot + G^-T E0 = G^-T u + G^-T Delta_d``, gives
    ``Delta_d = u_d - G^T (Delta_M sigma_e_ddot + Delta_C sigma_e_dot) - Delta_E``,
    and since ``M, C, E`` are linear in ``J``, ``Delta_M, Delta_C, Delta_E`` are the
    model evaluated at ``Delta_J``.  Note that ``Delta_d`` depends on
    ``sigma_e_ddot``, i.e. on the control itself.
    """
    as_symmetric_matrix3(J0, "J0")
    pert = lagrange_model(
        delta_J, sigma_e, sigma_e_dot, omega_d, omega_d_dot, error_model, require_positive_definite=False
    )
    return sp.ImmutableMatrix(
        as_vector3(u_d, "u_d")
        - pert.G.T
        * (pert.M * as_vector3(sigma_e_ddot, "sigma_e_ddot") + pert.C * as_vector3(sigma_e_dot, "sigma_e_dot"))
        - pert.E
    )


def lagrange_uncertainty_as_printed(J0, delta_J, sigma_e, sigma_e_dot, omega_d, omega_d_dot, u_d) -> list:
    """The terms of ``Delta_d`` as printed under eq 29, returned as a list (they do not add up).

    As printed: ``Delta_d = -G^-T dJ G^-1 + G^-T dJ G^-1 G_dot G^-1 + G^-T (dJ G^-1 sigma_e_dot)^x G^-1
    - G^-T omega_d^x dJ G^-1 - dJ omega_d_dot - omega_d^x dJ omega_d + u_d``.
    The first four terms are 3x3 matrices and the last three are 3-vectors:
    the printed sum is not defined.  ``J0`` is unused and kept for symmetry with
    :func:`lagrange_uncertainty`.
    """
    _ = J0
    dJ = as_symmetric_matrix3(delta_J, "delta_J", positive_definite=False)
    sigma_e = as_vector3(sigma_e, "sigma_e")
    Gi = mrp_G_inverse(sigma_e)
    Gd = mrp_G_dot(sigma_e, sigma_e_dot)
    wd = as_vector3(omega_d, "omega_d")
    return [
        -Gi.T * dJ * Gi,
        Gi.T * dJ * Gi * Gd * Gi,
        Gi.T * skew(dJ * Gi * as_vector3(sigma_e_dot, "sigma_e_dot")) * Gi,
        -Gi.T * skew(wd) * dJ * Gi,
        -dJ * as_vector3(omega_d_dot, "omega_d_dot"),
        -skew(wd) * dJ * wd,
        as_vector3(u_d, "u_d"),
    ]
