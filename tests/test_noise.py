"""The run's random processes (fsmctl.model.noise): layout, reproducibility and the statistics of each model.

Each statistical check compares with the model's theory (not with the implementation), with a tolerance derived
in a comment; the recursions are checked on a tiny case against a loop transcription of the formulas, and the
stream layout against draws made directly from the documented spawn keys.
"""

from __future__ import annotations

import math
import sys
import tracemalloc

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from fsmctl.model.noise import STREAMS, allan_deviation, hardware_noise, noise_bytes, random_walk_coefficients

STD = np.array([2.0e-5, 5.0e-5, 1.0e-4])
GYRO = {"angle_random_walk": 1e-3, "rate_random_walk": 5e-4, "bias": [1e-3, 0.0, -2e-3]}
LOSS = np.array([0.0, 0.3, 1.0, 0.05])


def everything(seed=0, n_agents=3, n_samples=200, period=0.1, **overrides):
    kw = {"star_tracker_std": STD, "gyro": GYRO, "loss_probability": LOSS, **overrides}
    return hardware_noise(seed, n_agents, n_samples, period, **kw)


def rng_of(seed: int, stream: str, index: int) -> np.random.Generator:
    """The generator the module docstring documents for one agent or link: spawn key (stream, index)."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(STREAMS[stream], index)))


# ----------------------------------------------------------------------------- shapes, layout, reproducibility


def test_shapes_dtypes_and_contiguity():
    out = everything(n_agents=3, n_samples=17)
    assert set(out) == {"dtheta", "gyro_error", "lost"}
    for key, shape, dtype in (("dtheta", (17, 3, 3), np.float64), ("gyro_error", (17, 3, 3), np.float64)):
        assert out[key].shape == shape and out[key].dtype == dtype and out[key].flags.c_contiguous, key
    assert out["lost"].shape == (17, 4) and out["lost"].dtype == np.uint8 and out["lost"].flags.c_contiguous
    assert set(np.unique(out["lost"]).tolist()) <= {0, 1}


def test_disabled_processes_are_zeros_of_the_right_shape():
    out = hardware_noise(0, 2, 9, 0.1)
    np.testing.assert_array_equal(out["dtheta"], np.zeros((9, 2, 3)))
    np.testing.assert_array_equal(out["gyro_error"], np.zeros((9, 2, 3)))
    assert out["lost"].shape == (9, 0) and out["lost"].dtype == np.uint8
    assert hardware_noise(0, 2, 9, 0.1, loss_probability=[])["lost"].shape == (9, 0)
    only_star = hardware_noise(0, 2, 9, 0.1, star_tracker_std=STD)
    assert np.all(only_star["dtheta"] != 0) and not only_star["gyro_error"].any()
    # zero noise densities and bias: the gyro reads the truth
    assert not hardware_noise(0, 2, 9, 0.1, gyro={})["gyro_error"].any()


def test_same_seed_same_arrays_and_different_seeds_differ():
    a, b, c = everything(seed=5), everything(seed=5), everything(seed=6)
    for key in a:
        np.testing.assert_array_equal(a[key], b[key])
    assert not np.array_equal(a["dtheta"], c["dtheta"])
    assert not np.array_equal(a["gyro_error"], c["gyro_error"])
    assert not np.array_equal(a["lost"], c["lost"])


def test_the_documented_layout():
    """Each agent's (link's) stream is drawn by its own generator, seeded by the documented spawn key, in the
    documented order: star tracker N(0, 1) (Q, 3) scaled by the std; loss: uniform (Q,) < p."""
    seed, Q = 11, 40
    out = everything(seed=seed, n_samples=Q)
    for i in range(3):
        np.testing.assert_array_equal(
            out["dtheta"][:, i], rng_of(seed, "star_tracker", i).standard_normal((Q, 3)) * STD
        )
    for e, p in enumerate(LOSS):
        np.testing.assert_array_equal(out["lost"][:, e], rng_of(seed, "links", e).random(Q) < p)
    # the spawn keys are what SeedSequence(seed).spawn(3)[s].spawn(n)[i] gives (the brief's construction)
    child = np.random.SeedSequence(seed).spawn(3)[STREAMS["gyro"]].spawn(5)[2]
    assert child.spawn_key == (STREAMS["gyro"], 2)


def test_streams_are_independent_of_the_other_processes():
    """Enabling or disabling one process leaves the other processes' arrays bit-identical."""
    full = everything(seed=2)
    star_only = hardware_noise(2, 3, 200, 0.1, star_tracker_std=STD)
    gyro_only = hardware_noise(2, 3, 200, 0.1, gyro=GYRO)
    loss_only = hardware_noise(2, 3, 200, 0.1, loss_probability=LOSS)
    np.testing.assert_array_equal(full["dtheta"], star_only["dtheta"])
    np.testing.assert_array_equal(full["gyro_error"], gyro_only["gyro_error"])
    np.testing.assert_array_equal(full["lost"], loss_only["lost"])


