"""The scenario reference page and JSON Schema are generated from the validating types, current, and agree with them."""

from __future__ import annotations

import dataclasses
import math
import tomllib
from pathlib import Path

import jsonschema
import pytest

import fsmctl
from fsmctl.model import scenario as sc
from fsmctl.model.scenario_schema import REFERENCE_PATH, ROOT, file_schema, main, shipped_schema

PAPER_TOML = (Path(fsmctl.__file__).parent / "scenarios" / "paper.toml").read_text()


def test_generated_files_are_current():
    assert main(["--check"]) == 0, "run `python -m fsmctl.model.scenario_schema`"


def test_shipped_schema_is_the_generated_one():
    assert shipped_schema() == file_schema()


def test_paper_scenario_file_is_valid_under_the_schema():
    jsonschema.Draft202012Validator.check_schema(file_schema())
    jsonschema.validate(tomllib.loads(PAPER_TOML), file_schema(), cls=jsonschema.Draft202012Validator)


@pytest.mark.parametrize(
    ("old", "new"),
    [
        ('integrator = "rk4"', 'integrator = "euler"'),
        ("c1 = 0.6 ", 'c1 = "0.6" '),
        ("alpha = 0.7 ", "alpha = 1.2 "),
        ("sigma0 = [0.3, 0.2, -0.3]", "sigma0 = [0.3, 0.2]"),
        ("dt = 0.001 ", "dt = 0.0 "),
        ('integrator = "rk4"', 'integrator = "rk4"\ngain = 3'),  # [simulation] has no extra keys
        ('surface = "fsm"', 'surface = "fsm"\nparameters = { gain = true }'),  # a law parameter is no bool
    ],
)
def test_schema_and_loader_reject_the_same_bad_values(tmp_path, old, new):
    """An editor using the schema and fsmctl's loader agree on what is wrong (two independent checkers)."""
    text = PAPER_TOML.replace(old, new, 1)
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(tomllib.loads(text), file_schema(), cls=jsonschema.Draft202012Validator)
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(sc.ScenarioError):
        sc.load_scenario(path)


def test_reference_page_documents_every_key_with_unit_and_default():
    page = (ROOT / REFERENCE_PATH).read_text()
    for cls, prefix in (
        (sc.SimulationSettings, "simulation."),
        (sc.ControllerSettings, "controller."),
        (sc.Agent, "agents[i]."),
        (sc.Reference, "reference."),
    ):
        for f in dataclasses.fields(cls):
            assert f"`{prefix}{f.name}`" in page, f"{prefix}{f.name} missing from {REFERENCE_PATH}"
    assert "| `simulation.dt` | number (> 0) | s | `0.001` |" in page
    from fsmctl.model import builtin_laws

    for name, law in builtin_laws().items():  # every built-in law's declared parameters, with range and default
        section = page.split(f'### `law = "{name}"`')[1].split("###")[0]
        for p in law.parameters:
            assert f"| `{p.name}` | {p.default_text()} | {p.unit} | {p.range_text()} |" in section
    assert '| `controller.law` | string |  | `"fsm"` |' in page
    # defaults in the page are the dataclasses' defaults
    assert sc.SimulationSettings().dt == 0.001 and math.isinf(sc.ControllerSettings().torque_limit)


# ----------------------------------------------------------------------------- hardware sections (issue 13)

