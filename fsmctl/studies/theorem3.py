"""Theorem 3 of Liang, Sun & Wang (2012), Section 3.3: settling times of the scalar sliding modes.

On the sliding surface each error component obeys one of three scalar laws
(Liang et al. 2012, Sec. 3.3)::

    FSM  x_dot = -c1 x - c2 sig(x)^alpha      (eq 14)
    TSM  x_dot = -c2 sig(x)^alpha             (c1 = 0)
    LSM  x_dot = -c1 x                        (c2 = 0)

and the time to reach ``|x| <= tau`` from ``|x(0)| = |x0| > tau`` is given in closed form
by eqs 34-36; Theorem 3 claims ``T_fsm < T_tsm`` and ``T_fsm < T_lsm`` (eqs 37-41).

This module *measures* those times by simulation and compares them with the closed forms:

* the right-hand side is the paper's scalar sliding mode as the symbolic layer derives it
  (:func:`fsmctl.symbolic.controller.scalar_sliding_mode`: one error component on the surface ``s = 0`` of eq 13),
  translated exactly into a CasADi ``SX`` function (:func:`fsmctl.codegen.to_casadi_function`) so that
  CVODES gets exact Jacobians;
* CVODES integrates ``x`` itself (no change of state variable), with time rescaled to a
  horizon ``h`` (the local time scale ``|x|/|x_dot|``), horizon after horizon, until the
  output grid brackets the crossing ``|x| = tau``;
* the crossing time is then refined by Newton's method on ``g(eta) = |x(t_a + eta)| - tau``,
  whose derivative ``g'(eta) = sgn(x) f(x)`` is that right-hand side itself.

The closed forms are not re-typed here: they are the SymPy expressions the proof check
derives and checks (:mod:`fsmctl.proofs.claims`, claim ``theorem3-closed-forms``),
lambdified and evaluated in 50-digit arithmetic (mpmath) so the oracle has no
cancellation error of its own (``alpha`` near 1 makes eq 34 a ratio of nearly equal numbers).
"""

from __future__ import annotations

import csv
import dataclasses
import functools
import itertools
import math
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import casadi as ca
import numpy as np

from fsmctl.errors import InputError

__all__ = [
    "MODES",
    "MODE_LABELS",
    "SURFACE_MODES",
    "SurfaceMode",
    "SettlingTimeInputError",
    "SettlingTimeMeasurement",
    "ScalarGrid",
    "ScalarStudy",
    "closed_form_settling_time",
    "closed_form_latex",
    "measure_settling_time",
    "default_extreme_grid",
    "fast_grid",
    "scalar_settling_study",
    "write_scalar_study_csv",
    "plot_settling_time_against_initial_error",
]


@dataclasses.dataclass(frozen=True)
class SurfaceMode:
    """One sliding surface of Sec. 3.3 in the scalar study: its label and which gains it keeps (eqs 34-36).

    Parameters
    ----------
    label : str
        How tables and figures name it.
    linear : bool
        Whether it keeps the linear gain ``c1`` (FSM, LSM); TSM sets it to 0.
    terminal : bool
        Whether it keeps the terminal gain ``c2`` (FSM, TSM); LSM sets it to 0.
    """

    label: str
    linear: bool
    terminal: bool


SURFACE_MODES = {
    "fsm": SurfaceMode("FSM (eq 34)", linear=True, terminal=True),
    "tsm": SurfaceMode("TSM (eq 35)", linear=False, terminal=True),
    "lsm": SurfaceMode("LSM (eq 36)", linear=True, terminal=False),
}
"""the surfaces of Theorem 3, one typed entry each"""
MODES = tuple(SURFACE_MODES)
MODE_LABELS = {name: m.label for name, m in SURFACE_MODES.items()}
_GRID_POINTS = 16
"""output points per horizon used to bracket the crossing"""
_MAX_ROUNDS = 2000


class SettlingTimeInputError(InputError):
    """Bad input to the Theorem 3 study (alpha, tau, ``|x0|``, gains): a one-line message (an
    :class:`~fsmctl.errors.InputError`).

    Examples
    --------
    >>> from fsmctl.studies import SettlingTimeInputError, closed_form_settling_time
    >>> try:
    ...     closed_form_settling_time("fsm", 1.0, 0.1, 0.6, 0.8, 0.4)
    ... except SettlingTimeInputError as exc:
    ...     print(exc)
    alpha must satisfy 0.5 < alpha < 1 (eq 13), got 0.4
    """


