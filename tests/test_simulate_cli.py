"""``fsmctl simulate`` (fsmctl/cli/commands.py), the figure builders (fsmctl/studies/figures.py), and the law
commands: ``fsmctl laws``, ``fsmctl derive`` and ``--law``/``--set`` on ``simulate`` and ``montecarlo``.

Oracles: the initial AAEM/RAEM (eqs 42-43) of the written NetCDF file are recomputed from
Table 1 with the independent NumPy transcription in ``tests/oracle_numpy.py``; exit codes and
one-line errors follow the contract of ``fsmctl/cli.py``.
"""

from __future__ import annotations

import json
import math
import re
import shutil
import subprocess
import sys

import numpy as np
import oracle_numpy as oracle
import pytest
import xarray as xr
from matplotlib.figure import Figure

from fsmctl.cli.main import main


def _run(argv, capsys):
    try:
        rc = main(argv)
    except SystemExit as exc:  # argparse errors
        rc = exc.code
    out, err = capsys.readouterr()
    return rc, out, err


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    """Case 1 for 2 s (the loop is the paper's: dt = 1 ms, 2 N m limit)."""
    out = tmp_path_factory.mktemp("simulate")
    rc = main(["simulate", "--case", "1", "--t-final", "2", "--out", str(out), "--no-progress"])
    return rc, out


def test_simulate_writes_netcdf_summary_and_figures(short_run):
    rc, out = short_run
    assert rc == 0
    nc = out / "paper_case_1.nc"
    assert nc.is_file()
    for name in ("aaem", "raem", "theta_e", "torques"):
        assert (out / f"paper_case_1_{name}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert "<svg" in (out / f"paper_case_1_{name}.svg").read_text()[:2000]
    summary = json.loads((out / "summary.json").read_text())  # strict JSON: NaN written as null
    assert summary["scenario"] == "paper case 1"
    assert {"alpha", "delta", "boundary_layer", "singularity_fix"} <= set(summary["choices"])
    assert any(line.strip().startswith("choice alpha") for line in summary["settings"])
    s = summary["summary"]
    assert s["u_max_abs_N_m"] == pytest.approx(2.0)  # the paper's per-axis limit is respected
    assert s["aaem_settling_s"]["1"] is None  # 2 s is far too short to settle (not NaN in JSON)


def test_netcdf_has_units_and_matches_independent_initial_metrics(short_run):
    _, out = short_run
    with xr.open_dataset(out / "paper_case_1.nc") as ds:
        assert ds["time_s"].attrs["units"] == "s"
        assert ds["aaem_deg"].attrs["units"] == "deg"
        assert ds["raem_deg"].attrs["units"] == "deg"
        assert ds["u_N_m"].attrs["units"] == "N m"
        assert ds["omega_rad_per_s"].attrs["units"] == "rad/s"
        assert float(ds["time_s"][-1]) == pytest.approx(2.0)
        assert float(np.abs(ds["u_N_m"]).max()) <= 2.0 + 1e-12
        aaem0, raem0 = float(ds["aaem_deg"][0]), float(ds["raem_deg"][0])
        theta0 = ds["theta_e_deg"].isel(time_s=0).values
    sc = oracle.paper_scenario()
    sigma_d0 = np.array([-0.3, -0.4, 0.4])
    errors = [oracle.mrp_error(s, sigma_d0) for s in sc["sigma0"]]
    theta = np.array([oracle.principal_angle(e) for e in errors])
    np.testing.assert_allclose(theta0, np.degrees(theta), atol=1e-9)
    assert aaem0 == pytest.approx(oracle.aaem_deg(theta), abs=1e-9)
    assert raem0 == pytest.approx(oracle.raem_deg(oracle.relative_angle_matrix(errors)), abs=1e-9)


def test_simulate_prints_settings_choices_and_summary(tmp_path, capsys):
    rc, out, err = _run(
        [
            "simulate",
            "--case",
            "2",
            "--t-final",
            "1",
            "--out",
            str(tmp_path),
            "--no-figures",
            "--torque-limit",
            "inf",
            "--error-model",
            "exact",
            "--boundary-layer",
            "0.002",
        ],
        capsys,
    )
    assert rc == 0, err
    assert "choice alpha" in out and "choice delta" in out
    assert "torque_limit=inf" in out and "error_model=exact" in out and "boundary_layer=0.002" in out
    assert "AAEM (eq 42)" in out and "RAEM (eq 43)" in out
    assert not list(tmp_path.glob("*.png"))
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["overrides"]["controller"] == {
        "error_model": "exact",
        "torque_limit": "inf",
        "boundary_layer": 0.002,
    }
    assert summary["summary"]["last_saturation_s"] is None  # no limit: never saturated
    assert summary["summary"]["u_max_abs_N_m"] > 2.0  # Case 2 commands far more than 2 N m at the start


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["simulate", "--case", "9"], "no case '9'"),
        (["simulate", "--dt", "0.3", "--t-final", "1"], "multiple of dt"),
        (["simulate", "--torque-limit", "-1"], "--torque-limit"),
        (["simulate", "--dt", "nan"], "--dt"),
        (["simulate", "--bogus-option"], "fsmctl simulate: unknown option --bogus-option"),
        (["simulate", "--error-model", "wrong"], "invalid choice"),
    ],
)
def test_bad_input_exits_2_with_one_line(argv, needle, tmp_path, capsys):
    rc, _, err = _run([*argv, "--out", str(tmp_path)], capsys)
    assert rc == 2
    assert needle in err
    assert len(err.strip().splitlines()) == 1
    assert "Traceback" not in err


