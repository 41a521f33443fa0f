"""The documentation's example scenarios (``docs/examples/``) load, fly, and show what they are written to show.

Each file is loaded with :func:`fsmctl.load_scenario`, flown for its short horizon with the compiled simulator,
and checked against something computed here from the file's raw TOML (read with ``tomllib``, not through
fsmctl) or from physics, so that a wrong file (a typo in a table name, a unit, a gain) fails:

* ``ring_of_three.toml``: the ring of three agents has the six directed links i <- j (i != j) with the file's
  weights; the initial AAEM (eq 42) equals the one computed from the file's attitudes with the NumPy oracle;
  the formation converges (AAEM and RAEM below 0.01 deg at 20 s) and the applied torque respects the limit;
* ``wheels_and_sensors.toml``: every spacecraft carries the four pyramid wheels; with no disturbance, the
  spacecraft and wheels at rest at t = 0, the total angular momentum ``J omega + J_s G_s Omega`` stays zero
  (the wheels' torque is internal; ``G_s`` built here from the pyramid's definition); the star tracker's
  error is the file's 5 arcsec (``sigma_measured - sigma`` has std ``noise_std / 4`` in MRP units); every
  wheel torque is within ``max_torque``; the formation converges to 0.1 deg in 60 s through noise, delay and loss;
* ``my_law.toml``: it flies the user's law of ``my_law.py`` (``my_pd``), whose commanded torque at t = 0 equals
  its formula ``-K sigma_e - P omega_e - k_c sum_j k^j_ij (sigma_e,i - sigma_e,j)``, evaluated here from the
  file's initial states (the reference is at rest at the identity, so ``sigma_e = sigma``, ``omega_e = omega``),
  and the formation converges.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import oracle_numpy as oracle
import pytest

import fsmctl
from fsmctl.studies.compare_runs import read_runs_file

EXAMPLES = Path(__file__).resolve().parent.parent / "docs" / "examples"


def _raw(name: str) -> dict:
    return tomllib.loads((EXAMPLES / name).read_text(encoding="utf-8"))


def test_every_example_scenario_is_checked_here():
    assert {p.name for p in EXAMPLES.glob("*.toml")} == {
        "ring_of_three.toml",
        "wheels_and_sensors.toml",
        "my_law.toml",
        "event_trigger_sweep.toml",
    }


def test_event_trigger_sweep():
    """The runs file of docs/findings.md's event-triggered comparison: periodic fsm, then fsm_event with the threshold
    floors its table lists; each flies (1 s at 10 Hz on Case 1) and periodic broadcasting sends one message per agent
    and control instant (6 x 11), the event-triggered runs fewer."""
    runs = read_runs_file(EXAMPLES / "event_trigger_sweep.toml")
    assert [(r.law, dict(r.parameters).get("threshold_floor")) for r in runs] == [
        ("fsm", None),
        *[("fsm_event", c0) for c0 in (0.01, 0.02, 0.05, 0.1, 0.2)],
    ]
    base = fsmctl.paper_scenario("1").replace(simulation={"t_final": 1.0, "control_period": 0.1})
    sent = []
    for r in runs:
        s = base.replace(controller={"law": r.law, "parameters": dict(r.parameters)})
        sent.append(int(fsmctl.simulate(s).messages_sent.sum()))
    assert sent[0] == 6 * 11
    assert all(6 <= n < sent[0] for n in sent[1:])


def test_ring_of_three():
    raw = _raw("ring_of_three.toml")
    sc = fsmctl.load_scenario(EXAMPLES / "ring_of_three.toml")
    assert sc.n_agents == 3
    links = {(link.receiver, link.sender) for link in sc.topology.links}
    assert links == {(i, j) for i in range(3) for j in range(3) if i != j}
    for link in sc.topology.links:
        assert link.k_i == raw["topology"]["k_i"]
        assert link.k_j.value(0.0) == link.k_j.value(17.3) == raw["topology"]["k_j"]

    result = fsmctl.simulate(sc)
    assert result.time[-1] == pytest.approx(raw["simulation"]["t_final"])
    sigma_d0 = raw["reference"]["sigma0"]
    theta0 = [oracle.principal_angle(oracle.mrp_error(a["sigma0"], sigma_d0)) for a in raw["agents"]]
    assert result.aaem_deg[0] == pytest.approx(oracle.aaem_deg(theta0), rel=1e-9)
    assert result.aaem_deg[0] > 10.0  # a real slew, not a formation already at rest
    assert result.aaem_deg[-1] < 0.01 and result.raem_deg[-1] < 0.01
    assert np.abs(result.u).max() <= raw["controller"]["torque_limit"] * (1 + 1e-12)


def _pyramid(angle_deg: float) -> np.ndarray:
    """Spin axes (columns) at ``angle_deg`` from body z, azimuths 45, 135, 225, 315 deg."""
    th = math.radians(angle_deg)
    return np.array(
        [
            [math.sin(th) * math.cos(a), math.sin(th) * math.sin(a), math.cos(th)]
            for a in np.radians([45, 135, 225, 315])
        ]
    ).T


def test_wheels_and_sensors():
    raw = _raw("wheels_and_sensors.toml")
    sc = fsmctl.load_scenario(EXAMPLES / "wheels_and_sensors.toml")
    assert sc.simulation.control_period == raw["simulation"]["control_period"] > 0
    result = fsmctl.simulate(sc)
    n_t = result.time.size
    assert result.wheel_speed is not None and result.wheel_speed.shape == (n_t, 3, 4)
    assert result.sigma_measured is not None

    # total angular momentum, body frame: J omega + J_s G_s Omega (Schaub & Junkins eq 4.146), zero at t = 0
    act = raw["actuator"]
    G = _pyramid(math.degrees(math.atan(math.sqrt(2.0))))  # the pyramid of (+-1, +-1, 1)/sqrt(3)
    for i, agent in enumerate(raw["agents"]):
        assert all(a == 0.0 for a in agent["omega0"])
        J = np.asarray(agent["J0"], dtype=float)
        wheels = act["spin_inertia"] * result.wheel_speed[:, i, :] @ G.T
        H = result.omega[:, i, :] @ J.T + wheels
        assert np.abs(wheels).max() > 0.05  # the wheels did absorb momentum
        assert np.abs(H).max() < 1e-9 * np.abs(wheels).max()
    assert np.abs(result.wheel_torque).max() <= act["max_torque"] * (1 + 1e-12)

    # the star tracker: a small rotation of std noise_std per axis is an MRP error of std noise_std / 4
    std = (result.sigma_measured - result.sigma)[1:].std(axis=0)
    expected = np.asarray(raw["sensors"]["star_tracker"]["noise_std"]) / 4
    assert np.all(np.abs(std / expected - 1) < 0.2), std

    assert result.aaem_deg[0] > 5.0
    assert result.aaem_deg[-1] < 0.1 and result.raem_deg[-1] < 0.1


def test_my_law():
    raw = _raw("my_law.toml")
    ctl = raw["controller"]
    sc = fsmctl.load_scenario(EXAMPLES / "my_law.toml")
    result = fsmctl.simulate(sc)
    assert result.law.name == "my_pd"

    # the formula of my_law.py at t = 0 (all-to-all, constant k^j: k_received_sum = 2 k^j for every agent)
    assert raw["reference"]["sigma0"] == [0.0, 0.0, 0.0] and not any(raw["reference"]["omega"]["amplitude"])
    sigma = np.array([a["sigma0"] for a in raw["agents"]])
    omega = np.array([a["omega0"] for a in raw["agents"]])
    k_j = raw["topology"]["k_j"]
    for i in range(3):
        consensus = sum(k_j * (sigma[i] - sigma[j]) for j in range(3) if j != i)
        u = -ctl["K"] * sigma[i] - ctl["P"] * omega[i] - ctl["k_c"] * consensus
        np.testing.assert_allclose(result.u_unsaturated[0, i], u, rtol=1e-12, atol=1e-14)
    np.testing.assert_array_equal(result.u[0], result.u_unsaturated[0])  # torque_limit = "inf"

    assert result.aaem_deg[-1] < 0.05 and result.raem_deg[-1] < 0.05
