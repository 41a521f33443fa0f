"""Communication topology: constant ``k^i_ij`` and time-varying, directed ``k^j_ij(t)`` (eq 19, Remark 2).

A :class:`Link` ``(i <- j)`` says that agent ``i`` receives ``s_j`` with weight ``k^j_ij(t) = schedule(t + phase)``
and applies ``k^i_ij s_i`` to its own sliding variable.  Schedules are piecewise constant, optionally periodic, like
Table 2 of the paper: ``k(t) = 5 if mod(t, 8) <= 6.5 else 0`` is ``Schedule(breakpoints=(0, 6.5), values=(5, 0),
period=8)``.  Segments are left-closed: the paper's ``mod(t, 8) <= 6.5`` and this ``[0, 6.5)`` differ only at
isolated instants, which no integral (and no trajectory) can see.
"""

from __future__ import annotations

import bisect
import itertools
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from fsmctl.errors import InputError
from fsmctl.suggest import did_you_mean

__all__ = [
    "Link",
    "Schedule",
    "Topology",
    "TopologyError",
    "all_to_all",
    "from_phase_table",
    "k_nearest",
    "ring",
    "schedule_weight",
]


class TopologyError(InputError):
    """A malformed topology table; the message names the entry (an :class:`~fsmctl.errors.InputError`).

    Examples
    --------
    >>> from fsmctl.model import TopologyError, k_nearest
    >>> try:
    ...     k_nearest(3, 3, k_i=8.0, k_j=5.0)
    ... except TopologyError as exc:
    ...     print(exc)
    k-nearest: need 1 <= k < n, got k=3, n=3
    """


def _num(x, where: str) -> float:
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
        raise TopologyError(f"{where}: expected a number, got {x!r}")
    return float(x)


def _is_index(x) -> bool:
    return isinstance(x, (int, np.integer)) and not isinstance(x, (bool, np.bool_))


def schedule_weight(
    breakpoints: Sequence[float], values: Sequence[float], period: float | None, tau: float | np.ndarray
) -> float | np.ndarray:
    """The schedule rule (Liang et al. 2012, eq 19 and Table 2), for ``tau = t + phase``: the one place it is written.

    ``tau`` is reduced to ``[0, period)`` as ``tau - floor(tau/period) period`` (periodic schedules) and the
    segments are left-closed: the value of the last breakpoint ``<= tau`` (the first value before the first
    breakpoint).  The compiled driver (``link_weight`` in ``fsmctl/csrc/formation.c``) applies the same rule.

    Parameters
    ----------
    breakpoints, values : sequence of float
        Increasing segment starts and the weight on each segment.
    period : float or None
        Period of the schedule; None (or ``<= 0``) for an aperiodic one.
    tau : float or numpy.ndarray
        Argument ``t + phase``.  A scalar takes the scalar route (``math``/``bisect``, no NumPy
        overhead, for the per-step callers); an array is evaluated elementwise with the same
        operations (``floor``, a right-sided binary search), so both routes give bit-identical weights.

    Returns
    -------
    float or numpy.ndarray
        The weight(s), shaped like ``tau``.

    Raises
    ------
    ValueError
        If a ``tau`` is not finite (there is no weight at t = inf or NaN).

    Examples
    --------
    Table 2 of the paper, ``k(t) = 5 if mod(t, 8) <= 6.5 else 0``:

    >>> from fsmctl.model import schedule_weight
    >>> schedule_weight((0.0, 6.5), (5.0, 0.0), 8.0, 7.0), schedule_weight((0.0, 6.5), (5.0, 0.0), 8.0, 9.0)
    (0.0, 5.0)
    >>> import numpy as np
    >>> schedule_weight((0.0, 6.5), (5.0, 0.0), 8.0, np.array([0.0, 6.5, 8.0]))
    array([5., 0., 5.])
    """
    periodic = period is not None and period > 0
    if isinstance(tau, np.ndarray):
        if not np.isfinite(tau).all():
            raise ValueError("schedule_weight: the time t + phase must be finite")
        if periodic:
            tau = tau - np.floor(tau / period) * period
        last = np.searchsorted(np.asarray(breakpoints, dtype=float), tau, side="right") - 1
        return np.asarray(values, dtype=float)[np.maximum(last, 0)]
    if not math.isfinite(tau):
        raise ValueError("schedule_weight: the time t + phase must be finite")
    if periodic:
        tau -= math.floor(tau / period) * period
    return float(values[max(0, bisect.bisect_right(breakpoints, tau) - 1)])


