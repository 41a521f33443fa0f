"""Monte Carlo robustness campaigns: ``fsmctl montecarlo`` and a Python API.

Each run perturbs a base scenario (Liang et al. 2012, Sec. 4) with

* an inertia perturbation ``Delta_J_i`` that is itself the inertia tensor of an added
  rigid mass distribution: symmetric positive definite *and* physically realizable
  (principal moments ``b + c, a + c, a + b`` with ``a, b, c > 0`` second moments, uniformly
  random principal axes), scaled so that ``0 < Delta_J_i <= rho_i J0_i`` in the Loewner order with
  ``rho_i ~ U(0, inertia_bound]`` (the paper's ``Delta_J = 0.3 J0`` is the extreme
  ``rho = 0.3``).  The true inertia ``J0_i + Delta_J_i`` is then SPD and, whenever ``J0_i`` is,
  realizable too (a sum of mass distributions);
* disturbance amplitudes ``U(0, disturbance_scale |a_k|)`` (signs and frequencies of the
  scenario's ``a_k``) and phases ``U(0, 2 pi)`` (eq 1's ``d_i(t)``);
* initial attitudes uniform over SO(3) (Haar measure: a normalized 4-D Gaussian quaternion,
  converted to the MRP of the shadow set ``|sigma| <= 1``, eq 2) and rates with
  ``|omega_k(0)| <= rate_bound`` uniformly;
* a random switching topology: every link of the scenario's graph is kept with probability
  ``1 - link_dropout``, its schedule ``k^j_ij(t)`` gets a uniform random phase over its period and
  its non-zero values a factor ``U(coupling_low, coupling_high)`` (Table 2, eq 19).

Per run the dataset holds settling times of AAEM/RAEM (eqs 42-43), steady-state accuracy, peak
torques, saturation time, whether Theorem 1's topology conditions hold for the run's graph
(:func:`fsmctl.proofs.theorem1.analyze_topology`), whether the configured ``delta_i`` exceeds
Theorem 2's requirement at the reference (``sigma_e = 0, omega_e = 0``, bound boxes of the
disturbance and the reference; :func:`fsmctl.proofs.theorem2.delta_requirements`), whether it
converged, and a status (``ok``, ``failed`` with the error, ``worker-died``).

Per-run seeds come from ``numpy.random.SeedSequence(seed).spawn(runs)``, so a seeded campaign
gives the same runs whatever the number of workers, chunking or backend (process pool or Dask).
Runs are grouped in chunks; every finished chunk is written to ``OUT/chunks/chunk_NNNNN.nc`` at
once, so an interrupted campaign resumes (``--resume``) with only the missing chunks.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from .cli_types import finite_or_inf_float, nonnegative_int, positive_int
from .parallel import process_pool_context, single_threaded_workers
from .scenario import Agent, Scenario, ScenarioError, Sinusoid, load_scenario
from .topology import Link, Topology

__all__ = [
    "CampaignSettings",
    "CampaignResult",
    "sample_inertia_perturbation",
    "sample_attitudes_mrp",
    "sample_run_scenario",
    "run_one",
    "run_campaign",
    "summarize",
    "plot_histograms",
    "add_parser",
]

STATUS_OK, STATUS_FAILED, STATUS_DIED = "ok", "failed", "worker-died"
TIMING_VARIABLES = ("wall_time_s", "cpu_time_s")
"""per-run variables that depend on the machine (excluded from reproducibility comparisons)"""


# ----------------------------------------------------------------------------- settings


@dataclass(frozen=True)
class CampaignSettings:
    """What a campaign perturbs, how it runs, and what counts as converged.

    Units: rad/s for ``rate_bound``, s for times, deg for ``tolerance_deg``, N m for ``torque_limit``.
    ``None`` keeps the scenario's value.
    """

    scenario: str = "paper"
    case: str | None = "1"
    runs: int = 100
    seed: int = 0
    inertia_bound: float = 0.3
    """rho_max: 0 < Delta_J <= rho J0 with rho ~ U(0, rho_max]"""
    disturbance_scale: float = 1.0
    rate_bound: float = 0.5
    link_dropout: float = 0.2
    coupling_low: float = 0.5
    coupling_high: float = 1.7
    t_final: float | None = None
    dt: float | None = None
    output_interval: float = 0.1
    """coarse output grid: only per-run summaries are kept (settling times resolved to this interval)"""
    torque_limit: float | None = None
    tolerance_deg: float = 1.0
    """converged: AAEM and RAEM below this at the end and settled (eqs 42-43)"""
    steady_window: float = 20.0
    chunk_size: int = 10

    def validate(self) -> None:
        """Raise :class:`ScenarioError` on a bad setting (one line, names the option)."""
        checks = [
            ("runs", self.runs >= 1, ">= 1"),
            ("chunk_size", self.chunk_size >= 1, ">= 1"),
            ("seed", self.seed >= 0, ">= 0"),
            ("inertia_bound", 0 <= self.inertia_bound < 10, "in [0, 10)"),
            ("disturbance_scale", 0 <= self.disturbance_scale < 1e6, ">= 0"),
            ("rate_bound", 0 <= self.rate_bound <= 10, "in [0, 10] rad/s"),
            ("link_dropout", 0 <= self.link_dropout <= 1, "in [0, 1]"),
            ("coupling_low", 0 <= self.coupling_low <= self.coupling_high, "in [0, coupling_high]"),
            ("output_interval", self.output_interval > 0, "> 0"),
            ("tolerance_deg", self.tolerance_deg > 0, "> 0"),
            ("steady_window", self.steady_window > 0, "> 0"),
        ]
        for name, ok, need in checks:
            value = getattr(self, name)
            if not ok or (isinstance(value, float) and not math.isfinite(value)):
                raise ScenarioError(f"montecarlo: {name} must be {need}, got {value!r}")
        for name in ("t_final", "dt", "torque_limit"):
            value = getattr(self, name)
            if value is not None and not value > 0:
                raise ScenarioError(f"montecarlo: {name} must be > 0, got {value!r}")

    def identity(self) -> dict:
        """Everything that determines the runs' results (a resumed campaign must match it)."""
        return asdict(self)


