"""A certificate of ``fsmctl certify``: what was asked, what was proved, and how to re-check it from its file.

:func:`certify_law` runs the search of :mod:`fsmctl.proofs.certify` for a law flown by one agent of a scenario;
:class:`Certificate` is its record: the law (name, source, the hash of its generated code), the agent's nominal
inertia, parameters and torque limit, the region, the uncertainty, the candidate ``V`` (its exact expression), the
method and the arithmetic, the verdict with its levels, bounds and counterexample, and every leaf box on which
``V_dot < 0`` was proved (the branch and bound's bisection tree, one code per box).  :meth:`Certificate.write`
saves it as JSON (the tree compressed, base64) and Markdown;
:func:`check_certificate` re-checks a saved file independently of the search: it rebuilds the closed loop from the
recorded inputs (refusing a law whose generated code changed), re-proves ``V_dot < 0`` on every recorded leaf,
rebuilds the leaves from the tree (a partition of the region by construction),
re-proves the origin's second-order argument and the levels, confirms the counterexample in ball arithmetic,
re-proves a sample of the leaves in python-flint's ball arithmetic (the formally rigorous route), and recomputes every
number the report derives from these (extents, ultimate bound, decrease, reach time, rates, the headline), failing
one more favourable than the recomputed one (:mod:`fsmctl.proofs.certify_check`).

Size: one concept, the certificate: its record and file format (the tree's encoding, writing, reading) and the two
entry points that produce and re-check it, each documented in full; the search lives in :mod:`fsmctl.proofs.certify`
and the re-check's steps in :mod:`fsmctl.proofs.certify_check`.
"""

from __future__ import annotations

import base64
import hashlib
import json
import math
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import sympy as sp

from fsmctl.errors import InputError
from fsmctl.model.laws import parameter_matrix, resolve_law
from fsmctl.model.scenario import Scenario, load_scenario
from fsmctl.outputs import write_text
from fsmctl.proofs.certify import (
    CANDIDATE_CHOICES,
    CERTIFIED,
    COUNTEREXAMPLE,
    INCONCLUSIVE,
    CandidateOutcome,
    SearchSettings,
    certify_candidate,
    choose_candidates,
)
from fsmctl.proofs.certify_check import recheck
from fsmctl.proofs.certify_problem import (
    Candidate,
    StateRegion,
    Uncertainty,
    build_problem,
    candidate_from_record,
    expression_tree,
)
from fsmctl.proofs.certify_report import (
    LEVEL_DIGITS,
    TABLE_LEVEL_DIGITS,
    CertifyStage,
    StageReporter,
    annulus_text,
    bound_down,
    bound_up,
    box_text,
    candidate_label,
    core_fractions,
    core_line,
    counterexample_table,
    extent_maxima,
    search_line,
    table_cell,
    ultimate_text,
)
from fsmctl.proofs.certify_symbolic import reduced_torque
from fsmctl.proofs.law_check import load_law_variants

__all__ = [
    "CERTIFICATE_FORMAT",
    "Certificate",
    "CertificateCheck",
    "CertificateError",
    "certify_law",
    "check_certificate",
    "read_certificate",
]

CERTIFICATE_FORMAT = 1
"""version of the certificate file's layout"""
ARB_SAMPLE = 64
"""proved leaves re-proved in ball arithmetic by :func:`check_certificate` (all of them with ``arb_sample=None``)"""
ARITHMETIC = (
    "IEEE-754 double intervals with outward rounding (one ulp after + - * / sqrt; libm functions widened by "
    "fsmctl.enclosures.intervals.LIBM_ULPS ulps), natural extension intersected with the mean-value form; "
    "the origin's values and counterexamples in python-flint ball arithmetic (256 bits)"
)


class CertificateError(InputError):
    """A certificate file that cannot be read or re-checked (one line, exit 2).

    Examples
    --------
    >>> from fsmctl.proofs import CertificateError, check_certificate
    >>> try:
    ...     check_certificate("no-such-certificate.json")
    ... except CertificateError as exc:
    ...     print(type(exc).__name__)
    CertificateError
    """


def _encode_tree(tree: dict) -> dict:
    codes = np.ascontiguousarray(tree.get("codes", np.zeros(0, np.int8)), dtype=np.int8)
    return {
        "batch": int(tree.get("batch", 0)),
        "boxes": int(codes.size),
        "codes_int8_zlib_base64": base64.b64encode(zlib.compress(codes.tobytes(), 9)).decode(),
    }


