"""The laws pid, super_twisting and adaptive_fsm (derive/laws/{pd,super_twisting,adaptive_fsm}.py).

(a) the generated ``law_local_*`` / ``law_control_*`` against an independent NumPy transcription of each law,
written here from the equations in the scripts' docstrings (DCM-based attitude error, computed-torque form
written from ``sigma_e_ddot = a``, no SymPy, no fsmctl.symbolic); (b) short closed loops of the paper
scenario; (c) Lyapunov functions along simulated isolated-agent trajectories; (d) rejected variants.
"""

from __future__ import annotations

import functools
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import fsmctl
from fsmctl.codegen.laws import load_derivation_script
from fsmctl.errors import InputError
from fsmctl.model.laws import LawSwitchWarning, initial_law_states, resolve_law
from fsmctl.model.scenario import scenario_from_dict
from fsmctl.simulation.simulator import simulate
from fsmctl.symbolic.law import LawBuilder, LawDefinitionError, law_variants

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = {
    "pid": ROOT / "derive" / "laws" / "pd.py",
    "super_twisting": ROOT / "derive" / "laws" / "super_twisting.py",
    "adaptive_fsm": ROOT / "derive" / "laws" / "adaptive_fsm.py",
}
DELTA_FLOOR = 1e-4  # adaptive_fsm: initial value and floor of delta_hat
RTOL = 1e-12
J0_PAPER_1 = [[100.0, 1.0, 2.0], [1.0, 150.0, 1.0], [2.0, 1.0, 200.0]]


@functools.cache
def _law(name: str):
    """Derive the script once per session (the law cache keeps it across sessions)."""
    return resolve_law(str(SCRIPTS[name]))


@functools.cache
def _variants(name: str):
    return load_derivation_script(SCRIPTS[name])


# ----------------------------------------------------------------------------- NumPy transcription


def skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def mrp_dcm(s):
    """[BN] of an MRP (Schaub & Junkins): I + (8 s~^2 - 4 (1 - s^T s) s~) / (1 + s^T s)^2."""
    s2 = s @ s
    S = skew(s)
    return np.eye(3) + (8 * S @ S - 4 * (1 - s2) * S) / (1 + s2) ** 2


def dcm_mrp(C):
    """The short-rotation MRP of a DCM, through Euler parameters by Shepperd's method."""
    tr = np.trace(C)
    b2 = np.array([1 + tr, 1 + 2 * C[0, 0] - tr, 1 + 2 * C[1, 1] - tr, 1 + 2 * C[2, 2] - tr]) / 4
    k = int(np.argmax(b2))
    b = np.empty(4)
    b[k] = math.sqrt(b2[k])
    p = {  # 4 b_i b_j
        (0, 1): C[1, 2] - C[2, 1],
        (0, 2): C[2, 0] - C[0, 2],
        (0, 3): C[0, 1] - C[1, 0],
        (1, 2): C[0, 1] + C[1, 0],
        (1, 3): C[2, 0] + C[0, 2],
        (2, 3): C[1, 2] + C[2, 1],
    }
    for j in range(4):
        if j != k:
            b[j] = p[(min(j, k), max(j, k))] / (4 * b[k])
    if b[0] < 0:
        b = -b
    return b[1:] / (1 + b[0])


def G(s):
    return ((1 - s @ s) * np.eye(3) + 2 * skew(s) + 2 * np.outer(s, s)) / 4


def error_state(model, sigma, omega, sigma_d, omega_d, omega_d_dot):
    """sigma_e ([BR] = [BN][RN]^T), omega_e, omega_r and the body-frame derivative of omega_r."""
    sigma_e = dcm_mrp(mrp_dcm(sigma) @ mrp_dcm(sigma_d).T)
    if model == "paper":  # eqs 7-8 as printed
        omega_r, omega_r_dot = omega_d.copy(), omega_d_dot.copy()
        return sigma_e, omega - omega_r, omega_r, omega_r_dot
    R = mrp_dcm(sigma_e)
    omega_r = R @ omega_d
    omega_e = omega - omega_r
    # d/dt in B of R omega_d: R omega_d_dot - omega_BR x (R omega_d)
    return sigma_e, omega_e, omega_r, R @ omega_d_dot + np.cross(omega_r, omega_e)