def test_an_agents_and_a_links_stream_do_not_depend_on_how_many_there_are():
    small = everything(seed=4, n_agents=2, loss_probability=LOSS[:2])
    large = everything(seed=4, n_agents=7, loss_probability=LOSS)
    np.testing.assert_array_equal(small["dtheta"], large["dtheta"][:, :2])
    np.testing.assert_array_equal(small["gyro_error"], large["gyro_error"][:, :2])
    np.testing.assert_array_equal(small["lost"], large["lost"][:, :2])


def test_a_longer_run_starts_with_the_noise_of_a_shorter_one():
    short, long = everything(seed=8, n_samples=50), everything(seed=8, n_samples=123)
    for key in short:
        np.testing.assert_array_equal(short[key], long[key][:50])


def test_the_parameters_scale_the_same_draws():
    a = hardware_noise(1, 2, 30, 0.1, star_tracker_std=STD)["dtheta"]
    b = hardware_noise(1, 2, 30, 0.1, star_tracker_std=2 * STD)["dtheta"]
    np.testing.assert_array_equal(b, 2 * a)  # exact: scaling by 2 is exact in binary floating point
    # the bias is added to the same random error
    no_bias = hardware_noise(1, 2, 30, 0.1, gyro={**GYRO, "bias": [0.0, 0.0, 0.0]})["gyro_error"]
    biased = hardware_noise(1, 2, 30, 0.1, gyro=GYRO)["gyro_error"]
    np.testing.assert_allclose(biased - no_bias, np.broadcast_to(GYRO["bias"], no_bias.shape), rtol=0, atol=1e-15)
    # for one link a larger probability loses a superset of the packets (one uniform draw per instant)
    lo = hardware_noise(1, 1, 500, 0.1, loss_probability=[0.2])["lost"]
    hi = hardware_noise(1, 1, 500, 0.1, loss_probability=[0.6])["lost"]
    assert np.all(hi >= lo) and hi.sum() > lo.sum()


# ----------------------------------------------------------------------------- star tracker


def test_star_tracker_covariance_is_diagonal_with_the_configured_variances():
    """M = 40000 instants x 2 agents. The mean is known (0), so sum(d_k^2) / std_k^2 is chi-square with M degrees
    of freedom: it must lie between the 1e-7 and 1 - 1e-7 quantiles (a false alarm once in 10^6 seeds; a std off
    by 2 % already falls outside, since the chi-square's relative spread is sqrt(2 / M) = 0.7 %).  The normalised
    cross products sum(d_j d_k) / (std_j std_k) have mean 0 and variance M (CLT): within 5.3 sqrt(M)."""
    M = 40_000
    d = hardware_noise(3, 2, M, 0.1, star_tracker_std=STD)["dtheta"]
    lo, hi = stats.chi2.ppf(1e-7, M), stats.chi2.isf(1e-7, M)
    for i in range(2):
        z = d[:, i] / STD
        scatter = z.T @ z
        assert np.all((lo < np.diag(scatter)) & (np.diag(scatter) < hi)), np.diag(scatter) / M
        off = scatter[np.triu_indices(3, 1)]
        assert np.all(np.abs(off) < 5.3 * math.sqrt(M)), off / M
    # the two agents' streams are uncorrelated too
    cross = (d[:, 0] / STD).T @ (d[:, 1] / STD)
    assert np.all(np.abs(cross) < 5.3 * math.sqrt(M)), cross / M


