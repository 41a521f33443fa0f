"""Modified Rodrigues parameters, symbolically (Liang et al. 2012, eqs 2, 3, 5, 6).

Conventions (Schaub & Junkins): ``sigma = n tan(theta/4)`` describes the frame B
relative to N; :func:`mrp_to_dcm` returns the direction-cosine matrix ``[BN]``
that maps N-frame components to B-frame components; angular velocities are
body-frame components.  The kinematics are ``sigma_dot = G(sigma) omega`` (eq 3).

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

import sympy as sp

from fsmctl.symbolic.symbols import as_vector3

__all__ = [
    "skew",
    "mrp_G",
    "mrp_G_inverse",
    "mrp_G_dot",
    "mrp_to_dcm",
    "mrp_to_quaternion",
    "quaternion_product",
    "quaternion_to_mrp",
    "mrp_compose",
    "mrp_error",
    "mrp_shadow",
    "mrp_principal_angle",
    "mrp_kinematics",
]


def skew(v) -> sp.ImmutableMatrix:
    """Skew-symmetric cross-product matrix ``v^x`` with ``v^x w = v x w`` (Liang et al. 2012, eq 6).

    Parameters
    ----------
    v : sequence or Matrix
        Three components (numbers or SymPy expressions).

    Returns
    -------
    sympy.ImmutableMatrix
        ``[[0, -v3, v2], [v3, 0, -v1], [-v2, v1, 0]]``.

    Raises
    ------
    fsmctl.symbolic.symbols.DerivationInputError
        ``v`` is not a 3-vector.

    Examples
    --------
    >>> import sympy as sp
    >>> from fsmctl.symbolic import skew
    >>> skew([1, 2, 3])
    Matrix([
    [ 0, -3,  2],
    [ 3,  0, -1],
    [-2,  1,  0]])
    >>> skew([1, 2, 3]) * sp.Matrix([4, 5, 6]) == sp.Matrix([1, 2, 3]).cross(sp.Matrix([4, 5, 6]))
    True
    """
    v = as_vector3(v, "v")
    return sp.ImmutableMatrix([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def _sq(v: sp.MatrixBase) -> sp.Expr:
    return (v.T * v)[0, 0]


def mrp_G(sigma) -> sp.ImmutableMatrix:
    """Kinematic matrix ``G(sigma) = 1/4 [(1 - sigma^T sigma) I + 2 sigma^x + 2 sigma sigma^T]`` (eq 5).

    Liang et al. 2012, eq 5 (the MRP kinematic matrix of Schaub & Junkins).

    The MRP kinematics are ``sigma_dot = G(sigma) omega`` (eq 3, :func:`mrp_kinematics`).

    Parameters
    ----------
    sigma : sequence or Matrix
        The MRP ``sigma`` (3 components, numbers or SymPy expressions).

    Returns
    -------
    sympy.ImmutableMatrix
        The 3x3 matrix ``G(sigma)``.

    Examples
    --------
    At the identity attitude ``G = I/4``; in general ``G G^T = ((1 + sigma^T sigma)/4)^2 I``:

    >>> import sympy as sp
    >>> from fsmctl.symbolic import mrp_G, vector_symbols
    >>> mrp_G([0, 0, 0])
    Matrix([
    [1/4,   0,   0],
    [  0, 1/4,   0],
    [  0,   0, 1/4]])
    >>> sigma = vector_symbols("sigma")
    >>> s2 = (sigma.T * sigma)[0]
    >>> sp.simplify(mrp_G(sigma) * mrp_G(sigma).T - ((1 + s2) / 4) ** 2 * sp.eye(3)) == sp.zeros(3)
    True
    """
    sigma = as_vector3(sigma, "sigma")
    return sp.ImmutableMatrix(((1 - _sq(sigma)) * sp.eye(3) + 2 * skew(sigma) + 2 * sigma * sigma.T) / 4)


def mrp_G_inverse(sigma) -> sp.ImmutableMatrix:
    """Closed-form inverse ``G^-1 = 16 / (1 + sigma^T sigma)^2 G^T`` of the MRP kinematic matrix (eq 5).

    It follows from ``G G^T = ((1 + sigma^T sigma)/4)^2 I``, which
    :func:`fsmctl.proofs.identities.verify_G_inverse` proves; ``G`` is therefore invertible
    for every real ``sigma``.  It appears in the Lagrange-like model (Liang et al. 2012, eq 9).

    Parameters
    ----------
    sigma : sequence or Matrix
        The MRP ``sigma`` (3 components).

    Returns
    -------
    sympy.ImmutableMatrix
        The 3x3 matrix ``G(sigma)^-1``.

    Examples
    --------
    >>> import sympy as sp
    >>> from fsmctl.symbolic import mrp_G, mrp_G_inverse, vector_symbols
    >>> sigma = vector_symbols("sigma")
    >>> sp.simplify(mrp_G(sigma) * mrp_G_inverse(sigma))
    Matrix([
    [1, 0, 0],
    [0, 1, 0],
    [0, 0, 1]])
    """
    sigma = as_vector3(sigma, "sigma")
    return sp.ImmutableMatrix(16 / (1 + _sq(sigma)) ** 2 * mrp_G(sigma).T)


def mrp_G_dot(sigma, sigma_dot) -> sp.ImmutableMatrix:
    """Time derivative ``G_dot = sum_k dG/dsigma_k sigma_dot_k``, linear in ``sigma_dot``."""
    sigma = as_vector3(sigma, "sigma")
    sigma_dot = as_vector3(sigma_dot, "sigma_dot")
    # G is quadratic in sigma; its directional derivative along sigma_dot, written out:
    return sp.ImmutableMatrix(
        (
            -2 * _dot(sigma, sigma_dot) * sp.eye(3)
            + 2 * skew(sigma_dot)
            + 2 * (sigma_dot * sigma.T + sigma * sigma_dot.T)
        )
        / 4
    )


def _dot(a: sp.MatrixBase, b: sp.MatrixBase) -> sp.Expr:
    return (a.T * b)[0, 0]


def mrp_to_dcm(sigma) -> sp.ImmutableMatrix:
    """Direction-cosine matrix ``[BN] = I + (8 (sigma^x)^2 - 4 (1 - sigma^T sigma) sigma^x) / (1 + sigma^T sigma)^2``.

    ``[BN]`` maps N-frame components to B-frame components (Schaub & Junkins; Liang et al. 2012, eq 2 for the MRP).

    Parameters
    ----------
    sigma : sequence or Matrix
        The MRP of B relative to N (3 components).

    Returns
    -------
    sympy.ImmutableMatrix
        The 3x3 rotation matrix ``[BN]``.

    Examples
    --------
    A rotation of 90 degrees about the first axis (``sigma = tan(theta/4) e1``):

    >>> import sympy as sp
    >>> from fsmctl.symbolic import mrp_to_dcm
    >>> sp.simplify(mrp_to_dcm([sp.tan(sp.pi / 8), 0, 0]))
    Matrix([
    [1,  0, 0],
    [0,  0, 1],
    [0, -1, 0]])
    """
    sigma = as_vector3(sigma, "sigma")
    s2 = _sq(sigma)
    sx = skew(sigma)
    return sp.ImmutableMatrix(sp.eye(3) + (8 * sx * sx - 4 * (1 - s2) * sx) / (1 + s2) ** 2)


def mrp_to_quaternion(sigma) -> tuple[sp.Expr, sp.ImmutableMatrix]:
    """Euler parameters ``(q0, q_v)`` of an MRP: ``q0 = (1 - |sigma|^2)/(1 + |sigma|^2)``, ``q_v = 2 sigma/(1 + |sigma|^2)``."""
    sigma = as_vector3(sigma, "sigma")
    s2 = _sq(sigma)
    return (1 - s2) / (1 + s2), sp.ImmutableMatrix(2 * sigma / (1 + s2))


def quaternion_product(q_outer, q_inner) -> tuple[sp.Expr, sp.ImmutableMatrix]:
    """Euler parameters of ``[FN] = [FB][BN]`` from ``q_outer`` = ``[FB]`` and ``q_inner`` = ``[BN]``."""
    a0, av = q_outer
    b0, bv = q_inner
    av = as_vector3(av, "q_outer vector part")
    bv = as_vector3(bv, "q_inner vector part")
    q0 = a0 * b0 - _dot(av, bv)
    qv = a0 * bv + b0 * av - skew(av) * bv
    return q0, sp.ImmutableMatrix(qv)


def quaternion_to_mrp(q0, qv) -> sp.ImmutableMatrix:
    """MRP of a unit quaternion, choosing the sign with ``q0 >= 0`` so that ``|sigma| <= 1``.

    ``sigma = sgn+(q0) q_v / (1 + |q0|)`` with ``sgn+(0) = 1``: the denominator is at
    least 1, so the map is never singular, and it returns the short-rotation
    member of the pair {sigma, shadow(sigma)}.
    """
    qv = as_vector3(qv, "q_v")
    sign = sp.Piecewise((1, q0 >= 0), (-1, True))
    return sp.ImmutableMatrix(sign * qv / (1 + sp.Abs(q0)))


def mrp_compose(sigma_outer, sigma_inner) -> sp.ImmutableMatrix:
    """MRP of ``[FN] = [FB][BN]`` by the direct formula (Schaub & Junkins).

    ``sigma = ((1-|s'|^2) s'' + (1-|s''|^2) s' - 2 s'' x s') / (1 + |s'|^2 |s''|^2 - 2 s'.s'')``
    with ``s''`` = ``sigma_outer`` ([FB]) and ``s'`` = ``sigma_inner`` ([BN]).  The
    denominator vanishes for a composite rotation of 360 deg; :func:`mrp_error`
    avoids that through quaternions and is what the generated code uses.
    """
    a = as_vector3(sigma_outer, "sigma_outer")
    b = as_vector3(sigma_inner, "sigma_inner")
    num = (1 - _sq(b)) * a + (1 - _sq(a)) * b - 2 * skew(a) * b
    den = 1 + _sq(a) * _sq(b) - 2 * _dot(a, b)
    return sp.ImmutableMatrix(num / den)


def mrp_error(sigma, sigma_d) -> sp.ImmutableMatrix:
    """Attitude error ``sigma_e`` with ``[B R] = [B N][R N]^T``, in the shadow set (``|sigma_e| <= 1``).

    This is the MRP composition of ``sigma`` with ``sigma_d^-1 = -sigma_d``
    (Liang et al. 2012, Sec. 2.2, "the absolute attitude error", whose kinematics are eqs 7-8), computed
    through Euler parameters so that it is defined for every pair of inputs.

    Parameters
    ----------
    sigma : sequence or Matrix
        The body attitude (MRP, B relative to N).
    sigma_d : sequence or Matrix
        The desired attitude (MRP, R relative to N).

    Returns
    -------
    sympy.ImmutableMatrix
        ``sigma_e`` (3 components), the MRP of B relative to R.

    Examples
    --------
    Two rotations about the same axis: the error is the difference of the angles (here 60 - 20 degrees):

    >>> import sympy as sp
    >>> from fsmctl.symbolic import mrp_error
    >>> angle = lambda deg: [sp.tan(sp.rad(deg) / 4), 0, 0]
    >>> err = mrp_error(angle(60), angle(20))
    >>> [float(x) for x in err] == [float(sp.tan(sp.rad(40) / 4)), 0.0, 0.0]
    True
    >>> mrp_error([0.1, 0.2, 0.3], [0.1, 0.2, 0.3]).T
    Matrix([[0, 0, 0]])
    """
    q = mrp_to_quaternion(as_vector3(sigma, "sigma"))
    qd0, qdv = mrp_to_quaternion(as_vector3(sigma_d, "sigma_d"))
    q0, qv = quaternion_product(q, (qd0, -qdv))
    return quaternion_to_mrp(q0, qv)


def mrp_shadow(sigma) -> sp.ImmutableMatrix:
    """Shadow-set switching: ``-sigma / |sigma|^2`` when ``|sigma| > 1``, else ``sigma``."""
    sigma = as_vector3(sigma, "sigma")
    s2 = _sq(sigma)
    return sp.ImmutableMatrix([sp.Piecewise((-x / s2, s2 > 1), (x, True)) for x in sigma])


def mrp_principal_angle(sigma) -> sp.Expr:
    """Euler principal angle ``theta = 4 atan(|sigma|)`` (eq 2), in ``[0, pi]`` on the shadow set."""
    sigma = as_vector3(sigma, "sigma")
    return 4 * sp.atan(sp.sqrt(_sq(sigma)))


def mrp_kinematics(sigma, omega) -> sp.ImmutableMatrix:
    """MRP kinematics ``sigma_dot = G(sigma) omega`` (Liang et al. 2012, eq 3, with ``G`` of eq 5).

    Parameters
    ----------
    sigma : sequence or Matrix
        The MRP (3 components).
    omega : sequence or Matrix
        The body angular velocity (body-frame components, rad/s).

    Returns
    -------
    sympy.ImmutableMatrix
        ``sigma_dot`` (3 components, 1/s).

    Examples
    --------
    >>> from fsmctl.symbolic import mrp_kinematics
    >>> mrp_kinematics([0, 0, 0], [1, 2, 3]).T  # G(0) = I/4
    Matrix([[1/4, 1/2, 3/4]])
    """
    return sp.ImmutableMatrix(mrp_G(sigma) * as_vector3(omega, "omega"))
