"""fsmctl: spacecraft-formation attitude control laws, derivable (SymPy), provable, generated and fast to fly.

It started from Liang, Sun & Wang (2012), whose fast-sliding-mode law is built in. The package's folders are
its layers, and imports flow one way (``tests/test_layers.py`` enforces it):

* :mod:`fsmctl.cli`: the ``fsmctl`` command;
* :mod:`fsmctl.studies`: reproduction of the paper, law comparisons, Monte Carlo campaigns, figures;
* :mod:`fsmctl.simulation` (the compiled whole-loop simulator, :func:`simulate`), :mod:`fsmctl.proofs`
  (``fsmctl prove``) and :mod:`fsmctl.plugin` (python-control systems);
* :mod:`fsmctl.model`: scenarios, topologies, laws at run time, the generated code;
* :mod:`fsmctl.codegen`: SymPy -> CasADi -> C;
* :mod:`fsmctl.symbolic`: the symbolic model and the law API derivation scripts use (pure SymPy);
* :mod:`fsmctl.errors`, :mod:`fsmctl.outputs`: the error types and atomic output files everyone uses.

The top level holds what a user needs to build and fly a formation and take its results elsewhere: the scenario
types, :func:`simulate`, the result files (:func:`save_result`, :func:`load_result`, :func:`scenario_from_result`),
the laws (:func:`resolve_law`), and the python-control systems with their time response (:func:`formation`,
:func:`law_controller`, :class:`FormationResponse`, :func:`attitude_error_angle`, ...).  The studies (reproduction, comparisons, Monte Carlo,
tuning) keep their own namespace, :mod:`fsmctl.studies`, like the ``fsmctl`` subcommands they back.

``derive/`` (beside the package) holds the project's own derivation scripts: the model and the built-in laws.
"""

from __future__ import annotations

import lazy_loader

from fsmctl.model.scenario import (
    ActuatorSettings,
    Agent,
    ControllerSettings,
    GyroSettings,
    LinkSettings,
    Reference,
    Scenario,
    ScenarioError,
    SensorSettings,
    SimulationSettings,
    Sinusoid,
    StarTrackerSettings,
    WheelCommandSettings,
    load_scenario,
    paper_scenario,
)
from fsmctl.model.topology import Link, Schedule, Topology
from fsmctl.version import __version__

#: The modules whose ``__all__`` is the public API: the API reference (``docs/api/``) documents them and
#: ``tests/test_api_docs.py`` checks that every name in them has complete numpydoc with a running example.
_PUBLIC_MODULES = (
    "fsmctl",
    "fsmctl.symbolic",
    "fsmctl.codegen",
    "fsmctl.model",
    "fsmctl.simulation",
    "fsmctl.plugin",
    "fsmctl.proofs",
    "fsmctl.studies",
    "fsmctl.export",
    "fsmctl.errors",
    "fsmctl.outputs",
    "fsmctl.policy",
)

__all__ = [
    "__version__",
    "ActuatorSettings",
    "WheelCommandSettings",
    "Agent",
    "GyroSettings",
    "LinkSettings",
    "SensorSettings",
    "StarTrackerSettings",
    "SimulationError",
    "ControllerSettings",
    "Link",
    "Reference",
    "Scenario",
    "ScenarioError",
    "Schedule",
    "SimulationSettings",
    "Sinusoid",
    "Topology",
    "load_scenario",
    "paper_scenario",
    "simulate",
    "simulate_many",
    "SimulationResult",
    "StepSizeWarning",
    "save_result",
    "load_result",
    "scenario_from_result",
    # python-control (fsmctl.plugin): the formation, its pieces, and its time response
    "formation",
    "initial_state",
    "mrp_state",
    "spacecraft",
    "reference_generator",
    "law_controller",
    "fsm_controller",
    "Neighbour",
    "reaction_wheel_spacecraft",
    "reaction_wheel_state",
    "star_tracker",
    "rate_gyro",
    "link",
    "mrp_linearization",
    "mrp_estimator",
    "FormationResponse",
    "formation_response",
    "agent_color",
    "attitude_error_angle",
    "resolve_law",
    "builtin_laws",
]

# the CasADi-backed parts load on first use (keeps ``import fsmctl`` light): SPEC 1 lazy loading
__getattr__, _lazy_dir, _lazy_all = lazy_loader.attach(
    __name__,
    submod_attrs={
        "simulation.simulator": ["simulate", "simulate_many"],
        "simulation.result": ["SimulationResult"],
        "simulation.failures": ["SimulationError", "StepSizeWarning"],
        "simulation.results_io": ["save_result", "load_result", "scenario_from_result"],
        "simulation.metrics": ["attitude_error_angle"],
        "plugin.iosys": [
            "spacecraft",
            "fsm_controller",
            "law_controller",
            "Neighbour",
            "reference_generator",
        ],
        "plugin.states": ["initial_state", "mrp_state"],
        "plugin.hardware": ["reaction_wheel_spacecraft", "reaction_wheel_state"],
        "plugin.sensors": ["star_tracker", "rate_gyro", "link"],
        "plugin.formation": ["formation"],
        "plugin.linearization": ["mrp_linearization", "mrp_estimator"],
        "model.time_response": ["FormationResponse", "formation_response", "agent_color"],
        "model.laws": ["resolve_law", "builtin_laws"],
    },
)


def __dir__() -> list[str]:
    """The public names, eager and lazy (for tab completion and ``dir(fsmctl)``)."""
    return sorted(set(__all__) | set(_lazy_all))
