"""The record of one flown run and its metrics: what every study keeps of a simulation, and its files.

A :class:`RunRecord` holds what a study reads from one simulation once the simulation itself is gone: which
scenario was flown (its label, the law, a fingerprint of the flown settings), the AAEM/RAEM series (Liang, Sun &
Wang 2012, eqs 42-43) that the settling times and the overlay figures need, the engine's summary
(:meth:`SimulationResult.summary <fsmctl.simulation.simulator.SimulationResult.summary>`), the steady-state maxima,
named scalar metrics (units in the names), the files written for it, its cost, and, for a run the integrator could
not fly, why (:attr:`RunRecord.error`).

This module is the one that writes and reads records: :meth:`RunRecord.to_json` is the entry of a run in
``fsmctl reproduce``'s ``claims.json`` (``"runs"``), :meth:`RunRecord.from_json` reads it back (the series from the
run's NetCDF file); :func:`write_csv` / :func:`read_csv` hold one row of scalar metrics per run.
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fsmctl.outputs import atomic_path

__all__ = ["FLOWN_SECTIONS", "RunRecord", "scenario_fingerprint", "write_csv", "read_csv", "CSV_FIELDS"]

FLOWN_SECTIONS = ("simulation", "controller", "actuator", "sensors", "links", "reference", "topology", "agents")
"""The scenario sections that decide what is simulated (not its name, description or cases)."""


def scenario_fingerprint(scenario) -> str:
    """A short hash of what a scenario flies: two scenarios with the same fingerprint give the same run.

    Parameters
    ----------
    scenario : Scenario
        The scenario (its :data:`FLOWN_SECTIONS`, as :meth:`fsmctl.model.scenario.Scenario.to_dict` writes them).

    Returns
    -------
    str
        16 hexadecimal digits (SHA-256 of the sections' JSON).

    Examples
    --------
    The paper's Case 3c has Case 1's settings (another description, the same flight):

    >>> import fsmctl
    >>> scenario_fingerprint(fsmctl.paper_scenario("1")) == scenario_fingerprint(fsmctl.paper_scenario("3c"))
    True
    >>> scenario_fingerprint(fsmctl.paper_scenario("1")) == scenario_fingerprint(fsmctl.paper_scenario("2"))
    False
    """
    data = scenario.to_dict()
    flown = {k: data.get(k) for k in FLOWN_SECTIONS}
    text = json.dumps(flown, sort_keys=True, default=repr, allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass
class RunRecord:
    """One flown run and its metrics (the full time series is in its NetCDF file, when saved).

    Parameters
    ----------
    key : str
        File-safe name of the run (``case1``, ``case1_no_torque_limit``, ...).
    label : str
        The scenario's label.
    t_final : float
        Horizon flown (s).
    torque_limit : float
        Per-axis torque limit (N m; ``inf`` when none).
    summary : dict
        ``SimulationResult.summary`` (saturation times, peaks, settling at the study's tolerances).
    time : (T,) array
        Output times (s), kept with the metrics for the settling times and the overlay figures.
    aaem_deg, raem_deg : (T,) array
        AAEM (Liang et al. 2012, eq 42) and RAEM (eq 43), deg.
    theta_e0_deg : list of float
        ``theta_ei(0)`` per agent (eq 2), deg.
    theta_e_peak_deg : float
        Largest ``theta_ei`` over the run, deg.
    steady_window_s : float
        Length of the final window of the steady-state maxima (s).
    aaem_steady_max_deg, raem_steady_max_deg : float
        Maxima of AAEM and RAEM over that window, deg.
    law : str
        The law flown (its name).
    fingerprint : str
        :func:`scenario_fingerprint` of the scenario flown.
    title, purpose, overrides, case : str
        What the study says of the run (``case``: the paper case).
    describe : list of str
        The scenario's settings, one per line (``Scenario.describe()``).
    metrics : dict of str -> float
        Further named metrics, the unit in each name (``u_peak_N_m``).
    netcdf : str
        The run's NetCDF file ("" when not saved).
    figures : list of str
        The run's figure files.
    wall_time_s, cpu_time_s : float
        Wall and CPU time of the simulation (s).
    same_as : str
        Key of an identical run whose results this record reuses ("" when simulated).
    warnings : list of str
        The run's warnings, one line each.
    error : str
        Why the simulation failed ("" when it did not; then the series are empty and the metrics NaN).

    Examples
    --------
    A 1 s run of the paper's Case 1:

    >>> import fsmctl
    >>> scenario = fsmctl.paper_scenario("1").replace(simulation={"t_final": 1.0})
    >>> rec = RunRecord.from_result("case1", scenario, fsmctl.simulate(scenario), steady_window_s=0.4)
    >>> rec.key, rec.law, rec.t_final, rec.torque_limit
    ('case1', 'fsm', 1.0, 2.0)
    >>> rec.settled(1.0), rec.settling("aaem", 1.0)  # AAEM(0) is about 135 deg: far from settled after 1 s
    (False, nan)
    >>> RunRecord.failed("case1", "SimulationError: step too large").ok
    False
    """

    key: str
    label: str
    t_final: float
    torque_limit: float
    summary: dict
    time: np.ndarray
    aaem_deg: np.ndarray
    raem_deg: np.ndarray
    theta_e0_deg: list[float]
    theta_e_peak_deg: float
    steady_window_s: float
    aaem_steady_max_deg: float
    raem_steady_max_deg: float
    law: str = ""
    fingerprint: str = ""
    title: str = ""
    purpose: str = ""
    overrides: str = ""
    case: str = ""
    describe: list[str] = field(default_factory=list)
    metrics: dict[str, float] = field(default_factory=dict)
    """further named metrics, the unit in each name"""
    netcdf: str = ""
    figures: list[str] = field(default_factory=list)
    wall_time_s: float = 0.0
    cpu_time_s: float = 0.0
    same_as: str = ""
    """key of an identical run whose results this record reuses ("" if simulated)"""
    warnings: list[str] = field(default_factory=list)
    error: str = ""
    """why the simulation failed ("" if it did not)"""

    @classmethod
    def from_result(
        cls,
        key: str,
        scenario,
        result,
        *,
        steady_window_s: float,
        tolerances_deg: Sequence[float] = (1.0,),
        **fields: Any,
    ) -> RunRecord:
        """The record of one simulation.

        Parameters
        ----------
        key : str
            The run's name.
        scenario : Scenario
            What was flown.
        result : SimulationResult
            Its simulation.
        steady_window_s : float
            Length of the final window of the steady-state maxima (s).
        tolerances_deg : sequence of float
            The settling tolerances of the summary (deg).
        **fields
            Further fields of :class:`RunRecord` (``title``, ``netcdf``, ``metrics``, ...).

        Returns
        -------
        RunRecord
            With the scenario's label, law and fingerprint.

        Examples
        --------
        >>> import fsmctl
        >>> scenario = fsmctl.paper_scenario("2").replace(simulation={"t_final": 2.0})
        >>> rec = RunRecord.from_result("case2", scenario, fsmctl.simulate(scenario), steady_window_s=0.8)
        >>> rec.steady_window_s, len(rec.theta_e0_deg)  # one angle per spacecraft
        (0.8, 6)
        """
        summary = result.summary(tolerances_deg=tuple(tolerances_deg), steady_window=steady_window_s)
        theta_deg = np.degrees(result.theta_e)
        return cls(
            key=key,
            label=scenario.label,
            t_final=scenario.simulation.t_final,
            torque_limit=scenario.controller.torque_limit,
            summary=summary,
            time=result.time,
            aaem_deg=result.aaem_deg,
            raem_deg=result.raem_deg,
            theta_e0_deg=[float(x) for x in theta_deg[0]],
            theta_e_peak_deg=float(theta_deg.max()),
            steady_window_s=steady_window_s,
            aaem_steady_max_deg=float(summary["aaem_steady_max_deg"]),
            raem_steady_max_deg=float(summary["raem_steady_max_deg"]),
            law=scenario.law.name,
            fingerprint=scenario_fingerprint(scenario),
            **fields,
        )

    @classmethod
    def failed(cls, key: str, error: str, **fields: Any) -> RunRecord:
        """The record of a run the integrator could not fly: no series, NaN metrics, the reason in ``error``.

        Parameters
        ----------
        key : str
            The run's name.
        error : str
            Why it failed (one line).
        **fields
            Further fields of :class:`RunRecord`.

        Returns
        -------
        RunRecord
            With :attr:`ok` False.

        Examples
        --------
        >>> rec = RunRecord.failed("case1", "SimulationError: the step size is too large")
        >>> rec.ok, rec.error
        (False, 'SimulationError: the step size is too large')
        """
        nan, empty = math.nan, np.zeros(0)
        return cls(key, "", nan, nan, {}, empty, empty, empty, [], nan, nan, nan, nan, error=error, **fields)

    @property
    def ok(self) -> bool:
        """bool: Whether the run was flown (no :attr:`error`)."""
        return not self.error

    def settling(self, metric: str, tolerance_deg: float) -> float:
        """Settling time of AAEM or RAEM to a tolerance (:func:`fsmctl.simulation.metrics.settling_time`).

        Parameters
        ----------
        metric : {"aaem", "raem"}
            The metric (eq 42 or eq 43).
        tolerance_deg : float
            The tolerance (deg).

        Returns
        -------
        float
            The first time (s) after which the metric stays at or below the tolerance; NaN if it never does.
        """
        from fsmctl.simulation.metrics import settling_time

        series = self.aaem_deg if metric == "aaem" else self.raem_deg
        return settling_time(self.time, series, tolerance_deg)

    def settled(self, tolerance_deg: float) -> bool:
        """Whether both AAEM and RAEM settle to ``tolerance_deg`` within the horizon.

        Parameters
        ----------
        tolerance_deg : float
            The tolerance (deg).

        Returns
        -------
        bool
            True when both settling times are finite.
        """
        return all(math.isfinite(self.settling(m, tolerance_deg)) for m in ("aaem", "raem"))

    @property
    def last_saturation_s(self) -> float:
        """float: The last output time (s) a commanded torque component exceeded the limit (NaN: never)."""
        return float(self.summary["last_saturation_s"])

    @property
    def saturated_time_s(self) -> list[float]:
        """list of float: Time (s) each agent spent with a torque component at the limit."""
        return [float(x) for x in self.summary["saturated_time_s"]]

    @property
    def commanded_peak_N_m(self) -> float:
        """float: Largest commanded (unsaturated) torque component over the run (N m)."""
        return float(self.summary["u_unsaturated_max_N_m"])

    def same_numbers(self, other: RunRecord) -> bool:
        """Bit-identical metric series and last saturation time (NaN = never); two failed runs count as the same.

        Parameters
        ----------
        other : RunRecord
            Another flight of the same run (e.g. re-loaded from its scenario file).

        Returns
        -------
        bool
            True when the two runs agree to the last bit.

        Examples
        --------
        >>> RunRecord.failed("a", "x").same_numbers(RunRecord.failed("a", "y"))
        True
        """
        if not (self.ok and other.ok):
            return self.ok == other.ok
        la, lb = self.last_saturation_s, other.last_saturation_s
        return (
            np.array_equal(self.time, other.time)
            and np.array_equal(self.aaem_deg, other.aaem_deg)
            and np.array_equal(self.raem_deg, other.raem_deg)
            and (la == lb or (math.isnan(la) and math.isnan(lb)))
        )

    # ------------------------------------------------------------------------- files

    def to_json(self, out_dir: str | Path, tolerances_deg: Sequence[float]) -> dict[str, Any]:
        """The run's entry in a study's JSON file (``claims.json``'s ``"runs"``); :meth:`from_json` reads it.

        Parameters
        ----------
        out_dir : str or Path
            The study's folder: the NetCDF path is written relative to it when inside it.
        tolerances_deg : sequence of float
            The settling tolerances reported (deg).

        Returns
        -------
        dict
            Title, purpose, overrides, scenario label, horizon, NetCDF file, settling times per tolerance, steady
            window and maxima, ``theta_e(0)`` and the engine's summary (pass it to
            :func:`fsmctl.outputs.write_json`, which writes NaN as ``null``).
        """
        out = Path(out_dir)
        nc = Path(self.netcdf)
        return {
            "title": self.title,
            "purpose": self.purpose,
            "overrides": self.overrides,
            "scenario": self.label,
            "t_final_s": self.t_final,
            "netcdf": str(nc.relative_to(out)) if nc.is_relative_to(out) else self.netcdf,
            "aaem_settling_s": {f"{t:g}": self.settling("aaem", t) for t in tolerances_deg},
            "raem_settling_s": {f"{t:g}": self.settling("raem", t) for t in tolerances_deg},
            "steady_window_s": self.steady_window_s,
            "aaem_steady_max_deg": self.aaem_steady_max_deg,
            "raem_steady_max_deg": self.raem_steady_max_deg,
            "theta_e0_deg": self.theta_e0_deg,
            "summary": self.summary,
        }

    @classmethod
    def from_json(cls, key: str, entry: Mapping[str, Any], out_dir: str | Path) -> RunRecord:
        """Read back a run written by :meth:`to_json`; the series come from its NetCDF file.

        Parameters
        ----------
        key : str
            The run's name (the key of ``entry`` in ``"runs"``).
        entry : mapping
            The parsed JSON entry (``null`` for NaN, ``"inf"`` for infinity).
        out_dir : str or Path
            The study's folder (the NetCDF path is relative to it).

        Returns
        -------
        RunRecord
            With the series of the NetCDF file (empty if it is missing); the torque limit and the peak of
            ``theta_e`` are not in the entry (NaN).
        """
        import xarray as xr

        nc = Path(out_dir) / entry["netcdf"]
        time = aaem = raem = np.zeros(0)
        if nc.is_file():
            with xr.open_dataset(nc) as ds:
                time, aaem, raem = (np.asarray(ds[v].values, float) for v in ("time_s", "aaem_deg", "raem_deg"))
        summary = _from_jsonable(entry["summary"])
        return cls(
            key=key,
            label=entry["scenario"],
            t_final=_number(entry["t_final_s"]),
            torque_limit=math.nan,  # not in the entry
            summary=summary,
            time=time,
            aaem_deg=aaem,
            raem_deg=raem,
            theta_e0_deg=[_number(x) for x in entry["theta_e0_deg"]],
            theta_e_peak_deg=math.nan,
            steady_window_s=_number(entry["steady_window_s"]),
            aaem_steady_max_deg=_number(entry["aaem_steady_max_deg"]),
            raem_steady_max_deg=_number(entry["raem_steady_max_deg"]),
            title=entry["title"],
            purpose=entry["purpose"],
            overrides=entry["overrides"],
            netcdf=str(nc),
        )

    def to_row(self) -> dict[str, Any]:
        """The run's scalar metrics as one CSV row (:data:`CSV_FIELDS`, then the named :attr:`metrics`).

        Returns
        -------
        dict
            Column name (unit in the name) -> value.

        Examples
        --------
        >>> rec = RunRecord.failed("case1", "diverged", metrics={"u_peak_N_m": 2.0})
        >>> row = rec.to_row()
        >>> row["key"], row["error"], row["u_peak_N_m"]
        ('case1', 'diverged', 2.0)
        """
        row = {name: getattr(self, name) for name in CSV_FIELDS}
        row.update(self.metrics)
        return row

    @classmethod
    def from_row(cls, row: Mapping[str, str]) -> RunRecord:
        """A record (without series or summary) from one row of :func:`write_csv`.

        Parameters
        ----------
        row : mapping of str -> str
            One row, as :class:`csv.DictReader` reads it.

        Returns
        -------
        RunRecord
            The scalar fields and the named metrics.
        """
        numbers = {k: float(row[k]) if row[k] != "" else math.nan for k in _CSV_NUMBERS}
        texts = {k: row[k] for k in CSV_FIELDS if k not in _CSV_NUMBERS}
        metrics = {k: float(v) if v != "" else math.nan for k, v in row.items() if k not in CSV_FIELDS}
        empty = np.zeros(0)
        return cls(
            summary={}, time=empty, aaem_deg=empty, raem_deg=empty, theta_e0_deg=[], metrics=metrics, **numbers, **texts
        )


CSV_FIELDS = (
    "key",
    "label",
    "law",
    "fingerprint",
    "case",
    "overrides",
    "t_final",
    "torque_limit",
    "theta_e_peak_deg",
    "steady_window_s",
    "aaem_steady_max_deg",
    "raem_steady_max_deg",
    "wall_time_s",
    "cpu_time_s",
    "same_as",
    "error",
)
"""The fixed columns of a record's CSV row (the named metrics follow)."""
_CSV_NUMBERS = (
    "t_final",
    "torque_limit",
    "theta_e_peak_deg",
    "steady_window_s",
    "aaem_steady_max_deg",
    "raem_steady_max_deg",
    "wall_time_s",
    "cpu_time_s",
)


def write_csv(path: str | Path, records: Sequence[RunRecord]) -> Path:
    """Write one row per record (:meth:`RunRecord.to_row`), atomically; :func:`read_csv` reads it back.

    Parameters
    ----------
    path : str or Path
        The CSV file.
    records : sequence of RunRecord
        The runs (their named metrics become columns, in order of first appearance).

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> recs = [RunRecord.failed("a", "diverged", metrics={"u_peak_N_m": 2.0}), RunRecord.failed("b", "")]
    >>> [r.key for r in read_csv(write_csv("runs.csv", recs))], read_csv("runs.csv")[0].metrics
    (['a', 'b'], {'u_peak_N_m': 2.0})
    """
    rows = [r.to_row() for r in records]
    fields = list(dict.fromkeys(k for row in rows for k in row)) or list(CSV_FIELDS)
    with atomic_path(Path(path)) as tmp, tmp.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields, restval="")
        writer.writeheader()
        writer.writerows(rows)
    return Path(path)


def read_csv(path: str | Path) -> list[RunRecord]:
    """The records of a :func:`write_csv` file.

    Parameters
    ----------
    path : str or Path
        The CSV file.

    Returns
    -------
    list of RunRecord
        One per row, without series or summary.
    """
    with Path(path).open(newline="") as fh:
        return [RunRecord.from_row(row) for row in csv.DictReader(fh)]


def _number(x: Any) -> float:
    """A JSON number back: ``null`` -> NaN, ``"inf"`` / ``"-inf"`` -> infinity."""
    return math.nan if x is None else float(x)


def _from_jsonable(value: Any) -> Any:
    """Undo :func:`fsmctl.outputs.jsonable` on numbers: ``null`` -> NaN, ``"inf"`` -> infinity (nested)."""
    if isinstance(value, Mapping):
        return {k: _from_jsonable(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_from_jsonable(v) for v in value]
    if value is None or value in ("inf", "-inf"):
        return _number(value)
    return value
