"""Bad input to the derivation entry points gets a clear DerivationInputError."""

from __future__ import annotations

import pytest
import sympy as sp

from fsmctl.symbolic.controller import (
    SingularityFix,
    closed_loop_acceleration,
    saturate,
    sliding_variable,
    switching_function,
)
from fsmctl.symbolic.model import ErrorModel, euler_rotational_dynamics, lagrange_model, lagrange_uncertainty
from fsmctl.symbolic.mrp import mrp_error, mrp_G, skew
from fsmctl.symbolic.symbols import DerivationInputError, check_alpha, symmetric_matrix_symbols, vector_symbols

sigma = vector_symbols("sigma")
J = symmetric_matrix_symbols("J")


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: mrp_G([1, 2]), "expected a 3-vector"),
        (lambda: skew(sp.zeros(3, 3)), "expected a 3-vector"),
        (lambda: mrp_error(sigma, "abc"), "expected a SymPy matrix"),
        (lambda: euler_rotational_dynamics(sp.Matrix([[1, 2, 0], [0, 1, 0], [0, 0, 1]]), sigma, sigma), "symmetric"),
        (
            lambda: euler_rotational_dynamics(sp.Matrix(3, 3, lambda i, j: sp.Symbol(f"q{i}{j}")), sigma, sigma),
            "symmetric",
        ),
        (lambda: euler_rotational_dynamics(sp.diag(1, -2, 3), sigma, sigma), "positive definite"),
        (lambda: euler_rotational_dynamics(sp.eye(2), sigma, sigma), "3x3"),
        (lambda: lagrange_model(J, sigma, sigma, sigma, sigma, "approximate"), "error model must be one of"),
        (
            lambda: lagrange_uncertainty(
                J, sp.Matrix([[0, 1, 0], [0, 0, 0], [0, 0, 0]]), sigma, sigma, sigma, sigma, sigma, sigma
            ),
            "symmetric",
        ),
        (lambda: sliding_variable(sigma, sigma, 1, 1, sp.Rational(1, 2)), "0.5 < alpha < 1"),
        (lambda: sliding_variable(sigma, sigma, 1, 1, 1), "0.5 < alpha < 1"),
        (lambda: sliding_variable(sigma, sigma, -1, 1, sp.Rational(7, 10)), "c1 must be non-negative"),
        (
            lambda: sliding_variable(sigma, sigma, 1, 1, sp.Rational(7, 10), fix="smooth"),
            "singularity fix must be one of",
        ),
        (lambda: switching_function(sigma, -1), "boundary layer must be >= 0"),
        (lambda: saturate(sigma, 0), "torque limit must be positive"),
        (lambda: closed_loop_acceleration(sigma, sigma, sigma, 1, 1, sp.Rational(7, 10), [1, 2], sigma), "3-vector"),
        (lambda: check_alpha(sp.I), "must be real"),
    ],
)
def test_bad_input_is_rejected_with_a_clear_message(call, message):
    with pytest.raises(DerivationInputError, match=message):
        call()


def test_symbolic_alpha_and_fix_are_accepted():
    alpha = sp.Symbol("alpha", positive=True)
    s = sliding_variable(sigma, sigma, 1, 1, alpha, fix=SingularityFix.CLAMP)
    assert s.shape == (3, 1)
    assert ErrorModel.parse("exact") is ErrorModel.EXACT
    assert SingularityFix.parse(1) is SingularityFix.SWITCH
