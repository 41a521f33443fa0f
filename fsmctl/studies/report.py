"""The report of ``fsmctl reproduce``: ``report.md``, ``claims.csv``, ``claims.json`` and the terminal summary.

:class:`Reproduction` is everything :func:`fsmctl.studies.reproduce.reproduce` computed; :func:`write_outputs` writes
its files (each run's entry by :meth:`fsmctl.studies.records.RunRecord.to_json`), :func:`to_markdown` is the report
and :func:`format_claims` the plain-text claims table.
"""

from __future__ import annotations

import csv
import math
import textwrap
from dataclasses import asdict, dataclass
from pathlib import Path

from fsmctl.outputs import atomic_path, write_json, write_text
from fsmctl.policy import SETTLING_TOLERANCES_DEG, STEADY_WINDOW_FRACTION
from fsmctl.studies.claim_types import PAPER_SETTLING_TIME_S, VERDICTS, ClaimVerdict
from fsmctl.studies.explain_report import markdown_section, text_lines
from fsmctl.studies.momentum import MomentumBound
from fsmctl.studies.records import RunRecord

__all__ = ["Reproduction", "write_outputs", "to_markdown", "format_claims"]


@dataclass
class Reproduction:
    """Everything ``fsmctl reproduce`` computed and wrote (:func:`~fsmctl.studies.reproduce.reproduce`).

    Parameters
    ----------
    out_dir : Path
        The output folder.
    fast : bool
        Whether the runs used the short horizon.
    scenario_lines : list of str
        Case 1's settings and the choices the paper leaves open, one per line.
    records : dict of str -> RunRecord
        Every run of :func:`~fsmctl.studies.paper_runs.run_plan`, in its order.
    bounds : list of MomentumBound
        :func:`~fsmctl.studies.momentum.angular_momentum_bound` of Case 1.
    claims : list of ClaimVerdict
        :func:`~fsmctl.studies.claims.evaluate_claims`.
    inertia_check : list of dict
        Principal moments of J0 and J0 + ΔJ per agent, with the triangle inequality.
    files : list of str
        Every written run and figure file.
    wall_time_s : float
        Wall time of the reproduction (s).
    explanations : list, optional
        :class:`fsmctl.studies.explain.Explanation` per claim and figure check (None: not searched).
    explain_wall_time_s : float
        Wall time of the explanations (s).

    Examples
    --------
    :func:`~fsmctl.studies.reproduce.reproduce` returns one; here one assembled from 1 s runs, to read it:

    >>> from pathlib import Path
    >>> from fsmctl import paper_scenario, simulate
    >>> from fsmctl.studies.claims import evaluate_claims
    >>> from fsmctl.studies.momentum import angular_momentum_bound
    >>> from fsmctl.studies.paper_runs import run_plan, run_record, run_scenario
    >>> def one_second(spec):  # a run of the plan, 1 s long (the reproduction flies 100 s)
    ...     scenario = run_scenario("paper", spec, fast=True).replace(simulation={"t_final": 1.0})
    ...     return run_record(spec, scenario, simulate(scenario, progress=False))
    >>> records = {spec.key: one_second(spec) for spec in run_plan()}
    >>> bounds = angular_momentum_bound(paper_scenario("1"))
    >>> rep = Reproduction(Path("out"), True, ["paper case 1"], records, bounds, evaluate_claims(records, bounds),
    ...                    inertia_check=[], files=[], wall_time_s=0.0)
    >>> rep.claims_table()[0]["verdict"]
    'impossible (bound)'
    >>> list(rep.records)[:3]
    ['case1', 'case2', 'case3a']
    """

    out_dir: Path
    fast: bool
    scenario_lines: list[str]
    records: dict[str, RunRecord]
    bounds: list[MomentumBound]
    claims: list[ClaimVerdict]
    inertia_check: list[dict]
    files: list[str]
    wall_time_s: float
    explanations: list | None = None
    """:class:`fsmctl.studies.explain.Explanation` per claim and figure check (None: not searched)"""
    explain_wall_time_s: float = 0.0

    def claims_table(self) -> list[dict]:
        """The claims as a list of dicts (one per claim).

        Returns
        -------
        list of dict
            The fields of each :class:`ClaimVerdict`.
        """
        return [asdict(c) for c in self.claims]

    def dataset(self, key: str):
        """The full time series of run ``key`` as an :class:`xarray.Dataset` (loaded from its NetCDF file).

        Parameters
        ----------
        key : str
            A run of :func:`~fsmctl.studies.paper_runs.run_plan` (``"case1"``, ``"case1_no_torque_limit"``, ...).

        Returns
        -------
        xarray.Dataset
            Variables with units in their names and attributes (see
            :meth:`fsmctl.simulation.simulator.SimulationResult.to_dataset`).

        Raises
        ------
        KeyError
            If there is no run ``key``.
        """
        import xarray as xr

        if key not in self.records:
            raise KeyError(f"no run {key!r} (runs: {list(self.records)})")
        with xr.open_dataset(self.records[key].netcdf) as ds:
            return ds.load()


