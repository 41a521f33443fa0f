"""Bursty packet loss: the Gilbert-Elliott model of ``[links]`` (fsmctl.model.noise, LinkSettings, the plug-in's
link), beside the Bernoulli model it must leave unchanged.

Oracles:

* statistics: the model's transition matrix, built here from its definition (Gilbert 1960, Elliott 1963), gives
  the stationary loss rate, the mean burst length and -- through the fundamental matrix of the Markov chain --
  the asymptotic standard error of their empirical estimates over a long record; each check allows 5 of those
  standard errors (the estimates are sums over an ergodic chain, asymptotically normal: a false failure has
  probability ~6e-7 per check), none on a boundary of the parameter space;
* the draws: a plain loop over the Markov chain, fed the uniforms of the documented stream layout;
* Bernoulli: the draws of main before the Gilbert-Elliott model (SHA-256 of the loss arrays), bit for bit.
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from formations import single_spacecraft

import fsmctl
from fsmctl.cli.main import main
from fsmctl.model.noise import STREAMS, gilbert_elliott_statistics, hardware_noise
from fsmctl.model.problem import pack, pack_hardware
from fsmctl.model.scenario import ScenarioError
from fsmctl.plugin.hardware import link

KEYS = ("good_to_bad", "bad_to_good", "loss_good", "loss_bad")
# (p, r, loss_good, loss_bad): Gilbert's channel, two Elliott channels (p + r < 1: positively correlated losses)
# and one with p + r > 1 (consecutive states anti-correlated)
CHANNELS = [(0.02, 0.2, 0.0, 1.0), (0.05, 0.3, 0.01, 0.7), (0.3, 0.6, 0.1, 0.9), (0.7, 0.5, 0.05, 0.8)]


def ge(*channels) -> dict[str, list[float]]:
    """The ``gilbert_elliott`` keyword of hardware_noise for links with these (p, r, loss_good, loss_bad)."""
    return {k: [c[i] for c in channels] for i, k in enumerate(KEYS)}


# ----------------------------------------------------------------------------- the oracle: the Markov chain


def pair_chain(p, r, eg, eb):
    """The chain of ``(state_q, lost_q, state_{q+1}, lost_{q+1})`` (16 states, index ``8 s + 4 l + 2 s' + l'``;
    state 1 = bad): its transition matrix and stationary distribution, from the model's definition."""
    T = np.array([[1 - p, p], [r, 1 - r]])  # state transitions: good -> bad with p, bad -> good with r
    e = np.array([eg, eb])  # loss probability in each state

    def emit(s, lost):
        return e[s] if lost else 1 - e[s]

    single = np.zeros((4, 4))  # (s, l) -> (s', l')
    for s, lost, s2, l2 in np.ndindex(2, 2, 2, 2):
        single[2 * s + lost, 2 * s2 + l2] = T[s, s2] * emit(s2, l2)
    P = np.zeros((16, 16))
    for a, b, c in np.ndindex(4, 4, 4):  # (Y_q, Y_{q+1}) -> (Y_{q+1}, Y_{q+2})
        P[4 * a + b, 4 * b + c] = single[b, c]
    pi_state = np.array([r, p]) / (p + r)
    pi_single = np.array([pi_state[s] * emit(s, lost) for s, lost in np.ndindex(2, 2)])
    pi = (pi_single[:, None] * single).reshape(16)
    np.testing.assert_allclose(pi @ P, pi, atol=1e-15)  # stationary indeed
    return P, pi


def asymptotic_variance(P, pi, f) -> float:
    """``lim Var(sum_q f(X_q)) / M`` of a stationary ergodic chain: ``2 <f~, Z f~>_pi - <f~, f~>_pi`` with
    ``f~ = f - pi f`` and the fundamental matrix ``Z = (I - P + 1 pi)^-1`` (Kemeny & Snell, Finite Markov
    Chains, 1960, Sec. 4.6)."""
    fc = f - pi @ f
    Z = np.linalg.inv(np.eye(P.shape[0]) - P + np.outer(np.ones(P.shape[0]), pi))
    return float(2 * pi @ (fc * (Z @ fc)) - pi @ fc**2)


