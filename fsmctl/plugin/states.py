"""The python-control formation's state vector: built from a scenario, read back as MRPs.

The layout of :func:`fsmctl.formation` (the reference quaternion, then per spacecraft its quaternion and body
rate; the wheels' states after them with reaction wheels): :func:`initial_state` writes a scenario's initial
conditions in it, :func:`mrp_state` reads attitudes out of it as MRPs.
"""

from __future__ import annotations

import numpy as np

from fsmctl.model.attitude import mrp_from_quaternion, quaternion_from_mrp
from fsmctl.model.laws import (
    initial_law_states,
)
from fsmctl.model.scenario import Scenario, ScenarioError


def initial_state(scenario: Scenario) -> np.ndarray:
    """The formation's initial state vector (order of :func:`formation`'s states): quaternions from the MRPs,
    then the law's initial states of every agent (none for the paper's law).

    Parameters
    ----------
    scenario : Scenario
        The formation: the reference's and the agents' initial MRPs and rates (and wheel speeds), the law.

    Returns
    -------
    numpy.ndarray
        ``[q_d, q_1, omega_1 (, Omega_1), ..., q_n, omega_n (, Omega_n), z_1, ..., z_n]``; with actuator or sensor
        blocks in :func:`formation`, pass ``[initial_state(s), x_blocks]`` (or ``[initial_state(s), 0]``).

    Raises
    ------
    fsmctl.ScenarioError
        ``scenario`` is not a :class:`fsmctl.Scenario`.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.plugin.iosys import initial_state
    >>> initial_state(fsmctl.paper_scenario("1")).shape
    (46,)
    """
    if not isinstance(scenario, Scenario):
        raise ScenarioError(f"initial_state: expected a Scenario, got {type(scenario).__name__}")
    x = [quaternion_from_mrp(scenario.reference.sigma0)]
    wheels = scenario.actuator.per_wheel("initial_speed") if scenario.actuator.enabled else np.zeros(0)
    for a in scenario.agents:
        x += [quaternion_from_mrp(a.sigma0), np.asarray(a.omega0, dtype=float), wheels]
    z0 = initial_law_states(scenario.law)
    x += [z0] * scenario.n_agents
    return np.concatenate(x)


def mrp_state(x, n_agents: int | None = None, n_wheels: int = 0) -> np.ndarray:
    """Formation states (of :func:`formation`) in the compiled simulator's MRP layout.

    Parameters
    ----------
    x : array_like, shape (4 + 7 n [+ law states], ...)
        ``[q_d, q_1, omega_1, ..., q_n, omega_n]`` along the first axis (e.g. ``response.states``), optionally
        followed by the controllers' law states (then give ``n_agents``).
    n_agents : int, optional
        The number of agents ``n``; by default ``(len(x) - 4) / (7 + n_wheels)`` (a law without states).
    n_wheels : int
        Reaction wheels per agent (their speeds follow each agent's rate; they are dropped here).

    Returns
    -------
    numpy.ndarray, shape (3 + 6 n, ...)
        ``[sigma_d, sigma_1, omega_1, ..., sigma_n, omega_n]`` with every MRP in the shadow set ``|sigma| <= 1``
        (the layout of :func:`fsmctl.simulate`'s ``sigma_d``, ``sigma``, ``omega``).

    Raises
    ------
    ValueError
        ``x`` is too short along its first axis for ``n_agents`` (or, without ``n_agents``, its length is not
        ``4 + (7 + n_wheels) n``).

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.plugin.iosys import initial_state, mrp_state
    >>> s = fsmctl.paper_scenario("1")
    >>> mrp_state(initial_state(s))[:3].round(12).tolist() == list(s.reference.sigma0)
    True
    """
    a = np.asarray(x, dtype=float)
    w = 7 + int(n_wheels)
    if n_agents is None:
        if a.ndim == 0 or (a.shape[0] - 4) % w or a.shape[0] < 4:
            raise ValueError(f"expected formation states of length 4 + {w} n along the first axis, got shape {a.shape}")
        n = (a.shape[0] - 4) // w
    else:
        n = int(n_agents)
        if a.ndim == 0 or n < 0 or a.shape[0] < 4 + w * n:
            raise ValueError(
                f"expected formation states of length >= 4 + {w} * {n} along the first axis, got {a.shape}"
            )
    rows = [mrp_from_quaternion(np.moveaxis(a[:4], 0, -1))]
    for i in range(n):
        o = 4 + w * i
        rows += [mrp_from_quaternion(np.moveaxis(a[o : o + 4], 0, -1)), np.moveaxis(a[o + 4 : o + 7], 0, -1)]
    return np.moveaxis(np.concatenate(rows, axis=-1), -1, 0)