# ----------------------------------------------------------------------------- rate gyro


def farrenkopf_loop(w: np.ndarray, N: float, K: float, b0, T: float) -> np.ndarray:
    """Direct transcription of Crassidis & Junkins (2nd ed., Sec. 7.2.1) for one agent: w[q, 0] = N_u, w[q, 1] = N_v."""
    Q = w.shape[0]
    beta = [np.zeros(3)]
    for q in range(Q):
        beta.append(beta[q] + K * math.sqrt(T) * w[q, 0])
    return np.array(
        [b0 + 0.5 * (beta[q + 1] + beta[q]) + math.sqrt(N**2 / T + K**2 * T / 12) * w[q, 1] for q in range(Q)]
    )


def test_gyro_tiny_case_against_the_recursion():
    """Three instants, two agents: the vectorised error equals the recursion on the documented draws."""
    seed, Q, T = 21, 3, 0.25
    N, K, b0 = GYRO["angle_random_walk"], GYRO["rate_random_walk"], np.array(GYRO["bias"])
    got = hardware_noise(seed, 2, Q, T, gyro=GYRO)["gyro_error"]
    for i in range(2):
        w = rng_of(seed, "gyro", i).standard_normal((Q, 2, 3))
        np.testing.assert_allclose(got[:, i], farrenkopf_loop(w, N, K, b0, T), rtol=1e-13, atol=1e-19)
    # and by hand for the first instant: beta_1 = K sqrt(T) N_u0, error_0 = b0 + beta_1 / 2 + s N_v0
    w = rng_of(seed, "gyro", 0).standard_normal((Q, 2, 3))
    s = math.sqrt(N**2 / T + K**2 * T / 12)
    np.testing.assert_allclose(got[0, 0], b0 + 0.5 * K * math.sqrt(T) * w[0, 0] + s * w[0, 1], rtol=1e-13)


def test_gyro_white_part_has_std_n_over_sqrt_t():
    """K = 0, b0 = 0: the error is white with variance N^2 / T; M = 3 x 50000 independent samples, known mean 0:
    the sum of squares over the variance is chi-square(M), checked at the 1e-7 quantiles (relative spread
    sqrt(2/M) = 0.37 %, so an error of 2 % in the variance would be caught)."""
    N, T, Q = 2e-3, 0.05, 50_000
    e = hardware_noise(9, 1, Q, T, gyro={"angle_random_walk": N})["gyro_error"][:, 0].ravel()
    M = e.size
    ss = float(e @ e) / (N**2 / T)
    assert stats.chi2.ppf(1e-7, M) < ss < stats.chi2.isf(1e-7, M), ss / M
    lag1 = float(e[3:] @ e[:-3]) / (N**2 / T)  # white: successive samples (same axis, 3 apart) uncorrelated
    assert abs(lag1) < 5.3 * math.sqrt(M), lag1 / M


def test_gyro_bias_is_the_mean():
    """K = 0: the error is b0 plus white noise of std N / sqrt(T); its mean over M = 20000 instants is within
    5 standard errors 5 N / sqrt(T M) of b0 (a missing or mis-scaled bias is 1e-3 rad/s away: > 100 errors)."""
    N, T, M = 1e-3, 0.1, 20_000
    b0 = np.array([1e-3, 0.0, -2e-3])
    e = hardware_noise(4, 1, M, T, gyro={"angle_random_walk": N, "bias": b0})["gyro_error"][:, 0]
    np.testing.assert_allclose(e.mean(axis=0), b0, rtol=0, atol=5 * N / math.sqrt(T * M))


