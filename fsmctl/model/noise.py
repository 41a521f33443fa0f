"""The random processes of a run: star-tracker noise, rate-gyro error and packet losses.

Everything random in a run is drawn here, in Python, before the run, from the single integer
``simulation.seed``; the compiled loop (``fsmctl/csrc/formation.c``) only applies the arrays, indexed by the
control instant ``q = 0 .. Q-1`` (``t_q = q T``, ``T`` the control period):

* star tracker: ``sigma_measured = compose(dtheta_q / 4 as an MRP, sigma)`` (small body-frame rotation);
* rate gyro: ``omega_measured = omega + gyro_error_q``;
* links: ``lost_q[e] = 1``: link ``e`` loses its packet at instant ``q`` (the receiver holds its last value).

Stream layout
-------------
All streams derive from ``root = numpy.random.SeedSequence(seed)`` with a fixed spawn structure, so a run does
not depend on the number of workers, nor on which other processes are enabled::

    star, gyro, links = root.spawn(3)        # spawn keys (0,), (1,), (2,)
    agent i, star tracker: star.spawn(n_agents)[i]   -> spawn key (0, i)
    agent i, rate gyro:    gyro.spawn(n_agents)[i]   -> spawn key (1, i)
    link e, packet loss:   links.spawn(n_links)[e]   -> spawn key (2, e)

Each child seeds its own ``numpy.random.default_rng`` (PCG64), which then draws, row by row (C order):

* star tracker: ``standard_normal((Q, 3))``, scaled per axis by ``noise_std``;
* rate gyro: ``standard_normal((Q, 2, 3))``: ``[q, 0]`` is ``N_u`` (bias random walk), ``[q, 1]`` is ``N_v``
  (white rate noise) of instant ``q``;
* packet loss, Bernoulli model: ``random(Q)``; the packet is lost when the uniform draw is ``< p_e``;
* packet loss, Gilbert-Elliott model: ``random((Q, 2))``: ``[q, 0]`` moves the channel's state (at ``q = 0`` it
  draws the initial state: bad when ``< p / (p + r)``, the stationary distribution), ``[q, 1]`` decides the loss
  in that state (lost when ``< loss_bad`` in the bad state, ``< loss_good`` in the good one).

Consequences (held by ``tests/test_noise.py``): the stream of agent ``i`` (link ``e``) does not change when
``n_agents`` (``n_links``) grows, nor when another sensor is enabled or disabled, nor when the parameters of
the process change (the same draws are scaled); the draws are made in instant order, so a longer run starts
with the noise of a shorter one (the first ``Q`` rows do not depend on the run's length); and for one link a
larger loss probability loses a superset of the packets.  A future process takes the next index of
``root.spawn``: the existing streams keep their spawn keys.  The streams are NumPy's: bit-for-bit
reproducible for a given NumPy version (NumPy may change a generator's stream between versions).

Models
------
* Star tracker: independent zero-mean Gaussian small rotations, per-axis standard deviation ``noise_std``
  (the usual white-noise attitude-sensor model; Markley & Crassidis, *Fundamentals of Spacecraft Attitude
  Determination and Control*, Springer 2014, Sec. 5.3 and 6.2).
* Rate gyro: Farrenkopf's model ``omega_measured = omega + b_0 + beta + eta_v``, ``beta_dot = eta_u`` (white
  noises of densities ``N``, the angle random walk, and ``K``, the rate random walk), sampled exactly at the
  period ``T`` (Crassidis & Junkins, *Optimal Estimation of Dynamic Systems*, 2nd ed., CRC 2012, Sec. 7.2.1;
  R. L. Farrenkopf, "Analytic steady-state accuracy solutions for two common spacecraft attitude estimators",
  J. Guidance and Control 1(4), 1978)::

      beta_0 = 0,   beta_{q+1} = beta_q + K sqrt(T) N_u,q
      error_q = b_0 + (beta_{q+1} + beta_q) / 2 + sqrt(N^2 / T + K^2 T / 12) N_v,q

  The ``K^2 T / 12`` term is the variance of the integral of the bias's Brownian bridge between two samples,
  so that the integrated angle has exactly the continuous model's law at the sampling instants: the Allan
  variance of ``error`` is ``sigma_A^2(tau) = N^2 / tau + K^2 tau / 3`` for ``tau = m T`` (IEEE Std 952-1997,
  Annex C; El-Sheimy, Hou & Niu, "Analysis and modeling of inertial sensors using Allan variance", IEEE Trans.
  Instrum. Meas. 57(1), 2008).
* Packet loss, ``bernoulli``: independent Bernoulli(``p_e``) per link and control instant (the Gilbert-Elliott
  channel with a single state; e.g. Hespanha, Naghshtabrizi & Xu, "A survey of recent results in networked
  control systems", Proc. IEEE 95(1), 2007).
* Packet loss, ``gilbert_elliott``: bursty losses.  Each link is a two-state Markov chain, good ``G`` and bad
  ``B``, stepped once per control instant: ``P(G -> B) = p`` (``good_to_bad``), ``P(B -> G) = r``
  (``bad_to_good``); in state ``G`` the packet is lost with probability ``loss_good`` (``1 - k`` in the
  literature), in ``B`` with ``loss_bad`` (``1 - h``), independently given the state.  The initial state is drawn
  from the chain's stationary distribution ``pi_B = p / (p + r)``, so the process is stationary from ``q = 0``:
  its loss rate is ``pi_G loss_good + pi_B loss_bad = (r loss_good + p loss_bad) / (p + r)`` at every instant.
  With ``loss_good = 0``, ``loss_bad = 1`` (Gilbert's channel) the losses are the bad periods, geometric of mean
  ``1 / r`` (E. N. Gilbert, "Capacity of a burst-noise channel", Bell Syst. Tech. J. 39(5), 1960; E. O. Elliott,
  "Estimates of error rates for codes on burst-noise channels", Bell Syst. Tech. J. 42(5), 1963; the general
  burst length is :func:`gilbert_elliott_statistics`).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping

import numpy as np

__all__ = [
    "hardware_noise",
    "gilbert_elliott_statistics",
    "gilbert_elliott_problem",
    "noise_bytes",
    "allan_deviation",
    "random_walk_coefficients",
    "STREAMS",
    "GILBERT_ELLIOTT_KEYS",
]

STREAMS = {"star_tracker": 0, "gyro": 1, "links": 2}
"""Index of each process among ``SeedSequence(seed).spawn(3)`` (the first level of the stream layout)."""

_GYRO_KEYS = ("angle_random_walk", "rate_random_walk", "bias")
GILBERT_ELLIOTT_KEYS = ("good_to_bad", "bad_to_good", "loss_good", "loss_bad")
"""The parameters of the Gilbert-Elliott loss model: ``p``, ``r``, ``1 - k`` and ``1 - h`` (probabilities)."""
_SCRATCH = 4  # (Q + 1, 3) float64 arrays alive at once while one agent's gyro error is generated (see noise_bytes)


# ----------------------------------------------------------------------------- validation


def _count(name: str, value, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ValueError(f"{name}: expected an integer, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name}: must be >= {minimum}, got {value}")
    return int(value)


def _real(name: str, value, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name}: expected a real number, got {value!r}")
    x = float(value)
    if not math.isfinite(x) or x < 0 or (positive and x == 0):
        raise ValueError(f"{name}: must be finite and {'> 0' if positive else '>= 0'}, got {value!r}")
    return x


def _vector(name: str, value, shape: tuple[int, ...] | None = (3,), *, nonnegative: bool = True) -> np.ndarray:
    try:
        v = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected an array of real numbers, got {value!r}") from None
    if shape is None and v.ndim != 1:
        raise ValueError(f"{name}: expected a 1-D array, got shape {v.shape}")
    if shape is not None and v.shape != shape:
        raise ValueError(f"{name}: expected shape {shape}, got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name}: must be finite, got {v.tolist()}")
    if nonnegative and np.any(v < 0):
        raise ValueError(f"{name}: must be >= 0, got {v.tolist()}")
    return v


def _gyro_parameters(gyro) -> tuple[float, float, np.ndarray]:
    if not isinstance(gyro, Mapping):
        raise ValueError(f"gyro: expected a mapping with keys {list(_GYRO_KEYS)}, got {type(gyro).__name__}")
    unknown = sorted(set(gyro) - set(_GYRO_KEYS))
    if unknown:
        raise ValueError(f"gyro: unknown keys {unknown}, expected some of {list(_GYRO_KEYS)}")
    N = _real("gyro.angle_random_walk", gyro.get("angle_random_walk", 0.0))
    K = _real("gyro.rate_random_walk", gyro.get("rate_random_walk", 0.0))
    b0 = _vector("gyro.bias", gyro.get("bias", (0.0, 0.0, 0.0)), nonnegative=False)
    return N, K, b0


def _loss_probabilities(p) -> np.ndarray:
    v = _vector("loss_probability", p, shape=None)
    if np.any(v > 1):
        raise ValueError(f"loss_probability: must be in [0, 1], got {v.tolist()}")
    return v


def gilbert_elliott_problem(good_to_bad: float, bad_to_good: float, loss_good: float, loss_bad: float) -> str:
    """Why Gilbert-Elliott parameters are invalid (``""``: valid): each a probability, ``p + r > 0``.

    The one check of the model's parameters (the scenario's links, :func:`hardware_noise` and the python-control
    link all call it).

    Parameters
    ----------
    good_to_bad, bad_to_good, loss_good, loss_bad : float
        ``p``, ``r``, ``1 - k``, ``1 - h``.

    Returns
    -------
    str
        One line naming the first bad parameter, or ``""``.

    Examples
    --------
    >>> gilbert_elliott_problem(0.0, 0.0, 0.0, 1.0)
    'good_to_bad + bad_to_good: must be > 0 (p + r = 0 leaves the initial state undefined), got 0 + 0'
    """
    values = dict(zip(GILBERT_ELLIOTT_KEYS, (good_to_bad, bad_to_good, loss_good, loss_bad), strict=True))
    for key, value in values.items():
        if isinstance(value, bool) or not isinstance(value, numbers.Real) or not 0 <= float(value) <= 1:
            return f"{key}: must be a probability in [0, 1], got {value!r}"
    if good_to_bad + bad_to_good <= 0:
        return (
            "good_to_bad + bad_to_good: must be > 0 (p + r = 0 leaves the initial state undefined), "
            f"got {good_to_bad:g} + {bad_to_good:g}"
        )
    return ""


def _gilbert_elliott_parameters(ge) -> np.ndarray:
    """The ``(n_links, 4)`` parameters ``[p, r, loss_good, loss_bad]`` of a ``gilbert_elliott`` mapping."""
    if not isinstance(ge, Mapping):
        raise ValueError(f"gilbert_elliott: expected a mapping with keys {list(GILBERT_ELLIOTT_KEYS)}")
    if set(ge) != set(GILBERT_ELLIOTT_KEYS):
        raise ValueError(f"gilbert_elliott: expected the keys {list(GILBERT_ELLIOTT_KEYS)}, got {sorted(ge)}")
    columns = [_vector(f"gilbert_elliott.{k}", ge[k], shape=None, nonnegative=False) for k in GILBERT_ELLIOTT_KEYS]
    if len({c.size for c in columns}) != 1:
        raise ValueError(f"gilbert_elliott: one value per link in each key, got sizes {[c.size for c in columns]}")
    params = np.stack(columns, axis=1) if columns[0].size else np.zeros((0, 4))
    for e, row in enumerate(params):
        problem = gilbert_elliott_problem(*map(float, row))
        if problem:
            raise ValueError(f"gilbert_elliott, link {e}: {problem}")
    return params


# ----------------------------------------------------------------------------- the processes


def _children(seed: int, stream: str, count: int) -> list[np.random.SeedSequence]:
    """The ``count`` children of one process: spawn keys ``(STREAMS[stream], 0 .. count-1)``."""
    return np.random.SeedSequence(seed).spawn(len(STREAMS))[STREAMS[stream]].spawn(count)


def _star_tracker(rng: np.random.Generator, std: np.ndarray, out: np.ndarray) -> None:
    """One agent's ``(Q, 3)`` rotation noise into ``out``."""
    d = rng.standard_normal(out.shape)
    d *= std
    out[...] = d


