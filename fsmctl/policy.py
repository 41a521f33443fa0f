"""fsmctl's policy constants and defaults: the one home of each, with its meaning and unit.

A policy constant is a choice of fsmctl, not a number of the paper or of a scenario: the tolerances at which
settling times are reported, the steady-state window, a study's default horizon, how long a Dask scheduler gets to
answer, how many worker processes a command starts.  Each is defined here once and imported by every layer that
uses it (the simulator's summary, the studies, the command line's defaults and help), so that changing one changes
it everywhere.  Plain Python (no NumPy): the bottom layer, importable by every other.

=================================  ============================  ======================================================
name                               value                         meaning
=================================  ============================  ======================================================
:data:`SETTLING_TOLERANCES_DEG`    (1, 0.1, 0.05, 0.03, 0.01)    deg: the bands at which ``simulate`` and ``reproduce``
                                                                 report the settling times of AAEM (eq 42) and RAEM
                                                                 (eq 43); the paper does not state the tolerance of its
                                                                 "27 s"
:data:`COMPARISON_TOLERANCES_DEG`  (1, 0.1, 0.01)                deg: ``compare``'s settling bands
:data:`TOLERANCE_DEG`              1                             deg: the AAEM/RAEM tolerance of "converged"
                                                                 (``simulate``, ``montecarlo``; ``tune``: settled)
:data:`STEADY_WINDOW_FRACTION`     0.4                           the steady-state statistics are taken over the last
                                                                 40 % of the horizon ...
:data:`STEADY_WINDOW_MAX_S`        40                            s: ... and over at most 40 s (the paper's last 40 of
                                                                 100 s; :func:`default_steady_window`)
:data:`STEADY_RULE`                (text)                        the steady-state window in words, as every output
                                                                 states it: "the last 40 % of the horizon, at most 40 s"
:data:`FAST_T_FINAL_S`             10                            s: the horizon of ``reproduce --fast``
:data:`FAST_OUTPUT_INTERVAL_S`     0.05                          s: the output grid of ``reproduce --fast``
:data:`LONG_HORIZON_FACTOR`        3                             ``reproduce``'s long runs (Cases 1 and 2) fly this
                                                                 many times the horizon (300 s; 30 s with ``--fast``)
:data:`SURFACE_REACH_THRESHOLD`    1e-3                          ``compare-surfaces``: the surface is reached when
                                                                 ``||s_i||`` is below it
:data:`SURFACE_SIGMA_TOLERANCE`    1e-3                          ``compare-surfaces``: settled when every
                                                                 ``|sigma_ei,k|`` stays below it (dimensionless MRP)
:data:`SURFACE_METRIC_TOLERANCE`   0.03                          deg: ``compare-surfaces``' AAEM/RAEM settling band
:data:`TUNE_BATCH`                 8                             trials a tuning study proposes, flies and tells
                                                                 together (part of the study: its trials depend on it)
:data:`BATCH_AGENTS`               64                            agents ``simulate_many`` flies in one compiled loop
                                                                 (and a tuning task's candidates fill at most)
:data:`DASK_TIMEOUT_S`             10                            s: how long a Dask scheduler gets to accept the
                                                                 connection and send its handshake
:data:`ZENO_CONSECUTIVE_CHECKS`    100                           an event-triggered run stops (Zeno guard) when an
                                                                 agent sends at this many consecutive trigger checks
=================================  ============================  ======================================================

Converged (:data:`CONVERGED_RULE`): a run has converged when AAEM and RAEM each stay at or below
:data:`TOLERANCE_DEG` from some time until the end of the run (``simulate``'s first line, a Monte Carlo run's
``converged``).  Steady (:func:`default_steady_window`, :func:`steady_window_text`): the steady-state figures of
every command (``simulate``, ``compare``, ``compare-surfaces``, ``tune``, ``montecarlo``, ``reproduce``'s report) are
taken over the last 40 % of the horizon, at most 40 s, unless a command is told ``--steady-window`` (``reproduce``'s
long runs keep the window of the horizon they lengthen: 40 s of 300 s, 4 s of 30 s with ``--fast``); each output
that prints one states its window.

Workers: every command that runs things in parallel (``prove``, ``reproduce``, ``compare``, ``compare-surfaces``,
``montecarlo``, ``tune``) starts, unless told ``--workers N``, one worker per CPU this process may run on
(:func:`default_workers`), and a study never starts more workers than it has tasks at once.  The library's entry
points (``run_claims``, ``reproduce``, ``compare_laws``, ``compare_surfaces``, ``run_campaign``, ``tune``) follow
the same rule: ``workers=None``, their default, is :func:`default_workers` of their number of tasks
(:func:`fsmctl.parallel.resolve_workers`).  The worker count changes the speed only: every study's results
are the same bit for bit for any worker count.
"""

