"""Theorem 2's certified delta requirement (fsmctl.proofs.theorem2_bound) against the sampled route."""

import casadi as ca
import numpy as np
import pytest
import sympy as sp

from fsmctl.enclosures.branch_bound import Budget
from fsmctl.model.scenario import paper_scenario
from fsmctl.proofs.theorem2 import Region, _drift_expressions, delta_requirements, fsm_parameters
from fsmctl.proofs.theorem2_bound import LIPSCHITZ_FIXES, certified_delta_requirements, requirement_functions
from fsmctl.proofs.theorem2_search import search_maxima
from fsmctl.symbolic.controller import SingularityFix, surface_term_slope

SMALL = Budget(max_boxes=200_000, max_seconds=4.0)


@pytest.fixture(scope="module")
def paper():
    return paper_scenario("1")


def test_certified_upper_bounds_every_sample(paper):
    """Oracle: the CasADi numeric route (delta_requirements) at many seeded random points never exceeds the certified
    upper bound, and the certified lower bound is below it."""
    region = Region(0.01, 0.01)
    cert = certified_delta_requirements(paper, region, budget=SMALL, refute=False)
    sampled = delta_requirements(paper, region, n_random=2000, seed=3, dt_reference=None, search_scale=False)
    for g in cert.groups:
        for agent in g.agents:
            values = sampled.agents[agent - 1].region
            for a, v in zip(g.axes, values, strict=True):
                assert v <= a.upper and a.lower <= a.upper


def test_paper_scenario_is_refuted_at_a_rigorous_point(paper):
    cert = certified_delta_requirements(paper, Region(), budget=SMALL)
    assert cert.verdict == "refuted"
    assert all(a.lower > a.configured for g in cert.groups for a in g.axes)
    p = cert.reaching
    assert p is not None
    # independent float check of s^T s_dot at the point (the full law, configured delta, no coordination)
    inputs, exprs = _drift_expressions(paper.controller.error_model, True)
    fn = ca.Function("r", list(inputs), [ca.dot(exprs["s"], exprs["d"]), exprs["s"], exprs["d"]])
    x = np.asarray(p.point)
    agent = paper.agents[p.agent - 1]
    v, s, s_dot = fn(
        x[0:3], x[3:6], x[6:9], x[9:12], agent.J0_array, agent.J_true, fsm_parameters(paper)[p.agent - 1], x[12:15]
    )
    assert float(v) > 0 and float(s[p.axis - 1] * s_dot[p.axis - 1]) > 0
    assert np.all(np.abs(x[0:3]) <= 0.05) and np.all(np.abs(x[3:6]) <= 0.05)


def test_raised_delta_on_a_small_region_is_proved(paper):
    """Region |sigma_e,k| <= 5e-5 (inside the Remark 6 band, epsilon = 1e-4), |omega_e,k| <= 1e-3: the requirement
    there is ~0.003 (the certified lower bounds are 0.002-0.003); 2000 boxes per axis (the budget's box count binds,
    not its time: deterministic) bring the certified upper bounds to ~0.04, so delta = 0.2 is proved with a margin
    of ~5x.  Oracle: the sampled requirement (delta_requirements) stays below every certified upper bound."""
    raised = paper.replace(controller={"delta": [0.2, 0.2, 0.2]})
    region = Region(5e-5, 1e-3)
    cert = certified_delta_requirements(raised, region, budget=Budget(max_boxes=36_000, max_seconds=300.0))
    assert cert.verdict == "proved", [(a.lower, a.upper) for g in cert.groups for a in g.axes]
    assert cert.reaching is None and "V = s^T s/2 decreases" in cert.reaching_note
    sampled = delta_requirements(raised, region, n_random=300, seed=5, dt_reference=None, search_scale=False)
    for g in cert.groups:
        for agent in g.agents:
            assert all(v <= a.upper for a, v in zip(g.axes, sampled.agents[agent - 1].region, strict=True))


def test_a_larger_region_never_gives_a_smaller_bound(paper):
    """Soundness across regions: the larger box contains the smaller one's witness, so its certified upper bound is
    at least the smaller box's certified lower bound (upper_large >= sup_large >= sup_small >= lower_small)."""
    small = certified_delta_requirements(paper, Region(2e-4, 2e-4), budget=SMALL, refute=False)
    large = certified_delta_requirements(paper, Region(1e-3, 1e-3), budget=SMALL, refute=False)
    for gs, gl in zip(small.groups, large.groups, strict=True):
        for a, b in zip(gs.axes, gl.axes, strict=True):
            assert b.upper >= a.lower


def test_box_enclosures_contain_float_samples(paper):
    """The enclosure of a box by the search (natural extension, mean-value forms about the centre and about the faces
    at the Remark 6 band, with the drift taken as Lipschitz) bounds the float value of |d| (CasADi, independent of the
    interval evaluator) at seeded points of the box: boxes astride |sigma_e,k| = epsilon and near the band's centre.
    With max_boxes at the number of start boxes the search returns the start box's enclosure (or a witness value)."""
    agent = paper.agents[0]
    params = fsm_parameters(paper)[0]
    f, jac = requirement_functions(paper.controller.error_model, agent.J0_array, agent.J_true, params)
    inputs, exprs = _drift_expressions(paper.controller.error_model, False)
    se, we, wd, ud, J0, J, p, wdd = inputs
    d = ca.Function("d", [ca.vertcat(se, we, wd, ud, wdd), J0, J, p], [ca.fabs(exprs["d"])])
    rng = np.random.default_rng(11)
    eps = 1e-4
    full = np.array([0.05] * 6 + [0.1] * 3 + [0.2, 0.24, 0.22, 0.0025, 0.002, 0.00167])
    for trial in range(24):
        centre = rng.uniform(-1, 1, 15) * full * 0.8
        scale = rng.uniform(0.97, 1.03, 3) if trial % 2 else rng.uniform(0.0, 2.5, 3)  # astride epsilon, or anywhere
        centre[:3] = rng.choice([-1, 1], 3) * scale * eps
        half = full * 0.002  # small boxes: the enclosure is within 0.2% of the samples' maximum (a planted 5% is seen)
        half[:3] = rng.uniform(0.01, 0.06, 3) * eps
        lo, hi = centre - half, centre + half
        m = search_maxima(f, jac, lo[:, None], hi[:, None], seconds=30, max_boxes=1, relative_gap=0.0, lipschitz=True,
                          seeds=lo[:, None], epsilon=eps)  # fmt: skip
        x = lo[:, None] + (hi - lo)[:, None] * rng.uniform(0, 1, (15, 400))
        values = np.asarray(d(x, agent.J0_array, agent.J_true, params))
        assert np.all(values.max(axis=1) <= m.upper), (trial, values.max(axis=1), m.upper)


@pytest.mark.parametrize("name", LIPSCHITZ_FIXES)
def test_lipschitz_fixes_have_a_continuous_slope_at_the_band_edge(name):
    """The search's mean-value form across ``|sigma_e,k| = epsilon`` assumes the Remark 6 device's slope (the gain of
    sigma_e_dot in s_dot) continuous there: every branch of the trusted device's Piecewise takes the same value at
    ``x = epsilon`` (symbolic alpha and epsilon)."""
    alpha, eps, x = sp.symbols("alpha epsilon x", positive=True)
    slope = surface_term_slope(x, alpha, SingularityFix[name.upper()], eps)
    assert isinstance(slope, sp.Piecewise) and len(slope.args) == 2
    at_edge = [sp.simplify(branch.subs(x, eps)) for branch, _ in slope.args]
    assert sp.simplify(at_edge[0] - at_edge[1]) == 0
