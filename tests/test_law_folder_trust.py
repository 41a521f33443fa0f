"""Law scripts, law folders and law parameters under bad input and faults (issue 25).

* A law folder is verified in full against its ``manifest.json`` before it flies (fsmctl.model.laws.resolve_law, the
  one path of the command line and of the python-control factories): an edited, missing, extra or copied file, a
  corrupt manifest, a format this fsmctl does not write, a folder of another fsmctl version: each a one-line
  ``LawError`` naming the file (exit 2), never a law flown with the edit.
* ``fsmctl derive --out F`` replaces an existing F by renames: F is the old complete folder or the new one, whatever
  step a Ctrl-C interrupts; a folder left aside by a killed process is restored on next use.
* A derivation script runs guarded: an exception or a ``sys.exit`` in it is a one-line ``LawDefinitionError``
  naming the script and line (exit 2), never the exit of fsmctl or of the caller's interpreter; Ctrl-C propagates.
* A law that is not finite at the initial state is a one-line error naming the law and the output.
* ``--set`` flies what the result says, checked against the flown law's own declared ranges.
"""

from __future__ import annotations

import hashlib
import json
import os
import shlex
import shutil
from pathlib import Path

import numpy as np
import pytest

import fsmctl
import fsmctl.model.laws as laws_module
from fsmctl.cli.main import main
from fsmctl.model import LawError, parameter_matrix, resolve_law
from fsmctl.model.laws import derive_script
from fsmctl.plugin import law_controller
from fsmctl.symbolic.law import LawDefinitionError

ROOT = Path(__file__).resolve().parent.parent
MY_LAW = ROOT / "docs" / "examples" / "my_law.py"
J0 = np.diag([20.0, 25.0, 30.0])
pytestmark = pytest.mark.filterwarnings("ignore::fsmctl.model.laws.LawSwitchWarning")
SHORT = ["--t-final", "0.2", "--output-interval", "0.1", "--no-figures"]


@pytest.fixture(scope="module")
def pristine(tmp_path_factory) -> Path:
    """A folder written by ``fsmctl derive docs/examples/my_law.py --out`` (parameters K = 4, P = 12, k_c = 1)."""
    out = tmp_path_factory.mktemp("derived") / "my_pd"
    assert main(["derive", str(MY_LAW), "--out", str(out)]) == 0
    return out


@pytest.fixture
def folder(pristine, tmp_path) -> Path:
    copy = tmp_path / "my_pd"
    shutil.copytree(pristine, copy)
    return copy


def _json(path: Path) -> dict:
    return json.loads(path.read_text())


def _write_json(path: Path, data) -> None:
    path.write_text(json.dumps(data, indent=2) + "\n")


def _reseal(folder: Path) -> None:
    """Record the current sha256 of every listed file in the manifest: an edit the manifest agrees with."""
    manifest = _json(folder / "manifest.json")
    manifest["sha256"] = {rel: hashlib.sha256((folder / rel).read_bytes()).hexdigest() for rel in manifest["sha256"]}
    _write_json(folder / "manifest.json", manifest)


def _edit_law_json(folder: Path, edit) -> None:
    meta = _json(folder / "law.json")
    edit(meta)
    _write_json(folder / "law.json", meta)


def _swap_parameters(meta):
    meta["parameters"][0], meta["parameters"][1] = meta["parameters"][1], meta["parameters"][0]


def _default_40(meta):
    assert meta["parameters"][0]["name"] == "K" and meta["parameters"][0]["default"] == 4.0
    meta["parameters"][0]["default"] = 40.0


def _set(key, value):
    def edit(meta):
        meta[key] = value

    return edit


def _drop_tunable(meta):  # what a folder written before `tunable` was declared holds
    for p in meta["parameters"]:
        del p["tunable"]


def _broadcast_4(meta):
    meta["broadcast"]["size"] = 4


