"""Studies built on the simulator: the paper's Section 4 reproduced, law comparisons, Theorem 3, Monte Carlo, tuning.

What a user of this layer calls:

* reproduction of Liang et al. (2012), Section 4 (:mod:`fsmctl.studies.reproduce`: the function
  ``fsmctl.studies.reproduce.reproduce``; its run plan :func:`run_plan`, the record of a run :class:`RunRecord`, the
  claims registry :data:`CLAIMS` and :func:`evaluate_claims`, the report :class:`Reproduction`) and what would
  reproduce each claim (:mod:`fsmctl.studies.explain`: ``fsmctl.studies.explain.explain``, :class:`Explanation`);
* comparisons: laws on one scenario (:func:`compare_laws`), sliding surfaces (:func:`compare_surfaces`),
  Theorem 3's settling time (:func:`closed_form_settling_time`, :func:`scalar_settling_study`);
* campaigns: Monte Carlo (:class:`CampaignSettings`, :func:`run_campaign`) and gain tuning
  (:mod:`fsmctl.studies.tune`: ``fsmctl.studies.tune.tune``, :class:`TuneSettings`, :func:`search_space`);
* what the wheels allow (:func:`momentum_budget`, :func:`torque_demand`) and the figures of a run
  (:func:`simulation_figures`, :func:`metric_figure`, ...).

The three entry points named like their modules (``reproduce``, ``explain``, ``tune``) are not re-exported here:
``fsmctl.studies.tune`` is the module (``from fsmctl.studies import tune`` keeps meaning the module); call
``fsmctl.studies.tune.tune(...)``.  Everything loads on first use (SPEC 1 lazy loading).
"""

from __future__ import annotations

import lazy_loader

_ATTRS = {
    "compare": ["compare_laws", "Comparison", "run_metrics", "metric_columns"],
    "compare_runs": ["LawRun"],
    "surfaces": ["compare_surfaces", "SurfaceComparison", "Variant", "default_variants"],
    "theorem3": [
        "closed_form_settling_time",
        "measure_settling_time",
        "SettlingTimeMeasurement",
        "SettlingTimeInputError",
        "scalar_settling_study",
        "ScalarStudy",
        "ScalarGrid",
        "fast_grid",
    ],
    "montecarlo": ["CampaignSettings", "CampaignResult", "run_campaign", "CampaignInterrupted"],
    "hardware": ["momentum_budget", "WheelBudget", "torque_demand", "TorqueDemand", "momentum_envelope"],
    "tune": ["TuneSettings", "TuneResult", "SearchParameter", "search_space", "available_constraints"],
    "explain_report": ["Explanation", "Evidence"],
    "explain_settings": ["Setting"],
    "figures": [
        "MAX_AGENTS_DRAWN",
        "METRIC_EQUATIONS",
        "COMPONENT_STYLES",
        "RUN_COLORS",
        "metric_figure",
        "principal_angles_figure",
        "torques_figure",
        "overlay_figure",
        "simulation_figures",
        "save_figure",
    ],
    "paper_runs": [
        "PAPER_CASES",
        "RunSpec",
        "run_plan",
        "load_case",
        "run_scenario",
        "run_record",
        "execute_run",
    ],
    "records": ["RunRecord", "scenario_fingerprint"],
    "momentum": ["MomentumBound", "reference_trajectory", "angular_momentum_bound"],
    "claim_types": [
        "REPRODUCED",
        "DIFFERS",
        "IMPOSSIBLE",
        "VERDICTS",
        "PAPER_SETTLING_TIME_S",
        "StudyClaim",
        "ClaimVerdict",
    ],
    "claims": ["CLAIMS", "claim_ids", "get_claim", "evaluate_claims"],
    "figure_checks": ["FIGURE_CHECKS", "FigureCheck"],
    "reproduce": ["overlay_figures"],
    "report": ["Reproduction", "write_outputs", "to_markdown", "to_html"],
    "report_text": ["format_claims"],
}

__all__ = [name for names in _ATTRS.values() for name in names]

# the modules named like their entry points are reachable as attributes too (``fsmctl.studies.tune.tune(...)``)
__getattr__, _lazy_dir, _lazy_all = lazy_loader.attach(
    __name__, submodules=["explain", "reproduce", "tune"], submod_attrs=_ATTRS
)


def __dir__() -> list[str]:
    """The public names, eager and lazy (for tab completion and ``dir(fsmctl.studies)``)."""
    return sorted(set(__all__) | set(_lazy_all))
