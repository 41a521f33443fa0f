"""``fsmctl export --target fmu``: FMI 2.0 co-simulation FMUs of a controller and of the plant, checked with FMPy.

Oracles: FMPy's own validation of the FMUs (XML schema, variable names, model structure, start values, units); the
torque-free and constant-torque rotation of a rigid body about a principal axis (closed form) for the plant alone;
the PD law written out by hand (with eq 19's consensus sum over the neighbour slots) for the controller alone; the
engine's own run of the same single-spacecraft scenario with zero-order hold at the same control period for the
plant and controller flown together (bit for bit: the same generated C and the same arithmetic order).
"""

from __future__ import annotations

import zipfile

import fmpy
import numpy as np
import pytest
from fmpy.validation import validate_fmu

from fsmctl.export import CoSimulationError, FMUError, cosimulate, write_controller_fmu, write_plant_fmu
from fsmctl.export.c_library import ExportError
from fsmctl.model.generated_code import c_compiler
from fsmctl.model.problem import pack
from fsmctl.model.scenario import scenario_from_dict
from fsmctl.simulation import simulate

LAWS = ("fsm", "pid", "super_twisting", "adaptive_fsm", "fsm_event", "fsm_wheels", "docs/examples/my_law.py")

pytestmark = pytest.mark.skipif(c_compiler() is None, reason="no C compiler")


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("fmus")


@pytest.fixture(scope="module")
def plant(folder):
    return write_plant_fmu(folder / "plant.fmu", dt=0.001)


@pytest.fixture(scope="module")
def pid(folder):
    return write_controller_fmu("pid", folder / "pid.fmu", n_neighbours=2, control_period=0.01)


def _stem(law: str) -> str:
    return law.rsplit("/", 1)[-1].removesuffix(".py")


@pytest.mark.parametrize("law", LAWS)
def test_every_law_exports_a_valid_fmu(law, folder):
    fmu = write_controller_fmu(law, folder / f"{_stem(law)}.fmu", precision="float32" if law == "fsm" else "float64")
    assert validate_fmu(str(fmu)) == []
    md = fmpy.read_model_description(str(fmu))
    names = {v.name for v in md.modelVariables}
    assert {"torque[1]", "J0[3,3]", "control_period", "neighbour[5].k_sender"} <= names
    with zipfile.ZipFile(fmu) as z:
        files = set(z.namelist())
    assert f"binaries/linux64/{md.coSimulation.modelIdentifier}.so" in files
    assert {"modelDescription.xml", "sources/fmi2Functions.h", "sources/LICENSE-FMI.txt"} <= files


def test_plant_fmu_is_valid_and_reproducible(plant, folder):
    assert validate_fmu(str(plant)) == []
    again = write_plant_fmu(folder / "plant-again.fmu", dt=0.001)
    assert again.read_bytes() == plant.read_bytes()  # sorted entries, fixed dates, GUID from the sources
    other = write_plant_fmu(folder / "plant-other.fmu", dt=0.002)
    assert fmpy.read_model_description(str(other)).guid != fmpy.read_model_description(str(plant)).guid


def test_plant_alone_rotates_about_a_principal_axis(plant):
    """Diagonal J, spin w about z and a constant torque c about z: omega_z = w + c t / J33 and sigma = tan(theta/4) z
    with theta = w t + c t^2 / (2 J33) (closed form)."""
    J33, w, c = 200.0, 0.3, 0.5
    start = {"J[1,1]": 100.0, "J[2,2]": 150.0, "J[3,3]": J33, "omega0[3]": w, "disturbance_offset[3]": c}
    result = fmpy.simulate_fmu(str(plant), stop_time=2.0, output_interval=0.01, start_values=start)
    t = result["time"]
    theta = w * t + c * t**2 / (2 * J33)
    np.testing.assert_allclose(result["sigma[3]"], np.tan(theta / 4), rtol=0, atol=1e-12)
    np.testing.assert_allclose(result["omega[3]"], w + c * t / J33, rtol=0, atol=1e-12)
    assert np.all(result["sigma[1]"] == 0) and np.all(result["omega[2]"] == 0)


