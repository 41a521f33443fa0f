"""Simulate a formation with the generated code (whole time loop in compiled C).

:func:`simulate` packs a :class:`~fsmctl.scenario.Scenario`, runs the
whole-loop driver ``fsmctl/csrc/formation.c`` (fixed-step RK4 by default, or
adaptive Dormand-Prince 5(4)), and returns a :class:`SimulationResult` with the
time series, the metrics of eqs 42-43, run statistics, and converters to an
:class:`xarray.Dataset` (NetCDF) and :class:`control.TimeResponseData`.

The piecewise-constant link weights ``k^j_ij(t)`` are evaluated at each RK4 step's midpoint, so the
switches of a schedule that fall on the step grid (all of Table 2 when dt divides 0.1 s) cost no accuracy.
A non-finite torque command stops the run with :class:`SimulationError` (the saturation would otherwise
turn NaN into ``-u_max``).

Without a C compiler the same loop runs in CasADi's virtual machine
(:mod:`fsmctl.casadi_formation`), with a warning.
"""

from __future__ import annotations

import ctypes
import functools
import math
import sys
import time as _time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .generated_code import compiled_library, manifest
from .metrics import aaem_deg, principal_angles, raem_deg, relative_principal_angles, settling_time, steady_state_max
from .problem import PackedProblem, pack
from .scenario import Scenario

__all__ = [
    "SimulationError",
    "DiscontinuousControlWarning",
    "SimulationResult",
    "simulate",
    "simulate_packed",
    "batched_kernels_preferred",
]


class SimulationError(RuntimeError):
    """A run failed (non-finite state, step size underflow, ...); the message says where and why."""


class DiscontinuousControlWarning(RuntimeWarning):
    """An adaptive integrator was asked to integrate the discontinuous sgn(s) law."""


# ----------------------------------------------------------------------------- ctypes binding

_dp = ctypes.POINTER(ctypes.c_double)
_ip = ctypes.POINTER(ctypes.c_int)


class _Problem(ctypes.Structure):
    _fields_ = [
        ("n_agents", ctypes.c_int),
        ("error_model", ctypes.c_int),
        ("integrator", ctypes.c_int),
        ("t0", ctypes.c_double),
        ("dt", ctypes.c_double),
        ("n_steps", ctypes.c_longlong),
        ("output_every", ctypes.c_longlong),
        ("hold_steps", ctypes.c_longlong),
        ("rtol", ctypes.c_double),
        ("atol", ctypes.c_double),
        ("h_min", ctypes.c_double),
        ("max_steps", ctypes.c_longlong),
        ("J_true", _dp),
        ("J0", _dp),
        ("gains", _dp),
        ("delta", _dp),
        ("u_max", _dp),
        ("dist_params", _dp),
        ("ref_params", _dp),
        ("n_links", ctypes.c_int),
        ("link_receiver", _ip),
        ("link_sender", _ip),
        ("link_k_i", _dp),
        ("sched_period", _dp),
        ("sched_phase", _dp),
        ("sched_start", _ip),
        ("sched_count", _ip),
        ("sched_times", _dp),
        ("sched_values", _dp),
        ("kernels", ctypes.c_int),
    ]


class _Output(ctypes.Structure):
    _fields_ = [
        ("capacity", ctypes.c_longlong),
        ("written", ctypes.c_longlong),
        ("t", _dp),
        ("sigma_d", _dp),
        ("sigma", _dp),
        ("omega", _dp),
        ("sigma_e", _dp),
        ("omega_e", _dp),
        ("s", _dp),
        ("u", _dp),
        ("u_unsat", _dp),
        ("saturated_time", _dp),
        ("u_total_variation", _dp),
        ("u_unsat_max", _dp),
        ("steps_taken", ctypes.c_longlong),
        ("steps_rejected", ctypes.c_longlong),
        ("fail_time", ctypes.c_double),
        ("fail_agent", ctypes.c_int),
    ]


_PROGRESS = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_longlong, ctypes.c_longlong)
_RC = {
    1: "a state became non-finite",
    2: "aborted",
    3: "out of memory",
    4: "the packed problem is inconsistent",
    5: "the adaptive step size fell below h_min",
    6: "the adaptive integrator exceeded its step budget",
    7: "the control law returned a non-finite torque command",
}