def test_bad_scenario_file_exits_2_one_line_subprocess(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("name = 'x'\n[controller\n")
    proc = subprocess.run(
        [sys.executable, "-m", "fsmctl.cli.main", "simulate", "--scenario", str(bad), "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "not valid TOML" in lines[0]
    missing = tmp_path / "missing.toml"
    rc = main(["simulate", "--scenario", str(missing), "--out", str(tmp_path / "o")])
    assert rc == 2


# ----------------------------------------------------------------------------- figures


def test_metric_figure_has_inset_of_the_last_part():
    from fsmctl.studies.figures import metric_figure

    t = np.linspace(0, 100, 1001)
    fig = metric_figure(t, 100 * np.exp(-t / 5), metric="AAEM", tolerances_deg=(0.03,))
    assert isinstance(fig, Figure)
    ax = fig.axes[0]
    assert "AAEM" in ax.get_ylabel() and "eq 42" in ax.get_ylabel()
    assert ax.get_xlabel() == "time (s)"
    (inset,) = ax.child_axes
    assert inset.get_xlim() == pytest.approx((50.0, 100.0), abs=0.2)
    assert inset.get_ylim()[1] == pytest.approx(1.1 * 100 * math.exp(-50 / 5), rel=0.05)
    with pytest.raises(ValueError):
        metric_figure(t, t, metric="XYZ")
    with pytest.raises(ValueError):
        metric_figure(t, t[:-1])


def test_torques_figure_one_panel_per_body_axis_with_limits():
    from fsmctl.studies.figures import torques_figure

    t = np.linspace(0, 10, 101)
    u = np.clip(np.sin(t)[:, None, None] * np.arange(1, 7)[None, :, None] * np.ones(3), -2, 2)
    fig = torques_figure(t, u, 2.0)
    assert len(fig.axes) == 3
    for k, ax in enumerate(fig.axes):
        assert ax.get_ylabel() == f"(u_i)_{k + 1} (N m)"
        assert [ln.get_label() for ln in ax.get_lines()][:6] == [f"u{i}" for i in range(1, 7)]
        horizontal = [ln for ln in ax.get_lines() if np.ptp(ln.get_ydata()) == 0 and len(ln.get_ydata()) == 2]
        assert sorted(float(ln.get_ydata()[0]) for ln in horizontal) == [-2.0, 2.0]
        assert ax.get_ylim() == pytest.approx((-2.3, 2.3))
    free = torques_figure(t, 100 * u, math.inf)
    assert not any(len(ln.get_ydata()) == 2 for ln in free.axes[0].get_lines())


def test_principal_angles_and_overlay_figures(tmp_path):
    from fsmctl.studies.figures import overlay_figure, principal_angles_figure, save_figure

    t = np.linspace(0, 10, 101)
    theta = np.degrees(np.abs(np.sin(t))[:, None] * np.ones(6))
    fig = principal_angles_figure(t, theta, agents=[1, 2, 3, 4])
    assert [ln.get_label() for ln in fig.axes[0].get_lines()] == ["θ1", "θ2", "θ3", "θ4"]
    with pytest.raises(ValueError):
        principal_angles_figure(t, theta, agents=[7])
    over = overlay_figure(
        {"Case 1": (t, np.exp(-t)), "Case 2": (t, np.exp(-t / 3))}, ylabel="AAEM (deg)", title="x", log=True
    )
    assert over.axes[0].get_yscale() == "log"
    assert [ln.get_label() for ln in over.axes[0].get_lines()] == ["Case 1", "Case 2"]
    paths = save_figure(over, tmp_path / "sub" / "overlay")
    assert [p.suffix for p in paths] == [".png", ".svg"]
    assert all(p.stat().st_size > 1000 for p in paths)


# ----------------------------------------------------------------------------- laws: fsmctl laws, derive, --law

PD_LAW = '''\
"""A PD law with consensus on the attitude error (test fixture)."""
from fsmctl.symbolic.law import LawBuilder


def law(error_model):
    b = LawBuilder("pd", error_model, doc="MRP PD with consensus on the attitude error")
    K = b.parameter("K", 1.0, unit="N m", minimum=0.0, doc="attitude gain")
    P = b.parameter("P", 10.0, unit="N m s", minimum=0.0, doc="rate gain")
    e = b.error_state()
    b.broadcast("sigma_e", e.sigma_e)
    b.torque(-K * e.sigma_e - P * e.omega_e - K * (b.k_sum * e.sigma_e - b.received))
    return b.build()
'''


@pytest.fixture(scope="module")
def pd_law(tmp_path_factory):
    """``fsmctl derive pd.py --out DIR``: the script, the folder, and what the command printed."""
    import contextlib
    import io

    root = tmp_path_factory.mktemp("pd_law")
    script = root / "pd.py"
    script.write_text(PD_LAW)
    folder = root / "pd_law"
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        rc = main(["derive", str(script), "--out", str(folder)])
    return script, folder, rc, out.getvalue()


def test_laws_lists_the_builtin_laws_with_their_parameters(capsys):
    rc, out, err = _run(["laws"], capsys)
    assert rc == 0, err
    assert "built-in laws: fsm" in out
    assert "reference: Liang, Sun & Wang" in out and "broadcast: s (3 values" in out and "states:    none" in out
    rows = {line.split()[0]: line for line in out.splitlines() if line.startswith("    ") and line.split()}
    assert {"c1", "c2", "alpha", "boundary_layer", "epsilon", "singularity_fix", "delta"} <= set(rows)
    assert "0.5 < x < 1" in rows["alpha"] and "0.7" in rows["alpha"]
    assert "none | switch | clamp" in rows["singularity_fix"] and "switch" in rows["singularity_fix"].split()[1]
    assert "[0.005, 0.005, 0.005]" in rows["delta"] and "1/s^2" in rows["delta"]


def test_laws_json_one_and_all(capsys):
    rc, out, _ = _run(["laws", "--json"], capsys)
    assert rc == 0
    laws = json.loads(out)
    assert laws[0]["name"] == "fsm"
    rc, out, _ = _run(["laws", "fsm", "--json"], capsys)
    fsm = json.loads(out)
    assert rc == 0 and fsm["builtin"] is True and fsm["broadcast"] == {"name": "s", "size": 3}
    alpha = next(p for p in fsm["parameters"] if p["name"] == "alpha")
    assert alpha["default"] == 0.7 and alpha["minimum"] == 0.5 and alpha["exclusive_minimum"] is True
    assert next(p for p in fsm["parameters"] if p["name"] == "singularity_fix")["default"] == "switch"


def test_laws_unknown_is_one_line_exit_2(capsys, tmp_path):
    for arg, needle in (("nope", "not a built-in law"), (str(tmp_path), "not a law folder")):
        rc, out, err = _run(["laws", arg], capsys)
        assert rc == 2 and needle in err and len(err.strip().splitlines()) == 1 and out == ""


def test_derive_checks_and_writes_a_law_folder(pd_law):
    _, folder, rc, out = pd_law
    assert rc == 0, out
    assert (folder / "law.json").is_file() and (folder / "manifest.json").is_file()
    assert not [p for p in folder.parent.iterdir() if p.name.startswith(".")]  # no temporary folder left
    meta = json.loads((folder / "law.json").read_text())
    assert meta["name"] == "pd" and meta["source"] == "pd.py"
    assert [p["name"] for p in meta["parameters"]] == ["K", "P"]
    assert "ok  broadcast 'sigma_e' (3 values) does not depend on what the agent receives" in out
    assert "ok  both error models give the same name, parameters, states, broadcast and constants" in out
    manifest = json.loads((folder / "manifest.json").read_text())
    for f in manifest["functions"]:
        assert re.search(rf"^  {f['name']}\s+{f['n_instructions']} instructions", out, re.M), f["name"]
    assert {"law_local_paper", "law_control_exact"} <= {f["name"] for f in manifest["functions"]}
    assert "fsmctl derive pd.py" in manifest["_comment"]  # the generator named in the do-not-edit header


def test_laws_shows_a_derived_folder(pd_law, capsys):
    _, folder, _, _ = pd_law
    rc, out, _ = _run(["laws", str(folder)], capsys)
    assert rc == 0
    assert out.startswith("pd: MRP PD with consensus") and "broadcast: sigma_e (3 values" in out
    assert re.search(r"^    K\s+1\s+N m\s+0 <= x\s+attitude gain$", out, re.M)


def test_derive_check_up_to_date_and_stale(pd_law, tmp_path, capsys):
    script, folder, _, _ = pd_law
    rc, out, err = _run(["derive", str(script), "--out", str(folder), "--check"], capsys)
    assert rc == 0 and "is up to date" in out, err
    stale = tmp_path / "stale"
    shutil.copytree(folder, stale)
    law_json = stale / "law.json"
    law_json.write_text(law_json.read_text().replace("attitude gain", "old text"))
    before = sorted((p.relative_to(stale), p.read_bytes()) for p in stale.rglob("*") if p.is_file())
    rc, out, err = _run(["derive", str(script), "--out", str(stale), "--check"], capsys)
    assert rc == 1
    assert "differs: law.json" in out and '-      "doc": "old text"' in out and '+      "doc": "attitude gain"' in out
    assert "is stale" in err and len(err.strip().splitlines()) == 1
    assert sorted((p.relative_to(stale), p.read_bytes()) for p in stale.rglob("*") if p.is_file()) == before
    rc, _, err = _run(["derive", str(script), "--out", str(tmp_path / "missing"), "--check"], capsys)
    assert rc == 1 and "is missing" in err


def test_derive_default_out_is_the_law_name_in_the_current_folder(pd_law, tmp_path, monkeypatch, capsys):
    script, _, _, _ = pd_law
    monkeypatch.chdir(tmp_path)
    rc, _, err = _run(["derive", str(script)], capsys)
    assert rc == 0, err
    assert (tmp_path / "pd" / "law.json").is_file()
    rc, _, err = _run(["derive", str(script)], capsys)  # again: a law folder is replaced
    assert rc == 0, err


BROKEN_SCRIPTS = [
    ("syntax", "def law(error_model:\n", r"broken\.py:1: syntax error"),
    ("no-law", "x = 1\n", r"defines no function law\(error_model\)"),
    ("returns-int", "def law(error_model):\n    return 1\n", r"must return LawBuilder\(\.\.\.\)\.build\(\), got int"),
    (
        "no-torque",
        "from fsmctl.symbolic.law import LawBuilder\n\ndef law(m):\n    b = LawBuilder('x', m, doc='d')\n"
        "    e = b.error_state()\n    b.broadcast('s', e.sigma_e)\n    return b.build()\n",
        r"x: no torque declared",
    ),
    (
        "raises",
        "def law(error_model):\n    raise RuntimeError('boom')\n",
        r"law\(error_model\) failed: RuntimeError: boom",
    ),
    ("import-fails", "import no_such_module_xyz\n", r"importing the script failed: ModuleNotFoundError"),
]


@pytest.mark.parametrize(("text", "pattern"), [pytest.param(t, p, id=i) for i, t, p in BROKEN_SCRIPTS])
def test_derive_broken_script_is_one_line_exit_2(text, pattern, tmp_path, capsys):
    script = tmp_path / "broken.py"
    script.write_text(text)
    rc, out, err = _run(["derive", str(script), "--out", str(tmp_path / "out")], capsys)
    assert rc == 2, (out, err)
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert err.startswith("fsmctl derive: error: ") and re.search(pattern, err), err
    assert not (tmp_path / "out").exists()


def test_derive_refuses_an_unusable_out(pd_law, tmp_path, capsys):
    script, _, _, _ = pd_law
    taken = tmp_path / "taken"
    taken.mkdir()
    (taken / "notes.txt").write_text("mine")
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    for out_dir, needle in (
        (taken, "exists and is not a law folder"),
        (a_file, "exists and is not a folder"),
        (a_file / "pd", f"cannot write the law folder {a_file / 'pd'}"),
    ):
        rc, _, err = _run(["derive", str(script), "--out", str(out_dir)], capsys)
        assert rc == 2 and needle in err and len(err.strip().splitlines()) == 1
    assert (taken / "notes.txt").read_text() == "mine" and sorted(p.name for p in taken.iterdir()) == ["notes.txt"]
    rc, _, err = _run(["derive", str(tmp_path / "missing.py")], capsys)
    assert rc == 2 and "no such derivation script" in err


def _sigma(folder):
    with xr.open_dataset(folder / "paper_case_1.nc") as ds:
        return ds["sigma"].values.copy(), ds["u_N_m"].values.copy()


def test_simulate_flies_a_derived_law_with_set_parameters(pd_law, tmp_path, capsys):
    """``--law DIR --set K=0 --set P=0`` commands no torque: the run equals the open-loop run of the paper's law."""
    _, folder, _, _ = pd_law
    short = ["--scenario", "paper", "--case", "1", "--t-final", "0.2", "--no-figures", "--no-progress"]
    rc, out, err = _run(
        ["simulate", *short, "--law", str(folder), "--set", "K=0", "--set", "P=0.0", "--out", str(tmp_path / "zero")],
        capsys,
    )
    assert rc == 0, err
    assert "law: pd (pd.py)" in out and "law parameters: K=0.0 P=0.0" in out
    summary = json.loads((tmp_path / "zero" / "summary.json").read_text())
    assert summary["law"] == str(folder)
    assert summary["overrides"]["controller"] == {"law": str(folder), "K": 0, "P": 0.0}
    rc, _, err = _run(["simulate", *short, "--set", "enabled=false", "--out", str(tmp_path / "open")], capsys)
    assert rc == 0, err
    sigma_zero, u_zero = _sigma(tmp_path / "zero")
    sigma_open, _ = _sigma(tmp_path / "open")
    assert np.all(u_zero == 0.0)
    np.testing.assert_allclose(sigma_zero, sigma_open, rtol=0, atol=1e-12)
    rc, _, err = _run(["simulate", *short, "--law", str(folder), "--set", "K=2", "--out", str(tmp_path / "k2")], capsys)
    assert rc == 0, err
    sigma_k2, u_k2 = _sigma(tmp_path / "k2")
    assert np.abs(u_k2).max() > 0 and not np.allclose(sigma_k2, sigma_open)


@pytest.mark.parametrize(
    ("extra", "needle"),
    [
        (["--set", "K"], "expected KEY=VALUE"),
        (["--set", "K=[1,"], "is not a TOML value"),
        (["--set", "nope=1"], "has no parameter 'nope'"),
        (["--set", "K=-1"], "controller.K: must be >= 0, got -1"),
        (["--set", "K=[1, 2]"], "controller.K: expected"),
        (["--set", "law=fsm"], "--set law=...: use --law"),
    ],
)
def test_simulate_bad_law_parameters_exit_2_with_one_line(pd_law, extra, needle, tmp_path, capsys):
    _, folder, _, _ = pd_law
    rc, _, err = _run(["simulate", "--law", str(folder), *extra, "--out", str(tmp_path / "o")], capsys)
    assert rc == 2 and needle in err, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_simulate_unknown_law_exit_2(tmp_path, capsys):
    rc, _, err = _run(["simulate", "--law", "no-such-law", "--out", str(tmp_path / "o")], capsys)
    assert rc == 2 and "not a built-in law" in err and len(err.strip().splitlines()) == 1


def test_montecarlo_flies_a_derived_law(pd_law, tmp_path):
    _, folder, _, _ = pd_law
    cmd = [sys.executable, "-m", "fsmctl.cli.main", "montecarlo", "--runs", "2", "--t-final", "0.2", "--workers", "1"]
    cmd += ["--no-progress", "--law", str(folder), "--set", "K=2.0", "--out", str(tmp_path / "mc")]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    head = proc.stdout.splitlines()
    assert head[0].startswith("montecarlo: paper case 1: 6 agents")
    assert any(line.startswith(f"  law: pd ({folder}), parameters K=2.0") for line in head[:12]), head[:12]
    assert "2 ok, 0 failed" in proc.stdout
    meta = json.loads((tmp_path / "mc" / "campaign.json").read_text())
    assert json.loads(meta["controller"]) == {"law": str(folder), "K": 2.0}  # the law is recorded
    resume = subprocess.run([*cmd, "--resume"], capture_output=True, text=True, timeout=120)
    assert resume.returncode == 0, resume.stderr  # same law and parameters: nothing left to run
    other = [*cmd[:-2], "--set", "K=3.0", "--out", str(tmp_path / "mc"), "--resume"]
    other = [c for i, c in enumerate(other) if not (c == "K=2.0" or (c == "--set" and other[i + 1] == "K=2.0"))]
    mixed = subprocess.run(other, capture_output=True, text=True, timeout=120)
    assert mixed.returncode == 2 and "different settings (controller)" in mixed.stderr, mixed.stderr


# ----------------------------------------------------------------------------- --control-period, --seed (issue 13)


def test_simulate_control_period_and_seed_reach_the_scenario(tmp_path, capsys):
    out = tmp_path / "zoh"
    rc, printed, err = _run(
        ["simulate", "--t-final", "0.2", "--control-period", "0.05", "--seed", "3", "--no-figures", "--no-progress",
         "--out", str(out)],
        capsys,
    )  # fmt: skip
    assert rc == 0, err
    assert "control_period=0.05 s, seed=3" in printed
    summary = json.loads((out / "summary.json").read_text())
    assert summary["overrides"]["simulation"]["control_period"] == 0.05
    assert summary["overrides"]["simulation"]["seed"] == 3
    assert any("control_period=0.05 s, seed=3" in line for line in summary["settings"])
    with xr.open_dataset(out / "paper_case_1.nc") as ds:
        assert "control_period=0.05 s, seed=3" in ds.attrs["scenario"]
        u = ds["u_N_m"].values
    # zero-order hold: the applied torque changes only at the control instants (every 5 output samples of 10 ms)
    steps = np.flatnonzero(np.any(np.abs(np.diff(u, axis=0)) > 0, axis=(1, 2))) + 1
    assert steps.size and np.all(steps % 5 == 0)


def test_the_options_are_defined_once():
    """simulate, compare and montecarlo share the definitions of fsmctl.cli.run_options."""
    from fsmctl.cli import commands, compare, montecarlo, run_options
    from fsmctl.cli.main import build_parser

    sub = build_parser()._subparsers._group_actions[0].choices
    for name in ("simulate", "compare", "montecarlo"):
        actions = {a.dest: a for a in sub[name]._actions}
        assert actions["control_period"].type is run_options.number
        assert actions["control_period"].metavar == "SECONDS"
    assert sub["simulate"]._option_string_actions["--seed"].dest == "noise_seed"
    assert sub["compare"]._option_string_actions["--seed"].dest == "noise_seed"
    assert sub["montecarlo"]._option_string_actions["--seed"].dest == "seed"  # the campaign seed
    for module in (commands, compare, montecarlo):
        source = module.__loader__.get_source(module.__name__)
        assert '"--control-period"' not in source  # defined in run_options only


@pytest.mark.parametrize("command", ["simulate", "compare", "montecarlo"])
@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["--control-period", "-1"], "simulation.control_period: must be >= 0"),
        (["--control-period", "0.0015"], "control_period = 0.0015 must be a multiple of dt = 0.001"),
        (["--control-period", "nan"], "simulation.control_period: must be finite"),
        (["--control-period", "soon"], "argument --control-period: expected a number, got 'soon'"),
        (["--seed", "-1"], "simulation.seed: must be >= 0, got -1"),
        (["--seed", "1.5"], "simulation.seed: expected a whole number, got 1.5"),
        (["--seed", "x"], "argument --seed: expected a number, got 'x'"),
    ],
)
def test_bad_control_period_or_seed_exits_2_with_one_line(command, argv, needle, tmp_path, capsys):
    if command == "montecarlo" and argv[0] == "--seed":
        # montecarlo's --seed is the campaign seed (a whole number >= 0, checked by argparse)
        needle = "argument --seed: must be >= 0" if argv[1] == "-1" else "argument --seed: expected an integer"
    extra = {"compare": ["--laws", "fsm"], "montecarlo": ["--runs", "1", "--workers", "1", "--no-progress"]}
    rc, _, err = _run(
        [command, *extra.get(command, []), "--t-final", "0.2", *argv, "--out", str(tmp_path / "o")], capsys
    )
    assert rc == 2, err
    assert needle in err, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_hardware_scenario_needs_its_control_period(tmp_path, capsys):
    rc, _, err = _run(
        ["simulate", "--scenario", "paper-hardware", "--control-period", "0", "--out", str(tmp_path / "o")], capsys
    )
    assert rc == 2 and "sensors: sensors and imperfect links act at the control instants" in err
    assert len(err.strip().splitlines()) == 1


