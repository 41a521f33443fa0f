"""Where a law's derivation script is, as every output names it (:meth:`fsmctl.model.laws.LawCode.script`).

A built-in law's ``law.json`` records its script as a path of the source tree (``derive/laws/fsm.py``), and
``derive/`` is not installed: what a user sees is the installed script (the package data ``fsmctl._builtin_laws``),
a file that exists, and what is written to files names it the same way on every machine.  Every test runs in an
empty working folder, so that a path of the source tree relative to the working folder is no file here.

Oracles: the file system (the named script is a file, its text the one the package data holds) and
``importlib.resources`` (the package ``fsmctl._builtin_laws`` holds a file of that name), not fsmctl's resolution.
"""

from __future__ import annotations

import json
import re
from importlib import resources
from pathlib import Path

import pytest

import fsmctl
from fsmctl.cli.main import main
from fsmctl.export import read_c_library, write_c_library
from fsmctl.model import builtin_laws, resolve_law
from fsmctl.proofs.law_check import check_law

EXAMPLES = Path(__file__).resolve().parents[1] / "docs" / "examples"
PORTABLE = re.compile(r"^(\w+\.py) in fsmctl\._builtin_laws$")


@pytest.fixture(autouse=True)
def _empty_working_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)


def _recorded(name: str) -> str:
    """The script ``law.json`` of a built-in law records (a path of the source tree)."""
    return json.loads((resolve_law(name).folder / "law.json").read_text())["source"]


def _installed(file_name: str) -> Path:
    return Path(str(resources.files("fsmctl._builtin_laws") / file_name))


def _assert_installed_script(shown: str, name: str) -> None:
    path = Path(shown)
    assert path.is_absolute() and path.is_file(), (name, shown)
    assert path.name == Path(_recorded(name)).name, (name, shown)
    assert path.read_bytes() == _installed(path.name).read_bytes(), (name, shown)


def test_a_builtin_laws_script_is_its_installed_file():
    for name, law in builtin_laws().items():
        assert law.source == _recorded(name)  # law.json's record is kept as written (python -m derive --check)
        _assert_installed_script(law.script(), name)


def test_a_builtin_laws_portable_script_is_the_same_everywhere_and_names_the_installed_file():
    for name, law in builtin_laws().items():
        portable = law.script(portable=True)
        m = PORTABLE.match(portable)
        assert m is not None, (name, portable)
        assert m.group(1) == Path(_recorded(name)).name and _installed(m.group(1)).is_file(), (name, portable)


def test_a_derived_laws_script_is_its_own_name_as_before():
    law = resolve_law(EXAMPLES / "my_law.py")
    assert not law.builtin
    assert law.script() == law.script(portable=True) == law.source == "my_law.py"


def test_fsmctl_laws_shows_each_builtin_laws_installed_script(capsys):
    assert main(["laws"]) == 0
    out = capsys.readouterr().out
    shown = re.findall(r"^  source:    (.+) \(built in\)$", out, re.M)
    assert len(shown) == len(builtin_laws())
    for name, script in zip(builtin_laws(), shown, strict=True):
        _assert_installed_script(script, name)


def test_fsmctl_laws_one_law_text_and_json_show_its_installed_script(capsys):
    assert main(["laws", "pid"]) == 0
    (script,) = re.findall(r"^  source:    (.+) \(built in\)$", capsys.readouterr().out, re.M)
    _assert_installed_script(script, "pid")
    assert main(["laws", "--json"]) == 0
    for entry in json.loads(capsys.readouterr().out):
        _assert_installed_script(entry["source"], entry["name"])


def test_a_result_file_and_the_scenario_lines_name_the_portable_script():
    scenario = fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.02})
    ds = fsmctl.simulate(scenario).to_dataset()
    assert ds.attrs["law_source"] == resolve_law("fsm").script(portable=True) == "fsm.py in fsmctl._builtin_laws"
    assert "  law: fsm (fsm.py in fsmctl._builtin_laws)" in scenario.describe()
    installed = str(Path(resolve_law("fsm").script()).parent)
    for key, value in ds.attrs.items():  # reproducible: nothing of this machine's installation, no source tree path
        assert installed not in str(value) and "derive/laws" not in str(value), key


def test_an_exported_library_names_the_portable_script(tmp_path):
    lib = write_c_library("pid", tmp_path / "pid_c", control_period=0.01)
    assert lib.manifest["law"]["source"] == "pd.py in fsmctl._builtin_laws"
    assert read_c_library(lib.folder).law.name == "pid"


def test_a_law_report_names_the_portable_script():
    report = check_law("pid", checks=["generated-equals-symbolic"], samples=4)
    assert report.source == report.to_dict()["source"] == "pd.py in fsmctl._builtin_laws"
    assert "from `pd.py in fsmctl._builtin_laws`" in report.to_markdown()
