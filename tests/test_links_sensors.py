"""Delayed and lossy links, and sensors, as flown by the compiled loop.

The link probe law (``tests/data/laws/echo_time.py``) broadcasts its clock and commands what it received, so the
recorded command of every control instant shows which broadcast each link delivered: a delay of ``d`` instants
delivers exactly ``t_q - d T``, a lost packet leaves the previous value.  The sensors are checked against their
definitions on the flown path: what the law saw minus the truth is exactly the drawn noise, its covariance and
Allan deviation are the configured ones, and the metrics see the truth.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from formations import single_spacecraft
from oracle_numpy import mrp_to_dcm as dcm  # [BN] through Euler parameters (an independent route)

import fsmctl
from fsmctl.model.problem import delay_instants, pack
from fsmctl.model.scenario import ScenarioError

ECHO = str(Path(__file__).parent / "data" / "laws" / "echo_time.py")
GAIN = 1e-6  # the probe's torque per second of received clock (its default)


def probe(t_final=20.0, period=0.1, **links):
    """Two spacecraft, each receiving the other with k^j = 1, flying the clock probe."""
    return single_spacecraft(
        law=ECHO,
        n_agents=2,
        topology={"kind": "all-to-all", "k_i": 1.0, "schedule": 1.0},
        t_final=t_final,
        dt=0.01,
        control_period=period,
        links=links or None,
    )


def delivered(result) -> np.ndarray:
    """(Q, 2) clock value each agent received at each control instant (outputs are at the instants)."""
    return result.u_unsaturated[:, :, 0] / GAIN


def test_ideal_links_deliver_the_current_broadcast():
    r = fsmctl.simulate(probe())
    np.testing.assert_allclose(delivered(r), np.stack([r.time, r.time], axis=1), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(r.u_unsaturated[:, :, 1] / GAIN, 1.0)  # k_received_sum


@pytest.mark.parametrize(("delay", "instants"), [(0.1, 1), (0.25, 3), (0.3, 3), (1.0, 10), (0.05, 1)])
def test_a_delayed_link_delivers_exactly_the_delayed_value(delay, instants):
    """At t_q the receiver holds the broadcast of the latest instant at or before t_q - delay (constant initial
    history before t = 0): instant q - ceil(delay / T)."""
    assert delay_instants(np.array([delay]), 0.1)[0] == instants
    r = fsmctl.simulate(probe(delay=delay))
    expected = np.maximum(r.time - instants * 0.1, 0.0)
    np.testing.assert_allclose(delivered(r), np.stack([expected, expected], axis=1), rtol=1e-12, atol=1e-12)


def test_per_link_delays_from_the_table():
    r = fsmctl.simulate(probe(delay_table=[[math.nan, 0.2], [0.5, math.nan]]))
    np.testing.assert_allclose(delivered(r)[:, 0], np.maximum(r.time - 0.2, 0), atol=1e-12)
    np.testing.assert_allclose(delivered(r)[:, 1], np.maximum(r.time - 0.5, 0), atol=1e-12)


def test_loss_probability_is_measured_and_a_lost_packet_holds_the_last_value():
    """p = 0.2 over 2 links x 4001 instants: the empirical loss rate is within 5 binomial standard deviations
    (sqrt(p (1 - p) / 8002) = 0.0045); after a loss the receiver keeps the previous delivered value."""
    p = 0.2
    r = fsmctl.simulate(probe(t_final=400.0, loss_probability=p))
    got = delivered(r)
    t = r.time
    lost = ~np.isclose(got, t[:, None], rtol=0, atol=1e-9)
    lost[0] = False  # instant 0 delivers the initial value either way
    rate = lost[1:].mean()
    assert abs(rate - p) < 5 * math.sqrt(p * (1 - p) / lost[1:].size), rate
    held = got[1:][lost[1:]]
    previous = got[:-1][lost[1:]]
    np.testing.assert_array_equal(held, previous)
    # the losses are the ones drawn for the run: pack() holds them
    mask = pack(probe(t_final=400.0, loss_probability=p)).hardware.link_lost.astype(bool)
    np.testing.assert_array_equal(lost[1:].sum(), mask[1:].sum())


def test_loss_one_never_delivers_after_the_initial_value():
    r = fsmctl.simulate(probe(t_final=2.0, loss_probability=1.0))
    np.testing.assert_array_equal(delivered(r), 0.0)


def test_seeds_reproduce_and_differ():
    a = fsmctl.simulate(probe(t_final=50.0, loss_probability=0.3))
    b = fsmctl.simulate(probe(t_final=50.0, loss_probability=0.3))
    np.testing.assert_array_equal(a.u_unsaturated, b.u_unsaturated)
    c = fsmctl.simulate(probe(t_final=50.0, loss_probability=0.3).replace(simulation={"seed": 1}))
    assert not np.array_equal(a.u_unsaturated, c.u_unsaturated)


def test_links_and_sensors_need_a_control_period():
    with pytest.raises(ScenarioError, match="control_period > 0"):
        probe().replace(simulation={"control_period": 0.0}, links={"delay": 0.1})


# ----------------------------------------------------------------------------- sensors


def error_rotation(measured: np.ndarray, true: np.ndarray) -> np.ndarray:
    """Small rotation vector of [B~B] = [B~N][BN]^T (body frame), from the DCMs (independent of the MRP code)."""
    R = dcm(measured) @ dcm(true).T
    return 0.5 * np.array([R[1, 2] - R[2, 1], R[2, 0] - R[0, 2], R[0, 1] - R[1, 0]])


def sensed(t_final=200.0, star=None, gyro=None, seed=0, **kw):
    return single_spacecraft(
        t_final=t_final,
        dt=0.1,
        control_period=0.1,
        omega0=(0.0, 0.0, 0.0),
        sensors={**({"star_tracker": star} if star else {}), **({"gyro": gyro} if gyro else {})},
        seed=seed,
        **kw,
    )


def test_the_law_sees_the_star_tracker_and_the_metrics_the_truth():
    """The recorded measurement is the truth rotated by the drawn noise (body frame); its covariance is the
    configured one (2001 samples: the sample variance is within 5 sqrt(2/2001) = 16 % of the truth)."""
    std = np.array([2.424e-5, 2.424e-5, 1.0e-4])  # 5 arcsec about x, y; a worse roll axis
    s = sensed(star={"noise_std": std.tolist()}, law_parameters={"bias": [0.01, -0.02, 0.005]})
    r = fsmctl.simulate(s)
    drawn = pack(s).hardware.sensor_dtheta[:, 0]
    err = np.array([error_rotation(m, t) for m, t in zip(r.sigma_measured[:, 0], r.sigma[:, 0], strict=True)])
    # small-angle form: dtheta/4 as an MRP is a rotation by 4 atan(|dtheta|/4) = |dtheta| (1 - |dtheta|^2/48), and
    # the DCM's antisymmetric part is sin(angle) ~ angle (1 - angle^2/6): relative differences ~|dtheta|^2 ~ 1e-7
    np.testing.assert_allclose(err, drawn, rtol=0, atol=1e-6 * std.max())
    var = err.var(axis=0)
    assert np.all(np.abs(var / std**2 - 1) < 5 * math.sqrt(2 / err.shape[0])), var / std**2
    # the metrics see the truth: the error state is computed from the true attitude
    truth = fsmctl.simulate(s.replace(sensors={"star_tracker": None, "gyro": None}))
    np.testing.assert_array_equal(truth.sigma, r.sigma)  # open loop: the noise does not reach the body
    np.testing.assert_array_equal(truth.sigma_e, r.sigma_e)


def test_gyro_error_on_the_flown_path_has_the_configured_allan_deviation():
    """omega_measured - omega is exactly the drawn gyro error; its Allan deviation is the configured
    sigma_A^2 = N^2/tau + K^2 tau/3 (angle random walk N, rate random walk K).  With 40001 samples (4000 s) the
    overlapping estimate's relative scatter is ~1.5 % at tau = 1-2 s and ~10 % at tau = 20-40 s (about
    T_total / tau independent clusters); the bands are 3-4 of those.  Below the crossover sqrt(3) N / K = 17 s
    N dominates, above it K."""
    N, K = 1e-4, 1e-5
    bias = [1e-4, 0.0, -2e-4]
    s = sensed(t_final=4000.0, gyro={"angle_random_walk": N, "rate_random_walk": K, "bias": bias})
    r = fsmctl.simulate(s)
    err = r.omega_measured[:, 0] - r.omega[:, 0]
    np.testing.assert_array_equal(err, (r.omega[:, 0] + pack(s).hardware.sensor_gyro[:, 0]) - r.omega[:, 0])
    allantools = pytest.importorskip("allantools")
    for axis in range(3):
        taus, adev, _, _ = allantools.oadev(err[:, axis], rate=10.0, data_type="freq", taus=[1.0, 2.0, 20.0, 40.0])
        np.testing.assert_allclose(adev[:2], np.sqrt(N**2 / taus[:2] + K**2 * taus[:2] / 3), rtol=0.06)
        np.testing.assert_allclose(adev[2:], np.sqrt(N**2 / taus[2:] + K**2 * taus[2:] / 3), rtol=0.4)
    np.testing.assert_allclose(err[:, 1].mean(), 0.0, atol=5 * K * math.sqrt(4000.0))  # bias walk spread
    assert abs(err[:, 2].mean() - bias[2]) < 5 * K * math.sqrt(4000.0)


def test_sensor_noise_is_reproducible_and_independent_of_the_links():
    star = {"noise_std": [1e-4, 1e-4, 1e-4]}
    a = pack(sensed(t_final=10.0, star=star)).hardware.sensor_dtheta
    b = pack(sensed(t_final=10.0, star=star)).hardware.sensor_dtheta
    np.testing.assert_array_equal(a, b)
    c = pack(sensed(t_final=10.0, star=star, seed=3)).hardware.sensor_dtheta
    assert not np.array_equal(a, c)


def test_noise_tables_are_checked_against_the_memory_before_they_are_drawn():
    from fsmctl.errors import ResourceLimitError
    from fsmctl.simulation.simulator import check_noise_memory

    s = sensed(t_final=10.0, star={"noise_std": [1e-4, 1e-4, 1e-4]})
    needed = check_noise_memory(s, available=10**12)
    assert needed > 101 * 2 * 8 * 3  # 101 instants of dtheta and gyro_error for one agent
    with pytest.raises(ResourceLimitError, match="control_period"):
        check_noise_memory(s, available=needed - 1)
    assert check_noise_memory(single_spacecraft(), available=0) == 0  # nothing drawn without sensors or links


def test_table_entries_without_a_link_do_not_switch_the_links_on():
    """A delay on the diagonal (no link there) is ignored: no control period needed, the ideal links fly."""
    s = probe(t_final=1.0).replace(simulation={"control_period": 0.0}, links={"delay_table": [[0.5, 0.0], [0.0, 0.5]]})
    assert s.links.enabled and not s.links_active
    assert not pack(s).hardware.links_imperfect


def test_a_delay_longer_than_the_run_holds_the_initial_value():
    """Delays beyond the horizon (even ones whose instant count overflows int32) deliver the instant-0 broadcast."""
    for delay in (50.0, 3e8):
        r = fsmctl.simulate(probe(t_final=2.0, delay=delay))
        np.testing.assert_array_equal(delivered(r), 0.0)
