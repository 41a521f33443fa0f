"""Theorem 1 for concrete topologies (Liang et al. 2012, Theorem 1, eqs 25-27): fsmctl.proofs.theorem1."""

from __future__ import annotations

import itertools
import math
from fractions import Fraction

import numpy as np
import oracle_numpy as oracle
import pytest

from fsmctl import paper_scenario
from fsmctl.model.topology import Link, Schedule, Topology, all_to_all
from fsmctl.proofs.theorem1 import analyze_topology, configurations, eta_interval


def _exact_k_j(topology: Topology, t: float) -> np.ndarray:
    """K_j(t) from each link's schedule data by the left-closed rule, in exact arithmetic (independent of
    ``Topology.k_j_matrix``; used only at segment midpoints, away from any switch)."""
    K = np.zeros((topology.n_agents, topology.n_agents))
    for link in topology.links:
        s = link.k_j
        tau = Fraction(t) + Fraction(link.phase)
        if s.period is not None:
            tau %= Fraction(s.period)
        value = s.values[0]
        for b, v in zip(s.breakpoints, s.values, strict=True):
            if Fraction(b) <= tau:
                value = v
        K[link.receiver, link.sender] = value
    return K


def _table2_k_j(t: float) -> np.ndarray:
    """Table 2 (Case 1): k^j_ij(t) = 5 if mod(t + phi_ij, 8) <= 6.5 else 0, exact (the NumPy oracle)."""
    return np.array([[oracle.k_j_exact(i, j, t) for j in range(1, 7)] for i in range(1, 7)])


def _table2_segments() -> list[tuple[Fraction, Fraction, np.ndarray]]:
    """The segments of one 8 s period between Table 2's exact switching instants, with K_j on each."""
    phases = [Fraction(repr(float(p))) for p in oracle.paper_scenario()["phases"].ravel() if np.isfinite(p)]
    cuts = {Fraction(0), Fraction(8)} | {(b - p) % 8 for p in phases for b in (Fraction(0), Fraction(13, 2))}
    return [(a, b, _table2_k_j(float((a + b) / 2))) for a, b in itertools.pairwise(sorted(cuts))]


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
    # 30 links, each switching twice per period at its own phase: as many distinct K_j as the oracle's Table 2 has
    assert len(an.configurations) == len({K.tobytes() for _, _, K in _table2_segments()}) == 44
    assert an.holds and an.symmetric_constant and an.printed_strict and an.exact_holds
    assert len(an.pairs) == 15
    for p in an.pairs:
        assert p.interval == pytest.approx(((8 - math.sqrt(39)) / 2, (8 + math.sqrt(39)) / 2))
        assert p.eta == Fraction(4)
    # L = 40 I - K_j(t): Gershgorin gives >= 15, attained when every k^j is on (at t = 0: every phi_ij < 6.5),
    # where sym L = 45 I - 5 ones(6, 6) has eigenvalues 45 and 45 - 30 = 15
    assert an.lambda_min == pytest.approx(15.0)