def oracle(p, r, eg, eb):
    """Loss rate, mean burst length and the functions whose sums estimate them, on the pair chain."""
    P, pi = pair_chain(p, r, eg, eb)
    lost = np.array([(i >> 2) & 1 for i in range(16)], dtype=float)  # l_q
    ends = np.array([((i >> 2) & 1) * (1 - (i & 1)) for i in range(16)], dtype=float)  # l_q (1 - l_{q+1})
    rate, burst_ends = pi @ lost, pi @ ends
    return P, pi, lost, ends, rate, rate / burst_ends


def bursts(lost: np.ndarray) -> tuple[int, int]:
    """(losses, bursts) of a record, a burst counted where a loss is followed by a delivery."""
    return int(lost[:-1].sum()), int(np.sum(lost[:-1] & ~lost[1:]))


# ----------------------------------------------------------------------------- statistics


def test_loss_rate_and_mean_burst_match_the_markov_chain():
    """M = 400000 instants per channel.  The loss rate's estimate is the mean of ``l_q``; the mean burst's is
    ``sum l_q / sum l_q (1 - l_{q+1})``, whose error is, to first order (delta method),
    ``sum (l_q - B l_q (1 - l_{q+1})) / (M beta)`` with ``beta`` the probability of a burst end: both standard
    errors come from the chain's asymptotic variance."""
    M = 400_000
    lost = hardware_noise(21, 1, M + 1, 0.1, gilbert_elliott=ge(*CHANNELS))["lost"].astype(bool)
    for e, channel in enumerate(CHANNELS):
        P, pi, f_lost, f_ends, rate, burst = oracle(*channel)
        n_lost, n_bursts = bursts(lost[:, e])
        se_rate = math.sqrt(asymptotic_variance(P, pi, f_lost) / M)
        assert abs(n_lost / M - rate) < 5 * se_rate, (channel, n_lost / M, rate, se_rate)
        beta = pi @ f_ends
        se_burst = math.sqrt(asymptotic_variance(P, pi, f_lost - burst * f_ends) / M) / beta
        assert abs(n_lost / n_bursts - burst) < 5 * se_burst, (channel, n_lost / n_bursts, burst, se_burst)
        # the documented closed forms are the chain's
        stats = gilbert_elliott_statistics(*channel)
        assert stats["loss_rate"] == pytest.approx(rate, rel=1e-12)
        assert stats["mean_burst"] == pytest.approx(burst, rel=1e-12)


def test_gilbert_channel_bursts_are_geometric_with_mean_one_over_r():
    """Gilbert's channel (loss_good = 0, loss_bad = 1): the bursts are the bad periods, i.i.d. geometric with
    P(length = n) = (1 - r)^(n-1) r: mean 1 / r, variance (1 - r) / r^2; the sample mean of N complete bursts is
    within 5 sqrt((1 - r) / (r^2 N)) of 1 / r, the fraction of length-1 bursts within 5 binomial errors of r.
    The closed forms p / (p + r) and 1 / r are those of the docs."""
    p, r = 0.01, 0.25
    lost = hardware_noise(3, 1, 500_000, 0.1, gilbert_elliott=ge((p, r, 0.0, 1.0)))["lost"][:, 0].astype(np.int8)
    edges = np.flatnonzero(np.diff(lost))
    starts, stops = edges[lost[edges + 1] == 1] + 1, edges[lost[edges + 1] == 0] + 1
    stops = stops[stops > starts[0]][: starts.size]  # complete bursts only (the record's ends cut theirs)
    lengths = stops - starts[: stops.size]
    N = lengths.size
    assert N > 1000
    assert abs(lengths.mean() - 1 / r) < 5 * math.sqrt((1 - r) / (r**2 * N)), lengths.mean()
    assert abs(np.mean(lengths == 1) - r) < 5 * math.sqrt(r * (1 - r) / N)
    assert gilbert_elliott_statistics(p, r) == pytest.approx(
        {"bad_fraction": p / (p + r), "loss_rate": p / (p + r), "loss_after_loss": 1 - r, "mean_burst": 1 / r}
    )


