"""``fsmctl.attitude_error_angle``: the angle between two MRP signals, continuous where sigma switches set.

The outputs ``sigma`` of fsmctl's systems are shadow-set MRPs (``|sigma| <= 1``) and switch to
``-sigma / |sigma|^2`` at 180 deg, so differences of outputs jump.  Oracles: SciPy's rotations
(``scipy.spatial.transform.Rotation``: ``(R_a R_b^-1).magnitude()``), the MRP shadow-set identities, and the
analytic attitude of a spacecraft spinning about a principal axis flown by python-control.
"""

from __future__ import annotations

import control as ct
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

import fsmctl
from fsmctl.errors import InputError
from fsmctl.plugin.iosys import quaternion_from_mrp

finite = st.floats(-3.0, 3.0, allow_nan=False, allow_infinity=False)
mrps = arrays(np.float64, 3, elements=finite)


@st.composite
def near_switch(draw):
    """An MRP with ``0.95 <= |sigma| <= 1.05``: attitudes within ~6 deg of 180 deg, on either side of the switch."""
    direction = draw(arrays(np.float64, 3, elements=st.floats(-1.0, 1.0)).filter(lambda v: np.linalg.norm(v) > 0.1))
    return direction / np.linalg.norm(direction) * draw(st.floats(0.95, 1.05))


def scipy_angle(a, b) -> np.ndarray:
    """The principal angle of ``R_a R_b^-1`` by SciPy (rotation objects, no MRP arithmetic of fsmctl's)."""
    return (Rotation.from_mrp(a) * Rotation.from_mrp(b).inv()).magnitude()


def shadow(sigma: np.ndarray) -> np.ndarray:
    return -sigma / (sigma @ sigma)


@given(a=st.one_of(mrps, near_switch()), b=st.one_of(mrps, near_switch()))
def test_the_angle_is_scipys_rotation_angle(a, b):
    theta = fsmctl.attitude_error_angle(a, b)
    assert theta.shape == ()
    assert abs(float(theta) - scipy_angle(a, b)) < 1e-9
    assert 0.0 <= float(theta) <= np.pi


@given(a=st.one_of(mrps, near_switch()).filter(lambda s: np.linalg.norm(s) > 1e-3), b=st.one_of(mrps, near_switch()))
def test_either_set_gives_the_same_angle_and_it_is_symmetric(a, b):
    theta = float(fsmctl.attitude_error_angle(a, b))
    assert abs(float(fsmctl.attitude_error_angle(shadow(a), b)) - theta) < 1e-9
    assert abs(float(fsmctl.attitude_error_angle(b, a)) - theta) < 1e-9
    assert float(fsmctl.attitude_error_angle(a, shadow(a))) < 1e-6  # one attitude, two MRPs


@given(
    axis=arrays(np.float64, 3, elements=st.floats(-1.0, 1.0)).filter(lambda v: np.linalg.norm(v) > 0.1),
    start=st.floats(0.0, 2 * np.pi),
    other=near_switch(),
)
def test_no_jump_across_the_switch_where_the_difference_of_outputs_jumps(axis, start, other):
    """A rotation through 720 deg about ``axis``, written as outputs are (shadow set): sigma jumps by 2 at each
    180 deg, the angle to a fixed attitude moves by at most the rotation of one step."""
    n = axis / np.linalg.norm(axis)
    phi = start + np.linspace(0.0, 4 * np.pi, 2001)  # 0.36 deg steps
    sigma = Rotation.from_rotvec(phi[:, None] * n).as_mrp()  # SciPy's MRPs: |sigma| <= 1, as fsmctl's outputs
    assert np.linalg.norm(np.diff(sigma, axis=0), axis=1).max() > 1.9  # the outputs do jump
    theta = fsmctl.attitude_error_angle(sigma, other)
    step = phi[1] - phi[0]
    assert np.abs(np.diff(theta)).max() <= step + 1e-9
    assert np.abs(theta - scipy_angle(sigma, other)).max() < 1e-9