def surface(x, alpha, fix, eps):
    """sig(x)^alpha, or (fix 1, switch) r1 x + r2 x|x| inside |x| < eps (Remark 6)."""
    raw = np.sign(x) * np.abs(x) ** alpha
    if fix != 1:
        return raw
    r1, r2 = (2 - alpha) * eps ** (alpha - 1), (alpha - 1) * eps ** (alpha - 2)
    return np.where(np.abs(x) >= eps, raw, r1 * x + r2 * x * np.abs(x))


def slope(x, alpha, fix, eps):
    """d surface/dx (switch), alpha max(|x|, eps)^(alpha-1) (clamp) or alpha |x|^(alpha-1) (none)."""
    ax = np.abs(x)
    if fix == 0:
        return alpha * ax ** (alpha - 1)
    if fix == 2:
        return alpha * np.maximum(ax, eps) ** (alpha - 1)
    r1, r2 = (2 - alpha) * eps ** (alpha - 1), (alpha - 1) * eps ** (alpha - 2)
    return np.where(ax >= eps, alpha * ax ** (alpha - 1), r1 + 2 * r2 * ax)


def torque_for(J0, sigma_e, omega_e, omega_r, omega_r_dot, accel):
    """The torque giving sigma_e_ddot = accel for J = J0: sigma_e_ddot = G_dot omega_e + G omega_e_dot and
    J0 omega_dot = -omega x J0 omega + u.  G is quadratic, so its central difference along sigma_e_dot is exact."""
    Gm = G(sigma_e)
    sd = Gm @ omega_e
    G_dot = (G(sigma_e + sd) - G(sigma_e - sd)) / 2
    omega = omega_e + omega_r
    omega_e_dot = np.linalg.solve(Gm, accel - G_dot @ omega_e)
    return np.cross(omega, J0 @ omega) + J0 @ (omega_r_dot + omega_e_dot)


def fsm_surface(p, sigma_e, omega_e):
    """s = sigma_e_dot + c1 sigma_e + c2 phi(sigma_e) (eq 13) and the rate terms of eq 17."""
    fix = int(p["singularity_fix"])
    sd = G(sigma_e) @ omega_e
    s = sd + p["c1"] * sigma_e + p["c2"] * surface(sigma_e, p["alpha"], fix, p["epsilon"])
    rate = p["c1"] * sd + p["c2"] * slope(sigma_e, p["alpha"], fix, p["epsilon"]) * sd
    return s, rate


def ref_pid(p, model, x):
    se, we, wr, wrd = error_state(model, x["sigma"], x["omega"], x["sigma_d"], x["omega_d"], x["omega_d_dot"])
    J0 = x["J0"]
    z = x["z"] + J0 @ we
    u = (
        -p["K"] * se
        - p["P"] * we
        - p["P"] * p["Ki"] * z
        + np.cross(wr - p["Ki"] * z, J0 @ (we + wr))
        + J0 @ wrd
        - p["k_coupling"] * (x["k_received_sum"] * se - x["received"])
    )
    return se, u, p["K"] * se


def ref_super_twisting(p, model, x):
    se, we, wr, wrd = error_state(model, x["sigma"], x["omega"], x["sigma_d"], x["omega_d"], x["omega_d_dot"])
    s, rate = fsm_surface(p, se, we)
    w = x["z"]
    v = -p["k1"] * np.sqrt(np.abs(s)) * np.sign(s) + w
    accel = -rate + v - (x["k_sum"] * s - x["received"])
    return s, torque_for(x["J0"], se, we, wr, wrd, accel), -p["k2"] * np.sign(s)


def ref_adaptive_fsm(p, model, x):
    se, we, wr, wrd = error_state(model, x["sigma"], x["omega"], x["sigma_d"], x["omega_d"], x["omega_d_dot"])
    s, rate = fsm_surface(p, se, we)
    d = x["z"]
    phi = p["boundary_layer"]
    switching = np.sign(s) if phi == 0 else np.clip(s / phi, -1, 1)
    accel = -rate - d * switching - (x["k_sum"] * s - x["received"])
    band = p["adaptation_band"]
    d_dot = p["gamma"] * np.abs(s) * np.sign(np.abs(s) - band)
    d_dot[(np.abs(s) > band) & (d >= p["delta_max"])] = 0.0
    d_dot[(np.abs(s) < band) & (d <= DELTA_FLOOR)] = 0.0
    return s, torque_for(x["J0"], se, we, wr, wrd, accel), d_dot


REFERENCES = {"pid": ref_pid, "super_twisting": ref_super_twisting, "adaptive_fsm": ref_adaptive_fsm}


# ----------------------------------------------------------------------------- random draws


