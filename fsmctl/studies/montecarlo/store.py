"""A Monte Carlo campaign's folder: chunk files, resume, the merged ``montecarlo.nc``, the summary and histograms."""

from __future__ import annotations

import contextlib
import errno
import json
import logging
import math
import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fsmctl.errors import EnvironmentProblem, InputError
from fsmctl.model.scenario import Scenario
from fsmctl.outputs import jsonable, temporary_files, write_json
from fsmctl.studies.montecarlo.runs import FLAGS, PER_AGENT, SCALARS
from fsmctl.studies.montecarlo.settings import (
    CAMPAIGN_FILE,
    CAMPAIGN_KEYS,
    COMPLETE_MARKER,
    STATUS_DIED,
    STATUS_FAILED,
    STATUS_OK,
    CampaignSettings,
    campaign_steady_window,
    child_seed,
    describe_campaign,
    random_processes,
    run_noise_seed,
)

_log = logging.getLogger(__name__)


# ----------------------------------------------------------------------------- files


def _environment_problem(what: str, exc: OSError) -> EnvironmentProblem:
    if isinstance(exc, EnvironmentProblem):
        return exc
    return EnvironmentProblem(exc.errno or errno.EIO, f"{what}: {exc.strerror or exc}")


def write_dataset(ds, path: Path, *, compress: bool = True) -> None:
    from fsmctl.simulation.results_io import write_netcdf

    write_netcdf(ds, path, compress=compress)


def chunk_path(out: Path, c: int) -> Path:
    return out / "chunks" / f"chunk_{c:05d}.nc"


def chunk_dataset(rows: list[tuple[int, str, str, dict]], n_agents: int, seed: int | None = None):
    """One chunk's runs as a dataset; with the campaign's ``seed``, every run's ``noise_seed`` (its
    :func:`run_noise_seed`, drawn for this chunk's runs alone: ``SeedSequence(seed).spawn(runs)[run]`` without
    spawning the others)."""
    import xarray as xr

    rows = sorted(rows, key=lambda r: r[0])
    run = np.array([r[0] for r in rows], dtype=np.int64)
    data: dict[str, Any] = {}
    units = {"_N_m_s": "N m s", "_rad_per_s": "rad/s", "_per_s": "1/s", "_s": "s", "_deg": "deg", "_N_m": "N m"}

    def unit(name: str) -> str:
        return next((u for suffix, u in units.items() if name.endswith(suffix)), "1")

    for k in SCALARS:
        data[k] = xr.Variable(("run",), np.array([r[3][k] for r in rows], dtype=float), {"units": unit(k)})
    for k in FLAGS:
        data[k] = xr.Variable(("run",), np.array([bool(r[3][k]) for r in rows], dtype=np.int8), {"units": "1 = true"})
    for k in PER_AGENT:
        arr = np.array([np.asarray(r[3][k], dtype=float) for r in rows]).reshape(len(rows), n_agents)
        data[k] = xr.Variable(("run", "agent"), arr, {"units": unit(k)})
    if seed is not None:
        root = np.random.SeedSequence(seed)
        data["noise_seed"] = xr.Variable(
            ("run",),
            np.array([float(run_noise_seed(child_seed(root, r[0]))) for r in rows], dtype=float),
            {
                "units": "1",
                "long_name": "the run's simulation.seed (an integer below 2**53, exact in float64: NetCDF 3 has no int64)",
            },
        )
    data["status"] = xr.Variable(("run",), np.array([r[1] for r in rows], dtype=object))
    data["message"] = xr.Variable(("run",), np.array([r[2] for r in rows], dtype=object))
    return xr.Dataset(data, coords={"run": run, "agent": np.arange(1, n_agents + 1, dtype=np.int32)})


