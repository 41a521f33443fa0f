"""Generated C, SymPy-lambdified and the independent NumPy oracle agree (issue: derive -> generated).

Hypothesis draws >= 200 random states, inertias and gains per property.  The oracle
(tests/oracle_numpy.py) is an independent transcription of the paper and of rigid-body
mechanics; it shares no code with derive/ or fsmctl/.
"""

from __future__ import annotations

import functools

import numpy as np
import oracle_numpy as oracle
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from spec_numpy import LambdifiedSpec

from derive.catalogue import function_catalogue
from derive.laws import fsm as fsm_script
from fsmctl.model.generated_code import casadi_function
from fsmctl.model.laws import resolve_law

SETTINGS = settings(max_examples=200, derandomize=True, deadline=None, database=None)
SPECS = {s.name: s for s in function_catalogue()}
for _model in ("paper", "exact"):  # the paper's law, generated once in its folder (generated/laws/fsm)
    _law = fsm_script.law(_model)
    SPECS.update({spec.name: spec for spec in (_law.constants_spec(), _law.local_spec(), _law.control_spec())})


@pytest.fixture(scope="module")
def lambdified():
    cache = {}

    def get(name):
        if name not in cache:
            cache[name] = LambdifiedSpec(SPECS[name])
        return cache[name]

    return get


def unit(x):
    return x / np.linalg.norm(x)


@st.composite
def inertias(draw):
    """Random symmetric positive-definite inertia: Q diag(lambda) Q^T."""
    lam = np.array([draw(st.floats(20.0, 400.0)) for _ in range(3)])
    axis = unit(np.array([draw(st.floats(-1, 1)) for _ in range(3)]) + np.array([1e-3, 0, 0]))
    angle = draw(st.floats(0, np.pi))
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    Q = np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K
    return Q @ np.diag(lam) @ Q.T


def vec(lo, hi):
    return st.tuples(*(st.floats(lo, hi) for _ in range(3))).map(np.array)


@st.composite
def states(draw):
    return dict(
        sigma=draw(vec(-1.2, 1.2)),
        omega=draw(vec(-0.8, 0.8)),
        sigma_d=draw(vec(-1.2, 1.2)),
        omega_d=draw(vec(-0.3, 0.3)),
        omega_d_dot=draw(vec(-0.05, 0.05)),
        c1=draw(st.floats(0.05, 3.0)),
        c2=draw(st.floats(0.05, 3.0)),
        alpha=draw(st.floats(0.55, 0.95)),
        delta=draw(vec(1e-3, 0.2)),
        coordination=draw(vec(-2.0, 2.0)),
        J0=draw(inertias()),
    )


def _law_inputs(x, fix=0, boundary_layer=0.0, u_max=np.inf):
    """The contract inputs of the paper's law (``generated/laws/fsm``) for a drawn state."""
    params = np.r_[x["c1"], x["c2"], x["alpha"], boundary_layer, 1e-4, fix, x["delta"]]
    constants = np.asarray(resolve_law("fsm").casadi("law_constants")(params)).ravel()
    # coordination = k_sum s - received; with k_sum = 0 the coordination vector is -received
    return dict(
        t=0.0,
        sigma=x["sigma"],
        omega=x["omega"],
        z=np.zeros(0),
        sigma_d=x["sigma_d"],
        omega_d=x["omega_d"],
        omega_d_dot=x["omega_d_dot"],
        J0=x["J0"],
        params=params,
        constants=constants,
        k_sum=0.0,
        received=-x["coordination"],
        k_received_sum=0.0,
        u_max=u_max,
    )


_LOCAL = ("t", "sigma", "omega", "z", "sigma_d", "omega_d", "omega_d_dot", "J0", "params", "constants")


def _fsm_law(model, inputs):
    """The paper's law's compiled ``law_local_<model>`` then ``law_control_<model>``: s, cache, u, u_commanded."""
    law = resolve_law("fsm")
    s, cache = law.casadi(f"law_local_{model}")(*(inputs[k] for k in _LOCAL))
    u, u_commanded, _ = law.casadi(f"law_control_{model}")(
        *(inputs[k] for k in _LOCAL), cache, *(inputs[k] for k in ("k_sum", "received", "k_received_sum", "u_max"))
    )
    return {k: np.asarray(v).ravel() for k, v in (("s", s), ("cache", cache), ("u", u), ("u_commanded", u_commanded))}


def _fsm_law_sympy(model, inputs, lambdified):
    """The same two functions evaluated from the law's SymPy stages (``sympy.lambdify``)."""
    local = lambdified(f"law_local_{model}")(**{k: inputs[k] for k in _LOCAL if k != "z"}, z=np.zeros((0, 1)))
    out = lambdified(f"law_control_{model}")(
        **{k: inputs[k] for k in _LOCAL if k != "z"},
        z=np.zeros((0, 1)),
        cache=local["cache"],
        **{k: inputs[k] for k in ("k_sum", "received", "k_received_sum", "u_max")},
    )
    return {"s": local["broadcast"].ravel(), "cache": local["cache"].ravel(), "u": out["u"].ravel(),
            "u_commanded": out["u_commanded"].ravel()}  # fmt: skip


