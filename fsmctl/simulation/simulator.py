"""Simulate a formation with the generated code (whole time loop in compiled C).

:func:`simulate` packs a :class:`~fsmctl.model.scenario.Scenario`, runs the
whole-loop driver ``fsmctl/csrc/formation.c`` (fixed-step RK4 by default, or
adaptive Dormand-Prince 5(4)), and returns a :class:`SimulationResult` with the
time series, the metrics of eqs 42-43, run statistics, and converters to an
:class:`xarray.Dataset` (NetCDF) and :class:`control.TimeResponseData`.

The piecewise-constant link weights ``k^j_ij(t)`` are evaluated at each RK4 step's midpoint, so the
switches of a schedule that fall on the step grid (all of Table 2 when dt divides 0.1 s) cost no accuracy.
A non-finite torque command stops the run with :class:`SimulationError` (the saturation would otherwise
turn NaN into ``-u_max``).

Without a C compiler the same loop runs in CasADi's virtual machine
(:mod:`fsmctl.simulation.casadi_formation`), with a warning.

Reliability guarantees of :func:`simulate` / :func:`simulate_packed`:

* memory: the output buffers (:func:`fsmctl.model.problem.output_buffer_bytes`) are estimated before they are
  allocated and a run whose results would not fit in the available memory (:func:`available_memory`) is
  refused with :class:`~fsmctl.errors.ResourceLimitError`; the relative attitude metric (eq 43) is computed
  in blocks of samples (:func:`fsmctl.simulation.metrics.streamed_raem_deg`), never as a ``T x n x n`` array;
* the last output sample is the final state: ``time[-1] == t_final`` or :class:`SimulationError`;
* Ctrl-C and SIGTERM: while the compiled loop runs, SIGINT and SIGTERM only set a flag that the progress callback
  polls; the loop stops at its next callback and the signal's own handler runs once C has returned
  (:class:`KeyboardInterrupt` for SIGINT; ``fsmctl`` turns SIGTERM into exit 143), raised from
  :func:`simulate_packed` (no exception ever passes through the ctypes callback);
* step size: :class:`StepSizeWarning` when the fixed RK4 step is too coarse for the loop's fastest time
  constant or for the rotation per step (:func:`step_size_report`).
"""

from __future__ import annotations

import ctypes
import functools
import math
import signal
import sys
import threading
import time as _time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fsmctl.errors import EnvironmentProblem, ResourceLimitError
from fsmctl.model.generated_code import compiled_library, default_law_dir, manifest
from fsmctl.model.problem import PackedProblem, output_buffer_bytes, pack
from fsmctl.model.scenario import Scenario
from fsmctl.simulation.metrics import (
    RAEM_WORKING_BYTES,
    aaem_deg,
    pair_angles,
    principal_angles,
    relative_angles_at,
    relative_angles_bytes,
    relative_principal_angles,
    settling_time,
    steady_state_max,
    streamed_raem_deg,
)

__all__ = [
    "SimulationError",
    "DiscontinuousControlWarning",
    "StepSizeWarning",
    "SimulationResult",
    "simulate",
    "simulate_many",
    "simulate_packed",
    "batched_kernels_preferred",
    "available_memory",
    "check_output_memory",
    "check_noise_memory",
    "RESULT_MEMORY_FACTOR",
    "step_size_report",
    "MAX_ROTATION_PER_STEP",
    "MAX_STEP_RATE",
]


class SimulationError(RuntimeError):
    """A run failed (non-finite state, step size underflow, ...); the message says where and why.

    ``fsmctl simulate`` exits 1 on it (:mod:`fsmctl.errors`): the input was valid, the run itself failed.

    Examples
    --------
    >>> import fsmctl
    >>> issubclass(fsmctl.SimulationError, RuntimeError)
    True
    """


class DiscontinuousControlWarning(RuntimeWarning):
    """An adaptive integrator was asked to integrate the discontinuous sgn(s) law.

    Examples
    --------
    >>> from fsmctl.simulation import DiscontinuousControlWarning
    >>> issubclass(DiscontinuousControlWarning, RuntimeWarning)
    True
    """


class StepSizeWarning(RuntimeWarning):
    """The fixed RK4 step is too coarse for the loop's fastest time constant or rotates too far per step.

    :func:`simulate` warns before the run; :func:`step_size_report` gives the numbers.

    Examples
    --------
    >>> import warnings, fsmctl
    >>> coarse = fsmctl.paper_scenario("1").replace(simulation={"dt": 0.05, "t_final": 0.1, "output_interval": 0.05})
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     _ = fsmctl.simulate(coarse)
    >>> any(issubclass(w.category, fsmctl.StepSizeWarning) for w in caught)
    True
    """


# ----------------------------------------------------------------------------- ctypes binding

_dp = ctypes.POINTER(ctypes.c_double)
_ip = ctypes.POINTER(ctypes.c_int)


class _Problem(ctypes.Structure):
    """Mirror of ``fsm_problem`` (fsmctl/csrc/formation.h); checked against the library at load (:func:`_check_abi`)."""

    _fields_ = [
        ("n_agents", ctypes.c_int),
        ("error_model", ctypes.c_int),
        ("integrator", ctypes.c_int),
        ("kernels", ctypes.c_int),
        ("n_params", ctypes.c_int),
        ("n_states", ctypes.c_int),
        ("n_broadcast", ctypes.c_int),
        ("n_links", ctypes.c_int),
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
        ("params", _dp),
        ("u_max", _dp),
        ("dist_params", _dp),
        ("ref_params", _dp),
        ("link_receiver", _ip),
        ("link_sender", _ip),
        ("link_k_i", _dp),
        ("sched_period", _dp),
        ("sched_phase", _dp),
        ("sched_start", _ip),
        ("sched_count", _ip),
        ("sched_times", _dp),
        ("sched_values", _dp),
        ("n_wheels", ctypes.c_int),
        ("sensors", ctypes.c_int),
        ("links_imperfect", ctypes.c_int),
        ("n_samples", ctypes.c_longlong),
        ("wheel_axes", _dp),
        ("wheel_pinv", _dp),
        ("wheel_Js", _dp),
        ("wheel_torque_max", _dp),
        ("wheel_params", _dp),
        ("J_spin", _dp),
        ("sensor_dtheta", _dp),
        ("sensor_gyro", _dp),
        ("link_delay", _ip),
        ("link_lost", ctypes.POINTER(ctypes.c_ubyte)),
        ("n_members", ctypes.c_int),
    ]


class _Output(ctypes.Structure):
    """Mirror of ``fsm_output`` (fsmctl/csrc/formation.h); checked against the library at load."""

    _fields_ = [
        ("capacity", ctypes.c_longlong),
        ("written", ctypes.c_longlong),
        ("t", _dp),
        ("sigma_d", _dp),
        ("sigma", _dp),
        ("omega", _dp),
        ("sigma_e", _dp),
        ("omega_e", _dp),
        ("u", _dp),
        ("u_unsat", _dp),
        ("broadcast", _dp),
        ("z", _dp),
        ("saturated_time", _dp),
        ("u_total_variation", _dp),
        ("u_unsat_max", _dp),
        ("steps_taken", ctypes.c_longlong),
        ("steps_rejected", ctypes.c_longlong),
        ("fail_time", ctypes.c_double),
        ("fail_agent", ctypes.c_int),
        ("wheel_speed", _dp),
        ("wheel_torque", _dp),
        ("sigma_measured", _dp),
        ("omega_measured", _dp),
    ]


ABI_VERSION = 4
"""``FSM_ABI_VERSION`` of fsmctl/csrc/formation.h that these mirrors describe."""

_PROGRESS = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_longlong, ctypes.c_longlong)
_RC = {
    1: "a state became non-finite",
    2: "aborted",
    3: "out of memory",
    4: "the packed problem is inconsistent (or the law's code does not match its description)",
    5: "the adaptive step size fell below h_min",
    6: "the adaptive integrator exceeded its step budget",
    7: "the control law returned a non-finite torque command",
}


def _expected_abi() -> list[int]:
    """``fsm_abi()`` as these ctypes mirrors see it: version, sizes, then every field offset."""
    return [
        ABI_VERSION,
        ctypes.sizeof(_Problem),
        ctypes.sizeof(_Output),
        *(getattr(_Problem, name).offset for name, _ in _Problem._fields_),
        *(getattr(_Output, name).offset for name, _ in _Output._fields_),
    ]


def _check_abi(dll: ctypes.CDLL, where: str) -> None:
    """The library's struct layout must be the one mirrored here (a stale or foreign library is refused)."""
    expected = _expected_abi()
    buf = (ctypes.c_longlong * (len(expected) + 8))()
    count = dll.fsm_abi(buf, len(buf))
    got = list(buf[: min(count, len(buf))])
    if count != len(expected) or got != expected:
        raise SimulationError(
            f"{where}: the compiled driver's struct layout (fsm_abi: {got[:3]}, {count} entries) does not match "
            f"fsmctl's ({expected[:3]}, {len(expected)} entries); clear the cache ({where}) and retry"
        )


@functools.cache
def _driver_for(law_dir: Path) -> ctypes.CDLL | None:
    lib = compiled_library(law_dir)
    if lib is None:
        return None
    dll = ctypes.CDLL(str(lib.path))
    dll.fsm_abi.argtypes = [ctypes.POINTER(ctypes.c_longlong), ctypes.c_int]
    dll.fsm_abi.restype = ctypes.c_int
    _check_abi(dll, str(lib.path))
    dll.fsm_simulate.argtypes = [ctypes.POINTER(_Problem), _dp, ctypes.POINTER(_Output), _PROGRESS, ctypes.c_longlong]
    dll.fsm_simulate.restype = ctypes.c_int
    dll.fsm_rhs.argtypes = [ctypes.POINTER(_Problem), ctypes.c_double, _dp, _dp, _dp]
    dll.fsm_rhs.restype = ctypes.c_int
    dll.fsm_link_weight.argtypes = [ctypes.POINTER(_Problem), ctypes.c_int, ctypes.c_double]
    dll.fsm_link_weight.restype = ctypes.c_double
    dll.fsm_law_sizes.argtypes = [ctypes.POINTER(ctypes.c_longlong)]
    dll.fsm_law_sizes.restype = None
    for name in ("fsm_batched_available", "fsm_batched_preferred"):
        getattr(dll, name).argtypes = []
        getattr(dll, name).restype = ctypes.c_int
    return dll


