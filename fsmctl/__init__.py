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

``derive/`` (beside the package) holds the project's own derivation scripts: the model and the built-in laws.
"""

from __future__ import annotations

__version__ = "0.1.0"

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
    load_scenario,
    paper_scenario,
)
from fsmctl.model.topology import Link, Schedule, Topology

__all__ = [
    "__version__",
    "ActuatorSettings",
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
    "spacecraft",
    "fsm_controller",
    "reference_generator",
    "formation",
    "initial_state",
    "reaction_wheel_spacecraft",
    "star_tracker",
    "rate_gyro",
    "link",
    "resolve_law",
    "builtin_laws",
]

_LAZY = {
    "simulate": "fsmctl.simulation.simulator",
    "simulate_many": "fsmctl.simulation.simulator",
    "SimulationResult": "fsmctl.simulation.simulator",
    "SimulationError": "fsmctl.simulation.simulator",
    "StepSizeWarning": "fsmctl.simulation.simulator",
    "spacecraft": "fsmctl.plugin.iosys",
    "fsm_controller": "fsmctl.plugin.iosys",
    "reference_generator": "fsmctl.plugin.iosys",
    "formation": "fsmctl.plugin.iosys",
    "initial_state": "fsmctl.plugin.iosys",
    "reaction_wheel_spacecraft": "fsmctl.plugin.hardware",
    "star_tracker": "fsmctl.plugin.hardware",
    "rate_gyro": "fsmctl.plugin.hardware",
    "link": "fsmctl.plugin.hardware",
    "resolve_law": "fsmctl.model.laws",
    "builtin_laws": "fsmctl.model.laws",
}


def __getattr__(name: str):
    """Import the CasADi-backed parts on first use (keeps ``import fsmctl`` light)."""
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'fsmctl' has no attribute {name!r}")
