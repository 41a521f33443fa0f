"""Flying a Monte Carlo chunk: its runs' scenarios together (``simulate_many``) and one record per run."""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from fsmctl.model.scenario import Agent, Scenario
from fsmctl.simulation.messages import message_metrics
from fsmctl.studies.montecarlo.sampling import sample_run_scenario, sampled_noise_scale
from fsmctl.studies.montecarlo.settings import STATUS_FAILED, STATUS_OK, CampaignSettings, child_seed

SCALARS = (
    "aaem_settling_s",
    "raem_settling_s",
    "aaem_settling_tight_s",
    "raem_settling_tight_s",
    "aaem_final_deg",
    "raem_final_deg",
    "aaem_steady_max_deg",
    "raem_steady_max_deg",
    "u_max_abs_N_m",
    "u_unsaturated_max_N_m",
    "saturated_time_max_s",
    "last_saturation_s",
    "theorem1_lambda_min",
    "theorem2_margin",
    "inertia_rho_max",
    "initial_angle_max_deg",
    "initial_rate_max_rad_per_s",
    "disturbance_amplitude_max_N_m",
    "n_links",
    "link_delay_max_s",
    "loss_probability_max",
    "sensor_noise_scale",
    "wheel_speed_peak_rad_per_s",
    "wheel_momentum_peak_N_m_s",
    "messages_count",
    "messages_per_agent_per_s",
    "wall_time_s",
    "cpu_time_s",
)
FLAGS = ("converged", "theorem1_holds", "theorem2_at_reference_holds")
PER_AGENT = ("saturated_time_s", "theta_e_final_deg")


def nan_record(n_agents: int) -> dict:
    rec: dict[str, Any] = {k: math.nan for k in SCALARS}
    rec.update({k: False for k in FLAGS})
    rec.update({k: np.full(n_agents, np.nan) for k in PER_AGENT})
    return rec


def _check_final_sample(time_s: np.ndarray, t_final: float) -> None:
    """Raise unless the last output sample is at ``t_final`` (within rounding): "final" means at t_final."""
    t_end = float(time_s[-1]) if len(time_s) else math.nan
    if not math.isclose(t_end, t_final, rel_tol=1e-9, abs_tol=1e-12):
        raise RuntimeError(
            f"the output grid ends at t = {t_end:.9g} s, not at t_final = {t_final:.9g} s: "
            "the final values would come from the wrong sample"
        )


def run_one(base: Scenario, settings: CampaignSettings, index: int, seed: np.random.SeedSequence) -> dict:
    """Simulate run ``index`` and return its summary record (raises on failure: the caller records it).

    The "final" values (``aaem_final_deg``, ``theta_e_final_deg``, ``converged``) are taken at
    ``t_final``; a result whose last sample is elsewhere raises, so the run is ``failed``.
    (:func:`run_chunk` flies a chunk's runs together, :func:`fsmctl.simulation.simulator.simulate_many`, with the
    same records.)

    Parameters
    ----------
    base : Scenario
        The campaign's base scenario.
    settings : CampaignSettings
        The campaign's settings.
    index : int
        The run's index.
    seed : numpy.random.SeedSequence
        The run's seed (:func:`sample_run_scenario`).

    Returns
    -------
    dict
        The run's summary: settling times, final errors, Theorem 1 and 2 checks, torques, what was drawn.

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.studies import CampaignSettings
    >>> from fsmctl.studies.montecarlo import campaign_base, run_one
    >>> settings, base = campaign_base(CampaignSettings(t_final=0.5))
    >>> record = run_one(base, settings, 0, np.random.SeedSequence(0).spawn(1)[0])
    >>> record["converged"], record["u_max_abs_N_m"] <= base.controller.torque_limit
    (False, True)
    """
    from fsmctl.simulation.simulator import simulate

    wall, cpu = time.perf_counter(), time.process_time()
    scenario = sample_run_scenario(base, settings, seed)
    result = simulate(scenario, progress=False)
    rec = run_record(scenario, settings, seed, result)
    rec["wall_time_s"] = time.perf_counter() - wall
    rec["cpu_time_s"] = time.process_time() - cpu
    return rec


