"""Result files a user can take elsewhere (issue 15): scenario files, NetCDF/CSV results, reading them back.

Oracles: the scenario round trip is checked against the scenario itself (equality of every validated field),
the files against the run's own arrays (bit for bit), the columns against names written out by hand, the
sha256 of a user law's manifest against ``hashlib`` on the file, and the compression against the HDF5
filters h5py reports.
"""

from __future__ import annotations

import hashlib
import math
import tempfile
from pathlib import Path

import numpy as np
import pytest
from formations import PI_LAW
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import fsmctl
from fsmctl.errors import InputError
from fsmctl.model.scenario import Agent, load_scenario, paper_scenario, scenario_from_dict
from fsmctl.model.topology import Schedule, ring
from fsmctl.simulation.results_io import (
    MissingScenarioError,
    NotAResultError,
    ResultFileError,
    load_result,
    provenance,
    scenario_from_result,
)

ARRAYS = ("sigma", "omega", "sigma_e", "omega_e", "u", "u_unsaturated", "broadcast", "z", "sigma_d", "time")
"""the run's arrays that a re-run must reproduce bit for bit"""


# ----------------------------------------------------------------------------- scenarios to files


@pytest.fixture(scope="module")
def user_law(tmp_path_factory):
    folder = tmp_path_factory.mktemp("user_law")
    script = folder / "pi_law.py"
    script.write_text(PI_LAW)
    return script


def _ring_of_three() -> fsmctl.Scenario:
    """Three of the paper's spacecraft on a ring, with reaction wheels (per-wheel values), sensors, lossy links."""
    base = paper_scenario("1")
    three = base.replace(agents=base.agents[:3], topology=ring(3, 4.0, Schedule((0.0, 2.0), (1.5, 0.0), 4.0)))
    return three.replace(
        simulation={"t_final": 1.0, "dt": 0.01, "output_interval": 0.1, "control_period": 0.1, "seed": 7},
        actuator={
            "kind": "reaction_wheels",
            "layout": "orthogonal",
            "spin_inertia": [0.1, 0.12, 0.11],
            "max_torque": [0.5, math.inf, 0.4],
            "max_speed": 600.0,
            "viscous_friction": 1e-5,
            "initial_speed": [1.0, -2.0, 3.0],
        },
        sensors={
            "star_tracker": {"noise_std": [2.4e-5, 2.4e-5, 4.8e-5]},
            "gyro": {"angle_random_walk": 4.4e-5, "bias": [1e-6, 0.0, -2e-6]},
        },
        links={"delay": 0.1, "loss_table": [[0.0, 0.05, 0.1], [0.2, 0.0, 0.0], [0.3, 0.01, 0.0]]},
    )


BASES = ("1", "2", "3a", "3b", "3c", "paper-hardware", "ring3", "user-law")


def _base(key: str, user_law: Path) -> fsmctl.Scenario:
    if key == "paper-hardware":
        return load_scenario("paper-hardware")
    if key == "ring3":
        return _ring_of_three()
    if key == "user-law":
        return paper_scenario("2").replace(controller={"law": str(user_law), "parameters": {"K": 3.0, "Ki": 0.25}})
    return paper_scenario(key)