def test_gyro_allan_variance_at_one_period_includes_the_bridge_term():
    """N = 0: sigma_A^2(T) = K^2 T / 3 exactly for the sampled model (the K^2 T / 12 white term is what makes it
    so; without it the value is K^2 T / 4, 25 % lower).  Estimated by hand, 0.5 mean(diff(y)^2) over M = 3 x
    200000 differences: the differences are Gaussian with lag-1 correlation 1/4 and none beyond, so their squares
    have lag-1 correlation 1/16 and the estimate's relative std is sqrt(2 (1 + 2/16) / M) = 0.19 %; 1 % is > 5 of it."""
    K, T, Q = 5e-4, 0.1, 200_001
    e = hardware_noise(12, 1, Q, T, gyro={"rate_random_walk": K})["gyro_error"][:, 0]
    avar = 0.5 * np.mean(np.diff(e, axis=0) ** 2)
    assert abs(avar / (K**2 * T / 3) - 1) < 0.01, avar / (K**2 * T / 3)


def test_gyro_allan_deviation_recovers_n_and_k():
    """Q = 200000 instants at T = 0.1 s, N = 1e-3, K = 5e-4 (the two terms cross at tau = sqrt(3) N / K = 3.5 s),
    octave cluster times up to Q T / 100 (at least 100 clusters each).  Over 45 seeded axis realisations the fit
    recovered N with a relative std of 0.34 % and K with 2.6 %: N within 2 % and K within 10 % are > 3.8 standard
    deviations; the theoretical curve itself is matched within the scatter of the last cluster time,
    ~1 / sqrt(2 (M / m - 1)) = 7 % at m = Q / 100 (20 % tolerance, about 3 of it)."""
    N, K, T, Q = 1e-3, 5e-4, 0.1, 200_000
    e = hardware_noise(0, 1, Q, T, gyro={"angle_random_walk": N, "rate_random_walk": K})["gyro_error"][:, 0]
    for axis in range(3):
        taus, adev = allan_deviation(e[:, axis], T)
        keep = taus <= Q * T / 100
        np.testing.assert_allclose(adev[keep], np.sqrt(N**2 / taus[keep] + K**2 * taus[keep] / 3), rtol=0.2)
        n_fit, k_fit = random_walk_coefficients(taus[keep], adev[keep])
        assert abs(n_fit / N - 1) < 0.02, (axis, n_fit / N)
        assert abs(k_fit / K - 1) < 0.10, (axis, k_fit / K)


# ----------------------------------------------------------------------------- packet loss


def test_loss_rate_is_within_a_binomial_band():
    """M = 100000 instants per link: the number lost is Binomial(M, p), within 5 sqrt(M p (1 - p)) of M p; p = 0
    and p = 1 are exact (a uniform draw in [0, 1) is never < 0 and always < 1)."""
    M = 100_000
    p = np.array([0.0, 0.01, 0.3, 0.5, 1.0])
    lost = hardware_noise(13, 1, M, 0.1, loss_probability=p)["lost"]
    count = lost.sum(axis=0, dtype=np.int64)
    assert np.all(np.abs(count - M * p) <= 5 * np.sqrt(M * p * (1 - p))), count / M
    assert count[0] == 0 and count[-1] == M
    # losses are independent between links: P(both lost) = p_a p_b, within 5 binomial sigmas of M p_a p_b
    both = int(np.sum(lost[:, 2] & lost[:, 3]))
    q = 0.3 * 0.5
    assert abs(both - M * q) < 5 * math.sqrt(M * q * (1 - q)), both / M


# ----------------------------------------------------------------------------- memory estimate


