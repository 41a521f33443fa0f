"""The solver options of an accurate python-control run of a formation (issue 24).

The oracle is the compiled simulator (RK4 at the scenario's 1 ms step).  On Case 1, 2 s, python-control's
defaults (RK45, rtol 1e-3, no step bound) step across the torque clip and end ~1e-2 away (2.8 deg after 10 s);
with :func:`solver_options` the two agree to both integrators' error (measured 2.2e-6 in sigma here, 2.6e-3 with the defaults).
"""

from __future__ import annotations

import control as ct
import numpy as np
import pytest

import fsmctl
from fsmctl.errors import InputError
from fsmctl.plugin import ParameterKeyError, solver_options


def _final_sigma_error(loop, s, **options):
    r = ct.input_output_response(loop, [0.0, s.simulation.t_final], 0, fsmctl.initial_state(s), **options)
    labels = list(loop.output_labels)
    rows = [labels.index(f"sc{i}_sigma[{k}]") for i in range(1, s.n_agents + 1) for k in range(3)]
    return np.abs(r.outputs[rows, -1] - fsmctl.simulate(s).sigma[-1].ravel()).max()


def test_the_options_make_python_control_agree_with_the_compiled_simulator():
    s = fsmctl.paper_scenario("1").replace(simulation={"t_final": 2.0})
    loop = fsmctl.formation(s)
    assert _final_sigma_error(loop, s, **solver_options(loop)) < 1e-5
    assert _final_sigma_error(loop, s) > 1e-3  # python-control's defaults: what the options are for


def test_the_step_bound_follows_what_the_loop_declares():
    paper = fsmctl.paper_scenario("1")
    bounded = {"solve_ivp_method": "RK45", "solve_ivp_kwargs": {"max_step": paper.simulation.dt}}
    assert solver_options(paper) == bounded  # torque clip
    smooth = paper.replace(controller={"torque_limit": float("inf"), "boundary_layer": 0.05})
    tolerances = {"solve_ivp_method": "RK45", "solve_ivp_kwargs": {"rtol": 1e-8, "atol": 1e-10}}
    assert solver_options(smooth) == tolerances
    assert solver_options(smooth.replace(controller={"boundary_layer": 0.0})) == bounded  # declared sgn
    loop = fsmctl.formation(smooth)
    assert solver_options(loop) == tolerances
    assert solver_options(loop, params={"boundary_layer": 0.0}) == bounded  # the flown value, by its bare name
    assert solver_options(loop, params={"ctrl3_u_max": 1.0}) == bounded  # one agent clipped
    assert solver_options(loop) == tolerances  # params= did not stick
    wheels = smooth.replace(actuator={"kind": "reaction_wheels", "spin_inertia": 0.159, "max_torque": 0.2})
    assert solver_options(wheels) == bounded
    assert solver_options(fsmctl.formation(paper.replace(simulation={"control_period": 0.1}))) == {}


def test_bad_arguments_are_one_line_errors():
    loop = fsmctl.formation(fsmctl.paper_scenario("1"))
    with pytest.raises(ParameterKeyError, match="C1"):
        solver_options(loop, params={"C1": 1.0})
    with pytest.raises(InputError, match="formation"):
        solver_options(fsmctl.spacecraft(np.eye(3)))
    with pytest.raises(InputError, match="boundary_layer"):
        solver_options(loop, params={"boundary_layer": -1.0})