def _gyro(rng: np.random.Generator, N: float, K: float, b0: np.ndarray, period: float, out: np.ndarray) -> None:
    """One agent's ``(Q, 3)`` Farrenkopf rate error into ``out`` (the discrete form, vectorised)."""
    Q = out.shape[0]
    w = rng.standard_normal((Q, 2, 3))
    beta = np.empty((Q + 1, 3))
    beta[0] = 0.0
    np.cumsum(w[:, 0], axis=0, out=beta[1:])
    beta[1:] *= K * math.sqrt(period)  # beta_{q+1} = beta_q + K sqrt(T) N_u,q
    white = w[:, 1]
    white *= math.sqrt(N**2 / period + K**2 * period / 12.0)
    np.add(beta[1:], beta[:-1], out=out)
    out *= 0.5
    out += white
    out += b0


def _losses(rng: np.random.Generator, p: float, out: np.ndarray) -> None:
    """One link's ``(Q,)`` losses into ``out`` (uint8): lost when the uniform draw in ``[0, 1)`` is ``< p``."""
    np.less(rng.random(out.shape[0]), p, out=out, casting="unsafe")


def _gilbert_elliott_losses(rng: np.random.Generator, params: np.ndarray, out: np.ndarray) -> None:
    """One link's ``(Q,)`` Gilbert-Elliott losses into ``out`` (uint8), from ``random((Q, 2))``.

    The state recursion is vectorised: with ``u = draws[q, 0]`` (``q >= 1``) the next state is *bad* whatever the
    state when ``r <= u < p``, *good* when ``p <= u < r``, the other state when ``u < min(p, r)`` and the same
    state when ``u >= max(p, r)``; so the state is the value of the latest reset (``q = 0`` included: the
    stationary draw) flipped once per flip since.
    """
    p, r, loss_good, loss_bad = params
    draws = rng.random((out.shape[0], 2))
    u = draws[:, 0]
    to_bad = u < p  # from the good state
    to_good = u < r  # from the bad state
    reset = to_bad != to_good  # the next state does not depend on the previous one
    reset[0] = True
    value = to_bad.copy()  # the state a reset sets (True: bad)
    value[0] = u[0] < p / (p + r)  # the initial state, from the stationary distribution
    flip = to_bad & to_good
    flip[0] = False
    flips = np.cumsum(flip, dtype=np.int64)
    last = np.maximum.accumulate(np.where(reset, np.arange(u.size), 0))
    bad = value[last] ^ ((flips - flips[last]) % 2).astype(bool)
    np.less(draws[:, 1], np.where(bad, loss_bad, loss_good), out=out, casting="unsafe")