def test_noise_bytes_bounds_the_peak_memory():
    """The estimate is the arrays' bytes plus the documented scratch, and bounds the traced peak (allowing 64 KiB
    for the Python objects: seed sequences, generators, the dict)."""
    n, Q, L = 3, 40_000, 5
    assert noise_bytes(n, Q, L) == 2 * 8 * 3 * Q * n + Q * L + 4 * 8 * 3 * (Q + 1)
    tracemalloc.start()
    try:
        out = everything(n_agents=n, n_samples=Q, loss_probability=np.full(L, 0.5))
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    arrays = sum(a.nbytes for a in out.values())
    assert arrays == 2 * 8 * 3 * Q * n + Q * L
    assert arrays < peak <= noise_bytes(n, Q, L) + 64 * 1024, (peak, noise_bytes(n, Q, L))


# ----------------------------------------------------------------------------- Allan deviation helpers


def test_allan_deviation_matches_the_definition():
    """Overlapping Allan deviation from the phase x_j = T sum_{k<j} y_k (x_0 = 0), written out by hand:
    sigma^2(m T) = sum_j (x_{j+2m} - 2 x_{j+m} + x_j)^2 / (2 (m T)^2 (len(x) - 2m))."""
    y = np.random.default_rng(0).standard_normal(200)
    T = 0.5
    taus, adev = allan_deviation(y, T, taus=[0.5, 1.0, 2.5, 10.0])
    np.testing.assert_allclose(taus, [0.5, 1.0, 2.5, 10.0])
    x = np.concatenate([[0.0], np.cumsum(y) * T])
    for tau, a in zip(taus, adev, strict=True):
        m = round(tau / T)
        d = x[2 * m :] - 2 * x[m:-m] + x[: -2 * m]
        np.testing.assert_allclose(a, math.sqrt(np.sum(d**2) / (2 * tau**2 * (x.size - 2 * m))), rtol=1e-12)
    default_taus, _ = allan_deviation(y, T)  # octave: T, 2T, 4T, ...
    np.testing.assert_allclose(default_taus, T * 2.0 ** np.arange(default_taus.size))


def test_allan_deviation_needs_allantools(monkeypatch):
    monkeypatch.setitem(sys.modules, "allantools", None)
    with pytest.raises(ImportError, match="pip install allantools"):
        allan_deviation(np.zeros(10), 0.1)


def test_random_walk_coefficients_on_exact_curves():
    taus = np.logspace(-1, 4, 20)
    for N, K in ((1e-4, 1e-6), (3e-2, 0.0), (2e-3, 7e-5)):
        n_fit, k_fit = random_walk_coefficients(taus, np.sqrt(N**2 / taus + K**2 * taus / 3))
        np.testing.assert_allclose([n_fit, k_fit], [N, K], rtol=1e-8, atol=1e-14)


# ----------------------------------------------------------------------------- bad inputs