def _decode_tree(d: dict) -> dict:
    raw = zlib.decompress(base64.b64decode(d["codes_int8_zlib_base64"]))
    return {"batch": int(d["batch"]), "codes": np.frombuffer(raw, dtype=np.int8).copy()}


def law_fingerprint(folder: Path) -> str:
    """SHA-256 of a law folder's ``manifest.json`` (it lists every generated file's hash)."""
    return hashlib.sha256((Path(folder) / "manifest.json").read_bytes()).hexdigest()


@dataclass
class Certificate:
    """The record of one ``fsmctl certify`` question and its answer (see the module docstring).

    What :func:`certify_law` returns and ``certificate.json`` holds: the question (:attr:`law`, :attr:`agent`,
    :attr:`region`, :attr:`uncertainty`), the answer (:attr:`verdict`, :attr:`kind`, the :attr:`candidate` ``V``,
    the :attr:`outcome` with its levels, extents, ultimate bound, counterexample or identity), the other candidates
    tried (:attr:`attempts`). :meth:`headline`, :meth:`lines` and :meth:`markdown` are the report as printed (bounds
    rounded outward), :meth:`method` and :meth:`arithmetic` say how it was proved, :meth:`write` writes the files;
    :func:`check_certificate` re-checks a file.

    Parameters
    ----------
    verdict : str
        ``"certified"``, ``"counterexample"`` or ``"inconclusive"``.
    kind : str or None
        For a certificate: ``"asymptotic"`` or ``"ultimately bounded"``; else None.
    law : dict
        The law: its spec, name and the SHA-256 of its folder's manifest (what :func:`check_certificate` compares).
    agent : dict
        The agent whose closed loop is certified (``number`` 1-based) and its nominal inertia.
    region : StateRegion
        The state region of the question.
    uncertainty : Uncertainty
        The admissible uncertainty (inertia set, disturbance bound, reference rate).
    candidate : dict
        The Lyapunov function ``V`` the answer is about (its expression and how it was built).
    outcome : dict
        The answer's evidence: levels, extents, ultimate bound, counterexample or sum-of-squares identity, coverage.
    attempts : list of dict
        The other candidates tried, each with its outcome.
    notes : list of str
        What the report adds (e.g. why a candidate was left out).
    tree : dict
        The branch and bound's bisection of the region (``codes`` and ``batch``).
    names : list of str
        The closed loop's input names (state, uncertainty) in the order of the enclosures.
    versions : dict
        The versions of fsmctl and of the libraries that made it.
    route : str
        How the law's torque entered the closed loop.

    Examples
    --------
    The documented PD example with a 5 % inertia uncertainty on a small region (a short budget keeps it quick):

    >>> from fsmctl.proofs import Certificate, SearchSettings, StateRegion, Uncertainty, certify_law
    >>> c = certify_law(EXAMPLES / "my_law.py", scenario=EXAMPLES / "my_law.toml",
    ...                 region=StateRegion(0.1, 0.02), uncertainty=Uncertainty(inertia=0.05),
    ...                 settings=SearchSettings(max_seconds=20))
    >>> isinstance(c, Certificate), c.verdict, c.kind, c.headline().split(":")[0]
    (True, 'certified', 'asymptotic', 'certified (asymptotic)')
    >>> c.as_dict()["verdict"] == c.verdict
    True
    """

    verdict: str
    kind: str | None
    law: dict
    agent: dict
    """the agent's record; ``number`` is 1-based, as the paper's agents 1..n and ``fsmctl certify --agent``"""
    region: StateRegion
    uncertainty: Uncertainty
    candidate: dict
    outcome: dict
    attempts: list[dict] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    tree: dict = field(default_factory=dict)
    """the branch and bound's bisection of the region: ``codes`` and ``batch``
    (:func:`fsmctl.enclosures.branch_bound.bisection_leaves` rebuilds every leaf from them)"""
    names: list[str] = field(default_factory=list)
    versions: dict = field(default_factory=dict)
    route: str = ""
    """how the law's torque entered the closed loop (:attr:`fsmctl.proofs.certify_problem.CertifyProblem.route`)"""

    # ------------------------------------------------------------------------------------------- text
    def headline(self) -> str:
        """The first line a reader needs (every bound and level rounded outward, :data:`BOUND_DIGITS`)."""
        o = self.outcome
        if self.verdict == CERTIFIED:
            if self.kind == "asymptotic":
                return (
                    f"certified ({self.kind}): V_dot < 0 on the region except the origin, for every admissible "
                    f"uncertainty; region of attraction contains {{V <= {bound_down(o['level'], LEVEL_DIGITS)}}}"
                )
            annulus = annulus_text(o["inner_level"], o["level"])
            return f"certified ({self.kind}): V_dot < 0 on {annulus}; ultimate bound {ultimate_text(o, attitude=False)}"
        if self.verdict == COUNTEREXAMPLE:
            c = o["counterexample"]
            return f"counterexample: V_dot = {c['V_dot']:.6g} > 0 at a point of the region (ball arithmetic: {c['V_dot_ball']})"
        return f"inconclusive: {o.get('difficulty') or 'the budget ran out'}"

    def lines(self) -> list[str]:
        """The console report: each bound rounded outward (an upper bound up, a lower bound down), the JSON exact."""
        o = self.outcome
        out = [
            self.headline(),
            f"law {self.law['name']} ({self.law['spec']}, {self.law['error_model']} error model), agent "
            f"{self.agent['number']} of {self.agent['scenario']}",
            f"region: {self.region.describe(len(self.names) and self.agent['n_states'])}",
            f"uncertainty: {self.uncertainty.describe()}",
            f"V: {self._plain(self.candidate['describe'])}",
            f"  = {self.candidate['expression'][:400]}" + (" ..." if len(self.candidate["expression"]) > 400 else ""),
        ]
        core = o.get("core") or {}
        if core.get("passed"):
            out.append(
                "origin: V_dot(0) = 0 and grad V_dot(0) = 0 (ball arithmetic), and the Hessian of V_dot is negative "
                f"definite on the core (the box of {core_fractions(core)} x the region around the origin)"
            )
        level = bound_down(o.get("level", 0.0), LEVEL_DIGITS)  # {V <= c} rounded down: a smaller set
        if o.get("level_extent"):
            out.append(f"{{V <= {level}}} lies in {box_text(extent_maxima(o['level_extent']))}")
        if core.get("passed"):
            out.append(core_line(core))
        if o.get("inner_target") is not None and self.verdict == CERTIFIED:
            target = bound_up(o["inner_target"], LEVEL_DIGITS)
            out.append(
                f"inner set {{V <= {bound_up(o['inner_level'], LEVEL_DIGITS)}}}: the boxes where V <= {target} (half the "
                f"least V on the region's boundary) belong to it without a proof of V_dot < 0; it lies in {ultimate_text(o)}"
            )
        if o.get("decrease") and o.get("reach_time") is not None:
            c_mid = 0.5 * (o["inner_level"] + o["level"])
            out.append(
                f"V_dot <= -{bound_down(o['decrease'])} on {annulus_text(c_mid, o['level'])}: from {{V <= {level}}} the level "
                f"{bound_up(c_mid, LEVEL_DIGITS)} is reached within {bound_up(o['reach_time'])} s"
            )
        if o.get("sos"):
            out.extend(self._sos_lines())
            return out + self._tail()
        out.append(search_line(o))
        return out + self._tail()

    def _sos_lines(self) -> list[str]:
        o = self.outcome
        c_in = bound_up(o["inner_level"], LEVEL_DIGITS)
        return [
            f"V_dot <= -{bound_down(o['sos']['rate'])} (V - {c_in}) wherever {annulus_text(o['inner_level'], o['level'])[1:-1]},"
            f" for every admissible disturbance and inertia: {o['sos']['detail']} ({o['sos']['seconds']:.1f} s)",
            f"inner set {{V <= {c_in}}} lies in {ultimate_text(o)}",
        ] + ([f"the identity's model of the loop: {o['sos']['model']}"] if o["sos"].get("model") else [])

    def _tail(self) -> list[str]:
        out = [f"also tried: {self._plain(a['describe'])}: {a['verdict']} ({a['why']})" for a in self.attempts[:-1]]
        return out + [f"note: {n}" for n in self.notes]

    def _plain(self, describe: str) -> str:
        """A candidate's description naming the law's own states ``z`` in ``x`` only when the law has some."""
        if self.agent.get("n_states"):
            return describe
        return describe.replace("x = (sigma_e, omega_e, z)", "x = (sigma_e, omega_e)")

    def arithmetic(self) -> str:
        """The arithmetic of the proof."""
        if self.outcome.get("sos"):
            return (
                "the identity: exact rationals (Python fractions, FLINT integers for definiteness); V's minimum on the "
                f"boundary and the extents: {ARITHMETIC}"
            )
        return ARITHMETIC

    def method(self) -> str:
        """How the statement was proved, in words."""
        if self.outcome.get("sos"):
            return (
                "a sum-of-squares (Putinar) identity from a semidefinite program, checked in exact rational arithmetic"
            )
        return "branch and bound on rigorous enclosures of V_dot (fsmctl.enclosures)"

    def markdown(self) -> str:
        """The Markdown report (what a reader of the file sees)."""
        o = self.outcome
        rows = [
            ("verdict", f"**{self.verdict}**" + (f" ({self.kind})" if self.verdict == CERTIFIED else "")),
            ("law", f"`{self.law['name']}` (`{self.law['spec']}`), {self.law['error_model']} error model"),
            ("generated code", f"manifest sha256 `{self.law['manifest_sha256'][:16]}...`"),
            ("agent", f"{self.agent['number']} of `{self.agent['scenario']}`"),
            ("region", self.region.describe(self.agent["n_states"])),
            ("uncertainty", self.uncertainty.describe()),
            ("candidate", self._plain(self.candidate["describe"])),
            ("method", self.method()),
            ("arithmetic", self.arithmetic()),
            ("level c", bound_down(o.get("level", 0), TABLE_LEVEL_DIGITS)),
        ]
        if o.get("inner_level") is not None:
            rows.append(("inner level c_in", bound_up(o["inner_level"], TABLE_LEVEL_DIGITS)))
        if self.verdict == CERTIFIED and o.get("ultimate_bound"):
            rows.append(("ultimate bound", ultimate_text(o)))
        text = [f"# Certificate: {self.law['name']}", "", self.headline(), "", "| item | value |", "|---|---|"]
        text += [f"| {k} | {table_cell(v)} |" for k, v in rows]
        text += ["", "## V", "", "```", self.candidate["expression"], "```", ""]
        if self.verdict == COUNTEREXAMPLE:
            text += counterexample_table(o["counterexample"])
        text += ["## Report", ""]
        text += [f"- {line}" for line in self.lines()[1:]]
        text += ["", "Re-check: `fsmctl certify --check certificate.json` (the JSON file beside this report)", ""]
        return "\n".join(text)

    # ------------------------------------------------------------------------------------------- files
    def as_dict(self) -> dict:
        """The certificate as ``certificate.json`` holds it (format, verdict, headline, question, answer, versions).

        Returns
        -------
        dict
            JSON-able apart from NumPy scalars and arrays (:meth:`write` converts those).
        """
        return {
            "format": CERTIFICATE_FORMAT,
            "verdict": self.verdict,
            "kind": self.kind,
            "headline": self.headline(),
            "law": self.law,
            "agent": self.agent,
            "region": {"sigma": self.region.sigma, "omega": self.region.omega, "z": self.region.z},
            "uncertainty": self.uncertainty.as_dict(),
            "candidate": self.candidate,
            "method": self.method(),
            "arithmetic": self.arithmetic(),
            "outcome": self.outcome,
            "attempts": self.attempts,
            "notes": self.notes,
            "inputs": self.names,
            "route": self.route,
            "versions": self.versions,
            "tree": _encode_tree(self.tree),
        }

    def write(self, json_path: Path, markdown_path: Path | None = None) -> None:
        """Write the JSON file (and the Markdown report), atomically.

        Parameters
        ----------
        json_path : path-like
            Receives :meth:`as_dict` as JSON (what :func:`check_certificate` reads).
        markdown_path : path-like, optional
            Receives :meth:`markdown`, the report as ``fsmctl certify`` writes it.
        """
        json_path = Path(json_path)
        write_text(json_path, json.dumps(self.as_dict(), indent=1, default=_json_default) + "\n")
        if markdown_path is not None:
            write_text(Path(markdown_path), self.markdown())


