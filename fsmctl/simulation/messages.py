"""Message counts of a run: what the agents sent and the links delivered (event-triggered or periodic broadcasting).

The result fields (:class:`~fsmctl.simulation.result.SimulationResult`), for a run with a control period
(``simulation.control_period > 0``; None for continuous control, where no message is a discrete event):

================================  ==========  ===========================================================================
field                             shape       meaning
================================  ==========  ===========================================================================
``messages_sent``                 (n,) int    messages each agent sent (its first at ``t0``)
``messages_per_link``             (L,) int    messages each link delivered to its receiver (sent, arrived by the end of
                                              the run, not lost), in the order of ``scenario.topology.links``
``events_per_output``             (T, n) int  messages each agent sent in ``(time[r-1], time[r]]`` (row 0: at ``t0``)
``min_inter_event_s``             (n,) s      shortest time between two consecutive messages of an agent (inf: fewer
                                              than two)
``mean_inter_event_s``            (n,) s      mean time between consecutive messages, ``(last - first) / (count - 1)``
                                              (NaN: fewer than two)
================================  ==========  ===========================================================================

An event-triggered law (one that declares ``LawBuilder.trigger``) has them counted by the compiled loop
(``fsmctl/csrc/formation.c``, ``event_trigger``).  Periodic broadcasting (a law without a trigger) sends one message
per agent at every control instant, so :func:`periodic_messages` gives them in closed form, on the same definitions:
the two compare.  With imperfect links a link delivers the message of instant ``q - delay`` at instant ``q`` unless
that packet is lost (no message arrives before the first one: the link holds the instant-0 value from the start).
"""

from __future__ import annotations

import ctypes
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from fsmctl.model.problem import PackedProblem
    from fsmctl.model.scenario import Scenario

__all__ = ["MESSAGE_FIELDS", "MESSAGE_METRICS", "periodic_messages", "mean_inter_event", "message_metrics"]

MESSAGE_FIELDS: tuple[str, ...] = (
    "messages_sent",
    "messages_per_link",
    "events_per_output",
    "min_inter_event_s",
    "mean_inter_event_s",
)
"""The names of the message fields of a result (and of a run's raw arrays)."""


MESSAGE_METRICS: tuple[tuple[str, str, str], ...] = (
    ("messages_count", "messages sent, all agents (nan: continuous control, no messages)", "1"),
    ("messages_per_agent_per_s", "messages per agent per second (nan: continuous control)", "1/s"),
)
"""``(name, description, unit)`` of the message metrics of a run (:func:`message_metrics`): the ``compare``
columns, the ``montecarlo`` per-run variables and the ``tune`` objective ``messages`` read them."""


def message_metrics(result: Any, rows: int | None = None) -> dict[str, float]:
    """The message metrics of a run: messages sent by all agents, and per agent per second of simulated time.

    The one definition of "how many messages a run needs" (``fsmctl compare``, ``fsmctl montecarlo``, the ``tune``
    objective ``messages``): the sum of :attr:`~fsmctl.simulation.SimulationResult.events_per_output` over the
    first ``rows`` output samples (all: every message of the run, ``messages_sent.sum()``), and that divided by the
    agents and the time those samples span.  Periodic broadcasting counts one message per agent and control instant
    (:func:`periodic_messages`), an event-triggered law the messages its trigger sent.

    Parameters
    ----------
    result : SimulationResult
        A run (or a run in progress: its first ``rows`` samples).
    rows : int, optional
        Count the messages sent up to output sample ``rows - 1``; default all.

    Returns
    -------
    dict
        :data:`MESSAGE_METRICS` names -> float: ``messages_count`` (messages sent) and ``messages_per_agent_per_s`` (1/s,
        NaN when the samples span no time).  Both NaN for continuous control (no control period: no message is a
        discrete event, so there is nothing to count; never 0).

    Examples
    --------
    Periodic broadcasting at 10 Hz for 2 s: 21 control instants, 6 agents.

    >>> import fsmctl
    >>> s = fsmctl.paper_scenario("1").replace(simulation={"t_final": 2.0, "control_period": 0.1})
    >>> message_metrics(fsmctl.simulate(s))
    {'messages_count': 126.0, 'messages_per_agent_per_s': 10.5}
    """
    nan = {name: float("nan") for name, _, _ in MESSAGE_METRICS}
    events = getattr(result, "events_per_output", None)
    if events is None:
        return nan
    w = np.asarray(events).shape[0] if rows is None else int(rows)
    t = np.asarray(result.time[:w], dtype=float)
    sent = float(np.sum(np.asarray(events)[:w]))
    span = float(t[-1] - t[0]) if t.size else 0.0
    n = np.asarray(events).shape[1]
    return {"messages_count": sent, "messages_per_agent_per_s": sent / (n * span) if span > 0 else float("nan")}