finite = st.floats(-0.9, 0.9, allow_nan=False, allow_infinity=False)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    key=st.sampled_from(BASES),
    seed=st.integers(0, 2**40),
    sigma0=st.lists(finite, min_size=3, max_size=3),
    scale=st.floats(0.5, 2.0),
    torque_limit=st.one_of(st.just(math.inf), st.floats(0.1, 10.0)),
    description=st.text(max_size=30),
    choice=st.text(min_size=1, max_size=20),
)
def test_scenario_file_round_trip(user_law, key, seed, sigma0, scale, torque_limit, description, choice):
    """Scenario -> dict/TOML -> Scenario gives the same scenario, for varied scenarios (arbitrary float bits)."""
    import dataclasses

    s = _base(key, user_law)
    agents = list(s.agents)
    agents[0] = dataclasses.replace(
        agents[0], sigma0=tuple(sigma0), J0=tuple(tuple(scale * x for x in row) for row in agents[0].J0)
    )
    agents[0] = dataclasses.replace(agents[0], delta_J=tuple(tuple(0.1 * x for x in row) for row in agents[0].J0))
    s = s.replace(agents=agents, simulation={"seed": seed}, controller={"torque_limit": torque_limit})
    s = dataclasses.replace(s, description=description, choices={**dict(s.choices), "test": choice})
    assert isinstance(s.agents[0], Agent)

    assert scenario_from_dict(s.to_dict(), case=s.case) == s
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "scenario.toml"
        path.write_text(s.to_toml(), encoding="utf-8")
        again = load_scenario(path)
    assert again == s
    assert again.case == s.case and again.label == s.label
    # every field spelled out: the equality above is not vacuous (the file is not the base's defaults)
    assert again.agents[0].sigma0 == tuple(sigma0) and again.simulation.seed == seed
    assert again.controller.torque_limit == torque_limit
    assert again.to_toml() == s.to_toml()


def test_the_file_holds_the_flown_case_only_and_selects_it(tmp_path):
    s = paper_scenario("3a")
    d = s.to_dict()
    assert d["cases"] == {"3a": {}}  # the other cases were overrides of the paper's base, not of this one
    assert d["topology"]["links"][0] == {
        "receiver": 1,
        "sender": 2,
        "k_i": 2.0,
        "phase": 0.0,
        "k_j": {"breakpoints": [0.0, 6.5], "values": [0.6, 0.0], "period": 8.0},
    }
    assert len(d["topology"]["links"]) == 30  # Table 2: every off-diagonal pair
    (tmp_path / "s.toml").write_text(s.to_toml())
    assert load_scenario(tmp_path / "s.toml").case == "3a"
    # a law parameter named like a [controller] agent default (delta) stays a law parameter
    pd = s.replace(controller={"parameters": {"delta": [0.01, 0.01, 0.01]}})
    assert pd.to_dict()["controller"]["parameters"] == {"delta": [0.01, 0.01, 0.01]}
    assert scenario_from_dict(pd.to_dict(), case="3a") == pd


def test_user_law_is_written_by_path(user_law, tmp_path):
    s = _base("user-law", user_law)
    text = s.to_toml()
    assert f"law = {str(user_law)!r}".replace("'", '"') in text
    assert "[controller.parameters]" in text and "K = 3.0" in text
    (tmp_path / "s.toml").write_text(text)
    assert load_scenario(tmp_path / "s.toml").law.name == "pi"


# ----------------------------------------------------------------------------- result files


@pytest.fixture(scope="module")
def short_run():
    s = paper_scenario("1").replace(simulation={"t_final": 0.5, "output_interval": 0.05})
    return fsmctl.simulate(s)


def _same_arrays(a, b) -> None:
    for name in ARRAYS:
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y), name


def test_netcdf_float64_holds_the_run_and_reruns_bit_for_bit(short_run, tmp_path):
    r = short_run
    path = r.save(tmp_path / "run.nc", command=["fsmctl", "simulate", "--case", "1", "--t-final", "0.5"])
    ds = load_result(path)
    assert np.array_equal(ds["time_s"].values, r.time)
    for name, values in (("sigma", r.sigma), ("omega_rad_per_s", r.omega), ("u_N_m", r.u), ("sigma_e", r.sigma_e)):
        assert ds[name].dtype == np.float64 and np.array_equal(ds[name].values, values), name
    assert np.array_equal(ds["aaem_deg"].values, r.aaem_deg) and np.array_equal(ds["raem_deg"].values, r.raem_deg)
    assert ds.attrs["command"] == "fsmctl simulate --case 1 --t-final 0.5"
    for package in ("fsmctl", "python", "numpy", "sympy", "casadi", "control", "xarray"):
        assert ds.attrs[f"version_{package}"], package
    assert ds.attrs["version_numpy"] == np.__version__
    assert ds.attrs["law"] == "fsm" and ds.attrs["case"] == "1"
    assert "t_final = 0.5" in ds.attrs["scenario_toml"]
    again = scenario_from_result(path)
    assert again == r.scenario
    _same_arrays(fsmctl.simulate(again), r)