@dataclass(frozen=True)
class Schedule:
    """Piecewise-constant link weight ``k^j_ij(t)`` (Liang et al. 2012, eq 19, Table 2): ``values[m]`` on
    ``[breakpoints[m], breakpoints[m+1])``.

    With a ``period``, the argument is reduced modulo the period, breakpoints start at 0 and lie in
    ``[0, period)``.  Without one, ``values[0]`` also holds before ``breakpoints[0]`` and the last value holds forever.

    Parameters
    ----------
    breakpoints : tuple of float
        Strictly increasing segment starts (s).
    values : tuple of float
        The weight on each segment (>= 0), as many as ``breakpoints``.
    period : float or None, optional
        The period (s) of a periodic schedule; None (default) for an aperiodic one.

    Raises
    ------
    TopologyError
        Mismatched lengths, breakpoints not increasing, negative or non-finite weights, a bad period.

    Examples
    --------
    >>> from fsmctl.model import Schedule
    >>> table2 = Schedule(breakpoints=(0.0, 6.5), values=(5.0, 0.0), period=8.0)
    >>> table2.value([0.0, 7.0, 8.5])
    array([5., 0., 5.])
    >>> table2.switching_times(0.0, 20.0)
    array([ 6.5,  8. , 14.5, 16. ])
    """

    breakpoints: tuple[float, ...]
    values: tuple[float, ...]
    period: float | None = None

    def __post_init__(self):
        b, v = self.breakpoints, self.values
        if isinstance(b, (str, bytes)) or isinstance(v, (str, bytes)):
            raise TopologyError("schedule: breakpoints and values must be sequences of numbers")
        for x in (*b, *v, *(() if self.period is None else (self.period,))):
            _num(x, "schedule")
        if len(b) != len(v) or not b:
            raise TopologyError(f"schedule: {len(b)} breakpoints but {len(v)} values (need equal, >= 1)")
        if any(not math.isfinite(x) for x in b) or any(b2 <= b1 for b1, b2 in itertools.pairwise(b)):
            raise TopologyError(f"schedule: breakpoints must be finite and strictly increasing, got {list(b)}")
        if any(not (math.isfinite(x) and x >= 0) for x in v):
            raise TopologyError(f"schedule: weights must be finite and >= 0, got {list(v)}")
        if self.period is not None:
            if not (math.isfinite(self.period) and self.period > 0):
                raise TopologyError(f"schedule: period must be > 0, got {self.period}")
            if b[0] != 0 or b[-1] >= self.period:
                raise TopologyError(
                    f"schedule: periodic breakpoints must start at 0 and stay below the period, got {list(b)}"
                )

    @classmethod
    def constant(cls, value: float) -> Schedule:
        """A schedule that is ``value`` at all times.

        Parameters
        ----------
        value : float
            The constant weight (>= 0).

        Returns
        -------
        Schedule
            ``Schedule((0.0,), (value,))``.

        Examples
        --------
        >>> from fsmctl.model import Schedule
        >>> Schedule.constant(5.0).value(123.0)
        5.0
        """
        return cls((0.0,), (float(value),))

    def value(self, t) -> np.ndarray | float:
        """Weight at time(s) ``t`` (vectorized), by the rule of :func:`schedule_weight`.

        Parameters
        ----------
        t : float or array_like
            Argument(s) (s), already shifted by a link's phase if any.

        Returns
        -------
        float or numpy.ndarray
            A float for a scalar ``t``, else an array shaped like ``t``.
        """
        out = schedule_weight(self.breakpoints, self.values, self.period, np.asarray(t, dtype=float))
        return float(out) if out.ndim == 0 else out

    @property
    def max(self) -> float:
        """The largest weight of the schedule (used by the bounds of Theorem 1)."""
        return max(self.values)

    @property
    def min(self) -> float:
        """The smallest weight of the schedule."""
        return min(self.values)

    def switching_times(self, t0: float, t1: float, phase: float = 0.0) -> np.ndarray:
        """Times in ``(t0, t1)`` where ``value(t + phase)`` may jump.

        Parameters
        ----------
        t0, t1 : float
            The open time interval (s).
        phase : float, optional
            The link's phase shift (s), default 0.

        Returns
        -------
        numpy.ndarray
            Sorted, unique switching times.
        """
        b = np.asarray(self.breakpoints)
        if self.period is None:
            times = b - phase
        else:
            k0 = math.floor((t0 + phase) / self.period) - 1
            k1 = math.ceil((t1 + phase) / self.period) + 1
            times = (np.arange(k0, k1 + 1)[:, None] * self.period + b[None, :]).ravel() - phase
        return np.unique(times[(times > t0) & (times < t1)])

    def with_values(self, values: Sequence[float]) -> Schedule:
        """The same breakpoints and period with other weights.

        Parameters
        ----------
        values : sequence of float
            One weight per segment.

        Returns
        -------
        Schedule
            The new schedule.
        """
        return Schedule(self.breakpoints, tuple(float(v) for v in values), self.period)

    def scaled(self, factor: float) -> Schedule:
        """Every weight multiplied by ``factor``.

        Parameters
        ----------
        factor : float
            The scale (>= 0).

        Returns
        -------
        Schedule
            The scaled schedule.
        """
        return self.with_values([factor * v for v in self.values])

    @classmethod
    def from_mapping(cls, d, where: str) -> Schedule:
        """A schedule from a scenario file: a number (constant) or a table ``{breakpoints, values, period}``.

        Parameters
        ----------
        d : float or Mapping
            The TOML value.
        where : str
            Where it is in the file, for error messages.

        Returns
        -------
        Schedule
            The schedule.

        Raises
        ------
        TopologyError
            Unknown keys, missing ``values``, or an invalid schedule.
        """
        if isinstance(d, (int, float)) and not isinstance(d, bool):
            return cls.constant(_num(d, where))
        if not isinstance(d, Mapping):
            raise TopologyError(f"{where}: expected a number or a table with breakpoints/values/period")
        unknown = set(d) - {"breakpoints", "values", "period"}
        if unknown:
            raise TopologyError(f"{where}: unknown key(s) {sorted(unknown)} (known: breakpoints, values, period)")
        try:
            b = tuple(_num(x, f"{where}.breakpoints") for x in d.get("breakpoints", [0.0]))
            v = tuple(_num(x, f"{where}.values") for x in d["values"])
        except KeyError:
            raise TopologyError(f"{where}.values: missing") from None
        except TypeError:
            raise TopologyError(f"{where}: breakpoints and values must be arrays of numbers") from None
        period = d.get("period")
        try:
            return cls(b, v, None if period is None else _num(period, f"{where}.period"))
        except TopologyError as exc:
            raise TopologyError(f"{where}: {str(exc).removeprefix('schedule: ')}") from None