def test_controller_alone_is_the_pd_law_with_its_neighbours(pid):
    """pid (Ki = 0) at rest reference, exact error kinematics: u = -K sigma - P omega - k_c sum_j k^j (sigma - b_j);
    a slot with both weights 0 adds nothing."""
    rng = np.random.default_rng(7)
    sigma, omega, b = rng.uniform(-0.05, 0.05, 3), rng.uniform(-0.01, 0.01, 3), rng.uniform(-0.05, 0.05, (2, 3))
    K, P, kc, k_sender = 20.0, 40.0, 0.3, 5.0
    start = {"K": K, "P": P, "k_coupling": kc, "J0[1,1]": 100.0, "J0[2,2]": 150.0, "J0[3,3]": 200.0}
    start |= {f"sigma[{k + 1}]": sigma[k] for k in range(3)} | {f"omega[{k + 1}]": omega[k] for k in range(3)}
    start |= {f"neighbour[1].broadcast[{k + 1}]": b[0, k] for k in range(3)}
    start |= {f"neighbour[2].broadcast[{k + 1}]": b[1, k] for k in range(3)}  # slot 2: weights 0, no link
    start |= {"neighbour[1].k_own": 8.0, "neighbour[1].k_sender": k_sender}
    result = fmpy.simulate_fmu(str(pid), stop_time=0.1, output_interval=0.01, start_values=start)
    expected = -K * sigma - P * omega - kc * k_sender * (sigma - b[0])
    torque = np.column_stack([result[f"torque[{k + 1}]"] for k in range(3)])
    np.testing.assert_allclose(torque[1:], np.broadcast_to(expected, (len(torque) - 1, 3)), rtol=1e-12, atol=1e-15)
    broadcast = np.column_stack([result[f"broadcast[{k + 1}]"] for k in range(3)])
    np.testing.assert_array_equal(broadcast[1:], np.broadcast_to(sigma, (len(broadcast) - 1, 3)))


def _scenario(law: str, error_model: str):
    """One spacecraft, reference at rest, the paper's agent 1 with its disturbance and dJ = 0.3 J0, 2 N m limit."""
    return scenario_from_dict({
        "name": "single",
        "simulation": {"t_final": 2.0, "dt": 0.001, "output_interval": 0.01, "control_period": 0.01},
        "controller": {"law": law, "torque_limit": 2.0, "error_model": error_model, "delta_J": {"scale": 0.3}},
        "reference": {"sigma0": [0.0, 0.0, 0.0], "omega": {"amplitude": [0.0, 0.0, 0.0]}},
        "topology": {"links": []},
        "agents": [{
            "J0": [[100.0, 1.0, 2.0], [1.0, 150.0, 1.0], [2.0, 1.0, 200.0]],
            "sigma0": [0.3, 0.2, -0.3],
            "omega0": [0.35, -0.13, 0.27],
            "disturbance": {"amplitude": [0.2, -0.24, 0.22], "frequency": [0.1, 0.15, 0.12],
                            "phase": [1.0, 1.0, 1.0], "kind": ["cos", "sin", "cos"]},
        }],
    })  # fmt: skip


def _fmu_parameters(scenario):
    """The packed problem's numbers as the two FMUs' parameters (the law state over hold_steps engine steps)."""
    p = pack(scenario)
    plant = {"J": p.J_true[0], "sigma0": scenario.agents[0].sigma0, "omega0": scenario.agents[0].omega0, "dt": p.dt}
    for j, name in enumerate(("amplitude", "frequency", "phase", "offset")):
        plant[f"disturbance_{name}"] = p.dist_params[0, 3 * j : 3 * j + 3]
    controller, k = {}, 0
    for parameter in p.law.parameters:
        controller[parameter.name], k = p.params[0, k : k + parameter.size], k + parameter.size
    controller |= {"J0": p.J0[0], "torque_limit": p.u_max[0], "control_period": p.dt}
    controller["law_state_substeps"] = p.hold_steps
    return plant, controller