_ROW = "[{}]".format(", ".join(["0.1"] * 6))
_LOSS_ROW = "[{}]".format(", ".join(["0.05"] * 6))
HARDWARE_TOML = PAPER_TOML.replace("control_period = 0.0 ", "control_period = 0.1 \nseed = 42 ", 1) + (
    f"""
[actuator]
kind = "reaction_wheels"
layout = "pyramid"
pyramid_angle = 60.0
spin_inertia = [0.1, 0.1, 0.12, 0.1]
max_torque = 0.2
max_speed = "inf"
viscous_friction = 1e-5
coulomb_friction = [2e-3, 2e-3, 2e-3, 2e-3]
coulomb_band = 0.5
initial_speed = 0.0

[sensors.star_tracker]
noise_std = [2.4e-5, 2.4e-5, 4.8e-5]

[sensors.gyro]
angle_random_walk = 4.4e-5
rate_random_walk = 1.6e-7
bias = [4.8e-6, -4.8e-6, 2.4e-6]

[links]
delay = 0.1
loss_probability = 0.05
delay_table = [{", ".join([_ROW] * 6)}]
loss_table = [{", ".join([_LOSS_ROW] * 6)}]

[cases."custom-wheels"]
description = "three orthogonal wheels and a skewed fourth, no gyro noise, no packet loss"
actuator = {{ layout = "custom", axes = [[1, 0, 0, 0.577], [0, 1, 0, 0.577], [0, 0, 1, 0.577]], max_torque = [0.2, 0.2, 0.2, inf] }}
sensors = {{ gyro = {{ angle_random_walk = 0.0 }} }}
links = {{ loss_probability = 0.0, loss_table = [{", ".join([_ROW.replace("0.1", "0.0")] * 6)}] }}
simulation = {{ seed = 7 }}
"""
)
"""paper.toml with every hardware key set (and a case overriding them)"""


def _schema_errors(data) -> list:
    validator = jsonschema.Draft202012Validator(file_schema())
    return list(validator.iter_errors(data))


def test_a_complete_hardware_scenario_is_valid_under_the_schema_and_loads(tmp_path):
    data = tomllib.loads(HARDWARE_TOML)
    assert _schema_errors(data) == []
    path = tmp_path / "hardware.toml"
    path.write_text(HARDWARE_TOML)
    s = sc.load_scenario(path, case="1")
    assert s.actuator.n_wheels == 4 and s.actuator.max_speed == (math.inf,)
    assert s.sensors.star_tracker.noise_std == (2.4e-5, 2.4e-5, 4.8e-5) and s.sensors.gyro.rate_random_walk == 1.6e-7
    assert s.links.enabled and s.simulation.seed == 42 and s.simulation.control_period == 0.1
    custom = sc.load_scenario(path, case="custom-wheels")
    assert custom.actuator.layout == "custom" and custom.actuator.max_torque == (0.2, 0.2, 0.2, math.inf)
    assert custom.sensors.gyro.angle_random_walk == 0.0 and custom.sensors.gyro.rate_random_walk == 1.6e-7  # merged
    assert custom.simulation.seed == 7 and custom.links.loss_probability == 0.0


@pytest.mark.parametrize(
    "rows",
    [
        [[0.01, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]],  # a torque per wheel, every spacecraft alike
        [[[0.01, 0.0, 0.0, 0.0]] * 6, [[0.0, 0.0, 0.0, 0.0]] * 6],  # per spacecraft a torque per wheel
    ],
    ids=["per-wheel", "per-spacecraft"],
)
def test_wheel_commands_tables_are_valid_under_the_schema_and_load(tmp_path, rows):
    data = tomllib.loads(HARDWARE_TOML)
    data["actuator"]["wheel_commands"] = {"time": [0.0, 10.0], "motor_torque": rows}
    assert _schema_errors(data) == []
    path = tmp_path / "commands.toml"
    path.write_text(
        HARDWARE_TOML.replace(
            "initial_speed = 0.0",
            f"initial_speed = 0.0\nwheel_commands = {{ time = [0.0, 10.0], motor_torque = {rows} }}",
        )
    )
    table = sc.load_scenario(path, case="1").actuator.wheel_commands.table(6)
    assert table.shape == (2, 6, 4) and table[0, 5, 0] == 0.01
    data["actuator"]["wheel_commands"] = {"time": [0.0, 10.0], "motor_torque": [["0.01", 0, 0, 0], [0, 0, 0, 0]]}
    assert _schema_errors(data)  # a string is no torque
    del data["actuator"]["wheel_commands"]["time"]
    assert _schema_errors(data)  # both keys are required


