"""FSM vs TSM vs LSM in the full formation loop, and ``fsmctl compare-surfaces``.

Theorem 3 (Liang et al. 2012, Sec. 3.3, eqs 34-41) compares the three sliding surfaces on the
ideal sliding phase of a scalar error: FSM settles faster than TSM (same ``c2``) and LSM (same
``c1``).  This module asks whether that ordering survives in the closed loop of eqs 16-20 with
what the theorem leaves out: the reaching phase, the torque limit (saturation), the inertia
uncertainty and disturbance of Case 1 (eq 29), and the coupling through the topology (eq 19).

The surface is selected by the ``surface`` preset of the paper's law (``[controller] surface``: ``tsm`` sets
``c1 = 0``, ``lsm`` sets ``c2 = 0``).  Per agent it measures

* the reaching time: first time ``||s_i|| <= reach_threshold``;
* the settling time: first time after which every ``|sigma_ei,k| <= sigma_tolerance``;
* the sliding-phase time (settling minus reaching; negative when the attitude settled before
  ``s_i`` reached the threshold, i.e. the reaching phase did the work), next to Theorem 3's prediction
  ``max_k T_surface(|sigma_ei,k(t_reach)|, sigma_tolerance)`` (eqs 34-36, the closed forms of
  :mod:`fsmctl.studies.theorem3`), exact if ``s_i`` stayed 0 after reaching;
* the control effort ``int sum_k |u_ik| dt`` (N m s);

and per run the settling of AAEM and RAEM (eqs 42-43) to a tolerance, their steady state, the control effort,
the peak commanded torque and the saturated time.  The full-loop runs are a law comparison
(:func:`fsmctl.studies.compare.compare_laws`): per variant, three runs of the law ``fsm`` with
``surface = fsm``/``tsm``/``lsm``, whose run-level metrics are :func:`fsmctl.studies.compare.run_metrics`; the
per-agent quantities above are measured on each run's result by the comparison's ``on_result`` hook
(:mod:`fsmctl.studies.surface_measures`; the figures: :mod:`fsmctl.studies.surface_figures`).

Remark 6 (the ``alpha |sigma_e|^(alpha-1)`` singularity) is handled for TSM exactly as for FSM:
the generated code applies the scenario's ``singularity_fix`` (default ``switch``) to the term
``c2 sig(sigma_e)^alpha`` whatever ``c1`` is; :func:`remark6_treatment` reads the resulting slope
of the surface at ``sigma_e = 0`` from the paper's law's generated ``law_local_paper`` (its broadcast ``s``).
"""

from __future__ import annotations

import csv
import dataclasses
import math
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from fsmctl.model.scenario import Scenario, Sinusoid
from fsmctl.model.topology import Topology
from fsmctl.outputs import atomic_path, write_json
from fsmctl.policy import (
    SURFACE_METRIC_TOLERANCE,
    SURFACE_REACH_THRESHOLD,
    SURFACE_SIGMA_TOLERANCE,
    default_steady_window,
)
from fsmctl.studies.surface_figures import plot_agent_times, plot_error_metrics
from fsmctl.studies.surface_measures import SURFACES, _agent_rows, _run_row

__all__ = [
    "Variant",
    "default_variants",
    "variant_scenario",
    "remark6_treatment",
    "SurfaceComparison",
    "compare_surfaces",
]

PAPER_TORQUE_LIMIT_N_M = 2.0


@dataclass(frozen=True)
class Variant:
    """Which of saturation, uncertainty (dJ and disturbance, eq 29) and coupling (eq 19) are on.

    Parameters
    ----------
    torque_limit : bool
        Keep the scenario's torque limit (the paper's 2 N m if it has none); False: no limit.
    uncertainty : bool
        Keep the inertia uncertainty ``delta_J`` and the disturbance of eq 29; False: nominal plant.
    coupling : bool
        Keep the topology's links (eq 19); False: no links.

    Examples
    --------
    >>> from fsmctl.studies import Variant
    >>> Variant(torque_limit=True, uncertainty=False, coupling=True).name
    'limit/nominal/coupled'
    """

    torque_limit: bool
    uncertainty: bool
    coupling: bool

    @property
    def name(self) -> str:
        """``limit|no-limit / uncertain|nominal / coupled|uncoupled``: the variant's label in tables."""
        return "/".join(
            (
                "limit" if self.torque_limit else "no-limit",
                "uncertain" if self.uncertainty else "nominal",
                "coupled" if self.coupling else "uncoupled",
            )
        )


