"""The hardware settings of a scenario (issue 13): ``[actuator]``, ``[sensors]``, ``[links]`` and ``simulation.seed``.

One validation path: a bad value gives the same one-line :class:`ScenarioError`, naming the same key, whether it
comes from a TOML file (:func:`load_scenario`), from :meth:`Scenario.replace` or from the dataclasses' own
constructors.  Then the geometry of the wheel layouts, and cases that override the hardware.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

import fsmctl
from fsmctl.model import scenario as sc

PAPER_TOML = (Path(fsmctl.__file__).parent / "scenarios" / "paper.toml").read_text()
CONTROL_PERIOD_LINE = "control_period = 0.0     # continuous control"
N = 6  # agents of paper.toml (all-to-all: every off-diagonal entry is a link)
NAN = math.nan
WHEELS = {"kind": "reaction_wheels"}
STAR = {"star_tracker": {"noise_std": [1e-5, 1e-5, 1e-5]}}


def _toml(value) -> str:
    """A TOML value (inline tables for mappings; nan/inf spelled as TOML does)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return (
            "nan"
            if math.isnan(value)
            else ("inf" if value == math.inf else ("-inf" if value == -math.inf else repr(value)))
        )
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + " }"
    return "[" + ", ".join(_toml(v) for v in value) + "]"


def _file_text(sections: dict) -> str:
    """paper.toml with ``simulation`` keys changed and hardware tables added."""
    assert CONTROL_PERIOD_LINE in PAPER_TOML
    sim = {"control_period": 0.0, **sections.get("simulation", {})}
    text = PAPER_TOML.replace(CONTROL_PERIOD_LINE, "\n".join(f"{k} = {_toml(v)}" for k, v in sim.items()), 1)
    for name in ("actuator", "sensors", "links"):
        if name in sections:
            text += f"\n[{name}]\n" + "".join(f"{k} = {_toml(v)}\n" for k, v in sections[name].items())
    return text


@pytest.fixture(scope="module")
def base() -> sc.Scenario:
    return sc.load_scenario("paper", case="1")


def _from_file(sections: dict, tmp_path: Path) -> str:
    path = tmp_path / "hardware.toml"
    path.write_text(_file_text(sections))
    with pytest.raises(sc.ScenarioError) as info:
        sc.load_scenario(path, case="1")
    message = str(info.value)
    assert message.startswith(f"{path}: "), message  # the file is named first
    return message.removeprefix(f"{path}: ")


def _from_replace(sections: dict, base: sc.Scenario) -> str:
    with pytest.raises(sc.ScenarioError) as info:
        base.replace(**sections)
    return str(info.value)


def _from_constructors(sections: dict, base: sc.Scenario) -> str:
    """The dataclasses built one by one; a section's own error gets the section's key path (as a file does)."""

    def build(where: str, cls, values: dict):
        try:
            return cls(**values)
        except sc.ScenarioError as exc:
            raise sc.ScenarioError(f"{where}.{exc}") from None

    try:
        fields = {f.name: getattr(base, f.name) for f in dataclasses.fields(base)}
        current = {f.name: getattr(base.simulation, f.name) for f in dataclasses.fields(base.simulation)}
        fields["simulation"] = build("simulation", sc.SimulationSettings, {**current, **sections.get("simulation", {})})
        if "actuator" in sections:
            fields["actuator"] = build("actuator", sc.ActuatorSettings, sections["actuator"])
        if "sensors" in sections:
            sensors = dict(sections["sensors"])
            for name, cls in (("star_tracker", sc.StarTrackerSettings), ("gyro", sc.GyroSettings)):
                if name in sensors:
                    sensors[name] = build(f"sensors.{name}", cls, sensors[name])
            fields["sensors"] = build("sensors", sc.SensorSettings, sensors)
        if "links" in sections:
            fields["links"] = build("links", sc.LinkSettings, sections["links"])
        sc.Scenario(**fields)
    except sc.ScenarioError as exc:
        return str(exc)
    raise AssertionError("the constructors accepted it")


def _table(value: float, diagonal: float = NAN, n: int = N) -> list[list[float]]:
    return [[diagonal if i == j else value for j in range(n)] for i in range(n)]