@functools.cache
def _driver() -> ctypes.CDLL | None:
    lib = compiled_library()
    if lib is None:
        return None
    dll = ctypes.CDLL(str(lib.path))
    dll.fsm_simulate.argtypes = [ctypes.POINTER(_Problem), _dp, ctypes.POINTER(_Output), _PROGRESS, ctypes.c_longlong]
    dll.fsm_simulate.restype = ctypes.c_int
    dll.fsm_rhs.argtypes = [ctypes.POINTER(_Problem), ctypes.c_double, _dp, _dp, _dp]
    dll.fsm_rhs.restype = ctypes.c_int
    dll.fsm_link_weight.argtypes = [ctypes.POINTER(_Problem), ctypes.c_int, ctypes.c_double]
    dll.fsm_link_weight.restype = ctypes.c_double
    for name in ("fsm_batched_available", "fsm_batched_preferred"):
        getattr(dll, name).argtypes = []
        getattr(dll, name).restype = ctypes.c_int
    return dll


def batched_kernels_preferred() -> bool:
    """Whether ``kernels="auto"`` uses the lane-batched kernels (the compiled library has AVX); False without C."""
    dll = _driver()
    return bool(dll is not None and dll.fsm_batched_preferred())


def _ptr(a: np.ndarray, ctype=ctypes.c_double):
    return a.ctypes.data_as(ctypes.POINTER(ctype))


_KERNELS = {"auto": 0, "batched": 1, "scalar": 2}


class _CProblem:
    """Keeps the arrays alive while C holds pointers into them."""

    def __init__(self, p: PackedProblem, max_steps: int = 0, kernels: str = "auto"):
        self._keep = {}

        def f(name, arr, dtype=np.float64):
            a = np.ascontiguousarray(arr, dtype=dtype)
            if a.size == 0:
                a = np.zeros(1, dtype=dtype)
            self._keep[name] = a
            return _ptr(a, ctypes.c_double if dtype == np.float64 else ctypes.c_int)

        self.struct = _Problem(
            n_agents=p.n_agents,
            error_model=p.error_model,
            integrator=p.integrator,
            t0=p.t0,
            dt=p.dt,
            n_steps=p.n_steps,
            output_every=p.output_every,
            hold_steps=p.hold_steps,
            rtol=p.rtol,
            atol=p.atol,
            h_min=1e-12 * max(1.0, p.dt * p.n_steps),
            max_steps=max_steps or 200 * p.n_steps + 10_000,
            J_true=f("J_true", p.J_true),
            J0=f("J0", p.J0),
            gains=f("gains", p.gains),
            delta=f("delta", p.delta),
            u_max=f("u_max", p.u_max),
            dist_params=f("dist", p.dist_params),
            ref_params=f("ref", p.ref_params),
            n_links=p.n_links,
            link_receiver=f("lr", p.link_receiver, np.int32),
            link_sender=f("ls", p.link_sender, np.int32),
            link_k_i=f("lk", p.link_k_i),
            sched_period=f("sp", p.sched_period),
            sched_phase=f("sph", p.sched_phase),
            sched_start=f("ss", p.sched_start, np.int32),
            sched_count=f("sc", p.sched_count, np.int32),
            sched_times=f("st", p.sched_times),
            sched_values=f("sv", p.sched_values),
            kernels=_KERNELS[kernels],
        )


def _progress_callback(total: int, enabled: bool, label: str):
    state = {"bar": None, "interrupted": False}
    if enabled:
        from tqdm.auto import tqdm

        state["bar"] = tqdm(total=total, desc=label, unit="step", unit_scale=True, leave=False, file=sys.stderr)

    def cb(done, planned):
        try:
            bar = state["bar"]
            if bar is not None:
                bar.update(int(done) - bar.n)
            return 0
        except KeyboardInterrupt:
            state["interrupted"] = True
            return 1

    return _PROGRESS(cb), state


# ----------------------------------------------------------------------------- results