def default_variants() -> list[Variant]:
    """All eight combinations, the paper's (limit, uncertain, coupled) first.

    Returns
    -------
    list of Variant
        The eight variants.

    Examples
    --------
    >>> from fsmctl.studies import default_variants
    >>> [v.name for v in default_variants()][:2]
    ['limit/uncertain/coupled', 'limit/uncertain/uncoupled']
    """
    return [Variant(a, b, c) for a in (True, False) for b in (True, False) for c in (True, False)]


def variant_scenario(scenario: Scenario, variant: Variant, surface: str) -> Scenario:
    """The scenario with the surface set and the variant's features switched off where asked.

    ``torque_limit``: the scenario's limit (the paper's 2 N m if the scenario has none) or none;
    ``uncertainty`` off: ``delta_J = 0`` and no disturbance; ``coupling`` off: no links.

    Parameters
    ----------
    scenario : Scenario
        The base scenario.
    variant : Variant
        Which features stay on.
    surface : str
        ``"fsm"``, ``"tsm"`` or ``"lsm"`` (the paper's law's ``surface`` preset).

    Returns
    -------
    Scenario
        The modified scenario.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.studies import Variant
    >>> from fsmctl.studies.surfaces import variant_scenario
    >>> s = variant_scenario(fsmctl.paper_scenario("1"), Variant(False, True, False), "tsm")
    >>> s.law_parameters()[0]["c1"], s.controller.torque_limit, len(s.topology.links)
    (0.0, inf, 0)
    """
    limit = scenario.controller.torque_limit
    if variant.torque_limit and not math.isfinite(limit):
        limit = PAPER_TORQUE_LIMIT_N_M
    s = scenario.replace(controller={"surface": surface, "torque_limit": limit if variant.torque_limit else math.inf})
    if not variant.uncertainty:
        zero = tuple(tuple(0.0 for _ in row) for row in scenario.agents[0].J0)
        s = s.with_agents([dataclasses.replace(a, delta_J=zero, disturbance=Sinusoid()) for a in s.agents])
    if not variant.coupling:
        s = s.with_topology(Topology(s.n_agents, ()))
    return s


# ----------------------------------------------------------------------------- Remark 6


def _paper_law_scenario(scenario: Scenario, surface: str | None = None) -> Scenario:
    """The scenario flying the paper's law (with a surface preset), as :func:`compare_surfaces` flies it."""
    return scenario.replace(controller={"law": "fsm"} if surface is None else {"law": "fsm", "surface": surface})


