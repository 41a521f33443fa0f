"""Theorem 1 for concrete topologies (Liang et al. 2012, Theorem 1, eqs 25-27): fsmctl.proofs.theorem1."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest

from fsmctl import paper_scenario
from fsmctl.proofs.theorem1 import analyze_topology, configurations, eta_interval
from fsmctl.topology import Link, Schedule, Topology, all_to_all


def _block_psd(ki: float, kj: float, eta: float) -> bool:
    B = np.array([[ki - eta, -kj / 2], [-kj / 2, eta]])
    return bool(np.linalg.eigvalsh(B)[0] >= -1e-12)


@pytest.mark.parametrize(("ki", "kj"), [(8.0, 5.0), (8.0, 0.0), (5.0, 5.0), (2.0, 0.6), (0.0, 0.0), (1.0, 0.999)])
def test_eta_interval_is_the_psd_set_of_the_pair_block(ki, kj):
    lo, hi = eta_interval(ki, kj)
    assert _block_psd(ki, kj, lo) and _block_psd(ki, kj, hi) and _block_psd(ki, kj, 0.5 * (lo + hi))
    assert lo >= 0 and hi <= ki + 1e-12
    for outside in (lo - 1e-3, hi + 1e-3):
        assert not _block_psd(ki, kj, outside)


def test_eta_interval_empty_iff_ki_below_kj():
    assert eta_interval(2.0, 5.0) is None
    assert eta_interval(0.0, 0.1) is None
    assert eta_interval(5.0, 5.0) == (2.5, 2.5)
    lo, hi = eta_interval(8.0, 5.0)
    assert lo == pytest.approx((8 - math.sqrt(39)) / 2) and hi == pytest.approx((8 + math.sqrt(39)) / 2)


def test_paper_case1_every_configuration_and_certified_eta():
    sc = paper_scenario("1")
    an = analyze_topology(sc.topology, sc.simulation.t_final)
    assert "common period [0, 8)" in an.window
    # 30 links, each switching twice per period at its own phase: many distinct configurations
    assert len(an.configurations) > 10
    assert an.holds and an.symmetric_constant and an.printed_strict and an.exact_holds
    assert len(an.pairs) == 15
    for p in an.pairs:
        assert p.interval == pytest.approx(((8 - math.sqrt(39)) / 2, (8 + math.sqrt(39)) / 2))
        assert p.eta == Fraction(4)
    # L = 40 I - K_j(t): Gershgorin gives >= 15, attained when every k^j is on
    assert an.lambda_min == pytest.approx(15.0)


def test_configurations_cover_every_switch_of_table2():
    sc = paper_scenario("1")
    confs, _ = configurations(sc.topology, sc.simulation.t_final)
    seen = {c.k_j.tobytes() for c in confs}
    for t in np.linspace(0.0, 40.0, 401):
        assert sc.topology.k_j_matrix(t).tobytes() in seen


def test_paper_case2_outside_printed_theorem_but_corrected_condition_holds():
    sc = paper_scenario("2")
    an = analyze_topology(sc.topology, sc.simulation.t_final)
    assert an.holds and an.symmetric_constant
    assert not an.printed_strict  # k^i = 0: no eta with k^i > eta > 0
    assert all(p.interval == (0.0, 0.0) and p.eta == 0 for p in an.pairs)
    assert an.lambda_min == pytest.approx(0.0)


def test_violation_reports_pair_time_reason_and_fix():
    topo = all_to_all(3, 2.0, Schedule((0.0, 4.0), (5.0, 0.0), 8.0))
    an = analyze_topology(topo, 100.0)
    assert not an.holds and not an.exact_holds
    assert len(an.failures) == 3
    f = an.failures[0]
    assert "pair 1-2" in f and "k^i_12 = 2 < max_t k^j_12(t) = 5" in f and "t in [0, 4) s" in f
    assert "raise k^i_12 to >= 5 and k^i_21 to >= 5" in f


def test_single_parameter_fix_is_minimal():
    # 1 <- 2 with k^j = 5, k^i_12 = 8; 2 <- 1 exists with k^i_21 = 0.5 and k^j_21 = 0: intervals disjoint
    links = (Link(0, 1, 8.0, Schedule.constant(5.0)), Link(1, 0, 0.5, Schedule.constant(0.0)))
    an = analyze_topology(Topology(2, links), 10.0)
    assert not an.symmetric_constant and not an.holds
    pair = an.pairs[0]
    lo = (8 - math.sqrt(39)) / 2
    assert f"raise k^i_21 to >= {math.ceil(lo * 1e4) / 1e4:.4f}".rstrip("0") in pair.fixes
    assert any(fix.startswith("lower max_t k^j_12(t) to <=") for fix in pair.fixes)
    value = float(next(x for x in pair.fixes if x.startswith("lower")).split("<= ")[1])
    assert eta_interval(8.0, value)[0] <= 0.5 + 1e-9  # the suggested k^j makes the intervals meet


def test_balanced_eta_covers_a_directed_cycle_that_symmetric_eta_does_not():
    # 1 <- 2, 2 <- 3, 3 <- 1 only: symmetric eta is forced to 0 by the missing reverse links
    links = tuple(Link(i, (i + 1) % 3, 8.0, Schedule.constant(5.0)) for i in range(3))
    an = analyze_topology(Topology(3, links), 10.0)
    assert not an.symmetric_constant and not an.symmetric_time_varying
    assert an.balanced_constant and an.holds  # eta_12 = eta_23 = eta_31 = 4 is balanced
    assert an.lambda_min == pytest.approx(3.0)  # 8 - 5 cos(2 pi k / 3) minimised
    assert an.failures  # the symmetric failure is still explained per pair


def test_time_varying_symmetric_eta_when_no_constant_one_exists():
    on_first = Schedule((0.0, 4.0), (8.0, 0.0), 8.0)
    on_second = Schedule((0.0, 4.0), (0.0, 2.9), 8.0)
    links = (Link(0, 1, 10.0, on_first), Link(1, 0, 3.0, on_second))
    an = analyze_topology(Topology(2, links), 10.0)
    assert not an.symmetric_constant and not an.balanced_constant
    assert an.symmetric_time_varying and an.balanced_time_varying and an.holds


def test_non_periodic_schedules_use_the_horizon():
    sched = Schedule((0.0, 3.0), (5.0, 0.0))  # no period: on until t = 3 then off forever
    topo = Topology(2, (Link(0, 1, 8.0, sched), Link(1, 0, 8.0, Schedule.constant(0.0))))
    confs, window = configurations(topo, 10.0)
    assert "horizon [0, 10]" in window and len(confs) == 2


def test_batched_configurations_and_lambda_min_equal_the_per_segment_computation():
    """K_j at each segment, and min_t lambda_min(sym L(t)) (eqs 25-27), as one matrix at a time would give them."""
    import itertools

    from fsmctl import montecarlo as mc

    sc = paper_scenario("1")
    for seed in range(3):
        topo = mc._random_topology(np.random.default_rng(seed), sc.topology, mc.CampaignSettings())
        confs, _ = configurations(topo, sc.simulation.t_final)
        where = {seg: c for c in confs for seg in c.segments}
        for a, b in itertools.pairwise(np.unique(np.concatenate(([0.0], topo.switching_times(0.0, 8.0), [8.0])))):
            assert np.array_equal(where[(float(a), float(b))].k_j, topo.k_j_matrix(0.5 * (a + b)))
        Ki = topo.k_i_matrix()
        lam = [float(np.linalg.eigvalsh(0.5 * (L + L.T))[0]) for L in (np.diag(Ki.sum(axis=1)) - c.k_j for c in confs)]
        an = analyze_topology(topo, sc.simulation.t_final)
        assert an.lambda_min == min(lam)
        assert an.lambda_min_time == confs[lam.index(min(lam))].t