def _surface_params(rng):
    return {
        "c1": rng.uniform(0, 1.5),
        "c2": rng.uniform(0, 1.5),
        "alpha": rng.uniform(0.55, 0.95),
        "epsilon": 10 ** rng.uniform(-4, -0.5),  # often wide enough that some |sigma_e,k| fall inside the band
        "singularity_fix": float(rng.integers(0, 3)),
    }


def draw_params(name, rng):
    if name == "pid":
        return {
            "K": rng.uniform(0.5, 50),
            "P": rng.uniform(0.5, 100),
            "Ki": 0.0 if rng.random() < 0.3 else rng.uniform(0, 0.01),
            "k_coupling": rng.uniform(0, 1),
        }
    if name == "super_twisting":
        return {**_surface_params(rng), "k1": rng.uniform(0.01, 1), "k2": rng.uniform(1e-3, 0.1)}
    return {
        **_surface_params(rng),
        "boundary_layer": 0.0 if rng.random() < 0.4 else rng.uniform(1e-3, 1),
        "gamma": rng.uniform(1e-3, 1),
        "adaptation_band": 10 ** rng.uniform(-3, 0),
        "delta_max": rng.uniform(0.01, 0.1),
    }


def draw_states(name, p, rng):
    if name == "pid":
        return rng.uniform(-50, 50, 3)
    if name == "super_twisting":
        return rng.uniform(-0.1, 0.1, 3)
    # at the floor, at the cap, or between: every branch of the projection
    picks = rng.integers(0, 3, 3)
    return np.where(picks == 0, DELTA_FLOOR, np.where(picks == 1, p["delta_max"], rng.uniform(DELTA_FLOOR, 0.1, 3)))


def draw_inputs(name, p, rng):
    A = rng.uniform(-5, 5, (3, 3))
    J0 = np.diag(rng.uniform(80, 240, 3)) + (A + A.T) / 2
    sigma = rng.uniform(-1, 1, 3) * rng.uniform(0.05, 1)
    if rng.random() < 0.3:
        # an attitude error inside the Remark 6 band on one axis.  With sigma_d = 0 so that sigma_e = sigma
        # to full relative precision: a small sigma_e,k computed from two large attitudes carries an absolute
        # rounding error ~1e-16, which |x|^(alpha-1) (singularity_fix none) amplifies beyond 1e-12 relative
        sigma_d = np.zeros(3)
        sigma[rng.integers(0, 3)] = rng.uniform(-1e-3, 1e-3)
    else:
        sigma_d = rng.uniform(-0.6, 0.6, 3)
    return {
        "t": rng.uniform(0, 100),
        "sigma": sigma,
        "omega": rng.uniform(-0.5, 0.5, 3),
        "z": draw_states(name, p, rng),
        "sigma_d": sigma_d,
        "omega_d": rng.uniform(-0.1, 0.1, 3),
        "omega_d_dot": rng.uniform(-0.01, 0.01, 3),
        "J0": J0,
        "k_sum": rng.choice([0.0, rng.uniform(0, 40)]),
        "received": rng.uniform(-2, 2, 3),
        "k_received_sum": rng.uniform(0, 25),
        "u_max": rng.choice([np.inf, rng.uniform(0.5, 5)]),
    }


def pack_params(law, p):
    assert sorted(p) == sorted(q.name for q in law.parameters)
    return np.array([p[q.name] for q in law.parameters], dtype=float)


def generated(law, model, p, x):
    """broadcast, u, u_commanded and z_dot from the generated functions."""
    params = pack_params(law, p)
    constants = law.casadi("law_constants")(params)
    agent = [x["t"], x["sigma"], x["omega"], x["z"], x["sigma_d"], x["omega_d"], x["omega_d_dot"], x["J0"]]
    broadcast, cache = law.casadi(f"law_local_{model}")(*agent, params, constants)
    u, u_cmd, z_dot = law.casadi(f"law_control_{model}")(
        *agent, params, constants, cache, x["k_sum"], x["received"], x["k_received_sum"], x["u_max"]
    )
    return (np.asarray(v, dtype=float).ravel() for v in (broadcast, u, u_cmd, z_dot))


def _close(got, want, what, k):
    scale = max(1.0, float(np.max(np.abs(want))))
    err = float(np.max(np.abs(got - want))) if want.size else 0.0
    assert err <= RTOL * scale, f"draw {k}: {what}: generated {got}, NumPy {want} (max error {err:.3g})"