def _copy_from_pid(folder: Path) -> None:
    other = resolve_law("pid").folder / "casadi" / "law_control_paper.casadi"
    shutil.copyfile(other, folder / "casadi" / "law_control_paper.casadi")


def _edit_c(folder: Path) -> None:
    path = folder / "c" / "law_control_paper.c"
    path.write_text(path.read_text().replace("casadi_real a0", "casadi_real  a0", 1) + "\n/* edited */\n")


def _manifest_format(number):
    def edit(folder: Path) -> None:
        manifest = _json(folder / "manifest.json")
        manifest["format"] = number
        _write_json(folder / "manifest.json", manifest)

    return edit


# (id, how the folder is damaged, the file the error names, what the error says)
DAMAGE = [
    ("parameters-reordered", lambda f: _edit_law_json(f, _swap_parameters), "law.json", "does not match its sha256"),
    ("default-changed", lambda f: _edit_law_json(f, _default_40), "law.json", "does not match its sha256"),
    ("format-99", lambda f: _edit_law_json(f, _set("format", 99)), "law.json", "does not match its sha256"),
    ("casadi-from-another-law", _copy_from_pid, "casadi/law_control_paper.casadi", "does not match its sha256"),
    ("c-edited", _edit_c, "c/law_control_paper.c", "does not match its sha256"),
    ("c-missing", lambda f: (f / "c" / "law_local_exact.c").unlink(), "c/law_local_exact.c", "missing"),
    (
        "extra-file",
        lambda f: (f / "casadi" / "law_extra.casadi").write_text("x"),
        "casadi/law_extra.casadi",
        "not listed",
    ),
    (
        "manifest-corrupt",
        lambda f: (f / "manifest.json").write_text('{"sha256": {"law.j'),
        "manifest.json",
        "cannot be read",
    ),
    ("manifest-missing", lambda f: (f / "manifest.json").unlink(), "manifest.json", "missing"),
    ("manifest-no-table", lambda f: _write_json(f / "manifest.json", {"format": 1}), "manifest.json", "corrupt"),
    ("manifest-format-newer", _manifest_format(2), "manifest.json", "format 2 is newer than this fsmctl"),
    # edits the manifest agrees with (resealed): the format, the schema and the sizes are checked for themselves
    (
        "law-format-newer",
        lambda f: (_edit_law_json(f, _set("format", 99)), _reseal(f)),
        "law.json",
        "format 99 is newer",
    ),
    ("law-format-older", lambda f: (_edit_law_json(f, _set("format", 0)), _reseal(f)), "law.json", "format 0, older"),
    (
        "law-format-none",
        lambda f: (_edit_law_json(f, _set("format", None)), _reseal(f)),
        "law.json",
        "no format number",
    ),
    ("other-version", lambda f: (_edit_law_json(f, _drop_tunable), _reseal(f)), "law.json", "another fsmctl version"),
    ("broadcast-size", lambda f: (_edit_law_json(f, _broadcast_4), _reseal(f)), "law.json", "broadcast size 4 is not"),
]


def test_a_derived_folder_flies_as_written(folder, tmp_path):
    law = resolve_law(folder)
    assert law.name == "my_pd" and [p.default for p in law.parameters] == [(4.0,), (12.0,), (1.0,)]
    assert main(["simulate", "--law", str(folder), *SHORT, "--out", str(tmp_path / "run")]) == 0