from __future__ import annotations

import os

__all__ = [
    "SETTLING_TOLERANCES_DEG",
    "COMPARISON_TOLERANCES_DEG",
    "TOLERANCE_DEG",
    "CONVERGED_RULE",
    "STEADY_WINDOW_FRACTION",
    "STEADY_WINDOW_MAX_S",
    "STEADY_RULE",
    "FAST_T_FINAL_S",
    "FAST_OUTPUT_INTERVAL_S",
    "LONG_HORIZON_FACTOR",
    "SURFACE_REACH_THRESHOLD",
    "SURFACE_SIGMA_TOLERANCE",
    "SURFACE_METRIC_TOLERANCE",
    "TUNE_BATCH",
    "BATCH_AGENTS",
    "DASK_TIMEOUT_S",
    "ZENO_CONSECUTIVE_CHECKS",
    "default_steady_window",
    "steady_window_text",
    "default_workers",
]

SETTLING_TOLERANCES_DEG: tuple[float, ...] = (1.0, 0.1, 0.05, 0.03, 0.01)
"""deg: tolerances of the reported settling times of AAEM and RAEM (eqs 42-43); the paper does not state the
tolerance of its "27 s", so several are reported (``simulate``'s summary, ``reproduce``'s report and claims)."""

COMPARISON_TOLERANCES_DEG: tuple[float, ...] = (1.0, 0.1, 0.01)
"""deg: the settling tolerances of a law comparison (``compare``, :func:`fsmctl.studies.compare_laws`)."""

TOLERANCE_DEG = 1.0
"""deg: the AAEM/RAEM tolerance of "converged" (:data:`CONVERGED_RULE`: ``simulate``, Monte Carlo's default), settled
within it (tuning)."""

CONVERGED_RULE = "AAEM and RAEM (eqs 42-43) stay at or below {tolerance} until the end of the run"
"""What "converged" means, everywhere (:func:`fsmctl.simulation.metrics.converged`: each metric settles, i.e. stays
at or below the tolerance from some time until the end), stated in the outputs: ``CONVERGED_RULE.format(tolerance=
"1 deg")``."""

STEADY_WINDOW_FRACTION = 0.4
"""The steady-state statistics are taken over the last 40 % of the horizon (the paper's last 40 s of 100 s)."""

STEADY_WINDOW_MAX_S = 40.0
"""s: the longest steady-state window (40 % of the paper's 100 s horizon); :func:`default_steady_window`."""

STEADY_RULE = f"the last {STEADY_WINDOW_FRACTION:.0%} of the horizon, at most {STEADY_WINDOW_MAX_S:g} s"
"""The steady-state window in words, as every output that prints a steady figure states it."""

FAST_T_FINAL_S = 10.0
"""s: the horizon of a fast reproduction (``fsmctl reproduce --fast``: tests and quick looks)."""

FAST_OUTPUT_INTERVAL_S = 0.05
"""s: the output grid of a fast reproduction (``fsmctl reproduce --fast``)."""

LONG_HORIZON_FACTOR = 3.0
"""How many times the scenario's horizon ``fsmctl reproduce``'s long runs (``case1_long``, ``case2_long``) fly."""

SURFACE_REACH_THRESHOLD = 1e-3
"""The norm ``||s_i||`` of agent i's sliding variable below which a sliding-surface comparison counts it as having
reached its surface (``compare-surfaces``)."""

SURFACE_SIGMA_TOLERANCE = 1e-3
"""Dimensionless (MRP): a sliding-surface comparison's run has settled when every ``|sigma_ei,k|`` stays below it."""

SURFACE_METRIC_TOLERANCE = 0.03
"""deg: the AAEM/RAEM settling tolerance of a sliding-surface comparison (``compare-surfaces``)."""

TUNE_BATCH = 8
"""Trials a tuning study proposes, flies (in parallel) and tells together; part of the study: its trials depend on
it, not on the number of workers."""