def test_configurations_cover_every_switch_of_table2():
    """Every segment of Table 2's period (exact switching instants) lies in one configuration with Table 2's K_j
    there, every configuration's K_j is Table 2's on each of its segments (evaluated exactly at the segment's
    midpoint: fsmctl's float switching times may leave slivers of 1 ulp, which must still be right), and the
    segments tile [0, 8)."""
    sc = paper_scenario("1")
    confs, _ = configurations(sc.topology, sc.simulation.t_final)
    for a, b, K in _table2_segments():
        mid = float((a + b) / 2)
        holding = [c for c in confs if any(lo <= mid < hi for lo, hi in c.segments)]
        assert len(holding) == 1 and np.array_equal(holding[0].k_j, K), (a, b)
    for c in confs:
        for lo, hi in c.segments:
            assert np.array_equal(c.k_j, _table2_k_j(0.5 * (lo + hi))), (lo, hi)
    assert sum(hi - lo for c in confs for lo, hi in c.segments) == pytest.approx(8.0, abs=1e-12)


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
    """Random Monte Carlo topologies (period 8, random phases and weights): every segment between the exact
    switching instants (from the links' data) lies in one configuration with the exactly evaluated K_j there, and
    min_t lambda_min(sym L(t)) (eqs 25-27) is the minimum over those matrices, computed here one at a time."""
    from fsmctl.studies.montecarlo import CampaignSettings, sampling

    sc = paper_scenario("1")
    for seed in range(3):
        topo = sampling._random_topology(np.random.default_rng(seed), sc.topology, CampaignSettings())
        assert {link.k_j.period for link in topo.links} == {8.0}
        confs, _ = configurations(topo, sc.simulation.t_final)
        cuts = sorted({Fraction(0), Fraction(8)} | {(Fraction(b) - Fraction(link.phase)) % 8
                                                     for link in topo.links for b in link.k_j.breakpoints})  # fmt: skip
        Ki = np.zeros((6, 6))
        for link in topo.links:
            Ki[link.receiver, link.sender] = link.k_i
        lam = []
        for a, b in itertools.pairwise(cuts):
            mid = float((a + b) / 2)
            K = _exact_k_j(topo, mid)
            holding = [c for c in confs if any(lo <= mid < hi for lo, hi in c.segments)]
            assert len(holding) == 1 and np.array_equal(holding[0].k_j, K), (seed, mid)
            L = np.diag(Ki.sum(axis=1)) - K
            lam.append(float(np.linalg.eigvalsh(0.5 * (L + L.T))[0]))
        an = analyze_topology(topo, sc.simulation.t_final)
        assert an.lambda_min == pytest.approx(min(lam), rel=1e-12, abs=1e-12)
        L = np.diag(Ki.sum(axis=1)) - _exact_k_j(topo, an.lambda_min_time)
        assert float(np.linalg.eigvalsh(0.5 * (L + L.T))[0]) == pytest.approx(min(lam), rel=1e-12, abs=1e-12)


def test_verdicts_without_the_explanations_are_the_full_analysis_verdicts():
    """``explain=False`` (a Monte Carlo record, a tuning constraint) gives every verdict and ``lambda_min`` of the
    full analysis, bit for bit, and no pairs or failure lines, on topologies where each condition holds or fails:
    the paper's cases, violations, a directed cycle (balanced only), time-varying symmetric eta, random Monte
    Carlo topologies (some with links dropped or weights above k^i)."""
    from fsmctl.studies.montecarlo import CampaignSettings, sampling

    cases = [(paper_scenario(c).topology, 100.0) for c in ("1", "2")]
    cases.append((all_to_all(3, 2.0, Schedule((0.0, 4.0), (5.0, 0.0), 8.0)), 100.0))
    cases.append((Topology(3, tuple(Link(i, (i + 1) % 3, 8.0, Schedule.constant(5.0)) for i in range(3))), 10.0))
    on_first, on_second = Schedule((0.0, 4.0), (8.0, 0.0), 8.0), Schedule((0.0, 4.0), (0.0, 2.9), 8.0)
    cases.append((Topology(2, (Link(0, 1, 10.0, on_first), Link(1, 0, 3.0, on_second))), 10.0))
    base = paper_scenario("1").topology
    for seed in range(12):
        settings = CampaignSettings(link_dropout=0.3 * (seed % 2), coupling_high=1.0 + 0.5 * (seed % 3))
        cases.append((sampling._random_topology(np.random.default_rng(seed), base, settings), 100.0))
    seen = set()
    for topology, t_final in cases:
        full = analyze_topology(topology, t_final)
        quick = analyze_topology(topology, t_final, explain=False)
        for name in ("symmetric_constant", "symmetric_time_varying", "balanced_constant", "balanced_time_varying",
                     "printed_strict", "lambda_min", "lambda_min_time", "holds"):  # fmt: skip
            assert getattr(quick, name) == getattr(full, name), name
        assert quick.pairs == () and quick.failures == ()
        assert len(quick.configurations) == len(full.configurations)
        seen.add((full.symmetric_constant, full.balanced_constant, full.holds))
    assert {(True, True, True), (False, True, True), (False, False, True), (False, False, False)} <= seen
