"""Result files a user can take elsewhere: NetCDF or CSV, each carrying the scenario that made it.

Every result file fsmctl writes embeds its **provenance** (:func:`provenance`, the one builder every writer
calls: ``fsmctl simulate``, and the Monte Carlo and reproduction writers): the complete scenario as TOML text
(:meth:`fsmctl.model.scenario.Scenario.to_toml`, self-contained: the flown case resolved), the case, the law
(its name, its content hash, the sha256 of its generated ``manifest.json``: :func:`law_content_sha256`, and
for a user's law its absolute path), the versions of fsmctl, Python, NumPy, SymPy, CasADi,
python-control and xarray, and the command line when one is given.  :func:`scenario_from_result` reads the
scenario back, so a result re-runs from itself (a user's law from its recorded absolute path; any law only if its
content hash is still the recorded one, a built-in law of another fsmctl included: else :class:`LawChangedError`)::

    fsmctl simulate --from runs/case1/result.nc

Formats (:func:`save_result`, also :meth:`fsmctl.simulation.result.SimulationResult.save`):

* **NetCDF** (``.nc``, NetCDF-4/HDF5 through ``h5netcdf``): the variables of
  :meth:`~fsmctl.simulation.result.SimulationResult.to_dataset`, compressed (zlib level 4 with the byte
  shuffle filter); ``precision="float32"`` stores the time series (every variable along ``time_s`` except the
  time itself) in single precision, about half the size again.  The provenance is the file's global
  attributes.  A float64 file holds the run's arrays bit for bit.
* **CSV** (``.csv``): one row per output sample, one column per scalar signal.  Column names are
  ``<quantity>[_<agent>][_<component>][_<unit>]``: the quantity as in the NetCDF variable name without its
  unit (``sigma``, ``omega``, ``sigma_e``, ``u``, ``u_unsaturated``, ``broadcast_s``, ``theta_e``, ``aaem``,
  ...), the agent number from 1, the component (``x``, ``y``, ``z`` for body axes; ``w1``, ``w2``, ... for
  wheels; ``0``, ``1``, ... for broadcast and law-state components), the unit last with spaces and slashes
  as ``_`` (``rad_s``, ``N_m``, ``deg``; none for dimensionless MRPs): ``time_s``, ``sigma_1_x``,
  ``omega_1_x_rad_s``, ``u_1_x_N_m``, ``aaem_deg``.  The metadata comes first, as ``#`` comment lines: a
  first line that says how many there are and how to read the table (``# fsmctl result, CSV: K comment
  lines ...``), then the
  provenance, one ``# key = <JSON value>`` per line (the scenario TOML is one JSON string), the coordinates
  (``# coords = {...}``) and the layout that maps the columns back to the NetCDF variables
  (``# layout = {...}``, with the per-agent statistics, which have no time axis).  The header is the line
  directly above the data, so ``pandas.read_csv(path, comment="#")`` reads the table, and so do
  ``numpy.genfromtxt(path, delimiter=",", names=True, skip_header=K)`` and
  ``numpy.loadtxt(path, delimiter=",", skiprows=K + 1)`` with ``K`` the number of comment lines the first
  line states (NumPy takes its names from the first line even when it is a comment).  Each value is the
  shortest decimal that reads back to the same double (the same single for ``float32`` series), so
  :func:`load_result` gives back the same :class:`xarray.Dataset` as the NetCDF
  file; with pandas pass ``float_precision="round_trip"`` for the exact bits (its default parser may differ
  in the last digit).

:func:`load_result` reads either format; a file that is not an fsmctl result raises
:class:`NotAResultError`, a result without the embedded scenario (written before it was embedded)
:class:`MissingScenarioError` from :func:`scenario_from_result`; both are :class:`~fsmctl.errors.InputError`.

Size: one file format, written and read here: the provenance, the NetCDF and CSV writers and the reader must
agree on every attribute, column name and layout entry, so the three sides of the format live together.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import platform
import shlex
import sys
import tomllib
import warnings
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from fsmctl.errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    import xarray as xr

    from fsmctl.model.laws import LawCode
    from fsmctl.model.scenario import Scenario
    from fsmctl.simulation.result import SimulationResult

__all__ = [
    "RESULT_FORMAT",
    "FORMATS",
    "PRECISIONS",
    "ResultFileError",
    "NotAResultError",
    "MissingScenarioError",
    "LawChangedError",
    "law_content_sha256",
    "problem_fingerprint",
    "fingerprint_change",
    "provenance",
    "versions",
    "save_result",
    "write_netcdf",
    "load_result",
    "scenario_from_result",
    "csv_column_names",
]

RESULT_FORMAT = "fsmctl-result 1"
"""The value of the ``fsmctl_result`` attribute that marks a file as an fsmctl result (name, layout version)."""
FORMATS = ("netcdf", "csv")
PRECISIONS = ("float64", "float32")
_SUFFIXES = {".nc": "netcdf", ".nc4": "netcdf", ".netcdf": "netcdf", ".csv": "csv"}
_COMPRESSION = {"zlib": True, "complevel": 4, "shuffle": True}
_AXES = ("x", "y", "z")
_CSV_MARK = "# fsmctl result, CSV:"
_CSV_FIRST_LINE = (
    _CSV_MARK + " {k} comment lines (this one, then the metadata as '# key = JSON value'), then the header, then one "
    'row per output time; read the table with pandas.read_csv(path, comment="#") or '
    'numpy.genfromtxt(path, delimiter=",", names=True, skip_header={k})'
)
"""The first line of a CSV result: how many comment lines precede the header, and how to read the table."""


class ResultFileError(InputError):
    """A result file cannot be used: unreadable, not a result, or without what was asked of it.

    An :class:`~fsmctl.errors.InputError`: the command line prints it as one line and exits 2.

    Examples
    --------
    >>> try:
    ...     load_result("missing.nc")
    ... except ResultFileError as exc:
    ...     print(exc)
    cannot read missing.nc: No such file or directory
    """


class NotAResultError(ResultFileError):
    """The file is not an fsmctl result (not NetCDF/CSV, or without fsmctl's marker attributes).

    Examples
    --------
    >>> _ = open("notes.csv", "w").write("a,b\\n1,2\\n")
    >>> try:
    ...     load_result("notes.csv")
    ... except NotAResultError as exc:
    ...     print(exc)
    notes.csv: not an fsmctl result file (neither NetCDF nor fsmctl's CSV)
    """


class MissingScenarioError(ResultFileError):
    """The result does not embed its scenario (written by an fsmctl older than the embedded provenance).

    Examples
    --------
    >>> import fsmctl
    >>> r = fsmctl.simulate(fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.1}))
    >>> r.to_dataset().to_netcdf("old.nc", engine="scipy")  # how results were written before
    >>> try:
    ...     scenario_from_result("old.nc")
    ... except MissingScenarioError as exc:
    ...     print(str(exc).split(";")[0])
    old.nc: this result does not embed its scenario (written by an older fsmctl)
    """


class LawChangedError(ResultFileError):
    """A result's law is no longer the one that was flown (a user law's script or folder changed, or another fsmctl's
    built-in law of that name): the law found now has another content hash (:func:`law_content_sha256`) than the one the result records, so a re-run would fly another law.

    Raised by :func:`scenario_from_result` (``fsmctl simulate --from``: one line, exit 2).

    Examples
    --------
    >>> issubclass(LawChangedError, ResultFileError)
    True
    """


# ----------------------------------------------------------------------------- provenance


def versions() -> dict[str, str]:
    """The versions that determine a result: fsmctl, Python, NumPy, SymPy, CasADi, python-control, xarray.

    Returns
    -------
    dict of str to str
        Package name to version (``"not installed"`` for an optional package that is absent).

    Examples
    --------
    >>> v = versions()
    >>> sorted(v)
    ['casadi', 'control', 'fsmctl', 'numpy', 'python', 'sympy', 'xarray']
    >>> v["python"].count(".")
    2
    """
    from importlib import metadata

    import fsmctl

    out = {"fsmctl": fsmctl.__version__, "python": platform.python_version()}
    for module, dist in (
        ("numpy", "numpy"),
        ("sympy", "sympy"),
        ("casadi", "casadi"),
        ("control", "control"),
        ("xarray", "xarray"),
    ):
        try:
            out[module] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            out[module] = "not installed"
    return out


def law_content_sha256(law: LawCode) -> str:
    """The sha256 of a law's generated ``manifest.json``, which lists the sha256 of every file of its folder.

    The law's content hash: two law folders with the same one fly the same law (same code, parameters, defaults
    and declarations), wherever they are.

    Parameters
    ----------
    law : LawCode
        A resolved law (:func:`fsmctl.model.resolve_law`, :attr:`fsmctl.model.scenario.Scenario.law`).

    Returns
    -------
    str
        64 hex digits.

    Raises
    ------
    ResultFileError
        The manifest cannot be read.

    Examples
    --------
    >>> from fsmctl.model import resolve_law
    >>> len(law_content_sha256(resolve_law("pid")))
    64
    """
    manifest = Path(law.folder) / "manifest.json"
    try:
        return hashlib.sha256(manifest.read_bytes()).hexdigest()
    except OSError as exc:  # the folder was just resolved, so this is the machine refusing
        raise ResultFileError(f"cannot read the law's manifest {manifest}: {exc.strerror or exc}") from None


def _law_provenance(scenario: Scenario) -> dict[str, str]:
    law = scenario.law
    out = {"law": law.name, "law_builtin": "true" if law.builtin else "false"}
    if not law.builtin:
        given = Path(scenario.controller.law).expanduser()  # a script or a derived folder
        out["law_path"] = str(given.resolve()) if given.exists() else scenario.controller.law
        out["law_folder"] = str(law.folder)
    # a built-in law too: another fsmctl's law of the same name may be another law (scenario_from_result checks it)
    out["law_manifest_sha256"] = law_content_sha256(law)
    return out


def problem_fingerprint(scenario: Scenario, law: str | None = None) -> dict[str, str]:
    """What the results of a study or campaign depend on besides its settings: recorded when it starts, checked
    when it is resumed (:func:`fingerprint_change`).

    ``fsmctl tune`` and ``fsmctl montecarlo`` record the settings they were given (file names, options); the
    problem those name can change under them (a scenario file edited, a law script re-derived, another fsmctl).
    Their trials or chunks must all come from one problem, so a resume whose fingerprint differs is refused.

    Parameters
    ----------
    scenario : Scenario
        The scenario as flown (case selected, the settings' changes applied).
    law : str, optional
        The law flown instead of ``scenario.controller.law`` (``fsmctl tune --law``).

    Returns
    -------
    dict of str to str
        ``scenario_sha256`` (of :meth:`~fsmctl.model.scenario.Scenario.to_toml`, the complete scenario),
        ``law`` (its name), ``law_sha256`` (:func:`law_content_sha256`) and ``fsmctl`` (the version, which decides
        the generated code and the simulator).

    Examples
    --------
    >>> import fsmctl
    >>> a = problem_fingerprint(fsmctl.paper_scenario("1"))
    >>> sorted(a), a["law"]
    (['fsmctl', 'law', 'law_sha256', 'scenario_sha256'], 'fsm')
    >>> b = problem_fingerprint(fsmctl.paper_scenario("1").replace(controller={"torque_limit": 0.01}))
    >>> fingerprint_change(a, b)
    'the scenario changed (its content as flown: torque limits, agents, horizon, ...)'
    """
    from fsmctl.model.laws import resolve_law
    from fsmctl.version import __version__

    code = scenario.law if law is None else resolve_law(law)
    return {
        "scenario_sha256": hashlib.sha256(scenario.to_toml().encode("utf-8")).hexdigest(),
        "law": code.name,
        "law_sha256": law_content_sha256(code),
        "fsmctl": __version__,
    }


def fingerprint_change(recorded: Mapping[str, Any] | None, now: Mapping[str, Any]) -> str | None:
    """What differs between a recorded :func:`problem_fingerprint` and the current one, in words; None if nothing.

    Parameters
    ----------
    recorded : mapping or None
        The fingerprint recorded when the study or campaign started (None: it recorded none).
    now : mapping
        The current one.

    Returns
    -------
    str or None
        The first difference (fsmctl version, law, scenario), or None when they are the same.

    Examples
    --------
    >>> fingerprint_change(None, {"fsmctl": "1.0"})
    'it records no fingerprint of its problem (started by an older fsmctl)'
    >>> fingerprint_change({"fsmctl": "0.9"}, {"fsmctl": "1.0"})
    'fsmctl changed (0.9 then, 1.0 now)'
    """
    if not isinstance(recorded, Mapping) or not recorded:
        return "it records no fingerprint of its problem (started by an older fsmctl)"
    if recorded.get("fsmctl") != now.get("fsmctl"):
        return f"fsmctl changed ({recorded.get('fsmctl')} then, {now.get('fsmctl')} now)"
    if recorded.get("law") != now.get("law"):
        return f"the law changed ({recorded.get('law')} then, {now.get('law')} now)"
    if recorded.get("law_sha256") != now.get("law_sha256"):
        then, current = str(recorded.get("law_sha256"))[:12], str(now.get("law_sha256"))[:12]
        return f"the law {now.get('law')} changed (its code or declarations: sha256 {then}... then, {current}... now)"
    if recorded.get("scenario_sha256") != now.get("scenario_sha256"):
        return "the scenario changed (its content as flown: torque limits, agents, horizon, ...)"
    if dict(recorded) != dict(now):
        keys = sorted(k for k in {*recorded, *now} if recorded.get(k) != now.get(k))
        return f"its fingerprint differs ({', '.join(keys)})"
    return None


def provenance(scenario: Scenario, *, command: Sequence[str] | str | None = None) -> dict[str, str]:
    """The attributes every fsmctl result file carries: where it came from, enough to run it again.

    The one builder of the provenance: :func:`save_result` (hence ``fsmctl simulate``) and the other writers
    of result files add these attributes as they are, so every file can be re-run with
    :func:`scenario_from_result`.

    Parameters
    ----------
    scenario : Scenario
        The scenario that was flown.
    command : sequence of str or str, optional
        The command line that produced the file (``sys.argv``), recorded as one shell-quoted string.

    Returns
    -------
    dict of str to str
        ``fsmctl_result`` (:data:`RESULT_FORMAT`), ``title``, ``source`` (the paper), ``scenario_label``,
        ``case`` (empty without one), ``scenario_toml`` (the complete scenario,
        :meth:`~fsmctl.model.scenario.Scenario.to_toml`), ``law``, ``law_builtin``, ``law_manifest_sha256`` (its
        content hash, :func:`law_content_sha256`) and, for a user's law, ``law_path`` (its script or folder) and
        ``law_folder`` (the derived code);
        ``version_<package>`` for each of :func:`versions`; ``command`` when given.  All values are strings
        (NetCDF attributes and CSV comment lines hold them alike).

    Raises
    ------
    ResultFileError
        The law's ``manifest.json`` cannot be read.

    Examples
    --------
    >>> import fsmctl
    >>> attrs = provenance(fsmctl.paper_scenario("2"), command=["fsmctl", "simulate", "--case", "2"])
    >>> attrs["fsmctl_result"], attrs["case"], attrs["law"], attrs["command"]
    ('fsmctl-result 1', '2', 'fsm', 'fsmctl simulate --case 2')
    >>> fsmctl.load_scenario.__module__ and attrs["scenario_toml"].splitlines()[1]
    'name = "paper"'
    """
    if command is not None and not isinstance(command, str):
        command = shlex.join(str(c) for c in command)
    attrs = {
        "fsmctl_result": RESULT_FORMAT,
        "title": f"fsmctl simulation: {scenario.label}",
        "source": "Liang, Sun & Wang, Acta Astronautica 81 (2012) 445-455",
        "scenario_label": scenario.label,
        "case": scenario.case or "",
        "scenario_toml": scenario.to_toml(),
        **_law_provenance(scenario),
        **{f"version_{k}": v for k, v in versions().items()},
    }
    if command is not None:
        attrs["command"] = command
    return attrs


# ----------------------------------------------------------------------------- writing


def _format_of(path: Path, format: str | None) -> str:
    if format is None:
        fmt = _SUFFIXES.get(path.suffix.lower())
        if fmt is None:
            raise InputError(
                f"{path}: cannot tell the result format from the suffix {path.suffix!r}; use .nc (NetCDF) or .csv, "
                "or pass format='netcdf' / 'csv'"
            )
        return fmt
    if not isinstance(format, str) or format.lower() not in FORMATS:
        raise InputError(f"format: must be one of {', '.join(FORMATS)} (or None: from the suffix), got {format!r}")
    return format.lower()


def _dataset(result: SimulationResult, precision: str, command) -> xr.Dataset:
    if not isinstance(precision, str) or precision.lower() not in PRECISIONS:
        raise InputError(f"precision: must be one of {', '.join(PRECISIONS)}, got {precision!r}")
    ds = result.to_dataset()
    ds.attrs.update(provenance(result.scenario, command=command))
    ds.attrs["precision"] = precision.lower()
    return ds


def _is_time_series(var) -> bool:
    return var.dims[:1] == ("time_s",) and var.dtype.kind == "f"


def save_result(
    result: SimulationResult,
    path: str | Path,
    *,
    format: str | None = None,
    precision: str = "float64",
    command: Sequence[str] | str | None = None,
) -> Path:
    """Write a run to a NetCDF or CSV file with its provenance, atomically (:mod:`fsmctl.outputs`).

    Parameters
    ----------
    result : SimulationResult
        The run.
    path : str or Path
        Target file (its folder must exist).
    format : {None, "netcdf", "csv"}
        None: from the suffix (``.nc`` NetCDF, ``.csv`` CSV).
    precision : {"float64", "float32"}
        Storage of the time series (the time itself stays float64; per-agent statistics stay float64).
    command : sequence of str or str, optional
        The command line, recorded in the file (:func:`provenance`).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    InputError
        An unknown format, suffix or precision.

    Examples
    --------
    >>> import fsmctl
    >>> r = fsmctl.simulate(fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.1}))
    >>> save_result(r, "run.nc", precision="float32").name
    'run.nc'
    >>> ds = load_result("run.nc")
    >>> str(ds["sigma"].dtype), str(ds["time_s"].dtype), ds.attrs["case"]
    ('float32', 'float64', '1')
    """
    from fsmctl.outputs import atomic_path

    path = Path(path)
    fmt = _format_of(path, format)
    ds = _dataset(result, precision, command)
    if fmt == "netcdf":
        return write_netcdf(ds, path, precision=ds.attrs["precision"])
    with atomic_path(path) as tmp:
        _write_csv(ds, tmp, ds.attrs["precision"] == "float32")
    return path


@contextlib.contextmanager
def _local_write_lock() -> Iterator[None]:
    """Make xarray take a local write lock even while a Dask client is the default scheduler.

    With a ``dask.distributed`` client active (the Monte Carlo ``--dask`` path), xarray asks the scheduler for a
    distributed lock named after the write target, which fails for an in-memory target ("Semaphore or Lock
    <BytesIO> not known").  The dataset written here is in memory (no Dask arrays), so the synchronous scheduler
    is the right one for the write itself.
    """
    if "dask" not in sys.modules:
        yield
        return
    import dask

    with dask.config.set(scheduler="synchronous"):
        yield


def write_netcdf(ds: xr.Dataset, path: str | Path, *, precision: str = "float64", compress: bool = True) -> Path:
    """Write a dataset as compressed NetCDF-4, atomically: the one NetCDF writer of fsmctl's result files.

    Every data variable is stored with zlib (level 4) and the shuffle filter; with ``precision="float32"`` the
    floating-point time series (variables whose first dimension is ``time_s``) are stored as float32, while the
    time itself and every other variable stay float64.  :func:`save_result` and the Monte Carlo campaign files
    (:mod:`fsmctl.studies.montecarlo`) write through it.  Without h5netcdf the file is an uncompressed NetCDF-3
    (SciPy), with a warning.

    Parameters
    ----------
    ds : xarray.Dataset
        The data, attributes included (:func:`provenance` for a result file).
    path : str or Path
        Target file (its folder must exist); replaced only once completely written (:mod:`fsmctl.outputs`).
    precision : {"float64", "float32"}
        Storage of the time series.
    compress : bool, optional
        ``False`` writes an uncompressed NetCDF-3 file (SciPy) instead: for intermediate files of many small
        variables, such as the Monte Carlo chunk files, which it writes about 5 times faster (0.06 s instead of
        0.33 s for a chunk of 10 runs: HDF5 creates every variable as an object of its own); every reader of
        NetCDF opens both.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    InputError
        An unknown precision.

    Examples
    --------
    >>> import numpy as np, xarray as xr
    >>> ds = xr.Dataset({"x": (("time_s",), np.linspace(0.0, 1.0, 5))}, coords={"time_s": np.linspace(0.0, 1.0, 5)})
    >>> write_netcdf(ds, "data.nc", precision="float32").name
    'data.nc'
    >>> with xr.open_dataset("data.nc") as back:
    ...     str(back["x"].dtype), back["x"].encoding["zlib"], float(back["x"][-1])
    ('float32', True, 1.0)
    >>> write_netcdf(ds, "chunk.nc", compress=False).name  # NetCDF-3, fast to write
    'chunk.nc'
    >>> open("chunk.nc", "rb").read(3)
    b'CDF'
    """
    from fsmctl.outputs import atomic_path

    if not isinstance(precision, str) or precision.lower() not in PRECISIONS:
        raise InputError(f"precision: must be one of {', '.join(PRECISIONS)}, got {precision!r}")
    single = precision.lower() == "float32"
    path = Path(path)
    encoding = {}
    for name, var in ds.variables.items():
        if name in ds.dims:
            continue  # coordinates: small, exact
        enc = dict(_COMPRESSION) if var.dtype.kind in "fiub" else {}
        if single and _is_time_series(var):
            enc["dtype"] = "float32"
        encoding[name] = enc
    engine = "h5netcdf" if compress and _h5netcdf_available() else "scipy"
    if compress and engine == "scipy":  # NetCDF-3 holds the same variables, uncompressed
        warnings.warn(
            "h5netcdf (with h5py) is not installed: writing an uncompressed NetCDF-3 file "
            "(pip install h5netcdf h5py for the compressed NetCDF-4 file)",
            stacklevel=2,
        )
    if engine == "scipy":  # no compression filters in NetCDF-3: only the storage type stays
        encoding = {k: {"dtype": v["dtype"]} for k, v in encoding.items() if "dtype" in v}
    # encoded in memory, then written as plain bytes: a full or failing disk is an ordinary OSError here, never an
    # HDF5 error inside the library (which can crash the interpreter when the half-written file is closed at exit)
    with _local_write_lock():
        data = ds.to_netcdf(engine=engine, encoding=encoding)
    with atomic_path(path) as tmp:
        tmp.write_bytes(bytes(data))
    return path


def _h5netcdf_available() -> bool:
    import importlib.util

    return importlib.util.find_spec("h5netcdf") is not None and importlib.util.find_spec("h5py") is not None


def _unit_suffix(units: str) -> str:
    u = units.strip()
    if u in ("", "1"):
        return ""
    return u.replace("/", "_").replace(" ", "_").replace("^", "")


def _base_name(name: str, units: str) -> str:
    """The NetCDF variable name without its unit (``omega_rad_per_s`` -> ``omega``, ``aaem_deg`` -> ``aaem``)."""
    for tail in ("_rad_per_s", "_N_m_s", "_N_m", "_deg"):
        if name.endswith(tail):
            return name[: -len(tail)]
    return name


def _component_labels(dim: str, size: int) -> list[str]:
    if dim == "axis":
        return list(_AXES[:size])
    if dim == "agent":
        return [str(k + 1) for k in range(size)]
    if dim == "wheel":
        return [f"w{k + 1}" for k in range(size)]
    return [str(k) for k in range(size)]


def csv_column_names(name: str, dims: Sequence[str], shape: Sequence[int], units: str) -> list[str]:
    """The CSV columns of one time series, in C order of its non-time dimensions.

    Parameters
    ----------
    name : str
        NetCDF variable name (``omega_rad_per_s``).
    dims : sequence of str
        Its dimensions, ``time_s`` first.
    shape : sequence of int
        Its shape.
    units : str
        Its ``units`` attribute (``"rad/s"``).

    Returns
    -------
    list of str
        ``<quantity>[_<agent>][_<component>][_<unit>]`` per scalar signal.

    Examples
    --------
    >>> csv_column_names("omega_rad_per_s", ("time_s", "agent", "axis"), (5, 2, 3), "rad/s")[:4]
    ['omega_1_x_rad_s', 'omega_1_y_rad_s', 'omega_1_z_rad_s', 'omega_2_x_rad_s']
    >>> csv_column_names("aaem_deg", ("time_s",), (5,), "deg"), csv_column_names("sigma", ("time_s", "axis"), (5, 3), "1")
    (['aaem_deg'], ['sigma_x', 'sigma_y', 'sigma_z'])
    """
    base, unit = _base_name(name, units), _unit_suffix(units)
    labels = [[]]
    for dim, size in zip(dims[1:], shape[1:], strict=True):
        labels = [[*head, c] for head in labels for c in _component_labels(dim, size)]
    return ["_".join([base, *parts] + ([unit] if unit else [])) for parts in labels]


def _jsonable_attr(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    return v


def _write_csv(ds: xr.Dataset, path: Path, single: bool) -> None:
    columns, blocks, layout = ["time_s"], [ds["time_s"].values[:, None]], {}
    # the data variables, then the coordinates that are not a dimension's index: a law's states are the variable
    # ``law_state`` along the dimension of the same name, which xarray keeps as a (non-index) coordinate
    extra = [(k, ds[k].variable) for k in ds.coords if k not in ds.indexes]
    for name, var in [*((k, v.variable) for k, v in ds.data_vars.items()), *extra]:
        entry = {
            "dims": list(var.dims),
            "shape": list(var.shape),
            "attrs": {k: _jsonable_attr(v) for k, v in var.attrs.items()},
        }
        if name in ds.coords:
            entry["coordinate"] = True
        if var.dims[:1] == ("time_s",):
            cols = csv_column_names(name, var.dims, var.shape, str(var.attrs.get("units", "1")))
            entry["columns"] = cols
            columns += cols
            values = var.values.reshape(var.shape[0], -1)
            blocks.append(values.astype(np.float32) if single and _is_time_series(var) else values)
        else:
            entry["values"] = var.values.tolist()
        layout[name] = entry
    coords = {k: ds[k].values.tolist() for k in ds.coords if k != "time_s" and k in ds.indexes}
    if len(set(columns)) != len(columns):  # two variables would share a column name: never an ambiguous table
        twice = sorted({c for c in columns if columns.count(c) > 1})
        raise InputError(f"{path}: the CSV column names are not unique ({twice[:3]})")
    # NumPy's shortest decimal that reads back to the same double (or single, for float32 series): exact, and
    # no digits the data do not have
    text = np.concatenate([b.astype(str) for b in blocks], axis=1).tolist()
    metadata = [f"# {key} = {json.dumps(_jsonable_attr(value))}" for key, value in ds.attrs.items()]
    metadata += [f"# coords = {json.dumps(coords)}", f"# layout = {json.dumps(layout, allow_nan=True)}"]
    with open(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(_CSV_FIRST_LINE.format(k=len(metadata) + 1) + "\n")  # the metadata first, the header above the data
        fh.write("\n".join(metadata) + "\n")
        fh.write(",".join(columns) + "\n")
        fh.write("\n".join(",".join(row) for row in text) + "\n")


# ----------------------------------------------------------------------------- reading


def _kind(path: Path) -> str:
    try:
        with open(path, "rb") as fh:
            head = fh.read(len(_CSV_MARK))
    except IsADirectoryError:
        raise NotAResultError(f"{path}: is a directory, not a result file") from None
    except OSError as exc:
        raise ResultFileError(f"cannot read {path}: {exc.strerror or exc}") from None
    if head.startswith(b"\x89HDF\r\n\x1a\n"):
        return "netcdf4"
    if head.startswith(b"CDF"):
        return "netcdf3"
    if head == _CSV_MARK.encode():
        return "csv"
    if head.startswith(b"time_s,"):
        raise NotAResultError(
            f"{path}: a CSV result of an earlier fsmctl (the header first, then the metadata), which this version "
            "does not read: write it again with this version"
        )
    raise NotAResultError(f"{path}: not an fsmctl result file (neither NetCDF nor fsmctl's CSV)")


def _check_marker(attrs: Mapping[str, Any], path: Path) -> None:
    marker = str(attrs.get("fsmctl_result", ""))
    if marker == RESULT_FORMAT:
        return
    if marker.startswith("fsmctl-result"):
        raise NotAResultError(
            f"{path}: an fsmctl result of another layout ({marker!r}; this fsmctl reads {RESULT_FORMAT!r})"
        )
    if not str(attrs.get("title", "")).startswith("fsmctl simulation"):
        raise NotAResultError(f"{path}: not an fsmctl result file (no fsmctl_result attribute)")


def _read_csv(path: Path) -> xr.Dataset:
    import xarray as xr

    attrs: dict[str, Any] = {}
    header: list[str] = []
    skip = 1
    try:
        with open(path, encoding="utf-8") as fh:
            fh.readline()  # the first line: what the file is (checked by _kind)
            for line in fh:
                skip += 1
                if not line.startswith("#"):
                    header = line.rstrip("\n").split(",")
                    break
                key, sep, value = line[2:].rstrip("\n").partition(" = ")
                if not line.startswith("# ") or not sep:
                    raise NotAResultError(f"{path}: line {skip} is not a '# key = value' metadata line")
                try:
                    attrs[key] = json.loads(value)
                except ValueError:
                    raise NotAResultError(f"{path}: line {skip}: the value of {key!r} is not JSON") from None
    except UnicodeDecodeError:
        raise NotAResultError(f"{path}: not an fsmctl result file (not UTF-8 text)") from None
    _check_marker(attrs, path)
    layout, coords = attrs.pop("layout", None), attrs.pop("coords", None)
    if not isinstance(layout, Mapping) or not isinstance(coords, Mapping):
        raise NotAResultError(f"{path}: an fsmctl CSV result needs its '# layout' and '# coords' lines")
    if not header:
        raise NotAResultError(f"{path}: no header line after the metadata")
    try:
        table = np.loadtxt(path, delimiter=",", skiprows=skip, ndmin=2, dtype=np.float64)
    except ValueError as exc:
        raise NotAResultError(f"{path}: the table is not numeric CSV ({exc})") from None
    if table.shape[1] != len(header):
        raise NotAResultError(f"{path}: {table.shape[1]} values per row but {len(header)} columns in the header")
    index = {c: k for k, c in enumerate(header)}
    single = attrs.get("precision") == "float32"
    variables, coord_variables = {}, {}
    try:
        for name, entry in layout.items():
            dims, shape = tuple(entry["dims"]), tuple(entry["shape"])
            if "columns" in entry:
                data = table[:, [index[c] for c in entry["columns"]]].reshape((table.shape[0], *shape[1:]))
                if single and dims[:1] == ("time_s",):
                    data = data.astype(np.float32)
            else:
                data = np.array(entry["values"], dtype=np.float64).reshape(shape)
            target = coord_variables if entry.get("coordinate") else variables
            target[name] = xr.Variable(dims, data, entry.get("attrs", {}))
    except (KeyError, TypeError, ValueError) as exc:
        raise NotAResultError(f"{path}: the CSV does not match its layout line ({exc})") from None
    coord_values: dict[str, Any] = {"time_s": ("time_s", table[:, index["time_s"]], {"units": "s"})}
    try:
        for k, v in coords.items():
            coord_values[k] = (k, np.asarray(v, dtype=np.int32))
        coord_values.update(coord_variables)
        return xr.Dataset(variables, coords=coord_values, attrs=attrs)
    except (TypeError, ValueError) as exc:
        raise NotAResultError(f"{path}: the CSV does not match its coords and layout lines ({exc})") from None


def load_result(path: str | Path) -> xr.Dataset:
    """Read an fsmctl result file (NetCDF or CSV) into an :class:`xarray.Dataset`, fully loaded.

    Both formats give the same variable names, dimensions, units and attributes (the provenance of
    :func:`provenance`), as written by :func:`save_result`.

    Parameters
    ----------
    path : str or Path
        A ``.nc`` or ``.csv`` result (the content decides, not the suffix).

    Returns
    -------
    xarray.Dataset
        Variables ``sigma``, ``omega_rad_per_s``, ``sigma_e``, ``u_N_m``, ``aaem_deg``, ... over ``time_s``,
        ``agent``, ``axis``; ``attrs`` with the provenance.

    Raises
    ------
    NotAResultError
        The file is not an fsmctl result.
    ResultFileError
        The file cannot be read.

    Examples
    --------
    >>> import fsmctl
    >>> r = fsmctl.simulate(fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.1}))
    >>> _ = r.save("run.csv")
    >>> ds = load_result("run.csv")
    >>> ds["omega_rad_per_s"].dims, bool((ds["omega_rad_per_s"].values == r.omega).all())
    (('time_s', 'agent', 'axis'), True)
    >>> ds.attrs["law"]
    'fsm'
    """
    import xarray as xr

    path = Path(path)
    kind = _kind(path)
    if kind == "csv":
        return _read_csv(path)
    engine = "h5netcdf" if kind == "netcdf4" else "scipy"
    try:
        with xr.open_dataset(path, engine=engine) as ds:
            ds.load()
    except Exception as exc:  # a damaged or foreign HDF5/NetCDF file: whatever the engine raises
        raise NotAResultError(f"{path}: not a readable NetCDF result ({type(exc).__name__}: {exc})") from None
    _check_marker(ds.attrs, path)
    return ds


def scenario_from_result(path: str | Path) -> Scenario:
    """The scenario a result file was flown with (re-run a result from itself).

    ``fsmctl.simulate(scenario_from_result(path))`` repeats the run: for a float64 NetCDF file its arrays
    equal the file's bit for bit (same fsmctl version and machine).

    Parameters
    ----------
    path : str or Path
        A result written by :func:`save_result` (NetCDF or CSV).

    Returns
    -------
    Scenario
        The embedded scenario, case selected.

    Raises
    ------
    MissingScenarioError
        The result does not embed its scenario.
    LawChangedError
        The law found now has another content hash than the one the result records: a built-in law of another
        fsmctl, or a user law (script or folder, found at the absolute path it records, else at the embedded path)
        that changed.
    ResultFileError
        The embedded scenario is not valid TOML or not a valid scenario.

    Examples
    --------
    >>> import fsmctl
    >>> s = fsmctl.paper_scenario("3a").replace(simulation={"t_final": 0.1})
    >>> _ = fsmctl.simulate(s).save("run.nc")
    >>> again = scenario_from_result("run.nc")
    >>> again == s, again.label
    (True, 'paper case 3a')
    """
    from fsmctl.model.scenario import ScenarioError, scenario_from_dict

    path = Path(path)
    attrs = load_result(path).attrs
    text = attrs.get("scenario_toml")
    if not isinstance(text, str) or not text.strip():
        raise MissingScenarioError(
            f"{path}: this result does not embed its scenario (written by an older fsmctl); run it again from "
            "its scenario file"
        )
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ResultFileError(f"{path}: the embedded scenario is not valid TOML ({exc})") from None
    case = attrs.get("case") or None
    recorded = attrs.get("law_manifest_sha256")
    law_path = attrs.get("law_path")
    controller = data.get("controller")
    if recorded and isinstance(law_path, str) and Path(law_path).is_absolute():
        embedded = controller.get("law") if isinstance(controller, dict) else None
        if Path(law_path).exists() and isinstance(embedded, str):
            # the law where it was flown (its absolute path), not whatever sits at a relative path from here
            controller["law"] = law_path
        elif isinstance(embedded, str) and not Path(embedded).expanduser().exists():
            raise ResultFileError(
                f"{path}: the law this result was flown with is gone from {law_path} (the absolute path it records) "
                f"and {embedded!r} is not found from here either: restore that law there, or fly the scenario afresh"
            )
    try:
        scenario = scenario_from_dict(data, case=case, where=f"{path} (embedded scenario)")
    except ScenarioError as exc:
        raise ResultFileError(str(exc)) from None
    if recorded:
        now = law_content_sha256(scenario.law)
        if now != recorded and scenario.law.builtin:
            raise LawChangedError(
                f"{path}: the law {scenario.controller.law} is not the one this result was flown with (content "
                f"sha256 {recorded[:12]}... recorded, {now[:12]}... now: another fsmctl generated this built-in law); "
                f"a re-run would fly another law: fly it with the fsmctl that made it (the result names fsmctl "
                f"{attrs.get('version_fsmctl', '?')}), or fly its embedded scenario (attribute scenario_toml) afresh"
            )
        if now != recorded:
            raise LawChangedError(
                f"{path}: the law {scenario.controller.law} is not the one this result was flown with (content "
                f"sha256 {recorded[:12]}... recorded for {law_path or 'it'}, {now[:12]}... now: its script, its folder "
                "or the code fsmctl generates from it changed); a re-run would fly another law: restore that law, or "
                "fly the scenario afresh"
            )
    return scenario