def _md_escape(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def write_outputs(rep: Reproduction) -> list[Path]:
    """Write ``claims.csv``, ``claims.json`` and ``report.md`` into ``rep.out_dir``.

    Parameters
    ----------
    rep : Reproduction
        From :func:`~fsmctl.studies.reproduce.reproduce`.

    Returns
    -------
    list of Path
        The three files.

    Examples
    --------
    >>> from pathlib import Path
    >>> rep = one_second_reproduction()  # conftest.py: the Reproduction example's 1 s runs (shared)
    >>> [p.name for p in write_outputs(rep)]
    ['claims.csv', 'claims.json', 'report.md']
    >>> Path("out/claims.csv").read_text().splitlines()[1].split(",")[0]
    'settling_27s'
    """
    out = rep.out_dir
    csv_path, json_path, md_path = out / "claims.csv", out / "claims.json", out / "report.md"
    fields = list(ClaimVerdict.__dataclass_fields__)
    with atomic_path(csv_path) as tmp, tmp.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields)
        writer.writeheader()
        for c in rep.claims:
            writer.writerow(asdict(c))
    runs = {k: r.to_json(out, SETTLING_TOLERANCES_DEG) for k, r in rep.records.items()}
    payload = {
        "source": "Liang, Sun & Wang, Acta Astronautica 81 (2012) 445-455, Section 4",
        "fast": rep.fast,
        "verdict_kinds": list(VERDICTS),
        "settling_tolerances_deg": list(SETTLING_TOLERANCES_DEG),
        "claims": rep.claims_table(),
        "angular_momentum_bound": [asdict(b) for b in rep.bounds],
        "inertia_check": rep.inertia_check,
        "scenario": rep.scenario_lines,
        "runs": runs,
        "wall_time_s": rep.wall_time_s,
    }
    if rep.explanations is not None:
        payload["explanations"] = [e.to_dict() for e in rep.explanations]
        payload["explain_wall_time_s"] = rep.explain_wall_time_s
    write_json(json_path, payload)
    write_text(md_path, to_markdown(rep))
    return [csv_path, json_path, md_path]