def mean_inter_event(count: np.ndarray, first: np.ndarray, last: np.ndarray) -> np.ndarray:
    """Mean time between consecutive messages per agent: ``(last - first) / (count - 1)``, NaN with fewer than two.

    Parameters
    ----------
    count : numpy.ndarray, shape (n,)
        Messages each agent sent.
    first, last : numpy.ndarray, shape (n,)
        Times of each agent's first and last message, s.

    Returns
    -------
    numpy.ndarray, shape (n,)
        Seconds.

    Examples
    --------
    >>> import numpy as np
    >>> mean_inter_event(np.array([3, 1]), np.array([0.0, 0.0]), np.array([1.0, 0.0])).tolist()
    [0.5, nan]
    """
    count = np.asarray(count)
    gaps = np.maximum(count - 1, 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(gaps > 0, (np.asarray(last, float) - np.asarray(first, float)) / np.maximum(gaps, 1), np.nan)


def periodic_messages(
    *,
    n_agents: int,
    rows: int,
    output_every: int,
    hold_steps: int,
    dt: float,
    link_senders: np.ndarray,
    link_delay: np.ndarray | None = None,
    link_lost: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """The message fields of periodic broadcasting: every agent sends at every control instant.

    Parameters
    ----------
    n_agents : int
        Agents.
    rows : int
        Output rows written (the run's ``time.size``; a run stopped early has fewer).
    output_every : int
        Integrator steps between output rows.
    hold_steps : int
        Integrator steps per control period (> 0).
    dt : float
        The integrator step, s.
    link_senders : numpy.ndarray, shape (L,)
        Each link's sender (0-based).
    link_delay : numpy.ndarray, shape (L,), optional
        Each link's delay in control instants (imperfect links); None: ideal links.
    link_lost : numpy.ndarray, shape (Q, L), optional
        1 where the packet of an instant is lost on a link (imperfect links).

    Returns
    -------
    dict
        :data:`MESSAGE_FIELDS` as arrays.

    Raises
    ------
    ValueError
        No control period (``hold_steps <= 0``): continuous control sends no discrete messages.

    Examples
    --------
    Ten seconds of 10 Hz control, outputs every second, two agents linked both ways:

    >>> import numpy as np
    >>> m = periodic_messages(n_agents=2, rows=11, output_every=100, hold_steps=10, dt=0.01,
    ...                       link_senders=np.array([1, 0]))
    >>> m["messages_sent"].tolist(), m["messages_per_link"].tolist(), m["events_per_output"][:3, 0].tolist()
    ([101, 101], [101, 101], [1, 10, 10])
    """
    if hold_steps <= 0:
        raise ValueError("periodic_messages: message counts need a control period (hold_steps > 0)")
    steps = np.arange(rows, dtype=np.int64) * int(output_every)  # the step of each output row
    instants_up_to = steps // int(hold_steps) + 1  # control instants at or before each row
    events = np.diff(instants_up_to, prepend=0)  # row 0: the instant-0 message
    q_last = int(instants_up_to[-1]) - 1 if rows else -1
    sent = q_last + 1
    senders = np.asarray(link_senders, dtype=np.int64)
    if link_delay is None:
        per_link = np.full(senders.size, sent, dtype=np.int64)
    else:
        q = np.arange(sent)[:, None]
        arrived = q >= np.asarray(link_delay, dtype=np.int64)[None, :]
        kept = np.asarray(link_lost[:sent], dtype=bool) == 0 if link_lost is not None else True
        per_link = np.sum(arrived & kept, axis=0).astype(np.int64)
    period = hold_steps * dt
    return {
        "messages_sent": np.full(n_agents, sent, dtype=np.int64),
        "messages_per_link": per_link,
        "events_per_output": np.repeat(events[:, None], n_agents, axis=1).astype(np.int64),
        "min_inter_event_s": np.full(n_agents, period if sent > 1 else np.inf),
        "mean_inter_event_s": np.full(n_agents, period if sent > 1 else np.nan),
    }


# ----------------------------------------------------------------------------- the simulator's side


def event_buffers(p: PackedProblem, lead: tuple) -> dict | None:
    """The arrays the compiled loop writes the message counts of an event-triggered run into (None: periodic)."""
    if not p.trigger_every:
        return None
    n = p.n_agents
    return {
        "messages_sent": np.zeros(n, dtype=np.int64),
        "messages_delivered": np.zeros(p.n_links, dtype=np.int64),
        "events_per_output": np.zeros(lead, dtype=np.int64),
        "first_event": np.full(n, np.nan),
        "last_event": np.full(n, np.nan),
        "min_inter_event": np.full(n, np.inf),
    }


def event_pointers(events: dict | None) -> dict:
    """The ctypes pointers of :func:`event_buffers`' arrays, as ``fsm_output`` fields (none for periodic runs)."""
    if events is None:
        return {}
    out = {}
    for k, v in events.items():
        ctype = ctypes.c_longlong if v.dtype == np.int64 else ctypes.c_double
        out[k] = v.ctypes.data_as(ctypes.POINTER(ctype))
    return out


def messages_now(p: PackedProblem, events: dict | None, w: int) -> dict:
    """The message fields (:mod:`fsmctl.simulation.messages`) after ``w`` output rows: the loop's counts of an
    event-triggered run, the closed form of periodic broadcasting, none for continuous control."""
    if events is not None:
        return {
            "messages_sent": events["messages_sent"].copy(),
            "messages_per_link": events["messages_delivered"].copy(),
            "events_per_output": events["events_per_output"][:w].copy(),
            "min_inter_event_s": events["min_inter_event"].copy(),
            "mean_inter_event_s": mean_inter_event(
                events["messages_sent"], events["first_event"], events["last_event"]
            ),
        }
    if p.hold_steps <= 0 or w == 0:
        return {}
    hw = p.hardware
    return periodic_messages(
        n_agents=p.n_agents,
        rows=w,
        output_every=p.output_every,
        hold_steps=p.hold_steps,
        dt=p.dt,
        link_senders=p.link_sender,
        link_delay=hw.link_delay if hw.links_imperfect else None,
        link_lost=hw.link_lost if hw.links_imperfect else None,
    )


def result_messages(scenario: Scenario, raw: dict) -> dict:
    """The message fields of a run: as the loop returned them, else (runs flown together, the CasADi fallback: ideal
    links, no trigger) periodic broadcasting's closed form; none for continuous control."""
    if raw.get("messages_sent") is not None:
        return {k: raw[k] for k in MESSAGE_FIELDS}
    sim = scenario.simulation
    if sim.hold_steps <= 0 or scenario.law.trigger is not None or scenario.links_active:
        return {}
    return periodic_messages(
        n_agents=scenario.n_agents,
        rows=int(np.asarray(raw["t"]).size),
        output_every=sim.output_every,
        hold_steps=sim.hold_steps,
        dt=sim.dt,
        link_senders=np.array([lk.sender for lk in scenario.topology.links], dtype=np.int64),
    )
