"""How a run fails or is doubtful: :class:`SimulationError`, :class:`StepSizeWarning`,
:class:`DiscontinuousControlWarning`, and the hint a non-finite command gets.

The bottom of :mod:`fsmctl.simulation`: both backends (the compiled driver, :mod:`fsmctl.simulation.simulator`, and
the CasADi fallback, :mod:`fsmctl.simulation.casadi_formation`) raise these.
"""

from __future__ import annotations

import numpy as np

from fsmctl.model.problem import PackedProblem


class SimulationError(RuntimeError):
    """A run failed (non-finite state, step size underflow, ...); the message says where and why.

    ``fsmctl simulate`` exits 1 on it (:mod:`fsmctl.errors`): the input was valid, the run itself failed.

    Examples
    --------
    >>> import fsmctl
    >>> issubclass(fsmctl.SimulationError, RuntimeError)
    True
    """


class ZenoError(SimulationError):
    """An event-triggered run stopped by the Zeno guard: an agent sent at every trigger check for
    :data:`fsmctl.policy.ZENO_CONSECUTIVE_CHECKS` checks in a row (the message names the agent, the time, the
    inter-event time and what to change).  A :class:`SimulationError` (``fsmctl simulate`` exits 1); the compiled
    loop's status is ``FSM_ZENO``.

    Examples
    --------
    >>> from fsmctl.simulation import SimulationError, ZenoError
    >>> issubclass(ZenoError, SimulationError)
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


def singularity_fix_none(p: PackedProblem) -> bool:
    """Whether a law on the paper's surface runs without the Remark 6 device (for the hint of a non-finite command):
    its declaration (``LawBuilder.paper_theorems``) names the parameter that selects the device."""
    theorems = p.law.paper_theorems
    if theorems is None or theorems.parameters.get("singularity_fix") is None:
        return False
    fix = p.law.parameter(theorems.parameters["singularity_fix"])
    k = sum(q.size for q in p.law.parameters[: p.law.parameters.index(fix)])
    return bool(np.any(p.params[:, k] == fix.choices.index("none")))


def nonfinite_hint(p: PackedProblem) -> str:
    """What to do about a law output that is not finite, in parentheses after the message: the paper's law flown
    without its Remark 6 device (:func:`singularity_fix_none`), else what to check."""
    if singularity_fix_none(p):
        return " (the Remark 6 term alpha|sigma_e|^(alpha-1) is singular with singularity_fix = 'none'; use 'switch')"
    return " (check inertias, gains and the step size)"