# ----------------------------------------------------------------------------- validation


def _check_inputs(mode: str, x0: float, tau: float, c1: float, c2: float, alpha: float) -> None:
    if mode not in MODES:
        raise SettlingTimeInputError(f"mode must be one of {list(MODES)}, got {mode!r}")
    values = {"x0": x0, "tau": tau, "c1": c1, "c2": c2, "alpha": alpha}
    for name, v in values.items():
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not math.isfinite(v):
            raise SettlingTimeInputError(f"{name} must be a finite number, got {v!r}")
    if not 0.5 < alpha < 1:
        raise SettlingTimeInputError(f"alpha must satisfy 0.5 < alpha < 1 (eq 13), got {alpha}")
    if not tau > 0:
        raise SettlingTimeInputError(f"tau must be > 0 (Theorem 3 measures the time to |x| <= tau), got {tau}")
    if not abs(x0) > tau:
        raise SettlingTimeInputError(
            f"|x0| must exceed tau (|x0| = {abs(x0)}, tau = {tau}): the settling time would be 0"
        )
    if SURFACE_MODES[mode].linear and not c1 > 0:
        raise SettlingTimeInputError(f"c1 must be > 0 for the {mode.upper()} mode, got {c1}")
    if SURFACE_MODES[mode].terminal and not c2 > 0:
        raise SettlingTimeInputError(f"c2 must be > 0 for the {mode.upper()} mode, got {c2}")


def _mode_gains(mode: str, c1: float, c2: float, alpha: float) -> tuple[float, float, float]:
    """``c = [c1, c2, alpha]`` of the right-hand side: TSM sets c1 = 0, LSM sets c2 = 0 (Sec. 3.3)."""
    m = SURFACE_MODES[mode]
    return (float(c1) if m.linear else 0.0, float(c2) if m.terminal else 0.0, float(alpha))


# ----------------------------------------------------------------------------- closed forms (single source)


@functools.cache
def _closed_form_expressions() -> dict:
    """The SymPy closed forms of eqs 34-36, as derived and checked by the proof check."""
    from fsmctl.symbolic.theorem3 import settling_time_closed_forms

    _, c1, c2, tau, x0, q, _alpha, T34, T35, T36 = settling_time_closed_forms()
    return {"symbols": (x0, tau, c1, c2, q), "fsm": T34, "tsm": T35, "lsm": T36}


@functools.cache
def _closed_form_functions() -> dict:
    import sympy as sp

    e = _closed_form_expressions()
    return {m: sp.lambdify(e["symbols"], e[m], modules="mpmath") for m in MODES}


def closed_form_latex(mode: str) -> str:
    """LaTeX of the closed form (eq 34, 35 or 36) in terms of ``x0 = |x(0)|`` and ``q = 1 - alpha``.

    Parameters
    ----------
    mode : {'fsm', 'tsm', 'lsm'}
        The sliding mode.

    Returns
    -------
    str
        The LaTeX of ``T``.

    Raises
    ------
    SettlingTimeInputError
        An unknown mode.

    Examples
    --------
    >>> from fsmctl.studies.theorem3 import closed_form_latex
    >>> "log" in closed_form_latex("lsm")
    True
    """
    import sympy as sp

    if mode not in MODES:
        raise SettlingTimeInputError(f"mode must be one of {list(MODES)}, got {mode!r}")
    return sp.latex(_closed_form_expressions()[mode])