@dataclass(frozen=True)
class Link:
    """Agent ``receiver`` (i) gets ``s_j`` from ``sender`` (j): weights ``k^i_ij`` and ``k^j_ij(t)`` (eq 19; 0-based indices).

    Parameters
    ----------
    receiver : int
        Agent ``i`` (0-based), which uses the link.
    sender : int
        Agent ``j`` (0-based), whose sliding variable ``s_j`` is received.
    k_i : float
        ``k^i_ij`` (>= 0), the weight of the receiver's own ``s_i``.
    k_j : Schedule
        ``k^j_ij(t)``, the weight of the received ``s_j``.
    phase : float, optional
        Time shift (s) of the schedule: ``k^j_ij(t) = k_j(t + phase)`` (Table 2's phases), default 0.

    Examples
    --------
    >>> from fsmctl.model import Link, Schedule
    >>> link = Link(receiver=0, sender=1, k_i=8.0, k_j=Schedule((0.0, 6.5), (5.0, 0.0), 8.0), phase=2.0)
    >>> link.k_j_at([0.0, 5.0])
    array([5., 0.])
    """

    receiver: int
    sender: int
    k_i: float
    k_j: Schedule
    phase: float = 0.0

    def k_j_at(self, t):
        """``k^j_ij(t)``: the schedule at ``t + phase``.

        Parameters
        ----------
        t : float or array_like
            Time(s) (s).

        Returns
        -------
        float or numpy.ndarray
            The weight(s), shaped like ``t``.
        """
        return self.k_j.value(np.asarray(t, dtype=float) + self.phase)