def remark6_treatment(scenario: Scenario) -> list[dict]:
    """Slope ``ds/dsigma_e`` of each surface at ``sigma_e = 0`` and at the band edge, from the generated code.

    The surface ``s = sigma_e_dot + c1 sigma_e + c2 phi(sigma_e)`` (eq 13) with the Remark 6 fix
    ``phi`` has slope ``c1 + c2 phi'(x)``; without a fix ``phi'(x) = alpha |x|^(alpha-1)`` is
    infinite at 0 for FSM and TSM.  With ``switch`` the slope at 0 is finite, so inside the band
    ``|x| < epsilon`` the sliding mode is linear with that rate (exponential, not finite-time).

    Parameters
    ----------
    scenario : Scenario
        The scenario whose ``[controller]`` (gains, ``epsilon``, ``singularity_fix``) is used for every surface.

    Returns
    -------
    list of dict
        Per surface: ``slope_at_zero_per_s``, ``slope_at_band_edge_per_s``, ``band_time_constant_s``,
        the fix and ``epsilon`` (of the first agent); computed by CasADi AD of the sliding variable ``s`` that the
        paper's law broadcasts (its generated ``law_local_paper``) with respect to the attitude, at
        ``sigma_d = 0`` and no rotation (there ``sigma_e = sigma`` and ``sigma_e_dot = 0``).

    Examples
    --------
    Case 1 (``c1 = 0.6``, ``c2 = 0.8``, ``alpha = 0.7``, ``epsilon = 1e-4``): at the band edge the FSM slope is
    ``c1 + c2 alpha epsilon^(alpha - 1) = 0.6 + 0.56 * 10^1.2 = 9.475`` 1/s; LSM's is ``c1`` everywhere:

    >>> import fsmctl
    >>> from fsmctl.studies.surfaces import remark6_treatment
    >>> rows = remark6_treatment(fsmctl.paper_scenario("1"))
    >>> [(r["surface"], round(r["slope_at_band_edge_per_s"], 3)) for r in rows]
    [('fsm', 9.475), ('tsm', 8.875), ('lsm', 0.6)]
    """
    import casadi as ca

    from fsmctl.model.generated_code import law_sx_function
    from fsmctl.model.laws import parameter_matrix

    x = ca.SX.sym("x", 3)
    z = ca.DM.zeros(3)
    out = []
    for surface in SURFACES:
        sc = _paper_law_scenario(scenario, surface)
        law, values = sc.law, sc.law_parameters()[0]
        params = parameter_matrix(law, sc)[0]
        local = law_sx_function(law.folder, "law_local_paper")  # at sigma_d = 0, omega = 0 both error models agree
        constants = law_sx_function(law.folder, "law_constants")(params)
        # s(sigma) at omega = 0, sigma_d = 0, omega_d = 0: c1 sigma_e + c2 phi(sigma_e) (eq 13, Remark 6's phi)
        s = local(0, x, z, ca.DM.zeros(law.n_states), z, z, z, ca.DM.eye(3), params, constants)[0]
        slope = ca.Function("slope", [x], [ca.jacobian(s, x)[0, 0]])
        at_zero = float(slope(z))
        edge = float(slope(ca.DM([values["epsilon"] * (1 + 1e-9), 0.0, 0.0])))
        out.append(
            {
                "surface": surface,
                "singularity_fix": values["singularity_fix"],
                "epsilon": values["epsilon"],
                "c1_used": values["c1"],
                "c2_used": values["c2"],
                "slope_at_zero_per_s": at_zero,
                "slope_at_band_edge_per_s": edge,
                "band_time_constant_s": 1.0 / at_zero if math.isfinite(at_zero) and at_zero > 0 else math.nan,
            }
        )
    return out


def _faster(a: float, b: float) -> str:
    """'yes' if a < b (NaN = did not settle = infinitely slow), 'no', or 'n/a' when neither settles."""
    fa, fb = math.isfinite(a), math.isfinite(b)
    if not fa and not fb:
        return "n/a"
    if fa and not fb:
        return "yes"
    if fb and not fa:
        return "no"
    return "yes" if a < b else "no"