def closed_form_settling_time(mode: str, x0: float, tau: float, c1: float, c2: float, alpha: float) -> float:
    """Settling time to ``|x| <= tau`` from the closed forms of Liang et al. 2012, eqs 34-36.

    Parameters
    ----------
    mode : {'fsm', 'tsm', 'lsm'}
        Fast (eq 34), terminal (eq 35) or linear (eq 36) sliding mode.
    x0 : float
        Initial value; only ``|x0|`` matters (the modes are odd).
    tau : float
        Target ``tau > 0`` with ``|x0| > tau``.
    c1, c2 : float
        Gains (``c1`` unused by TSM, ``c2`` unused by LSM).
    alpha : float
        Exponent, ``0.5 < alpha < 1`` (unused by LSM).

    Returns
    -------
    float
        ``T`` in seconds, evaluated in 50-digit arithmetic and rounded to a float.

    Raises
    ------
    SettlingTimeInputError
        An unknown mode, ``alpha`` outside (0.5, 1), ``tau <= 0``, ``|x0| <= tau`` or a non-positive gain the
        mode uses.

    Examples
    --------
    The paper's gains ``c1 = 0.6``, ``c2 = 0.8``, ``alpha = 0.7`` from ``|x0| = 1`` to ``tau = 0.1``; by hand
    (``q = 1 - alpha``): LSM ``ln(10)/c1 = 3.8376``, TSM ``(1 - 0.1^q)/(c2 q) = 2.0784``, FSM
    ``ln((c1 + c2)/(c1 0.1^q + c2))/(c1 q) = 1.3362``, so FSM is the fastest (Theorem 3):

    >>> from fsmctl.studies import closed_form_settling_time
    >>> [round(closed_form_settling_time(m, 1.0, 0.1, 0.6, 0.8, 0.7), 4) for m in ("fsm", "tsm", "lsm")]
    [1.3362, 2.0784, 3.8376]
    """
    _check_inputs(mode, x0, tau, c1, c2, alpha)
    import mpmath

    fn = _closed_form_functions()[mode]
    with mpmath.workdps(50):
        q = 1 - mpmath.mpf(float(alpha))
        value = fn(mpmath.mpf(abs(float(x0))), mpmath.mpf(float(tau)), mpmath.mpf(float(c1)), mpmath.mpf(float(c2)), q)
        return float(value)


# ----------------------------------------------------------------------------- simulation


@functools.cache
def _scalar_rhs() -> ca.Function:
    """``scalar_sliding_mode: (x, c) -> x_dot``, ``c = [c1, c2, alpha]``: the SymPy scalar sliding mode of Sec. 3.3
    (:func:`fsmctl.symbolic.controller.scalar_sliding_mode`) as a differentiable CasADi SX function."""
    import sympy as sp

    from fsmctl.codegen import to_casadi_function
    from fsmctl.symbolic.controller import scalar_sliding_mode
    from fsmctl.symbolic.symbols import vector_symbols

    x = sp.ImmutableMatrix([sp.Symbol("x", real=True)])
    c = vector_symbols("c", 3)
    x_dot = sp.ImmutableMatrix([scalar_sliding_mode(x[0], c[0], c[1], c[2])])
    return to_casadi_function("scalar_sliding_mode", [("x", x), ("c", c)], [("x_dot", x_dot)])


@functools.cache
def _integrators(rtol: float, atol: float) -> tuple[ca.Function, ca.Function]:
    """CVODES on ``dx/ds = h f(x, c)``, ``s`` in [0, 1] (time ``t = t_start + h s``); p = [c1, c2, alpha, h].

    Returns the bracketing integrator (outputs at ``s = k/N``, k = 1..N) and the one-shot one (``s = 1``).
    """
    x = ca.MX.sym("x")
    p = ca.MX.sym("p", 4)
    dae = {"x": x, "p": p, "ode": p[3] * _scalar_rhs()(x, p[:3])}
    opts = {"abstol": atol, "reltol": rtol, "max_num_steps": 100000}
    grid = [k / _GRID_POINTS for k in range(1, _GRID_POINTS + 1)]
    return (
        ca.integrator("theorem3_bracket", "cvodes", dae, 0.0, grid, opts),
        ca.integrator("theorem3_shot", "cvodes", dae, 0.0, [1.0], opts),
    )


@dataclass(frozen=True)
class SettlingTimeMeasurement:
    """One simulated settling time next to its closed form (Liang et al. 2012, eqs 34-36).

    Parameters
    ----------
    mode : str
        ``"fsm"``, ``"tsm"`` or ``"lsm"``.
    x0, tau, c1, c2, alpha : float
        The inputs, as in :func:`closed_form_settling_time`.
    time_simulated_s : float
        The first time ``|x| <= tau`` measured by simulation (s).
    time_closed_form_s : float
        The closed form's ``T`` (s).
    newton_iterations : int
        Newton steps that refined the crossing.
    integrator_calls : int
        CVODES calls in all.

    Examples
    --------
    >>> from fsmctl.studies import measure_settling_time
    >>> m = measure_settling_time("lsm", 1.0, 0.1, 0.6, 0.8, 0.7)
    >>> round(m.time_closed_form_s, 4), m.to_dict()["relative_error"] < 1e-9
    (3.8376, True)
    """

    mode: str
    x0: float
    tau: float
    c1: float
    c2: float
    alpha: float
    time_simulated_s: float
    time_closed_form_s: float
    newton_iterations: int
    integrator_calls: int

    @property
    def relative_error(self) -> float:
        """``|T_sim - T_closed| / T_closed``."""
        return abs(self.time_simulated_s - self.time_closed_form_s) / self.time_closed_form_s

    def to_dict(self) -> dict:
        """The fields and the relative error, as a flat dict (a CSV row).

        Returns
        -------
        dict
            Every field plus ``relative_error``.
        """
        d = asdict(self)
        d["relative_error"] = self.relative_error
        return d


