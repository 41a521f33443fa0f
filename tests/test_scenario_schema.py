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
    assert "| `controller.alpha` | number (> 0.5, < 1) | 1 | the law's |" in page
    assert '| `controller.law` | string |  | `"fsm"` |' in page
    # defaults in the page are the dataclasses' defaults
    assert sc.SimulationSettings().dt == 0.001 and math.isinf(sc.ControllerSettings(c1=1, c2=1, alpha=0.7).torque_limit)