# ----------------------------------------------------------------------------- (a) generated code vs NumPy


@pytest.mark.parametrize("model", ["paper", "exact"])
@pytest.mark.parametrize("name", list(SCRIPTS))
def test_generated_law_matches_numpy_transcription(name, model):
    law = _law(name)
    assert law.name == name
    rng = np.random.default_rng(20240611 + len(name) + (model == "exact"))
    for k in range(150):
        p = draw_params(name, rng)
        x = draw_inputs(name, p, rng)
        broadcast, u, u_cmd, z_dot = generated(law, model, p, x)
        b_ref, u_ref, z_dot_ref = REFERENCES[name](p, model, x)
        _close(broadcast, b_ref, "broadcast", k)
        _close(u_cmd, u_ref, "u_commanded", k)
        _close(u, np.clip(u_ref, -x["u_max"], x["u_max"]), "u (clipped at u_max)", k)
        _close(z_dot, z_dot_ref, "z_dot", k)


def test_declared_metadata():
    pid, st, ad = (_law(n) for n in SCRIPTS)
    assert [q.name for q in pid.parameters] == ["K", "P", "Ki", "k_coupling"]
    assert pid.parameter("Ki").default == (0.0,) and pid.parameter("k_coupling").default == (0.0,)
    assert (pid.broadcast_name, pid.n_states, pid.has_lyapunov) == ("sigma_e", 3, True)
    assert (st.broadcast_name, st.n_states, st.has_lyapunov) == ("s", 3, True)
    assert (ad.broadcast_name, ad.n_states) == ("s", 3)
    np.testing.assert_array_equal(initial_law_states(ad), [DELTA_FLOOR] * 3)
    np.testing.assert_array_equal(initial_law_states(pid), [0.0] * 3)
    for law in (pid, st, ad):
        assert all(q.doc and q.unit for q in law.parameters if not q.choices), law.name
        assert "delta" not in [q.name for q in law.parameters]  # agents' delta must not override anything
    # the FSM-shaped laws share the paper's surface parameters, so a scenario's typed keys reach them
    for law in (st, ad):
        for key, value in {"c1": 0.6, "c2": 0.8, "alpha": 0.7, "epsilon": 1e-4}.items():
            assert law.parameter(key).default == (value,)


# ----------------------------------------------------------------------------- (b) closed loops


