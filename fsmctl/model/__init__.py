"""The runtime model: scenarios, topologies, laws at run time, hardware and noise, and the generated code.

What a user of this layer calls:

* scenarios (TOML files, the paper's cases): :class:`Scenario`, :func:`load_scenario`, :func:`paper_scenario` and
  their settings classes (:mod:`fsmctl.model.scenario`), the JSON Schema of the file (:func:`file_schema`);
* communication graphs (Liang et al. 2012, Assumption 1; switching schedules): :class:`Topology`, :class:`Link`,
  :class:`Schedule`, :func:`ring`, :func:`k_nearest`, :func:`all_to_all`, :func:`from_phase_table`;
* laws at run time (built-in, derived folders, derivation scripts): :func:`resolve_law`, :func:`builtin_laws`,
  :class:`LawCode`, :func:`parameter_matrix`; the formation aggregation rule (eq 13): :func:`aggregate`;
* attitude conversions (MRP <-> quaternion), the wheel torque distribution and the sensor noise of a run;
* the generated code: :func:`backend`, :func:`compiled_library` (compiled once, then cached; the first compile logs
  one INFO record on the ``"fsmctl"`` logger);
* simulated formations as python-control time responses (:class:`FormationResponse`, :func:`formation_response`)
  and the colour each agent has in every figure (:func:`agent_color`).

Everything loads on first use (SPEC 1 lazy loading), so ``import fsmctl.model`` stays light.
"""

from __future__ import annotations

import lazy_loader

_ATTRS = {
    "scenario": [
        "Scenario",
        "ScenarioError",
        "InertiaWarning",
        "UncoupledTopologyWarning",
        "Agent",
        "Sinusoid",
        "Reference",
        "ControllerSettings",
        "SimulationSettings",
        "ActuatorSettings",
        "WheelCommandSettings",
        "StarTrackerSettings",
        "GyroSettings",
        "SensorSettings",
        "LinkSettings",
        "load_scenario",
        "paper_scenario",
        "scenario_from_dict",
        "check_inertia",
        "BUILTIN_SCENARIOS",
    ],
    "scenario_schema": ["file_schema"],
    "topology": [
        "Topology",
        "TopologyError",
        "Link",
        "Schedule",
        "ring",
        "k_nearest",
        "all_to_all",
        "from_phase_table",
        "schedule_weight",
    ],
    "laws": [
        "LawCode",
        "LawDiscontinuity",
        "LawError",
        "LawPaperTheorems",
        "LawParameterInfo",
        "LawPresetGroup",
        "LawTrigger",
        "LawSwitchWarning",
        "builtin_laws",
        "resolve_law",
        "parameter_matrix",
        "written_keys",
        "carried_keys",
        "check_written_parameters",
    ],
    "coupling": ["aggregate"],
    "attitude": ["quaternion_from_mrp", "mrp_from_quaternion"],
    "actuators": [
        "spin_inertia_matrix",
        "distribution_matrix",
        "distribute",
        "max_body_torque",
        "ALLOCATIONS",
        "SPEED_GATES",
        "sample_wheel_commands",
    ],
    "noise": ["hardware_noise", "allan_deviation", "random_walk_coefficients"],
    "generated_paths": ["generated_dir", "GeneratedCodeError"],
    "generated_code": [
        "backend",
        "compiled_library",
        "CompilerUnavailableWarning",
        "LibraryCacheWarning",
    ],
    "time_response": ["FormationResponse", "formation_response", "agent_color"],
}

__all__ = [name for names in _ATTRS.values() for name in names]

__getattr__, _lazy_dir, _lazy_all = lazy_loader.attach(__name__, submod_attrs=_ATTRS)


def __dir__() -> list[str]:
    """The public names, eager and lazy (for tab completion and ``dir(fsmctl.model)``)."""
    return sorted(set(__all__) | set(_lazy_all))
