"""Faults of the python-control plug-in: shared parameter keys, attitudes past 360 deg, unchecked arguments.

Oracles, independent of fsmctl: Euler's equation and the direction-cosine kinematics d[BN]/dt = -[omega x][BN]
integrated with SciPy's ``solve_ivp`` in NumPy; the MRP direction-cosine matrix and the Euler-parameter <-> MRP
maps of Schaub & Junkins (Analytical Mechanics of Space Systems, eqs 3.152-3.154); and
``scipy.spatial.transform.Rotation`` (its quaternion ``(x, y, z, w)`` of the active rotation [NB] is
``(q1, q2, q3, q0)`` of [BN]; body rates compose on the right: R(t) = R(0) exp(omega t)).
"""

from __future__ import annotations

import copy
import math
import warnings

import control as ct
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import fsmctl
from fsmctl import ScenarioError
from fsmctl.errors import InputError
from fsmctl.plugin.iosys import InvalidStateError, ParameterKeyError, initial_state, law_controller, quaternion_from_mrp

J1 = np.array([[100.0, 2.0, -3.0], [2.0, 150.0, 4.0], [-3.0, 4.0, 200.0]])
J2 = np.array([[30.0, 0.0, 1.0], [0.0, 80.0, 0.0], [1.0, 0.0, 60.0]])
OMEGA0 = np.array([0.6, -0.55, 0.55])  # |omega| ~ 1 rad/s, far from every principal axis: a tumble
SIGMA0 = np.array([0.1, -0.2, 0.3])
TIGHT = {"solve_ivp_method": "RK45", "solve_ivp_kwargs": {"rtol": 1e-10, "atol": 1e-12}}


# ----------------------------------------------------------------------------- NumPy oracles


def skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def dcm_of_mrp(s):
    """[BN] of an MRP (Schaub & Junkins eq 3.152)."""
    s = np.asarray(s, dtype=float)
    S = skew(s)
    return np.eye(3) + (8.0 * S @ S - 4.0 * (1.0 - s @ s) * S) / (1.0 + s @ s) ** 2


def quat(s):
    """Euler parameters (scalar first) of an MRP (eq 3.153)."""
    s = np.asarray(s, dtype=float)
    return np.concatenate([[1.0 - s @ s], 2.0 * s]) / (1.0 + s @ s)


def mrp_of_quat(q):
    """MRP of q / |q| (eq 3.154): q_v / (1 + q0), or the shadow set -q_v / (1 - q0) when q0 < 0."""
    q = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return q[1:] / (1.0 + q[0]) if q[0] >= 0 else -q[1:] / (1.0 - q[0])


def rigid_body_route(J, omega0, sigma0, t):
    """omega(t) and [BN](t) of a torque-free rigid body: Euler's equation and d[BN]/dt = -[omega x][BN]."""
    Jinv = np.linalg.inv(J)

    def rhs(_, y):
        w, C = y[:3], y[3:].reshape(3, 3)
        return np.concatenate([Jinv @ (-np.cross(w, J @ w)), (-skew(w) @ C).ravel()])

    y0 = np.concatenate([omega0, dcm_of_mrp(sigma0).ravel()])
    sol = solve_ivp(rhs, (t[0], t[-1]), y0, t_eval=t, rtol=1e-12, atol=1e-13, method="DOP853")
    assert sol.success
    return sol.y[:3], sol.y[3:].reshape(3, 3, -1)


def plant_state(sigma0, omega0):
    return np.concatenate([quat(sigma0), omega0])


def assert_flies_with(states, J, t, tol=1e-7):
    """The (q, omega) rows of one plant in ``states`` follow the rigid body with inertia J."""
    w_ref, C_ref = rigid_body_route(J, states[4:7, 0], mrp_of_quat(states[:4, 0]), t)
    assert np.abs(states[4:7] - w_ref).max() < tol
    C = np.stack([dcm_of_mrp(mrp_of_quat(states[:4, k])) for k in range(t.size)], axis=-1)
    assert np.abs(C - C_ref).max() < tol


def pair(a, b, **kwargs):
    return ct.interconnect([a, b], inplist=[], outlist=[], check_unused=False, **kwargs)


