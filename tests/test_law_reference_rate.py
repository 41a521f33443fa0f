"""What the LawBuilder documentation says about the reference rate is what the law computes.

``omega_d`` has reference-frame components (``sigma_d_dot = G(sigma_d) omega_d``); the law sees the reference rate
in the body frame as ``omega_r = C(sigma_e) omega_d`` (exact model; ``omega_d`` in the paper's), whose derivative
is ``omega_r_dot = C(sigma_e) omega_d_dot + omega_r^x omega_e`` (exact; ``omega_d_dot`` in the paper's).

Oracle, independent of :func:`fsmctl.symbolic.model.reference_acceleration_in_body`: the reference frame's rate in
body components is ``[BN][RN]^T omega_d`` (two direction-cosine matrices, no MRP composition), and its time
derivative is taken by the chain rule along ``sigma_dot = G(sigma) omega`` and ``sigma_d_dot = G(sigma_d)
omega_d``.  Everything is evaluated exactly (rationals) at a few states.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import sympy as sp

from fsmctl.symbolic import LawBuilder, mrp_G, mrp_to_dcm, skew

GUIDE = Path(__file__).resolve().parent.parent / "docs" / "guide" / "own-law.md"

# the formulas as the LawBuilder docstring and the own-law guide write them (checked below)
DOCSTRING_FORMULAS = (
    "sigma_d_dot = G(sigma_d) omega_d",
    "omega_r = C(sigma_e) omega_d",
    "omega_r_dot = C(sigma_e) omega_d_dot + omega_r^x omega_e",
    "omega_r_dot = omega_d_dot",
)
GUIDE_FORMULAS = ("σ̇_d = G(σ_d) ω_d", "ω_r = C(σ_e) ω_d", "ω̇_r = C(σ_e) ω̇_d + ω_r × ω_e", "ω̇_r = ω̇_d")


def test_the_formulas_are_written_where_a_law_author_reads():
    doc = " ".join(LawBuilder.__doc__.split())
    assert all(f in doc for f in DOCSTRING_FORMULAS), [f for f in DOCSTRING_FORMULAS if f not in doc]
    assert "inertial-frame" not in doc and "R-frame components" in doc
    guide = GUIDE.read_text(encoding="utf-8")
    assert all(f in guide for f in GUIDE_FORMULAS), [f for f in GUIDE_FORMULAS if f not in guide]


STATES = [
    # sigma, omega, sigma_d, omega_d, omega_d_dot
    ((1, -2, 3), (3, 1, -2), (-2, 1, 1), (1, 2, -1), (-1, 3, 2)),
    ((4, 1, -1), (-1, 2, 2), (1, 3, -2), (-2, 1, 3), (2, -1, 1)),
    ((0, 0, 0), (1, 1, 1), (2, -3, 1), (3, -1, 2), (1, 1, -3)),
]


def _at(values, scale):
    return sp.Matrix([sp.Rational(v, scale) for v in values])


def _law_and_error(error_model: str):
    b = LawBuilder("doc_rate", error_model, doc="reads the error state")
    e = b.error_state()
    b.broadcast("sigma_e", e.sigma_e)
    b.torque(e.omega_e + e.omega_r + e.omega_r_dot)  # every stage reaches the torque, so the law keeps them
    return b, b.build(), e


def _zero(m) -> bool:
    return all(sp.simplify(x) == 0 for x in m)


@pytest.mark.parametrize("error_model", ["paper", "exact"])
def test_documented_reference_rate_and_its_derivative(error_model):
    b, law, e = _law_and_error(error_model)
    stages = {name: law.expanded(getattr(e, name)) for name in ("sigma_e", "omega_e", "omega_r", "omega_r_dot")}
    # the reference frame's rate in body components, and its time derivative by the chain rule
    true_omega_r = mrp_to_dcm(b.sigma) * mrp_to_dcm(b.sigma_d).T * b.omega_d
    true_omega_r_dot = (
        true_omega_r.jacobian(b.sigma) * mrp_G(b.sigma) * b.omega
        + true_omega_r.jacobian(b.sigma_d) * mrp_G(b.sigma_d) * b.omega_d
        + true_omega_r.jacobian(b.omega_d) * b.omega_d_dot
    )
    for sigma, omega, sigma_d, omega_d, omega_d_dot in STATES:
        x = {
            "sigma": _at(sigma, 10),
            "omega": _at(omega, 20),
            "sigma_d": _at(sigma_d, 10),
            "omega_d": _at(omega_d, 50),
            "omega_d_dot": _at(omega_d_dot, 100),
        }
        at = {s: v for name, value in x.items() for s, v in zip(getattr(b, name), value, strict=True)}
        value = {name: expr.xreplace(at) for name, expr in stages.items()}
        if error_model == "exact":  # the documented formulas, with C = C(sigma_e) the DCM of the error MRP
            C = mrp_to_dcm(value["sigma_e"])
            omega_r = C * x["omega_d"]
            omega_r_dot = C * x["omega_d_dot"] + skew(omega_r) * value["omega_e"]
            assert _zero(true_omega_r.xreplace(at) - omega_r)  # omega_d has reference-frame components
            assert _zero(true_omega_r_dot.xreplace(at) - omega_r_dot)
        else:  # the paper's eqs 7-8
            omega_r, omega_r_dot = x["omega_d"], x["omega_d_dot"]
        assert _zero(value["omega_r"] - omega_r)
        assert _zero(value["omega_r_dot"] - omega_r_dot)
        assert _zero(value["omega_e"] - (x["omega"] - omega_r))
