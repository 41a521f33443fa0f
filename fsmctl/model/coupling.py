"""What each agent receives from its neighbours: the formation's aggregation rule, for the Python routes.

Liang et al. 2012, eq 19, for any broadcast ``b`` (:mod:`fsmctl.symbolic.law`): over the directed links
``j -> i`` with the receiver's constant weight ``k^i_ij`` and the sender's time-varying ``k^j_ij(t)``,

* ``received_i = sum_j k^j_ij(t) b_j``,
* ``k_sum_i = sum_j k^i_ij``,
* ``k_received_sum_i = sum_j k^j_ij(t)``.

The compiled engine has this rule in C (``aggregate`` in ``fsmctl/csrc/formation.c``); every Python route
(the no-compiler fallback, whose values are CasADi expressions, and the python-control plug-in, whose values
are NumPy arrays) uses :func:`aggregate`, and the tests check the routes against each other.  The link
weights at a time come from :meth:`fsmctl.model.problem.PackedProblem.link_weights` (the schedule rule of
:func:`fsmctl.model.topology.schedule_weight`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

__all__ = ["aggregate"]


def aggregate(
    broadcasts: Sequence[Any],
    weights: Sequence[Any],
    receivers: Sequence[int],
    senders: Sequence[int],
    k_i: Sequence[float],
    zero: Callable[[], Any],
) -> tuple[list[Any], np.ndarray, list[Any]]:
    """``(received, k_sum, k_received_sum)`` of every agent (see the module docstring).

    Parameters
    ----------
    broadcasts : sequence
        ``b_j`` of every agent (NumPy arrays or CasADi expressions: anything with ``*`` and ``+``).
    weights : sequence
        ``k^j_ij(t)`` of every link (numbers or CasADi expressions).
    receivers, senders : sequence of int
        ``i`` and ``j`` of every link.
    k_i : sequence of float
        ``k^i_ij`` of every link.
    zero : callable
        Returns a zero of a broadcast's shape (the start of each sum) and of a weight's type.

    Returns
    -------
    received : list
        ``sum_j k^j_ij(t) b_j`` per agent.
    k_sum : ndarray
        ``sum_j k^i_ij`` per agent.
    k_received_sum : list
        ``sum_j k^j_ij(t)`` per agent.

    Examples
    --------
    >>> import numpy as np
    >>> b = [np.array([1.0, 0.0, 0.0]), np.array([0.0, 2.0, 0.0])]
    >>> received, k_sum, total = aggregate(b, [5.0], [0], [1], [8.0], lambda: np.zeros(3))
    >>> received[0], k_sum, total
    (array([ 0., 10.,  0.]), array([8., 0.]), [5.0, 0.0])
    """
    n = len(broadcasts)
    received = [zero() for _ in range(n)]
    total: list[Any] = [0.0] * n
    k_sum = np.zeros(n)
    for e in range(len(receivers)):
        i, j = int(receivers[e]), int(senders[e])
        k_sum[i] += k_i[e]
        total[i] = total[i] + weights[e]
        received[i] = received[i] + weights[e] * broadcasts[j]
    return received, k_sum, total