def _well_conditioned(x, model):
    se, we, _ = oracle.error_rates(x["sigma"], x["omega"], x["sigma_d"], x["omega_d"], model)
    sd = oracle.mrp_G(se) @ we
    s = oracle.sliding_variable(se, sd, x["c1"], x["c2"], x["alpha"])
    # away from the sgn discontinuity and the Remark 6 singularity, so the raw law is smooth there
    return np.min(np.abs(se)) > 1e-3 and np.min(np.abs(s)) > 1e-6


def _oracle_law_args(x):
    """The positional arguments of the oracle's control-law functions, from a drawn state."""
    keys = ("J0", "sigma", "omega", "sigma_d", "omega_d", "omega_d_dot", "c1", "c2", "alpha", "delta", "coordination")
    return tuple(x[k] for k in keys)


@pytest.mark.parametrize("model", ["paper", "exact"])
@SETTINGS
@given(x=states())
def test_control_law_three_ways(model, x, lambdified):
    """The paper's law as generated once (``generated/laws/fsm``, compiled), its SymPy stages (lambdified) and the
    independent oracle (dynamic inversion; eqs 16-19 literally) agree: torque, sliding variable, error state."""
    assume(_well_conditioned(x, model))
    inputs = _law_inputs(x)
    compiled = _fsm_law(model, inputs)
    sym = _fsm_law_sympy(model, inputs, lambdified)
    args = _oracle_law_args(x)
    inverted = oracle.control_by_dynamic_inversion(*args, error_model=model)
    scale = 1.0 + np.abs(inverted).max()
    for key in ("u", "u_commanded", "s", "cache"):
        np.testing.assert_allclose(compiled[key], sym[key], rtol=1e-9, atol=1e-9 * scale, err_msg=key)
    np.testing.assert_allclose(compiled["u_commanded"], inverted, rtol=1e-7, atol=1e-8 * scale)
    se, we, _ = oracle.error_rates(x["sigma"], x["omega"], x["sigma_d"], x["omega_d"], model)
    s = oracle.sliding_variable(se, oracle.mrp_G(se) @ we, x["c1"], x["c2"], x["alpha"])
    np.testing.assert_allclose(compiled["cache"][:3], se, rtol=1e-9, atol=1e-12)  # the cache starts with sigma_e
    np.testing.assert_allclose(compiled["s"], s, rtol=1e-8, atol=1e-10)
    if model == "paper":  # eqs 16-19 literally, with the oracle's own (Euler-consistent) C
        literal = oracle.control_law_eqs_16_19(*args, variant="euler")
        np.testing.assert_allclose(compiled["u_commanded"], literal["u"], rtol=1e-7, atol=1e-8 * scale)


@SETTINGS
@given(x=states())
def test_printed_C_would_give_a_different_torque(x):
    """The oracle's printed-C law differs from fsmctl's exactly by (J0 omega_d) x omega_e (erratum eq9-C)."""
    assume(_well_conditioned(x, "paper"))
    assume(np.linalg.norm(np.cross(x["J0"] @ x["omega_d"], x["omega"] - x["omega_d"])) > 1e-3)
    args = _oracle_law_args(x)
    printed = oracle.control_law_eqs_16_19(*args, variant="printed")["u"]
    mine = _fsm_law("paper", _law_inputs(x))["u_commanded"]
    gap = np.cross(x["J0"] @ x["omega_d"], x["omega"] - x["omega_d"])
    np.testing.assert_allclose(printed - mine, gap, rtol=1e-6, atol=1e-8 * (1 + np.abs(mine).max()))


@SETTINGS
@given(x=states(), tau=vec(-5, 5))
def test_plant_three_ways(x, tau, lambdified):
    J = x["J0"]
    compiled = [np.asarray(v).ravel() for v in casadi_function("plant_rhs")(x["sigma"], x["omega"], tau, J)]
    sym = lambdified("plant_rhs")(sigma=x["sigma"], omega=x["omega"], tau=tau, J=J)
    ref = oracle.plant_rhs(x["sigma"], x["omega"], tau, J)
    for mine, s, o in zip(compiled, (sym["sigma_dot"], sym["omega_dot"]), ref, strict=False):
        np.testing.assert_allclose(mine, s.ravel(), rtol=1e-10, atol=1e-13)
        np.testing.assert_allclose(mine, o, rtol=1e-9, atol=1e-12)