def gilbert_elliott_statistics(
    good_to_bad: float, bad_to_good: float, loss_good: float = 0.0, loss_bad: float = 1.0
) -> dict[str, float]:
    """Stationary loss rate and mean loss-burst length of a Gilbert-Elliott channel.

    With ``p`` = ``good_to_bad``, ``r`` = ``bad_to_good``, ``e_G`` = ``loss_good`` and ``e_B`` = ``loss_bad``
    the chain ``(state, lost)`` is stationary from its first instant (:mod:`fsmctl.model.noise`), with

    * ``pi_B = p / (p + r)``, loss rate ``P(lost) = (r e_G + p e_B) / (p + r)``;
    * ``P(lost at q+1 | lost at q) = [pi_G e_G ((1-p) e_G + p e_B) + pi_B e_B (r e_G + (1-r) e_B)] / P(lost)``;
    * mean burst length (a burst: consecutive lost packets, ended by a delivered one): the number of losses per
      burst in a long record, ``P(lost) / (P(lost) - P(lost at q and q+1)) = 1 / (1 - P(lost at q+1 | lost at q))``
      (each burst ends with exactly one pair (lost, delivered); the chain is ergodic).  For Gilbert's channel
      (``e_G = 0``, ``e_B = 1``) the bursts are the bad periods: geometric, mean ``1 / r``; with ``e_G > 0`` or
      ``e_B < 1`` they are not geometric, but this is still their mean.

    Parameters
    ----------
    good_to_bad, bad_to_good : float
        Transition probabilities ``p`` (good to bad) and ``r`` (bad to good) per control instant, ``p + r > 0``.
    loss_good, loss_bad : float, optional
        Loss probabilities in the good (``1 - k``, default 0) and bad (``1 - h``, default 1) states.

    Returns
    -------
    dict
        ``"bad_fraction"`` ``pi_B``, ``"loss_rate"``, ``"loss_after_loss"`` and ``"mean_burst"`` (``inf`` when
        every packet is lost; ``nan`` when none is).

    Raises
    ------
    ValueError
        Parameters that are not probabilities, or ``p + r = 0``.

    Examples
    --------
    >>> s = gilbert_elliott_statistics(0.01, 0.25)  # Gilbert's channel
    >>> round(s["loss_rate"], 6), round(s["mean_burst"], 6)  # p / (p + r), 1 / r
    (0.038462, 4.0)
    """
    problem = gilbert_elliott_problem(good_to_bad, bad_to_good, loss_good, loss_bad)
    if problem:
        raise ValueError(problem)
    p, r, eg, eb = float(good_to_bad), float(bad_to_good), float(loss_good), float(loss_bad)
    pi_b = p / (p + r)
    pi_g = 1.0 - pi_b
    rate = pi_g * eg + pi_b * eb
    both = pi_g * eg * ((1 - p) * eg + p * eb) + pi_b * eb * (r * eg + (1 - r) * eb)
    after = both / rate if rate > 0 else math.nan
    if rate == 0:
        burst = math.nan
    elif after >= 1:
        burst = math.inf
    else:
        burst = 1.0 / (1.0 - after)
    return {"bad_fraction": pi_b, "loss_rate": rate, "loss_after_loss": after, "mean_burst": burst}