@dataclass(frozen=True)
class Topology:
    """The directed, possibly time-varying communication graph of eq 19 (Liang et al. 2012; Assumption 1); the
    usual graphs: :func:`ring`, :func:`k_nearest`, :func:`all_to_all`, :func:`from_phase_table`.

    Parameters
    ----------
    n_agents : int
        Number of agents (>= 1).
    links : tuple of Link
        The directed links; no self-links, no duplicates, agents in ``0..n_agents-1``.

    Raises
    ------
    TopologyError
        An invalid link (see the message).

    Examples
    --------
    >>> from fsmctl.model import Link, Schedule, Topology
    >>> topo = Topology(2, (Link(0, 1, 8.0, Schedule.constant(5.0)), Link(1, 0, 8.0, Schedule.constant(0.0))))
    >>> topo.k_i_matrix()
    array([[0., 8.],
           [8., 0.]])
    >>> topo.k_j_matrix(0.0)
    array([[0., 5.],
           [0., 0.]])
    """

    n_agents: int
    links: tuple[Link, ...]

    def __post_init__(self):
        if not _is_index(self.n_agents) or self.n_agents < 1:
            raise TopologyError(f"topology: needs an integer number of agents >= 1, got {self.n_agents!r}")
        if isinstance(self.links, (str, bytes)) or not isinstance(self.links, Sequence):
            raise TopologyError(f"topology: links must be a sequence of Link, got {self.links!r}")
        seen = set()
        for e, link in enumerate(self.links):
            if not isinstance(link, Link):
                raise TopologyError(f"topology link {e + 1}: expected a Link, got {link!r}")
            if not (_is_index(link.receiver) and _is_index(link.sender)):
                raise TopologyError(f"topology link {e + 1}: receiver and sender must be integers, got {link!r}")
            if not isinstance(link.k_j, Schedule):
                raise TopologyError(f"topology link {e + 1}: k_j must be a Schedule, got {link.k_j!r}")
            _num(link.k_i, f"topology link {e + 1}: k_i")
            _num(link.phase, f"topology link {e + 1}: phase")
            w = f"topology link {e + 1} ({link.receiver + 1} <- {link.sender + 1})"
            for idx in (link.receiver, link.sender):
                if not (0 <= idx < self.n_agents):
                    raise TopologyError(f"{w}: agent {idx + 1} is not in 1..{self.n_agents}")
            if link.receiver == link.sender:
                raise TopologyError(f"{w}: an agent cannot link to itself")
            if (link.receiver, link.sender) in seen:
                raise TopologyError(f"{w}: duplicate link")
            seen.add((link.receiver, link.sender))
            if not (math.isfinite(link.k_i) and link.k_i >= 0):
                raise TopologyError(f"{w}: k^i must be finite and >= 0, got {link.k_i}")
            if not math.isfinite(link.phase):
                raise TopologyError(f"{w}: phase must be finite")

    # --- queries -------------------------------------------------------------------
    def k_i_matrix(self) -> np.ndarray:
        """``K_i[i, j] = k^i_ij`` (zero where there is no link)."""
        K = np.zeros((self.n_agents, self.n_agents))
        for link in self.links:
            K[link.receiver, link.sender] = link.k_i
        return K

    def k_j_matrix(self, t: float) -> np.ndarray:
        """``K_j[i, j] = k^j_ij(t)`` (Liang et al. 2012, eq 19).

        Parameters
        ----------
        t : float
            Time (s).

        Returns
        -------
        numpy.ndarray
            ``(n_agents, n_agents)``, zero where there is no link.
        """
        return self.k_j_matrices(np.array([t], dtype=float))[0]

    def k_j_matrices(self, times: npt.ArrayLike) -> np.ndarray:
        """``K_j(t)`` at many times at once: ``K[..., i, j] = k^j_ij(times[...])`` (Liang et al. 2012, eq 19).

        Parameters
        ----------
        times : array_like
            Times (s), any shape.

        Returns
        -------
        numpy.ndarray
            Shape ``(*times.shape, n_agents, n_agents)``; each link's schedule is evaluated on every time in
            one call of :func:`schedule_weight`, so ``k_j_matrices(times)[k]`` equals ``k_j_matrix(times[k])``.
        """
        t = np.asarray(times, dtype=float)
        K = np.zeros((*t.shape, self.n_agents, self.n_agents))
        for link in self.links:
            K[..., link.receiver, link.sender] = link.k_j_at(t)
        return K

    def k_j_max_matrix(self) -> np.ndarray:
        """``K[i, j] = max_t k^j_ij(t)``: every link's largest weight (zero where there is no link).

        Returns
        -------
        numpy.ndarray
            ``(n_agents, n_agents)``.
        """
        K = np.zeros((self.n_agents, self.n_agents))
        for link in self.links:
            K[link.receiver, link.sender] = link.k_j.max
        return K

    def switching_times(self, t0: float, t1: float) -> np.ndarray:
        """All times in ``(t0, t1)`` at which some ``k^j_ij`` may change.

        Parameters
        ----------
        t0, t1 : float
            The open time interval (s).

        Returns
        -------
        numpy.ndarray
            Sorted, unique times.
        """
        parts = [link.k_j.switching_times(t0, t1, link.phase) for link in self.links]
        return np.unique(np.concatenate(parts)) if parts else np.zeros(0)

    def edge_count(self) -> int:
        """The number of directed links.

        Returns
        -------
        int
            ``len(links)``.
        """
        return len(self.links)

    def scaled(self, k_i: float | None = None, k_j_on: float | None = None) -> Topology:
        """Same graph and timing with ``k^i`` replaced and/or every schedule's nonzero values set to ``k_j_on``.

        Parameters
        ----------
        k_i : float or None, optional
            New ``k^i_ij`` of every link; None keeps each link's.
        k_j_on : float or None, optional
            New value of every nonzero schedule weight; None keeps the schedules.

        Returns
        -------
        Topology
            The rescaled graph.
        """
        links = []
        for link in self.links:
            sched = link.k_j
            if k_j_on is not None:
                sched = sched.with_values([k_j_on if v != 0 else 0.0 for v in sched.values])
            links.append(Link(link.receiver, link.sender, link.k_i if k_i is None else float(k_i), sched, link.phase))
        return Topology(self.n_agents, tuple(links))

    # --- construction ------------------------------------------------------------
    @classmethod
    def from_mapping(cls, d: Mapping, n_agents: int, where: str = "topology") -> Topology:
        """From a TOML table: ``phase_table`` + ``schedule`` + ``k_i``, ``kind`` (``ring``, one way with ``directed =
        true``; ``all-to-all``; ``k-nearest`` with ``neighbours``), or an explicit ``links = [{receiver = 1, sender =
        2, k_i = 8, phase = 0.0, k_j = <number or schedule table>}, ...]`` (1-based agents; ``k_i``,
        ``k_j``/``schedule`` default to the table-level values).

        Parameters
        ----------
        d : Mapping
            The ``[topology]`` table.
        n_agents : int
            Number of agents of the scenario.
        where : str, optional
            Where the table is, for error messages (default ``"topology"``).

        Returns
        -------
        Topology
            The graph.

        Raises
        ------
        TopologyError
            Unknown keys, conflicting or missing keys, invalid links or schedules.
        """
        if not isinstance(d, Mapping):
            raise TopologyError(f"{where}: expected a table")
        known = ("k_i", "schedule", "phase_table", "links", "kind", "k_j", "neighbours", "directed")
        unknown = sorted(set(d) - set(known))
        if unknown:
            hint = did_you_mean(unknown[0], known)  # fsmctl.suggest: the one rule of suggestions
            raise TopologyError(f"{where}: unknown key(s) {unknown}{hint and ': ' + hint} (known: {', '.join(known)})")
        k_i = _num(d.get("k_i", 0.0), f"{where}.k_i")
        if "schedule" in d and "k_j" in d:
            raise TopologyError(f"{where}: give either schedule or k_j, not both")
        sched = Schedule.from_mapping(d.get("schedule", d.get("k_j", 0.0)), f"{where}.schedule")
        given = [k for k in ("phase_table", "links", "kind") if k in d]
        if len(given) != 1:
            raise TopologyError(f"{where}: give exactly one of phase_table, links or kind (got {given or 'none'})")
        if "phase_table" in d:
            return from_phase_table(d["phase_table"], n_agents, k_i, sched, where=f"{where}.phase_table")
        directed = d.get("directed", False)
        if "directed" in d and (not isinstance(directed, bool) or d.get("kind") != "ring"):
            raise TopologyError(f"{where}.directed: true or false, with kind = 'ring' only; got {directed!r}")
        if "kind" in d:
            return _generated(d, n_agents, k_i, sched, where)
        raw = d["links"]
        if not isinstance(raw, Sequence) or isinstance(raw, str):
            raise TopologyError(f"{where}.links: expected an array of tables")
        links = []
        for e, item in enumerate(raw):
            w = f"{where}.links[{e + 1}]"
            if not isinstance(item, Mapping):
                raise TopologyError(f"{w}: expected a table")
            extra = set(item) - {"receiver", "sender", "k_i", "k_j", "phase"}
            if extra:
                raise TopologyError(f"{w}: unknown key(s) {sorted(extra)} (known: receiver, sender, k_i, k_j, phase)")
            try:
                i, j = item["receiver"], item["sender"]
            except KeyError as exc:
                raise TopologyError(f"{w}: missing {exc.args[0]}") from None
            for name, idx in (("receiver", i), ("sender", j)):
                if not isinstance(idx, int) or isinstance(idx, bool) or not 1 <= idx <= n_agents:
                    raise TopologyError(f"{w}.{name}: must be an agent number 1..{n_agents}, got {idx!r}")
            link_sched = Schedule.from_mapping(item["k_j"], f"{w}.k_j") if "k_j" in item else sched
            links.append(
                Link(
                    i - 1,
                    j - 1,
                    _num(item.get("k_i", k_i), f"{w}.k_i"),
                    link_sched,
                    _num(item.get("phase", 0.0), f"{w}.phase"),
                )
            )
        try:
            return cls(n_agents, tuple(links))
        except TopologyError as exc:
            raise TopologyError(f"{where}: {exc}") from None