def measure_settling_time(
    mode: str,
    x0: float,
    tau: float,
    c1: float,
    c2: float,
    alpha: float,
    *,
    rtol: float = 1e-12,
) -> SettlingTimeMeasurement:
    """Simulate a scalar sliding mode with CVODES and measure the first time ``|x| <= tau``.

    Parameters
    ----------
    mode : {'fsm', 'tsm', 'lsm'}
        ``x_dot = -c1 x - c2 sig(x)^alpha`` (eq 14), with ``c1 = 0`` (TSM) or ``c2 = 0`` (LSM).
    x0, tau, c1, c2, alpha : float
        As in :func:`closed_form_settling_time`; ``0.5 < alpha < 1``, ``tau > 0``, ``|x0| > tau``.
    rtol : float
        Relative tolerance of CVODES; the absolute tolerance is ``1e-3 rtol tau`` (x never goes below tau
        before the crossing).

    Returns
    -------
    SettlingTimeMeasurement
        The simulated time, the closed form (eqs 34-36) and the work done.

    Raises
    ------
    SettlingTimeInputError
        For ``alpha`` outside (0.5, 1), ``tau <= 0``, ``|x0| <= tau``, a non-positive gain the mode uses, or
        ``rtol`` outside (0, 1e-3).

    Examples
    --------
    >>> from fsmctl.studies import measure_settling_time
    >>> m = measure_settling_time("fsm", 1.0, 0.1, 0.6, 0.8, 0.7)
    >>> round(m.time_simulated_s, 6), round(m.time_closed_form_s, 6), m.relative_error < 1e-9
    (1.336193, 1.336193, True)
    """
    _check_inputs(mode, x0, tau, c1, c2, alpha)
    if not 0 < rtol < 1e-3:
        raise SettlingTimeInputError(f"rtol must be in (0, 1e-3), got {rtol}")
    gains = _mode_gains(mode, c1, c2, alpha)
    atol = 10.0 ** math.floor(math.log10(1e-3 * rtol * tau))  # a power of ten: integrators are cached per value
    bracket, shot = _integrators(float(rtol), atol)
    rhs = _scalar_rhs()

    def f(v: float) -> float:
        return float(rhs(v, gains))

    x_start, t_start = float(x0), 0.0
    calls = 0
    for _ in range(_MAX_ROUNDS):
        # horizon = the local time scale |x|/|x_dot|: it needs no knowledge of the answer, and it is shorter than
        # the time to reach x = 0 (TSM: (|x|^(1-alpha)/c2)/(1-alpha); FSM: ln(1 + z)/(c1(1-alpha)) >= z/(c1(1+z)),
        # z = c1|x|^(1-alpha)/c2), so no output lies past the non-Lipschitz point x = 0
        horizon = abs(x_start / f(x_start))
        xs = np.asarray(bracket(x0=x_start, p=[*gains, horizon])["xf"]).ravel()
        calls += 1
        below = np.nonzero(np.abs(xs) <= tau)[0]
        if below.size:
            k = int(below[0])
            t_a = t_start + horizon * k / _GRID_POINTS
            x_a = x_start if k == 0 else float(xs[k - 1])
            x_b = float(xs[k])
            break
        t_start += horizon
        x_start = float(xs[-1])
    else:  # pragma: no cover - every mode with positive gains settles
        raise RuntimeError(f"{mode}: |x| did not reach tau = {tau} after {_MAX_ROUNDS} horizons")
    step = horizon / _GRID_POINTS
    # Newton on g(eta) = |x(t_a + eta)| - tau, g'(eta) = sgn(x) f(x), started from the secant of the bracket
    eta = step * (abs(x_a) - tau) / (abs(x_a) - abs(x_b))
    iterations = 0
    for iterations in range(1, 60):  # noqa: B007 - the count is reported
        xe = float(shot(x0=x_a, p=[*gains, eta])["xf"])
        calls += 1
        g = abs(xe) - tau
        dg = math.copysign(1.0, xe) * f(xe)
        new = min(max(eta - g / dg, 0.0), step)
        done = abs(new - eta) <= 1e-15 * (t_a + eta) + 1e-300
        eta = new
        if done:
            break
    return SettlingTimeMeasurement(
        mode=mode,
        x0=float(x0),
        tau=float(tau),
        c1=float(c1),
        c2=float(c2),
        alpha=float(alpha),
        time_simulated_s=t_a + eta,
        time_closed_form_s=closed_form_settling_time(mode, x0, tau, c1, c2, alpha),
        newton_iterations=iterations,
        integrator_calls=calls,
    )