def test_the_chain_starts_in_its_stationary_distribution():
    """20000 links (independent streams), Gilbert's channel with p = 0.1, r = 0.3: the number lost at instant 0
    (and at instant 1) is Binomial(20000, pi_B = 0.25) if the initial state is drawn from the stationary
    distribution: within 5 binomial standard deviations (a chain started in the good state would lose none at
    q = 0 and p = 0.1 at q = 1)."""
    L, pi_b = 20_000, 0.25
    lost = hardware_noise(5, 1, 2, 0.1, gilbert_elliott=ge(*[(0.1, 0.3, 0.0, 1.0)] * L))["lost"]
    for q in (0, 1):
        assert abs(lost[q].mean() - pi_b) < 5 * math.sqrt(pi_b * (1 - pi_b) / L), (q, lost[q].mean())


# ----------------------------------------------------------------------------- the draws: layout, reproducibility


def loop_transcription(seed: int, index: int, Q: int, p, r, eg, eb) -> np.ndarray:
    """The documented draws, one instant at a time: uniforms ``(Q, 2)`` of the link's stream (spawn key
    ``(links, index)``), column 0 moves the state (at q = 0: bad when < p / (p + r)), column 1 decides the loss."""
    u = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(STREAMS["links"], index))).random((Q, 2))
    out = np.zeros(Q, dtype=np.uint8)
    bad = u[0, 0] < p / (p + r)
    for q in range(Q):
        if q > 0:
            bad = (u[q, 0] >= r) if bad else (u[q, 0] < p)
        out[q] = u[q, 1] < (eb if bad else eg)
    return out


@pytest.mark.parametrize("channel", [*CHANNELS, (0.0, 0.4, 0.2, 1.0), (0.3, 0.0, 0.0, 0.6), (1.0, 1.0, 0.0, 1.0)])
def test_draws_are_the_documented_markov_chain(channel):
    """The vectorised recursion against a loop over the chain, on the documented stream (also: absorbing states,
    p = 0 or r = 0, and the alternating chain p = r = 1)."""
    lost = hardware_noise(9, 1, 3000, 0.1, gilbert_elliott=ge(*[(0.5, 0.5, 0.0, 1.0)] * 2, channel))["lost"]
    np.testing.assert_array_equal(lost[:, 2], loop_transcription(9, 2, 3000, *channel))


def test_gilbert_elliott_draws_are_reproducible_and_per_link():
    """Same seed, same draws; another seed, others; a link's draws do not depend on the number of links, and a
    longer run starts with the draws of a shorter one."""
    a = hardware_noise(4, 1, 500, 0.1, gilbert_elliott=ge(*CHANNELS))["lost"]
    np.testing.assert_array_equal(a, hardware_noise(4, 1, 500, 0.1, gilbert_elliott=ge(*CHANNELS))["lost"])
    assert not np.array_equal(a, hardware_noise(5, 1, 500, 0.1, gilbert_elliott=ge(*CHANNELS))["lost"])
    fewer = hardware_noise(4, 1, 500, 0.1, gilbert_elliott=ge(*CHANNELS[:2]))["lost"]
    np.testing.assert_array_equal(fewer, a[:, :2])
    longer = hardware_noise(4, 1, 900, 0.1, gilbert_elliott=ge(*CHANNELS))["lost"]
    np.testing.assert_array_equal(longer[:500], a)


# main's draws (commit 5784432, before the Gilbert-Elliott model): SHA-256 of the loss arrays
GOLDEN_NOISE = {
    0: "b0e63b52524be5679c70bf9a1b2909ca5ac53e5f3c10c1e916803f071d8c38d6",
    1: "f95931164a9f3c41b346bdb05b6941ec8637fbca418181dbb0a0b0db2c25457b",
    12345: "efdb9856533eee8038faa9c52f7e62b6343bc02adb758437eb9900f7b5195150",
}
GOLDEN_HARDWARE = {
    0: "4c194f92609581045bb82f7eb56d340adc1941888a27ddc5ce0e0c7d52f2021e",
    7: "9285a204c83761d47565b75c5001a0af955b9884c96fb9df449ccdb1736bd84f",
}