def test_netcdf_is_compressed_and_float32_halves_the_series(short_run, tmp_path):
    h5py = pytest.importorskip("h5py")
    r = short_run
    p64 = r.save(tmp_path / "run64.nc")
    p32 = r.save(tmp_path / "run32.nc", precision="float32")
    with h5py.File(p64, "r") as f:
        assert f["sigma"].compression == "gzip" and f["sigma"].shuffle
        assert f["sigma"].dtype == np.float64
    with h5py.File(p32, "r") as f:
        assert f["sigma"].compression == "gzip" and f["sigma"].dtype == np.float32
        assert f["time_s"].dtype == np.float64  # time stays double
        assert f["saturated_time_s"].dtype == np.float64  # per-agent statistics are not time series
    ds = load_result(p32)
    assert ds.attrs["precision"] == "float32"
    assert np.array_equal(ds["time_s"].values, r.time)
    assert np.array_equal(ds["sigma"].values, r.sigma.astype(np.float32))
    assert np.array_equal(ds["u_N_m"].values, r.u.astype(np.float32))
    assert p32.stat().st_size < p64.stat().st_size
    assert scenario_from_result(p32) == r.scenario  # the scenario is text: exact in either precision


def test_csv_columns_metadata_and_readers(short_run, tmp_path):
    pd = pytest.importorskip("pandas")
    r = short_run
    path = r.save(tmp_path / "run.csv", command="fsmctl simulate --format csv")
    df = pd.read_csv(path, comment="#", float_precision="round_trip")
    assert len(df) == r.time.size
    expected = {
        "time_s": r.time,
        "sigma_1_x": r.sigma[:, 0, 0],
        "sigma_6_z": r.sigma[:, 5, 2],
        "omega_1_x_rad_s": r.omega[:, 0, 0],
        "omega_4_y_rad_s": r.omega[:, 3, 1],
        "u_1_x_N_m": r.u[:, 0, 0],
        "u_unsaturated_2_z_N_m": r.u_unsaturated[:, 1, 2],
        "sigma_e_3_y": r.sigma_e[:, 2, 1],
        "theta_e_5_deg": np.degrees(r.theta_e[:, 4]),
        "sigma_d_x": r.sigma_d[:, 0],
        "aaem_deg": r.aaem_deg,
        "raem_deg": r.raem_deg,
    }
    for column, values in expected.items():
        assert np.array_equal(df[column].to_numpy(), values), column  # shortest round-trip decimals: float64 exactly
    # the metadata first (comment lines), the header directly above the data: the first line says how many
    lines = path.read_text(encoding="utf-8").splitlines()
    comments = sum(1 for line in lines if line.startswith("#"))
    assert all(line.startswith("#") for line in lines[:comments]) and lines[comments].split(",") == list(df.columns)
    assert f"{comments} comment lines" in lines[0] and f"skip_header={comments}" in lines[0]
    assert [float(x) for x in lines[comments + 1].split(",")] == df.iloc[0].tolist()
    table = np.genfromtxt(path, delimiter=",", names=True, skip_header=comments)  # as the first line says
    assert np.array_equal(table["omega_1_x_rad_s"], r.omega[:, 0, 0]) and table.size == r.time.size
    ds = load_result(path)
    assert ds.attrs["command"] == "fsmctl simulate --format csv"
    nc = load_result(r.save(tmp_path / "run.nc"))
    assert set(ds.variables) == set(nc.variables)
    for name in nc.variables:
        assert ds[name].dims == nc[name].dims, name
        assert ds[name].dtype == nc[name].dtype and np.array_equal(ds[name].values, nc[name].values), name
        assert ds[name].attrs.get("units") == nc[name].attrs.get("units"), name
    for key in ("scenario_toml", "law", "case", "version_casadi", "fsmctl_result"):
        assert ds.attrs[key] == nc.attrs[key], key
    _same_arrays(fsmctl.simulate(scenario_from_result(path)), r)