def run_record(scenario: Scenario, settings: CampaignSettings, seed: np.random.SeedSequence, result) -> dict:
    """The summary record of a run of ``scenario`` (drawn from ``seed``) from its result (raises on a bad result).

    Parameters
    ----------
    scenario : Scenario
        The run's scenario (:func:`sample_run_scenario`).
    settings : CampaignSettings
        The campaign (tolerance, steady window, noise ranges).
    seed : numpy.random.SeedSequence
        The run's seed.
    result : SimulationResult
        Its result (:func:`fsmctl.simulate`, or one entry of :func:`fsmctl.simulate_many`).

    Returns
    -------
    dict
        The record :func:`run_one` returns, with ``wall_time_s`` and ``cpu_time_s`` left NaN for the caller.

    Examples
    --------
    >>> import numpy as np, fsmctl
    >>> from fsmctl.studies.montecarlo import CampaignSettings, campaign_base, run_record, sample_run_scenario
    >>> settings, base = campaign_base(CampaignSettings(runs=1, t_final=0.5))
    >>> seed = np.random.SeedSequence(settings.seed).spawn(1)[0]
    >>> scenario = sample_run_scenario(base, settings, seed)
    >>> rec = run_record(scenario, settings, seed, fsmctl.simulate(scenario))
    >>> rec["converged"], bool(np.isnan(rec["wall_time_s"]))
    (False, True)
    """
    from fsmctl.proofs.theorem1 import analyze_topology
    from fsmctl.proofs.theorem2 import Region, delta_requirements
    from fsmctl.simulation.metrics import converged, principal_angles

    _check_final_sample(np.asarray(result.time), scenario.simulation.t_final)
    tol = settings.tolerance_deg
    summary = result.summary(tolerances_deg=(tol, 0.1 * tol), steady_window=settings.steady_window)
    aaem, raem = result.aaem_deg, result.raem_deg
    t1 = analyze_topology(scenario.topology, scenario.simulation.t_final, explain=False)  # holds, lambda_min
    paper_law = scenario.law.paper_theorems is not None  # Theorems 1-2 apply to a law that declares them
    t2 = (
        delta_requirements(scenario, Region(0.0, 0.0), n_random=0, dt_reference=None, search_scale=False)
        if paper_law
        else None
    )
    margins = (
        [c / r if r > 0 else math.inf for a in t2.agents for c, r in zip(a.configured, a.reference_bound, strict=True)]
        if t2 is not None
        else [math.nan]
    )
    rec = nan_record(scenario.n_agents)
    rec.update(
        aaem_settling_s=summary["aaem_settling_s"][f"{tol:g}"],
        raem_settling_s=summary["raem_settling_s"][f"{tol:g}"],
        aaem_settling_tight_s=summary["aaem_settling_s"][f"{0.1 * tol:g}"],
        raem_settling_tight_s=summary["raem_settling_s"][f"{0.1 * tol:g}"],
        aaem_final_deg=float(aaem[-1]),
        raem_final_deg=float(raem[-1]),
        aaem_steady_max_deg=summary["aaem_steady_max_deg"],
        raem_steady_max_deg=summary["raem_steady_max_deg"],
        u_max_abs_N_m=summary["u_max_abs_N_m"],
        u_unsaturated_max_N_m=summary["u_unsaturated_max_N_m"],
        saturated_time_max_s=float(np.max(result.saturated_time)),
        last_saturation_s=summary["last_saturation_s"],
        theorem1_lambda_min=float(t1.lambda_min),
        theorem2_margin=float(min(margins)),
        inertia_rho_max=max(_relative_perturbation(a) for a in scenario.agents),
        initial_angle_max_deg=float(np.degrees(principal_angles(np.array([a.sigma0 for a in scenario.agents]))).max()),
        initial_rate_max_rad_per_s=float(np.abs([a.omega0 for a in scenario.agents]).max()),
        disturbance_amplitude_max_N_m=float(np.abs([a.disturbance.amplitude for a in scenario.agents]).max()),
        n_links=float(len(scenario.topology.links)),
        **_hardware_record(scenario, sampled_noise_scale(settings, seed)),
        **{k: summary[k] for k in ("wheel_speed_peak_rad_per_s", "wheel_momentum_peak_N_m_s") if k in summary},
        **message_metrics(result),  # NaN for continuous control
        converged=converged(np.asarray(result.time), aaem, raem, tol),  # the one definition (policy.CONVERGED_RULE)
        theorem1_holds=bool(t1.holds) and paper_law,
        theorem2_at_reference_holds=bool(t2 is not None and t2.ok),
        saturated_time_s=np.asarray(result.saturated_time, dtype=float),
        theta_e_final_deg=np.degrees(result.theta_e[-1]),
    )
    return rec