BAD = [
    pytest.param(
        {"actuator": {**WHEELS, "layout": "custom", "axes": [[1, 0, 1], [0, 1, 1], [0, 0, 0]]}},
        r"^actuator\.axes: the spin axes do not span 3-D",
        id="axes-coplanar",
    ),
    pytest.param(
        {"actuator": {**WHEELS, "layout": "custom", "axes": [[1, 0], [0, 1], [0, 0]]}},
        r"^actuator\.axes: the spin axes do not span 3-D",
        id="axes-two-wheels",
    ),
    pytest.param(
        {"actuator": {**WHEELS, "layout": "custom", "axes": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]}},
        r"^actuator\.axes: wheel 4 has a zero spin axis",
        id="axes-zero-column",
    ),
    pytest.param(
        {"actuator": {**WHEELS, "layout": "custom"}},
        r"^actuator\.axes: layout = 'custom' needs axes",
        id="custom-without-axes",
    ),
    pytest.param(
        {"actuator": {**WHEELS, "layout": "orthogonal", "axes": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}},
        r"^actuator\.axes: given with layout = 'orthogonal'",
        id="axes-without-custom",
    ),
    pytest.param(
        {"actuator": {**WHEELS, "spin_inertia": [0.1, 0.1, 0.1]}},
        r"^actuator\.spin_inertia: give one value or one per wheel \(4\), got 3$",
        id="per-wheel-length-pyramid",
    ),
    pytest.param(
        {"actuator": {**WHEELS, "layout": "orthogonal", "initial_speed": [0.0, 1.0, 2.0, 3.0]}},
        r"^actuator\.initial_speed: give one value or one per wheel \(3\), got 4$",
        id="per-wheel-length-orthogonal",
    ),
    pytest.param(
        {"actuator": {**WHEELS, "max_torque": 0.0}},
        r"^actuator\.max_torque: every value must be > 0, got \[0\.0\]$",
        id="max-torque-zero",
    ),
    pytest.param(
        {"actuator": {**WHEELS, "max_torque": [0.2, 0.2, -0.2, 0.2]}},
        r"^actuator\.max_torque: every value must be > 0",
        id="max-torque-negative",
    ),
    pytest.param(
        {"actuator": {**WHEELS, "max_speed": -math.inf}},
        r"^actuator\.max_speed: expected finite numbers or inf",
        id="max-speed-minus-inf",
    ),
    pytest.param(
        {"actuator": {**WHEELS, "max_speed": NAN}},
        r"^actuator\.max_speed: expected finite numbers or inf",
        id="max-speed-nan",
    ),
    pytest.param(
        {"actuator": {**WHEELS, "spin_inertia": math.inf}},
        r"^actuator\.spin_inertia: values must be finite",
        id="spin-inertia-inf",
    ),
    pytest.param(
        {"actuator": {**WHEELS, "coulomb_friction": -1e-3}},
        r"^actuator\.coulomb_friction: every value must be >= 0",
        id="coulomb-negative",
    ),
    pytest.param(
        {"actuator": {"kind": "wheels"}},
        r"^actuator\.kind: must be one of 'ideal' or 'reaction_wheels', got 'wheels'$",
        id="kind-typo",
    ),
    pytest.param(
        {"actuator": {**WHEELS, "layout": "pyramidal"}},
        r"^actuator\.layout: must be one of 'pyramid', 'orthogonal' or 'custom', got 'pyramidal'$",
        id="layout-typo",
    ),
    pytest.param(
        {"actuator": {**WHEELS, "pyramid_angle": 90.0}},
        r"^actuator\.pyramid_angle: must be < 90",
        id="pyramid-angle-90",
    ),
    pytest.param(
        {"sensors": STAR},
        r"^sensors: sensors and imperfect links act at the control instants; set simulation\.control_period > 0",
        id="star-tracker-without-control-period",
    ),
    pytest.param(
        {"sensors": {"gyro": {"angle_random_walk": 1e-5}}},
        r"^sensors: .*control_period > 0",
        id="gyro-without-control-period",
    ),
    pytest.param(
        {"links": {"delay": 0.1}},
        r"^links: .*control_period > 0",
        id="delay-without-control-period",
    ),
    pytest.param(
        {"simulation": {"control_period": 0.1}, "sensors": {"star_tracker": {"noise_std": [1e-5, -1e-5, 1e-5]}}},
        r"^sensors\.star_tracker\.noise_std: must be >= 0, got \[1e-05, -1e-05, 1e-05\]$",
        id="noise-negative",
    ),
    pytest.param(
        {"simulation": {"control_period": 0.1}, "sensors": {"gyro": {"rate_random_walk": -1e-7}}},
        r"^sensors\.gyro\.rate_random_walk: must be >= 0",
        id="gyro-negative",
    ),
    pytest.param(
        {"simulation": {"control_period": 0.1}, "links": {"delay_table": _table(0.1, n=N - 1)}},
        r"^links\.delay_table: expected an? 6 x 6 table \(one row per agent\), got 5 rows$",
        id="delay-table-5x5",
    ),
    pytest.param(
        {"simulation": {"control_period": 0.1}, "links": {"delay_table": _table(0.1)[:-1]}},
        r"^links\.delay_table: expected an n x n table",
        id="delay-table-not-square",
    ),
    pytest.param(
        {"simulation": {"control_period": 0.1}, "links": {"delay_table": [[0.0, *row[1:]] for row in _table(NAN)]}},
        r"^links\.delay_table\[1\]\[2\]: the link 1 <- 2 needs a value in \[0, inf\], got nan$",
        id="delay-table-nan-on-a-link",
    ),
    pytest.param(
        {"simulation": {"control_period": 0.1}, "links": {"delay_table": _table(-0.1)}},
        r"^links\.delay_table\[1\]\[2\]: the link 1 <- 2 needs a value in \[0, inf\], got -0\.1$",
        id="delay-table-negative",
    ),
    pytest.param(
        {"simulation": {"control_period": 0.1}, "links": {"loss_table": _table(1.2)}},
        r"^links\.loss_table\[1\]\[2\]: the link 1 <- 2 needs a value in \[0, 1\], got 1\.2$",
        id="loss-table-above-1",
    ),
    pytest.param(
        {"simulation": {"control_period": 0.1}, "links": {"loss_probability": 1.5}},
        r"^links\.loss_probability: must be <= 1(\.0)?, got 1\.5$",
        id="loss-probability-1.5",
    ),
    pytest.param(
        {"simulation": {"control_period": 0.1}, "links": {"delay": -0.1}},
        r"^links\.delay: must be >= 0",
        id="delay-negative",
    ),
    pytest.param({"simulation": {"seed": -1}}, r"^simulation\.seed: must be >= 0, got -1$", id="seed-negative"),
    pytest.param(
        {"simulation": {"seed": 1.5}}, r"^simulation\.seed: expected a whole number, got 1\.5$", id="seed-float"
    ),
    pytest.param(
        {"simulation": {"seed": 2.0}}, r"^simulation\.seed: expected a whole number, got 2\.0$", id="seed-whole-float"
    ),
    pytest.param(
        {"simulation": {"seed": True}}, r"^simulation\.seed: expected a whole number, got True$", id="seed-bool"
    ),
    pytest.param(
        {"simulation": {"seed": "3"}}, r"^simulation\.seed: expected a whole number, got '3'$", id="seed-string"
    ),
    pytest.param(
        {"simulation": {"control_period": 0.0015}},
        r"^simulation\.control_period = 0\.0015 must be a multiple of dt = 0\.001$",
        id="control-period-off-grid",
    ),
    pytest.param(
        {"simulation": {"control_period": -0.1}},
        r"^simulation\.control_period: must be >= 0",
        id="control-period-negative",
    ),
]