BATCH_AGENTS = 64
"""Default size of a batch of :func:`fsmctl.simulate_many`: runs are stacked up to this many agents in all (10 runs of
the paper's 6 agents); the time per run levels off from ~8 runs of Case 1 (``benchmarks/run.py``, throughput
section).  A tuning task flies at most this many agents' worth of candidates together (the speed only: the results
do not depend on it)."""

EXPORT_CONTROL_PERIOD = 0.01
"""s: the control period of an exported law (``fsmctl export``) and of its software-in-the-loop flight when the
scenario flies continuous control (the paper's scenario): 100 Hz, a common attitude-control rate on a flight
computer, and ten of the paper scenario's 1 ms integrator steps."""

DASK_TIMEOUT_S = 10.0
"""s: how long a Dask scheduler gets to accept the connection and send its handshake (``--dask-timeout``)."""

ZENO_CONSECUTIVE_CHECKS = 100
"""The Zeno guard of event-triggered communication: a run stops (``fsmctl.simulation.ZenoError``) when an agent sends
at this many consecutive trigger checks (10 s at the usual 10 Hz checks).  Why: checked at sampled instants, a
trigger cannot fire faster than its checks, so the continuous-time Zeno collapse of the inter-event time shows as an
agent that sends at every check; such a run is periodic broadcasting at the check rate while it reports itself as
event-triggered (e.g. a threshold of 0 fires whenever the broadcast moves).  The legitimate bursts of a transient
are shorter: the built-in ``fsm_event`` on the paper's Case 1 at 10 Hz, its torque saturated throughout, sends at
most 4 checks in a row (69 with its threshold floor lowered to 0.03 1/s)."""


def default_steady_window(horizon_s: float) -> float:
    """The steady-state window of a run: the last :data:`STEADY_WINDOW_FRACTION` of its horizon, at most
    :data:`STEADY_WINDOW_MAX_S`.

    Parameters
    ----------
    horizon_s : float
        The run's horizon (s).

    Returns
    -------
    float
        The window's length (s).

    Examples
    --------
    >>> from fsmctl.policy import default_steady_window
    >>> default_steady_window(100.0), default_steady_window(10.0), default_steady_window(300.0)
    (40.0, 4.0, 40.0)
    """
    return min(STEADY_WINDOW_MAX_S, STEADY_WINDOW_FRACTION * float(horizon_s))


def steady_window_text(window_s: float, horizon_s: float) -> str:
    """How an output states the window of a steady-state figure: its length and its share of the horizon.

    Parameters
    ----------
    window_s : float
        The window's length (s).
    horizon_s : float
        The run's horizon (s).

    Returns
    -------
    str
        ``"the last W s (P % of the H s horizon)"``.

    Examples
    --------
    >>> from fsmctl.policy import default_steady_window, steady_window_text
    >>> steady_window_text(default_steady_window(100.0), 100.0)
    'the last 40 s (40 % of the 100 s horizon)'
    >>> steady_window_text(default_steady_window(300.0), 300.0)
    'the last 40 s (13.3 % of the 300 s horizon)'
    """
    share = 100.0 * float(window_s) / float(horizon_s) if horizon_s > 0 else 100.0
    return f"the last {window_s:g} s ({share:.3g} % of the {horizon_s:g} s horizon)"


def default_workers(tasks: int | None = None) -> int:
    """The default number of worker processes (or threads): one per CPU this process may run on, at most ``tasks``.

    The CPUs this process may run on are ``os.process_cpu_count()`` (Python >= 3.13), else its CPU affinity
    (``os.sched_getaffinity``, which a container's or a batch scheduler's CPU set restricts), else every CPU of the
    machine (``os.cpu_count``); at least one.

    Parameters
    ----------
    tasks : int, optional
        The number of tasks that can run at once (a cap; at least one worker whatever it is).

    Returns
    -------
    int
        A whole number >= 1.

    Examples
    --------
    >>> import os
    >>> from fsmctl.policy import default_workers
    >>> 1 <= default_workers() <= (os.cpu_count() or 1), default_workers(tasks=1), default_workers(tasks=0)
    (True, 1, 1)
    """
    if hasattr(os, "process_cpu_count"):  # Python >= 3.13
        cpus = os.process_cpu_count() or 1
    elif hasattr(os, "sched_getaffinity"):  # Linux
        cpus = len(os.sched_getaffinity(0))
    else:
        cpus = os.cpu_count() or 1
    cpus = max(1, cpus)
    return cpus if tasks is None else max(1, min(cpus, int(tasks)))