def test_compare_flies_every_run_with_the_control_period_and_seed(tmp_path, capsys):
    rc, printed, err = _run(
        ["compare", "--laws", "fsm", "--t-final", "0.2", "--control-period", "0.05", "--seed", "4", "--no-figures",
         "--out", str(tmp_path / "cmp")],
        capsys,
    )  # fmt: skip
    assert rc == 0, err
    assert "compare: every run with control_period=0.05 s, seed=4 (--control-period, --seed)" in printed
    assert "compare: paper case 1" in printed


# ----------------------------------------------------------------------------- --format, --precision, --from (issue 15)


@pytest.fixture(scope="module")
def format_runs(tmp_path_factory):
    """Case 1 for 0.1 s (10 ms output spacing) written three ways: NetCDF float64, CSV, NetCDF float32."""
    base = tmp_path_factory.mktemp("formats")
    common = ["simulate", "--case", "1", "--t-final", "0.1", "--no-figures", "--no-progress"]
    variants = {"nc64": [], "csv": ["--format", "csv"], "nc32": ["--precision", "float32"]}
    codes = {name: main([*common, *extra, "--out", str(base / name)]) for name, extra in variants.items()}
    return codes, base


def _csv_table(path):
    """Header and data rows of an fsmctl CSV result, read with the csv module (comment lines skipped)."""
    import csv

    with open(path, newline="") as fh:
        rows = [r for r in csv.reader(fh) if r and not r[0].startswith("#")]
    return rows[0], np.array(rows[1:], dtype=float)