@SETTINGS
@given(x=states())
def test_mrp_error_and_angle_three_ways(x, lambdified):
    se = np.asarray(casadi_function("mrp_error")(x["sigma"], x["sigma_d"])).ravel()
    np.testing.assert_allclose(
        se, lambdified("mrp_error")(sigma=x["sigma"], sigma_d=x["sigma_d"])["sigma_e"].ravel(), atol=1e-12
    )
    ref = oracle.mrp_error(x["sigma"], x["sigma_d"])
    # both live on |sigma_e| <= 1; at exactly 180 deg the two members coincide in norm: compare attitudes
    np.testing.assert_allclose(oracle.mrp_to_dcm(se), oracle.mrp_to_dcm(ref), atol=1e-10)
    theta = float(casadi_function("mrp_principal_angle")(se))
    assert theta == pytest.approx(oracle.principal_angle(ref), abs=1e-6)


@SETTINGS
@given(x=states(), t=st.floats(0, 200))
def test_reference_three_ways(x, t, lambdified):
    from fsmctl import paper_scenario

    p = paper_scenario().reference.omega.params()
    out = [np.asarray(v).ravel() for v in casadi_function("reference_rhs")(t, x["sigma_d"], p)]
    sym = lambdified("reference_rhs")(t=t, sigma_d=x["sigma_d"], params=p)
    paper = oracle.paper_scenario()
    np.testing.assert_allclose(out[1], paper["omega_d"](t), atol=1e-15)
    np.testing.assert_allclose(out[2], paper["omega_d_dot"](t), atol=1e-15)
    np.testing.assert_allclose(out[0], oracle.mrp_G(x["sigma_d"]) @ paper["omega_d"](t), atol=1e-14)
    for k, name in enumerate(("sigma_d_dot", "omega_d", "omega_d_dot")):
        np.testing.assert_allclose(out[k], sym[name].ravel(), atol=1e-14)


@functools.cache
def _closed_loop_eq20():
    """Eq 20 from the symbolic layer's stages (:func:`fsmctl.symbolic.controller.closed_loop_acceleration`), lambdified."""
    import sympy as sp

    from fsmctl.symbolic.controller import SingularityFix, closed_loop_acceleration, sliding_variable

    se, sed, delta, coord = (sp.Matrix(sp.symbols(f"{n}:3", real=True)) for n in ("se", "sed", "delta", "coord"))
    c1, c2, alpha = sp.symbols("c1 c2 alpha", positive=True)
    s = sliding_variable(se, sed, c1, c2, alpha, SingularityFix.NONE)
    acc = closed_loop_acceleration(se, sed, s, c1, c2, alpha, delta, coord, fix=SingularityFix.NONE)
    return sp.lambdify([se, sed, c1, c2, alpha, delta, coord], [acc, s], "numpy")


@SETTINGS
@given(x=states(), sigma_e_dot=vec(-0.5, 0.5))
def test_closed_loop_eq20_two_ways(x, sigma_e_dot):
    """The closed loop of eq 20 as the symbolic layer derives it equals the oracle's transcription."""
    se = x["sigma"] / max(1.0, np.linalg.norm(x["sigma"]))
    assume(np.min(np.abs(se)) > 1e-3)
    s = oracle.sliding_variable(se, sigma_e_dot, x["c1"], x["c2"], x["alpha"])
    assume(np.min(np.abs(s)) > 1e-9)
    acc, s_sym = _closed_loop_eq20()(se, sigma_e_dot, x["c1"], x["c2"], x["alpha"], x["delta"], x["coordination"])
    ref = oracle.closed_loop_eq20(se, sigma_e_dot, x["c1"], x["c2"], x["alpha"], x["delta"], x["coordination"])
    np.testing.assert_allclose(np.asarray(acc, float).ravel(), ref, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(np.asarray(s_sym, float).ravel(), s, rtol=1e-10, atol=1e-12)


def test_the_papers_law_is_generated_once_in_its_folder():
    """The model catalogue (``generated/``) derives no control law: no model function outputs a torque, a sliding
    variable or sliding dynamics, or reads a law's gains; the paper's law lives in ``generated/laws/fsm`` alone."""
    import json

    from fsmctl.model.generated_code import generated_dir, manifest

    law_outputs = {"u", "u_unsaturated", "u_commanded", "s", "x_dot", "sigma_e_ddot", "gain_constants"}
    for f in manifest()["functions"]:
        assert not law_outputs & {o["name"] for o in f["outputs"]}, f["name"]
        assert not {"gains", "gain_constants", "delta"} & {i["name"] for i in f["inputs"]}, f["name"]
    assert set(manifest()["layouts"]) == {"wheel", "sinusoid_params"}
    folder = json.loads((generated_dir() / "laws" / "fsm" / "manifest.json").read_text())
    assert {f["name"] for f in folder["functions"]} >= {"law_constants", "law_local_paper", "law_control_paper"}