# ----------------------------------------------------------------------------- grid study


@dataclass(frozen=True)
class ScalarGrid:
    """Axes of the (c1, c2, alpha, ``|x0|``, tau) grid; combinations with ``|x0| <= tau`` are skipped.

    Parameters
    ----------
    c1, c2 : tuple of float
        Gains of eq 14.
    alpha : tuple of float
        Exponents, each in (0.5, 1).
    x0 : tuple of float
        Initial values (the sign does not matter: the modes are odd).
    tau : tuple of float
        Targets ``tau > 0``.

    Examples
    --------
    >>> from fsmctl.studies import ScalarGrid
    >>> ScalarGrid(c1=(0.6,), c2=(0.8,), alpha=(0.7,), x0=(1.0, 0.05), tau=(0.1,)).points()
    [(0.6, 0.8, 0.7, 1.0, 0.1)]
    """

    c1: tuple[float, ...]
    c2: tuple[float, ...]
    alpha: tuple[float, ...]
    x0: tuple[float, ...]
    tau: tuple[float, ...]

    def points(self) -> list[tuple[float, float, float, float, float]]:
        """The grid points ``(c1, c2, alpha, x0, tau)`` with ``|x0| > tau``, in product order.

        Returns
        -------
        list of tuple of float
            The points.
        """
        return [p for p in itertools.product(self.c1, self.c2, self.alpha, self.x0, self.tau) if abs(p[3]) > p[4]]


def default_extreme_grid() -> ScalarGrid:
    """Grid with the extreme corners: alpha near 0.5 and 1, tiny tau, large |x0|, c1 >> c2 and c2 >> c1.

    Includes the paper's gains (c1 = 0.6, c2 = 0.8) and a negative ``x0`` (the modes are odd).

    Returns
    -------
    ScalarGrid
        3 values per axis (243 points).

    Examples
    --------
    >>> from fsmctl.studies.theorem3 import default_extreme_grid
    >>> len(default_extreme_grid().points())
    243
    """
    return ScalarGrid(
        c1=(0.01, 0.6, 100.0),
        c2=(0.01, 0.8, 100.0),
        alpha=(0.5001, 0.7, 0.9999),
        x0=(-0.5, 2.0, 1e4),
        tau=(1e-12, 1e-3, 0.1),
    )


def fast_grid() -> ScalarGrid:
    """A small grid that still has every extreme (for tests and ``FSMCTL_FAST=1``).

    Returns
    -------
    ScalarGrid
        2 values per axis (32 points).

    Examples
    --------
    >>> from fsmctl.studies import fast_grid
    >>> g = fast_grid()
    >>> len(g.points()), min(g.alpha), max(g.alpha)
    (32, 0.5001, 0.9999)
    """
    return ScalarGrid(c1=(0.01, 100.0), c2=(0.01, 100.0), alpha=(0.5001, 0.9999), x0=(-0.5, 1e4), tau=(1e-12, 0.1))