def test_a_spinning_spacecraft_flown_by_python_control():
    """Torque-free spin at w about the principal axis z from R_x(0.6): ``B(t) = R_z(w t) B(0)``, so the angle
    between the output at t and at 0 is the spin angle wrapped to [0, pi]; the attitude passes 180 deg at w t = pi,
    where the outputs switch set."""
    w = 1.0
    sc = fsmctl.spacecraft(np.diag([100.0, 150.0, 200.0]), name="sc")
    sigma0 = np.array([np.tan(0.6 / 4), 0.0, 0.0])
    x0 = np.concatenate([quaternion_from_mrp(sigma0), [0.0, 0.0, w]])
    t = np.linspace(0.0, 10.0, 1001)
    r = ct.input_output_response(sc, t, 0, x0, solve_ivp_kwargs={"rtol": 1e-10, "atol": 1e-12})
    sigma = r.outputs[:3]  # python-control rows: (3, T)
    assert np.linalg.norm(np.diff(sigma, axis=1), axis=0).max() > 1.5  # the switch at t = pi
    theta = fsmctl.attitude_error_angle(sigma, sigma0[:, None], axis=0)
    spin = np.mod(w * t, 2 * np.pi)
    assert theta.shape == t.shape
    assert np.abs(theta - np.minimum(spin, 2 * np.pi - spin)).max() < 1e-6
    deg = fsmctl.attitude_error_angle(sigma, sigma0[:, None], axis=0, degrees=True)
    assert np.abs(deg - np.degrees(theta)).max() < 1e-9


def test_shapes_broadcast_over_time_and_agents():
    rng = np.random.default_rng(3)
    a = rng.uniform(-1, 1, (50, 4, 3))  # (T, agents, 3)
    b = rng.uniform(-1, 1, (4, 3))  # one attitude per agent
    theta = fsmctl.attitude_error_angle(a, b)
    assert theta.shape == (50, 4)
    expected = scipy_angle(a.reshape(-1, 3), np.broadcast_to(b, a.shape).reshape(-1, 3)).reshape(50, 4)
    assert np.abs(theta - expected).max() < 1e-9
    rows = fsmctl.attitude_error_angle(np.moveaxis(a, -1, 0), np.moveaxis(b, -1, 0), axis=0)
    assert np.array_equal(rows, theta)
    assert fsmctl.attitude_error_angle(np.zeros((0, 3)), np.zeros(3)).shape == (0,)


def test_it_is_the_simulators_relative_angle():
    """The formula of RAEM's pairwise angles (eq 43): one route, so the same bits."""
    rng = np.random.default_rng(5)
    sigma_e = rng.uniform(-1, 1, (20, 3, 3))
    theta = fsmctl.simulation.relative_principal_angles(sigma_e)
    assert np.array_equal(fsmctl.attitude_error_angle(sigma_e[:, 0], sigma_e[:, 2]), theta[:, 0, 2])


@pytest.mark.parametrize(
    ("a", "b", "kwargs", "match"),
    [
        (np.zeros(4), np.zeros(3), {}, r"sigma_a has 4 components along axis -1, an MRP has 3"),
        (np.zeros((3, 5)), np.zeros((3, 5)), {}, r"sigma_a has 5 components along axis -1.*pass axis=0"),
        (np.zeros((3, 5)), np.zeros((3, 4)), {"axis": 0}, r"the shapes \(3, 5\) and \(3, 4\) do not broadcast"),
        (np.zeros(3), [0.0, np.nan, 0.0], {}, r"sigma_b holds a value that is not finite"),
        (np.zeros(3), np.zeros(3), {"axis": 2}, r"sigma_a of shape \(3,\) has no axis 2"),
        ("abc", np.zeros(3), {}, r"sigma_a must be an array of numbers"),
        (np.zeros(3), np.zeros(3), {"axis": True}, r"axis must be an integer, got True"),
    ],
)
def test_bad_input_is_one_line(a, b, kwargs, match):
    with pytest.raises(InputError, match=match) as info:
        fsmctl.attitude_error_angle(a, b, **kwargs)
    assert "\n" not in str(info.value)


def test_the_names_users_find():
    assert fsmctl.attitude_error_angle is fsmctl.simulation.attitude_error_angle
    assert "attitude_error_angle" in fsmctl.__all__ and "attitude_error_angle" in fsmctl.simulation.__all__