def to_markdown(rep: Reproduction) -> str:
    """The reproduction report (Markdown).

    Parameters
    ----------
    rep : Reproduction
        From :func:`~fsmctl.studies.reproduce.reproduce`.

    Returns
    -------
    str
        Claims table, the angular-momentum bound per agent, the numbers of every run, the choices, and the
        figures: the paper's Figs 1-9 in their order, then the diagnostic figures.

    Examples
    --------
    >>> rep = one_second_reproduction()  # conftest.py: the Reproduction example's 1 s runs (shared)
    >>> text = to_markdown(rep)
    >>> [line for line in text.splitlines() if line.startswith("## ")][:3]
    ['## Claims', '## Angular-momentum bound (independent of the controller)', '## Initial numbers (Table 1 and the reference, t = 0)']
    """
    R = rep.records
    c1 = R["case1"]
    out = rep.out_dir
    L: list[str] = []
    L += [
        "# Reproduction of Liang, Sun & Wang (2012), Section 4",
        "",
        f"`fsmctl reproduce`{' --fast' if rep.fast else ''}: {len(R)} runs in {rep.wall_time_s:.1f} s wall time"
        + (f" (the explanations: {rep.explain_wall_time_s:.1f} s)." if rep.explanations is not None else ".")
        + (" **Fast mode: short horizon, the verdicts are not those of the paper's 100 s runs.**" if rep.fast else ""),
        "",
        "Verdicts: `reproduced`; `differs` (the reason, with the diagnostic run that shows it); "
        "`impossible (bound)` (no controller within the paper's torque limit can do it, by the bound below).",
        "",
        "## Claims",
        "",
        "| claim | figures | paper | this run | verdict | reason | diagnostic runs |",
        "|---|---|---|---|---|---|---|",
    ]
    for c in rep.claims:
        L.append(
            "| "
            + " | ".join(
                _md_escape(x)
                for x in (
                    f"**{c.id}**: {c.claim}",
                    c.figures,
                    c.paper_value,
                    c.this_run_value,
                    f"**{c.verdict}**",
                    c.reason,
                    c.diagnostic_runs or "-",
                )
            )
            + " |"
        )
    if rep.explanations is not None:
        L += ["", *markdown_section(rep.explanations, rep.fast)]
        L.pop()
    b0 = rep.bounds[0]
    L += [
        "",
        "## Angular-momentum bound (independent of the controller)",
        "",
        "In the inertial frame N the angular momentum of spacecraft i is H = [BN]^T J ω with the true inertia "
        "J = J0 + ΔJ (eq 29), and dH/dt = [BN]^T (u + d). With |u_k| ≤ u_max per body axis, "
        "|dH/dt| ≤ √3 u_max + |d(t)|. Tracking the reference at time T means H(T) = H_d(T) = [DN]^T J ω_d(T) "
        "(reference integrated open loop from σ_d(0), eq 3), so any settling time T satisfies "
        "|H_d(T) − H(0)| ≤ √3 u_max T + ∫₀ᵀ |d| dt. The table gives the smallest such T (to the grid step "
        f"{b0.grid_step_s:g} s, rounded down), without and with the disturbance helping at full magnitude, and the "
        "naive |J ω(0)| / (√3 u_max). 'Settled' here means ω_i = ω_d in the body frame, which a metric that stays "
        "within its tolerance requires up to a small residual rate.",
        "",
        "| agent | u_max (N m) | \\|H(0)\\| (N m s) | \\|H(0) − H_d(0)\\| (N m s) | naive (s) | bound, no disturbance (s) "
        "| bound with disturbance (s) | vs 27 s |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for b in rep.bounds:
        flag = "exceeds" if b.min_time_s > PAPER_SETTLING_TIME_S else "below"
        L.append(
            f"| {b.agent} | {b.torque_limit_N_m:g} | {b.H0_N_m_s:.2f} | {b.H0_minus_Hd0_N_m_s:.2f} | "
            f"{b.naive_time_s:.2f} | {b.min_time_no_disturbance_s:.2f} | {b.min_time_s:.2f} | {flag} |"
        )
    L += [
        "",
        "## Initial numbers (Table 1 and the reference, t = 0)",
        "",
        f"- AAEM(0) = {c1.summary['aaem_initial_deg']:.2f}°, RAEM(0) = {c1.summary['raem_initial_deg']:.2f}°; "
        f"peaks over Case 1: AAEM {c1.summary['aaem_peak_deg']:.2f}°, RAEM {c1.summary['raem_peak_deg']:.2f}°, "
        f"θ_ei {c1.theta_e_peak_deg:.2f}°.",
        "- θ_ei(0) = " + ", ".join(f"{x:.2f}° (agent {i + 1})" for i, x in enumerate(c1.theta_e0_deg)) + ".",
        "- The paper's figure axes reach AAEM ≈ 300°, RAEM ≈ 140°, θ_i ≈ 200°. Here θ_ei = 4 atan|σ_ei| with σ_ei "
        "in the shadow set (|σ| ≤ 1), so θ_ei ≤ 180° and AAEM ≤ 180°; axes beyond 180° suggest the paper did not "
        "switch its error MRPs to the shadow set (then θ ranges up to 360°).",
        "",
        "## Runs",
        "",
        f"Settling time to a tolerance: the first time after which the metric stays at or below it "
        f"(`fsmctl.simulation.metrics.settling_time`); the paper does not state its tolerance, so {', '.join(f'{t:g}°' for t in SETTLING_TOLERANCES_DEG)} "
        f"are reported. Steady-state accuracy: the maximum over the last {STEADY_WINDOW_FRACTION:.0%} of the horizon.",
        "",
        "| run | overrides | horizon (s) | AAEM settling (s) at "
        + " / ".join(f"{t:g}°" for t in SETTLING_TOLERANCES_DEG)
        + " | RAEM settling (s) | steady AAEM / RAEM (deg) | saturated time per agent (s) | last saturation (s) "
        "| peak commanded (N m) | file |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]

    def sett(r: RunRecord, m: str) -> str:
        return " / ".join(
            "–" if not math.isfinite(x) else f"{x:.2f}" for x in (r.settling(m, t) for t in SETTLING_TOLERANCES_DEG)
        )

    for r in R.values():
        sat = r.saturated_time_s
        nc = Path(r.netcdf)
        rel = nc.relative_to(out) if nc.is_relative_to(out) else nc
        last = r.last_saturation_s
        overrides = r.overrides + (f" (identical settings to {r.same_as}: not re-run)" if r.same_as else "")
        L.append(
            f"| {r.key} | {_md_escape(overrides)} | {r.t_final:g} | {sett(r, 'aaem')} | {sett(r, 'raem')} | "
            f"{r.aaem_steady_max_deg:.3g} / {r.raem_steady_max_deg:.3g} | "
            f"{min(sat):.1f}–{max(sat):.1f} | {'never' if not math.isfinite(last) else f'{last:.2f}'} | "
            f"{r.commanded_peak_N_m:.4g} | [{rel}]({rel}) |"
        )
    L += ["", "(– : not settled within the horizon.)", "", "## Inertia check", ""]
    L += ["| agent | inertia | principal moments (kg m²) | J1 + J2 − J3 (kg m²) |", "|---|---|---|---|"]
    for row in rep.inertia_check:
        m = ", ".join(f"{x:.4f}" for x in row["principal_moments_kg_m2"])
        note = " (violates the rigid-body triangle inequality)" if row["J1_plus_J2_minus_J3_kg_m2"] < 0 else ""
        L.append(f"| {row['agent']} | {row['inertia']} | {m} | {row['J1_plus_J2_minus_J3_kg_m2']:.3g}{note} |")
    L += ["", "## Settings and the choices the paper leaves open", "", "```", *rep.scenario_lines, "```", ""]
    figs = _in_paper_order(f for f in rep.files if f.endswith(".png"))
    if figs:
        L += ["## Figures", ""]
        for f in figs:
            p = Path(f)
            rel = p.relative_to(out) if p.is_relative_to(out) else p
            L += [f"![{p.stem}]({rel})", ""]
    return "\n".join(L) + "\n"


def _in_paper_order(paths) -> list[str]:
    """Figure files in the paper's order: ``figNN_*`` by NN (Figs 1-9), then the others (diagnostics) by name."""

    def key(path: str) -> tuple[int, int, str]:
        stem = Path(path).stem
        if stem.startswith("fig") and stem[3:5].isdigit():
            return (0, int(stem[3:5]), stem)
        return (1, 0, stem)

    return sorted(paths, key=key)


# ----------------------------------------------------------------------------- text


def format_claims(rep: Reproduction, width: int = 110) -> str:
    """Plain-text claims table (id, verdict, this run's value).

    Parameters
    ----------
    rep : Reproduction
        From :func:`~fsmctl.studies.reproduce.reproduce`.
    width : int
        Wrap width of the detail lines.

    Returns
    -------
    str
        One line per claim, the values and reasons indented below.

    Examples
    --------
    >>> rep = one_second_reproduction()  # conftest.py: the Reproduction example's 1 s runs (shared)
    >>> print(format_claims(rep).splitlines()[2])
    settling_27s         impossible (bound)
    """
    w = max(len(c.id) for c in rep.claims)
    lines = [f"{'claim':{w}}  verdict", f"{'-' * w}  {'-' * 20}"]
    explained = {e.id: e for e in rep.explanations or ()}
    for c in rep.claims:
        lines.append(f"{c.id:{w}}  {c.verdict}")
        for label, text in (("paper", c.paper_value), ("this run", c.this_run_value), ("why", c.reason)):
            if not text:
                continue
            lines += textwrap.wrap(
                f"{label}: {text}", width, initial_indent=" " * (w + 2), subsequent_indent=" " * (w + 4)
            )
        if c.id in explained:
            lines += text_lines(explained[c.id], w + 2, width)
    figure_checks = [
        e for e in rep.explanations or () if e.id not in explained or e.id not in {c.id for c in rep.claims}
    ]
    if figure_checks:
        lines.append("figure-level checks (the printed axes and insets of Figs 1-9):")
        for e in figure_checks:
            lines.append(f"  {e.id}: {e.verdict}; {e.claim}")
            lines += text_lines(e, 4, width)
    bounds = ", ".join(f"{b.agent}: {b.min_time_s:.1f} s" for b in rep.bounds)
    lines.append(f"angular-momentum bound on the settling time per agent: {bounds}")
    return "\n".join(lines)