class OutputFolder:
    """``OUT``: created on demand, checked against a resumed campaign, removed again if nothing was written."""

    def __init__(self, out: Path):
        self.out = out
        self.chunks = out / "chunks"
        self._created_dirs: list[Path] = []  # deepest first
        self._created_meta = False

    def prepare(self, ident: dict, resume: bool) -> None:
        """Create ``OUT`` and write ``campaign.json`` (``ident``: :func:`campaign_record`), or check a resumed one."""
        out = self.out
        if out.exists() and not out.is_dir():
            raise EnvironmentProblem(
                errno.ENOTDIR, f"--out {out}: cannot create the output folder (a file is in the way)"
            )
        missing = []
        p = out.absolute()
        while not os.path.lexists(p) and p.parent != p:
            missing.append(p)
            p = p.parent
        chunks_missing = not self.chunks.is_dir()
        self._created_dirs = [self.chunks.absolute(), *missing] if chunks_missing else missing
        try:
            out.mkdir(parents=True, exist_ok=True)
            self.chunks.mkdir(exist_ok=True)
        except OSError as exc:
            self._remove_created()
            raise EnvironmentProblem(
                exc.errno or errno.EIO, f"--out {out}: cannot create the output folder ({exc.strerror or exc})"
            ) from None
        meta = out / CAMPAIGN_FILE
        if meta.is_file():
            if not resume:
                raise InputError(
                    f"{out} already holds a campaign; pass --resume to continue it or choose another --out"
                )
            old, damage = _read_campaign_file(meta)
            if damage is not None:
                self._recover(meta, f"{meta} is damaged ({damage})", ident)
            elif old != ident:
                kind, detail = _difference(old, ident)
                raise InputError(f"{out} holds a campaign {kind} ({detail}); cannot resume")
        elif any(self.chunks.glob("chunk_*.nc")):
            if not resume:
                raise InputError(
                    f"{out}/chunks holds chunk files but no {CAMPAIGN_FILE}; pass --resume to rebuild it from them "
                    "or choose another --out"
                )
            self._recover(meta, f"{meta} is missing", ident)
        self._created_meta = not meta.exists()
        marker = out / COMPLETE_MARKER
        try:
            marker.unlink(missing_ok=True)  # the campaign in the folder is (again) under way
        except OSError as exc:
            raise _environment_problem(f"cannot remove {marker}", exc) from exc
        try:
            write_json(meta, ident)
        except BaseException:
            self.discard_if_empty()
            raise

    def _recover(self, meta: Path, what: str, ident: dict) -> None:
        """``campaign.json`` is damaged or missing: resume if the chunk files record these settings, else explain.

        Every chunk file records the settings of its campaign (attribute ``settings``).  When the readable
        chunk files all record ``ident``, the campaign is this one and ``prepare`` rewrites ``campaign.json``;
        without a readable chunk nothing of the old campaign is kept and this one starts afresh.  Unreadable
        chunk files (cut short by an interrupt) are flown again anyway.
        """
        recorded = {}
        for path in self.chunk_files():
            try:
                recorded[path.name] = _chunk_settings(path)
            except Exception:  # unreadable: the chunk is flown again and its file replaced
                continue
        fix = f"start afresh in another --out or after removing {self.out}"
        if any(v is None for v in recorded.values()):
            unrecorded = sorted(k for k, v in recorded.items() if v is None)
            raise InputError(
                f"{what}; cannot resume: the chunk files do not record the campaign's settings ({unrecorded[0]} "
                f"records none: an older fsmctl wrote it); {fix}"
            )
        different = {k: v for k, v in recorded.items() if v != ident}
        if different:
            name, other = sorted(different.items())[0]
            kind, detail = _difference(other, ident)
            raise InputError(
                f"{what}; cannot resume: the chunk files record a campaign {kind} ({name}: {detail}); resume with "
                f"what they record, or {fix}"
            )
        if recorded:
            _log.warning("%s; rebuilt from the %d chunk files, which record these settings", what, len(recorded))
        else:
            _log.warning("%s; no chunk file to keep: the campaign starts afresh", what)

    def chunk_files(self) -> list[Path]:
        try:
            return sorted(self.chunks.glob("chunk_*.nc"))
        except OSError:
            return []

    def discard_if_empty(self) -> int:
        """After a failure: remove what this campaign created unless a chunk exists; returns the chunks kept."""
        kept = len(self.chunk_files())
        if kept:
            return kept
        for folder in (self.chunks, self.out):
            with contextlib.suppress(OSError):
                for tmp in temporary_files(folder):
                    tmp.unlink()
        if self._created_meta:
            with contextlib.suppress(OSError):
                (self.out / CAMPAIGN_FILE).unlink()
        self._remove_created()
        return 0

    def _remove_created(self) -> None:
        for d in self._created_dirs:
            try:
                d.rmdir()  # only if empty: never removes anything else
            except FileNotFoundError:
                continue  # mkdir failed before reaching it
            except OSError:
                break
        self._created_dirs = []