def from_phase_table(table, n_agents: int, k_i: float, schedule: Schedule, where: str = "phase_table") -> Topology:
    """Table 2 form (Liang et al. 2012): ``k^j_ij(t) = schedule(t + table[i][j])``; NaN means no link.

    A phase is a time shift and may be any finite number; only NaN removes a link (a negative entry is a shift like
    any other, never a silent way to drop a link).

    Parameters
    ----------
    table : array_like
        ``(n_agents, n_agents)`` phases (s); NaN on the diagonal and where there is no link.
    n_agents : int
        Number of agents.
    k_i : float
        ``k^i_ij`` of every link.
    schedule : Schedule
        The schedule every link shifts by its phase.
    where : str, optional
        Where the table is, for error messages.

    Returns
    -------
    Topology
        One link per finite entry.

    Raises
    ------
    TopologyError
        Wrong shape, non-numbers, a non-NaN diagonal or an infinite phase.

    Examples
    --------
    >>> import math
    >>> from fsmctl.model import Schedule, from_phase_table
    >>> nan = math.nan
    >>> topo = from_phase_table([[nan, 0.0], [2.0, nan]], 2, k_i=8.0, schedule=Schedule((0.0, 6.5), (5.0, 0.0), 8.0))
    >>> [(link.receiver, link.sender, link.phase) for link in topo.links]
    [(0, 1, 0.0), (1, 0, 2.0)]
    >>> topo.k_j_matrix(5.0)
    array([[0., 5.],
           [0., 0.]])
    """
    try:
        a = np.asarray(table, dtype=float)
    except (TypeError, ValueError):
        raise TopologyError(f"{where}: expected an {n_agents}x{n_agents} array of numbers (nan = no link)") from None
    if a.shape != (n_agents, n_agents):
        raise TopologyError(f"{where}: expected shape ({n_agents}, {n_agents}) for {n_agents} agents, got {a.shape}")
    links = []
    for i in range(n_agents):
        for j in range(n_agents):
            if i == j:
                if not np.isnan(a[i, j]):
                    raise TopologyError(
                        f"{where}[{i + 1}][{j + 1}]: the diagonal must be nan (an agent cannot link to itself)"
                    )
                continue
            if np.isfinite(a[i, j]):
                links.append(Link(i, j, float(k_i), schedule, float(a[i, j])))
            elif np.isinf(a[i, j]):
                raise TopologyError(f"{where}[{i + 1}][{j + 1}]: phase must be finite (or nan for no link)")
    return Topology(n_agents, tuple(links))


