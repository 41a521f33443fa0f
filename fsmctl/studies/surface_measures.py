"""What ``fsmctl compare-surfaces`` measures on each full-loop run (Liang et al. 2012, Theorem 3, eqs 34-41).

Per agent (:func:`_agent_rows`, the law comparison's ``on_result`` hook): the reaching time (first ``||s_i|| <=``
the threshold), the settling time (every ``|sigma_ei,k|`` within the tolerance for good), the sliding-phase time
between them and Theorem 3's prediction of it from ``sigma_e`` at reaching (the closed forms of
:mod:`fsmctl.studies.theorem3`), the control effort and the saturated time.  Per run (:func:`_run_row`): the run's
:class:`~fsmctl.studies.records.RunRecord` metrics under the surface comparison's names, and the means over the
agents.  :mod:`fsmctl.studies.surfaces` is the study that flies the runs.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from fsmctl.studies.records import RunRecord
    from fsmctl.studies.surfaces import Variant

__all__ = ["SURFACES"]

SURFACES = ("fsm", "tsm", "lsm")
"""The sliding surfaces compared (the ``surface`` preset of the paper's law)."""

_trapezoid = getattr(np, "trapezoid", None) or np.trapz  # noqa: NPY201 (NumPy < 2 has only trapz)


def _first_time_below(time_s: np.ndarray, values: np.ndarray, threshold: float) -> float:
    idx = np.nonzero(values <= threshold)[0]
    return float(time_s[idx[0]]) if idx.size else math.nan


def _settling(time_s: np.ndarray, values: np.ndarray, threshold: float) -> float:
    from fsmctl.simulation.metrics import settling_time

    return settling_time(time_s, values, threshold)


def _predicted_sliding_time(surface: str, sigma_e: np.ndarray, tol: float, p: dict) -> float:
    """Theorem 3 (eqs 34-36): time for every component to reach ``|x| <= tol`` on the ideal sliding mode.

    ``p``: the agent's law parameters as flown (``c1``, ``c2``, ``alpha``; the surface's preset applied)."""
    from fsmctl.studies.theorem3 import closed_form_settling_time

    times = [
        closed_form_settling_time(surface, float(x), tol, p["c1"], p["c2"], p["alpha"])
        for x in sigma_e
        if abs(float(x)) > tol
    ]
    return max(times, default=0.0)


def _agent_rows(result, surface: str, variant: Variant, opts: dict) -> list[dict]:
    """Per agent: reaching, settling and sliding-phase times, Theorem 3's prediction, effort, saturated time.

    Called by :func:`fsmctl.studies.compare.compare_laws` with each finished run (its ``on_result`` hook)."""
    t = result.time
    flown = result.scenario.law_parameters()
    s_norm = np.linalg.norm(result.s, axis=2)
    sig_max = np.max(np.abs(result.sigma_e), axis=2)
    abs_u = np.sum(np.abs(result.u), axis=2)
    effort = _trapezoid(abs_u, t, axis=0)
    agents = []
    for i in range(result.n_agents):
        reach = _first_time_below(t, s_norm[:, i], opts["reach_threshold"])
        settle = _settling(t, sig_max[:, i], opts["sigma_tolerance"])
        if math.isfinite(reach):
            k = int(np.searchsorted(t, reach))
            predicted = _predicted_sliding_time(surface, result.sigma_e[k, i], opts["sigma_tolerance"], flown[i])
        else:
            predicted = math.nan
        agents.append(
            {
                "variant": variant.name,
                "surface": surface,
                "agent": i + 1,
                "reaching_time_s": reach,
                "settling_time_s": settle,
                "sliding_phase_time_s": settle - reach,
                "sliding_phase_theorem3_s": predicted,
                "control_effort_N_m_s": float(effort[i]),
                "saturated_time_s": float(result.saturated_time[i]),
            }
        )
    return agents


def _run_row(record: RunRecord, agents: list[dict], variant: Variant, t_final: float, opts: dict) -> dict:
    """One run of the comparison: its record's metrics (:func:`fsmctl.studies.compare.run_metrics`, the record of
    the surface's run in the variant's law comparison) under this module's names, and the means over the agents."""
    tol = f"{opts['metric_tolerance_deg']:g}"
    row, surface = record.metrics, record.key
    return {
        "variant": variant.name,
        "surface": surface,
        "torque_limit": variant.torque_limit,
        "uncertainty": variant.uncertainty,
        "coupling": variant.coupling,
        "t_final_s": float(t_final),
        "aaem_settling_s": row[f"aaem_settling_{tol}deg_s"],
        "raem_settling_s": row[f"raem_settling_{tol}deg_s"],
        "aaem_steady_max_deg": row["aaem_steady_max_deg"],
        "raem_steady_max_deg": row["raem_steady_max_deg"],
        # the means are NaN (= not reached: infinitely slow for the verdicts) unless every agent gets there
        "n_agents": len(agents),
        "agents_reached": int(sum(math.isfinite(a["reaching_time_s"]) for a in agents)),
        "agents_settled": int(sum(math.isfinite(a["settling_time_s"]) for a in agents)),
        "mean_reaching_time_s": float(np.mean([a["reaching_time_s"] for a in agents])),
        "mean_sliding_phase_time_s": float(np.mean([a["sliding_phase_time_s"] for a in agents])),
        "mean_sliding_phase_theorem3_s": float(np.mean([a["sliding_phase_theorem3_s"] for a in agents])),
        "control_effort_N_m_s": row["control_effort_N_m_s"],
        "u_unsaturated_max_N_m": row["peak_commanded_torque_N_m"],
        "max_saturated_time_s": row["saturated_time_max_s"],
        "wall_time_s": row["wall_time_s"],
    }