def _driver(law=None) -> ctypes.CDLL | None:
    """The compiled driver for a law (a :class:`~fsmctl.model.laws.LawCode`, default the paper's FSM law)."""
    folder = default_law_dir() if law is None else law.folder
    return _driver_for(Path(folder).resolve())


_driver.cache_clear = _driver_for.cache_clear  # type: ignore[attr-defined]


def batched_kernels_preferred() -> bool:
    """Whether ``kernels="auto"`` uses the lane-batched kernels (the compiled library has AVX); False without C."""
    dll = _driver()
    return bool(dll is not None and dll.fsm_batched_preferred())


def _ptr(a: np.ndarray, ctype=ctypes.c_double):
    return a.ctypes.data_as(ctypes.POINTER(ctype))


_KERNELS = {"auto": 0, "batched": 1, "scalar": 2}


class _CProblem:
    """Keeps the arrays alive while C holds pointers into them."""

    def __init__(self, p: PackedProblem, max_steps: int = 0, kernels: str = "auto", members: int = 1):
        self._keep = {}

        ctypes_of = {np.float64: ctypes.c_double, np.int32: ctypes.c_int, np.uint8: ctypes.c_ubyte}

        def f(name, arr, dtype=np.float64):
            a = np.ascontiguousarray(arr, dtype=dtype)
            if a.size == 0:
                a = np.zeros(1, dtype=dtype)
            self._keep[name] = a
            return _ptr(a, ctypes_of[dtype])

        hw = p.hardware

        self.struct = _Problem(
            n_agents=p.n_agents,
            error_model=p.error_model,
            integrator=p.integrator,
            n_params=p.law.n_params,
            n_states=p.n_states,
            n_broadcast=p.n_broadcast,
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
            params=f("params", p.params),
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
            n_wheels=hw.n_wheels,
            sensors=int(hw.sensors),
            links_imperfect=int(hw.links_imperfect),
            n_samples=hw.n_samples,
            wheel_axes=f("wa", hw.wheel_axes),
            wheel_pinv=f("wp", hw.wheel_pinv),
            wheel_Js=f("wj", hw.wheel_Js),
            wheel_torque_max=f("wt", hw.wheel_torque_max),
            wheel_params=f("wpar", hw.wheel_params),
            J_spin=f("jspin", hw.J_spin),
            sensor_dtheta=f("sdt", hw.sensor_dtheta),
            sensor_gyro=f("sgy", hw.sensor_gyro),
            link_delay=f("ld", hw.link_delay, np.int32),
            link_lost=f("ll", hw.link_lost, np.uint8),
            n_members=members,
        )


class _DeferredSignals:
    """Context manager: while the compiled loop runs, ``SIGINT`` and ``SIGTERM`` only record themselves.

    Python runs signal handlers between bytecodes of the main thread, and while C runs the next bytecodes
    are those of the progress callback: a handler that raises (the default ``SIGINT`` handler's
    :class:`KeyboardInterrupt`, the command line's ``SIGTERM`` handler) raises inside the ctypes callback,
    typically at its first line, before its ``try`` (or inside tqdm).  ctypes then prints "Exception ignored on
    calling ctypes callback function" with the traceback, discards the exception and hands C an undefined
    return value (observed: the loop stopped, the run was reported as "simulation failed: aborted" and
    ``fsmctl simulate`` exited 1 instead of 130 or 143).  This handler raises nothing; the callback polls
    :attr:`pending` and asks C to stop, and :meth:`deliver` runs the original handler of the signal that
    arrived (``SIGINT`` by default: raise :class:`KeyboardInterrupt`; ``fsmctl``'s ``SIGTERM`` handler: exit
    143) once C has returned.

    Installed only in the main thread (the only one that receives signals) and only over a Python-level
    handler; a signal that is ignored (``SIG_IGN``, e.g. ``SIGINT`` in pool workers) or left to the OS
    (``SIG_DFL``: ``SIGTERM`` outside the command line ends the process) stays so.
    """

    SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM") if hasattr(signal, n))

    def __init__(self):
        self.pending: tuple | None = None
        self._previous: dict = {}

    def _record(self, signum, frame):
        if self.pending is None:
            self.pending = (signum, frame)

    def __enter__(self) -> _DeferredSignals:
        if threading.current_thread() is threading.main_thread():
            for sig in self.SIGNALS:
                previous = signal.getsignal(sig)
                if callable(previous):
                    try:
                        signal.signal(sig, self._record)
                    except (ValueError, OSError):  # pragma: no cover - e.g. an embedded interpreter
                        continue
                    self._previous[sig] = previous
        return self

    def __exit__(self, *exc) -> None:
        for sig, previous in self._previous.items():
            signal.signal(sig, previous)

    def deliver(self) -> None:
        """Run the handler that was deferred (after C returned); :class:`KeyboardInterrupt` if it returns."""
        if self.pending is not None:
            (signum, frame), self.pending = self.pending, None
            previous = self._previous.get(signum)
            if previous is not None:
                previous(signum, frame)
            raise KeyboardInterrupt  # the loop was stopped: the run is not complete


def _progress_callback(total: int, enabled: bool, label: str, guard: _DeferredSignals | None = None, watch=None):
    """The ctypes progress callback; a nonzero return stops the loop.

    Nothing may escape a ctypes callback (ctypes would print it and carry on), so every exception is caught
    and kept in ``state["error"]``; a deferred SIGINT (``guard.pending``) stops the loop too.  ``watch(done)``
    (optional) runs after the bar's update; its nonzero return stops the loop (a monitor's early stop).
    """
    state = {"bar": None, "interrupted": False, "error": None}
    if enabled:
        from tqdm.auto import tqdm

        state["bar"] = tqdm(total=total, desc=label, unit="step", unit_scale=True, leave=False, file=sys.stderr)

    def cb(done, planned):
        try:
            if guard is not None and guard.pending is not None:
                state["interrupted"] = True
                return 1
            bar = state["bar"]
            if bar is not None:
                bar.update(int(done) - bar.n)
            return 0 if watch is None else watch(int(done))
        except BaseException as exc:  # re-raised by simulate_packed once C has returned
            state["interrupted"] = isinstance(exc, KeyboardInterrupt)
            state["error"] = exc
            return 1

    return _PROGRESS(cb), state


_CALLBACK_AGENT_STEPS = 50_000
"""The progress callback (which also polls for Ctrl-C) runs at least every this many agent-steps
(~20 ms of compiled loop), and at most 200 times per run for small formations."""