@dataclass
class SimulationResult:
    """Time series and statistics of one run.

    Arrays (``T`` output samples, ``n`` agents): ``time`` (T,) s; ``sigma``,
    ``sigma_e`` (T, n, 3) MRP; ``omega``, ``omega_e`` (T, n, 3) rad/s; ``s`` (T, n, 3);
    ``u``, ``u_unsaturated`` (T, n, 3) N m (applied and commanded); ``sigma_d`` (T, 3).
    """

    scenario: Scenario
    time: np.ndarray
    sigma: np.ndarray
    omega: np.ndarray
    sigma_e: np.ndarray
    omega_e: np.ndarray
    s: np.ndarray
    u: np.ndarray
    u_unsaturated: np.ndarray
    sigma_d: np.ndarray
    saturated_time: np.ndarray
    """(n,) s with at least one torque component saturated"""
    u_total_variation: np.ndarray
    """(n,) N m: sum over steps of |u(t_k) - u(t_k-1)|_1"""
    u_unsaturated_max: np.ndarray
    backend: str
    wall_time: float
    steps_taken: int = 0
    steps_rejected: int = 0
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def n_agents(self) -> int:
        return self.sigma.shape[1]

    @property
    def theta_e(self) -> np.ndarray:
        """(T, n) rad: principal angle of each agent's attitude error."""
        if "theta_e" not in self._cache:
            self._cache["theta_e"] = principal_angles(self.sigma_e)
        return self._cache["theta_e"]

    @property
    def theta_relative(self) -> np.ndarray:
        """(T, n, n) rad: principal angle between agents i and j."""
        if "theta_ij" not in self._cache:
            self._cache["theta_ij"] = relative_principal_angles(self.sigma_e)
        return self._cache["theta_ij"]

    @property
    def aaem_deg(self) -> np.ndarray:
        """Absolute attitude error metric, eq 42 (deg)."""
        return aaem_deg(self.theta_e)

    @property
    def raem_deg(self) -> np.ndarray:
        """Relative attitude error metric, eq 43 (deg)."""
        return raem_deg(self.theta_relative)

    @property
    def chattering_index(self) -> np.ndarray:
        """(n,) N m/s: total variation of the applied torque per second of simulated time."""
        span = float(self.time[-1] - self.time[0]) or 1.0
        return self.u_total_variation / span

    def summary(self, tolerances_deg=(1.0, 0.1, 0.05, 0.03, 0.01), steady_window: float = 40.0) -> dict:
        """Settling times of AAEM/RAEM per tolerance, steady-state accuracy, torque statistics."""
        t, a, r = self.time, self.aaem_deg, self.raem_deg
        window = min(steady_window, float(t[-1] - t[0]))
        return {
            "scenario": self.scenario.label,
            "backend": self.backend,
            "wall_time_s": self.wall_time,
            "aaem_initial_deg": float(a[0]),
            "raem_initial_deg": float(r[0]),
            "aaem_peak_deg": float(a.max()),
            "raem_peak_deg": float(r.max()),
            "aaem_settling_s": {f"{tol:g}": settling_time(t, a, tol) for tol in tolerances_deg},
            "raem_settling_s": {f"{tol:g}": settling_time(t, r, tol) for tol in tolerances_deg},
            "steady_window_s": window,
            "aaem_steady_max_deg": steady_state_max(t, a, window),
            "raem_steady_max_deg": steady_state_max(t, r, window),
            "u_max_abs_N_m": float(np.abs(self.u).max()),
            "u_unsaturated_max_N_m": float(self.u_unsaturated_max.max()),
            "saturated_time_s": self.saturated_time.tolist(),
            "last_saturation_s": self.last_saturation_time(),
            "chattering_index_N_m_per_s": self.chattering_index.tolist(),
        }

    def last_saturation_time(self) -> float:
        """Last output time at which any torque component was at the limit (NaN if never)."""
        limit = self.scenario.controller.effective_torque_limit
        if not math.isfinite(limit):
            return float("nan")
        hit = np.nonzero(np.any(np.abs(self.u_unsaturated) > limit, axis=(1, 2)))[0]
        return float(self.time[hit[-1]]) if hit.size else float("nan")

    # --- conversion -------------------------------------------------------------------
    def to_dataset(self):
        """An :class:`xarray.Dataset` with units in the variable names and attributes."""
        import xarray as xr

        n = self.n_agents
        coords = {
            "time_s": self.time,
            "agent": np.arange(1, n + 1, dtype=np.int32),
            "axis": np.arange(3, dtype=np.int32),
        }
        tna = ("time_s", "agent", "axis")

        def var(data, dims, units, long_name):
            return xr.Variable(dims, data, {"units": units, "long_name": long_name})

        ds = xr.Dataset(
            {
                "sigma": var(self.sigma, tna, "1", "MRP attitude sigma_i (shadow set)"),
                "omega_rad_per_s": var(self.omega, tna, "rad/s", "body angular velocity omega_i"),
                "sigma_e": var(self.sigma_e, tna, "1", "MRP attitude error sigma_ei"),
                "omega_e_rad_per_s": var(self.omega_e, tna, "rad/s", "angular velocity error omega_ei"),
                "s": var(self.s, tna, "1/s", "sliding variable s_i (eq 13)"),
                "u_N_m": var(self.u, tna, "N m", "applied control torque u_i"),
                "u_unsaturated_N_m": var(self.u_unsaturated, tna, "N m", "commanded torque before saturation"),
                "sigma_d": var(self.sigma_d, ("time_s", "axis"), "1", "reference MRP sigma_d"),
                "theta_e_deg": var(
                    np.degrees(self.theta_e), ("time_s", "agent"), "deg", "error principal angle theta_ei"
                ),
                "aaem_deg": var(self.aaem_deg, ("time_s",), "deg", "absolute attitude error metric (eq 42)"),
                "raem_deg": var(self.raem_deg, ("time_s",), "deg", "relative attitude error metric (eq 43)"),
                "saturated_time_s": var(self.saturated_time, ("agent",), "s", "time with a saturated component"),
                "u_total_variation_N_m": var(self.u_total_variation, ("agent",), "N m", "total variation of u"),
                "u_unsaturated_max_N_m": var(self.u_unsaturated_max, ("agent",), "N m", "max |commanded torque|"),
            },
            coords=coords,
        )
        ds["time_s"].attrs["units"] = "s"
        ds.attrs.update(
            {
                "title": f"fsmctl simulation: {self.scenario.label}",
                "scenario": "\n".join(self.scenario.describe()),
                "backend": self.backend,
                "generated_code": ", ".join(f"{k} {v}" for k, v in manifest()["versions"].items()),
                "source": "Liang, Sun & Wang, Acta Astronautica 81 (2012) 445-455",
            }
        )
        return ds

    def save(self, path: str | Path) -> Path:
        """Write NetCDF (``.nc``) or NumPy (``.npz``), chosen by the suffix."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        if path.suffix == ".npz":
            ds = self.to_dataset()
            np.savez_compressed(path, **{k: v.values for k, v in ds.variables.items()})
        else:
            self.to_dataset().to_netcdf(path, engine="scipy")
        return path

    def to_time_response(self):
        """A :class:`control.TimeResponseData` with the signal names of :func:`fsmctl.formation`."""
        import control as ct

        n = self.n_agents
        T = self.time.size
        x = np.concatenate(
            [self.sigma_d.T] + [np.concatenate([self.sigma[:, i].T, self.omega[:, i].T]) for i in range(n)]
        )
        y = np.concatenate([np.concatenate([self.sigma[:, i].T, self.omega[:, i].T, self.u[:, i].T]) for i in range(n)])
        state_labels = [f"reference_sigma_d[{k}]" for k in range(3)] + [
            f"sc{i + 1}_{v}[{k}]" for i in range(n) for v in ("sigma", "omega") for k in range(3)
        ]
        output_labels = [f"sc{i + 1}_{v}[{k}]" for i in range(n) for v in ("sigma", "omega", "tau") for k in range(3)]
        return ct.TimeResponseData(
            self.time,
            y,
            x,
            np.zeros((0, T)),
            output_labels=output_labels,
            state_labels=state_labels,
            input_labels=[],
            sysname=f"formation ({self.scenario.label})",
            title=f"fsmctl formation: {self.scenario.label}",
            issiso=False,
            plot_inputs=False,  # a closed formation has no inputs: plot() shows the outputs
        )


# ----------------------------------------------------------------------------- running


def _check_integrator(p: PackedProblem, scenario: Scenario) -> None:
    if p.integrator == 1 and scenario.controller.boundary_layer == 0:
        warnings.warn(
            "adaptive integration of the discontinuous sgn(s) control (boundary_layer = 0): the step size will "
            "collapse near the sliding surface; use integrator='rk4' or a boundary layer (Remark 7)",
            DiscontinuousControlWarning,
            stacklevel=3,
        )


def simulate_packed(
    p: PackedProblem, *, progress: bool = False, label: str = "simulate", kernels: str = "auto"
) -> dict:
    """Run a packed problem on the compiled driver (or the CasADi fallback); returns raw arrays.

    ``kernels`` (compiled driver only): ``"batched"`` evaluates the per-agent functions through the
    lane-batched kernels of ``generated/c/batched.c`` (4 agents per call, SIMD); ``"scalar"`` calls
    the CasADi-generated scalar functions agent by agent; ``"auto"`` (default) is ``"batched"`` when the
    library was built with AVX (see :func:`batched_kernels_preferred`), else ``"scalar"``.  The results are
    bit-identical (up to the sign of a zero from ``fmin``/``fmax`` of ``+0`` and ``-0``).
    """
    if kernels not in _KERNELS:
        raise ValueError(f"kernels must be one of {sorted(_KERNELS)}, got {kernels!r}")
    dll = _driver()
    if dll is None:
        from .casadi_formation import simulate_casadi

        return simulate_casadi(p, progress=progress, label=label)
    if kernels == "batched" and not dll.fsm_batched_available():
        raise SimulationError(
            "kernels='batched': this build of the library has no batched kernels (the C compiler lacks the "
            "GCC/Clang vector extension); use kernels='auto' or 'scalar'"
        )
    n, cap = p.n_agents, p.n_outputs + 1
    bufs = {k: np.zeros((cap, n, 3)) for k in ("sigma", "omega", "sigma_e", "omega_e", "s", "u", "u_unsat")}
    bufs["t"] = np.zeros(cap)
    bufs["sigma_d"] = np.zeros((cap, 3))
    stats = {k: np.zeros(n) for k in ("saturated_time", "u_total_variation", "u_unsat_max")}
    out = _Output(capacity=cap, **{k: _ptr(v) for k, v in {**bufs, **stats}.items()})
    cp = _CProblem(p, kernels=kernels)
    x0 = np.ascontiguousarray(p.x0, dtype=float)
    every = max(1, p.n_steps // 200)
    cb, state = _progress_callback(p.n_steps, progress, label)
    t0 = _time.perf_counter()
    try:
        rc = dll.fsm_simulate(ctypes.byref(cp.struct), _ptr(x0), ctypes.byref(out), cb, every)
    finally:
        if state["bar"] is not None:
            state["bar"].close()
    wall = _time.perf_counter() - t0
    if state["interrupted"]:
        raise KeyboardInterrupt
    if rc != 0:
        detail = _RC.get(rc, f"error code {rc}")
        if rc in (1, 7):
            who = "the reference" if out.fail_agent == -1 else f"agent {out.fail_agent + 1}"
            detail += f" at t = {out.fail_time:.6g} s in {who}"
            detail += (
                " (the Remark 6 term alpha|sigma_e|^(alpha-1) is singular with singularity_fix = 'none'; use 'switch')"
                if any(p.gains[:, 5] == 0)
                else " (check inertias, gains and the step size)"
            )
        elif rc == 5:
            detail += f" at t = {out.fail_time:.6g} s (discontinuous control? use rk4 or a boundary layer)"
        raise SimulationError(f"simulation failed: {detail}")
    w = out.written
    raw = {k: v[:w] for k, v in bufs.items()}
    raw.update(stats)
    if kernels == "auto":
        kernels = "batched" if dll.fsm_batched_preferred() else "scalar"
    raw.update(wall_time=wall, backend="compiled", steps_taken=out.steps_taken, steps_rejected=out.steps_rejected)
    raw["kernels"] = kernels
    return raw


def simulate(scenario: Scenario, *, progress: bool | None = None) -> SimulationResult:
    """Simulate ``scenario`` with the generated code; see :class:`SimulationResult`.

    ``progress``: show a progress bar (default: for runs of more than 10^6 agent-steps on a terminal).
    """
    p = pack(scenario)
    _check_integrator(p, scenario)
    if progress is None:
        progress = p.n_steps * p.n_agents > 1_000_000 and sys.stderr.isatty()
    raw = simulate_packed(p, progress=progress, label=scenario.label)
    return SimulationResult(
        scenario=scenario,
        time=raw["t"],
        sigma=raw["sigma"],
        omega=raw["omega"],
        sigma_e=raw["sigma_e"],
        omega_e=raw["omega_e"],
        s=raw["s"],
        u=raw["u"],
        u_unsaturated=raw["u_unsat"],
        sigma_d=raw["sigma_d"],
        saturated_time=raw["saturated_time"],
        u_total_variation=raw["u_total_variation"],
        u_unsaturated_max=raw["u_unsat_max"],
        backend=raw["backend"],
        wall_time=raw["wall_time"],
        steps_taken=int(raw["steps_taken"]),
        steps_rejected=int(raw["steps_rejected"]),
    )