@dataclass
class ScalarStudy:
    """Simulated vs closed-form settling times over a grid, and Theorem 3's ordering (eqs 37-41).

    Parameters
    ----------
    measurements : list of SettlingTimeMeasurement
        Three per grid point (FSM, TSM, LSM).
    ordering : list of dict, optional
        Per grid point: the inputs, ``T_fsm_s``, ``T_tsm_s``, ``T_lsm_s`` (simulated) and whether
        ``T_fsm < T_tsm`` (``fsm_faster_than_tsm``) and ``T_fsm < T_lsm`` (``fsm_faster_than_lsm``).

    Examples
    --------
    >>> from fsmctl.studies import ScalarGrid, scalar_settling_study
    >>> study = scalar_settling_study(ScalarGrid((0.6,), (0.8,), (0.7,), (1.0,), (0.1,)), progress=False)
    >>> s = study.summary()
    >>> s["n_measurements"], s["ordering_holds_everywhere"], s["ordering_violations"]
    (3, True, [])
    """

    measurements: list[SettlingTimeMeasurement]
    ordering: list[dict] = field(default_factory=list)
    """per grid point: T_fsm, T_tsm, T_lsm (simulated) and whether T_fsm < T_tsm, T_fsm < T_lsm"""

    @property
    def max_relative_error(self) -> float:
        """The largest ``|T_sim - T_closed| / T_closed`` over the measurements."""
        return max(m.relative_error for m in self.measurements)

    @property
    def worst(self) -> SettlingTimeMeasurement:
        """The measurement with the largest relative error."""
        return max(self.measurements, key=lambda m: m.relative_error)

    @property
    def ordering_holds(self) -> bool:
        """Whether FSM is faster than TSM and LSM at every grid point (Theorem 3)."""
        return all(o["fsm_faster_than_tsm"] and o["fsm_faster_than_lsm"] for o in self.ordering)

    def summary(self) -> dict:
        """Counts, the largest relative error, the worst case and the ordering verdict (JSON-able).

        Returns
        -------
        dict
            ``n_measurements``, ``n_grid_points``, ``max_relative_error``, ``worst_case``,
            ``ordering_holds_everywhere`` and ``ordering_violations`` (the grid points where it fails).
        """
        w = self.worst
        return {
            "n_measurements": len(self.measurements),
            "n_grid_points": len(self.ordering),
            "max_relative_error": self.max_relative_error,
            "worst_case": w.to_dict(),
            "ordering_holds_everywhere": self.ordering_holds,
            "ordering_violations": [
                o for o in self.ordering if not (o["fsm_faster_than_tsm"] and o["fsm_faster_than_lsm"])
            ],
        }


def scalar_settling_study(
    grid: ScalarGrid | Iterable[tuple[float, float, float, float, float]] | None = None,
    *,
    rtol: float = 1e-12,
    progress: bool | None = None,
) -> ScalarStudy:
    """Measure FSM, TSM and LSM settling times over a grid and compare with eqs 34-36 (Theorem 3).

    Parameters
    ----------
    grid : ScalarGrid or iterable of (c1, c2, alpha, x0, tau), optional
        Default :func:`default_extreme_grid`.
    rtol : float
        CVODES relative tolerance.
    progress : bool, optional
        tqdm progress bar (default: on a terminal).

    Returns
    -------
    ScalarStudy
        Every measurement and, per grid point, the ordering of the three simulated times.

    Examples
    --------
    One grid point (the paper's gains), three simulations:

    >>> from fsmctl.studies import ScalarGrid, scalar_settling_study
    >>> grid = ScalarGrid(c1=(0.6,), c2=(0.8,), alpha=(0.7,), x0=(1.0,), tau=(0.1,))
    >>> study = scalar_settling_study(grid, progress=False)
    >>> len(study.measurements), study.ordering_holds, study.max_relative_error < 1e-9
    (3, True, True)
    >>> [round(study.ordering[0][f"T_{m}_s"], 4) for m in ("fsm", "tsm", "lsm")]
    [1.3362, 2.0784, 3.8376]
    """
    import sys

    from tqdm import tqdm

    if grid is None:
        grid = default_extreme_grid()
    points = grid.points() if isinstance(grid, ScalarGrid) else list(grid)
    if progress is None:
        progress = sys.stderr.isatty()
    measurements, ordering = [], []
    for c1, c2, alpha, x0, tau in tqdm(points, desc="Theorem 3 grid", disable=not progress, unit="pt"):
        ms = {m: measure_settling_time(m, x0, tau, c1, c2, alpha, rtol=rtol) for m in MODES}
        measurements += ms.values()
        t = {m: ms[m].time_simulated_s for m in MODES}
        ordering.append(
            {
                "c1": c1, "c2": c2, "alpha": alpha, "x0": x0, "tau": tau,
                "T_fsm_s": t["fsm"], "T_tsm_s": t["tsm"], "T_lsm_s": t["lsm"],
                "fsm_faster_than_tsm": t["fsm"] < t["tsm"], "fsm_faster_than_lsm": t["fsm"] < t["lsm"],
            }
        )  # fmt: skip
    return ScalarStudy(measurements, ordering)