# ----------------------------------------------------------------------------- sampling


def sample_attitudes_mrp(rng: np.random.Generator, count: int) -> np.ndarray:
    """``count`` attitudes uniform over SO(3) (Haar measure) as MRPs of the shadow set, shape ``(count, 3)``.

    A 4-D standard normal vector normalized to the unit sphere is a uniformly distributed unit
    quaternion; with the scalar part made non-negative, ``sigma = q_v / (1 + q_0)`` (Liang et al.
    2012, eq 2) has ``|sigma| <= 1``.  The principal angle ``theta = 4 atan|sigma|`` then has the
    density ``(1 - cos theta) / pi`` on ``[0, pi]``.
    """
    q = rng.standard_normal((count, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)
    return q[:, 1:] / (1.0 + q[:, :1])


def _random_rotation(rng: np.random.Generator) -> np.ndarray:
    q = rng.standard_normal(4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def sample_inertia_perturbation(rng: np.random.Generator, J0: np.ndarray, bound: float) -> np.ndarray:
    """A random ``Delta_J`` (kg m^2): SPD, realizable, ``0 < Delta_J <= rho J0`` with ``rho ~ U(0, bound]``.

    ``Delta_J = R diag(b + c, a + c, a + b) R^T`` is the inertia of a mass distribution with
    principal second moments ``a, b, c ~ U(0, 1)`` (so it satisfies the triangle inequality of a
    rigid body) about uniformly random axes ``R``; it is scaled so that the largest eigenvalue of
    ``J0^-1/2 Delta_J J0^-1/2`` equals ``rho``.  Liang et al. 2012, eq 29 (``J = J0 + Delta_J``).
    """
    J0 = np.asarray(J0, dtype=float)
    a, b, c = rng.uniform(0.0, 1.0, 3)
    R = _random_rotation(rng)
    rho = bound * (1.0 - rng.uniform(0.0, 1.0))  # (0, bound]
    D = R @ np.diag([b + c, a + c, a + b]) @ R.T
    w, V = np.linalg.eigh(J0)
    inv_sqrt = V @ np.diag(w**-0.5) @ V.T
    top = float(np.linalg.eigvalsh(inv_sqrt @ D @ inv_sqrt)[-1])
    D = D * (rho / top) if top > 0 else np.zeros((3, 3))
    return 0.5 * (D + D.T)


def _random_topology(rng: np.random.Generator, topology: Topology, s: CampaignSettings) -> Topology:
    links = []
    for link in topology.links:
        keep = rng.uniform() >= s.link_dropout
        factor = rng.uniform(s.coupling_low, s.coupling_high)
        period = link.k_j.period
        phase = rng.uniform(0.0, period) if period else link.phase
        if keep:
            links.append(Link(link.receiver, link.sender, link.k_i, link.k_j.scaled(factor), float(phase)))
    return Topology(topology.n_agents, tuple(links))


def sample_run_scenario(base: Scenario, settings: CampaignSettings, seed: np.random.SeedSequence) -> Scenario:
    """The perturbed scenario of one run (everything drawn from ``seed``, in a fixed order)."""
    rng = np.random.default_rng(seed)
    agents = []
    for agent in base.agents:
        sigma0 = sample_attitudes_mrp(rng, 1)[0]
        omega0 = rng.uniform(-settings.rate_bound, settings.rate_bound, 3)
        delta_J = sample_inertia_perturbation(rng, agent.J0_array, settings.inertia_bound)
        d = agent.disturbance
        amplitude = np.asarray(d.amplitude) * settings.disturbance_scale * rng.uniform(0.0, 1.0, 3)
        phase = rng.uniform(0.0, 2 * math.pi, 3)
        disturbance = Sinusoid(tuple(amplitude.tolist()), d.frequency, tuple(phase.tolist()), d.offset)
        agents.append(
            Agent(
                J0=agent.J0,
                delta_J=tuple(tuple(row) for row in delta_J.tolist()),
                sigma0=tuple(sigma0.tolist()),
                omega0=tuple(omega0.tolist()),
                delta=agent.delta,
                disturbance=disturbance,
            )
        )
    topology = _random_topology(rng, base.topology, settings)
    return replace(base, agents=tuple(agents), topology=topology)  # validated once


def _base_scenario(settings: CampaignSettings) -> Scenario:
    base = load_scenario(settings.scenario, settings.case)
    sim: dict[str, Any] = {"output_interval": settings.output_interval}
    if settings.t_final is not None:
        sim["t_final"] = settings.t_final
    if settings.dt is not None:
        sim["dt"] = settings.dt
    ctrl = {} if settings.torque_limit is None else {"torque_limit": settings.torque_limit}
    dt = sim.get("dt", base.simulation.dt)
    sim["output_interval"] = max(dt, round(settings.output_interval / dt) * dt)
    return base.replace(simulation=sim, controller=ctrl)


# ----------------------------------------------------------------------------- one run

_SCALARS = (
    "aaem_settling_s",
    "raem_settling_s",
    "aaem_settling_tight_s",
    "raem_settling_tight_s",
    "aaem_final_deg",
    "raem_final_deg",
    "aaem_steady_max_deg",
    "raem_steady_max_deg",
    "u_max_abs_N_m",
    "u_unsaturated_max_N_m",
    "saturated_time_max_s",
    "last_saturation_s",
    "theorem1_lambda_min",
    "theorem2_margin",
    "inertia_rho_max",
    "initial_angle_max_deg",
    "initial_rate_max_rad_per_s",
    "disturbance_amplitude_max_N_m",
    "n_links",
    "wall_time_s",
    "cpu_time_s",
)
_FLAGS = ("converged", "theorem1_holds", "theorem2_at_reference_holds")
_PER_AGENT = ("saturated_time_s", "theta_e_final_deg")


def _nan_record(n_agents: int) -> dict:
    rec: dict[str, Any] = {k: math.nan for k in _SCALARS}
    rec.update({k: False for k in _FLAGS})
    rec.update({k: np.full(n_agents, np.nan) for k in _PER_AGENT})
    return rec


def run_one(base: Scenario, settings: CampaignSettings, index: int, seed: np.random.SeedSequence) -> dict:
    """Simulate run ``index`` and return its summary record (raises on failure: the caller records it)."""
    from .metrics import principal_angles
    from .proofs.theorem1 import analyze_topology
    from .proofs.theorem2 import Region, delta_requirements
    from .simulator import simulate

    wall, cpu = time.perf_counter(), time.process_time()
    scenario = sample_run_scenario(base, settings, seed)
    result = simulate(scenario, progress=False)
    tol = settings.tolerance_deg
    summary = result.summary(tolerances_deg=(tol, 0.1 * tol), steady_window=settings.steady_window)
    aaem, raem = result.aaem_deg, result.raem_deg
    t1 = analyze_topology(scenario.topology, scenario.simulation.t_final)
    t2 = delta_requirements(scenario, Region(0.0, 0.0), n_random=0, dt_reference=0.5, search_scale=False)
    margins = [
        c / r if r > 0 else math.inf for a in t2.agents for c, r in zip(a.configured, a.reference_bound, strict=True)
    ]
    rec = _nan_record(scenario.n_agents)
    rec.update(
        aaem_settling_s=summary["aaem_settling_s"][f"{tol:g}"],
        raem_settling_s=summary["raem_settling_s"][f"{tol:g}"],
        aaem_settling_tight_s=summary["aaem_settling_s"][f"{0.1 * tol:g}"],
        raem_settling_tight_s=summary["raem_settling_s"][f"{0.1 * tol:g}"],
        aaem_final_deg=float(aaem[-1]),
        raem_final_deg=float(raem[-1]),
        aaem_steady_max_deg=summary["aaem_steady_max_deg"],
        raem_steady_max_deg=summary["raem_steady_max_deg"],
        u_max_abs_N_m=summary["u_max_abs_N_m"],
        u_unsaturated_max_N_m=summary["u_unsaturated_max_N_m"],
        saturated_time_max_s=float(np.max(result.saturated_time)),
        last_saturation_s=summary["last_saturation_s"],
        theorem1_lambda_min=float(t1.lambda_min),
        theorem2_margin=float(min(margins)),
        inertia_rho_max=max(_relative_perturbation(a) for a in scenario.agents),
        initial_angle_max_deg=float(np.degrees(principal_angles(np.array([a.sigma0 for a in scenario.agents]))).max()),
        initial_rate_max_rad_per_s=float(np.abs([a.omega0 for a in scenario.agents]).max()),
        disturbance_amplitude_max_N_m=float(np.abs([a.disturbance.amplitude for a in scenario.agents]).max()),
        n_links=float(len(scenario.topology.links)),
        converged=bool(
            aaem[-1] < tol
            and raem[-1] < tol
            and math.isfinite(summary["aaem_settling_s"][f"{tol:g}"])
            and math.isfinite(summary["raem_settling_s"][f"{tol:g}"])
        ),
        theorem1_holds=bool(t1.holds),
        theorem2_at_reference_holds=bool(t2.ok),
        saturated_time_s=np.asarray(result.saturated_time, dtype=float),
        theta_e_final_deg=np.degrees(result.theta_e[-1]),
    )
    rec["wall_time_s"] = time.perf_counter() - wall
    rec["cpu_time_s"] = time.process_time() - cpu
    return rec


def _relative_perturbation(agent: Agent) -> float:
    J0, dJ = agent.J0_array, np.array(agent.delta_J)
    w, V = np.linalg.eigh(J0)
    inv_sqrt = V @ np.diag(w**-0.5) @ V.T
    return float(np.linalg.eigvalsh(inv_sqrt @ dJ @ inv_sqrt)[-1])


RunFunction = Callable[[Scenario, CampaignSettings, int, np.random.SeedSequence], dict]


def _run_chunk(
    base: Scenario, settings: CampaignSettings, indices: Sequence[int], run_fn: RunFunction | None = None
) -> list[tuple[int, str, str, dict]]:
    """Runs ``indices``; each gives ``(index, status, message, record)``; a failing run does not stop the chunk."""
    # Reaches only BLAS libraries loaded after this point (e.g. SciPy's, at the first linprog). The local
    # pool's workers get one thread from their environment at start (parallel.single_threaded_workers).
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    fn = run_fn or run_one
    seeds = np.random.SeedSequence(settings.seed).spawn(settings.runs)
    out = []
    for k in indices:
        try:
            out.append((k, STATUS_OK, "", fn(base, settings, k, seeds[k])))
        except Exception as exc:  # a failed run is reported in the dataset, never dropped
            out.append(
                (k, STATUS_FAILED, f"{type(exc).__name__}: {exc}".splitlines()[0][:500], _nan_record(base.n_agents))
            )
    return out


# ----------------------------------------------------------------------------- datasets


def _chunk_dataset(rows: list[tuple[int, str, str, dict]], n_agents: int):
    import xarray as xr

    rows = sorted(rows, key=lambda r: r[0])
    run = np.array([r[0] for r in rows], dtype=np.int64)
    data: dict[str, Any] = {}
    units = {"_s": "s", "_deg": "deg", "_N_m": "N m", "_rad_per_s": "rad/s"}

    def unit(name: str) -> str:
        return next((u for suffix, u in units.items() if name.endswith(suffix)), "1")

    for k in _SCALARS:
        data[k] = xr.Variable(("run",), np.array([r[3][k] for r in rows], dtype=float), {"units": unit(k)})
    for k in _FLAGS:
        data[k] = xr.Variable(("run",), np.array([bool(r[3][k]) for r in rows], dtype=np.int8), {"units": "1 = true"})
    for k in _PER_AGENT:
        arr = np.array([np.asarray(r[3][k], dtype=float) for r in rows]).reshape(len(rows), n_agents)
        data[k] = xr.Variable(("run", "agent"), arr, {"units": unit(k)})
    data["status"] = xr.Variable(("run",), np.array([r[1] for r in rows], dtype=object))
    data["message"] = xr.Variable(("run",), np.array([r[2] for r in rows], dtype=object))
    return xr.Dataset(data, coords={"run": run, "agent": np.arange(1, n_agents + 1, dtype=np.int32)})


def _write_atomic_netcdf(ds, path: Path) -> None:
    tmp = path.with_suffix(".tmp.nc")
    ds.to_netcdf(tmp, engine="scipy")
    os.replace(tmp, path)


def _chunk_path(out: Path, c: int) -> Path:
    return out / "chunks" / f"chunk_{c:05d}.nc"


# ----------------------------------------------------------------------------- campaign


@dataclass
class CampaignResult:
    """Outcome of :func:`run_campaign`: the merged dataset and where everything was written."""

    dataset: Any
    """xarray.Dataset with dimension ``run`` (and ``agent``)"""
    summary: dict
    out_dir: Path
    wall_time_s: float
    resumed_chunks: int = 0
    files: dict = field(default_factory=dict)

    @property
    def failed_runs(self) -> list[int]:
        return [
            int(r) for r, s in zip(self.dataset.run.values, self.dataset.status.values, strict=True) if s != STATUS_OK
        ]


def _chunks(settings: CampaignSettings) -> list[list[int]]:
    n, c = settings.runs, settings.chunk_size
    return [list(range(a, min(n, a + c))) for a in range(0, n, c)]


def _prepare_out(out: Path, settings: CampaignSettings, resume: bool) -> None:
    try:
        out.mkdir(parents=True, exist_ok=True)
        (out / "chunks").mkdir(exist_ok=True)
    except OSError as exc:
        raise ScenarioError(f"--out {out}: cannot create the output folder ({exc.strerror or exc})") from None
    meta = out / "campaign.json"
    ident = settings.identity()
    if meta.is_file():
        try:
            old = json.loads(meta.read_text())
        except (OSError, json.JSONDecodeError):
            old = None
        if not resume:
            raise ScenarioError(f"{out} already holds a campaign; pass --resume to continue it or choose another --out")
        if old != ident:
            diff = sorted(k for k in ident if old is None or old.get(k) != ident[k])
            raise ScenarioError(f"{out} holds a campaign with different settings ({', '.join(diff)}); cannot resume")
    elif any((out / "chunks").glob("chunk_*.nc")):
        raise ScenarioError(f"{out}/chunks holds chunk files but no campaign.json; choose another --out")
    meta.write_text(json.dumps(ident, indent=2))


def _existing_chunk(path: Path, indices: Sequence[int]) -> bool:
    if not path.is_file():
        return False
    try:
        import xarray as xr

        with xr.open_dataset(path, engine="scipy") as ds:
            # a chunk with a failed or died run is not done: --resume tries those runs again
            return [int(r) for r in ds.run.values] == list(indices) and all(
                str(v) == STATUS_OK for v in ds.status.values
            )
    except Exception:  # unreadable partial file: rerun the chunk
        return False


def _progress(total: int, initial: int, enabled: bool | None):
    from tqdm.auto import tqdm

    if enabled is None:
        enabled = sys.stderr.isatty()
    return tqdm(total=total, initial=initial, unit="run", desc="montecarlo", disable=not enabled, file=sys.stderr)


def _run_local(base, settings, todo, workers, run_fn, on_chunk) -> None:
    """Process pool; a chunk whose worker died is retried in a fresh pool, then run by run in isolation.

    The workers run with one BLAS/OpenMP thread each (:func:`fsmctl.parallel.single_threaded_workers`).
    """
    if workers <= 1:
        for c, idx in todo:
            on_chunk(c, idx, _run_chunk(base, settings, idx, run_fn))
        return
    with single_threaded_workers():  # every pool of _run_pools starts its workers inside
        _run_pools(base, settings, todo, workers, run_fn, on_chunk)


def _run_pools(base, settings, todo, workers, run_fn, on_chunk) -> None:
    pending = list(todo)
    attempt = 0
    while pending:
        attempt += 1
        if attempt > 2:  # isolate: one run per single-worker pool; a run that kills it is reported
            for c, idx in pending:
                rows = []
                for k in idx:
                    with ProcessPoolExecutor(1, mp_context=process_pool_context()) as ex:
                        try:
                            rows += ex.submit(_run_chunk, base, settings, [k], run_fn).result()
                        except BrokenProcessPool:
                            rows.append((k, STATUS_DIED, "the worker process died", _nan_record(base.n_agents)))
                on_chunk(c, idx, rows)
            return
        failed = []
        with ProcessPoolExecutor(max_workers=workers, mp_context=process_pool_context()) as ex:
            futures = {ex.submit(_run_chunk, base, settings, idx, run_fn): (c, idx) for c, idx in pending}
            not_done = set(futures)
            while not_done:
                done, not_done = wait(not_done, return_when=FIRST_COMPLETED)
                for f in done:
                    c, idx = futures[f]
                    try:
                        rows = f.result()
                    except BrokenProcessPool:
                        failed.append((c, idx))
                        continue
                    on_chunk(c, idx, rows)
        pending = failed


def _run_dask(base, settings, todo, address_or_client, run_fn, on_chunk) -> None:
    from distributed import Client, as_completed

    if isinstance(address_or_client, Client):
        client = address_or_client
    else:
        try:
            client = Client(address_or_client, timeout="10s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise ScenarioError(f"--dask {address_or_client}: cannot connect to a Dask scheduler ({exc})") from None
    try:
        futures = {}
        for c, idx in todo:
            f = client.submit(
                _run_chunk,
                base,
                settings,
                idx,
                run_fn,
                pure=False,
                key=f"fsmctl-mc-{settings.seed}-{c}-{os.getpid()}-{time.time_ns()}",
            )
            futures[f] = (c, idx)
        for f in as_completed(list(futures)):
            c, idx = futures[f]
            try:
                rows = f.result()
            except Exception as exc:  # KilledWorker and friends: every run of the chunk is reported
                msg = f"{type(exc).__name__}: {exc}".splitlines()[0][:500]
                rows = [(k, STATUS_DIED, msg, _nan_record(base.n_agents)) for k in idx]
            on_chunk(c, idx, rows)
    finally:
        if not isinstance(address_or_client, Client):
            client.close()


def run_campaign(
    settings: CampaignSettings,
    out_dir: str | Path,
    *,
    workers: int | None = None,
    dask: Any = None,
    resume: bool = False,
    progress: bool | None = None,
    run_fn: RunFunction | None = None,
    figures: bool = True,
    base: Scenario | None = None,
) -> CampaignResult:
    """Run (or resume) a Monte Carlo campaign and write ``out_dir``.

    Parameters
    ----------
    settings : CampaignSettings
        Scenario, number of runs, seed, perturbation bounds, horizon.
    out_dir : str or Path
        Receives ``campaign.json``, ``chunks/*.nc`` (one per chunk, written as soon as it is done),
        ``montecarlo.nc`` (all runs), ``summary.json`` and ``histograms.png``/``.svg``.
    workers : int, optional
        Local worker processes (default: the number of CPUs); 1 runs in this process.
    dask : str or distributed.Client, optional
        Address of (or a client to) an existing Dask distributed cluster; replaces the local pool.
    resume : bool
        Continue a campaign already in ``out_dir`` (same settings), running only missing chunks.
    progress : bool, optional
        Progress bar (default: when stderr is a terminal).
    run_fn : callable, optional
        Replaces :func:`run_one` (same signature); used to test failure handling.
    figures : bool
        Write the histogram figure.
    base : Scenario, optional
        Use this scenario instead of loading ``settings.scenario``/``case`` (a :class:`Scenario` built in code).

    Returns
    -------
    CampaignResult
    """
    settings.validate()
    t_start = time.perf_counter()
    out = Path(out_dir)
    if base is None:
        base = _base_scenario(settings)
    _prepare_out(out, settings, resume)
    chunks = _chunks(settings)
    todo, resumed = [], 0
    for c, idx in enumerate(chunks):
        if resume and _existing_chunk(_chunk_path(out, c), idx):
            resumed += 1
        else:
            todo.append((c, idx))
    bar = _progress(settings.runs, settings.runs - sum(len(i) for _, i in todo), progress)

    def on_chunk(c: int, idx: Sequence[int], rows) -> None:
        _write_atomic_netcdf(_chunk_dataset(rows, base.n_agents), _chunk_path(out, c))
        bar.update(len(idx))

    try:
        if dask is not None:
            _run_dask(base, settings, todo, dask, run_fn, on_chunk)
        else:
            workers = workers or os.cpu_count() or 1
            _run_local(base, settings, todo, min(workers, max(1, len(todo))), run_fn, on_chunk)
    finally:
        bar.close()
    return finish_campaign(out, settings, base, t_start, resumed, figures=figures)


def finish_campaign(
    out: Path, settings: CampaignSettings, base: Scenario, t_start: float, resumed: int = 0, *, figures: bool = True
) -> CampaignResult:
    """Merge the chunk files into ``montecarlo.nc``, write ``summary.json`` and the histograms."""
    import xarray as xr

    parts = []
    for c in range(len(_chunks(settings))):
        with xr.open_dataset(_chunk_path(out, c), engine="scipy") as ds:
            parts.append(ds.load())
    ds = xr.concat(parts, dim="run")
    for var in ds.variables.values():
        var.encoding = {}  # string widths differ between chunks
    ds.attrs.update(
        {
            "title": f"fsmctl Monte Carlo campaign: {base.label}, {settings.runs} runs, seed {settings.seed}",
            "settings": json.dumps(settings.identity()),
            "scenario": "\n".join(base.describe()),
            "source": "Liang, Sun & Wang, Acta Astronautica 81 (2012) 445-455",
            "seeds": "numpy.random.SeedSequence(seed).spawn(runs)[run]",
        }
    )
    ds.to_netcdf(out / "montecarlo.nc", engine="scipy")
    summary = summarize(ds, settings)
    summary["campaign_wall_time_s"] = time.perf_counter() - t_start
    summary["resumed_chunks"] = resumed
    (out / "summary.json").write_text(json.dumps(summary, indent=2, default=float))
    files = {"dataset": out / "montecarlo.nc", "summary": out / "summary.json"}
    if figures:
        files.update(plot_histograms(ds, out / "histograms", settings))
    return CampaignResult(ds, summary, out, summary["campaign_wall_time_s"], resumed, files)


def summarize(ds, settings: CampaignSettings) -> dict:
    """Counts, fractions and statistics (finite values only) of every per-run variable."""
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
    }
    for k in _FLAGS:
        v = ds[k].values.astype(bool)[ok]
        out[f"{k}_fraction"] = float(v.mean()) if v.size else math.nan
    stats = {}
    for k in _SCALARS:
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
    out["cpu_time_s_total"] = float(np.nansum(ds["cpu_time_s"].values))
    return out


def plot_histograms(ds, stem: str | Path, settings: CampaignSettings) -> dict:
    """Histograms of the main per-run results (PNG and SVG)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

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
    stem = Path(stem)
    files = {}
    for ext in ("png", "svg"):
        path = stem.with_suffix(f".{ext}")
        fig.savefig(path, dpi=110)
        files[ext] = path
    plt.close(fig)
    return files


# ----------------------------------------------------------------------------- CLI


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``fsmctl montecarlo``."""
    p = subparsers.add_parser(
        "montecarlo",
        help="robustness campaign: random inertia, disturbances, initial attitudes/rates and topologies",
        description=(
            "Monte Carlo campaign over random Delta_J (SPD, realizable, <= rho J0), disturbance amplitudes and phases, "
            "initial attitudes uniform over SO(3) and bounded rates, and random switching topologies (Liang et al. 2012). "
            "Writes OUT/montecarlo.nc, OUT/summary.json, OUT/histograms.png/.svg and one file per chunk (resumable)."
        ),
    )
    d = CampaignSettings()
    p.add_argument("--scenario", default="paper", help="built-in name or TOML file (default: paper)")
    p.add_argument("--case", default="1", help="case of the scenario (default: 1)")
    p.add_argument("--runs", type=positive_int, default=100, help="number of runs (default: 100)")
    p.add_argument("--workers", type=positive_int, default=None, help="local worker processes (default: all CPUs)")
    p.add_argument("--seed", type=nonnegative_int, default=0, help="campaign seed (default: 0)")
    p.add_argument("--dask", metavar="ADDRESS", default=None, help="run on an existing Dask distributed scheduler")
    p.add_argument("--out", default="montecarlo_out", help="output folder (default: montecarlo_out)")
    p.add_argument("--resume", action="store_true", help="continue the campaign already in --out")
    p.add_argument("--chunk-size", type=positive_int, default=d.chunk_size, help="runs per chunk file")
    p.add_argument("--t-final", type=finite_or_inf_float, default=None, help="horizon in s (default: the scenario's)")
    p.add_argument("--dt", type=finite_or_inf_float, default=None, help="step in s (default: the scenario's)")
    p.add_argument(
        "--output-interval", type=finite_or_inf_float, default=d.output_interval, help="output grid in s (default: 0.1)"
    )
    p.add_argument(
        "--torque-limit", type=finite_or_inf_float, default=None, help="N m per component (default: the scenario's)"
    )
    p.add_argument(
        "--inertia-bound", type=finite_or_inf_float, default=d.inertia_bound, help="rho_max of 0 < Delta_J <= rho J0"
    )
    p.add_argument("--rate-bound", type=finite_or_inf_float, default=d.rate_bound, help="|omega_k(0)| bound in rad/s")
    p.add_argument("--disturbance-scale", type=finite_or_inf_float, default=d.disturbance_scale, help="amplitude scale")
    p.add_argument(
        "--link-dropout", type=finite_or_inf_float, default=d.link_dropout, help="probability a link is removed"
    )
    p.add_argument(
        "--tolerance-deg", type=finite_or_inf_float, default=d.tolerance_deg, help="convergence tolerance (deg)"
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=_cli)
    return p


def _cli(args: argparse.Namespace) -> int:
    settings = CampaignSettings(
        scenario=args.scenario,
        case=args.case,
        runs=args.runs,
        seed=args.seed,
        chunk_size=args.chunk_size,
        t_final=args.t_final,
        dt=args.dt,
        output_interval=args.output_interval,
        torque_limit=args.torque_limit,
        inertia_bound=args.inertia_bound,
        rate_bound=args.rate_bound,
        disturbance_scale=args.disturbance_scale,
        link_dropout=args.link_dropout,
        tolerance_deg=args.tolerance_deg,
    )
    result = run_campaign(
        settings,
        args.out,
        workers=args.workers,
        dask=args.dask,
        resume=args.resume,
        progress=False if args.no_progress else None,
    )
    for line in _report_lines(result):
        print(line)
    return 0 if not result.failed_runs else 1


def _report_lines(result: CampaignResult) -> Iterable[str]:
    s = result.summary
    st = s["statistics"]

    def med(k: str) -> str:
        e = st[k]
        return f"median {e['median']:.4g} [p5 {e['p5']:.4g}, p95 {e['p95']:.4g}]" if e["finite"] else "no finite value"

    yield f"montecarlo: {s['runs']} runs in {result.wall_time_s:.1f} s ({result.resumed_chunks} chunks resumed): {s['ok']} ok, {s['failed']} failed, {s['worker_died']} worker died"
    yield f"  converged (AAEM and RAEM < {s['tolerance_deg']:g} deg): {s['converged_fraction']:.1%}; Theorem 1 held: {s['theorem1_holds_fraction']:.1%}; Theorem 2 at the reference held: {s['theorem2_at_reference_holds_fraction']:.1%}"
    yield f"  AAEM settling: {med('aaem_settling_s')} s ({st['aaem_settling_s']['nan']} never settled)"
    yield f"  AAEM steady max: {med('aaem_steady_max_deg')} deg; max |u_unsat|: {med('u_unsaturated_max_N_m')} N m; saturation time: {med('saturated_time_max_s')} s"
    for f in s["failures"][:10]:
        yield f"  run {f['run']}: {f['status']}: {f['message']}"
    if len(s["failures"]) > 10:
        yield f"  ... {len(s['failures']) - 10} more in summary.json"
    yield f"  wrote {result.out_dir}/montecarlo.nc, summary.json, histograms.png/.svg"