def test_csv_has_one_row_per_time_and_named_columns_with_units(format_runs):
    codes, base = format_runs
    assert codes["csv"] == 0
    assert [p.name for p in base.glob("csv/paper_case_1.*")] == ["paper_case_1.csv"]  # no NetCDF file
    header, data = _csv_table(base / "csv" / "paper_case_1.csv")
    assert header[0] == "time_s" and len(set(header)) == len(header)
    np.testing.assert_allclose(data[:, 0], np.linspace(0.0, 0.1, 11), rtol=0, atol=1e-12)  # every 10 ms
    sc = oracle.paper_scenario()
    n = len(sc["sigma0"])
    for i in range(1, n + 1):  # <quantity>_<agent>_<axis>_<unit>, the unit's spaces and slashes as _
        for axis in "xyz":
            assert {f"sigma_{i}_{axis}", f"omega_{i}_{axis}_rad_s", f"u_{i}_{axis}_N_m"} <= set(header), (i, axis)
    assert {"aaem_deg", "raem_deg"} <= set(header)
    col = {name: data[:, k] for k, name in enumerate(header)}
    sigma0 = np.array([[col[f"sigma_{i}_{a}"][0] for a in "xyz"] for i in range(1, n + 1)])
    np.testing.assert_allclose(sigma0, np.array(sc["sigma0"]), rtol=0, atol=1e-15)  # Table 1, as flown
    errors = [oracle.mrp_error(s, np.array([-0.3, -0.4, 0.4])) for s in sc["sigma0"]]
    theta = np.array([oracle.principal_angle(e) for e in errors])
    assert col["aaem_deg"][0] == pytest.approx(oracle.aaem_deg(theta), abs=1e-9)  # eq 42, independent transcription
    assert col["raem_deg"][0] == pytest.approx(oracle.raem_deg(oracle.relative_angle_matrix(errors)), abs=1e-9)
    applied = [k for k, h in enumerate(header) if re.fullmatch(r"u_\d+_[xyz]_N_m", h)]
    assert len(applied) == 3 * n and np.abs(data[:, applied]).max() <= 2.0  # the paper's per-axis limit
    with xr.open_dataset(base / "nc64" / "paper_case_1.nc") as ds:  # the same run, written as NetCDF
        assert ds["u_N_m"].attrs["units"] == "N m" and ds["omega_rad_per_s"].attrs["units"] == "rad/s"
        np.testing.assert_array_equal(col["u_2_y_N_m"], ds["u_N_m"].values[:, 1, 1])  # 17 digits: exact
        np.testing.assert_array_equal(col["omega_3_z_rad_s"], ds["omega_rad_per_s"].values[:, 2, 2])
    summary = json.loads((base / "csv" / "summary.json").read_text())
    assert summary["format"] == "csv" and summary["files"] == ["paper_case_1.csv"]