@dataclass
class SurfaceComparison:
    """Results of :func:`compare_surfaces`: per-run and per-agent rows, ordering verdicts, Remark 6, time series.

    Parameters
    ----------
    scenario_label : str
        The compared scenario (and case).
    settings : dict
        Thresholds, tolerances, horizon and variants of the comparison.
    runs : list of dict
        One row per (variant, surface): AAEM/RAEM settling (eqs 42-43), reaching and sliding times (means over
        agents), Theorem 3's prediction, control effort, saturated time.
    agents : list of dict
        One row per (variant, surface, agent): reaching, settling and sliding-phase times, effort.
    series : dict, optional
        Time series per run (AAEM, RAEM) for the figures.
    remark6 : list of dict, optional
        :func:`remark6_treatment` of the scenario.
    scalar : dict, optional
        Summary of the scalar Theorem 3 check (empty without it).
    wall_time_s : float, optional
        Wall time of the whole comparison.
    scalar_study : fsmctl.studies.theorem3.ScalarStudy or None, optional
        The study behind ``scalar`` (None without the scalar check).
    law_comparisons : dict, optional
        Variant name -> the :class:`~fsmctl.studies.compare.Comparison` of its three surfaces (table, series).

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.studies import Variant, compare_surfaces
    >>> c = compare_surfaces(fsmctl.paper_scenario("1"), t_final=1.0, variants=[Variant(True, True, True)],
    ...                      scalar_check=False, workers=1, progress=False)
    >>> c.run_row("limit/uncertain/coupled", "fsm")["n_agents"]
    6
    >>> [o["metric"] for o in c.ordering()]
    ['aaem_settling_s', 'raem_settling_s', 'mean_sliding_phase_time_s']
    >>> sorted(p.name for p in c.write("out", figures=False))
    ['surfaces.json', 'surfaces_agents.csv', 'surfaces_ordering.csv', 'surfaces_runs.csv']
    """

    scenario_label: str
    settings: dict
    runs: list[dict]
    agents: list[dict]
    series: dict = field(default_factory=dict)
    remark6: list[dict] = field(default_factory=list)
    scalar: dict = field(default_factory=dict)
    wall_time_s: float = 0.0
    scalar_study: object = field(default=None, repr=False)
    """the :class:`fsmctl.studies.theorem3.ScalarStudy` behind ``scalar`` (None without the scalar check)"""
    law_comparisons: dict = field(default_factory=dict, repr=False)
    """variant name -> the :class:`fsmctl.studies.compare.Comparison` of its three surfaces (table, series)"""

    def run_row(self, variant: str, surface: str) -> dict:
        """The row of one run.

        Parameters
        ----------
        variant : str
            The variant's name (:attr:`Variant.name`).
        surface : str
            ``"fsm"``, ``"tsm"`` or ``"lsm"``.

        Returns
        -------
        dict
            The row of :attr:`runs`.

        Raises
        ------
        StopIteration
            No such run.
        """
        return next(r for r in self.runs if r["variant"] == variant and r["surface"] == surface)

    def ordering(self) -> list[dict]:
        """Per variant and metric: does FSM beat TSM and LSM (Theorem 3's ordering, eqs 37-41)?"""
        out = []
        variants = list(dict.fromkeys(r["variant"] for r in self.runs))
        for v in variants:
            for metric in ("aaem_settling_s", "raem_settling_s", "mean_sliding_phase_time_s"):
                t = {s: self.run_row(v, s)[metric] for s in SURFACES}
                if metric == "mean_sliding_phase_time_s" and any(x < 0 for x in t.values() if math.isfinite(x)):
                    # some agent's attitude settled before its s_i reached the threshold: no sliding phase to compare
                    out.append({"variant": v, "metric": metric, **{f"{s}_s": t[s] for s in SURFACES},
                                "fsm_faster_than_tsm": "n/a (settled before reaching)",
                                "fsm_faster_than_lsm": "n/a (settled before reaching)"})  # fmt: skip
                    continue
                out.append(
                    {
                        "variant": v,
                        "metric": metric,
                        **{f"{s}_s": t[s] for s in SURFACES},
                        "fsm_faster_than_tsm": _faster(t["fsm"], t["tsm"]),
                        "fsm_faster_than_lsm": _faster(t["fsm"], t["lsm"]),
                    }
                )
        return out

    def outcome_line(self) -> str:
        """The result in one plain line: in how many variants FSM settles AAEM first (Theorem 3's ordering).

        Returns
        -------
        str
            ``"Theorem 3's ordering (FSM settles AAEM before TSM and LSM, eqs 37-41): holds in K of N variants
            (...), fails in ..., undecided in ... (no surface settles)"``.
        """
        rows = [o for o in self.ordering() if o["metric"] == "aaem_settling_s"]
        groups: dict[str, list[str]] = {"holds": [], "fails": [], "undecided": []}
        for o in rows:
            verdicts = (o["fsm_faster_than_tsm"], o["fsm_faster_than_lsm"])
            key = "holds" if verdicts == ("yes", "yes") else "fails" if "no" in verdicts else "undecided"
            groups[key].append(o["variant"])
        parts = [f"holds in {len(groups['holds'])} of {len(rows)} variants"]
        parts[0] += f" ({', '.join(groups['holds'])})" if groups["holds"] else ""
        if groups["fails"]:
            parts.append(f"fails in {len(groups['fails'])} ({', '.join(groups['fails'])})")
        if groups["undecided"]:
            parts.append(f"undecided in {len(groups['undecided'])} (not every surface settles)")
        return "Theorem 3's ordering (FSM settles AAEM before TSM and LSM, eqs 37-41): " + "; ".join(parts)

    def table(self) -> str:
        """Plain-text table: first :meth:`outcome_line`, then one line per run, then the ordering verdicts."""
        tol = self.settings["metric_tolerance_deg"]
        head = (
            f"{'variant':<28} {'surf':<4} {'AAEM<' + format(tol, 'g') + 'deg':>11} {'RAEM<' + format(tol, 'g') + 'deg':>11} "
            f"{'AAEM_ss':>9} {'reached':>7} {'reach':>7} {'slide':>7} {'slide_T3':>8} {'effort':>9} {'sat_max':>7}"
        )
        units = (
            f"{'':<28} {'':<4} {'s':>11} {'s':>11} {'deg':>9} {'agents':>7} {'s':>7} {'s':>7} {'s':>8} {'N m s':>9} "
            f"{'s':>7}"
        )
        lines = [self.outcome_line(), f"compare-surfaces: {self.scenario_label}", head, units]
        for r in self.runs:
            lines.append(
                f"{r['variant']:<28} {r['surface']:<4} {_fmt(r['aaem_settling_s']):>11} {_fmt(r['raem_settling_s']):>11} "
                f"{_fmt(r['aaem_steady_max_deg'], '.3g'):>9} {str(r['agents_reached']) + '/' + str(r['n_agents']):>7} "
                f"{_fmt(r['mean_reaching_time_s']):>7} "
                f"{_fmt(r['mean_sliding_phase_time_s']):>7} {_fmt(r['mean_sliding_phase_theorem3_s']):>8} "
                f"{_fmt(r['control_effort_N_m_s'], '.4g'):>9} {_fmt(r['max_saturated_time_s'], '.1f'):>7}"
            )
        lines.append("")
        lines.append(
            "reach/slide are means over agents: nan unless every agent reached the surface (|s| below the threshold)"
        )
        lines.append("Theorem 3 ordering (nan = not settled within the horizon): FSM faster than TSM / than LSM")
        for o in self.ordering():
            lines.append(
                f"  {o['variant']:<28} {o['metric']:<26} fsm {_fmt(o['fsm_s'])} tsm {_fmt(o['tsm_s'])} "
                f"lsm {_fmt(o['lsm_s'])}: vs TSM {o['fsm_faster_than_tsm']}, vs LSM {o['fsm_faster_than_lsm']}"
            )
        lines.append("")
        lines.append("Remark 6 fix per surface (slope ds/dsigma_e of the generated surface):")
        for r in self.remark6:
            lines.append(
                f"  {r['surface']}: fix={r['singularity_fix']} eps={r['epsilon']:g} c1={r['c1_used']:g} c2={r['c2_used']:g} "
                f"slope at 0 = {r['slope_at_zero_per_s']:.4g} 1/s, at the band edge = {r['slope_at_band_edge_per_s']:.4g} 1/s"
            )
        if self.scalar:
            lines.append(
                f"scalar Theorem 3 check: {self.scalar['n_measurements']} simulated settling times, max relative error "
                f"{self.scalar['max_relative_error']:.2e} vs eqs 34-36; ordering holds everywhere: "
                f"{self.scalar['ordering_holds_everywhere']}"
            )
        lines.append(f"reach: first ||s_i|| <= {self.settings['reach_threshold']:g}; slide: until every "
                     f"|sigma_ei,k| <= {self.settings['sigma_tolerance']:g} for good; slide_T3: Theorem 3 (eqs 34-36) "
                     f"from sigma_e at reaching; effort: sum_i int sum_k |u_ik| dt")  # fmt: skip
        lines.append(f"wall time {self.wall_time_s:.1f} s")
        return "\n".join(lines)

    def to_json(self) -> dict:
        """Scenario, settings, runs, agents, ordering, Remark 6 and the scalar check, as JSON-able data.

        Returns
        -------
        dict
            What ``surfaces.json`` holds.
        """
        return {
            "scenario": self.scenario_label,
            "settings": self.settings,
            "runs": self.runs,
            "agents": self.agents,
            "ordering": self.ordering(),
            "remark6": self.remark6,
            "scalar_theorem3": self.scalar,
            "wall_time_s": self.wall_time_s,
        }

    def write(self, out_dir: str | Path, *, figures: bool = True) -> list[Path]:
        """Write ``surfaces_runs.csv``, ``surfaces_agents.csv``, ``surfaces_ordering.csv``, ``surfaces.json``, figures.

        Every file is written atomically; the folder is created if needed.

        Parameters
        ----------
        out_dir : str or pathlib.Path
            The output folder.
        figures : bool, optional
            Also write the figures (PNG and SVG), default True.

        Returns
        -------
        list of pathlib.Path
            The files written.
        """
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        paths = [
            _write_csv(out / "surfaces_runs.csv", self.runs),
            _write_csv(out / "surfaces_agents.csv", self.agents),
            _write_csv(out / "surfaces_ordering.csv", self.ordering()),
        ]
        paths.append(write_json(out / "surfaces.json", self.to_json(), indent=1))
        if figures:
            for name, fig in (
                ("surfaces_error_metrics", plot_error_metrics(self)),
                ("surfaces_agents", plot_agent_times(self)),
            ):
                for ext in ("png", "svg"):
                    fp = out / f"{name}.{ext}"
                    with atomic_path(fp) as tmp:
                        fig.savefig(tmp, dpi=120, format=ext)
                    paths.append(fp)
        return paths