@pytest.mark.parametrize(("law", "error_model"), [("pid", "exact"), ("fsm", "paper"), ("adaptive_fsm", "exact")])
def test_plant_and_controller_fly_as_the_engine(law, error_model, plant, folder):
    scenario = _scenario(law, error_model)
    reference = simulate(scenario, progress=False)
    controller = write_controller_fmu(law, folder / f"{law}-{error_model}.fmu", error_model=error_model, n_neighbours=0)
    plant_parameters, controller_parameters = _fmu_parameters(scenario)
    run = cosimulate(plant, controller, t_final=2.0, step=0.01, plant_parameters=plant_parameters,
                     controller_parameters=controller_parameters)  # fmt: skip
    np.testing.assert_array_equal(run.time, reference.time)
    # bit for bit: the same generated C, the same RK4 arithmetic, the same hold
    np.testing.assert_array_equal(run.sigma, reference.sigma[:, 0])
    np.testing.assert_array_equal(run.omega, reference.omega[:, 0])
    np.testing.assert_array_equal(run.torque, reference.u[:-1, 0])
    np.testing.assert_array_equal(run.z, reference.z[1:, 0])
    assert np.max(np.abs(run.torque)) == 2.0  # the limit was flown


def test_bad_options_are_one_line_input_errors(plant, pid, folder):
    with pytest.raises(FMUError, match="n_neighbours: must be an integer >= 0"):
        write_controller_fmu("pid", folder / "x.fmu", n_neighbours=-1)
    with pytest.raises(FMUError, match="dt: must be a finite number > 0"):
        write_plant_fmu(folder / "x.fmu", dt=0.0)
    with pytest.raises(FMUError, match="inertia: must be 9 finite numbers"):
        write_plant_fmu(folder / "x.fmu", inertia=np.eye(2))
    with pytest.raises(ExportError, match="precision"):
        write_controller_fmu("pid", folder / "x.fmu", precision="float16")
    with pytest.raises(FMUError, match="multiple of step"):
        cosimulate(plant, pid, t_final=1.005, step=0.01)
    with pytest.raises(FMUError, match="has no variable 'gain'"):
        cosimulate(plant, pid, t_final=0.1, step=0.01, controller_parameters={"gain": 1.0})
    assert not (folder / "x.fmu").exists()


@pytest.mark.parametrize(
    ("plant_parameters", "controller_parameters", "step", "reason"),
    [
        ({"J": np.diag([1.0, -1.0, 1.0])}, {}, 0.01, "plant.fmu: exitInitializationMode failed: J: must be finite"),
        ({}, {"K": -1.0}, 0.01, "pid.fmu: exitInitializationMode failed: K: must be 0 < x"),
        (
            {},
            {},
            0.02,
            "pid.fmu: doStep failed: doStep: the step size must be control_period * law_state_substeps = "
            "0.01 s (one control instant per step), got 0.02 s",
        ),
        (
            {"dt": 0.003},
            {},
            0.01,
            "plant.fmu: doStep failed: doStep: the step size must be a positive multiple of the "
            "internal step dt = 0.003 s, got 0.01 s",
        ),
    ],
)
def test_a_refused_call_reports_the_fmu_reason(plant, pid, plant_parameters, controller_parameters, step, reason):
    controller_parameters = {"J0": 100 * np.eye(3), **controller_parameters}
    with pytest.raises(CoSimulationError) as caught:
        cosimulate(plant, pid, t_final=0.04, step=step, plant_parameters=plant_parameters,
                   controller_parameters=controller_parameters)  # fmt: skip
    assert str(caught.value).startswith(reason) and "\n" not in str(caught.value)