def test_float32_precision_is_in_the_file(format_runs):
    codes, base = format_runs
    assert codes["nc32"] == 0 and codes["nc64"] == 0
    with (
        xr.open_dataset(base / "nc32" / "paper_case_1.nc") as single,
        xr.open_dataset(base / "nc64" / "paper_case_1.nc") as double,
    ):
        assert single["time_s"].dtype == np.float64  # the time stays exact
        for name in ("sigma", "omega_rad_per_s", "u_N_m", "aaem_deg"):
            assert single[name].dtype == np.float32, name
            assert double[name].dtype == np.float64, name
            np.testing.assert_array_equal(single[name].values, double[name].values.astype(np.float32))
    assert json.loads((base / "nc32" / "summary.json").read_text())["precision"] == "float32"


def _arrays(path):
    with xr.open_dataset(path) as ds:
        return {name: ds[name].values for name in ds.variables}, dict(ds.attrs)


@pytest.mark.parametrize("source", ["nc64/paper_case_1.nc", "csv/paper_case_1.csv"])
def test_from_a_result_flies_it_again_identically(source, format_runs, tmp_path, capsys):
    _, base = format_runs
    again = tmp_path / "again"
    rc, printed, err = _run(["simulate", "--from", str(base / source), "--out", str(again), "--no-figures"], capsys)
    assert rc == 0, err
    assert f"from {base / source}:" in printed and "paper case 1" in printed
    first, _ = _arrays(base / "nc64" / "paper_case_1.nc")
    second, attrs = _arrays(again / "paper_case_1.nc")
    assert first.keys() == second.keys()
    for name in first:
        np.testing.assert_array_equal(second[name], first[name], err_msg=name)  # bit for bit
    assert attrs["command"] == f"fsmctl simulate --from {base / source} --out {again} --no-figures"
    summary = json.loads((again / "summary.json").read_text())
    assert summary["from"] == str(base / source) and summary["overrides"]["simulation"] == {}