@pytest.mark.parametrize(("sections", "pattern"), BAD)
def test_a_bad_value_is_the_same_one_line_error_on_every_path(sections, pattern, base, tmp_path):
    """TOML file, Scenario.replace and the constructors: one line, the same key path and reason."""
    from_file = _from_file(sections, tmp_path)
    from_replace = _from_replace(sections, base)
    from_constructors = _from_constructors(sections, base)
    for message in (from_file, from_replace, from_constructors):
        assert len(message.splitlines()) == 1 and "Traceback" not in message, message
    assert re.search(pattern, from_file), from_file
    assert from_replace == from_file
    assert from_constructors == from_file


def test_replace_reports_a_section_check_like_a_file(base, tmp_path):
    sections = {"actuator": {**WHEELS, "max_torque": 0.0}}
    assert _from_replace(sections, base) == _from_file(sections, tmp_path)


@pytest.mark.parametrize(
    ("file_value", "python_value"),
    [
        ("inf", math.inf),
        ('"inf"', "inf"),
        ('"none"', "none"),
        ('"Infinity"', "Infinity"),
        ("[0.2, inf, 0.2, inf]", None),
    ],
)
def test_inf_is_no_limit_for_max_torque_and_max_speed(file_value, python_value, base, tmp_path):
    expected = (math.inf,) if python_value is not None else (0.2, math.inf, 0.2, math.inf)
    text = _file_text({"actuator": WHEELS}) + f"max_torque = {file_value}\nmax_speed = {file_value}\n"
    path = tmp_path / "inf.toml"
    path.write_text(text)
    from_file = sc.load_scenario(path, case="1").actuator
    value = python_value if python_value is not None else [0.2, math.inf, 0.2, math.inf]
    from_replace = base.replace(actuator={**WHEELS, "max_torque": value, "max_speed": value}).actuator
    direct = sc.ActuatorSettings(**WHEELS, max_torque=value, max_speed=value)
    for actuator in (from_file, from_replace, direct):
        assert actuator.max_torque == expected and actuator.max_speed == expected
        assert np.all(np.isinf(actuator.per_wheel("max_torque")) == np.isinf(np.broadcast_to(expected, (4,))))