@pytest.mark.parametrize("seed", sorted(GOLDEN_NOISE))
def test_bernoulli_draws_are_main_s_bit_for_bit(seed):
    lost = hardware_noise(seed, 2, 5000, 0.1, loss_probability=[0.0, 0.05, 0.3, 0.5, 1.0])["lost"]
    assert hashlib.sha256(lost.tobytes()).hexdigest() == GOLDEN_NOISE[seed]


@pytest.mark.parametrize("seed", sorted(GOLDEN_HARDWARE))
def test_the_hardware_scenario_s_losses_are_main_s_bit_for_bit(seed):
    """paper-hardware (Bernoulli, 5 %) as the engine receives it: 61 instants x 30 links."""
    s = fsmctl.load_scenario("paper-hardware").replace(simulation={"seed": seed})
    assert s.links.loss_model == "bernoulli"
    lost = pack_hardware(s, 6000, 100).link_lost
    assert lost.shape == (61, 30)
    assert hashlib.sha256(lost.tobytes()).hexdigest() == GOLDEN_HARDWARE[seed]


# ----------------------------------------------------------------------------- the scenario


def bursty(**links):
    return fsmctl.load_scenario("paper-hardware").replace(
        links={"loss_probability": 0.0, "loss_model": "gilbert_elliott", **links}
    )


def test_scenario_flies_the_gilbert_elliott_losses_per_link():
    """Scalars for every link, tables per link (row receiver, column sender): the engine's losses are the
    model's draws for each link's parameters."""
    s = bursty(good_to_bad=0.05, bad_to_good=0.3)
    links = s.topology.links
    Q = 61
    lost = pack_hardware(s, 6000, 100).link_lost
    expected = hardware_noise(0, 6, Q, 0.1, gilbert_elliott=ge(*[(0.05, 0.3, 0.0, 1.0)] * len(links)))["lost"]
    np.testing.assert_array_equal(lost, expected)
    n = s.n_agents
    table = np.full((n, n), np.nan)
    for k, lk in enumerate(links):
        table[lk.receiver, lk.sender] = 0.01 * (k + 1)
    per_link = bursty(good_to_bad_table=table.tolist(), bad_to_good=0.3, loss_good=0.02, loss_bad=0.9)
    channels = [(0.01 * (k + 1), 0.3, 0.02, 0.9) for k in range(len(links))]
    np.testing.assert_array_equal(
        pack_hardware(per_link, 6000, 100).link_lost,
        hardware_noise(0, 6, Q, 0.1, gilbert_elliott=ge(*channels))["lost"],
    )
    rates = per_link.links.loss_rates([lk.receiver for lk in links], [lk.sender for lk in links])
    np.testing.assert_allclose(rates, [(0.3 * 0.02 + c[0] * 0.9) / (c[0] + 0.3) for c in channels], rtol=1e-14)
    line = next(x for x in per_link.hardware_lines() if "links:" in x)
    assert "loss_model=gilbert_elliott good_to_bad=per link bad_to_good=0.3 loss_good=0.02 loss_bad=0.9" in line


def test_a_lossless_gilbert_elliott_channel_leaves_the_links_ideal():
    """p = 0 (never leaves the good state, where nothing is lost): no loss, so no imperfect link."""
    s = fsmctl.load_scenario("paper-hardware").replace(
        links={
            "delay": 0.0,
            "loss_probability": 0.0,
            "loss_model": "gilbert_elliott",
            "good_to_bad": 0.0,
            "bad_to_good": 0.5,
        }
    )
    assert not s.links_active


