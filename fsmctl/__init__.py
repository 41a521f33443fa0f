"""fsmctl: the fast-sliding-mode formation attitude controller of Liang, Sun & Wang (2012), derivable, provable, fast.

* :mod:`derive` (top-level package) holds the symbolic model and writes ``generated/``;
* :mod:`fsmctl.scenario`, :mod:`fsmctl.topology`: typed scenarios (the paper's Section 4 is built in);
* :mod:`fsmctl.simulator`: the compiled whole-loop simulator (:func:`simulate`);
* :mod:`fsmctl.iosys`: python-control factories (:func:`spacecraft`, :func:`fsm_controller`, :func:`formation`);
* :mod:`fsmctl.proofs`: the proof check behind ``fsmctl prove``;
* :mod:`fsmctl.cli`: the ``fsmctl`` command.
"""

from __future__ import annotations

__version__ = "0.1.0"

from .scenario import (
    Agent,
    ControllerSettings,
    Reference,
    Scenario,
    ScenarioError,
    SimulationSettings,
    Sinusoid,
    load_scenario,
    paper_scenario,
)
from .topology import Link, Schedule, Topology

__all__ = [
    "__version__",
    "Agent",
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
    "SimulationResult",
    "StepSizeWarning",
    "spacecraft",
    "fsm_controller",
    "reference_generator",
    "formation",
]

_LAZY = {
    "simulate": "simulator",
    "SimulationResult": "simulator",
    "StepSizeWarning": "simulator",
    "spacecraft": "iosys",
    "fsm_controller": "iosys",
    "reference_generator": "iosys",
    "formation": "iosys",
}


def __getattr__(name: str):
    """Import the CasADi-backed parts on first use (keeps ``import fsmctl`` light)."""
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module 'fsmctl' has no attribute {name!r}")
