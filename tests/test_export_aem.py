"""CCSDS AEM export (issue 30 item 4): a flown run written per agent, read back and compared.

Oracles: the run's own arrays (the file keeps every float64 digit: the library writes shortest round-trip
decimals, so quaternions come back bit for bit and MRPs to a few ulp after the two conversions); a hand-computed
90-degree rotation about z and its direction-cosine matrix (Schaub & Junkins eq 3.97, written out here); scipy's
``Rotation`` as an independent route between MRPs and quaternions; the raw KVN text, split by hand, for the
column order.
"""

from __future__ import annotations

import dataclasses
from datetime import datetime

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import fsmctl
from fsmctl.errors import InputError
from fsmctl.export import (
    AemError,
    EmptyResultError,
    NotAnAemError,
    UnknownAgentError,
    aem_quaternions,
    mrp_from_aem_quaternions,
    read_aem,
    write_aem,
)
from fsmctl.simulation.results_io import load_result

SETTINGS = settings(max_examples=200, derandomize=True, deadline=None)
SIGMA_ATOL = 1e-13
"""MRP agreement after MRP -> quaternion (written exactly) -> MRP: two float64 conversions, a few ulp of |sigma| <= 1"""


@pytest.fixture(scope="module")
def run(paper_case1):
    return fsmctl.simulate(paper_case1.replace(simulation={"t_final": 0.2}))


def _with_attitude(run, time, sigma_one_agent, omega=(0.0, 0.0, 0.0)):
    """The run with its time axis and every agent's attitude and rate replaced (a known history, the public type)."""
    T = len(time)
    n = run.sigma.shape[1]
    sigma = np.repeat(np.asarray(sigma_one_agent, dtype=float)[:, None, :], n, axis=1)
    omega = np.broadcast_to(np.asarray(omega, dtype=float), (T, n, 3)).copy()
    return dataclasses.replace(run, time=np.asarray(time, dtype=float), sigma=sigma, omega=omega, sigma_d=sigma[:, 0])


def _shadow(sigma):
    s = np.asarray(sigma, dtype=float)
    s2 = np.sum(s * s, axis=-1, keepdims=True)
    return np.where(s2 > 1, -s / np.maximum(s2, 1.0), s)


