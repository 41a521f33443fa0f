"""Symbol factories and input checks shared by the derivation.

Pure SymPy: no NumPy, no I/O.  Every public function of :mod:`derive` accepts
either symbols or numbers; the checks here turn malformed input (wrong shapes,
a non-symmetric inertia, an exponent outside the paper's range) into a clear
:class:`DerivationInputError` instead of a SymPy traceback deep inside an
expression.
"""

from __future__ import annotations

from collections.abc import Sequence

import sympy as sp

from fsmctl.errors import InputError

__all__ = [
    "DerivationInputError",
    "as_vector3",
    "as_matrix3",
    "as_symmetric_matrix3",
    "as_scalar",
    "check_alpha",
    "vector_symbols",
    "symmetric_matrix_symbols",
    "matrix_symbols",
]


class DerivationInputError(InputError):
    """Raised when a derivation entry point receives malformed input (an :class:`~fsmctl.errors.InputError`)."""


def vector_symbols(name: str, n: int = 3, real: bool = True) -> sp.ImmutableMatrix:
    """Column vector ``[name[0], ..., name[n-1]]`` of real symbols (e.g. ``sigma``, ``omega`` of eqs 3-4).

    Parameters
    ----------
    name : str
        The base name; component ``k`` is the symbol ``name[k]``.
    n : int
        Number of components.
    real : bool
        Whether the symbols are real (SymPy assumption).

    Returns
    -------
    sympy.ImmutableMatrix
        An ``n x 1`` column of symbols.  Equal names give equal symbols, so two calls agree.

    Examples
    --------
    >>> from fsmctl.symbolic import vector_symbols
    >>> sigma = vector_symbols("sigma")
    >>> sigma.T
    Matrix([[sigma[0], sigma[1], sigma[2]]])
    >>> sigma == vector_symbols("sigma"), sigma[0].is_real
    (True, True)
    """
    return sp.ImmutableMatrix([sp.Symbol(f"{name}[{k}]", real=real) for k in range(n)])


def symmetric_matrix_symbols(name: str) -> sp.ImmutableMatrix:
    """Symmetric 3x3 matrix of real symbols ``name[i,j]`` with ``i <= j`` (e.g. the inertia ``J0``, eq 4).

    Parameters
    ----------
    name : str
        The base name.

    Returns
    -------
    sympy.ImmutableMatrix
        3x3, entry ``(i, j)`` and ``(j, i)`` the same symbol ``name[min(i,j),max(i,j)]``.

    Examples
    --------
    >>> from fsmctl.symbolic import symmetric_matrix_symbols
    >>> J = symmetric_matrix_symbols("J0")
    >>> J
    Matrix([
    [J0[0,0], J0[0,1], J0[0,2]],
    [J0[0,1], J0[1,1], J0[1,2]],
    [J0[0,2], J0[1,2], J0[2,2]]])
    >>> J == J.T
    True
    """
    return sp.ImmutableMatrix(3, 3, lambda i, j: sp.Symbol(f"{name}[{min(i, j)},{max(i, j)}]", real=True))


def matrix_symbols(name: str, rows: int = 3, cols: int = 3) -> sp.ImmutableMatrix:
    """General ``rows x cols`` matrix of real symbols ``name[i,j]``."""
    return sp.ImmutableMatrix(rows, cols, lambda i, j: sp.Symbol(f"{name}[{i},{j}]", real=True))


def _as_matrix(value, what: str) -> sp.ImmutableMatrix:
    if isinstance(value, sp.MatrixBase):
        return sp.ImmutableMatrix(value)
    if isinstance(value, Sequence) and not isinstance(value, str):
        try:
            return sp.ImmutableMatrix(value)
        except (TypeError, ValueError) as exc:
            raise DerivationInputError(f"{what}: cannot be read as a matrix ({exc})") from None
    raise DerivationInputError(f"{what}: expected a SymPy matrix or a nested sequence, got {type(value).__name__}")


def as_vector3(value, what: str) -> sp.ImmutableMatrix:
    """Return ``value`` as a 3x1 column, or raise :class:`DerivationInputError`."""
    m = _as_matrix(value, what)
    if m.shape == (1, 3):
        m = m.T
    if m.shape != (3, 1):
        raise DerivationInputError(f"{what}: expected a 3-vector, got shape {m.shape}")
    return m


def as_matrix3(value, what: str) -> sp.ImmutableMatrix:
    """Return ``value`` as a 3x3 matrix, or raise :class:`DerivationInputError`."""
    m = _as_matrix(value, what)
    if m.shape != (3, 3):
        raise DerivationInputError(f"{what}: expected a 3x3 matrix, got shape {m.shape}")
    return m


def as_symmetric_matrix3(value, what: str = "J", *, positive_definite: bool = True) -> sp.ImmutableMatrix:
    """Return a 3x3 inertia-like matrix, rejecting non-symmetric input.

    Symmetry is decided structurally (``J[i,j] - J[j,i]`` must simplify to zero),
    so a symbolic inertia built by :func:`symmetric_matrix_symbols` passes and a
    matrix of nine independent symbols does not.  Numeric input must also be
    positive definite (all leading principal minors positive) unless
    ``positive_definite=False`` (an inertia perturbation may be indefinite).
    """
    m = as_matrix3(value, what)
    for i in range(3):
        for j in range(i + 1, 3):
            if sp.simplify(m[i, j] - m[j, i]) != 0:
                raise DerivationInputError(
                    f"{what} must be symmetric: {what}[{i},{j}] = {m[i, j]} but {what}[{j},{i}] = {m[j, i]}"
                )
    if positive_definite and all(x.is_number for x in m):
        for k in (1, 2, 3):
            minor = m[:k, :k].det()
            if not (minor.is_real and minor > 0):
                raise DerivationInputError(f"{what} must be positive definite: leading principal minor {k} is {minor}")
    return m


def as_scalar(value, what: str) -> sp.Expr:
    """Sympify a scalar, rejecting matrices and non-real numbers."""
    try:
        x = sp.sympify(value)
    except (sp.SympifyError, TypeError) as exc:
        raise DerivationInputError(f"{what}: not a scalar ({exc})") from None
    if isinstance(x, sp.MatrixBase) or not isinstance(x, sp.Expr):
        raise DerivationInputError(f"{what}: expected a scalar, got {type(value).__name__}")
    if x.is_number and not x.is_real:
        raise DerivationInputError(f"{what}: must be real, got {x}")
    return x


def check_alpha(alpha) -> sp.Expr:
    """The exponent of the fast sliding surface (eq 13): 0.5 < alpha < 1.

    A symbolic alpha is accepted as is (the proofs carry it); a number outside
    the open interval (0.5, 1) is rejected, because for alpha <= 0.5 the
    singular term of Remark 6 does not vanish on the surface and for alpha >= 1
    the surface is no longer terminal.
    """
    a = as_scalar(alpha, "alpha")
    if a.is_number and not (sp.Rational(1, 2) < a < 1):
        raise DerivationInputError(f"alpha must satisfy 0.5 < alpha < 1 (Liang et al. 2012, eq 13); got {a}")
    return a