def _paper(name, parameters, t_final=20.0, **typed):
    """The paper's Case 1 flying a law, without the torque limit (the paper's written keys that the law declares
    carry over, e.g. its boundary_layer = 0.001)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LawSwitchWarning)
        return fsmctl.paper_scenario("1").replace(
            controller={"law": str(SCRIPTS[name]), **parameters, "torque_limit": math.inf, **typed},
            simulation={"t_final": t_final},
        )


def test_pid_closed_loop_converges_and_integrates_sigma_e():
    p = {"K": 20.0, "P": 40.0, "Ki": 5e-4, "k_coupling": 0.2}
    r = simulate(_paper("pid", p))
    assert r.law.name == "pid" and r.z.shape == (r.time.size, 6, 3)
    theta = np.degrees(r.theta_e)
    assert np.all(theta[-1] < 0.5 * theta[0]), theta[[0, -1]]
    # z holds K int sigma_e dt (trapezoid on the output grid; sigma_e jumps where it crosses 180 deg)
    expected = p["K"] * np.trapezoid(r.sigma_e, r.time, axis=0)
    np.testing.assert_allclose(r.z[-1], expected, rtol=0, atol=2e-3 * np.abs(expected).max())
    np.testing.assert_allclose(r.broadcast, r.sigma_e, atol=1e-9)


def test_super_twisting_closed_loop_converges():
    r = simulate(_paper("super_twisting", {}))
    theta = np.degrees(r.theta_e)
    assert theta[-1].max() < 0.01 and np.all(theta[-1] < theta[0])
    assert np.abs(r.s[-1]).max() < 1e-4  # second-order sliding: s and its derivative reach 0
    assert np.all(np.isfinite(r.z)) and np.abs(r.z).max() > 0  # w moved


def test_adaptive_fsm_closed_loop_adapts_within_bounds():
    r = simulate(_paper("adaptive_fsm", {}))
    assert r.scenario.law_parameters()[0]["boundary_layer"] == 0.001  # carried over from the paper scenario
    theta = np.degrees(r.theta_e)
    assert theta[-1].max() < 0.01 and np.all(theta[-1] < theta[0])
    delta_hat = r.z  # (T, n, 3)
    assert delta_hat.min() >= DELTA_FLOOR * (1 - 1e-9) and delta_hat.max() <= 0.05 * (1 + 1e-6)
    assert np.all(delta_hat[-1] > 1.5 * DELTA_FLOOR)  # every gain grew from the floor while reaching
    # Plestan et al.: the gain rises while |s_k| is outside the band (0.001 1/s) and falls inside it
    s, step = np.abs(r.s), np.diff(delta_hat, axis=0)
    outside, inside = (s[:-1] > 1e-3) & (s[1:] > 1e-3), (s[:-1] < 1e-3) & (s[1:] < 1e-3)
    assert step[outside].min() >= 0 and step[inside].max() <= 0
    assert outside.any() and inside.any()


# ----------------------------------------------------------------------------- (c) Lyapunov functions


def _isolated(name, parameters, t_final=60.0):
    """One agent, no links, J = J0, no disturbance, the reference at rest at sigma_d = 0."""
    return scenario_from_dict(
        {
            "name": "isolated",
            "simulation": {"t_final": t_final, "dt": 0.001, "output_interval": 0.01},
            "controller": {"law": str(SCRIPTS[name]), "torque_limit": "inf", **parameters},
            "reference": {"sigma0": [0.0, 0.0, 0.0], "omega": {}},
            "agents": [{"J0": J0_PAPER_1, "sigma0": [0.3, 0.2, -0.3], "omega0": [0.35, -0.13, 0.27]}],
            "topology": {"links": []},
        }
    )


@pytest.mark.parametrize("Ki", [0.0, 3e-3])
def test_pid_lyapunov_function_decreases_along_isolated_trajectory(Ki):
    K, P = 20.0, 40.0
    r = simulate(_isolated("pid", {"K": K, "P": P, "Ki": Ki}))
    J0 = np.array(J0_PAPER_1)
    sigma, omega, int_sigma = r.sigma[:, 0], r.omega[:, 0], r.z[:, 0]
    np.testing.assert_allclose(r.sigma_e[:, 0], sigma, atol=1e-12)  # the reference is at rest
    z = int_sigma + omega @ J0
    V = 2 * K * np.log1p(np.sum(sigma**2, axis=1)) + 0.5 * np.einsum("ti,ij,tj->t", omega, J0, omega)
    V += 0.5 * Ki * np.sum(z**2, axis=1)
    V_dot = -P * np.sum((omega + Ki * z) ** 2, axis=1)
    assert np.all(np.diff(V) <= 1e-12 * V[0]), np.diff(V).max()
    assert V[-1] < 1e-2 * V[0]
    # the claimed derivative, against central differences of V on the output grid
    dV = np.gradient(V, r.time)[1:-1]
    np.testing.assert_allclose(dV, V_dot[1:-1], rtol=0, atol=1e-4 * np.abs(V_dot).max())

    # the derivation script declares this V and V_dot (evaluated here from its SymPy expressions)
    import sympy as sp

    law = _variants("pid").paper
    values = dict(zip(law.symbols["params"], [K, P, Ki, 0.0], strict=True))
    values.update({law.symbols["J0"][i, j]: J0[i, j] for i in range(3) for j in range(3)})
    args = [*law.symbols["sigma"], *law.symbols["omega"], *law.symbols["z"]]
    V_decl = sp.lambdify(args, law.lyapunov.V.xreplace(values), "math")
    V_dot_decl = sp.lambdify(args, law.lyapunov.claimed_derivative.xreplace(values), "math")
    for k in range(0, r.time.size, 500):
        row = [*sigma[k], *omega[k], *int_sigma[k]]
        assert V_decl(*row) == pytest.approx(V[k], rel=1e-12)
        assert V_dot_decl(*row) == pytest.approx(V_dot[k], rel=1e-10, abs=1e-14)


def test_super_twisting_lyapunov_function_decreases_along_isolated_trajectory():
    """Moreno & Osorio's V (declared by the script) along an isolated agent, until s has converged."""
    import sympy as sp

    params = {"k1": 0.1, "k2": 0.005}
    r = simulate(_isolated("super_twisting", params, t_final=30.0))
    law = _variants("super_twisting").paper
    defaults = {q.name: q.default[0] for q in law.parameters}
    values = dict(zip(law.symbols["params"], [{**defaults, **params}[q.name] for q in law.parameters], strict=True))
    values.update({law.symbols["J0"][i, j]: J0_PAPER_1[i][j] for i in range(3) for j in range(3)})
    args = [*law.symbols["sigma"], *law.symbols["omega"], *law.symbols["z"]]
    V_decl = sp.lambdify(args, law.lyapunov.V.xreplace(values), "numpy")
    V = np.array([V_decl(*r.sigma[k, 0], *r.omega[k, 0], *r.z[k, 0]) for k in range(r.time.size)])
    # NumPy: the same V from the simulated s and w
    s, w = r.s[:, 0], r.z[:, 0]
    phi = np.sqrt(np.abs(s)) * np.sign(s)
    V_np = np.sum(2 * params["k2"] * np.abs(s) + w**2 / 2 + (params["k1"] * phi - w) ** 2 / 2, axis=1)
    np.testing.assert_allclose(V, V_np, rtol=1e-9, atol=1e-15)
    live = V > 1e-6 * V[0]  # before the (finite-time) convergence; after it RK4 chatters at rounding level
    assert not live[-1], "s did not converge within 30 s"
    assert np.all(np.diff(V)[live[:-1]] <= 1e-12 * V[0]), np.diff(V)[live[:-1]].max()