def test_valid_seeds_and_hardware_round_trip(base):
    s = base.replace(
        simulation={"control_period": 0.1, "seed": 2**62},
        actuator={**WHEELS, "layout": "orthogonal", "spin_inertia": [0.1, 0.2, 0.3]},
        sensors={**STAR, "gyro": {"angle_random_walk": 1e-5, "bias": [1e-6, 0, 0]}},
        links={"delay": 0.2, "loss_probability": 1.0},
    )
    assert s.simulation.seed == 2**62 and s.actuator.n_wheels == 3 and s.links.enabled and s.sensors.enabled
    assert s.actuator.per_wheel("spin_inertia").tolist() == [0.1, 0.2, 0.3]
    assert s.replace(simulation={"seed": np.int64(5)}).simulation.seed == 5
    assert dataclasses.replace(s, simulation=dataclasses.replace(s.simulation, seed=3)).simulation.seed == 3
    with pytest.raises(sc.ScenarioError, match=r"^seed: expected a whole number, got 3\.0$"):
        dataclasses.replace(s.simulation, seed=3.0)
    # the off switches: wheels off -> no wheels; zero loss and delay -> links disabled (no control period needed)
    assert sc.ActuatorSettings().n_wheels == 0 and not sc.ActuatorSettings().enabled
    assert not sc.LinkSettings(delay=0.0, loss_probability=0.0).enabled
    assert base.replace(links={"delay": 0.0}).simulation.control_period == 0.0


# ----------------------------------------------------------------------------- wheel layouts


@pytest.mark.parametrize("angle_deg", [10.0, 30.0, 54.735610317245346, 70.0, 89.0])
def test_pyramid_axes_are_unit_vectors_at_the_stated_angle(angle_deg):
    a = sc.ActuatorSettings(kind="reaction_wheels", layout="pyramid", pyramid_angle=angle_deg)
    G = a.spin_axes()
    assert G.shape == (3, 4) and a.n_wheels == 4
    np.testing.assert_allclose(np.linalg.norm(G, axis=0), 1.0, rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.degrees(np.arccos(G[2])), angle_deg, rtol=0, atol=1e-9)  # angle from body z
    azimuth = np.degrees(np.arctan2(G[1], G[0])) % 360.0
    np.testing.assert_allclose(azimuth, [45.0, 135.0, 225.0, 315.0], rtol=0, atol=1e-9)
    assert np.linalg.matrix_rank(G) == 3
    # balanced: the four axes cancel in x and y, and the minimum-norm split of a body torque is exact
    np.testing.assert_allclose(G[:2].sum(axis=1), 0.0, atol=1e-15)
    u = np.array([0.1, -0.2, 0.3])
    np.testing.assert_allclose(G @ (np.linalg.pinv(G) @ u), u, atol=1e-14)


