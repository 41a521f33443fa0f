"""``fsmctl simulate`` (fsmctl/commands.py) and the figure builders (fsmctl/figures.py).

Oracles: the initial AAEM/RAEM (eqs 42-43) of the written NetCDF file are recomputed from
Table 1 with the independent NumPy transcription in ``tests/oracle_numpy.py``; exit codes and
one-line errors follow the contract of ``fsmctl/cli.py``.
"""

from __future__ import annotations

import json
import math
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
        (["simulate", "--bogus-option"], "unrecognized arguments"),
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


def test_torques_figure_one_panel_per_agent_with_limits():
    from fsmctl.studies.figures import torques_figure

    t = np.linspace(0, 10, 101)
    u = np.clip(np.sin(t)[:, None, None] * np.arange(1, 7)[None, :, None] * np.ones(3), -2, 2)
    fig = torques_figure(t, u, 2.0)
    assert len(fig.axes) == 6
    for i, ax in enumerate(fig.axes):
        assert ax.get_ylabel() == f"u{i + 1} (N m)"
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