def campaign_record(settings: CampaignSettings, base: Scenario) -> dict:
    """What ``campaign.json`` and every chunk file record: the settings and, under ``problem``, the fingerprint of
    the problem they name (:func:`fsmctl.simulation.results_io.problem_fingerprint`: the base scenario as flown,
    the law's content hash, the fsmctl version).  A resumed campaign must record the same."""
    from fsmctl.simulation.results_io import problem_fingerprint

    return {**jsonable(settings.identity()), "problem": problem_fingerprint(base)}


def _difference(old: Mapping, ident: Mapping) -> tuple[str, str]:
    """How a recorded campaign differs from this one: ``("with different settings", names)`` or ``("of another
    problem", what changed)``."""
    from fsmctl.simulation.results_io import fingerprint_change

    keys = sorted(k for k in {*old, *ident} if k != "problem" and old.get(k) != ident.get(k))
    if keys:
        return "with different settings", ", ".join(keys)
    return "of another problem", str(fingerprint_change(old.get("problem"), ident["problem"]))


def existing_chunk(path: Path, indices: Sequence[int]) -> bool:
    if not path.is_file():
        return False
    try:
        import xarray as xr

        with xr.open_dataset(path) as ds:
            # a chunk with a failed or died run is not done: --resume tries those runs again
            return [int(r) for r in ds.run.values] == list(indices) and all(
                str(v) == STATUS_OK for v in ds.status.values
            )
    except Exception:  # unreadable partial file: rerun the chunk
        return False


def _read_campaign_file(meta: Path) -> tuple[dict, str | None]:
    """``(settings, None)`` from ``campaign.json``, or ``({}, what is wrong)`` when it is not a campaign's settings."""
    try:
        text = meta.read_bytes().decode("utf-8")
    except UnicodeDecodeError:
        return {}, "not UTF-8 text"
    except OSError as exc:
        raise _environment_problem(f"cannot read {meta}", exc) from exc
    try:
        old = json.loads(text)
    except ValueError as exc:
        return {}, f"not valid JSON: {exc}"
    if not isinstance(old, dict) or not all(k in old for k in CAMPAIGN_KEYS):
        return {}, "not a JSON object holding a campaign's settings (" + ", ".join(CAMPAIGN_KEYS) + ")"
    return old, None


def _chunk_settings(path: Path) -> dict | None:
    """The campaign settings a chunk file records (its ``settings`` attribute); None if it records none."""
    import xarray as xr

    with xr.open_dataset(path) as ds:
        text = ds.attrs.get("settings")
    return None if text is None else json.loads(text)


# ----------------------------------------------------------------------------- campaign


@dataclass
class CampaignResult:
    """Outcome of :func:`run_campaign`: the merged dataset and where everything was written.

    Parameters
    ----------
    dataset : xarray.Dataset
        Per-run results, dimension ``run`` (and ``agent``): status, settling times, final errors, Theorem checks.
    summary : dict
        Counts, fractions and statistics (what ``summary.json`` holds).
    out_dir : pathlib.Path
        The campaign folder.
    wall_time_s : float
        Wall time of the campaign (s).
    resumed_chunks : int, optional
        Chunks found done in ``out_dir`` and not run again.
    files : dict, optional
        Name -> path of the files written (``dataset``, ``summary``, ``complete``, figures).
    settings : CampaignSettings or None, optional
        The settings that ran (the case made explicit).

    Examples
    --------
    >>> from fsmctl.studies import CampaignSettings, run_campaign
    >>> result = run_campaign(CampaignSettings(runs=2, t_final=0.5, steady_window=0.2), "mc", workers=1,
    ...                       progress=False, figures=False)
    >>> dict(result.dataset.sizes), sorted(result.files)
    ({'run': 2, 'agent': 6}, ['complete', 'dataset', 'summary'])
    >>> result.settings.case
    '1'
    """

    dataset: Any
    """xarray.Dataset with dimension ``run`` (and ``agent``)"""
    summary: dict
    out_dir: Path
    wall_time_s: float
    resumed_chunks: int = 0
    files: dict = field(default_factory=dict)
    settings: CampaignSettings | None = None
    """the settings that ran (the case made explicit)"""

    @property
    def failed_runs(self) -> list[int]:
        """The indices of the runs whose status is not ``ok``."""
        return [
            int(r) for r, s in zip(self.dataset.run.values, self.dataset.status.values, strict=True) if s != STATUS_OK
        ]