def _links(pairs: Iterable[tuple[int, int]], k_i: float, schedule: Schedule) -> tuple[Link, ...]:
    return tuple(Link(i, j, float(k_i), schedule) for i, j in pairs)


def _generated(d: Mapping, n: int, k_i: float, sched: Schedule, where: str) -> Topology:
    """``[topology] kind = ...``: a generated graph (``neighbours`` for ``k-nearest``, ``directed`` for ``ring``)."""
    kind, k = d["kind"], d.get("neighbours")
    if kind == "ring":
        return ring(n, k_i, sched, directed=d.get("directed", False))
    if kind == "all-to-all":
        return all_to_all(n, k_i, sched)
    if kind != "k-nearest":
        raise TopologyError(f"{where}.kind: must be 'ring', 'all-to-all' or 'k-nearest', got {kind!r}")
    if not isinstance(k, int) or isinstance(k, bool):
        raise TopologyError(f"{where}.neighbours: an integer is required for kind = 'k-nearest'")
    return k_nearest(n, k, k_i, sched)


def ring(n: int, k_i: float, k_j: Schedule | float, *, directed: bool = False) -> Topology:
    """Ring: agent ``i`` receives from ``i-1`` and ``i+1`` (modulo ``n``); directed: from ``i-1`` only (the cycle
    1 -> 2 -> ... -> n -> 1: ``[topology] kind = "ring"``, ``directed = true``).

    Parameters
    ----------
    n : int
        Number of agents (fewer than 2: no links).
    k_i : float
        ``k^i_ij`` of every link.
    k_j : Schedule or float
        ``k^j_ij(t)`` of every link (a number is a constant schedule).
    directed : bool
        One direction only: agent ``i`` receives from ``i-1`` (``n`` links instead of ``2n``).

    Returns
    -------
    Topology
        The graph.

    Examples
    --------
    >>> from fsmctl.model import ring
    >>> ring(4, k_i=8.0, k_j=5.0).k_i_matrix()
    array([[0., 8., 0., 8.],
           [8., 0., 8., 0.],
           [0., 8., 0., 8.],
           [8., 0., 8., 0.]])
    >>> ring(3, k_i=8.0, k_j=5.0, directed=True).k_i_matrix()  # 1 -> 2 -> 3 -> 1
    array([[0., 0., 8.],
           [8., 0., 0.],
           [0., 8., 0.]])
    """
    s = k_j if isinstance(k_j, Schedule) else Schedule.constant(k_j)
    if n < 2:
        return Topology(n, ())
    steps = (-1,) if directed else (-1, 1)
    pairs = sorted({(i, (i + d) % n) for i in range(n) for d in steps if (i + d) % n != i})
    return Topology(n, _links(pairs, k_i, s))