def _hardware_record(scenario: Scenario, noise_scale: float) -> dict[str, float]:
    """The run's link delay and loss (largest over its links, the stationary loss rate for a Gilbert-Elliott link;
    0 without links or a control period) and the factor on its sensor noise (NaN without sensors)."""
    links = scenario.topology.links
    out = {"link_delay_max_s": 0.0, "loss_probability_max": 0.0}
    if links and scenario.simulation.control_period > 0:
        receivers, senders = [lk.receiver for lk in links], [lk.sender for lk in links]
        out["link_delay_max_s"] = float(np.max(scenario.links.per_link(receivers, senders, "delay")))
        out["loss_probability_max"] = float(np.max(scenario.links.loss_rates(receivers, senders)))
    out["sensor_noise_scale"] = noise_scale if scenario.sensors.enabled else math.nan
    return out


def _relative_perturbation(agent: Agent) -> float:
    J0, dJ = agent.J0_array, np.array(agent.delta_J)
    w, V = np.linalg.eigh(J0)
    inv_sqrt = V @ np.diag(w**-0.5) @ V.T
    return float(np.linalg.eigvalsh(inv_sqrt @ dJ @ inv_sqrt)[-1])


RunFunction = Callable[[Scenario, CampaignSettings, int, np.random.SeedSequence], dict]


def _failed(k: int, exc: BaseException, n_agents: int) -> tuple[int, str, str, dict]:
    return (k, STATUS_FAILED, f"{type(exc).__name__}: {exc}".splitlines()[0][:500], nan_record(n_agents))


def run_chunk(
    base: Scenario, settings: CampaignSettings, indices: Sequence[int], run_fn: RunFunction | None = None
) -> list[tuple[int, str, str, dict]]:
    """Runs ``indices``; each gives ``(index, status, message, record)``; a failing run does not stop the chunk.

    Without ``run_fn`` the chunk's runs fly together (:func:`fsmctl.simulation.simulator.simulate_many`: batches in
    one compiled loop, each run's results those of its run alone, bit for bit) and each gets :func:`run_record`;
    ``wall_time_s``/``cpu_time_s`` are then its own drawing and summary plus its share of the batch's flight.
    ``run_fn`` (e.g. :func:`run_one`) runs them one by one.
    """
    # Reaches only BLAS libraries loaded after this point (e.g. SciPy's, at the first linprog). The local
    # pool's workers get one thread from their environment at start (parallel.single_threaded_workers).
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    # run k's seed is SeedSequence(seed).spawn(runs)[k], built for this chunk's runs alone (spawning all the
    # campaign's seeds in every chunk would cost O(runs) per chunk)
    seeds = {k: child_seed(np.random.SeedSequence(settings.seed), k) for k in indices}
    if run_fn is not None:
        out = []
        for k in indices:
            try:
                out.append((k, STATUS_OK, "", run_fn(base, settings, k, seeds[k])))
            except Exception as exc:  # a failed run is reported in the dataset, never dropped
                out.append(_failed(k, exc, base.n_agents))
        return out
    return run_chunk_together(base, settings, indices, seeds)


def run_chunk_together(
    base: Scenario, settings: CampaignSettings, indices: Sequence[int], seeds: Mapping[int, np.random.SeedSequence]
) -> list[tuple[int, str, str, dict]]:
    from fsmctl.simulation.simulator import SimulationError, simulate_many

    rows: dict[int, tuple[int, str, str, dict]] = {}
    drawn: dict[int, Scenario] = {}
    own = {}  # per run: (wall, cpu) of its own work
    for k in indices:
        wall, cpu = time.perf_counter(), time.process_time()
        try:
            drawn[k] = sample_run_scenario(base, settings, seeds[k])
        except Exception as exc:
            rows[k] = _failed(k, exc, base.n_agents)
        own[k] = (time.perf_counter() - wall, time.process_time() - cpu)
    flying = list(drawn)
    wall, cpu = time.perf_counter(), time.process_time()
    try:
        results = simulate_many([drawn[k] for k in flying], errors="return")
    except Exception:  # not one run's failure (e.g. memory): one by one, so each run gets its own outcome
        return run_chunk(base, settings, indices, run_one)
    share = ((time.perf_counter() - wall) / max(1, len(flying)), (time.process_time() - cpu) / max(1, len(flying)))
    for k, result in zip(flying, results, strict=True):
        wall, cpu = time.perf_counter(), time.process_time()
        try:
            if isinstance(result, SimulationError):
                raise result
            rec = run_record(drawn[k], settings, seeds[k], result)
        except Exception as exc:  # a failed run is reported in the dataset, never dropped
            rows[k] = _failed(k, exc, base.n_agents)
            continue
        rec["wall_time_s"] = own[k][0] + share[0] + time.perf_counter() - wall
        rec["cpu_time_s"] = own[k][1] + share[1] + time.process_time() - cpu
        rows[k] = (k, STATUS_OK, "", rec)
    return [rows[k] for k in indices]