def n_chunks(settings: CampaignSettings) -> int:
    return -(-settings.runs // settings.chunk_size)


def chunk_runs(settings: CampaignSettings, c: int) -> list[int]:
    """The runs of chunk ``c``."""
    start = c * settings.chunk_size
    return list(range(start, min(settings.runs, start + settings.chunk_size)))


def finish_campaign(
    out: Path,
    settings: CampaignSettings,
    base: Scenario,
    t_start: float,
    resumed: int = 0,
    *,
    figures: bool = True,
    command: Sequence[str] | str | None = None,
) -> CampaignResult:
    """Merge the chunk files into ``montecarlo.nc``, write ``summary.json``, the histograms and, last, ``complete.json``.

    Parameters
    ----------
    out : pathlib.Path
        The campaign folder (its ``chunks/`` are complete).
    settings : CampaignSettings
        The campaign's settings.
    base : Scenario
        The base scenario.
    t_start : float
        :func:`time.perf_counter` at the start of the campaign (for the wall time).
    resumed : int, optional
        Chunks that were resumed.
    figures : bool, optional
        Write the histograms.
    command : sequence of str or str, optional
        The command line, embedded in ``montecarlo.nc`` with the base scenario, the law and the versions
        (:func:`fsmctl.simulation.results_io.provenance`).

    Returns
    -------
    CampaignResult
        The merged result.
    """
    import xarray as xr

    from fsmctl.simulation.results_io import provenance

    out = Path(out)
    parts = []
    for c in range(n_chunks(settings)):
        with xr.open_dataset(chunk_path(out, c)) as ds:
            parts.append(ds.load())
    ds = xr.concat(parts, dim="run")
    for var in ds.variables.values():
        var.encoding = {}  # string widths differ between chunks
    ident = campaign_record(settings, base)  # as campaign.json and every chunk file record it
    # the base scenario, law, versions and command line (scenario_from_result re-runs the base scenario)
    ds.attrs.update(provenance(base, command=command))
    ds.attrs.update(
        {
            "title": f"fsmctl Monte Carlo campaign: {base.label}, {settings.runs} runs, seed {settings.seed}",
            "settings": json.dumps(ident, allow_nan=False),
            "scenario": "\n".join(base.describe()),
            "campaign": "\n".join(describe_campaign(settings, base)),
            "source": "Liang, Sun & Wang, Acta Astronautica 81 (2012) 445-455",
            "seeds": "numpy.random.SeedSequence(seed).spawn(runs)[run]; noise_seed (the run's simulation.seed): its "
            "first child's generate_state(1, uint64) >> 11",
            "vary": settings.vary,
            "random_processes": ", ".join(random_processes(base)) or "none",
            "law": base.law.name,
            # 1: the law declares it is the paper's eqs 13-19 (LawBuilder.paper_theorems), so Theorems 1-2 apply
            "paper_theorems": int(base.law.paper_theorems is not None),
        }
    )
    write_dataset(ds, out / "montecarlo.nc")
    summary = summarize(ds, settings)
    summary["campaign_wall_time_s"] = time.perf_counter() - t_start
    summary["resumed_chunks"] = resumed
    summary["settings"] = ident
    summary["output_interval_s"] = base.simulation.output_interval
    summary["horizon_s"] = base.simulation.t_final
    summary["steady_window_s"] = campaign_steady_window(settings, base)
    summary["campaign"] = describe_campaign(settings, base)
    files = {"dataset": out / "montecarlo.nc", "summary": out / "summary.json"}
    if figures:
        files.update(plot_histograms(ds, out / "histograms", settings))
    write_json(out / "summary.json", summary)
    for tmp in temporary_files(out / "chunks"):  # left by an interrupted earlier attempt
        with contextlib.suppress(OSError):
            tmp.unlink()
    marker = {
        "complete": True,
        "runs": summary["runs"],
        "ok": summary["ok"],
        "files": sorted(str(p.relative_to(out)) for p in files.values()),
    }
    write_json(out / COMPLETE_MARKER, marker)
    files["complete"] = out / COMPLETE_MARKER
    return CampaignResult(ds, summary, out, summary["campaign_wall_time_s"], resumed, files, settings)


def summarize(ds, settings: CampaignSettings) -> dict:
    """Counts, fractions and statistics (finite values only) of every per-run variable.

    Parameters
    ----------
    ds : xarray.Dataset
        The merged per-run dataset.
    settings : CampaignSettings
        The campaign's settings.

    Returns
    -------
    dict
        ``runs``, ``ok``, ``failed``, ``converged_fraction``, the Theorem checks' fractions, ``statistics`` per
        variable, ... (written as ``summary.json``).
    """
    status = [str(s) for s in ds.status.values]
    ok = np.array([s == STATUS_OK for s in status])
    out: dict[str, Any] = {
        "runs": len(status),
        "ok": int(ok.sum()),
        "failed": int(sum(s == STATUS_FAILED for s in status)),
        "worker_died": int(sum(s == STATUS_DIED for s in status)),
        "failures": [
            {"run": int(r), "status": s, "message": str(m)}
            for r, s, m in zip(ds.run.values, status, ds.message.values, strict=True)
            if s != STATUS_OK
        ],
        "tolerance_deg": settings.tolerance_deg,
        "law": str(ds.attrs["law"]),
        "paper_theorems": bool(int(ds.attrs["paper_theorems"])),
    }
    for k in FLAGS:
        v = ds[k].values.astype(bool)[ok]
        applies = k == "converged" or out["paper_theorems"]  # Theorems 1-2 apply to a law that declares them
        out[f"{k}_fraction"] = float(v.mean()) if v.size and applies else math.nan
    stats = {}
    for k in SCALARS:
        v = ds[k].values[ok]
        fin = v[np.isfinite(v)]
        entry = {"finite": int(fin.size), "nan": int(v.size - fin.size)}
        if fin.size:
            q = np.percentile(fin, [5, 50, 95])
            entry.update(
                mean=float(fin.mean()), std=float(fin.std()), min=float(fin.min()), p5=float(q[0]),
                median=float(q[1]), p95=float(q[2]), max=float(fin.max()),
            )  # fmt: skip
        stats[k] = entry
    out["statistics"] = stats
    if "messages_count" in stats and stats["messages_count"]["finite"] == 0:
        out["messages"] = "not applicable: continuous control (no control period), no message is a discrete event"
    out["cpu_time_s_total"] = float(np.nansum(ds["cpu_time_s"].values))
    return out


def plot_histograms(ds, stem: str | Path, settings: CampaignSettings) -> dict:
    """Histograms of the main per-run results (PNG and SVG, each written atomically).

    Parameters
    ----------
    ds : xarray.Dataset
        The merged per-run dataset.
    stem : str or pathlib.Path
        The files' path without suffix.
    settings : CampaignSettings
        The campaign's settings (tolerances in the titles).

    Returns
    -------
    dict
        ``{"png": path, "svg": path}``.
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    from fsmctl.studies.figures import save_figure

    ok = np.array([str(s) == STATUS_OK for s in ds.status.values])
    panels = [
        ("aaem_settling_s", f"AAEM settling time to {settings.tolerance_deg:g} deg (s)"),
        ("aaem_steady_max_deg", "AAEM steady-state max (deg)"),
        ("raem_steady_max_deg", "RAEM steady-state max (deg)"),
        ("u_unsaturated_max_N_m", "max |commanded torque| (N m)"),
        ("saturated_time_max_s", "saturation time, worst agent (s)"),
        ("theorem2_margin", "Theorem 2 margin min delta/required"),
    ]
    fig, axes = plt.subplots(2, 3, figsize=(13, 7), constrained_layout=True)
    for ax, (k, label) in zip(axes.ravel(), panels, strict=True):
        v = ds[k].values[ok]
        fin = v[np.isfinite(v)]
        if fin.size:
            positive = fin[fin > 0]
            log = positive.size == fin.size and fin.size > 1 and fin.max() / max(fin.min(), 1e-300) > 1e3
            bins = np.geomspace(positive.min(), positive.max(), 30) if log else 30
            ax.hist(fin, bins=bins, color="tab:blue", alpha=0.8)
            if log:
                ax.set_xscale("log")
        ax.set_xlabel(label)
        ax.set_ylabel("runs")
        ax.set_title(f"{fin.size} finite of {v.size} ok runs", fontsize=9)
    n_conv = int(ds.converged.values[ok].sum())
    fig.suptitle(
        f"Monte Carlo: {ds.attrs.get('title', '')}\nconverged {n_conv}/{int(ok.sum())}, "
        f"Theorem 1 held {int(ds.theorem1_holds.values[ok].sum())}, Theorem 2 (at reference) held "
        f"{int(ds.theorem2_at_reference_holds.values[ok].sum())}; {int((~ok).sum())} failed/died",
        fontsize=10,
    )
    try:
        png, svg = save_figure(fig, stem, dpi=110)
    finally:
        plt.close(fig)
    return {"png": png, "svg": svg}