def write_scalar_study_csv(study: ScalarStudy, path: str | Path) -> Path:
    """Write one row per measurement (mode, inputs, simulated and closed-form time in s, relative error).

    Parameters
    ----------
    study : ScalarStudy
        The study.
    path : str or pathlib.Path
        The CSV file.

    Returns
    -------
    pathlib.Path
        ``path``.

    Examples
    --------
    >>> from fsmctl.studies import ScalarGrid, scalar_settling_study
    >>> from fsmctl.studies.theorem3 import write_scalar_study_csv
    >>> study = scalar_settling_study(ScalarGrid((0.6,), (0.8,), (0.7,), (1.0,), (0.1,)), progress=False)
    >>> write_scalar_study_csv(study, "t3.csv").read_text().splitlines()[0].split(",")[:7]
    ['mode', 'x0', 'tau', 'c1', 'c2', 'alpha', 'time_simulated_s']
    """
    from fsmctl.outputs import atomic_path

    path = Path(path)
    rows = [m.to_dict() for m in study.measurements]
    with atomic_path(path) as tmp, tmp.open("w", newline="") as fh:  # complete, or the old file stays
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return path


# ----------------------------------------------------------------------------- figure


def plot_settling_time_against_initial_error(
    c1: float = 0.6,
    c2: float = 0.8,
    alpha: float = 0.7,
    tau: float = 1e-3,
    x0_values: Sequence[float] | None = None,
    *,
    n_closed_form: int = 200,
):
    """Settling time T against ``|x0|`` for FSM, TSM, LSM: simulation (markers) over eqs 34-36 (lines).

    Parameters
    ----------
    c1, c2, alpha, tau : float
        Gains, exponent and target (default: the paper's c1, c2 with alpha = 0.7, tau = 1e-3).
    x0_values : sequence of float, optional
        Simulated initial values (default: 12 log-spaced values from 1.5 tau to 10).
    n_closed_form : int
        Points of each closed-form curve.

    Returns
    -------
    matplotlib.figure.Figure
        Built without pyplot (log-scale initial error).

    Examples
    --------
    >>> from fsmctl.studies.theorem3 import plot_settling_time_against_initial_error
    >>> fig = plot_settling_time_against_initial_error(x0_values=[0.01, 1.0], n_closed_form=20)
    >>> ax = fig.axes[0]
    >>> ax.get_xscale(), [line.get_label() for line in ax.lines][:2]
    ('log', ['FSM (eq 34) closed form', 'FSM simulated (CVODES)'])
    """
    from matplotlib.figure import Figure

    for m in MODES:
        _check_inputs(m, 10 * tau, tau, c1, c2, alpha)
    if x0_values is None:
        x0_values = np.geomspace(tau * 1.5, 10.0, 12)
    x0_values = [float(v) for v in x0_values]
    for v in x0_values:
        _check_inputs("fsm", v, tau, c1, c2, alpha)
    dense = np.geomspace(tau * 1.0001, max(x0_values) * 1.2, n_closed_form)
    fig = Figure(figsize=(7.0, 4.5), layout="constrained")
    ax = fig.add_subplot()
    colors = {"fsm": "C0", "tsm": "C1", "lsm": "C2"}
    for m in MODES:
        ax.plot(dense, [closed_form_settling_time(m, v, tau, c1, c2, alpha) for v in dense], color=colors[m],
                label=f"{MODE_LABELS[m]} closed form")  # fmt: skip
        ax.plot(x0_values, [measure_settling_time(m, v, tau, c1, c2, alpha).time_simulated_s for v in x0_values],
                "o", color=colors[m], mfc="none", label=f"{m.upper()} simulated (CVODES)")  # fmt: skip
    ax.set_xscale("log")
    ax.set_xlabel(r"$|x_0|$")
    ax.set_ylabel(r"settling time $T$ to $|x| \leq \tau$ (s)")
    ax.set_title(rf"Theorem 3: $c_1$ = {c1:g}, $c_2$ = {c2:g}, $\alpha$ = {alpha:g}, $\tau$ = {tau:g}")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return fig
