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

import lazy_loader

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
    "fsmctl.errors",
    "fsmctl.outputs",
)

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

# the CasADi-backed parts load on first use (keeps ``import fsmctl`` light): SPEC 1 lazy loading
__getattr__, _lazy_dir, _lazy_all = lazy_loader.attach(
    __name__,
    submod_attrs={
        "simulation.simulator": ["simulate", "simulate_many", "SimulationResult", "SimulationError", "StepSizeWarning"],
        "plugin.iosys": ["spacecraft", "fsm_controller", "reference_generator", "formation", "initial_state"],
        "plugin.hardware": ["reaction_wheel_spacecraft", "star_tracker", "rate_gyro", "link"],
        "model.laws": ["resolve_law", "builtin_laws"],
    },
)


def __dir__() -> list[str]:
    """The public names, eager and lazy (for tab completion and ``dir(fsmctl)``)."""
    return sorted(set(__all__) | set(_lazy_all))
