"""``SimulationResult.to_time_response()``: the states, the error signals and the metrics as python-control outputs.

Oracle: the NumPy transcription ``tests/oracle_numpy.py`` recomputes, from the *absolute* attitudes (the
states sigma_i and the reference sigma_d, not the engine's sigma_e), the attitude error sigma_ei through
direction-cosine matrices, its principal angle theta_ei from the DCM trace, AAEM (eq 42) and RAEM (eq 43)
from the pairwise relative angles theta_ij of DCM(sigma_i) DCM(sigma_j)^T.
"""

from __future__ import annotations

import control as ct
import numpy as np
import oracle_numpy as oracle
import pytest

import fsmctl
from fsmctl.model.topology import ring


@pytest.fixture(scope="module")
def run():
    s = fsmctl.paper_scenario("1").replace(simulation={"t_final": 2.0, "output_interval": 0.1})
    return fsmctl.simulate(s)


@pytest.fixture(scope="module")
def three():
    base = fsmctl.paper_scenario("2")
    s = base.replace(agents=base.agents[:3], topology=ring(3, 8.0, 5.0))
    return fsmctl.simulate(s.replace(simulation={"t_final": 1.0, "output_interval": 0.25}))


def _signal(tr, label: str) -> np.ndarray:
    return tr.outputs[list(tr.output_labels).index(label)]


def test_labels_follow_the_plugin_scheme(three):
    n = 3
    tr = three.to_time_response()
    labels = list(tr.output_labels)
    plugin = [f"sc{i}_{v}[{k}]" for i in range(1, n + 1) for v in ("sigma", "omega", "tau") for k in range(3)]
    assert labels[: 9 * n] == plugin
    assert labels[9 * n :] == (
        [f"sc{i}_sigma_e[{k}]" for i in range(1, n + 1) for k in range(3)]
        + [f"sc{i}_theta_e_deg" for i in range(1, n + 1)]
        + ["aaem_deg", "raem_deg"]
    )
    assert tr.outputs.shape == (13 * n + 2, three.time.size)
    assert tr.ninputs == 0 and tr.nstates == 4 + 7 * n
    assert isinstance(tr, ct.TimeResponseData)
    plain = three.to_time_response(errors=False)
    assert list(plain.output_labels) == plugin
    assert np.array_equal(plain.outputs, tr.outputs[: 9 * n])
    assert np.array_equal(plain.states, tr.states) and np.array_equal(plain.time, three.time)


def test_response_class_is_the_model_layers_when_it_exists(three):
    from fsmctl.model import time_response

    cls = getattr(time_response, "FormationResponse", ct.TimeResponseData)
    assert type(three.to_time_response()) is cls


@pytest.mark.parametrize("fixture", ["run", "three"])
def test_errors_and_metrics_match_the_numpy_oracle(fixture, request):
    r = request.getfixturevalue(fixture)
    tr = r.to_time_response()
    n, T = r.n_agents, r.time.size
    for k in range(T):
        theta = np.empty(n)
        for i in range(n):
            sigma_e = oracle.mrp_error(r.sigma[k, i], r.sigma_d[k])  # DCM route, |sigma_e| <= 1
            got = np.array([_signal(tr, f"sc{i + 1}_sigma_e[{c}]")[k] for c in range(3)])
            assert np.allclose(got, sigma_e, rtol=0, atol=1e-12), (k, i)
            theta[i] = oracle.principal_angle(sigma_e)
            assert abs(_signal(tr, f"sc{i + 1}_theta_e_deg")[k] - np.degrees(theta[i])) < 1e-6, (k, i)
        assert abs(_signal(tr, "aaem_deg")[k] - oracle.aaem_deg(theta)) < 1e-6, k
        pairs = oracle.relative_angle_matrix(list(r.sigma[k]))  # from the absolute attitudes
        assert abs(_signal(tr, "raem_deg")[k] - oracle.raem_deg(pairs)) < 1e-6, k
    # the metrics move: a constant or zero signal would pass the comparisons above only by accident
    aaem = _signal(tr, "aaem_deg")
    assert aaem.max() - aaem.min() > 1.0 and _signal(tr, "raem_deg").min() > 1.0


def test_outputs_are_the_runs_own_arrays(run):
    tr = run.to_time_response()
    n = run.n_agents
    y = tr.outputs
    assert np.array_equal(y[: 9 * n].reshape(n, 3, 3, -1)[:, 2], run.u.transpose(1, 2, 0))
    assert np.array_equal(y[9 * n : 12 * n].reshape(n, 3, -1), run.sigma_e.transpose(1, 2, 0))
    assert np.array_equal(_signal(tr, "raem_deg"), run.raem_deg)
    assert np.array_equal(_signal(tr, "sc4_theta_e_deg"), np.degrees(run.theta_e[:, 3]))