def test_format_and_precision_arguments(short_run, tmp_path):
    r = short_run
    path = r.save(tmp_path / "run.dat", format="CSV")
    assert load_result(path)["sigma"].shape == r.sigma.shape
    with pytest.raises(InputError, match="suffix"):
        r.save(tmp_path / "run.txt")
    with pytest.raises(InputError, match="format"):
        r.save(tmp_path / "run.nc", format="hdf5")
    with pytest.raises(InputError, match="precision"):
        r.save(tmp_path / "run.nc", precision="float16")
    assert not (tmp_path / "run.txt").exists() and not (tmp_path / "run.nc").exists()


def test_user_law_provenance(user_law, tmp_path):
    s = _base("user-law", user_law).replace(simulation={"t_final": 0.2, "output_interval": 0.1})
    attrs = provenance(s)
    folder = Path(attrs["law_folder"])
    assert attrs["law"] == "pi" and attrs["law_builtin"] == "false"
    assert attrs["law_path"] == str(user_law.resolve())
    assert attrs["law_manifest_sha256"] == hashlib.sha256((folder / "manifest.json").read_bytes()).hexdigest()
    assert "command" not in attrs
    r = fsmctl.simulate(s)
    path = r.save(tmp_path / "pi.nc")
    _same_arrays(fsmctl.simulate(scenario_from_result(path)), r)
    assert provenance(paper_scenario("1")).get("law_path") is None


def test_files_that_are_not_results(short_run, tmp_path):
    xr = pytest.importorskip("xarray")
    text = tmp_path / "notes.csv"
    text.write_text("a,b\n1,2\n")
    with pytest.raises(NotAResultError, match="not an fsmctl result"):
        load_result(text)
    foreign = tmp_path / "foreign.nc"
    xr.Dataset({"x": ("t", np.arange(3.0))}).to_netcdf(foreign, engine="scipy")
    with pytest.raises(NotAResultError, match="no fsmctl_result"):
        load_result(foreign)
    with pytest.raises(NotAResultError, match="directory"):
        load_result(tmp_path)
    with pytest.raises(ResultFileError, match="cannot read"):
        load_result(tmp_path / "missing.nc")
    # a result written before the scenario was embedded: readable, but it cannot re-run itself
    old = tmp_path / "old.nc"
    short_run.to_dataset().to_netcdf(old, engine="scipy")
    assert np.array_equal(load_result(old)["sigma"].values, short_run.sigma)
    with pytest.raises(MissingScenarioError, match="does not embed its scenario"):
        scenario_from_result(old)
    # a CSV whose layout line no longer matches its columns
    good = short_run.save(tmp_path / "run.csv").read_text().splitlines()
    at = next(k for k, line in enumerate(good) if not line.startswith("#"))  # the header
    broken = tmp_path / "broken.csv"
    broken.write_text("\n".join([*good[:at], good[at].replace("sigma_1_x", "renamed"), *good[at + 1 :]]) + "\n")
    with pytest.raises(NotAResultError, match="layout"):
        load_result(broken)
    # the layout of fsmctl before the metadata came first (the header, then the comment lines): one clear line
    earlier = tmp_path / "earlier.csv"
    earlier.write_text("\n".join([good[at], *good[1:at], *good[at + 1 :]]) + "\n")
    with pytest.raises(NotAResultError, match="earlier fsmctl"):
        load_result(earlier)
    for error in (NotAResultError, MissingScenarioError):
        assert issubclass(error, InputError)


def test_without_h5netcdf_the_file_is_uncompressed_netcdf3(short_run, tmp_path, monkeypatch):
    from fsmctl.simulation import results_io

    monkeypatch.setattr(results_io, "_h5netcdf_available", lambda: False)
    with pytest.warns(UserWarning, match="h5netcdf"):
        path = short_run.save(tmp_path / "run.nc")
    assert path.read_bytes()[:3] == b"CDF"  # NetCDF-3 (the HDF5 signature is b"\x89HDF")
    ds = load_result(path)
    assert np.array_equal(ds["omega_rad_per_s"].values, short_run.omega)
    assert scenario_from_result(path) == short_run.scenario