def hardware_noise(
    seed: int,
    n_agents: int,
    n_samples: int,
    period: float,
    *,
    star_tracker_std=None,
    gyro: Mapping | None = None,
    loss_probability=None,
    gilbert_elliott: Mapping | None = None,
) -> dict[str, np.ndarray]:
    """The sensor noise and packet losses of a run, at its ``n_samples`` control instants.

    Parameters
    ----------
    seed : int
        ``simulation.seed`` (>= 0); see the module docstring for the stream layout.
    n_agents : int
        Number of spacecraft (>= 1).
    n_samples : int
        Number of control instants ``Q`` (>= 1), ``t_q = q * period``.
    period : float
        Control period ``T`` (s, > 0).
    star_tracker_std : array_like (3,), optional
        Per-axis standard deviation of the star tracker's body-frame rotation noise (rad, >= 0); unset: no noise.
    gyro : mapping, optional
        Rate gyro: ``angle_random_walk`` ``N`` (rad/s^0.5), ``rate_random_walk`` ``K`` (rad/s^1.5), ``bias``
        ``b_0`` (3,) rad/s (missing keys: 0); unset: no error.
    loss_probability : array_like (n_links,), optional
        Bernoulli loss model: per-link probability of losing the packet at a control instant (in [0, 1]).
    gilbert_elliott : mapping, optional
        Gilbert-Elliott loss model (instead of ``loss_probability``): keys ``good_to_bad`` (``p``),
        ``bad_to_good`` (``r``), ``loss_good`` (``1 - k``) and ``loss_bad`` (``1 - h``), each an array_like
        ``(n_links,)`` of probabilities, ``p + r > 0`` per link.  Neither given: no link.

    Returns
    -------
    dict
        ``"dtheta"`` (Q, n_agents, 3) rad and ``"gyro_error"`` (Q, n_agents, 3) rad/s, float64; ``"lost"``
        (Q, n_links) uint8, 1 = lost.  C-contiguous; zeros for a disabled process.

    Raises
    ------
    ValueError
        A count, period or parameter out of its range (one line naming it), or both loss models given.

    Examples
    --------
    >>> noise = hardware_noise(0, 2, 5, 0.1, star_tracker_std=[1e-4, 1e-4, 2e-4], loss_probability=[0.0, 1.0])
    >>> noise["dtheta"].shape, noise["gyro_error"].any(), noise["lost"].tolist()[0]
    ((5, 2, 3), False, [0, 1])
    >>> ge = {"good_to_bad": [0.15], "bad_to_good": [0.3], "loss_good": [0.0], "loss_bad": [1.0]}
    >>> hardware_noise(1, 1, 16, 0.1, gilbert_elliott=ge)["lost"][:, 0].tolist()  # a burst of 8 losses
    [0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1, 0, 0, 0]
    """
    seed = _count("seed", seed, 0)
    n = _count("n_agents", n_agents, 1)
    Q = _count("n_samples", n_samples, 1)
    T = _real("period", period, positive=True)
    std = None if star_tracker_std is None else _vector("star_tracker_std", star_tracker_std)
    gyro_params = None if gyro is None else _gyro_parameters(gyro)
    if loss_probability is not None and gilbert_elliott is not None:
        raise ValueError("loss_probability, gilbert_elliott: give one loss model, not both")
    p = np.zeros(0) if loss_probability is None else _loss_probabilities(loss_probability)
    ge = np.zeros((0, 4)) if gilbert_elliott is None else _gilbert_elliott_parameters(gilbert_elliott)
    n_links = max(p.size, ge.shape[0])

    dtheta = np.zeros((Q, n, 3))
    gyro_error = np.zeros((Q, n, 3))
    lost = np.zeros((Q, n_links), dtype=np.uint8)
    if std is not None:
        for i, child in enumerate(_children(seed, "star_tracker", n)):
            _star_tracker(np.random.default_rng(child), std, dtheta[:, i])
    if gyro_params is not None:
        for i, child in enumerate(_children(seed, "gyro", n)):
            _gyro(np.random.default_rng(child), *gyro_params, T, gyro_error[:, i])
    for e, child in enumerate(_children(seed, "links", n_links)):
        if gilbert_elliott is None:
            _losses(np.random.default_rng(child), p[e], lost[:, e])
        else:
            _gilbert_elliott_losses(np.random.default_rng(child), ge[e], lost[:, e])
    return {"dtheta": dtheta, "gyro_error": gyro_error, "lost": lost}