@pytest.mark.parametrize(
    ("args", "kwargs", "match"),
    [
        ((-1, 1, 5, 0.1), {}, r"seed: must be >= 0"),
        ((1.5, 1, 5, 0.1), {}, r"seed: expected an integer"),
        ((True, 1, 5, 0.1), {}, r"seed: expected an integer"),
        ((0, 0, 5, 0.1), {}, r"n_agents: must be >= 1"),
        ((0, 2.0, 5, 0.1), {}, r"n_agents: expected an integer"),
        ((0, 1, 0, 0.1), {}, r"n_samples: must be >= 1"),
        ((0, 1, 5, 0.0), {}, r"period: must be finite and > 0"),
        ((0, 1, 5, math.inf), {}, r"period: must be finite and > 0"),
        ((0, 1, 5, "0.1"), {}, r"period: expected a real number"),
        ((0, 1, 5, 0.1), {"star_tracker_std": [1e-5, -1e-5, 0.0]}, r"star_tracker_std: must be >= 0"),
        ((0, 1, 5, 0.1), {"star_tracker_std": [1e-5, 1e-5]}, r"star_tracker_std: expected shape \(3,\)"),
        ((0, 1, 5, 0.1), {"star_tracker_std": [1e-5, math.nan, 0]}, r"star_tracker_std: must be finite"),
        ((0, 1, 5, 0.1), {"star_tracker_std": "abc"}, r"star_tracker_std: expected an array of real numbers"),
        ((0, 1, 5, 0.1), {"gyro": {"angle_random_walk": -1.0}}, r"gyro.angle_random_walk: must be finite and >= 0"),
        ((0, 1, 5, 0.1), {"gyro": {"rate_random_walk": math.nan}}, r"gyro.rate_random_walk: must be finite"),
        ((0, 1, 5, 0.1), {"gyro": {"bias": [0.0, 0.0]}}, r"gyro.bias: expected shape \(3,\)"),
        ((0, 1, 5, 0.1), {"gyro": {"arw": 1.0}}, r"gyro: unknown keys \['arw'\]"),
        ((0, 1, 5, 0.1), {"gyro": 1e-3}, r"gyro: expected a mapping"),
        ((0, 1, 5, 0.1), {"loss_probability": [0.5, 1.5]}, r"loss_probability: must be in \[0, 1\]"),
        ((0, 1, 5, 0.1), {"loss_probability": [-0.1]}, r"loss_probability: must be >= 0"),
        ((0, 1, 5, 0.1), {"loss_probability": 0.5}, r"loss_probability: expected a 1-D array"),
    ],
)
def test_bad_inputs_are_rejected_with_one_line_messages(args, kwargs, match):
    with pytest.raises(ValueError, match=match) as info:
        hardware_noise(*args, **kwargs)
    assert "\n" not in str(info.value)


def test_bad_inputs_of_the_helpers():
    with pytest.raises(ValueError, match=r"n_links: must be >= 0"):
        noise_bytes(1, 10, -1)
    with pytest.raises(ValueError, match=r"rate: expected at least 3 samples"):
        allan_deviation([1.0, 2.0], 0.1)
    with pytest.raises(ValueError, match=r"period: must be finite and > 0"):
        allan_deviation(np.zeros(10), -0.1)
    with pytest.raises(ValueError, match=r"taus: must be > 0"):
        allan_deviation(np.zeros(10), 0.1, taus=[0.0, 0.2])
    with pytest.raises(ValueError, match=r"same length >= 2"):
        random_walk_coefficients([1.0, 2.0], [1.0])
    with pytest.raises(ValueError, match=r"taus, adev: must be > 0"):
        random_walk_coefficients([1.0, 2.0], [1.0, 0.0])


finite = st.floats(min_value=-1e3, max_value=1e3, allow_nan=False)


@settings(max_examples=40, deadline=None)
@given(std=st.lists(finite, min_size=3, max_size=3), p=st.lists(finite, min_size=0, max_size=4))
def test_property_out_of_range_parameters_raise_and_valid_ones_run(std, p):
    """Any negative std or probability outside [0, 1] raises ValueError; anything else gives the right shapes and
    the p = 0 / p = 1 links are exactly never / always lost."""
    bad = min(std) < 0 or any(not 0 <= x <= 1 for x in p)
    if bad:
        with pytest.raises(ValueError, match=r"(star_tracker_std|loss_probability): must be"):
            hardware_noise(0, 2, 4, 0.1, star_tracker_std=std, loss_probability=p)
        return
    out = hardware_noise(0, 2, 4, 0.1, star_tracker_std=std, loss_probability=p)
    assert out["dtheta"].shape == (4, 2, 3) and out["lost"].shape == (4, len(p))
    for e, x in enumerate(p):
        if x in (0.0, 1.0):
            assert np.all(out["lost"][:, e] == int(x))


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**64), n_agents=st.integers(1, 4), n_samples=st.integers(1, 30))
def test_property_any_seed_and_size_is_reproducible(seed, n_agents, n_samples):
    a = everything(seed=seed, n_agents=n_agents, n_samples=n_samples)
    b = everything(seed=seed, n_agents=n_agents, n_samples=n_samples)
    for key in a:
        np.testing.assert_array_equal(a[key], b[key])
    assert a["dtheta"].shape == (n_samples, n_agents, 3)
