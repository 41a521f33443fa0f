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
import math
import sys
import time as _time
import warnings

import numpy as np

from fsmctl.errors import EnvironmentProblem, ResourceLimitError
from fsmctl.model.problem import PackedProblem, output_buffer_bytes, pack
from fsmctl.model.scenario import Scenario
from fsmctl.policy import BATCH_AGENTS, ZENO_CONSECUTIVE_CHECKS
from fsmctl.simulation.driver import (
    _KERNELS,
    _RC,
    ExternalController,
    _CProblem,
    _driver,
    _Output,
    _ptr,
    batched_kernels_preferred,
)
from fsmctl.simulation.failures import (
    DiscontinuousControlWarning,
    SimulationError,
    StepSizeWarning,
    ZenoError,
    nonfinite_hint,
)
from fsmctl.simulation.memory import available_memory, format_bytes
from fsmctl.simulation.messages import MESSAGE_FIELDS, event_buffers, event_pointers, messages_now, result_messages
from fsmctl.simulation.metrics import (
    RAEM_WORKING_BYTES,
)
from fsmctl.simulation.progress import _callback_every, _DeferredSignals, _progress_callback
from fsmctl.simulation.result import SimulationResult
from fsmctl.simulation.step_size import (
    MAX_ROTATION_PER_STEP,
    MAX_STEP_RATE,
    _check_law_at_start,
    _warn_rotation_reached,
    _warn_step_size,
    step_size_report,
)

__all__ = [
    "SimulationError",
    "ZenoError",
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


# ----------------------------------------------------------------------------- memory


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
    buffers = p.output_bytes
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
            f"this run's results would need ~{format_bytes(needed)} of memory ({p.n_agents} agents x "
            f"{p.n_outputs:,} output samples) but only {format_bytes(available)} is available: raise "
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
            f"~{format_bytes(needed)} of memory but only {format_bytes(available)} is available: raise "
            f"simulation.control_period (now {sim.control_period:g} s) or shorten t_final"
        )
    return needed


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
    controller: ExternalController | None = None,
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
    events = event_buffers(p, lead)  # event-triggered communication: the counts the loop writes
    out = _Output(capacity=cap, **{k: _ptr(v) for k, v in {**bufs, **stats}.items()}, **event_pointers(events))
    cp = _CProblem(p, kernels=kernels, members=members, controller=controller)
    x0 = np.ascontiguousarray(p.x0, dtype=float)
    if kernels == "auto":
        kernels = "batched" if dll.fsm_batched_preferred() and controller is None else "scalar"
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
        raw.update(messages_now(p, events, w))
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


def _zeno_message(p: PackedProblem, raw: dict) -> str:
    """The one line of the Zeno guard (:data:`fsmctl.policy.ZENO_CONSECUTIVE_CHECKS`): agent, time, inter-event time,
    what to change."""

    check = p.trigger_every * p.hold_steps * p.dt
    return (
        f"simulation failed: Zeno guard: agent {raw['fail_agent'] + 1} of law {p.law.name} sent at each of "
        f"{ZENO_CONSECUTIVE_CHECKS} consecutive trigger checks up to t = {raw['fail_time']:.6g} s (inter-event time "
        f"{check:g} s, the check period: the trigger holds no message back); raise the trigger's threshold (e.g. a "
        "floor c0 > 0), check it less often (LawBuilder.trigger(period=...)), or fly a law without a trigger"
    )