def _json_default(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(type(o).__name__)


def read_certificate(path: Path) -> dict:
    """The JSON of a certificate file, with its bisection tree decoded (``tree``: ``codes`` array and ``batch``).

    Raises
    ------
    CertificateError
        Not a readable certificate of this format.
    """
    path = Path(path)
    if path.is_dir():
        inside = path / "certificate.json"
        there = f": give the certificate in it, {inside}" if inside.is_file() else ""
        raise CertificateError(f"{path} is a folder; a certificate JSON file is expected{there}")
    try:
        text = path.read_text("utf-8")
    except (OSError, ValueError) as exc:
        raise CertificateError(
            f"{path}: not a readable certificate ({getattr(exc, 'strerror', None) or exc})"
        ) from None
    try:
        d = json.loads(text)
    except ValueError:
        what = "a Markdown report" if path.suffix.lower() == ".md" else "not JSON"
        beside = [p for p in (path.with_suffix(".json"), path.parent / "certificate.json") if p != path and p.is_file()]
        there = f": the certificate beside it is {beside[0]}" if beside else ""
        raise CertificateError(f"{path}: {what}; a certificate JSON file is expected{there}") from None
    if not isinstance(d, dict) or d.get("format") != CERTIFICATE_FORMAT:
        raise CertificateError(f"{path}: not a certificate of format {CERTIFICATE_FORMAT}")
    try:
        d["tree"] = _decode_tree(d["tree"]) if d.get("tree", {}).get("batch") else {}
    except (KeyError, TypeError, ValueError, zlib.error) as exc:
        raise CertificateError(f"{path}: the certificate's bisection tree cannot be read ({exc})") from None
    return d


def outcome_dict(o: CandidateOutcome) -> dict:
    s = o.search
    return {
        "level": o.level,
        "inner_level": o.inner_level,
        "inner_target": o.inner_target,
        "boundary_level": o.boundary_level,
        "level_extent": o.level_extent,
        "ultimate_bound": o.ultimate_bound,
        "decrease": o.decrease,
        "reach_time": o.reach_time,
        "core": o.core,
        "counterexample": o.counterexample,
        "difficulty": o.difficulty,
        "boxes": 0 if s is None else s.boxes,
        "seconds": o.seconds,
        "sos": o.sos,
        "exhausted": False if s is None else s.exhausted,
        "volume": {} if s is None else s.volume,
    }


def candidate_dict(c: Candidate) -> dict:
    return {
        "kind": c.kind,
        "describe": c.describe(),
        "expression": sp.sstr(c.expression, full_prec=True),
        "tree": expression_tree(c.expression),
        "epsilon": c.epsilon,
        "P": None if c.P is None else [list(r) for r in c.P],
        "note": c.note,
    }


def _why(o: CandidateOutcome) -> str:
    if o.verdict == CERTIFIED:
        return "the answer"
    if o.counterexample:
        return f"V_dot = {o.counterexample['V_dot']:.3g} > 0 at a point"
    return o.difficulty or "not proved"


def tree_of(o: CandidateOutcome) -> dict:
    s = o.search
    return {} if s is None else {"codes": s.codes, "batch": s.batch}


def choose_outcome(outcomes: list[CandidateOutcome]) -> CandidateOutcome:
    """The answer: the first certified candidate, else the declared candidate's counterexample, else the candidate
    that left the least of the region undecided (the first of equals)."""
    for o in outcomes:
        if o.verdict == CERTIFIED:
            return o
    for o in outcomes:
        if o.verdict == COUNTEREXAMPLE and o.candidate.kind == "declared":
            return o

    def undecided(o: CandidateOutcome) -> float:
        if o.search is None:
            return math.inf
        v = o.search.volume
        return v.get("undecided", 0.0) + v.get("positive", 0.0)

    return min(outcomes, key=undecided)


# ----------------------------------------------------------------------------------------------- the question


def _versions() -> dict[str, str]:
    from importlib import metadata

    out = {}
    for name in ("fsmctl", "casadi", "sympy", "numpy", "python-flint", "cvxpy"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def scenario_uncertainty(scenario: Scenario, agent: int) -> Uncertainty:
    """The uncertainty a scenario states for one agent: its ``delta_J`` as a set, its disturbance's and its
    reference's bounds (eq 29).

    The inertia set is ``"proportional"`` with ``|theta| <= |kappa|`` when ``delta_J = kappa J0`` (the paper's
    ``0.3 J0``), else ``"entries"`` with the largest relative entry.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    agent : int
        0-based.

    Returns
    -------
    Uncertainty

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.proofs.certificate import scenario_uncertainty
    >>> u = scenario_uncertainty(fsmctl.paper_scenario("1"), 0)
    >>> u.inertia, u.inertia_set
    (0.3, 'proportional')
    """
    a = scenario.agents[agent]
    J0, dJ = a.J0_array, np.asarray(a.delta_J, float)
    kappa = float(np.trace(dJ) / np.trace(J0))
    if np.max(np.abs(dJ - kappa * J0)) <= 1e-12 * np.max(np.abs(J0)):
        inertia, kind = abs(kappa), "proportional"
    else:
        nz = J0 != 0
        if np.any(dJ[~nz] != 0):
            raise CertificateError(
                f"agent {agent + 1}: delta_J changes an entry where J0 is 0; certify's inertia sets scale J0's entries"
            )
        inertia, kind = float(np.max(np.abs(dJ[nz] / J0[nz]))), "entries"
    return Uncertainty(
        inertia=round(inertia, 12),
        inertia_set=kind,
        disturbance=tuple(a.disturbance.bound()),
        reference_rate=tuple(scenario.reference.omega.bound()),
        reference_acceleration=tuple(scenario.reference.omega.rate_bound()),
    )


def _closed_loop(code, symbolic, error_model, J0, params, limit, region, uncertainty):
    """The closed loop as certify and its re-check build it (the torque reduced symbolically where it can be)."""
    at_rest = not (any(uncertainty.reference_rate) or any(uncertainty.reference_acceleration))
    reduced = reduced_torque(symbolic, params, J0, at_rest=at_rest)
    return build_problem(code, error_model, J0, params, limit, region, uncertainty, law=symbolic, reduced=reduced)


def _vertices(problem, uncertainty: Uncertainty) -> list[np.ndarray]:
    n_theta = sum(1 for name in problem.names if name.startswith("theta"))
    rest = len(problem.names) - problem.n_state - n_theta
    corners = [np.zeros(n_theta)]
    if uncertainty.inertia > 0:
        grid = np.array(np.meshgrid(*[[-1.0, 1.0]] * n_theta, indexing="ij")).reshape(n_theta, -1).T
        corners += list(grid * uncertainty.inertia)
    return [np.concatenate([c, np.zeros(rest)]) for c in corners]


def certify_law(
    law: str | Path,
    *,
    scenario: Scenario | str | Path | None = None,
    agent: int = 0,
    region: StateRegion | None = None,
    uncertainty: Uncertainty | None = None,
    settings: SearchSettings | None = None,
    candidates: str = "auto",
    progress: Callable[[int, float], None] | None = None,
    stage: Callable[[CertifyStage], None] | None = None,
) -> Certificate:
    """Certify a law's closed loop over a region with the uncertainty, or refute it, or say why not.

    The isolated agent flying ``law`` with the scenario's nominal inertia, parameters and torque limit, in error
    coordinates, for every true inertia, disturbance and reference motion in ``uncertainty``
    (:mod:`fsmctl.proofs.certify` describes the verdicts and the candidates).

    Parameters
    ----------
    law : str or pathlib.Path
        A built-in law name or a derivation script (the candidate ``V`` is read from its SymPy declaration).
    scenario : Scenario, str or pathlib.Path, optional
        Supplies ``J0``, the parameters, the torque limit and (by default) the uncertainty; default the paper's
        Case 1 flying ``law``.  A scenario flying another law flies ``law`` instead.
    agent : int
        Which agent (0-based).
    region : StateRegion, optional
        Default ``|sigma_e,k| <= 0.5``, ``|omega_e,k| <= 0.1`` rad/s, ``|z_k| <= 1``.
    uncertainty : Uncertainty, optional
        Default the scenario's (:func:`scenario_uncertainty`).
    settings : SearchSettings, optional
        The budget per candidate.
    candidates : str
        ``"auto"``: the law's declared ``V``, then the candidates fsmctl finds (the first certified one answers; the
        declared one's counterexample is kept in the attempts); ``"declared"``: the law's own ``V`` only (a wrong
        declared ``V`` is then refuted even when the law is stable).
    progress : callable, optional
        ``progress(boxes, fraction_decided)`` during each search.
    stage : callable, optional
        ``stage(CertifyStage)`` when the work moves on (:data:`fsmctl.proofs.certify_report.STEPS`): the candidates
        being chosen, then for each candidate its boundary level, its sum of squares (ultimately bounded questions),
        its origin's argument, its branch and bound and its levels (:class:`fsmctl.proofs.certify_report.CertifyStage`).

    Returns
    -------
    Certificate

    Raises
    ------
    fsmctl.model.LawError
        An unknown law.
    CertificateError, fsmctl.proofs.certify_problem.CertifyInputError
        An agent index out of range, a region or uncertainty certify cannot take.

    Examples
    --------
    The documented PD example (``docs/examples/my_law.py``, ``EXAMPLES`` that folder) with a 10 % inertia
    uncertainty (a small region and budget keep this quick):

    >>> from fsmctl.proofs.certificate import certify_law
    >>> from fsmctl.proofs.certify import SearchSettings
    >>> from fsmctl.proofs.certify_problem import StateRegion, Uncertainty
    >>> c = certify_law(EXAMPLES / "my_law.py", scenario=EXAMPLES / "my_law.toml",
    ...                 region=StateRegion(0.1, 0.02), uncertainty=Uncertainty(inertia=0.1),
    ...                 settings=SearchSettings(max_seconds=20))
    >>> c.verdict, c.kind
    ('certified', 'asymptotic')
    """
    spec = str(law)
    code = resolve_law(spec)
    variants = load_law_variants(spec)
    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario or "paper")
    if code.name != sc.law.name:
        sc = sc.with_law(spec)
    if not 0 <= agent < sc.n_agents:
        raise CertificateError(f"agent {agent + 1}: the scenario has {sc.n_agents} agents")
    error_model = str(getattr(sc.controller.error_model, "value", sc.controller.error_model))
    symbolic = getattr(variants, error_model)
    region = region or StateRegion()
    uncertainty = uncertainty or scenario_uncertainty(sc, agent)
    settings = settings or SearchSettings()
    J0 = sc.agents[agent].J0_array
    params = parameter_matrix(code, sc)[agent]
    limit = float(sc.controller.effective_torque_limit)
    notes: list[str] = []
    problem = _closed_loop(code, symbolic, error_model, J0, params, limit, region, uncertainty)
    notes.append(f"the law's torque: {problem.route}")
    if candidates not in CANDIDATE_CHOICES:
        raise CertificateError(f"candidates must be one of {CANDIDATE_CHOICES}, got {candidates!r}")
    stages = StageReporter(stage, progress)
    stages.choosing()
    chosen_candidates, more = choose_candidates(
        problem, symbolic, params, J0, _vertices(problem, uncertainty), which=candidates
    )
    notes.extend(more)
    if sc.actuator.kind != "ideal":
        notes.append("the scenario flies reaction wheels: certify models an ideal actuator with the torque limit")
    if sc.simulation.control_period:
        notes.append("the scenario samples its control: certify treats the continuous-time loop")
    outcomes: list[CandidateOutcome] = []
    for i, cand in enumerate(chosen_candidates):
        stages.candidate(candidate_label(cand), i + 1, len(chosen_candidates))
        o = certify_candidate(problem, cand, settings, progress=stages.progress, stage=stages.step)
        outcomes.append(o)
        if o.verdict == CERTIFIED:
            break
    names = [p.name for p in code.parameters]
    info = {
        "number": agent + 1,
        "scenario": sc.label,
        "J0_kg_m2": J0.tolist(),
        "parameters": dict(zip(names, _by_name(code, params), strict=True)),
        "packed_parameters": params.tolist(),
        "torque_limit_N_m": limit if math.isfinite(limit) else "inf",
        "n_states": int(code.n_states),
    }
    lawd = {
        "name": code.name,
        "spec": spec,
        "error_model": error_model,
        "manifest_sha256": law_fingerprint(code.folder),
    }
    if not outcomes:
        return Certificate(
            "inconclusive", None, lawd, info, region, uncertainty,
            {"kind": "none", "describe": "no candidate", "expression": "", "epsilon": None, "P": None, "note": ""},
            {"difficulty": "no Lyapunov candidate: " + "; ".join(more), "level": 0.0}, [], notes, {},
            problem.names, _versions(), problem.route,
        )  # fmt: skip
    chosen = choose_outcome(outcomes)
    attempts = [
        {"describe": o.candidate.describe(), "verdict": o.verdict, "why": _why(o)} for o in outcomes if o is not chosen
    ] + [{"describe": chosen.candidate.describe(), "verdict": chosen.verdict, "why": _why(chosen)}]
    return Certificate(
        chosen.verdict, chosen.kind if chosen.verdict == CERTIFIED else None, lawd, info, region, uncertainty,
        candidate_dict(chosen.candidate), outcome_dict(chosen), attempts, notes, tree_of(chosen), problem.names,
        _versions(), problem.route,
    )  # fmt: skip


def _by_name(code, params: np.ndarray) -> list:
    out, k = [], 0
    for p in code.parameters:
        v = params[k : k + p.size]
        out.append(p.choices[int(v[0])] if p.choices else float(v[0]) if p.size == 1 else v.tolist())
        k += p.size
    return out


# ----------------------------------------------------------------------------------------------- re-check


@dataclass(frozen=True)
class CertificateCheck:
    """What :func:`check_certificate` re-established: ``ok`` (every statement of the file holds), one line per step,
    and the file's ``verdict`` (a file that holds may still certify nothing: ``certified`` is what to trust).

    Parameters
    ----------
    ok : bool
        Every statement of the file was re-established.
    lines : tuple of str
        One line per step of the check, as ``fsmctl certify --check`` prints them.
    verdict : str
        The file's verdict (``"certified"``, ``"counterexample"`` or ``"inconclusive"``).

    Examples
    --------
    A file whose statements all hold but that records an inconclusive search certifies nothing:

    >>> from fsmctl.proofs import CertificateCheck
    >>> CertificateCheck(True, ("every box re-checked",), "inconclusive").certified
    False
    >>> CertificateCheck(True, ("every box re-checked",)).certified
    True
    """

    ok: bool
    lines: tuple[str, ...]
    verdict: str = CERTIFIED

    @property
    def certified(self) -> bool:
        """Every statement holds and the file certifies its law."""
        return self.ok and self.verdict == CERTIFIED


def check_certificate(path: str | Path, *, arb_sample: int | None = ARB_SAMPLE, seed: int = 0) -> CertificateCheck:
    """Re-check a certificate file independently of the search that produced it (see the module docstring).

    Parameters
    ----------
    path : str or pathlib.Path
        The JSON file written by :meth:`Certificate.write`.
    arb_sample : int or None
        Proved leaves re-proved in ball arithmetic (None: all of them; slow).
    seed : int
        Which leaves are sampled.

    Returns
    -------
    CertificateCheck

    Raises
    ------
    CertificateError
        Not a certificate, or its law's generated code has changed since it was written.

    Examples
    --------
    >>> from fsmctl.proofs import SearchSettings, StateRegion, Uncertainty, certify_law, check_certificate
    >>> c = certify_law(EXAMPLES / "my_law.py", scenario=EXAMPLES / "my_law.toml",
    ...                 region=StateRegion(0.1, 0.02), uncertainty=Uncertainty(inertia=0.05),
    ...                 settings=SearchSettings(max_seconds=20))
    >>> c.write("my_pd.certificate.json")
    >>> check_certificate("my_pd.certificate.json", arb_sample=4).ok
    True
    """
    d = read_certificate(Path(path))
    code = resolve_law(d["law"]["spec"])
    if law_fingerprint(code.folder) != d["law"]["manifest_sha256"]:
        raise CertificateError(
            f"{path}: law {d['law']['name']!r}'s generated code has changed since the certificate was written "
            "(manifest hash differs): certify it again"
        )
    region = StateRegion(**d["region"])
    u = d["uncertainty"]
    uncertainty = Uncertainty(
        u["inertia"], u["inertia_set"], tuple(u["disturbance_N_m"]), tuple(u["reference_rate_rad_s"]),
        tuple(u["reference_acceleration_rad_s2"]),
    )  # fmt: skip
    a = d["agent"]
    limit = math.inf if a["torque_limit_N_m"] == "inf" else float(a["torque_limit_N_m"])
    error_model = d["law"]["error_model"]
    symbolic = getattr(load_law_variants(d["law"]["spec"]), error_model)
    J0, params = np.array(a["J0_kg_m2"], float), np.array(a["packed_parameters"], float)
    problem = _closed_loop(code, symbolic, error_model, J0, params, limit, region, uncertainty)
    if problem.route != d.get("route"):
        raise CertificateError(f"{path}: the law's torque enters differently now ({problem.route})")
    if problem.names != d["inputs"]:
        raise CertificateError(f"{path}: the closed loop's inputs differ from the certificate's")
    verdict = d["verdict"]
    if verdict not in (CERTIFIED, COUNTEREXAMPLE, INCONCLUSIVE) or (
        verdict == COUNTEREXAMPLE and not (d["outcome"] or {}).get("counterexample")
    ):
        raise CertificateError(f"{path}: the verdict {verdict!r} does not match the rest of the file")
    if not d["candidate"]["expression"]:
        return CertificateCheck(verdict != CERTIFIED, ("no candidate: nothing to re-check",), verdict)
    V = candidate_from_record(d["candidate"], problem.n_state - 6)
    ok, lines = recheck(problem, V, d, arb_sample=arb_sample, seed=seed)
    cert = Certificate(verdict, d["kind"], d["law"], a, region, uncertainty, d["candidate"], d["outcome"])
    same, line = _headline_check(d.get("headline"), cert.headline())
    return CertificateCheck(ok and same, (*lines, line), verdict)


def _headline_check(stated: str | None, rebuilt: str) -> tuple[bool, str]:
    """The file's headline against the one its (re-checked) outcome gives (:meth:`Certificate.headline`): its
    numbers are the outcome's, printed, so the two agree character for character."""
    if stated == rebuilt:
        return True, "[ok] the headline is the re-checked outcome's"
    return False, f"[FAILS] headline: the file states {stated!r}, the re-checked outcome gives {rebuilt!r}"