@pytest.mark.parametrize("fmt", ["kvn", "xml"])
def test_round_trip_of_a_flown_run(run, tmp_path, fmt):
    paths = write_aem(run, tmp_path, format=fmt, command=["fsmctl", "export"])
    n = run.sigma.shape[1]
    assert len(paths) == n + 1 and all(p.exists() for p in paths)
    for k, path in enumerate(paths[:n], start=1):
        e = read_aem(path)
        assert e.object_name == f"paper-case-1-agent-{k}"
        assert (e.ref_frame_a, e.ref_frame_b, e.time_system) == ("EME2000", "SC_BODY_1", "UTC")
        assert e.attitude_type == "QUATERNION/ANGVEL" and e.angular_velocity_frame == "SC_BODY_1"
        assert e.epoch == datetime(2000, 1, 1, 12, 0, 0)
        np.testing.assert_array_equal(e.time, run.time)  # exactly: every digit of repr(t) is written
        np.testing.assert_array_equal(e.quaternion, aem_quaternions(run.sigma[:, k - 1]))
        np.testing.assert_allclose(e.sigma, run.sigma[:, k - 1], rtol=0, atol=SIGMA_ATOL)
        np.testing.assert_allclose(e.angular_velocity, run.omega[:, k - 1], rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(np.linalg.norm(e.quaternion, axis=1), 1.0, rtol=0, atol=1e-15)
        assert e.provenance["law"] == run.scenario.controller.law == "fsm"
        assert e.provenance["version_fsmctl"] == fsmctl.__version__
        assert e.provenance["command"] == "fsmctl export"
        assert e.provenance["scenario_toml"] == run.scenario.to_toml()
    ref = read_aem(paths[-1])
    assert ref.object_name == "paper-case-1-reference" and ref.angular_velocity is None
    np.testing.assert_allclose(ref.sigma, run.sigma_d, rtol=0, atol=SIGMA_ATOL)


def test_ninety_degrees_about_z_hand_computed(run, tmp_path):
    """Body rotated +90 deg about z from N: sigma = tan(22.5 deg) z, q = (0, 0, sin 45, cos 45) scalar last."""
    sigma = np.array([[0.0, 0.0, np.tan(np.pi / 8)]] * 2)
    flown = _with_attitude(run, [0.0, 1.0], sigma, omega=(0.0, 0.0, np.pi / 180))  # 1 deg/s about z
    path = write_aem(flown, tmp_path, agents=[1], reference_name_format=None)[0]
    line = path.read_text().split("DATA_START")[1].split("DATA_STOP")[0].split("COMMENT")[0].strip().splitlines()[0]
    numbers = [float(x) for x in line.split()[1:]]
    h = np.sqrt(0.5)
    np.testing.assert_allclose(numbers[:4], [0.0, 0.0, h, h], rtol=0, atol=1e-15)  # Q1 Q2 Q3 QC
    np.testing.assert_allclose(numbers[4:], [0.0, 0.0, 1.0], rtol=1e-15)  # ANGVEL_X Y Z in deg/s
    assert line.split()[0] == "2000-01-01T12:00:00.000000"
    # the direction: [BN] of these Euler parameters (Schaub & Junkins eq 3.97) maps N's y axis to B's x axis
    b1, b2, b3, b0 = numbers[:4]
    bn = np.array(
        [
            [b0**2 + b1**2 - b2**2 - b3**2, 2 * (b1 * b2 + b0 * b3), 2 * (b1 * b3 - b0 * b2)],
            [2 * (b1 * b2 - b0 * b3), b0**2 - b1**2 + b2**2 - b3**2, 2 * (b2 * b3 + b0 * b1)],
            [2 * (b1 * b3 + b0 * b2), 2 * (b2 * b3 - b0 * b1), b0**2 - b1**2 - b2**2 + b3**2],
        ]
    )
    np.testing.assert_allclose(bn @ [0.0, 1.0, 0.0], [1.0, 0.0, 0.0], atol=1e-15)
    # scipy's active rotation of the same MRP is [BN]^T
    np.testing.assert_allclose(Rotation.from_mrp(sigma[0]).as_matrix().T, bn, atol=1e-15)


def test_sign_is_continuous_across_a_shadow_switch(run, tmp_path):
    phi = np.radians(np.linspace(150.0, 210.0, 61))  # through 180 deg about a tilted axis
    axis = np.array([1.0, -2.0, 2.0]) / 3.0
    sigma = _shadow(np.tan(phi / 4)[:, None] * axis)
    assert np.linalg.norm(sigma, axis=1).max() <= 1.0 and (sigma @ axis < 0).any()  # the switch is in there
    raw = Rotation.from_mrp(sigma).as_quat(canonical=True)  # scalar last, w >= 0: jumps at 180 deg
    assert (np.einsum("ij,ij->i", raw[1:], raw[:-1]) < 0).any()
    time = np.cumsum(np.full(61, 0.1)) - 0.1  # 0.30000000000000004 and the like
    path = write_aem(_with_attitude(run, time, sigma), tmp_path, agents=[3], epoch=datetime(2031, 12, 31, 23, 59, 58))[
        0
    ]
    e = read_aem(path)
    step = np.cos(np.radians(1.0) / 2)  # the dot product of successive quaternions one degree apart
    np.testing.assert_allclose(np.einsum("ij,ij->i", e.quaternion[1:], e.quaternion[:-1]), step, rtol=1e-12)
    assert e.quaternion[0, 3] > 0
    np.testing.assert_allclose(np.abs(np.einsum("ij,ij->i", e.quaternion, raw)), 1.0, rtol=1e-13)  # same attitude
    np.testing.assert_allclose(e.sigma, sigma, rtol=0, atol=SIGMA_ATOL)
    np.testing.assert_array_equal(e.time, time)
    assert e.epoch == datetime(2031, 12, 31, 23, 59, 58)
    assert "2032-01-01T00:00:00.000000" in path.read_text()  # crossed the year at t = 2.0


def test_epoch_with_microseconds_and_explicit_origin_round_trip(run, tmp_path):
    time = np.array([0.0, 1e-9, 0.1 + 0.2, 86399.99999999999, 1.5e6])
    sigma = np.zeros((5, 3))
    epoch = datetime(2024, 2, 28, 23, 59, 59, 999999)
    path = write_aem(_with_attitude(run, time, sigma), tmp_path, agents=[1], epoch=epoch, format="xml")[0]
    np.testing.assert_array_equal(read_aem(path).time, time)
    later = read_aem(path, epoch=datetime(2024, 2, 29, 0, 0, 0))
    np.testing.assert_allclose(later.time, time - 1e-6, rtol=0, atol=1e-9)


@SETTINGS
@given(st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3))
def test_mrp_quaternion_mrp_property(s):
    sigma = np.array([s])
    q = aem_quaternions(sigma)
    scipy_q = Rotation.from_mrp(sigma[0]).as_quat()  # scalar last, independent route
    assert abs(abs(float(q[0] @ scipy_q)) - 1.0) < 1e-12
    np.testing.assert_allclose(np.linalg.norm(q), 1.0, atol=1e-15)
    back = mrp_from_aem_quaternions(q)
    np.testing.assert_allclose(back, _shadow(sigma), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(mrp_from_aem_quaternions(-q), back, rtol=1e-12, atol=1e-12)


def _one_line(exc: BaseException) -> str:
    text = str(exc)
    assert "\n" not in text and text
    return text


@pytest.mark.parametrize("agents", [[0], [7], [1, 99], ["1"]])
def test_unknown_agent(run, tmp_path, agents):
    with pytest.raises(UnknownAgentError) as info:
        write_aem(run, tmp_path, agents=agents)
    assert "agents 1..6" in _one_line(info.value)
    assert not list(tmp_path.iterdir())


def test_empty_result(run, tmp_path):
    empty = dataclasses.replace(run, time=run.time[:0], sigma=run.sigma[:0], omega=run.omega[:0])
    with pytest.raises(EmptyResultError) as info:
        write_aem(empty, tmp_path)
    assert isinstance(info.value, InputError) and "no time sample" in _one_line(info.value)


def test_bad_name_format_and_format(run, tmp_path):
    with pytest.raises(AemError, match="share one file name"):
        write_aem(run, tmp_path, object_name_format="{scenario}")
    with pytest.raises(AemError, match="object name format"):
        write_aem(run, tmp_path, object_name_format="{agent}")
    with pytest.raises(AemError, match="format 'json'"):
        write_aem(run, tmp_path, format="json")


def test_files_that_are_not_an_aem(run, tmp_path):
    good = write_aem(run, tmp_path, agents=[1], reference_name_format=None)[0]
    text = good.read_text()
    cases = {
        "hello.aem": "hello world\n",
        "truncated.aem": text[: text.index("DATA_START")],
        "bad_number.aem": text.replace(
            "DATA_START\n2000-01-01T12:00:00.000000 ", "DATA_START\n2000-01-01T12:00:00.000000 x"
        ),
        "oem.aem": text.replace("CCSDS_AEM_VERS", "CCSDS_OEM_VERS"),
        "empty.aem": "",
    }
    for name, content in cases.items():
        path = tmp_path / name
        path.write_text(content)
        with pytest.raises(NotAnAemError) as info:
            read_aem(path)
        assert _one_line(info.value).startswith(str(path)), name
    with pytest.raises(NotAnAemError, match="cannot be read"):
        read_aem(tmp_path / "missing.aem")
    two = tmp_path / "two.aem"
    segment = text[text.index("META_START") :]
    two.write_text(text + segment)
    with pytest.raises(AemError, match="2 segments"):
        read_aem(two)


def test_a_result_file_exports_as_the_run_does(run, tmp_path):
    saved = run.save(tmp_path / "run.nc", command=["fsmctl", "simulate"])
    ds = load_result(saved)
    from_file = write_aem(ds, tmp_path / "file", command="fsmctl export --target aem")
    from_run = write_aem(run, tmp_path / "run")
    assert [p.name for p in from_file] == [p.name for p in from_run]
    for a, b in zip(from_file, from_run, strict=True):
        ea, eb = read_aem(a), read_aem(b)
        np.testing.assert_array_equal(ea.time, eb.time)
        np.testing.assert_array_equal(ea.quaternion, eb.quaternion)
        assert (ea.angular_velocity is None) == (eb.angular_velocity is None)
        assert ea.provenance["scenario_toml"] == eb.provenance["scenario_toml"]
        assert ea.provenance["command"] == "fsmctl simulate"
        assert ea.provenance["export_command"] == "fsmctl export --target aem"
    with pytest.raises(AemError, match="not an fsmctl result"):
        write_aem(ds.drop_vars("sigma"), tmp_path / "bad")