def _failure_message(p: PackedProblem, raw: dict) -> str:
    rc = raw["rc"]
    detail = _RC.get(rc, f"error code {rc}")
    if rc == 8:
        return _zeno_message(p, raw)
    if rc in (1, 7):
        who = "the reference" if raw["fail_agent"] == -1 else f"agent {raw['fail_agent'] + 1}"
        detail += f" at t = {raw['fail_time']:.6g} s in {who}"
        detail += nonfinite_hint(p)
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
    controller: ExternalController | None = None,
) -> dict:
    """Run a packed problem on the compiled driver (or the CasADi fallback); returns raw arrays.

    ``kernels`` (compiled driver only): ``"batched"`` evaluates the per-agent functions through the
    lane-batched kernels of ``generated/c/batched.c`` (4 agents per call, 8 with AVX-512: :func:`~fsmctl.simulation.driver.lane_width`; SIMD); ``"scalar"`` calls
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
    if controller is not None and (dll is None or p.hold_steps <= 0):
        raise SimulationError(
            "a controller in the loop runs in the compiled simulator at the control instants: it needs a C compiler "
            "and simulation.control_period > 0"
        )
    if dll is None:
        if p.trigger_every:
            raise EnvironmentProblem(
                f"the law {p.law.name} is event-triggered, which runs in the compiled simulator only, which is not "
                "available (no C compiler was found, or compiling failed: see the warning; install gcc or clang, or "
                "set CC)"
            )
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
    raw = _fly(
        p,
        progress=progress,
        label=label,
        kernels=kernels,
        monitor=monitor,
        monitor_interval=monitor_interval,
        controller=controller,
    )
    if raw["rc"] == 8:
        raise ZenoError(_failure_message(p, raw))
    if raw["rc"] != 0:
        raise SimulationError(_failure_message(p, raw))
    if raw["stopped_at"] is None:
        _check_final_sample(raw["t"], t_end, "compiled")
    for k in ("rc", "fail_time", "fail_agent"):
        raw.pop(k, None)
    return raw


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
        **result_messages(scenario, raw),
    )


def _prepare(scenario: Scenario, wheel_commands=None) -> PackedProblem:
    """The checks before a run (noise memory, integrator, step size) and the packed problem."""
    check_noise_memory(scenario)
    p = pack(scenario, wheel_commands=wheel_commands)
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
    wheel_commands=None,
    controller_in_the_loop: ExternalController | None = None,
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
    wheel_commands : callable or numpy.ndarray, optional
        Open-loop motor torques of the reaction wheels (N m; positive spins a wheel up along its axis):
        ``f(t) -> (n_agents, n_wheels)``, called at each control instant ``t = q * control_period`` and held until
        the next, or the array ``(Q, n_agents, n_wheels)`` of those samples.  Added to what the wheels get from the
        law's body torque before the torque limit (``actuator.allocation``); the scenario must fly reaction wheels
        with ``simulation.control_period > 0`` and have no ``actuator.wheel_commands`` table.
    controller_in_the_loop : ExternalController, optional
        A controller in C evaluated at the control instants instead of the law's generated functions (software in
        the loop; :func:`fsmctl.export.verify_export` builds one from an exported library).  Needs the compiled
        simulator and ``simulation.control_period > 0``.

    Returns
    -------
    SimulationResult
        The run; ``stopped_at`` is None for a completed run.

    Raises
    ------
    ~fsmctl.errors.ResourceLimitError
        When the results would not fit in memory.
    SimulationError
        When the run fails or its last sample is not at ``t_final``.
    KeyboardInterrupt
        On Ctrl-C.

    Warns
    -----
    StepSizeWarning
        Before the run when the RK4 step is too coarse (:func:`step_size_report`), and after it when the rotation
        per step actually reached exceeds :data:`MAX_ROTATION_PER_STEP`.

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

    Reaction wheels flying an open-loop command on wheel 1 (the law switched off):

    >>> import numpy as np
    >>> hw = s.replace(
    ...     controller={"enabled": False}, simulation={"control_period": 0.1},
    ...     actuator={"kind": "reaction_wheels", "layout": "pyramid", "spin_inertia": 0.05, "allocation": "clipped"},
    ... )
    >>> r = fsmctl.simulate(hw, wheel_commands=lambda t: np.tile([0.01, 0.0, 0.0, 0.0], (6, 1)))
    >>> r.wheel_torque[0, 0].tolist()
    [0.01, 0.0, 0.0, 0.0]
    """
    p = _prepare(scenario, wheel_commands)
    if progress is None:
        progress = p.n_steps * p.n_agents > 1_000_000 and sys.stderr.isatty()
    raw_monitor = None
    if monitor is not None:

        def raw_monitor(t, partial_raw):
            return bool(monitor(t, lambda: [_result(scenario, partial_raw())]))

    raw = simulate_packed(
        p,
        progress=progress,
        label=scenario.label,
        monitor=raw_monitor,
        monitor_interval=monitor_interval,
        controller=controller_in_the_loop,
    )
    return _finish(scenario, raw)


_PER_AGENT_KEYS = (
    "sigma", "omega", "sigma_e", "omega_e", "u", "u_unsat", "broadcast", "z",
    "saturated_time", "u_total_variation", "u_unsat_max",
)  # fmt: skip


def _split(raw: dict, n: int, count: int) -> list[dict]:
    """The raw arrays of ``count`` runs of ``n`` agents flown together (member-major, :func:`_fly` with ``members =
    count``) as one raw dict per run: contiguous views of the batch's buffers, as a run alone returns them."""
    out = []
    for m in range(count):
        # the message counts of the stack are recomputed per run (_result_messages; runs flown together broadcast
        # periodically over ideal links)
        raw_m = {k: v for k, v in raw.items() if k not in _PER_AGENT_KEYS and k not in MESSAGE_FIELDS}
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
        Most runs per batch (default: as many as fit in :data:`fsmctl.policy.BATCH_AGENTS` agents; a group of compatible runs is
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
