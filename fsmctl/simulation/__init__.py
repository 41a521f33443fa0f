"""The compiled whole-loop simulator, its metrics and its result files.

* :func:`simulate` / :func:`simulate_many` fly a :class:`~fsmctl.model.scenario.Scenario` (the generated C, the
  whole time loop compiled; CasADi's virtual machine without a compiler) and return a :class:`SimulationResult`;
* the metrics of Liang et al. (2012), eqs 42-43: :func:`aaem_deg`, :func:`raem_deg`, from the principal angles
  :func:`principal_angles` / :func:`relative_principal_angles`, and :func:`settling_time`; the same angle between
  any two MRP signals, :func:`attitude_error_angle` (it does not jump where sigma switches to its shadow set);
* result files (:mod:`fsmctl.simulation.results_io`): :meth:`SimulationResult.save` writes NetCDF or CSV with the
  run's provenance (:func:`provenance`), :func:`load_result` reads them, :func:`scenario_from_result` re-runs one.

The names load on first use (SPEC 1 lazy loading): importing the package does not load CasADi.
"""

from __future__ import annotations

import lazy_loader

_ATTRS = {
    "simulator": ["simulate", "simulate_many"],
    "result": ["SimulationResult"],
    "failures": ["SimulationError", "ZenoError", "StepSizeWarning", "DiscontinuousControlWarning"],
    "messages": ["periodic_messages", "MESSAGE_FIELDS", "message_metrics", "MESSAGE_METRICS"],
    "step_size": ["step_size_report"],
    "driver": ["ExternalController", "lane_width"],
    "metrics": [
        "principal_angles",
        "relative_principal_angles",
        "attitude_error_angle",
        "aaem_deg",
        "raem_deg",
        "settling_time",
    ],
    "results_io": [
        "save_result",
        "write_netcdf",
        "load_result",
        "scenario_from_result",
        "provenance",
        "versions",
        "csv_column_names",
        "ResultFileError",
        "NotAResultError",
        "MissingScenarioError",
        "LawChangedError",
    ],
}

__all__ = [name for names in _ATTRS.values() for name in names]

__getattr__, _lazy_dir, _lazy_all = lazy_loader.attach(__name__, submod_attrs=_ATTRS)


def __dir__() -> list[str]:
    """The public names, eager and lazy (for tab completion and ``dir(fsmctl.simulation)``)."""
    return sorted(set(__all__) | set(_lazy_all))