def one_line(exc: pytest.ExceptionInfo) -> str:
    msg = str(exc.value)
    assert msg and "\n" not in msg, msg
    return msg


# ----------------------------------------------------------------------------- parameter sharing


def test_default_named_spacecraft_fly_with_their_own_inertia():
    """Two ``fsmctl.spacecraft`` made without a name, interconnected: each flies with its own J (the defect:
    both used the last one's ``spacecraft_J``)."""
    a, b = fsmctl.spacecraft(J1), fsmctl.spacecraft(J2)
    assert a.name != b.name and not set(a.params) & set(b.params)
    t = np.linspace(0.0, 20.0, 41)
    x0 = np.concatenate([plant_state(SIGMA0, OMEGA0), plant_state(-SIGMA0, 0.5 * OMEGA0)])
    r = ct.input_output_response(pair(a, b), t, 0, x0, **TIGHT)
    assert r.success
    assert_flies_with(r.states[:7], J1, t)
    assert_flies_with(r.states[7:], J2, t)


def test_copied_spacecraft_flies_with_its_own_inertia():
    """``sys.copy()`` re-keys the copy to its new name: changing the copy's J leaves the original alone."""
    t = np.linspace(0.0, 20.0, 41)
    x0 = np.concatenate([plant_state(SIGMA0, OMEGA0), plant_state(-SIGMA0, 0.5 * OMEGA0)])
    for a in (fsmctl.spacecraft(J1), fsmctl.spacecraft(J1, name="bus")):
        b = a.copy()
        assert b.name == f"{a.name}$copy" and b.param_key("J") == f"{b.name}_J"
        b.params[f"{b.name}_J"] = J2
        assert np.array_equal(a.params[f"{a.name}_J"], J1)
        r = ct.input_output_response(pair(a, b), t, 0, x0, **TIGHT)
        assert r.success
        assert_flies_with(r.states[:7], J1, t)
        assert_flies_with(r.states[7:], J2, t)
    # a named copy, and python-control's own copy of a system listed twice
    c = a.copy("other")
    assert set(c.params) == {"other_J", "other_disturbance", "other_owner"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # python-control: "duplicate object found in system list"
        twice = pair(a, a)
    r = ct.input_output_response(twice, t[:11], 0, np.concatenate([x0[:7], x0[:7]]), **TIGHT)
    assert np.abs(r.states[:7] - r.states[7:]).max() < 1e-12  # both with J1 (BLAS rounding aside)
    # a copied interconnection (deep copy of the container) keeps its subsystems' tags consistent
    loop = fsmctl.formation(fsmctl.paper_scenario("1"))
    x = fsmctl.plugin.iosys.initial_state(fsmctl.paper_scenario("1"))
    assert np.array_equal(loop.copy().dynamics(0.0, x, []), loop.dynamics(0.0, x, []))


def test_two_systems_with_one_name_raise_instead_of_sharing_parameters():
    """Same explicit name, a deep-copy twin, a shallow copy: an error on the first evaluation, not shared values;
    interconnect params given explicitly are what both use."""
    x0 = np.concatenate([plant_state(SIGMA0, OMEGA0)] * 2)
    a = fsmctl.spacecraft(J1, name="x")
    for b in (fsmctl.spacecraft(J2, name="x"), copy.deepcopy(a), copy.copy(a)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # python-control: "duplicate name found in system list"
            ic = pair(a, b)
        with pytest.raises(InputError, match="unique name") as exc:
            ct.input_output_response(ic, [0.0, 1.0], 0, x0)
        assert "'x'" in one_line(exc)
        with pytest.raises(InputError, match="unique name"):
            ic.dynamics(0.0, x0, [])
    # the twin alone is a working system of its own
    assert np.array_equal(copy.deepcopy(a).dynamics(0.0, x0[:7], [0, 0, 0]), a.dynamics(0.0, x0[:7], [0, 0, 0]))
    # explicit params= of interconnect: "x_J" is what the user asked for, for every system named x
    J3 = np.diag([10.0, 20.0, 30.0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ic = pair(a, fsmctl.spacecraft(J2, name="x"), params={"x_J": J3})
    dx = ic.dynamics(0.0, x0, [])
    w = OMEGA0
    expected = np.linalg.solve(J3, -np.cross(w, J3 @ w))
    assert np.allclose(dx[4:7], expected, rtol=1e-13) and np.allclose(dx[11:14], expected, rtol=1e-13)


def test_explicit_params_are_used_and_validated():
    """``params=`` at evaluation time replaces one system's value (also after an in-place edit) and is checked."""
    a, b = fsmctl.spacecraft(J1, name="a"), fsmctl.spacecraft(J2, name="b")
    ic = pair(a, b)
    x0 = np.concatenate([plant_state(SIGMA0, OMEGA0), plant_state(-SIGMA0, 0.5 * OMEGA0)])

    def euler(J, w):
        return np.linalg.solve(J, -np.cross(w, J @ w))

    J3 = np.diag([10.0, 20.0, 30.0])
    dx = ic.dynamics(0.0, x0, [], params={"b_J": J3})
    assert np.allclose(dx[4:7], euler(J1, x0[4:7]), rtol=1e-13)
    assert np.allclose(dx[11:14], euler(J3, x0[11:14]), rtol=1e-13)
    J3[2, 2] = 60.0  # the same array, edited in place: the new value is used
    dx = ic.dynamics(0.0, x0, [], params={"b_J": J3})
    assert np.allclose(dx[11:14], euler(J3, x0[11:14]), rtol=1e-13)
    # the system's own values are back without params=
    assert np.allclose(ic.dynamics(0.0, x0, [])[11:14], euler(J2, x0[11:14]), rtol=1e-13)
    bad = [
        (np.full((3, 3), np.nan), "not finite"),
        ([[True, False, False], [False, True, False], [False, False, True]], "got True"),
        (np.eye(2), r"shape \(2, 2\)"),
        (-np.eye(3), "not positive definite"),
    ]
    for J, match in bad:
        with pytest.raises(ScenarioError, match=match) as exc:
            ic.dynamics(0.0, x0, [], params={"b_J": J})
        assert "'b_J'" in one_line(exc)
    with pytest.raises(ScenarioError, match="12 real numbers"):
        a.dynamics(0.0, x0[:7], [0, 0, 0], params={"a_disturbance": np.zeros(3)})


# ----------------------------------------------------------------------------- attitudes


def test_tumbling_spacecraft_conserves_momentum_and_energy_for_60_s():
    """|omega| ~ 1 rad/s, torque-free, 60 s: a general tumble (about ten turns) and a spin about a principal axis
    from sigma = 0, whose unswitched MRP goes through infinity at t = 2 pi (the MRP plant stopped there with
    "solve_ivp failed").  Success, |sigma| <= 1, inertial angular momentum [NB] J omega and rotational energy
    conserved, attitude and rate = the NumPy route."""
    t = np.linspace(0.0, 60.0, 601)
    spin_J = np.diag([100.0, 150.0, 200.0])
    for J, omega0, sigma0 in ((J1, OMEGA0, SIGMA0), (spin_J, np.array([0.0, 0.0, 1.0]), np.zeros(3))):
        sc = fsmctl.spacecraft(J, name="tumbler")
        r = ct.input_output_response(sc, t, 0, plant_state(sigma0, omega0), **TIGHT)
        assert r.success
        sigma, omega = r.outputs[:3], r.outputs[3:]
        norms = np.linalg.norm(sigma, axis=0)
        assert norms.max() <= 1.0 + 1e-12 and norms.max() > 0.99  # in the shadow set, and it did switch
        H = np.stack([dcm_of_mrp(sigma[:, k]).T @ J @ omega[:, k] for k in range(t.size)], axis=-1)
        assert np.abs(H - H[:, :1]).max() / np.linalg.norm(H[:, 0]) < 1e-7
        E = 0.5 * np.einsum("ik,ij,jk->k", omega, J, omega)
        assert np.abs(E / E[0] - 1.0).max() < 1e-8
        assert np.abs(np.linalg.norm(r.states[:4], axis=0) - 1.0).max() < 1e-8
        assert_flies_with(r.states, J, t, tol=1e-6)
    # the spin: sigma = (0, 0, tan(t/4)) in the shadow set, i.e. tan of the angle wrapped to [-pi, pi), over 4
    wrapped = (t + np.pi) % (2 * np.pi) - np.pi
    assert np.abs(sigma[2] - np.tan(wrapped / 4)).max() < 1e-8 and np.abs(sigma[:2]).max() < 1e-12


def test_quaternion_normalisation_drift_control():
    """A non-unit initial q is the same attitude; the drift term drives |q| to 1 and changes nothing else."""
    t = np.linspace(0.0, 20.0, 201)
    unit = ct.input_output_response(fsmctl.spacecraft(J1, name="u"), t, 0, plant_state(SIGMA0, OMEGA0), **TIGHT)
    x0 = plant_state(SIGMA0, OMEGA0)
    x0[:4] *= 1.25
    scaled = ct.input_output_response(fsmctl.spacecraft(J1, name="s"), t, 0, x0, **TIGHT)
    assert np.abs(scaled.outputs - unit.outputs).max() < 1e-8
    assert abs(np.linalg.norm(scaled.states[:4, -1]) - 1.0) < 1e-8  # e^(-2 k t) with k = 1/s
    free = fsmctl.spacecraft(J1, name="f", normalization_gain=0.0)
    r = ct.input_output_response(free, t, 0, x0, **TIGHT)
    assert np.abs(r.outputs - unit.outputs).max() < 1e-8
    assert abs(np.linalg.norm(r.states[:4, -1]) - 1.25) < 1e-8  # without the term |q| stays where it started


def test_attitude_kinematics_match_scipy_rotation():
    """Constant body rate (isotropic J, and the reference generator with a constant omega_d) for 60 s, well past
    360 deg: the attitude is scipy's R(0) exp([omega x] t) and sigma stays in the shadow set."""
    w = np.array([0.3, -0.7, 0.5])
    t = np.linspace(0.0, 60.0, 241)
    R0 = Rotation.from_mrp(SIGMA0)
    truth = (R0 * Rotation.from_rotvec(np.outer(t, w))).as_matrix()
    sc = fsmctl.spacecraft(2.0 * np.eye(3), name="iso")
    r = ct.input_output_response(sc, t, 0, plant_state(SIGMA0, w), **TIGHT)
    ref = fsmctl.reference_generator(fsmctl.Sinusoid(offset=tuple(w)), name="ref")
    rr = ct.input_output_response(ref, t, 0, quat(SIGMA0), **TIGHT)
    for sigma in (r.outputs[:3], rr.outputs[:3]):
        assert np.linalg.norm(sigma, axis=0).max() <= 1.0 + 1e-12
        assert np.abs(Rotation.from_mrp(sigma.T).as_matrix() - truth).max() < 1e-7
    assert np.allclose(rr.outputs[3:6], w[:, None], rtol=0, atol=1e-15)
    # the rate itself, at random attitudes: q_dot against a central difference of scipy's rotation
    rng = np.random.default_rng(5)
    for _ in range(5):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        omega = rng.normal(size=3)
        qdot = sc.dynamics(0.0, np.concatenate([q, omega]), [0, 0, 0])[:4]
        R = Rotation.from_quat(np.r_[q[1:], q[0]])
        h = 1e-5
        qp, qm = ((R * Rotation.from_rotvec(s * h * omega)).as_quat() for s in (1, -1))
        qp, qm = (np.r_[v[3], v[:3]] * np.sign(np.r_[v[3], v[:3]] @ q) for v in (qp, qm))
        assert np.allclose(qdot, (qp - qm) / (2 * h), rtol=0, atol=1e-9)


def test_mrp_quaternion_conversions_match_scipy():
    """``quaternion_from_mrp`` / ``mrp_from_quaternion`` / ``mrp_state`` against scipy's Rotation."""
    from fsmctl.plugin.iosys import initial_state, mrp_from_quaternion, mrp_state, quaternion_from_mrp

    rng = np.random.default_rng(11)
    sigma = rng.normal(size=(2, 50, 3))  # |sigma| up to ~3: both sides of the shadow switch
    q = quaternion_from_mrp(sigma)
    assert q.shape == (2, 50, 4)
    xyzw = Rotation.from_mrp(sigma.reshape(-1, 3)).as_quat()
    ours = q.reshape(-1, 4)
    theirs = np.c_[xyzw[:, 3], xyzw[:, :3]]
    assert np.allclose(ours * np.sign(np.sum(ours * theirs, axis=1))[:, None], theirs, atol=1e-14)
    assert np.all(q[np.linalg.norm(sigma, axis=-1) <= 1][..., 0] >= 0)
    scaled = ours * rng.uniform(0.5, 2.0, size=(ours.shape[0], 1)) * rng.choice([-1, 1], size=(ours.shape[0], 1))
    s = mrp_from_quaternion(scaled)
    assert np.linalg.norm(s, axis=1).max() <= 1.0 + 1e-15
    assert np.allclose(s, Rotation.from_mrp(sigma.reshape(-1, 3)).as_mrp(), atol=1e-13)
    assert mrp_from_quaternion([1.0, 0.0, 0.0, 0.0]).shape == (3,)
    # the formation's state map: initial_state builds quaternions of the scenario's MRPs, mrp_state maps back
    paper = fsmctl.paper_scenario("1")
    x0 = initial_state(paper)
    back = mrp_state(np.stack([x0, x0], axis=1))
    assert back.shape == (3 + 6 * paper.n_agents, 2)
    expected = np.concatenate([paper.reference.sigma0] + [np.r_[a.sigma0, a.omega0] for a in paper.agents])
    assert np.allclose(back[:, 1], expected, atol=1e-15)


# ----------------------------------------------------------------------------- arguments


def test_spacecraft_rejects_bad_inertias_in_one_line():
    """Non-finite, wrong shape, non-symmetric, not positive definite, bools, strings, None, complex: ScenarioError."""
    eye = np.eye(3).tolist()
    cases = [
        (np.diag([100.0, np.nan, 200.0]), "not finite"),
        (np.diag([100.0, np.inf, 200.0]), "not finite"),
        (np.eye(2), r"3x3.*shape \(2, 2\)"),
        (np.ones(9), r"shape \(9,\)"),
        (np.eye(3)[..., None], r"shape \(3, 3, 1\)"),
        ([[1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], "ragged"),
        ([[100.0, 1.0, 0.0], [0.0, 150.0, 0.0], [0.0, 0.0, 200.0]], "not symmetric"),
        (np.diag([100.0, -1.0, 200.0]), "not positive definite"),
        (np.zeros((3, 3)), "not positive definite"),
        (np.eye(3, dtype=bool), "dtype bool"),
        ([[True, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], r"got True \(bool\)"),
        ([["1", 0, 0], [0, 1, 0], [0, 0, 1]], r"got '1' \(str\)"),
        ("eye", r"got 'eye' \(str\)"),
        (None, "got None"),
        (np.eye(3) * (1 + 0j), "dtype complex128"),
        ([[*eye[0][:2], None], eye[1], eye[2]], "got None"),
    ]
    for J, match in cases:
        with pytest.raises(ScenarioError, match=match) as exc:
            fsmctl.spacecraft(J, name="sc7")
        assert one_line(exc).startswith("spacecraft 'sc7': J: ")
        with pytest.raises(ScenarioError, match=match):
            fsmctl.fsm_controller(J, fsmctl.paper_scenario("1").controller, (1.0, 1.0, 1.0))


def test_factories_reject_bad_numbers_in_one_line():
    """Every numeric argument of the factories is checked: finite, the right shape and sign, not a bool/str."""
    from fsmctl.model.topology import Schedule
    from fsmctl.plugin.iosys import Neighbour

    paper = fsmctl.paper_scenario("1")
    c = paper.controller
    always = Schedule.constant(5.0)
    cases = [
        (lambda: fsmctl.fsm_controller(J1, c, (1.0, math.nan, 1.0)), "delta: not finite"),
        (lambda: fsmctl.fsm_controller(J1, c, (1.0, True, 1.0)), r"delta: .*got True \(bool\)"),
        (lambda: fsmctl.fsm_controller(J1, c, (1.0, 0.0, 1.0)), "delta: every component must be > 0"),
        (lambda: fsmctl.fsm_controller(J1, c, (1.0, 1.0)), r"delta: .*shape \(2,\)"),
        (lambda: fsmctl.fsm_controller(J1, c, "abc"), r"delta: .*'abc' \(str\)"),
        (lambda: fsmctl.fsm_controller(J1, {"c1": 1}, (1.0, 1.0, 1.0)), "controller: expected ControllerSettings"),
        (lambda: fsmctl.fsm_controller(J1, c, (1, 1, 1), neighbours=[("a", 1.0)]), "expected Neighbour"),
        (
            lambda: fsmctl.fsm_controller(J1, c, (1, 1, 1), neighbours=[Neighbour("a", 1, always)] * 2),
            "names must be unique",
        ),
        (lambda: Neighbour("a", True, always), r"k_i: expected a real number, got True \(bool\)"),
        (lambda: Neighbour("a", math.inf, always), "k_i: must be finite"),
        (lambda: Neighbour("a", -1.0, always), "k_i: must be >= 0"),
        (lambda: Neighbour("a", 1.0, always, phase=math.nan), "phase: must be finite"),
        (lambda: Neighbour("a", 1.0, always, phase="0"), "phase: expected a real number"),
        (lambda: Neighbour("a", 1.0, 5.0), "k_j: expected a fsmctl.Schedule"),
        (lambda: Neighbour("a.b", 1.0, always), "name must be"),
        (lambda: fsmctl.spacecraft(J1, disturbance=(0.1, 0.1, 0.1)), "disturbance: expected a fsmctl.Sinusoid"),
        (lambda: fsmctl.spacecraft(J1, normalization_gain=math.nan), "normalization_gain: must be finite"),
        (lambda: fsmctl.spacecraft(J1, normalization_gain=False), r"normalization_gain: .*got False \(bool\)"),
        (lambda: fsmctl.spacecraft(J1, normalization_gain=-1.0), "normalization_gain: must be >= 0"),
        (lambda: fsmctl.spacecraft(J1, name="a.b"), "name must be a non-empty string"),
        (lambda: fsmctl.spacecraft(J1, name=3), "name must be a non-empty string"),
        (lambda: fsmctl.reference_generator([0.1, 0.0, 0.0]), "omega_d: expected a fsmctl.Sinusoid"),
        (lambda: fsmctl.reference_generator(paper.reference.omega, normalization_gain=math.inf), "must be finite"),
        (lambda: fsmctl.formation("paper"), "formation: expected a Scenario"),
        (lambda: fsmctl.plugin.iosys.initial_state(None), "initial_state: expected a Scenario"),
    ]
    for make, match in cases:
        with pytest.raises(ScenarioError, match=match) as exc:
            make()
        one_line(exc)


# ----------------------------------------------------------------------------- python-control's defaults (issue 24)


def _wheel_plant():
    from fsmctl.plugin.hardware import reaction_wheel_spacecraft

    return reaction_wheel_spacecraft(np.diag([100.0, 150.0, 200.0]), {"layout": "pyramid"}, name="rw")


@pytest.mark.parametrize(
    "make, hint",
    [
        (lambda: fsmctl.spacecraft(np.diag([100.0, 150.0, 200.0]), name="sc1"), "quaternion_from_mrp"),
        (lambda: fsmctl.reference_generator(fsmctl.Sinusoid(offset=(0.0, 0.0, 0.1)), name="ref"), "quaternion_from"),
        (_wheel_plant, "reaction_wheel_state"),
    ],
)
def test_the_default_zero_state_is_refused_with_its_cause(make, hint):
    """x = 0 (python-control's default X0) holds q = 0, which is no rotation: a one-line error naming the cause
    (the old code gave NaN sigma and found x = 0 an equilibrium with success=True)."""
    sys = make()
    u = np.zeros(sys.ninputs)
    for call in (
        lambda: ct.input_output_response(sys, [0.0, 1.0]),
        lambda: sys.dynamics(0.0, np.zeros(sys.nstates), u),
        lambda: sys.output(0.0, np.zeros(sys.nstates), u),
        lambda: ct.find_operating_point(sys, 0, u),
    ):
        with pytest.raises(InvalidStateError) as info:
            call()
        message = str(info.value)
        assert "\n" not in message and isinstance(info.value, ValueError) and isinstance(info.value, InputError)
        assert f"{sys.name!r}: the attitude quaternion" in message and "default X0" in message
        assert hint in message and "[1, 0, 0, 0]" in message
    # a quaternion of tiny norm is refused too; a valid one of any other norm flies as before
    x = np.zeros(sys.nstates)
    x[0] = 1e-7
    with pytest.raises(InvalidStateError):
        sys.output(0.0, x, u)
    x[0] = 1e-3  # q / |q| is the identity: a valid (if unnormalised) state
    assert np.all(np.isfinite(sys.output(0.0, x, u)))


def test_formation_from_the_default_zero_state_names_the_cause_not_an_algebraic_loop():
    loop = fsmctl.formation(fsmctl.paper_scenario("1"))
    with pytest.raises(InvalidStateError, match=r"reference.*initial_state"):
        ct.input_output_response(loop, [0.0, 0.1])
    x = initial_state(fsmctl.paper_scenario("1"))
    x[4:8] = 0.0  # sc1's quaternion
    with pytest.raises(InvalidStateError, match=r"spacecraft 'sc1'"):
        loop.dynamics(0.0, x, [])


def test_valid_states_give_bit_identical_results_to_the_unchecked_functions():
    """The check reads the state only: every result at a valid state is the model's own output, bit for bit."""
    s = fsmctl.paper_scenario("1")
    loop = fsmctl.formation(s)
    x = initial_state(s)
    r = ct.input_output_response(loop, np.linspace(0.0, 0.2, 5), 0, x, solve_ivp_kwargs={"max_step": 0.01})
    for k, t in enumerate(r.time):
        assert np.array_equal(loop.output(t, r.states[:, k], []), r.outputs[:, k])
    sc = loop.syslist[1]
    assert sc.name == "sc1"
    xs, us = x[4:11], np.array([0.1, -0.2, 0.3])
    p = sc.params
    assert np.array_equal(sc.dynamics(0.3, xs, us), sc._model_update(0.3, xs, us, sc._resolve(p)))
    assert np.array_equal(sc.output(0.3, xs, us), sc._model_output(0.3, xs, us, sc._resolve(p)))


@pytest.mark.parametrize(
    "make, key, closest",
    [
        (lambda: fsmctl.spacecraft(np.eye(3), name="sc"), "JJ", "J"),  # "J" is its local name
        (lambda: fsmctl.spacecraft(np.eye(3), name="sc"), "sc_j", "sc_J"),
        (_wheel_plant, "torque_limit", None),
        (
            lambda: law_controller("fsm", np.eye(3), name="ctrl"),
            "umax",
            "u_max",
        ),
        (lambda: law_controller("fsm", np.eye(3), name="ctrl"), "ctrl_C1", "ctrl_c1"),
    ],
)
def test_unknown_parameter_keys_of_a_system_raise(make, key, closest):
    sys = make()
    x0 = np.zeros(sys.nstates)
    if sys.nstates:
        x0[0] = 1.0
    u = np.zeros(sys.ninputs)
    for call in (
        lambda: sys.dynamics(0.0, x0, u, params={key: 1.0}),
        lambda: sys.output(0.0, x0, u, params={key: 1.0}),
        lambda: ct.input_output_response(sys, [0.0, 0.1], 0, x0, params={key: 1.0}),
    ):
        with pytest.raises(ParameterKeyError) as info:
            call()
        message = str(info.value)
        assert "\n" not in message and isinstance(info.value, ValueError)
        assert f"unknown parameter {key!r}" in message
        known = message.split("closest first: ", 1)[1]
        if closest:
            assert known.startswith(closest)
        assert f"{sys.name}_owner" not in known
        for k in sys.params:
            if not k.endswith("_owner"):
                assert k in known


@pytest.mark.parametrize("key, closest", [("C1", "c1"), ("umax", None), ("torque_limit", None), ("j", None)])
def test_unknown_parameter_keys_of_a_formation_raise(key, closest):
    s = fsmctl.paper_scenario("1").replace(controller={"torque_limit": float("inf")})  # c1 acts at t = 0
    loop = fsmctl.formation(s)
    x = initial_state(s)
    with pytest.raises(ParameterKeyError, match=rf"unknown parameter {key!r}") as info:
        ct.input_output_response(loop, [0.0, 0.01], 0, x, params={key: 0.3})
    if closest:
        assert str(info.value).split("closest first: ", 1)[1].startswith(closest)
    assert len(str(info.value)) < 700 and "more: the keys of the system's params" in str(info.value)  # ~70 known
    with pytest.raises(ParameterKeyError):
        loop.dynamics(0.0, x, [], params={key: 0.3})
    # known keys, bare or prefixed, are taken as before
    assert not np.array_equal(loop.dynamics(0.0, x, [], params={"c1": 1.2}), loop.dynamics(0.0, x, []))
    assert np.array_equal(
        loop.dynamics(0.0, x, [], params={"ctrl3_c1": 1.2}),
        loop.dynamics(0.0, x, [], params={"ctrl3_c1": 1.2, "ctrl3_owner": loop.params["ctrl3_owner"]}),
    )


def test_adding_a_params_key_by_mutation_raises_and_replacing_a_known_one_is_used():
    s = fsmctl.paper_scenario("1").replace(controller={"torque_limit": float("inf")})
    loop = fsmctl.formation(s)
    x = initial_state(s)
    before = loop.dynamics(0.0, x, [])
    for key in ("c1", "ctrl1_C1"):
        with pytest.raises(ParameterKeyError, match=rf"unknown parameter {key!r}"):
            loop.params[key] = 1.2
        with pytest.raises(ParameterKeyError):
            loop.params.update({key: 1.2})
        with pytest.raises(ParameterKeyError):
            loop.params.setdefault(key, 1.2)
        with pytest.raises(ParameterKeyError):
            loop.params |= {key: 1.2}
    assert np.array_equal(loop.dynamics(0.0, x, []), before)
    loop.params["ctrl1_c1"] = 1.2
    assert np.array_equal(loop.dynamics(0.0, x, []), loop.dynamics(0.0, x, [], params={"ctrl1_c1": 1.2}))
    assert not np.array_equal(loop.dynamics(0.0, x, []), before)
    sc = fsmctl.spacecraft(np.eye(3), name="sc")
    with pytest.raises(ParameterKeyError, match="unknown parameter 'J'"):
        sc.params["J"] = 2 * np.eye(3)
    # copies, deep copies and pickles keep the rule
    import pickle

    for other in (sc.copy("sd"), copy.deepcopy(sc), copy.copy(sc)):
        with pytest.raises(ParameterKeyError):
            other.params["J"] = 2 * np.eye(3)
    p = pickle.loads(pickle.dumps(sc.params))
    with pytest.raises(ParameterKeyError):
        p["J"] = 1.0


def test_fsmctl_system_inside_a_plain_interconnect_takes_every_key_as_python_control_does():
    """Documented limit: python-control hands every key of a plain ct.interconnect to every subsystem, so fsmctl
    cannot tell a typo there from another subsystem's key."""
    sc = fsmctl.spacecraft(np.diag([100.0, 150.0, 200.0]), name="sc")
    pd = ct.ss([], [], [], -np.hstack([np.eye(3), 10 * np.eye(3)]), inputs=6, outputs=3, name="pd")
    loop = ct.interconnect(
        [sc, pd],
        connections=[["sc.tau", "pd.y"], ["pd.u[0:3]", "sc.sigma"], ["pd.u[3:6]", "sc.omega"]],
        inplist=[],
        outlist=["sc.sigma"],
    )
    x0 = np.concatenate([quaternion_from_mrp([0.1, 0.0, 0.0]), np.zeros(3)])
    assert np.array_equal(loop.dynamics(0.0, x0, [], params={"tau_gain": 1.0}), loop.dynamics(0.0, x0, []))
    # a local name of the one fsmctl system that has it is that system's parameter
    J = np.diag([10.0, 20.0, 30.0])
    assert np.array_equal(loop.dynamics(0.0, x0, [], params={"J": J}), loop.dynamics(0.0, x0, [], params={"sc_J": J}))