@pytest.mark.parametrize(("damage", "named", "says"), [pytest.param(d, n, s, id=i) for i, d, n, s in DAMAGE])
def test_a_damaged_law_folder_is_refused_naming_the_file(folder, damage, named, says, tmp_path, capsys):
    damage(folder)
    with pytest.raises(LawError, match=says) as caught:
        resolve_law(folder)
    assert str(folder / named) in str(caught.value) and "\n" not in str(caught.value)
    with pytest.raises(LawError, match=says):  # the python-control factory reads the folder the same way
        law_controller(str(folder), J0)
    capsys.readouterr()
    assert main(["simulate", "--law", str(folder), *SHORT, "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("fsmctl simulate: error: ") and len(err.strip().splitlines()) == 1, err
    assert str(folder / named) in err and says in err
    assert not (tmp_path / "run").exists()


def test_a_result_whose_law_folder_was_edited_is_refused_naming_the_file(folder, tmp_path, capsys):
    """--from re-reads the law where it was flown: an edited folder is the same one-line error, the key path and
    the file apart (a fresh user saw 'controller./.../law.json: ...')."""
    run = tmp_path / "run"
    assert main(["simulate", "--law", str(folder), *SHORT, "--out", str(run)]) == 0
    _edit_law_json(folder, _default_40)
    capsys.readouterr()
    (result,) = run.glob("*.nc")
    assert main(["simulate", "--from", str(result), "--out", str(tmp_path / "again"), "--no-figures"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"controller: {folder / 'law.json'}: " in err, err


def test_a_law_edited_within_one_session_is_read_again(folder, tmp_path):
    """A notebook session that derives a folder again, or edits its script, gets the new law, never the first one
    read (the cache of resolved laws is keyed by the files' modification times and sizes)."""
    assert resolve_law(folder).parameter("K").default == (4.0,)
    _edit_law_json(folder, _default_40)  # not resealed: the verification must run again
    with pytest.raises(LawError, match="does not match its sha256"):
        resolve_law(folder)
    script = tmp_path / "my_law.py"
    script.write_text(MY_LAW.read_text())
    assert resolve_law(script).parameter("K").default == (4.0,)
    text = script.read_text()
    assert text.count('"K", 4.0') == 1, "the example's K default is written as '\"K\", 4.0'"
    before = script.stat()
    script.write_text(text.replace('"K", 4.0', '"K", 5.0'))
    # the same size, and the same modification time (as an edit within one tick of the file system's clock, or
    # one second of Python's bytecode cache, has): still the new law
    os.utime(script, ns=(before.st_atime_ns, before.st_mtime_ns))
    assert resolve_law(script).parameter("K").default == (5.0,)


def test_a_folder_rewritten_within_one_clock_tick_is_verified_again(folder):
    """law.json edited to the same size with its modification time restored (a rewrite within one tick of the file
    system's clock): the cached law is not returned, the folder is verified again and refused."""
    assert resolve_law(folder).parameter("K").default == (4.0,)
    path = folder / "law.json"
    before, text = path.stat(), path.read_text()
    assert text.count('"default": 4.0') == 1
    path.write_text(text.replace('"default": 4.0', '"default": 5.0'))
    os.utime(path, ns=(before.st_atime_ns, before.st_mtime_ns))
    assert path.stat().st_size == before.st_size
    with pytest.raises(LawError, match="does not match its sha256"):
        resolve_law(folder)


def test_an_edited_cached_derivation_is_derived_again(tmp_path, monkeypatch):
    """A script's law is derived into the cache once; a cached folder edited since is not flown but derived again."""
    monkeypatch.setenv("FSMCTL_CACHE_DIR", str(tmp_path / "cache"))
    script = tmp_path / "my_law.py"
    shutil.copyfile(MY_LAW, script)
    resolve_law.cache_clear()
    try:
        cached = resolve_law(script).folder
        _edit_law_json(cached, _default_40)
        resolve_law.cache_clear()
        again = resolve_law(script)
        assert again.folder == cached and again.parameter("K").default == (4.0,) and _complete(cached)
    finally:
        resolve_law.cache_clear()


def test_a_builtin_law_is_verified_by_the_same_path(tmp_path, monkeypatch):
    """The built-in folders pass the check every derived folder passes (no separate, weaker reading)."""
    root = tmp_path / "generated"
    shutil.copytree(fsmctl.model.generated_dir(), root)
    monkeypatch.setattr(laws_module, "generated_dir", lambda: root)
    resolve_law.cache_clear()
    try:
        assert list(laws_module.builtin_laws()) == [
            "fsm",
            "fsm_wheels",
            "adaptive_fsm",
            "fsm_event",
            "pid",
            "super_twisting",
        ]
        _edit_law_json(root / "laws" / "pid", _swap_parameters)
        resolve_law.cache_clear()  # package data: read and verified once per session, again after cache_clear
        with pytest.raises(LawError, match=r"pid/law\.json: does not match its sha256"):
            laws_module.builtin_laws()
    finally:
        resolve_law.cache_clear()


# ------------------------------------------------------------------------------------------- atomic replace

NEW_DEFAULT = 7.0


@pytest.fixture(scope="module")
def new_script(tmp_path_factory) -> Path:
    """my_law.py with another default K: the folder it writes differs from the pristine one."""
    path = tmp_path_factory.mktemp("script") / "my_law_k7.py"
    path.write_text(MY_LAW.read_text().replace('b.parameter("K", 4.0', f'b.parameter("K", {NEW_DEFAULT}'))
    return path


def _complete(folder: Path) -> bool:
    """Whether every file the folder's manifest lists is there with its sha256, and nothing else."""
    listed = _json(folder / "manifest.json")["sha256"]
    present = {p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file()} - {"manifest.json"}
    return present == set(listed) and all(
        hashlib.sha256((folder / rel).read_bytes()).hexdigest() == digest for rel, digest in listed.items()
    )


def _interrupt_at(monkeypatch, step: str, folder: Path) -> None:
    """Raise KeyboardInterrupt at one step of replacing ``folder``: writing, the n-th rename, or midway through
    deleting the old folder."""
    renames = {"n": 0}
    real_rename, real_replace, real_rmtree = os.rename, os.replace, shutil.rmtree

    def counted(real):
        def rename(src, dst, *args, **kwargs):
            renames["n"] += 1
            if step == f"rename {renames['n']}":
                raise KeyboardInterrupt
            return real(src, dst, *args, **kwargs)

        return rename

    def rmtree(path, *args, **kwargs):
        old = Path(path).name == folder.name or Path(path).name.startswith(f".{folder.name}.old-")
        if step == "delete" and old and Path(path).is_dir():
            files = sorted(p for p in Path(path).rglob("*") if p.is_file())
            for p in files[: len(files) // 2]:  # Ctrl-C half-way through deleting a folder
                p.unlink()
            raise KeyboardInterrupt
        return real_rmtree(path, *args, **kwargs)

    def write_law(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "rename", counted(real_rename))
    monkeypatch.setattr(os, "replace", counted(real_replace))
    monkeypatch.setattr(shutil, "rmtree", rmtree)
    if step == "write":
        monkeypatch.setattr("fsmctl.codegen.laws.write_law", write_law)


@pytest.mark.parametrize("step", ["write", "rename 1", "rename 2", "delete"])
def test_an_interrupted_replacement_leaves_the_old_or_the_new_complete_folder(folder, new_script, step, monkeypatch):
    with monkeypatch.context() as m:
        _interrupt_at(m, step, folder)
        with pytest.raises(KeyboardInterrupt):
            derive_script(new_script, folder)
    assert _complete(folder)  # the test's own check of the folder against its manifest
    law = resolve_law(folder)  # and fsmctl's
    assert law.parameter("K").default in ((4.0,), (NEW_DEFAULT,))
    derive_script(new_script, folder)  # the next run completes the replacement and leaves nothing beside it
    resolve_law.cache_clear()
    assert resolve_law(folder).parameter("K").default == (NEW_DEFAULT,)
    assert sorted(p.name for p in folder.parent.iterdir()) == ["my_pd"]


def test_a_process_killed_between_the_renames_leaves_the_old_folder_for_the_next_run(folder, new_script, monkeypatch):
    """Killed right after the old folder was renamed aside (the restore never runs): the next use puts it back."""
    with monkeypatch.context() as m:
        _interrupt_at(m, "rename 2", folder)
        real_rename = os.rename

        def killed(src, dst, *args, **kwargs):
            if Path(dst) == folder and Path(src).name.startswith(".my_pd.old-"):
                raise KeyboardInterrupt  # the restore does not happen either
            return real_rename(src, dst, *args, **kwargs)

        m.setattr(os, "rename", killed)
        with pytest.raises(KeyboardInterrupt):
            derive_script(new_script, folder)
    assert not folder.exists()
    assert resolve_law(folder).parameter("K").default == (4.0,)  # the old folder, restored and verified
    assert sorted(p.name for p in folder.parent.iterdir()) == ["my_pd"]


# ------------------------------------------------------------------------------------- guarded derivation scripts

EXITS = [
    ("exit-0-on-import", "import sys\nsys.exit(0)\n", r"exits\.py:2: importing the script called sys\.exit\(0\)"),
    ("exit-3-on-import", "import sys\n\nsys.exit(3)\n", r"exits\.py:3: importing the script called sys\.exit\(3\)"),
    (
        "exit-in-law",
        "import sys\n\n\ndef law(error_model):\n    sys.exit('no')\n",
        r"exits\.py:5: law\(error_model\) called sys\.exit\('no'\)",
    ),
    (
        "raises-in-law",
        "def law(error_model):\n    return 1 / 0\n",
        r"exits\.py:2: law\(error_model\) failed: ZeroDivisionError",
    ),
]


@pytest.mark.parametrize(("text", "pattern"), [pytest.param(t, p, id=i) for i, t, p in EXITS])
def test_a_script_that_exits_or_raises_is_a_one_line_error(text, pattern, tmp_path, capsys):
    script = tmp_path / "exits.py"
    script.write_text(text)
    with pytest.raises(LawDefinitionError, match=pattern):
        law_controller(str(script), J0)  # never SystemExit: the caller's interpreter goes on
    for argv in (
        ["derive", str(script), "--out", str(tmp_path / "law")],
        ["simulate", "--law", str(script), *SHORT, "--out", str(tmp_path / "run")],
        ["montecarlo", "--law", str(script), "--runs", "2", "--t-final", "0.2", "--out", str(tmp_path / "mc")],
    ):
        capsys.readouterr()
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
        assert str(script) in err
    assert not any(p.name in ("law", "run", "mc") for p in tmp_path.iterdir())


def test_ctrl_c_in_a_script_still_interrupts(tmp_path, capsys):
    script = tmp_path / "interrupted.py"
    script.write_text("raise KeyboardInterrupt\n")
    with pytest.raises(KeyboardInterrupt):
        law_controller(str(script), J0)
    assert main(["derive", str(script), "--out", str(tmp_path / "law")]) == 130


# ------------------------------------------------------------------------------------------------ messages


def test_the_command_to_fly_a_derived_folder_is_quoted_for_the_shell(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = Path("my laws") / "out fold"
    assert main(["derive", str(MY_LAW), "--out", str(out)]) == 0
    line = capsys.readouterr().out.strip().splitlines()[-1]
    command = shlex.split(line.split("fly it with: ", 1)[1])
    assert command == ["fsmctl", "simulate", "--law", str(out)]
    assert main([*command[1:], *SHORT, "--out", "run"]) == 0


NAN_LAW = """
import sympy as sp
from fsmctl.symbolic.law import LawBuilder


def law(error_model):
    b = LawBuilder("nan_law", error_model, doc="a PD times the root of a negative number: NaN everywhere")
    K = b.parameter("K", 4.0, unit="N m", minimum=0.0, exclusive_minimum=True, doc="attitude gain")
    e = b.error_state()
    b.broadcast("sigma_e", e.sigma_e)
    b.torque(-K * e.sigma_e * sp.sqrt(-1 - (e.sigma_e.T * e.sigma_e)[0]) - 10 * e.omega_e)
    return b.build()
"""


def test_a_law_not_finite_at_the_initial_state_is_refused_naming_it(tmp_path, capsys):
    """It ended in `internal error: LinAlgError: SVD did not converge` (the step-size report's estimate)."""
    script = tmp_path / "nan_law.py"
    script.write_text(NAN_LAW)
    scenario = fsmctl.paper_scenario("1").replace(controller={"law": str(script)}, simulation={"t_final": 0.2})
    with pytest.raises(LawError, match=r"law 'nan_law': its torque is not finite at the initial state of agent 1"):
        fsmctl.simulate(scenario)
    capsys.readouterr()
    assert main(["simulate", "--law", str(script), *SHORT, "--out", str(tmp_path / "run")]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if not line.startswith("fsmctl: warning: ")]
    assert len(errors) == 1 and "nan_law" in errors[0] and "torque is not finite" in errors[0], errors


# ------------------------------------------------------------------------------------------- law parameters


@pytest.mark.filterwarnings("ignore::fsmctl.simulation.StepSizeWarning")  # delta = 0.5: a 500 1/s layer
def test_set_delta_flies_what_the_result_says(tmp_path):
    """--set delta=[0.5,0.5,0.5] flies 0.5 for every agent: the same trajectory as delta written per agent."""
    out = tmp_path / "set"
    assert main(["simulate", *SHORT, "--out", str(out), "--set", "delta=[0.5,0.5,0.5]"]) == 0
    path = next(out.glob("*.nc"))
    flown = fsmctl.load_result(path)
    embedded = fsmctl.scenario_from_result(path)
    assert {p["delta"] for p in embedded.law_parameters()} == {(0.5, 0.5, 0.5)}
    paper = fsmctl.paper_scenario("1")
    per_agent = paper.replace(
        simulation={"t_final": 0.2, "output_interval": 0.1}, agents=[{"delta": [0.5, 0.5, 0.5]}] * len(paper.agents)
    )
    assert per_agent.law_parameters()[0]["delta"] == (0.5, 0.5, 0.5)
    written = fsmctl.simulate(per_agent)
    np.testing.assert_allclose(flown.sigma, written.sigma, rtol=1e-9, atol=1e-12)
    default = fsmctl.simulate(paper.replace(simulation={"t_final": 0.2, "output_interval": 0.1}))
    assert np.max(np.abs(written.sigma - default.sigma)) > 1e-6  # delta matters over this run


def test_a_negative_delta_is_refused(tmp_path, capsys):
    assert main(["simulate", *SHORT, "--out", str(tmp_path / "neg"), "--set", "delta=-0.5"]) == 2
    assert "delta" in capsys.readouterr().err and not (tmp_path / "neg").exists()


ALPHA_LAW = """
from fsmctl.symbolic.law import LawBuilder


def law(error_model):
    b = LawBuilder("own_alpha", error_model, doc="a PD whose gain is called alpha, in (0, 10]")
    alpha = b.parameter("alpha", 1.0, unit="N m", minimum=0.0, exclusive_minimum=True, maximum=10.0, doc="gain")
    e = b.error_state()
    b.broadcast("sigma_e", e.sigma_e)
    b.torque(-alpha * e.sigma_e - 10 * e.omega_e)
    return b.build()
"""


def test_a_users_own_alpha_has_its_own_range(tmp_path, capsys):
    script = tmp_path / "own_alpha.py"
    script.write_text(ALPHA_LAW)
    scenario = fsmctl.paper_scenario("1").replace(controller={"law": str(script), "alpha": 2.0})
    assert parameter_matrix(scenario.law, scenario)[:, 0].tolist() == [2.0] * len(scenario.agents)
    argv = ["simulate", "--law", str(script), "--set", "alpha=2", *SHORT]
    assert main([*argv, "--out", str(tmp_path / "run")]) == 0
    capsys.readouterr()
    assert main(["simulate", "--law", str(script), "--set", "alpha=11", *SHORT, "--out", str(tmp_path / "x")]) == 2
    assert "alpha: must be <= 10" in capsys.readouterr().err