def test_the_builtin_hardware_scenario_is_valid_under_the_schema():
    """paper-hardware.toml only says what differs (``extends = "paper"``): the schema does not ask it for agents."""
    text = (Path(fsmctl.__file__).parent / "scenarios" / "paper-hardware.toml").read_text()
    assert _schema_errors(tomllib.loads(text)) == []
    # without extends the four sections are required again
    data = tomllib.loads(text)
    del data["extends"]
    assert _schema_errors(data)


@pytest.mark.parametrize(
    ("old", "new", "key"),
    [
        ('kind = "reaction_wheels"', 'kind = "reaction_wheels"\nwheel_count = 4', "wheel_count"),
        ('layout = "pyramid"', 'layout = "pyramidal"', "actuator.layout"),
        (
            "noise_std = [2.4e-5, 2.4e-5, 4.8e-5]",
            "noise_std = [2.4e-5, -2.4e-5, 4.8e-5]",
            "sensors.star_tracker.noise_std",
        ),
        ("loss_probability = 0.05", "loss_probability = 1.5", "links.loss_probability"),
        ("angle_random_walk = 4.4e-5", "angle_random_walk = -1.0", "sensors.gyro.angle_random_walk"),
        ("max_torque = 0.2", "max_torque = 0.0", "actuator.max_torque"),
        ("max_torque = 0.2", 'max_torque = "unlimited"', "actuator.max_torque"),
        ("spin_inertia = [0.1, 0.1, 0.12, 0.1]", "spin_inertia = []", "actuator.spin_inertia"),
        ("seed = 42 ", "seed = -1 ", "simulation.seed"),
        ("seed = 42 ", 'seed = "42" ', "simulation.seed"),
        ("[sensors.gyro]", "[sensors.gyro]\nbias_drift = 1.0", "bias_drift"),
        ("[links]", "[links]\njitter = 0.01", "jitter"),
    ],
)
def test_schema_and_loader_reject_the_same_bad_hardware_values(tmp_path, old, new, key):
    """Each bad value is refused by the schema (an editor) and by load_scenario, in one line naming the key."""
    assert old in HARDWARE_TOML
    text = HARDWARE_TOML.replace(old, new, 1)
    assert _schema_errors(tomllib.loads(text)), "the schema accepts it"
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(sc.ScenarioError) as info:
        sc.load_scenario(path)
    message = str(info.value)
    assert len(message.splitlines()) == 1 and message.startswith(f"{path}: ")
    assert key in message, message


def test_reference_page_documents_every_hardware_key():
    page = (ROOT / REFERENCE_PATH).read_text()
    for cls, prefix in (
        (sc.ActuatorSettings, "actuator."),
        (sc.SensorSettings, "sensors."),
        (sc.StarTrackerSettings, "sensors.star_tracker."),
        (sc.GyroSettings, "sensors.gyro."),
        (sc.LinkSettings, "links."),
        (sc.WheelCommandSettings, "actuator.wheel_commands."),
    ):
        for f in dataclasses.fields(cls):
            assert f"`{prefix}{f.name}`" in page, f"{prefix}{f.name} missing from {REFERENCE_PATH}"
    assert "| `simulation.seed` | integer (>= 0) |  | `0` |" in page
    assert (
        '| `actuator.max_torque` | number or `"inf"` \\| `"infinity"` \\| `"none"`, or an array of them (> 0) | N m | `"inf"` |'
        in page
    )
    assert "| `links.loss_probability` | number (>= 0, <= 1) | 1 | `0.0` |" in page
    assert "| `sensors.star_tracker.noise_std` | 3 numbers (>= 0) | rad | required |" in page
    for heading in ("## `[actuator]`", "### `[sensors.star_tracker]`", "### `[sensors.gyro]`", "## `[links]`"):
        assert heading in page
    assert "### `[actuator.wheel_commands]`" in page
    assert "| `actuator.wheel_commands` | table |  | optional |" in page  # an unset table, not "the law's"
    actuator = page.split("## `[actuator]`")[1].split("| key |")[0]  # the section's prose: every rule it names
    for rule in ('`"scaled"`', '`"clipped"`', "`speed_gate`", '`"step_start"`', "`wheel_commands`"):
        assert rule in actuator, rule