@pytest.mark.parametrize(
    ("links", "words"),
    [
        ({"good_to_bad": 0.0, "bad_to_good": 0.0}, "links: good_to_bad + bad_to_good: must be > 0"),
        ({"good_to_bad": 1.5, "bad_to_good": 0.3}, "links.good_to_bad: must be <= 1"),
        ({"good_to_bad": 0.1, "bad_to_good": -0.3}, "links.bad_to_good: must be >= 0"),
        ({"good_to_bad": 0.1, "bad_to_good": 0.3, "loss_bad": 2.0}, "links.loss_bad: must be <= 1"),
        ({"bad_to_good": 0.3}, "links.good_to_bad: loss_model = 'gilbert_elliott' needs good_to_bad"),
        ({"good_to_bad": 0.1}, "links.bad_to_good: loss_model = 'gilbert_elliott' needs bad_to_good"),
        ({"good_to_bad": 0.1, "bad_to_good": 0.3, "loss_probability": 0.1}, "links.loss_probability: a parameter of"),
        ({"loss_model": "gilbert", "good_to_bad": 0.1}, "links.loss_model: must be one of"),
        ({"loss_model": "bernoulli", "good_to_bad": 0.1}, "links.good_to_bad: a parameter of loss_model ="),
        ({"loss_model": "bernoulli", "loss_bad_table": [[0.5] * 6] * 6}, "links.loss_bad_table: a parameter of"),
    ],
)
def test_bad_gilbert_elliott_settings_are_one_line_errors(links, words):
    with pytest.raises(ScenarioError) as info:
        bursty(**links)
    assert words in str(info.value) and "\n" not in str(info.value)


def test_a_table_entry_that_leaves_a_link_without_a_state_is_an_error():
    s = fsmctl.load_scenario("paper-hardware")
    n = s.n_agents
    lk = s.topology.links[3]
    p = np.full((n, n), 0.1)
    r = np.full((n, n), 0.3)
    p[lk.receiver, lk.sender] = r[lk.receiver, lk.sender] = 0.0
    with pytest.raises(ScenarioError, match=rf"links: the link {lk.receiver + 1} <- {lk.sender + 1}: good_to_bad \+"):
        bursty(good_to_bad_table=p.tolist(), bad_to_good_table=r.tolist())
    p[lk.receiver, lk.sender] = 1.2
    with pytest.raises(ScenarioError, match=rf"links.good_to_bad_table\[{lk.receiver + 1}\]\[{lk.sender + 1}\]"):
        bursty(good_to_bad_table=p.tolist(), bad_to_good_table=r.tolist())


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"gilbert_elliott": ge((0.0, 0.0, 0.0, 1.0))}, "good_to_bad + bad_to_good: must be > 0"),
        ({"gilbert_elliott": ge((0.1, 0.2, -0.1, 1.0))}, "loss_good: must be a probability in [0, 1]"),
        ({"gilbert_elliott": {"good_to_bad": [0.1]}}, "gilbert_elliott: expected the keys"),
        ({"gilbert_elliott": ge((0.1, 0.2, 0, 1)), "loss_probability": [0.1]}, "give one loss model, not both"),
    ],
)
def test_hardware_noise_refuses_bad_gilbert_elliott_parameters(kwargs, words):
    with pytest.raises(ValueError) as info:
        hardware_noise(0, 1, 10, 0.1, **kwargs)
    assert words in str(info.value)


# ----------------------------------------------------------------------------- fsmctl simulate, the results file

SCENARIO = """
extends = "paper-hardware"
name = "bursty-links"
description = "paper-hardware with bursty (Gilbert-Elliott) packet loss"

[simulation]
t_final = 1.0

[links]
loss_probability = 0.0          # paper-hardware's Bernoulli loss, off
loss_model = "gilbert_elliott"
good_to_bad = 0.05              # p: mean good period 20 instants
bad_to_good = 0.25              # r: mean burst 4 instants (loss_bad = 1)
"""