def _fmt(v: float, spec: str = ".2f") -> str:
    return "nan" if v is None or not math.isfinite(v) else format(v, spec)


def _write_csv(path: Path, rows: list[dict]) -> Path:
    with atomic_path(path) as tmp, tmp.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return path


def compare_surfaces(
    scenario: Scenario,
    *,
    fast: bool = False,
    t_final: float | None = None,
    variants: Sequence[Variant] | None = None,
    reach_threshold: float = SURFACE_REACH_THRESHOLD,
    sigma_tolerance: float = SURFACE_SIGMA_TOLERANCE,
    metric_tolerance_deg: float = SURFACE_METRIC_TOLERANCE,
    workers: int | None = None,
    scalar_check: bool = True,
    progress: bool | None = None,
) -> SurfaceComparison:
    """Run the scenario with each sliding surface under each variant and measure Theorem 3's quantities.

    Parameters
    ----------
    scenario : Scenario
        Base scenario (e.g. :func:`fsmctl.paper_scenario`).
    fast : bool
        10 s horizon at dt = 2 ms, and the small scalar grid (for tests and notebooks).
    t_final : float, optional
        Horizon in s (default: the scenario's; 10 s with ``fast``).
    variants : sequence of Variant, optional
        Default :func:`default_variants` (limit x uncertainty x coupling).
    reach_threshold : float
        ``||s_i||`` below which agent i counts as having reached the surface.
    sigma_tolerance : float
        Target ``tau`` of Theorem 3 for every ``|sigma_ei,k|`` (MRP); keep it above the Remark 6 band ``epsilon``.
    metric_tolerance_deg : float
        Tolerance of the AAEM/RAEM settling times (eqs 42-43).
    workers : int, optional
        Variants simulated at the same time, in threads of the campaign runner
        (:class:`fsmctl.studies.campaign.Runner`; the compiled loop releases the GIL); 1 runs them in turn.
        Default: one per CPU, at most one per variant (:func:`fsmctl.policy.default_workers` of the number of
        variants).  The results do not depend on it.
    scalar_check : bool
        Also run the scalar Theorem 3 grid (:func:`fsmctl.studies.theorem3.scalar_settling_study`).
    progress : bool, optional
        tqdm progress bar (default: on a terminal).

    Returns
    -------
    SurfaceComparison
        Per-run and per-agent rows, the ordering verdicts (:meth:`SurfaceComparison.ordering`), Remark 6's slopes
        and the scalar check.

    Raises
    ------
    fsmctl.errors.InputError
        A tolerance or threshold that is not a finite positive number, ``sigma_tolerance`` inside the Remark 6 band
        ``epsilon``, ``workers < 1`` or a non-positive ``t_final``.

    Examples
    --------
    One variant (the paper's: torque limit, uncertainty, coupling), a 1 s horizon, no scalar grid:

    >>> import fsmctl
    >>> from fsmctl.studies import Variant, compare_surfaces
    >>> c = compare_surfaces(fsmctl.paper_scenario("1"), t_final=1.0, variants=[Variant(True, True, True)],
    ...                      scalar_check=False, workers=1, progress=False)
    >>> [(r["variant"], r["surface"]) for r in c.runs]
    [('limit/uncertain/coupled', 'fsm'), ('limit/uncertain/coupled', 'tsm'), ('limit/uncertain/coupled', 'lsm')]
    >>> all(r["control_effort_N_m_s"] > 0 for r in c.runs), len(c.agents)
    (True, 18)
    """
    from fsmctl.errors import InputError
    from fsmctl.parallel import resolve_workers
    from fsmctl.simulation.simulator import SimulationError
    from fsmctl.studies.campaign import Runner, Task
    from fsmctl.studies.compare import LawRun, compare_laws

    for name, v in (("reach_threshold", reach_threshold), ("sigma_tolerance", sigma_tolerance),
                    ("metric_tolerance_deg", metric_tolerance_deg)):  # fmt: skip
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise InputError(f"{name} must be a finite number > 0, got {v}")
    band = max(v["epsilon"] for v in _paper_law_scenario(scenario).law_parameters())
    if sigma_tolerance <= band:
        raise InputError(
            f"sigma_tolerance = {sigma_tolerance:g} must exceed the Remark 6 band epsilon = {band:g} "
            "(inside the band the surface is linear and Theorem 3 does not apply)"
        )
    sim = {}
    if fast:
        sim = {"t_final": 10.0, "dt": 0.002, "output_interval": 0.02}
    if t_final is not None:
        if not (math.isfinite(t_final) and t_final > 0):
            raise InputError(f"t_final must be > 0, got {t_final}")
        sim["t_final"] = float(t_final)
    base = scenario.replace(simulation=sim) if sim else scenario
    variants = list(default_variants() if variants is None else variants)
    workers = resolve_workers(workers, len(variants), "compare_surfaces")
    opts = {
        "reach_threshold": reach_threshold,
        "sigma_tolerance": sigma_tolerance,
        "metric_tolerance_deg": metric_tolerance_deg,
    }
    if progress is None:
        progress = sys.stderr.isatty()
    start = time.perf_counter()

    def one(v: Variant):
        """The three surfaces of one variant: a law comparison of the law ``fsm`` with surface = fsm/tsm/lsm."""
        runs = [LawRun(s, "fsm", {"surface": s}) for s in SURFACES]
        return compare_laws(
            variant_scenario(base, v, "fsm"),
            runs,
            tolerances_deg=(metric_tolerance_deg,),
            steady_window_s=default_steady_window(base.simulation.t_final),
            workers=1,  # the variants run in parallel, each one's three surfaces in turn
            on_result=lambda run, result: _agent_rows(result, run.label, v, opts),
        )

    with Runner(workers=workers, threads=True, name="compare-surfaces", interrupts=False) as runner:
        runner.progress(len(variants), unit="variant", enabled=progress)
        comparisons = runner.run([Task(v.name, one, (v,)) for v in variants])
    runs, agents, series = [], [], {}
    for v, comp in zip(variants, comparisons, strict=True):
        if comp.failures:
            label, reason = comp.failures[0]
            raise SimulationError(f"compare-surfaces, {v.name}, {label}: {reason}")
        for s in SURFACES:
            runs.append(_run_row(comp.record(s), comp.extras[s], v, base.simulation.t_final, opts))
            agents += comp.extras[s]
            series[(v.name, s)] = comp.series[s]
    scalar = {}
    if scalar_check:
        from fsmctl.studies.theorem3 import default_extreme_grid, fast_grid, scalar_settling_study

        study = scalar_settling_study(fast_grid() if fast else default_extreme_grid(), progress=progress)
        scalar = study.summary()
        scalar["study"] = study
    settings = {
        **opts,
        "t_final_s": base.simulation.t_final,
        "dt_s": base.simulation.dt,
        "fast": fast,
        "variants": [v.name for v in variants],
        "controller": dataclasses.asdict(base.controller),
    }
    comp = SurfaceComparison(
        scenario_label=base.label,
        settings=settings,
        runs=runs,
        agents=agents,
        series=series,
        remark6=remark6_treatment(base),
        scalar={k: v for k, v in scalar.items() if k != "study"},
        wall_time_s=time.perf_counter() - start,
        scalar_study=scalar.get("study"),
        law_comparisons={v.name: c for v, c in zip(variants, comparisons, strict=True)},
    )
    return comp