def _callback_every(p: PackedProblem) -> int:
    return max(1, min(max(1, p.n_steps // 200), _CALLBACK_AGENT_STEPS // max(1, p.n_agents)))


# ----------------------------------------------------------------------------- memory


def available_memory() -> int | None:
    """Bytes of memory a new allocation can use, or None when unknown (then nothing is checked).

    ``psutil.virtual_memory().available`` when psutil is importable, else ``MemAvailable`` of
    ``/proc/meminfo``; lowered to the room left under a cgroup v2 limit (``memory.max - memory.current``
    of ``/sys/fs/cgroup``, i.e. a container's limit) when there is one.
    """
    avail = None
    try:
        import psutil
    except ImportError:
        try:
            with open("/proc/meminfo") as fh:
                for line in fh:
                    if line.startswith("MemAvailable:"):
                        avail = int(line.split()[1]) * 1024
                        break
        except (OSError, ValueError, IndexError):
            avail = None
    else:
        try:
            avail = int(psutil.virtual_memory().available)
        except Exception:  # psutil unsupported on this platform: no check
            avail = None
    try:
        with open("/sys/fs/cgroup/memory.max") as fh:
            limit = fh.read().strip()
        if limit != "max":
            with open("/sys/fs/cgroup/memory.current") as fh:
                room = int(limit) - int(fh.read().strip())
            avail = room if avail is None else min(avail, room)
    except (OSError, ValueError):
        pass
    return avail


def _fmt_bytes(x: float) -> str:
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if abs(x) >= scale:
            return f"{x / scale:.3g} {unit}"
    return f"{x:.0f} B"


RESULT_MEMORY_FACTOR = 2.5
"""Peak memory of a run's results as a multiple of its output buffers: the buffers, what the results derive
from them (``theta_e``, the metrics) and, while the NetCDF file is written, SciPy's in-memory copy of the
whole dataset (measured by ``benchmarks/memory.py``: 0.81 GB above the interpreter for 0.34 GB of buffers,
200 agents over 100 s)."""


def check_output_memory(p: PackedProblem, *, available: int | None = None) -> int:
    """Estimate the memory of a run's results and refuse (:class:`ResourceLimitError`) when it is not there.

    The estimate is :func:`fsmctl.model.problem.output_buffer_bytes` (seven ``(T, n, 3)`` float64 arrays, time,
    ``sigma_d`` and the per-agent statistics, ``T = n_outputs + 1`` rows) times :data:`RESULT_MEMORY_FACTOR`
    plus the streamed metric's working memory (:data:`fsmctl.simulation.metrics.RAEM_WORKING_BYTES`): what ``fsmctl
    simulate`` needs to run, summarise and save the results.  It is compared with ``available`` (default:
    :func:`available_memory`; None: no check) before anything is allocated.  Returns the estimate in bytes.
    """
    buffers = output_buffer_bytes(
        p.n_agents, p.n_outputs + 1, p.n_broadcast, p.n_states, p.n_wheels, p.hardware.sensors
    )
    needed = int(RESULT_MEMORY_FACTOR * buffers) + RAEM_WORKING_BYTES
    if available is None:
        available = available_memory()
    if available is not None and needed > available:
        dt_out = p.output_every * p.dt
        t_final = p.n_steps * p.dt
        per_row = max(1, int(RESULT_MEMORY_FACTOR * output_buffer_bytes(p.n_agents, 1)))
        rows_fit = max(2, (available - RAEM_WORKING_BYTES) // per_row - 1)
        every_fit = max(p.output_every, -(-p.n_steps // max(1, rows_fit - 1)))
        raise ResourceLimitError(
            f"this run's results would need ~{_fmt_bytes(needed)} of memory ({p.n_agents} agents x "
            f"{p.n_outputs:,} output samples) but only {_fmt_bytes(available)} is available: raise "
            f"output_interval (now {dt_out:g} s; >= {every_fit * p.dt:.3g} s dividing t_final would fit) or shorten t_final "
            f"(now {t_final:g} s)"
        )
    return needed


def check_noise_memory(scenario: Scenario, *, available: int | None = None) -> int:
    """Refuse (:class:`ResourceLimitError`) a run whose sensor noise and packet-loss tables (drawn before the run,
    one row per control instant: :func:`fsmctl.model.noise.noise_bytes`) would not fit in memory; returns the bytes.
    """
    sim = scenario.simulation
    if not (scenario.sensors.enabled or scenario.links_active):
        return 0
    from fsmctl.model.noise import noise_bytes

    instants = sim.n_steps // sim.hold_steps + 1
    needed = noise_bytes(scenario.n_agents, instants, len(scenario.topology.links))
    if available is None:
        available = available_memory()
    if available is not None and needed > available:
        raise ResourceLimitError(
            f"the sensor noise and packet losses of this run ({instants:,} control instants) would need "
            f"~{_fmt_bytes(needed)} of memory but only {_fmt_bytes(available)} is available: raise "
            f"simulation.control_period (now {sim.control_period:g} s) or shorten t_final"
        )
    return needed


# ----------------------------------------------------------------------------- results


@dataclass
class SimulationResult:
    """Time series and statistics of one run.

    Arrays (``T`` output samples, ``n`` agents): ``time`` (T,) s; ``sigma``,
    ``sigma_e`` (T, n, 3) MRP; ``omega``, ``omega_e`` (T, n, 3) rad/s (the error of the true attitude and rate,
    not of the measurements, in the kinematics of the scenario's ``controller.error_model``); ``broadcast`` (T, n, n_b): what each agent sends (for the paper's law the sliding
    variable, also available as ``s``); ``z`` (T, n, n_z): the law's own states;
    ``u``, ``u_unsaturated`` (T, n, 3) N m (applied and commanded; with reaction wheels ``u`` is their reaction
    torque on the body); ``sigma_d`` (T, 3).  With reaction wheels: ``wheel_speed`` (T, n, N) rad/s relative to the
    hub and ``wheel_torque`` (T, n, N) N m (motor torque after the speed limit); with sensors:
    ``sigma_measured``, ``omega_measured`` (T, n, 3), what the law saw at the last control instant (the other
    arrays are the truth).  Absent hardware gives ``None``.

    Made by :func:`simulate`; the derived quantities (:attr:`theta_e`, :attr:`aaem_deg`, :attr:`raem_deg`,
    :meth:`summary`) are computed on access, the conversions write files (:meth:`save`) or build an
    :class:`xarray.Dataset` (:meth:`to_dataset`) or a python-control response (:meth:`to_time_response`).

    Parameters
    ----------
    scenario : Scenario
        The scenario that was flown.
    time : numpy.ndarray, shape (T,)
        Output times, s (``time[-1]`` is ``t_final``, or the stop time of a run a monitor stopped).
    sigma, omega : numpy.ndarray, shape (T, n, 3)
        Attitude (MRP, shadow set) and body rate (rad/s) of each agent.
    sigma_e, omega_e : numpy.ndarray, shape (T, n, 3)
        Attitude error (MRP) and rate error (rad/s), eqs 5-8, of the true attitude and rate (not of what the
        sensors measured), in the error kinematics of the scenario's ``controller.error_model``:
        ``omega_e = omega - omega_d`` (``"paper"``, eq 8 as printed) or ``omega - C(sigma_e) omega_d``
        (``"exact"``), the error state the flown law variant is built on.
    broadcast : numpy.ndarray, shape (T, n, n_b)
        What each agent broadcasts (``s`` for the paper's law).
    z : numpy.ndarray, shape (T, n, n_z)
        The law's own states.
    u, u_unsaturated : numpy.ndarray, shape (T, n, 3)
        Applied and commanded torques, N m.
    sigma_d : numpy.ndarray, shape (T, 3)
        Reference attitude (MRP).
    saturated_time : numpy.ndarray, shape (n,)
        Time with at least one torque component saturated, s.
    u_total_variation : numpy.ndarray, shape (n,)
        Sum over the steps of ``|u(t_k) - u(t_k-1)|_1``, N m.
    u_unsaturated_max : numpy.ndarray, shape (n,)
        Largest commanded torque component, N m.
    backend : str
        ``"compiled"`` (the generated C, compiled on first use) or ``"casadi-vm"`` (the fallback without a C
        compiler or with ``FSMCTL_NO_COMPILE=1``: the serialized CasADi functions).
    wall_time : float
        Seconds the run took.
    steps_taken, steps_rejected : int
        Integrator steps (dopri45 rejects some).
    wheel_speed, wheel_torque : numpy.ndarray or None, shape (T, n, N)
        Reaction-wheel speeds (rad/s, relative to the hub) and motor torques (N m); None without wheels.
    sigma_measured, omega_measured : numpy.ndarray or None, shape (T, n, 3)
        What the law saw through the sensors; None without sensors.
    stopped_at : float or None
        The stop time when a monitor stopped the run early; None when it completed.

    Examples
    --------
    >>> import fsmctl
    >>> r = fsmctl.simulate(fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.2}))
    >>> r.sigma.shape, float(r.time[-1])
    ((21, 6, 3), 0.2)
    >>> round(float(r.aaem_deg[0]), 3), round(float(r.raem_deg[0]), 3)
    (134.427, 114.1)
    >>> r.backend  # "casadi-vm" on a machine without a C compiler
    'compiled'
    """

    scenario: Scenario
    time: np.ndarray
    sigma: np.ndarray
    omega: np.ndarray
    sigma_e: np.ndarray
    omega_e: np.ndarray
    broadcast: np.ndarray
    z: np.ndarray
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
    wheel_speed: np.ndarray | None = None
    wheel_torque: np.ndarray | None = None
    sigma_measured: np.ndarray | None = None
    omega_measured: np.ndarray | None = None
    stopped_at: float | None = None
    """s: the time of the last sample when a monitor stopped the run early (``time[-1]``); None: the run completed"""
    _cache: dict = field(default_factory=dict, repr=False, init=False)

    @property
    def wheel_momentum(self) -> np.ndarray | None:
        """(T, n, N) N m s: each wheel's spin momentum relative to the hub, ``J_s Omega`` (None without wheels)."""
        if self.wheel_speed is None:
            return None
        return self.wheel_speed * self.scenario.actuator.per_wheel("spin_inertia")

    @property
    def wheel_momentum_norm(self) -> np.ndarray | None:
        """(T, n) N m s: magnitude of the wheel array's momentum vector ``|sum_k J_s,k Omega_k g_k|`` (body frame)."""
        h = self.wheel_momentum
        if h is None:
            return None
        return np.linalg.norm(h @ self.scenario.actuator.spin_axes().T, axis=-1)

    @property
    def n_agents(self) -> int:
        """Number of agents ``n``."""
        return self.sigma.shape[1]

    @property
    def law(self):
        """The :class:`~fsmctl.model.laws.LawCode` that was flown."""
        return self.scenario.law

    @property
    def s(self) -> np.ndarray:
        """(T, n, 3) 1/s: the sliding variable of a sliding-mode law (its broadcast, when the law calls it ``s``)."""
        if self.law.broadcast_name != "s":
            raise AttributeError(
                f"the law {self.law.name!r} broadcasts {self.law.broadcast_name!r}, not a sliding variable s"
            )
        return self.broadcast

    @property
    def theta_e(self) -> np.ndarray:
        """(T, n) rad: principal angle of each agent's attitude error."""
        if "theta_e" not in self._cache:
            self._cache["theta_e"] = principal_angles(self.sigma_e)
        return self._cache["theta_e"]

    @property
    def theta_relative(self) -> np.ndarray:
        """(T, n, n) rad: principal angle between agents i and j at every output sample.

        Costly: ``T n^2`` doubles (200 agents over 100 s at 0.01 s: 3.2 GB, twice that while it is
        computed; :func:`fsmctl.simulation.metrics.relative_angles_bytes`), so it is computed on each access (cached
        only below 64 MiB), refused with :class:`~fsmctl.errors.ResourceLimitError` when it would not fit
        in the available memory, and used by nothing else here: :attr:`raem_deg` streams, and
        :meth:`relative_angles_at` (one sample) and :meth:`pair_angles` (one pair) are cheap.
        """
        if "theta_ij" in self._cache:
            return self._cache["theta_ij"]
        T, n = self.sigma_e.shape[:2]
        needed = relative_angles_bytes(T, n)
        available = available_memory()
        if available is not None and needed > available:
            raise ResourceLimitError(
                f"theta_relative ({T:,} samples x {n} x {n} agents) would need ~{_fmt_bytes(needed)} of memory "
                f"but only {_fmt_bytes(available)} is available: use relative_angles_at(k), pair_angles(i, j) "
                "or raem_deg (streamed)"
            )
        theta = relative_principal_angles(self.sigma_e)
        if theta.nbytes <= RAEM_WORKING_BYTES:
            self._cache["theta_ij"] = theta
        return theta

    def relative_angles_at(self, k: int) -> np.ndarray:
        """(n, n) rad: the relative principal angles of every pair of agents at output sample ``k``.

        Parameters
        ----------
        k : int
            Output sample index.

        Returns
        -------
        numpy.ndarray
            ``theta_ij`` at ``time[k]`` (the theta_ij of eq 43).
        """
        return relative_angles_at(self.sigma_e[k])

    def pair_angles(self, i: int, j: int) -> np.ndarray:
        """(T,) rad: the relative principal angle of agents ``i`` and ``j`` (0-based) over time.

        Parameters
        ----------
        i, j : int
            Agent indices, 0-based.

        Returns
        -------
        numpy.ndarray
            ``theta_ij(t)`` at every output sample.
        """
        return pair_angles(self.sigma_e, i, j)

    @property
    def aaem_deg(self) -> np.ndarray:
        """Absolute attitude error metric, eq 42 (deg)."""
        return aaem_deg(self.theta_e)

    @property
    def raem_deg(self) -> np.ndarray:
        """Relative attitude error metric, eq 43 (deg); streamed over blocks of samples (O(n^2) memory), cached."""
        if "raem_deg" not in self._cache:
            self._cache["raem_deg"] = streamed_raem_deg(self.sigma_e)
        return self._cache["raem_deg"]

    @property
    def chattering_index(self) -> np.ndarray:
        """(n,) N m/s: total variation of the applied torque per second of simulated time."""
        span = float(self.time[-1] - self.time[0]) or 1.0
        return self.u_total_variation / span

    def summary(self, tolerances_deg=(1.0, 0.1, 0.05, 0.03, 0.01), steady_window: float = 40.0) -> dict:
        """Settling times of AAEM/RAEM per tolerance, steady-state accuracy, torque statistics.

        Parameters
        ----------
        tolerances_deg : sequence of float
            Settling bands of AAEM and RAEM (eqs 42-43), deg.
        steady_window : float
            Length of the final window of the steady-state maxima, s.

        Returns
        -------
        dict
            JSON-ready values (see the keys), times in s, angles in deg, torques in N m.
        """
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
            **(
                {
                    "wheel_speed_peak_rad_per_s": float(np.abs(self.wheel_speed).max()),
                    "wheel_momentum_peak_N_m_s": float(self.wheel_momentum_norm.max()),
                    "wheel_momentum_final_N_m_s": self.wheel_momentum_norm[-1].tolist(),
                }
                if self.wheel_speed is not None
                else {}
            ),
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
                f"broadcast_{self.law.broadcast_name}": var(
                    self.broadcast,
                    ("time_s", "agent", "broadcast_component"),
                    self.law.broadcast_unit,
                    f"what each agent broadcasts to its neighbours ({self.law.broadcast_name}, law {self.law.name})",
                ),
                **(
                    {"law_state": var(self.z, ("time_s", "agent", "law_state"), "1", f"states of law {self.law.name}")}
                    if self.z.shape[-1]
                    else {}  # NetCDF 3 has no zero-length fixed dimension
                ),
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
                **self._hardware_variables(var),
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
                "law": self.law.name,
                "law_source": self.law.source,
                "law_states": ", ".join(self.law.state_labels()),
            }
        )
        return ds

    def _hardware_variables(self, var) -> dict:
        out = {}
        if self.wheel_speed is not None:
            tnw = ("time_s", "agent", "wheel")
            out["wheel_speed_rad_per_s"] = var(self.wheel_speed, tnw, "rad/s", "wheel speed relative to the hub")
            out["wheel_torque_N_m"] = var(self.wheel_torque, tnw, "N m", "wheel motor torque (after the speed limit)")
            out["wheel_momentum_norm_N_m_s"] = var(
                self.wheel_momentum_norm, ("time_s", "agent"), "N m s", "|wheel array momentum| (body frame)"
            )
        if self.sigma_measured is not None:
            tna = ("time_s", "agent", "axis")
            out["sigma_measured"] = var(self.sigma_measured, tna, "1", "attitude the law saw (star tracker)")
            out["omega_measured_rad_per_s"] = var(self.omega_measured, tna, "rad/s", "rate the law saw (gyro)")
        return out

    def save(
        self,
        path: str | Path,
        *,
        format: str | None = None,
        precision: str = "float64",
        command=None,
    ) -> Path:
        """Write the run to a NetCDF (``.nc``) or CSV (``.csv``) file with its provenance, atomically.

        The file embeds the scenario, the law and the versions (:func:`fsmctl.simulation.results_io.provenance`);
        :func:`fsmctl.simulation.results_io.load_result` reads it back and
        :func:`fsmctl.simulation.results_io.scenario_from_result` re-runs it.  ``.npz`` writes the dataset's
        arrays with NumPy (no provenance).

        Parameters
        ----------
        path : str or Path
            Target file.
        format : {None, "netcdf", "csv"}
            None: from the suffix.
        precision : {"float64", "float32"}
            Storage of the time series (time stays float64).
        command : sequence of str or str, optional
            The command line, recorded in the file.

        Returns
        -------
        Path
            ``path``.

        Examples
        --------
        >>> import fsmctl
        >>> r = fsmctl.simulate(fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.1}))
        >>> r.save("run.csv").name
        'run.csv'
        >>> open("run.csv").readline()[:40]
        'time_s,sigma_1_x,sigma_1_y,sigma_1_z,sig'
        """
        from fsmctl.outputs import atomic_path
        from fsmctl.simulation.results_io import save_result

        path = Path(path)
        if format is None and path.suffix == ".npz":
            with atomic_path(path) as tmp:
                ds = self.to_dataset()
                with open(tmp, "wb") as fh:  # a file object: np.savez would append ".npz" to the temporary name
                    np.savez_compressed(fh, **{k: v.values for k, v in ds.variables.items()})
            return path
        return save_result(self, path, format=format, precision=precision, command=command)

    def to_time_response(self, *, errors: bool = True):
        """The run as a python-control time response: the formation's states and outputs, the errors and metrics.

        States and the first ``9 n`` outputs are those of :func:`fsmctl.formation` (the python-control plug-in),
        named alike: states ``reference_q_d[0..3]``, ``sc<i>_q[0..3]``, ``sc<i>_omega[0..2]``; outputs
        ``sc<i>_sigma[k]``, ``sc<i>_omega[k]`` (rad/s), ``sc<i>_tau[k]`` (N m).  With ``errors`` the outputs go on
        with the error signals and the metrics: ``sc<i>_sigma_e[k]`` (the MRP attitude error sigma_ei, eqs 5-6),
        ``sc<i>_theta_e_deg`` (its principal angle theta_ei, deg), ``aaem_deg`` and ``raem_deg`` (the absolute and
        relative attitude error metrics, Liang et al. 2012, eqs 42-43, deg).

        Parameters
        ----------
        errors : bool
            Append the error signals and metrics (``4 n + 2`` outputs) to the plug-in's ``9 n``.

        Returns
        -------
        control.TimeResponseData
            A :class:`fsmctl.model.time_response.FormationResponse` where that class exists (its ``plot()`` groups
            the signals: one axes per signal, one colour per agent), else a plain
            :class:`control.TimeResponseData`; no inputs.

        Examples
        --------
        >>> import fsmctl
        >>> r = fsmctl.simulate(fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.1}))
        >>> tr = r.to_time_response()
        >>> tr.outputs.shape, tr.output_labels[-3:]
        ((80, 11), ['sc6_theta_e_deg', 'aaem_deg', 'raem_deg'])
        >>> round(float(tr.outputs[tr.output_labels.index("aaem_deg"), 0]), 3)
        134.427
        >>> r.to_time_response(errors=False).outputs.shape
        (54, 11)
        """
        import control as ct

        try:
            from fsmctl.model.time_response import FormationResponse as response_class
        except ImportError:
            response_class = ct.TimeResponseData
        n = self.n_agents
        T = self.time.size
        from fsmctl.model.attitude import quaternion_from_mrp

        x = np.concatenate(
            [quaternion_from_mrp(self.sigma_d).T]
            + [np.concatenate([quaternion_from_mrp(self.sigma[:, i]).T, self.omega[:, i].T]) for i in range(n)]
        )
        y = np.concatenate([np.concatenate([self.sigma[:, i].T, self.omega[:, i].T, self.u[:, i].T]) for i in range(n)])
        state_labels = [f"reference_q_d[{k}]" for k in range(4)] + [
            f"sc{i + 1}_{v}[{k}]" for i in range(n) for v, m in (("q", 4), ("omega", 3)) for k in range(m)
        ]
        output_labels = [f"sc{i + 1}_{v}[{k}]" for i in range(n) for v in ("sigma", "omega", "tau") for k in range(3)]
        if errors:
            y = np.concatenate(
                [
                    y,
                    self.sigma_e.transpose(1, 2, 0).reshape(3 * n, T),
                    np.degrees(self.theta_e).T,
                    self.aaem_deg[None, :],
                    self.raem_deg[None, :],
                ]
            )
            output_labels += [f"sc{i + 1}_sigma_e[{k}]" for i in range(n) for k in range(3)]
            output_labels += [f"sc{i + 1}_theta_e_deg" for i in range(n)] + ["aaem_deg", "raem_deg"]
        return response_class(
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
    act = scenario.actuator
    if p.integrator == 1 and act.enabled and (np.isfinite(act.per_wheel("max_speed")).any() or act.coulomb_band == 0):
        warnings.warn(
            "adaptive integration with a wheel speed limit or sgn Coulomb friction (coulomb_band = 0): a wheel at "
            "its limit switches its torque on and off, which collapses the step size; use integrator='rk4'",
            DiscontinuousControlWarning,
            stacklevel=3,
        )
    d = p.law.discontinuity  # declared by the law (LawBuilder.discontinuous)
    if p.integrator == 1 and d is not None and d.discontinuous(p.params):
        smoothing = f" ({d.smoothed_by} = 0)" if d.smoothed_by is not None else ""
        remedy = f" or {d.smoothed_by} > 0" if d.smoothed_by is not None else ""
        warnings.warn(
            f"adaptive integration of the law {p.law.name}, discontinuous at {d.where}{smoothing}: the step size "
            f"will collapse near the switching surface; use integrator='rk4'{remedy}",
            DiscontinuousControlWarning,
            stacklevel=3,
        )


def _check_output_grid(p: PackedProblem) -> None:
    """The output grid must end on the final state (the loop records every ``output_every`` steps)."""
    if p.n_steps % p.output_every:
        raise SimulationError(
            f"the output grid misses the final state: outputs every {p.output_every} steps "
            f"({p.output_every * p.dt:g} s) do not divide the run's {p.n_steps} steps ({p.n_steps * p.dt:g} s), "
            f"so the last {p.n_steps % p.output_every} steps would not be recorded; make output_interval divide t_final"
        )


def _check_final_sample(time: np.ndarray, t_final: float, backend: str) -> None:
    """Raise :class:`SimulationError` unless the last output sample is at ``t_final`` (to rounding)."""
    tol = 1e-9 * max(1.0, abs(t_final))
    last = float(time[-1]) if time.size else float("nan")
    if not abs(last - t_final) <= tol:
        raise SimulationError(
            f"simulation failed: the {backend} run's last output sample is at t = {last:.12g} s, not at "
            f"t_final = {t_final:.12g} s ({time.size} samples written); the final state would be lost"
        )


def _singularity_fix_none(p: PackedProblem) -> bool:
    """Whether a law on the paper's surface runs without the Remark 6 device (for the hint of a non-finite command):
    its declaration (``LawBuilder.paper_theorems``) names the parameter that selects the device."""
    theorems = p.law.paper_theorems
    if theorems is None or theorems.parameters.get("singularity_fix") is None:
        return False
    fix = p.law.parameter(theorems.parameters["singularity_fix"])
    k = sum(q.size for q in p.law.parameters[: p.law.parameters.index(fix)])
    return bool(np.any(p.params[:, k] == fix.choices.index("none")))


def _monitor_grid(p: PackedProblem, interval: float | None) -> tuple[int, int]:
    """``(outputs between monitor calls, callback period in steps)`` for a monitor every ``interval`` seconds.

    The interval is rounded to a whole number (>= 1) of output intervals (default: a tenth of the run, at least one
    output interval).  RK4: the callback period is the largest divisor of the monitor period in steps that is at
    most :func:`_callback_every`, so that every monitor instant is a callback instant right after its record;
    dopri45: every accepted step (its outputs fall between steps of varying length).
    """
    out_dt = p.output_every * p.dt
    if interval is None:
        interval = max(out_dt, 0.1 * p.n_steps * p.dt)
    if not (isinstance(interval, (int, float)) and math.isfinite(interval) and interval > 0):
        raise ValueError(f"monitor_interval must be a positive number of seconds, got {interval!r}")
    k_out = max(1, round(interval / out_dt))
    if p.integrator == 1:
        return k_out, 1
    m_steps, base = k_out * p.output_every, _callback_every(p)
    every = next(d for d in range(min(base, m_steps), 0, -1) if m_steps % d == 0)
    return k_out, every


def _fly(
    p: PackedProblem,
    *,
    progress: bool,
    label: str,
    kernels: str,
    monitor=None,
    monitor_interval=None,
    members: int = 1,
) -> dict:
    """One call of the compiled loop: the raw arrays, or ``raw["rc"] != 0`` with ``fail_time``/``fail_agent``.

    ``monitor(t, partial)`` (optional) is called from the progress callback at the output samples every
    ``monitor_interval`` s (:func:`_monitor_grid`) before ``t_final``; ``partial()`` returns the raw arrays so far
    (the output rows are views, the statistics copies).  When it returns True the loop stops there and
    ``raw["stopped_at"]`` is that sample's time.  Exceptions (from the monitor or the progress bar) and a deferred
    SIGINT are raised here once C has returned.  ``members > 1`` (a stack of that many runs,
    :func:`fsmctl.model.problem.stack`): the per-agent output arrays are member-major, ``(members, rows, n /
    members, ...)``, so that each run's outputs are contiguous (:func:`_split`).
    """
    dll = _driver(p.law)
    hw = p.hardware
    n, cap = p.n_agents, p.n_outputs + 1
    lead = (cap, n) if members <= 1 else (members, cap, n // members)
    bufs = {k: np.zeros((*lead, 3)) for k in ("sigma", "omega", "sigma_e", "omega_e", "u", "u_unsat")}
    bufs["broadcast"] = np.zeros((*lead, p.n_broadcast))
    bufs["z"] = np.zeros((*lead, p.n_states))
    if hw.n_wheels:
        bufs["wheel_speed"] = np.zeros((*lead, hw.n_wheels))
        bufs["wheel_torque"] = np.zeros((*lead, hw.n_wheels))
    if hw.sensors:
        bufs["sigma_measured"] = np.zeros((*lead, 3))
        bufs["omega_measured"] = np.zeros((*lead, 3))
    bufs["t"] = np.zeros(cap)
    bufs["sigma_d"] = np.zeros((cap, 3))
    stats = {k: np.zeros(n) for k in ("saturated_time", "u_total_variation", "u_unsat_max")}
    out = _Output(capacity=cap, **{k: _ptr(v) for k, v in {**bufs, **stats}.items()})
    cp = _CProblem(p, kernels=kernels, members=members)
    x0 = np.ascontiguousarray(p.x0, dtype=float)
    if kernels == "auto":
        kernels = "batched" if dll.fsm_batched_preferred() else "scalar"
    t_end = p.t0 + p.n_steps * p.dt
    started = 0.0  # set when the loop starts

    def raw_now(w: int, stats_copy: bool) -> dict:
        raw = {k: v[:w] if v.ndim < 3 or members <= 1 else v[:, :w] for k, v in bufs.items()}
        raw.update({k: v.copy() if stats_copy else v for k, v in stats.items()})
        raw.update(
            wall_time=_time.perf_counter() - started,
            backend="compiled",
            kernels=kernels,
            steps_taken=int(out.steps_taken),
            steps_rejected=int(out.steps_rejected),
            stopped_at=None,
            rc=0,
        )
        return raw

    every = _callback_every(p)
    watch = None
    if monitor is not None:
        k_out, every = _monitor_grid(p, monitor_interval)
        watch = {"next": k_out, "seen": 1, "stopped_at": None}
        eps = 1e-9 * max(1.0, abs(t_end))

        def watch_cb(done: int) -> int:
            w = int(out.written)
            current = w > watch["seen"] if p.integrator == 1 else done % p.output_every == 0
            watch["seen"] = w
            j = w - 1
            if not current or j < watch["next"] or not bufs["t"][j] < t_end - eps:
                return 0
            watch["next"] = (j // k_out + 1) * k_out
            t = float(bufs["t"][j])
            if monitor(t, lambda: raw_now(w, True)):
                watch["stopped_at"] = t
                return 1
            return 0

    guard = _DeferredSignals()
    started = _time.perf_counter()
    with guard:
        cb, state = _progress_callback(p.n_steps, progress, label, guard, watch_cb if watch else None)
        try:
            rc = dll.fsm_simulate(ctypes.byref(cp.struct), _ptr(x0), ctypes.byref(out), cb, every)
        finally:
            if state["bar"] is not None:
                state["bar"].close()
    guard.deliver()  # a SIGINT or SIGTERM during the loop: its handler runs now (KeyboardInterrupt by default)
    if state["error"] is not None:
        raise state["error"]
    if rc == 2 and state["interrupted"]:
        raise KeyboardInterrupt
    raw = raw_now(int(out.written), False)
    raw["wall_time"] = _time.perf_counter() - started
    if rc == 2 and watch is not None and watch["stopped_at"] is not None:
        raw["stopped_at"] = watch["stopped_at"]
        return raw
    raw.update(rc=int(rc), fail_time=float(out.fail_time), fail_agent=int(out.fail_agent))
    return raw


def _failure_message(p: PackedProblem, raw: dict) -> str:
    rc = raw["rc"]
    detail = _RC.get(rc, f"error code {rc}")
    if rc in (1, 7):
        who = "the reference" if raw["fail_agent"] == -1 else f"agent {raw['fail_agent'] + 1}"
        detail += f" at t = {raw['fail_time']:.6g} s in {who}"
        detail += (
            " (the Remark 6 term alpha|sigma_e|^(alpha-1) is singular with singularity_fix = 'none'; use 'switch')"
            if _singularity_fix_none(p)
            else " (check inertias, gains and the step size)"
        )
    elif rc == 5:
        d = p.law.discontinuity
        why = (
            "a discontinuous right-hand side (a wheel at its speed limit, Coulomb friction)? use rk4"
            if d is None
            else f"discontinuous at {d.where}? use rk4" + ("" if d.smoothed_by is None else f" or {d.smoothed_by} > 0")
        )
        detail += f" at t = {raw['fail_time']:.6g} s ({why})"
    return f"simulation failed: {detail}"


def simulate_packed(
    p: PackedProblem,
    *,
    progress: bool = False,
    label: str = "simulate",
    kernels: str = "auto",
    monitor=None,
    monitor_interval: float | None = None,
) -> dict:
    """Run a packed problem on the compiled driver (or the CasADi fallback); returns raw arrays.

    ``kernels`` (compiled driver only): ``"batched"`` evaluates the per-agent functions through the
    lane-batched kernels of ``generated/c/batched.c`` (4 agents per call, SIMD); ``"scalar"`` calls
    the CasADi-generated scalar functions agent by agent; ``"auto"`` (default) is ``"batched"`` when the
    library was built with AVX (see :func:`batched_kernels_preferred`), else ``"scalar"``.  The results are
    bit-identical (up to the sign of a zero from ``fmin``/``fmax`` of ``+0`` and ``-0``).

    ``monitor(t, partial)`` (compiled driver only; ignored with a warning by the CasADi fallback) is called at the
    output samples every ``monitor_interval`` seconds before ``t_final`` (rounded to whole output intervals;
    default a tenth of the run) with ``partial()`` returning the raw arrays up to ``t``; a True return stops the
    run there: the returned arrays and statistics then cover ``[t0, t]`` exactly (a prefix of the complete run,
    bit for bit) and ``raw["stopped_at"]`` is ``t`` (None for a completed run).

    Before anything is allocated: the output grid must end on the final state (else
    :class:`SimulationError`) and the results must fit in memory (:func:`check_output_memory`, else
    :class:`~fsmctl.errors.ResourceLimitError`), on both backends.  After the run the last sample is checked
    to be at ``t0 + n_steps dt``.  SIGINT during the compiled loop stops it and raises
    :class:`KeyboardInterrupt` here (see :class:`_DeferredSignals`; SIGTERM: its handler, ``fsmctl``'s exits 143).
    """
    if kernels not in _KERNELS:
        raise ValueError(f"kernels must be one of {sorted(_KERNELS)}, got {kernels!r}")
    _check_output_grid(p)
    check_output_memory(p)
    t_end = p.t0 + p.n_steps * p.dt
    dll = _driver(p.law)
    hw = p.hardware
    if dll is None:
        if hw.n_wheels or hw.sensors or hw.links_imperfect:
            raise EnvironmentProblem(
                "reaction wheels, sensors and imperfect links run in the compiled simulator only, which is not "
                "available (no C compiler was found, or compiling failed: see the warning; install gcc or clang, or "
                "set CC)"
            )
        from fsmctl.simulation.casadi_formation import simulate_casadi

        if monitor is not None:
            warnings.warn(
                "the CasADi fallback (no C compiler) cannot monitor a run: it runs to t_final",
                RuntimeWarning,
                stacklevel=2,
            )
        raw = simulate_casadi(p, progress=progress, label=label)
        _check_final_sample(raw["t"], t_end, "casadi-vm")
        raw["stopped_at"] = None
        return raw
    if kernels == "batched" and not dll.fsm_batched_available():
        raise SimulationError(
            "kernels='batched': this build of the library has no batched kernels (the C compiler lacks the "
            "GCC/Clang vector extension); use kernels='auto' or 'scalar'"
        )
    raw = _fly(p, progress=progress, label=label, kernels=kernels, monitor=monitor, monitor_interval=monitor_interval)
    if raw["rc"] != 0:
        raise SimulationError(_failure_message(p, raw))
    if raw["stopped_at"] is None:
        _check_final_sample(raw["t"], t_end, "compiled")
    for k in ("rc", "fail_time", "fail_agent"):
        raw.pop(k, None)
    return raw


# ----------------------------------------------------------------------------- step size

MAX_ROTATION_PER_STEP = 0.1
"""rad: largest rotation per RK4 step ``max|omega| dt`` without :class:`StepSizeWarning`."""
MAX_STEP_RATE = 0.5
"""Largest ``dt * rho`` (``rho``: bound on the loop's fastest rate, 1/s) without :class:`StepSizeWarning`."""


def step_size_report(scenario: Scenario | PackedProblem) -> dict:
    """Bounds on the fastest rates of a scenario's closed loop and what they mean for the RK4 step ``dt``.

    Rates (1/s), each from the (packed) scenario alone, no run; over agents the worst value is taken:

    * ``surface`` and ``layer``: the law's own rates, as it declares them
      (:meth:`fsmctl.symbolic.law.LawBuilder.loop_rates`, evaluated per agent): for the paper's law
      ``surface = c1 + c2 r1``, the sliding surface (eq 13) on which ``sigma_e`` decays at
      ``c1 + c2 d sig(x)^alpha/dx`` with the slope's largest value in the Remark 6 band (``r1 = (2 - alpha)
      epsilon^(alpha-1)`` for ``switch``, the ``c2 r1`` of the paper scenario's [choices] 'step' text), and
      ``layer = max delta_k / phi`` inside the boundary layer ``sat(s/phi)`` (Remark 7; 0 for ``sgn``)
      (:func:`fsmctl.symbolic.fsm_parameters.fsm_loop_rates`).  A law that declares none gets ``surface``
      from its linearisation at the initial state (finite differences of the generated law, ``a + sqrt(b)``
      for ``omega_dot = J0^-1 u`` with ``a = ||J0^-1 du/domega||``, ``b = ||J0^-1 du/dsigma|| / 4``; an
      estimate) and ``layer = 0``.
    * ``coordination = max_i (sum_j k^i_ij + sum_j max_t |k^j_ij(t)|)``: Gershgorin's bound on the
      eigenvalues of the coupling ``k_sum_i s_i - sum_j k^j_ij s_j`` (eq 19) over the receiving agents.
    * ``gain = max_i ||(J0_i + delta_J_i)^-1 J0_i||_2``: the controller computes torques with ``J0``, the plant
      divides by ``J = J0 + delta_J``, so every closed-loop rate is scaled by up to this factor (the
      conditioning of ``J0`` against ``J0 + delta_J``; 1/1.3 in the paper's Case 1).  With
      ``s = sigma_e_dot + a sigma_e`` the linearised loop per axis is
      ``sigma_e_ddot = -g((a + b + k) sigma_e_dot + (b + k) a sigma_e)``, whose roots
      have modulus at most ``max(g, sqrt(g)) (a + b + k)``: ``loop = max(gain, sqrt(gain)) (surface + layer
      + coordination)`` (0 with the controller disabled).
    * ``gyroscopic = max_i sqrt(sum_k ||A_ik||^2) omega_max``: the Jacobian of Euler's
      ``-J^-1 (omega x J omega)`` is ``sum_k omega_k A_k`` with ``A_k = J^-1 ((J e_k)^x - e_k^x J)``, of norm at
      most ``|omega| sqrt(sum_k ||A_k||^2)`` (Cauchy-Schwarz).  For a rigid body (``|J2 - J3| <= J1``, the
      triangle inequality) this is about ``|omega|``; an unphysical or ill-conditioned inertia makes it
      large (``(J2 - J3)/J1 omega`` of Euler's equations).  ``omega_max`` is the largest initial body rate
      ``|omega_i(0)|`` or the reference's rate bound ``|omega_d|`` (amplitude + offset).

    * ``wheel_friction = max_ik (c_v,k + c_c,k / b) m_ik`` (reaction wheels): a wheel's spin relative to the hub
      obeys ``J_s Omega_dot = u_motor - c_v Omega - c_c sat(Omega / b) - J_s g^T omega_dot``
      (:func:`fsmctl.symbolic.hardware.wheel_motor_torque`, Schaub & Junkins eq 4.146), and with the hub's reaction
      ``omega_dot = -(J - J_spin)^-1 g u_net`` a friction torque ``f`` changes ``Omega`` at ``f m`` per second, with
      ``m_ik = 1/J_s,k + g_k^T (J_i - J_spin,i)^-1 g_k``.  Inside the stiction band ``|Omega| < b`` the friction
      ``(c_v + c_c / b) Omega`` is a decay at this rate, so ``dt * wheel_friction`` is judged like ``dt rho``
      (:data:`MAX_STEP_RATE`): one step changes the speed by ``c_c m dt``, which must stay below half the band ``b``,
      the wheel's speed scale of the friction (beyond it RK4 turns the decay into a growing oscillation: a wheel
      whose friction creates energy).  With ``b = 0`` (``sgn``) the band is 0 and the friction of a wheel near rest
      is never resolved by a fixed step: its speed jumps by ``2 c_c m dt`` at every crossing of 0
      (``wheel_chatter``, rad/s; reported, not judged: sgn friction has no speed scale of its own; a band
      ``b >= c_c m dt / MAX_STEP_RATE`` resolves it).

    ``rho = loop + gyroscopic`` bounds the spectral radius of the linearised right-hand side (a sum of
    the parts' norms).  RK4 is stable for ``dt rho < 2.78`` on the negative real axis and accurate to
    ``(dt rho)^5 / 120`` per step; ``dt rho <= 0.5`` (:data:`MAX_STEP_RATE`, ``dt`` at most half the fastest
    time constant ``1/rho``) keeps that below 3e-4.  ``rotation = omega_max dt`` must stay below
    :data:`MAX_ROTATION_PER_STEP` (0.1 rad): the kinematics ``sigma_dot = G(sigma) omega`` are integrated
    through the MRP shadow switch, and a step that turns the body by a sizeable angle loses accuracy however
    slow the loop is.  The paper scenario (dt = 1 ms, Case 1): ``rho ~ 78 1/s``, ``dt rho ~ 0.08``, rotation 7e-4 rad.

    Parameters
    ----------
    scenario : Scenario or PackedProblem
        The scenario (or its packed form, :func:`fsmctl.model.problem.pack`).

    Returns
    -------
    dict
        These rates (1/s), ``rho``, ``omega_max`` (rad/s), ``rotation_per_step`` (rad), ``dt`` and the list
        ``problems`` (empty when the step is fine; only the fixed-step RK4 integrator is judged: dopri45
        controls its own steps).

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.simulation import step_size_report
    >>> report = step_size_report(fsmctl.paper_scenario("1"))
    >>> round(report["rho"], 1), round(report["dt"] * report["rho"], 3), report["problems"]
    (77.5, 0.078, [])
    """
    p = pack(scenario) if isinstance(scenario, Scenario) else scenario
    n = p.n_agents
    J, J0 = np.asarray(p.J_true, dtype=float), np.asarray(p.J0, dtype=float)
    declared = p.law.loop_rates(p.params)  # the law's own bounds (LawBuilder.loop_rates), the worst agent
    if declared is not None:
        surface, layer = declared
    else:  # a law that declares none: its linearisation at the initial state, by finite differences (an estimate)
        surface, layer = _law_rate_estimate(p), 0.0
    k_in = np.zeros(n)
    for e in range(p.n_links):
        start, count = int(p.sched_start[e]), int(p.sched_count[e])
        k_in[int(p.link_receiver[e])] += abs(float(p.link_k_i[e])) + float(
            np.max(np.abs(p.sched_values[start : start + count]))
        )
    coordination = float(k_in.max()) if n else 0.0
    gain = max(float(np.linalg.norm(np.linalg.solve(J[i], J0[i]), 2)) for i in range(n))
    enabled = bool(np.any(p.u_max > 0))  # a disabled controller is packed with a zero torque limit
    loop = max(gain, math.sqrt(gain)) * (surface + layer + coordination) if enabled else 0.0
    omega0 = p.x0[3:].reshape(n, p.stride)[:, 3:6]
    ref = np.asarray(p.ref_params, dtype=float)
    omega_max = max(
        float(np.max(np.linalg.norm(omega0, axis=1))), float(np.linalg.norm(np.abs(ref[0:3]) + np.abs(ref[9:12])))
    )
    gyroscopic = _gyroscopic_gain(J) * omega_max
    rho = loop + gyroscopic
    dt = p.dt
    friction, chatter, m_worst, coulomb, viscous, band, spin = _wheel_friction_rate(p, J)
    problems = []
    if p.integrator == 0:  # rk4
        if dt * rho > MAX_STEP_RATE:
            parts = ", ".join(
                f"{name} {value:.3g}"
                for name, value in (
                    ("law surface", surface),
                    ("law layer", layer),
                    ("coordination", coordination),
                    ("inertia gain ||J^-1 J0||", gain),
                    ("gyroscopic", gyroscopic),
                )
            )
            problems.append(
                f"dt = {dt:g} s is coarse for the loop's fastest rate rho ~ {rho:.3g} 1/s (dt rho = {dt * rho:.3g} > "
                f"{MAX_STEP_RATE:g}; {parts}): use dt <= {MAX_STEP_RATE / rho:.2g} s"
            )
        if omega_max * dt > MAX_ROTATION_PER_STEP:
            problems.append(
                f"dt = {dt:g} s turns a body by up to {omega_max * dt:.3g} rad per step (|omega| <= {omega_max:.3g} "
                f"rad/s; bound {MAX_ROTATION_PER_STEP:g} rad): use dt <= {MAX_ROTATION_PER_STEP / omega_max:.2g} s"
            )
        if dt * friction > MAX_STEP_RATE:
            problems.append(
                f"dt = {dt:g} s cannot resolve the reaction wheels' friction: it changes a wheel's speed at up to "
                f"{friction:.3g} 1/s inside the stiction band (coulomb_friction {coulomb:.3g} N m over coulomb_band "
                f"{band:g} rad/s, viscous_friction {viscous:.3g} N m s, spin inertia {spin:.3g} kg m^2; dt rate = "
                f"{dt * friction:.3g} > {MAX_STEP_RATE:g}), and the wheel would gain energy from it: use dt <= "
                f"{MAX_STEP_RATE / friction:.2g} s or a wider coulomb_band (>= {coulomb * m_worst * dt / MAX_STEP_RATE:.2g} "
                "rad/s)"
            )
    return {
        "dt": dt,
        "surface": surface,
        "layer": layer,
        "coordination": coordination,
        "gain": gain,
        "loop": loop,
        "gyroscopic": gyroscopic,
        "rho": rho,
        "omega_max": omega_max,
        "rotation_per_step": omega_max * dt,
        "wheel_friction": friction,
        "wheel_chatter": chatter,
        "problems": problems,
    }


def _wheel_friction_rate(p: PackedProblem, J: np.ndarray) -> tuple[float, float, float, float, float, float, float]:
    """``(rate, chatter, m, coulomb, viscous, band, J_s)`` of the worst wheel (see :func:`step_size_report`): the
    friction's decay rate inside the stiction band (1/s), the speed jump ``2 c_c m dt`` of sgn friction (rad/s, only
    for ``b = 0``), and that wheel's ``m = 1/J_s + g^T (J - J_spin)^-1 g`` and friction settings; zeros without
    wheels."""
    hw = p.hardware
    worst = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    for i in range(hw.n_wheels and p.n_agents):
        hub = np.linalg.inv(J[i] - hw.J_spin[i])
        for k in range(hw.n_wheels):
            g, Js = hw.wheel_axes[i, k], float(hw.wheel_Js[i, k])
            _, viscous, coulomb, band = (float(x) for x in hw.wheel_params[i, k])
            m = 1.0 / Js + float(g @ hub @ g)
            rate = (viscous + (coulomb / band if band > 0 else 0.0)) * m
            chatter = 2.0 * coulomb * m * p.dt if band == 0 else 0.0
            if (rate, chatter) > worst[:2]:
                worst = (rate, chatter, m, coulomb, viscous, band, Js)
    return worst


def _law_rate_estimate(p: PackedProblem, h: float = 1e-6) -> float:
    """A law's loop rate at the initial state (1/s): ``a + sqrt(b)`` for the linearised ``omega_dot = J0^-1 u`` with
    ``a = ||J0^-1 du/domega||``, ``b = ||J0^-1 du/dsigma|| / 4`` (``G(0) = I/4``), the worst agent; finite
    differences of the generated law with no neighbours (an estimate, for laws without a closed form here; an agent
    where they are not finite is left out, :func:`_check_law_at_start` refuses a law not finite there)."""
    worst = 0.0
    for i in range(p.n_agents):
        xi = p.x0[p.agent_slice(i)]
        outputs = _law_outputs(p, i)
        base = outputs(xi)["torque"]
        jac = np.zeros((3, 6))
        for c in range(6):
            dx = np.zeros_like(xi)
            dx[c] = h
            jac[:, c] = (outputs(xi + dx)["torque"] - base) / h
        if not np.all(np.isfinite(jac)):
            continue
        Jinv = np.linalg.inv(p.J0[i])
        a = float(np.linalg.norm(Jinv @ jac[:, 3:6], 2))
        b = float(np.linalg.norm(Jinv @ jac[:, 0:3], 2)) / 4.0
        worst = max(worst, a + math.sqrt(b))
    return worst


def _law_outputs(p: PackedProblem, i: int):
    """``x -> {name: value}``: agent ``i``'s law at its state ``x`` (attitude, rate, law state) at ``t = 0``, alone
    (no neighbours, no torque limit): its ``constants``, ``broadcast``, ``torque`` and ``law state derivative``."""
    from fsmctl.model.generated_code import casadi_function

    model = "exact" if p.error_model == 1 else "paper"
    local, control = p.law.casadi(f"law_local_{model}"), p.law.casadi(f"law_control_{model}")
    _, wd, wdd = (
        np.asarray(v, dtype=float).ravel() for v in casadi_function("reference_rhs")(0.0, p.x0[:3], p.ref_params)
    )
    k = np.asarray(p.law.casadi("law_constants")(p.params[i]), dtype=float).ravel()

    def outputs(x: np.ndarray) -> dict[str, np.ndarray]:
        args = [0.0, x[0:3], x[3:6], x[6 : 6 + p.n_states], p.x0[:3], wd, wdd, p.J0[i], p.params[i], k]
        broadcast, cache = local(*args)
        _, u, z_dot = control(*args, cache, 0.0, np.zeros(p.n_broadcast), 0.0, np.inf)
        flat = {"broadcast": broadcast, "torque": u, "law state derivative": z_dot}
        return {"constants": k, **{name: np.asarray(v, dtype=float).ravel() for name, v in flat.items()}}

    return outputs


def _check_law_at_start(p: PackedProblem) -> None:
    """Refuse a law that is not finite at an agent's initial state (NaN or inf): it would fly NaN."""
    from fsmctl.model.laws import LawError

    for i in range(p.n_agents):
        for name, value in _law_outputs(p, i)(p.x0[p.agent_slice(i)]).items():
            if not np.all(np.isfinite(value)):
                shown = ", ".join(f"{v:g}" for v in value)
                raise LawError(
                    f"law {p.law.name!r}: its {name} is not finite at the initial state of agent {i + 1} "
                    f"([{shown}]): the law is undefined there (a division by zero, or a root or log of a negative "
                    "number?); fix the law or the initial state"
                )


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _gyroscopic_gain(J: np.ndarray) -> float:
    """``max_i sqrt(sum_k ||A_ik||_2^2)`` with ``A_ik = J_i^-1 ((J_i e_k)^x - e_k^x J_i)``: the Jacobian of Euler's
    ``-J^-1 (omega x J omega)`` is ``sum_k omega_k A_k``, whose norm is at most this times ``|omega|``."""
    worst = 0.0
    for Ji in J:
        Jinv = np.linalg.inv(Ji)
        parts = [Jinv @ (_skew(Ji[:, k]) - _skew(np.eye(3)[k]) @ Ji) for k in range(3)]
        worst = max(worst, math.sqrt(sum(float(np.linalg.norm(A, 2)) ** 2 for A in parts)))
    return worst


def _warn_step_size(scenario: Scenario, p: PackedProblem) -> None:
    for problem in step_size_report(p)["problems"]:
        warnings.warn(f"{scenario.label}: {problem}", StepSizeWarning, stacklevel=3)


def _warn_rotation_reached(scenario: Scenario, omega: np.ndarray) -> None:
    """After an RK4 run: the rotation per step actually reached (largest |omega| of the output samples)."""
    if scenario.simulation.integrator != "rk4" or omega.size == 0:
        return
    dt = scenario.simulation.dt
    peak = 0.0
    for start in range(0, omega.shape[0], 4096):  # blocks: no (T, n) temporary
        block = omega[start : start + 4096]
        peak = max(peak, float(np.sqrt(np.max(np.einsum("...k,...k->...", block, block)))))
    if not math.isfinite(peak) or peak * dt > MAX_ROTATION_PER_STEP:
        warnings.warn(
            f"{scenario.label}: a body reached |omega| = {peak:.4g} rad/s, {peak * dt:.3g} rad per step of "
            f"dt = {dt:g} s (bound {MAX_ROTATION_PER_STEP:g} rad): the results are not resolved in time; "
            f"use dt <= {MAX_ROTATION_PER_STEP / peak if peak > 0 else dt:.2g} s or check the inertias and gains",
            StepSizeWarning,
            stacklevel=3,
        )


def _result(scenario: Scenario, raw: dict) -> SimulationResult:
    """A :class:`SimulationResult` of the raw arrays of :func:`simulate_packed` (no copy)."""
    return SimulationResult(
        scenario=scenario,
        time=raw["t"],
        sigma=raw["sigma"],
        omega=raw["omega"],
        sigma_e=raw["sigma_e"],
        omega_e=raw["omega_e"],
        broadcast=raw["broadcast"],
        z=raw["z"],
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
        **{k: raw.get(k) for k in ("wheel_speed", "wheel_torque", "sigma_measured", "omega_measured")},
        stopped_at=raw.get("stopped_at"),
    )


def _prepare(scenario: Scenario) -> PackedProblem:
    """The checks before a run (noise memory, integrator, step size) and the packed problem."""
    check_noise_memory(scenario)
    p = pack(scenario)
    _check_integrator(p, scenario)
    _check_law_at_start(p)
    _warn_step_size(scenario, p)
    return p


def _finish(scenario: Scenario, raw: dict) -> SimulationResult:
    """The checks after a run (final sample unless stopped, rotation per step) and its result."""
    if raw.get("stopped_at") is None:
        _check_final_sample(raw["t"], scenario.simulation.t_final, raw["backend"])
    _warn_rotation_reached(scenario, raw["omega"])
    return _result(scenario, raw)


def simulate(
    scenario: Scenario,
    *,
    progress: bool | None = None,
    monitor=None,
    monitor_interval: float | None = None,
) -> SimulationResult:
    """Simulate ``scenario`` with the generated code; see :class:`SimulationResult`.

    Parameters
    ----------
    scenario : Scenario
        The formation, law and run settings.
    progress : bool, optional
        Show a progress bar (default: for runs of more than 10^6 agent-steps on a terminal).
    monitor : callable, optional
        ``monitor(t, partial) -> bool``, called every ``monitor_interval`` simulated seconds at an output sample
        ``t < t_final``, while the compiled loop runs; ``partial()`` returns ``[SimulationResult]`` (a list of one,
        as :func:`simulate_many` passes one result per scenario of a batch) truncated at ``t``.  Returning True
        stops the run at ``t``: the result then holds the samples up to ``t`` (the prefix of the complete run,
        bit for bit, with the run statistics up to ``t``) and ``stopped_at == t``.  Without a C compiler (the
        CasADi fallback) the monitor is not called and the run completes (a warning says so).
    monitor_interval : float, optional
        Seconds of simulated time between monitor calls, rounded to a whole number (>= 1) of output intervals
        (default: a tenth of ``t_final``).

    Returns
    -------
    SimulationResult
        ``stopped_at`` is None for a completed run.

    Warns (:class:`StepSizeWarning`) before the run when the RK4 step is too coarse
    (:func:`step_size_report`) and after it when the rotation per step actually reached exceeds
    :data:`MAX_ROTATION_PER_STEP`.  Raises :class:`~fsmctl.errors.ResourceLimitError` when the results would
    not fit in memory, :class:`SimulationError` when the run fails or its last sample is not at ``t_final``,
    and :class:`KeyboardInterrupt` on Ctrl-C.

    Examples
    --------
    >>> import fsmctl
    >>> s = fsmctl.paper_scenario("1").replace(simulation={"t_final": 2.0})
    >>> r = fsmctl.simulate(s)
    >>> float(r.time[-1]), r.stopped_at
    (2.0, None)

    Stop as soon as the absolute error metric is below 20 degrees, looking every 0.5 s:

    >>> early = fsmctl.simulate(s, monitor=lambda t, partial: partial()[0].aaem_deg[-1] < 20.0, monitor_interval=0.5)
    >>> early.stopped_at is None or early.stopped_at == float(early.time[-1])
    True
    """
    p = _prepare(scenario)
    if progress is None:
        progress = p.n_steps * p.n_agents > 1_000_000 and sys.stderr.isatty()
    raw_monitor = None
    if monitor is not None:

        def raw_monitor(t, partial_raw):
            return bool(monitor(t, lambda: [_result(scenario, partial_raw())]))

    raw = simulate_packed(
        p, progress=progress, label=scenario.label, monitor=raw_monitor, monitor_interval=monitor_interval
    )
    return _finish(scenario, raw)


BATCH_AGENTS = 64
"""Default size of a batch of :func:`simulate_many`: runs are stacked up to this many agents in all (10 runs of the
paper's 6 agents); the time per run levels off from ~8 runs of Case 1 (``benchmarks/run.py``, throughput section)."""

_PER_AGENT_KEYS = (
    "sigma", "omega", "sigma_e", "omega_e", "u", "u_unsat", "broadcast", "z",
    "saturated_time", "u_total_variation", "u_unsat_max",
)  # fmt: skip


def _split(raw: dict, n: int, count: int) -> list[dict]:
    """The raw arrays of ``count`` runs of ``n`` agents flown together (member-major, :func:`_fly` with ``members =
    count``) as one raw dict per run: contiguous views of the batch's buffers, as a run alone returns them."""
    out = []
    for m in range(count):
        raw_m = {k: v for k, v in raw.items() if k not in _PER_AGENT_KEYS}
        raw_m["t"], raw_m["sigma_d"] = raw["t"].copy(), raw["sigma_d"].copy()
        for k in _PER_AGENT_KEYS:
            v = raw[k]
            raw_m[k] = v[m * n : (m + 1) * n] if v.ndim == 1 else v[m]
        raw_m["wall_time"] = raw["wall_time"] / count
        out.append(raw_m)
    return out


def _fly_batch(scenarios: list[Scenario], problems: list[PackedProblem], monitor, monitor_interval) -> list:
    """Fly runs as one stacked problem (one run: alone, on either backend); a run that fails is flown alone (for
    its own error) and the others again without it; a batch whose results would not fit in memory is halved.
    Returns one raw dict (or :class:`SimulationError`) per run."""
    from fsmctl.model.problem import stack

    count = len(problems)
    if count == 1:
        raw_monitor = None
        if monitor is not None:

            def raw_monitor(t, partial_raw):
                return bool(monitor(t, lambda: [_result(scenarios[0], partial_raw())]))

        try:
            return [
                simulate_packed(
                    problems[0], label=scenarios[0].label, monitor=raw_monitor, monitor_interval=monitor_interval
                )
            ]
        except SimulationError as exc:
            return [exc]
    n = problems[0].n_agents
    st = stack(problems)
    _check_output_grid(st)
    try:
        check_output_memory(st)  # the whole batch's buffers
    except ResourceLimitError:
        half = count // 2
        return _fly_batch(scenarios[:half], problems[:half], monitor, monitor_interval) + _fly_batch(
            scenarios[half:], problems[half:], monitor, monitor_interval
        )
    raw_monitor = None
    if monitor is not None:

        def raw_monitor(t, partial_raw):
            def partial():
                return [_result(sc, r) for sc, r in zip(scenarios, _split(partial_raw(), n, count), strict=True)]

            return bool(monitor(t, partial))

    raw = _fly(
        st,
        progress=False,
        label="simulate_many",
        kernels="auto",
        monitor=raw_monitor,
        monitor_interval=monitor_interval,
        members=count,
    )
    if raw["rc"] == 0:
        return _split(raw, n, count)
    # a failed run stopped the batch: fly it alone (its own error message), the others again without it
    bad = raw["fail_agent"] // n if raw["rc"] in (1, 7) and raw["fail_agent"] >= 0 else None
    if bad is None:  # not one run's failure (the shared reference, the step budget): every run alone
        return [
            out
            for k in range(count)
            for out in _fly_batch(scenarios[k : k + 1], problems[k : k + 1], monitor, monitor_interval)
        ]
    keep = [k for k in range(count) if k != bad]
    out = _fly_batch([scenarios[k] for k in keep], [problems[k] for k in keep], monitor, monitor_interval)
    out.insert(bad, _fly_batch([scenarios[bad]], [problems[bad]], monitor, monitor_interval)[0])
    return out


def simulate_many(
    scenarios,
    *,
    monitor=None,
    monitor_interval: float | None = None,
    errors: str = "raise",
    batch_size: int | None = None,
) -> list:
    """Simulate several scenarios, flying compatible ones together; the results in the order given.

    Runs that share the formation's structure (law, error model, agents per run, fixed-step RK4 with the same
    step, horizon, output grid and control period, and the same reference: :func:`fsmctl.model.problem.batch_key`)
    are flown in batches, each batch as one block-diagonal formation in one call of the compiled loop
    (:func:`fsmctl.model.problem.stack`): the SIMD lanes hold agents of several runs, the reference and the per-step
    bookkeeping are shared, and each run's results are those of :func:`simulate` alone, bit for bit (arrays, run
    statistics, summaries; ``wall_time`` is the batch's divided among its runs).  Runs with flight hardware
    (wheels, sensors, imperfect links), with dopri45, or without a C compiler fly one by one.

    Parameters
    ----------
    scenarios : iterable of Scenario
        The runs.
    monitor : callable, optional
        ``monitor(t, partial) -> bool`` as for :func:`simulate`, called during each flight with ``partial()``
        returning one truncated :class:`SimulationResult` per scenario of that flight (a batch, or one scenario
        flying alone), in the order given; True stops the whole flight (all its scenarios) at ``t``.  A batch in
        which a run fails is flown again without it (the monitor then sees the smaller batch from the start).
    monitor_interval : float, optional
        Seconds of simulated time between monitor calls (see :func:`simulate`).
    errors : {"raise", "return"}
        ``"raise"``: a :class:`SimulationError` propagates (after the batch it belongs to has flown);
        ``"return"``: it takes the failed scenario's place in the list and the others still run.
    batch_size : int, optional
        Most runs per batch (default: as many as fit in :data:`BATCH_AGENTS` agents; a group of compatible runs is
        split into batches of nearly equal sizes); 1 flies every run alone.

    Returns
    -------
    list of SimulationResult or SimulationError
        One entry per scenario, in order.

    Raises
    ------
    ValueError
        If ``errors`` is not ``"raise"`` or ``"return"``, or ``batch_size`` is not an integer >= 1.
    SimulationError
        With ``errors="raise"``, the first failed run's error (after its batch has flown).
    InputError
        For a scenario the engine cannot fly (the same checks as :func:`simulate`).

    Examples
    --------
    >>> import fsmctl
    >>> base = fsmctl.paper_scenario("1").replace(simulation={"t_final": 1.0})
    >>> runs = [base.replace(controller={"c1": c1}) for c1 in (0.4, 0.6, 0.8)]
    >>> results = fsmctl.simulate_many(runs)
    >>> [float(r.time[-1]) for r in results]
    [1.0, 1.0, 1.0]
    >>> bool((results[1].sigma == fsmctl.simulate(runs[1]).sigma).all())
    True
    """
    from fsmctl.model.problem import batch_key

    if errors not in ("raise", "return"):
        raise ValueError(f"errors must be 'raise' or 'return', got {errors!r}")
    if batch_size is not None and not (isinstance(batch_size, int) and batch_size >= 1):
        raise ValueError(f"batch_size must be an integer >= 1, got {batch_size!r}")
    scenarios = list(scenarios)
    problems = [_prepare(s) for s in scenarios]
    groups: dict = {}
    for k, p in enumerate(problems):
        key = batch_key(p) if _driver(p.law) is not None else None  # the CasADi fallback flies runs one by one
        if key is None and p.hardware.n_samples:
            problems[k] = None  # its noise tables are drawn again when it flies (same seed, same draws)
        groups.setdefault(("alone", k) if key is None else key, []).append(k)
    results: list = [None] * len(scenarios)
    for members in groups.values():
        n = problems[members[0]].n_agents
        most = batch_size or max(1, BATCH_AGENTS // n)
        count = -(-len(members) // most)  # batches, of nearly equal sizes
        for b in range(count):
            batch = members[b * len(members) // count : (b + 1) * len(members) // count]
            packed = [pack(scenarios[k]) if problems[k] is None else problems[k] for k in batch]
            raws = _fly_batch([scenarios[k] for k in batch], packed, monitor, monitor_interval)
            for k, out in zip(batch, raws, strict=True):
                try:
                    if isinstance(out, SimulationError):
                        raise out
                    results[k] = _finish(scenarios[k], out)
                except SimulationError as exc:
                    if errors == "raise":
                        raise
                    results[k] = exc
    return results