def k_nearest(n: int, k: int, k_i: float, k_j: Schedule | float) -> Topology:
    """Each agent receives from its ``k`` nearest neighbours on a circle (``k`` even: ``k/2`` per side; ``k`` odd:
    one more ahead).

    Parameters
    ----------
    n : int
        Number of agents.
    k : int
        Neighbours per agent, ``1 <= k < n``.
    k_i : float
        ``k^i_ij`` of every link.
    k_j : Schedule or float
        ``k^j_ij(t)`` of every link (a number is a constant schedule).

    Returns
    -------
    Topology
        The graph.

    Raises
    ------
    TopologyError
        ``k`` outside ``1..n-1``.

    Examples
    --------
    >>> from fsmctl.model import k_nearest
    >>> topo = k_nearest(5, 2, k_i=1.0, k_j=1.0)
    >>> topo.edge_count(), sorted(link.sender for link in topo.links if link.receiver == 0)
    (10, [1, 4])
    """
    if k < 1 or k >= n:
        raise TopologyError(f"k-nearest: need 1 <= k < n, got k={k}, n={n}")
    s = k_j if isinstance(k_j, Schedule) else Schedule.constant(k_j)
    offsets = [d for m in range(1, k // 2 + 1) for d in (-m, m)] + ([k // 2 + 1] if k % 2 else [])
    pairs = sorted({(i, (i + d) % n) for i in range(n) for d in offsets})
    return Topology(n, _links(pairs, k_i, s))


def all_to_all(n: int, k_i: float, k_j: Schedule | float) -> Topology:
    """Every agent receives from every other (a complete directed graph).

    Parameters
    ----------
    n : int
        Number of agents.
    k_i : float
        ``k^i_ij`` of every link.
    k_j : Schedule or float
        ``k^j_ij(t)`` of every link (a number is a constant schedule).

    Returns
    -------
    Topology
        The graph.

    Examples
    --------
    >>> from fsmctl.model import all_to_all
    >>> all_to_all(3, k_i=2.0, k_j=1.0).edge_count()
    6
    """
    s = k_j if isinstance(k_j, Schedule) else Schedule.constant(k_j)
    return Topology(n, _links(((i, j) for i in range(n) for j in range(n) if i != j), k_i, s))
