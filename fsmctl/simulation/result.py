"""The result of one run: :class:`SimulationResult` (time series, metrics, conversions to files and to
python-control).

Made by :func:`fsmctl.simulation.simulator.simulate`; written and read by :mod:`fsmctl.simulation.results_io`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fsmctl.errors import ResourceLimitError
from fsmctl.model.generated_code import manifest
from fsmctl.model.scenario import Scenario
from fsmctl.outputs import atomic_path
from fsmctl.policy import SETTLING_TOLERANCES_DEG, TOLERANCE_DEG, default_steady_window
from fsmctl.simulation.memory import available_memory, format_bytes
from fsmctl.simulation.metrics import (
    RAEM_WORKING_BYTES,
    aaem_deg,
    converged,
    pair_angles,
    principal_angles,
    relative_angles_at,
    relative_angles_bytes,
    relative_principal_angles,
    settling_time,
    steady_state_max,
    streamed_raem_deg,
)
from fsmctl.simulation.results_io import save_result

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
    messages_sent : numpy.ndarray or None, shape (n,), int
        Messages each agent sent (:mod:`fsmctl.simulation.messages`): an event-triggered law's as its trigger fired,
        periodic broadcasting's one per control instant (so the two compare); None for continuous control
        (``simulation.control_period = 0``).
    messages_per_link : numpy.ndarray or None, shape (L,), int
        Messages each link (``scenario.topology.links`` order) delivered to its receiver (sent, arrived, not lost).
    events_per_output : numpy.ndarray or None, shape (T, n), int
        Messages each agent sent in ``(time[r-1], time[r]]`` (row 0: at ``time[0]``): the event rate over time.
    min_inter_event_s, mean_inter_event_s : numpy.ndarray or None, shape (n,)
        Shortest and mean time between consecutive messages of each agent, s (inf / NaN with fewer than two).

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
    messages_sent: np.ndarray | None = None
    """(n,) int: messages each agent sent; None for continuous control (:mod:`fsmctl.simulation.messages`)"""
    messages_per_link: np.ndarray | None = None
    """(L,) int: messages each link delivered to its receiver"""
    events_per_output: np.ndarray | None = None
    """(T, n) int: messages each agent sent since the previous output sample"""
    min_inter_event_s: np.ndarray | None = None
    """(n,) s: shortest time between consecutive messages of each agent (inf: fewer than two)"""
    mean_inter_event_s: np.ndarray | None = None
    """(n,) s: mean time between consecutive messages of each agent (NaN: fewer than two)"""
    _cache: dict = field(default_factory=dict, repr=False, init=False)

    @property
    def event_triggered(self) -> bool:
        """Whether the law flown declares a trigger (its agents send only when it fires; else at every control
        instant).

        Examples
        --------
        >>> import fsmctl
        >>> s = fsmctl.paper_scenario("1").replace(
        ...     controller={"law": "fsm_event"}, simulation={"t_final": 2.0, "control_period": 0.1}
        ... )
        >>> r = fsmctl.simulate(s)
        >>> r.event_triggered, int(r.messages_sent.sum()) < 6 * 21  # fewer than one per agent and control instant
        (True, True)
        """
        return self.law.trigger is not None

    def messages_line(self) -> str | None:
        """One line on the messages of the run (``fsmctl simulate`` prints it); None for continuous control.

        Examples
        --------
        >>> import fsmctl
        >>> r = fsmctl.simulate(fsmctl.paper_scenario("1").replace(simulation={"t_final": 1.0, "control_period": 0.1}))
        >>> print(r.messages_line())
        messages: 66 sent (periodic broadcasting, one per agent and control instant; 11 per agent), 330 delivered on 30 links; inter-event time min 0.1 s, mean 0.1 s
        """
        if self.messages_sent is None:
            return None
        sent, links = self.messages_sent, self.messages_per_link
        how = (
            f"event-triggered, {sent.min()}-{sent.max()} per agent"
            if self.event_triggered
            else f"periodic broadcasting, one per agent and control instant; {sent.max()} per agent"
        )
        finite = self.min_inter_event_s[np.isfinite(self.min_inter_event_s)]
        mean = self.mean_inter_event_s[np.isfinite(self.mean_inter_event_s)]
        gaps = (
            f"; inter-event time min {finite.min():.3g} s, mean {mean.mean():.3g} s"
            if finite.size and mean.size
            else ""
        )
        return f"messages: {int(sent.sum())} sent ({how}), {int(links.sum())} delivered on {links.size} links{gaps}"

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
                f"theta_relative ({T:,} samples x {n} x {n} agents) would need ~{format_bytes(needed)} of memory "
                f"but only {format_bytes(available)} is available: use relative_angles_at(k), pair_angles(i, j) "
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

    def summary(self, tolerances_deg=SETTLING_TOLERANCES_DEG, steady_window: float | None = None) -> dict:
        """Settling times of AAEM/RAEM per tolerance, final values, convergence, steady-state accuracy, torques.

        Parameters
        ----------
        tolerances_deg : sequence of float
            Settling bands of AAEM and RAEM (eqs 42-43), deg (default
            :data:`fsmctl.policy.SETTLING_TOLERANCES_DEG`).
        steady_window : float, optional
            Length of the final window of the steady-state maxima, s (default
            :func:`fsmctl.policy.default_steady_window` of the run's span: the last 40 % of it, at most 40 s;
            clipped to the span).

        Returns
        -------
        dict
            JSON-ready values (see the keys), times in s, angles in deg, torques in N m; ``converged`` is
            :func:`fsmctl.simulation.metrics.converged` at ``convergence_tolerance_deg``
            (:data:`fsmctl.policy.TOLERANCE_DEG`).

        Examples
        --------
        >>> import fsmctl
        >>> r = fsmctl.simulate(fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.5}))
        >>> s = r.summary()
        >>> s["steady_window_s"], s["horizon_s"], s["converged"]  # 40 % of 0.5 s; far from the reference
        (0.2, 0.5, False)
        """
        t, a, r = self.time, self.aaem_deg, self.raem_deg
        span = float(t[-1] - t[0])
        window = min(default_steady_window(span) if steady_window is None else float(steady_window), span)
        return {
            "scenario": self.scenario.label,
            "backend": self.backend,
            "wall_time_s": self.wall_time,
            "horizon_s": span,
            "converged": converged(t, a, r, TOLERANCE_DEG),
            "convergence_tolerance_deg": TOLERANCE_DEG,
            "aaem_final_deg": float(a[-1]),
            "raem_final_deg": float(r[-1]),
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
            **(
                {
                    "event_triggered": self.event_triggered,
                    "messages_sent": int(self.messages_sent.sum()),
                    "messages_sent_per_agent": self.messages_sent.tolist(),
                    "messages_delivered": int(self.messages_per_link.sum()),
                    "min_inter_event_s": float(self.min_inter_event_s.min()),
                    "messages_line": self.messages_line(),
                }
                if self.messages_sent is not None
                else {}
            ),
        }

    @property
    def saturated(self) -> np.ndarray:
        """(T, n) bool: the agent's actuator saturated at each output time, by the rule that adds to
        :attr:`saturated_time` (``fsmctl/csrc/formation.c``, ``accumulate``).

        Saturated: a commanded torque component beyond ``controller.torque_limit``; with reaction wheels also a
        wheel at its torque limit (the distribution of the clipped command, :func:`fsmctl.model.distribute`,
        scales the wheel torques down) or at its speed limit (``|Omega| >= max_speed`` while commanded further).

        Examples
        --------
        >>> import fsmctl
        >>> r = fsmctl.simulate(fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.2}))
        >>> r.saturated.shape, bool(r.saturated[0].all())
        ((21, 6), True)
        """
        if "saturated" in self._cache:
            return self._cache["saturated"]
        from fsmctl.model.actuators import distribute, distribution_matrix

        limit = self.scenario.controller.effective_torque_limit
        flags = np.any(np.abs(self.u_unsaturated) > limit, axis=2)
        act = self.scenario.actuator
        if act.enabled and self.wheel_speed is not None:
            pinv = distribution_matrix(act.spin_axes())
            max_torque, max_speed = act.per_wheel("max_torque"), act.per_wheel("max_speed")
            command = np.clip(self.u_unsaturated, -limit, limit)  # the law's applied torque (its saturation)
            for k, i in np.ndindex(*flags.shape):
                if flags[k, i]:
                    continue
                u_w, scale = distribute(command[k, i], pinv, max_torque)
                speed = self.wheel_speed[k, i]
                flags[k, i] = scale > 1.0 or bool(np.any((np.abs(speed) >= max_speed) & (u_w * speed > 0)))
        self._cache["saturated"] = flags
        return flags

    def last_saturation_time(self) -> float:
        """Last output time at which some agent's actuator was saturated (:attr:`saturated`; NaN if never)."""
        hit = np.nonzero(self.saturated.any(axis=1))[0]
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
                **self._message_variables(var),
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
                "law_source": self.law.script(portable=True),
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

    def _message_variables(self, var) -> dict:
        """The message counts (:mod:`fsmctl.simulation.messages`) as variables: int32 (NetCDF-3 has no int64), the
        per-link counts only when there are links (NetCDF-3 has no zero-length fixed dimension)."""
        if self.messages_sent is None:
            return {}
        out = {
            "messages_sent": var(self.messages_sent.astype(np.int32), ("agent",), "1", "messages each agent sent"),
            "events_per_output": var(
                self.events_per_output.astype(np.int32),
                ("time_s", "agent"),
                "1",
                "messages each agent sent since the previous output sample",
            ),
            "min_inter_event_s": var(self.min_inter_event_s, ("agent",), "s", "shortest time between messages"),
            "mean_inter_event_s": var(self.mean_inter_event_s, ("agent",), "s", "mean time between messages"),
        }
        if self.messages_per_link.size:
            out["messages_per_link"] = var(
                self.messages_per_link.astype(np.int32),
                ("link",),
                "1",
                "messages each link delivered to its receiver (topology.links order)",
            )
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
        >>> import pandas
        >>> list(pandas.read_csv("run.csv", comment="#").columns[:4])  # the metadata first, as # lines
        ['time_s', 'sigma_1_x', 'sigma_1_y', 'sigma_1_z']
        """
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
