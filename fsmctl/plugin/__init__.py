"""The python-control plug-in: spacecraft, control laws, flight hardware and whole formations as I/O systems.

What a user of this layer calls:

* :func:`formation`: the closed loop of a scenario (:class:`FormationSystem`, a :class:`control.InterconnectedSystem`
  whose law parameters take their bare names in ``params``), with optional actuator and sensor blocks per agent;
  :func:`initial_state` and :func:`mrp_state` map its states to and from the scenario's MRPs;
* its pieces, to wire by hand: :func:`spacecraft`, :func:`reference_generator`, :func:`law_controller` (any law;
  :func:`fsm_controller` is the paper's, Liang et al. 2012, eqs 13-19) with its :class:`Neighbour` links, and
  :class:`ParameterizedSystem` (their parameter ownership);
* the flight hardware (:mod:`fsmctl.plugin.hardware`, :mod:`fsmctl.plugin.sensors`): :func:`reaction_wheel_spacecraft`, :func:`star_tracker`,
  :func:`rate_gyro`, :func:`link`;
* :func:`solver_options` (:mod:`fsmctl.plugin.solver`): the ``solve_ivp`` options of an accurate run;
* sampled-data loops (:mod:`fsmctl.plugin.sampled`): :func:`zoh`, :func:`discrete_law_controller`,
  :func:`discrete_fsm_controller`, and :func:`sampled_formation` (what :func:`formation` builds for a scenario
  with ``simulation.control_period > 0``; both in :mod:`fsmctl.plugin.formation`);
* exact linearization (:mod:`fsmctl.plugin.jacobians`, :mod:`fsmctl.plugin.linearization`): ``control.linearize``
  of every fsmctl system is exact, :func:`linearize` also for a plain ``control.interconnect``;
  :func:`mrp_linearization` and :func:`mrp_estimator` for an LQR design in MRP coordinates;
  :class:`NonDifferentiableError` where no linearization exists.

Their responses: :func:`fsmctl.formation_response` (a grouped ``plot()`` taking python-control's keywords) and
:func:`fsmctl.attitude_error_angle` (the angle between two ``sigma`` outputs, which jump at 180 deg), at the top
level of :mod:`fsmctl`.

Everything loads on first use (SPEC 1 lazy loading), so ``import fsmctl.plugin`` does not import CasADi or
python-control.
"""

from __future__ import annotations

import lazy_loader

_ATTRS = {
    "iosys": [
        "spacecraft",
        "reference_generator",
        "law_controller",
        "fsm_controller",
        "Neighbour",
        "quaternion_from_mrp",
        "mrp_from_quaternion",
    ],
    "states": ["initial_state", "mrp_state"],
    "system": ["ParameterizedSystem", "QuaternionNormWarning"],
    "parameters": ["law_parameter_values", "InvalidStateError", "ParameterKeyError"],
    "formation": ["formation", "sampled_formation"],
    "formation_system": ["FormationSystem"],
    "sampled": ["zoh", "discrete_law_controller", "discrete_fsm_controller"],
    "solver": ["solver_options"],
    "hardware": ["reaction_wheel_spacecraft", "reaction_wheel_state"],
    "sensors": ["star_tracker", "rate_gyro", "link"],
    "jacobians": ["NonDifferentiableError"],
    "linearization": ["linearize", "mrp_linearization", "mrp_estimator"],
}

__all__ = [name for names in _ATTRS.values() for name in names]

__getattr__, _lazy_dir, _lazy_all = lazy_loader.attach(__name__, submod_attrs=_ATTRS)


def __dir__() -> list[str]:
    """The public names, eager and lazy (for tab completion and ``dir(fsmctl.plugin)``)."""
    return sorted(set(__all__) | set(_lazy_all))