def noise_bytes(n_agents: int, n_samples: int, n_links: int) -> int:
    """Peak memory (bytes) of :func:`hardware_noise`: its arrays plus the generation's scratch.

    The returned arrays take ``2 * 8 * 3 * Q * n_agents + Q * n_links`` bytes; while one agent's gyro error is
    generated, at most four ``(Q + 1, 3)`` float64 scratch arrays are alive (the draws, the bias walk and
    NumPy's temporaries), which are added.

    Parameters
    ----------
    n_agents : int
        Number of agents (>= 1).
    n_samples : int
        Samples ``Q`` per agent (>= 1).
    n_links : int
        Number of directed links (>= 0).

    Returns
    -------
    int
        Bytes.

    Examples
    --------
    >>> noise_bytes(2, 1000, 2) == 2 * 8 * 3 * 1000 * 2 + 1000 * 2 + 4 * 8 * 3 * 1001
    True
    """
    n = _count("n_agents", n_agents, 1)
    Q = _count("n_samples", n_samples, 1)
    L = _count("n_links", n_links, 0)
    return 2 * 8 * 3 * Q * n + Q * L + _SCRATCH * 8 * 3 * (Q + 1)


# ----------------------------------------------------------------------------- Allan deviation


def allan_deviation(rate, period: float, taus=None) -> tuple[np.ndarray, np.ndarray]:
    """Overlapping Allan deviation of a rate signal sampled every ``period`` (``allantools.oadev``).

    Parameters
    ----------
    rate : array_like (M,)
        Rate samples (e.g. a gyro error, rad/s), at least 3.
    period : float
        Sampling period (s, > 0).
    taus : array_like or str, optional
        Cluster times (s; rounded to multiples of ``period``, those beyond the data dropped) or an ``allantools``
        keyword (``"octave"``, ``"decade"``, ``"all"``); default ``"octave"``.

    Returns
    -------
    taus, adev : numpy.ndarray
        The cluster times used and the overlapping Allan deviation at each (units of ``rate``).

    Raises
    ------
    ImportError
        The optional ``allantools`` package is not installed.
    ValueError
        Fewer than 3 samples, or a ``tau`` that is not positive.

    Examples
    --------
    >>> e = hardware_noise(0, 1, 20000, 0.1, gyro={"angle_random_walk": 1e-3})["gyro_error"][:, 0, 0]
    >>> taus, adev = allan_deviation(e, 0.1, taus=[1.0, 10.0])
    >>> taus.tolist(), bool(abs(adev[0] / 1e-3 - 1) < 0.1)  # N / sqrt(tau), tau = 1 s
    ([1.0, 10.0], True)
    """
    try:
        import allantools
    except ImportError:
        raise ImportError("allan_deviation needs the allantools package: pip install allantools") from None
    y = _vector("rate", rate, shape=None, nonnegative=False)
    if y.size < 3:
        raise ValueError(f"rate: expected at least 3 samples, got {y.size}")
    T = _real("period", period, positive=True)
    if taus is not None and not isinstance(taus, str):
        taus = _vector("taus", taus, shape=None)
        if np.any(taus <= 0):
            raise ValueError(f"taus: must be > 0, got {taus.tolist()}")
    out_taus, adev, _, _ = allantools.oadev(y, rate=1.0 / T, data_type="freq", taus=taus)
    return np.asarray(out_taus, dtype=float), np.asarray(adev, dtype=float)