def test_from_with_overrides_applies_and_records_them(format_runs, tmp_path, capsys):
    _, base = format_runs
    out = tmp_path / "longer"
    argv = ["simulate", "--from", str(base / "nc64" / "paper_case_1.nc"), "--t-final", "0.2", "--format", "csv",
            "--torque-limit", "inf", "--no-figures", "--out", str(out)]  # fmt: skip
    rc, _, err = _run(argv, capsys)
    assert rc == 0, err
    header, data = _csv_table(out / "paper_case_1.csv")
    assert data[-1, 0] == pytest.approx(0.2) and data.shape[0] == 21
    summary = json.loads((out / "summary.json").read_text())
    assert summary["overrides"] == {
        "controller": {"torque_limit": "inf"},
        "simulation": {"t_final": 0.2, "output_interval": 0.01},  # the scenario's spacing, kept with the horizon
    }
    from fsmctl.simulation.results_io import load_result, scenario_from_result

    assert load_result(out / "paper_case_1.csv").attrs["command"] == "fsmctl " + " ".join(argv)
    flown = scenario_from_result(out / "paper_case_1.csv")  # the overrides are part of the embedded scenario
    assert flown.simulation.t_final == 0.2 and math.isinf(flown.controller.torque_limit)
    first, _ = _arrays(base / "nc64" / "paper_case_1.nc")
    u = data[:, [header.index(f"u_1_{a}_N_m") for a in "xyz"]]
    assert np.abs(u).max() > 2.0 >= np.abs(first["u_N_m"]).max()  # the limit was lifted


@pytest.mark.parametrize(
    ("content", "name"),
    [
        ("just some text\n", "notes.nc"),
        ("a,b\n1,2\n", "table.csv"),
        (None, "missing.nc"),
    ],
)
def test_from_a_file_that_is_not_a_result_exits_2_with_one_line(content, name, tmp_path, capsys):
    path = tmp_path / name
    if content is not None:
        path.write_text(content)
    rc, out, err = _run(["simulate", "--from", str(path), "--out", str(tmp_path / "o")], capsys)
    assert rc == 2, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert err.startswith("fsmctl simulate: error: ") and name in err, err
    assert not (tmp_path / "o").exists() and out == ""


def test_from_excludes_scenario_and_case(format_runs, tmp_path, capsys):
    _, base = format_runs
    result = str(base / "nc64" / "paper_case_1.nc")
    for extra in (["--scenario", "paper"], ["--case", "1"]):
        rc, _, err = _run(["simulate", "--from", result, *extra, "--out", str(tmp_path / "o")], capsys)
        assert rc == 2 and f"--from cannot be combined with {extra[0]}" in err, err
        assert len(err.strip().splitlines()) == 1