def test_default_pyramid_axes_are_the_cube_diagonals():
    G = sc.ActuatorSettings(kind="reaction_wheels").spin_axes()
    np.testing.assert_allclose(np.abs(G) * math.sqrt(3), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.sign(G), [[1, -1, -1, 1], [1, 1, -1, -1], [1, 1, 1, 1]])


def test_orthogonal_is_the_identity_and_custom_axes_are_normalised():
    orthogonal = sc.ActuatorSettings(kind="reaction_wheels", layout="orthogonal")
    assert orthogonal.n_wheels == 3
    np.testing.assert_array_equal(orthogonal.spin_axes(), np.eye(3))
    custom = sc.ActuatorSettings(
        kind="reaction_wheels", layout="custom", axes=[[2, 0, 0, 1], [0, 3, 0, 1], [0, 0, 0.5, 1]]
    )
    G = custom.spin_axes()
    assert custom.n_wheels == 4
    np.testing.assert_allclose(np.linalg.norm(G, axis=0), 1.0, atol=1e-15)
    np.testing.assert_allclose(G[:, :3], np.eye(3), atol=1e-15)
    np.testing.assert_allclose(G[:, 3], np.ones(3) / math.sqrt(3), atol=1e-15)
    assert custom.per_wheel("spin_inertia").shape == (4,)


# ----------------------------------------------------------------------------- cases


CASES_TOML = _file_text(
    {
        "simulation": {"control_period": 0.1, "seed": 11},
        "actuator": {**WHEELS, "max_torque": 0.2},
        "sensors": STAR,
        "links": {"delay": 0.1},
    }
) + (
    """
[cases."orthogonal"]
description = "three wheels, a gyro, lossy links"
actuator = { layout = "orthogonal", spin_inertia = [0.1, 0.1, 0.2] }
sensors = { gyro = { angle_random_walk = 4e-5 } }
links = { loss_probability = 0.1 }
simulation = { seed = 12 }

[cases."ideal"]
description = "the ideal actuator and perfect links, the star tracker kept"
actuator = { kind = "ideal" }
links = { delay = 0.0 }

[cases."noisier".sensors.star_tracker]
noise_std = [1e-4, 1e-4, 1e-4]
"""
)


def test_cases_override_actuator_sensors_and_links(tmp_path):
    path = tmp_path / "cases.toml"
    path.write_text(CASES_TOML)
    base = sc.load_scenario(path, case="1")
    assert base.actuator.n_wheels == 4 and base.actuator.max_torque == (0.2,) and base.sensors.gyro is None
    assert base.links.delay == 0.1 and base.simulation.seed == 11

    ortho = sc.load_scenario(path, case="orthogonal")
    assert ortho.actuator.layout == "orthogonal" and ortho.actuator.n_wheels == 3
    assert ortho.actuator.max_torque == (0.2,)  # merged key by key with the base table
    assert ortho.sensors.star_tracker == base.sensors.star_tracker and ortho.sensors.gyro.angle_random_walk == 4e-5
    assert ortho.links.delay == 0.1 and ortho.links.loss_probability == 0.1 and ortho.simulation.seed == 12
    assert "case orthogonal: three wheels" in ortho.description

    ideal = sc.load_scenario(path, case="ideal")
    assert not ideal.actuator.enabled and ideal.actuator.n_wheels == 0
    assert not ideal.links.enabled and ideal.sensors.star_tracker is not None

    noisier = base.with_case("noisier")
    assert noisier.sensors.star_tracker.noise_std == (1e-4, 1e-4, 1e-4) and noisier.actuator == base.actuator
    assert any("star tracker: noise_std=[0.0001, 0.0001, 0.0001]" in line for line in noisier.describe())


def test_a_bad_case_override_names_the_case_key(tmp_path):
    path = tmp_path / "cases.toml"
    path.write_text(CASES_TOML + '\n[cases."bad"]\nactuator = { layout = "hexagon" }\n')
    sc.load_scenario(path, case="orthogonal")  # the other cases still load
    with pytest.raises(sc.ScenarioError, match=r"actuator\.layout: must be one of .*got 'hexagon'$"):
        sc.load_scenario(path, case="bad")
    path.write_text(CASES_TOML + '\n[cases."bad"]\nsensors = { sonar = { range = 3 } }\n')
    with pytest.raises(sc.ScenarioError, match=r"sensors: unknown key\(s\) \['sonar'\]"):
        sc.load_scenario(path, case="bad")