def test_simulate_flies_a_gilbert_elliott_scenario_and_the_result_records_it(tmp_path, capsys):
    path = tmp_path / "bursty.toml"
    path.write_text(SCENARIO)
    out = tmp_path / "out"
    rc = main(["simulate", "--scenario", str(path), "--out", str(out), "--no-figures", "--no-progress"])
    stdout, err = capsys.readouterr()
    assert rc == 0, err
    assert "loss_model=gilbert_elliott good_to_bad=0.05 bad_to_good=0.25" in stdout
    (nc,) = Path(out).glob("*.nc")
    again = fsmctl.scenario_from_result(nc)
    assert again.links.loss_model == "gilbert_elliott"
    assert (again.links.good_to_bad, again.links.bad_to_good) == (0.05, 0.25)
    with xr.open_dataset(nc) as ds:
        assert np.isfinite(ds["sigma"].values).all()
    bad = tmp_path / "bad.toml"
    bad.write_text(SCENARIO.replace("bad_to_good = 0.25", "bad_to_good = 1.25"))
    rc = main(["simulate", "--scenario", str(bad), "--out", str(out), "--no-figures", "--no-progress"])
    err = capsys.readouterr().err
    assert rc == 2 and "links.bad_to_good: must be <= 1" in err and len(err.strip().splitlines()) == 1


# ----------------------------------------------------------------------------- python-control's link

ECHO = str(Path(__file__).parent / "data" / "laws" / "echo_time.py")


def test_the_plugin_link_draws_and_delivers_what_the_compiled_loop_does():
    """Two agents broadcasting their clocks (the probe law): the link block's losses are the run's, bit for bit,
    and fed the sender's broadcasts it outputs what the compiled loop delivered."""
    import control as ct

    links = {"delay": 0.1, "loss_model": "gilbert_elliott", "good_to_bad": 0.1, "bad_to_good": 0.3, "loss_good": 0.05}
    s = single_spacecraft(
        law=ECHO,
        n_agents=2,
        topology={"kind": "all-to-all", "k_i": 1.0, "schedule": 1.0},
        t_final=20.0,
        dt=0.01,
        control_period=0.1,
        links=links,
        seed=5,
    )
    r = fsmctl.simulate(s)
    lost = pack(s).hardware.link_lost
    assert 0 < lost.mean() < 1
    for e, lk in enumerate(s.topology.links):
        ln = link(
            0.1,
            0.0,
            0.1,
            horizon=20.0,
            seed=5,
            index=e,
            size=1,
            signal="clock",
            name=f"l{e}",
            **{k: v for k, v in links.items() if k != "delay"},
        )
        np.testing.assert_array_equal(ln.lost, lost[:, e])
        resp = ct.input_output_response(ln, r.time, r.broadcast[:, lk.sender, 0][None, :], np.zeros(ln.nstates))
        np.testing.assert_allclose(resp.outputs, r.u_unsaturated[:, lk.receiver, 0] / 1e-6, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"loss_model": "gilbert_elliott", "good_to_bad": 0.0, "bad_to_good": 0.0}, "good_to_bad + bad_to_good"),
        ({"loss_model": "gilbert_elliott", "good_to_bad": 0.1}, "needs bad_to_good"),
        ({"loss_model": "gilbert_elliott", "good_to_bad": 0.1, "bad_to_good": 2.0}, "bad_to_good: must be <= 1"),
        ({"good_to_bad": 0.1, "bad_to_good": 0.2}, "good_to_bad: a parameter of loss_model = 'gilbert_elliott'"),
        ({"loss_model": "markov"}, "loss_model: must be one of"),
    ],
)
def test_the_plugin_link_refuses_bad_gilbert_elliott_parameters(kwargs, words):
    with pytest.raises(ScenarioError) as info:
        link(0.0, 0.0, 0.1, horizon=1.0, name="ln", **kwargs)
    message = str(info.value)
    assert message.startswith("link 'ln': ") and words in message and "\n" not in message
    with pytest.raises(ScenarioError, match="loss_probability: a parameter of loss_model = 'bernoulli'"):
        link(0.0, 0.2, 0.1, horizon=1.0, loss_model="gilbert_elliott", good_to_bad=0.1, bad_to_good=0.2)