# ----------------------------------------------------------------------------- (d) rejected variants


def test_law_variants_reject_inconsistent_scripts():
    pd_law = _variants("pid").paper
    st_law = _variants("super_twisting").paper
    with pytest.raises(LawDefinitionError, match="built a law for the paper error model"):
        law_variants(lambda model: pd_law)  # ignores error_model
    with pytest.raises(LawDefinitionError, match="differ in name"):
        law_variants(lambda model: pd_law if model.value == "paper" else _variants("super_twisting").exact)
    with pytest.raises(LawDefinitionError, match="must return"):
        law_variants(lambda model: None)
    assert st_law.n_states == 3


def test_law_builder_rejects_broken_variants():
    import sympy as sp

    b = LawBuilder("broken", "paper", doc="x")
    with pytest.raises(LawDefinitionError, match="must be finite"):
        b.parameter("integral_limit", math.inf, unit="N m s", minimum=0.0)  # why pid has no integral limit
    with pytest.raises(LawDefinitionError, match=">= 0"):
        b.parameter("K", -1.0, minimum=0.0)
    with pytest.raises(LawDefinitionError, match="'z' is reserved"):
        b.parameter("z", 1.0)  # a contract input
    b.parameter("K2", 1.0)
    with pytest.raises(LawDefinitionError, match="already used"):
        b.parameter("K2", 2.0)  # declared twice
    e = b.error_state()
    w = b.state("w", 3)
    with pytest.raises(LawDefinitionError, match="declare the broadcast"):
        _ = b.received
    b.broadcast("s", e.sigma_e)
    with pytest.raises(LawDefinitionError, match="3 components"):
        b.torque(e.sigma_e[:2, 0])
    with pytest.raises(LawDefinitionError, match="has 2 components"):
        b.derivative(w, e.sigma_e[:2, 0])
    b.torque(-e.sigma_e)
    with pytest.raises(LawDefinitionError, match="without a derivative"):
        b.build()
    # an expression in a symbol that is no input of the law
    c = LawBuilder("foreign", "paper", doc="x")
    c.broadcast("s", c.error_state().sigma_e)
    c.torque([sp.Symbol("J_true"), 0, 0])
    with pytest.raises(LawDefinitionError, match="no input of the law"):
        c.build()


def test_broken_script_and_out_of_range_parameters_are_refused(tmp_path):
    script = tmp_path / "typo.py"
    script.write_text(SCRIPTS["pid"].read_text().replace("return b.build()", "return b"))
    with pytest.raises(InputError, match="must return"):
        resolve_law(str(script))
    base = fsmctl.paper_scenario("1")
    for name, params, message in [
        ("pid", {"K": -1.0}, "controller.K: must be > 0"),
        ("pid", {"Ki": -1e-3}, "controller.Ki: must be >= 0"),
        ("pid", {"delta": 0.1}, "has no parameter 'delta'"),
        ("super_twisting", {"k2": 0.0}, "controller.k2: must be > 0"),
        ("adaptive_fsm", {"gamma": 0.0}, "controller.gamma: must be > 0"),
        ("adaptive_fsm", {"delta_max": 1e-5}, "controller.delta_max: must be > 0.0001"),
    ]:
        with pytest.raises(InputError, match=message):
            base.replace(controller={"law": str(SCRIPTS[name]), "parameters": params})