def random_walk_coefficients(taus, adev) -> tuple[float, float]:
    """Angle and rate random walks ``(N, K)`` fitted to an Allan deviation curve.

    Non-negative least squares (``scipy.optimize.nnls``) of ``sigma_A^2(tau) = N^2 / tau + K^2 tau / 3`` in
    ``(N^2, K^2)``, each point weighted by ``1 / adev^2`` (relative residuals): the ``tau^-1/2`` region
    determines ``N``, the ``tau^+1/2`` region ``K`` (IEEE Std 952-1997, Annex C).  Quantisation, bias
    instability and rate ramp are not modelled: restrict ``taus`` to where the two terms dominate.

    Parameters
    ----------
    taus, adev : array_like (M,)
        Cluster times (s, > 0) and Allan deviations (> 0), at least 2 points, e.g. from :func:`allan_deviation`.

    Returns
    -------
    N, K : float
        Angle random walk (rate unit * s^0.5) and rate random walk (rate unit / s^0.5).

    Raises
    ------
    ValueError
        ``taus`` and ``adev`` of different lengths, fewer than 2 points, or values that are not positive.

    Examples
    --------
    >>> taus = np.array([0.1, 1.0, 10.0, 100.0, 1000.0])
    >>> N, K = random_walk_coefficients(taus, np.sqrt(1e-8 / taus + 1e-12 * taus / 3))
    >>> round(N, 12), round(K, 12)
    (0.0001, 1e-06)
    """
    from scipy.optimize import nnls

    t = _vector("taus", taus, shape=None)
    a = _vector("adev", adev, shape=None)
    if t.size != a.size or t.size < 2:
        raise ValueError(f"taus, adev: expected two arrays of the same length >= 2, got {t.size} and {a.size}")
    if np.any(t <= 0) or np.any(a <= 0):
        raise ValueError("taus, adev: must be > 0")
    w = 1.0 / a**2
    A = np.stack([w / t, w * t / 3.0], axis=1)
    scale = np.linalg.norm(A, axis=0)  # unit columns: N^2 and K^2 may differ by many orders of magnitude
    x, _ = nnls(A / scale, np.ones_like(t))
    N2, K2 = x / scale
    return float(math.sqrt(N2)), float(math.sqrt(K2))
