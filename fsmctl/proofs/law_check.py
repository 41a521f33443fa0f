"""``fsmctl prove --law L``: what can be checked about a control law written with :mod:`fsmctl.symbolic.law`.

Each check says what kind of evidence it is (:data:`KINDS`):

``checked``
    a comparison that passed or failed at stated points or symbolically (the detail says which);
``derived``
    an expression computed from the law (shown, not judged);
``proved``
    established symbolically with SymPy (an identity, plus a sign read off the structure);
``evidence``
    numeric sampling over a stated region only: *not a proof*;
``fails``
    a counterexample was found (the detail gives the point), or a declared claim is false;
``not declared``
    the law declares nothing to check (e.g. no Lyapunov candidate).

The checks:

1. ``generated-equals-symbolic`` (checked): the generated ``law_constants``, ``law_local_<model>`` and
   ``law_control_<model>`` (:meth:`fsmctl.model.laws.LawCode.casadi`) against the symbolic law
   (:meth:`fsmctl.symbolic.law.Law.expanded`, evaluated by ``sympy.lambdify``) at seeded random inputs,
   excluding points within ``1e-6`` of a switching surface (a ``sign`` argument or an inequality of a
   ``Piecewise``); pass at a relative error of ``1e-9``.
   For a law that commands its reaction wheels (:meth:`fsmctl.symbolic.law.LawBuilder.wheel_torques`) also
   ``wheels-realise-torque`` (checked): at seeded random inputs, random spin axes (``N`` unit columns spanning the
   body), wheel speeds and spin inertias, the generated ``law_wheels_<model>`` commands ``u_w`` produce on the
   body the law's applied (limited) torque ``u = sat(u_commanded, u_max)`` of ``law_control_<model>``:
   ``||-G u_w - u||_inf <= 1e-9 max(||u||_inf, ||u_w||_inf)`` (null motion ``G v = 0`` adds no body torque, so
   a law such as ``fsm_wheels`` meets it to round-off); before the wheels' own limits, which the engine applies.
2. ``closed-loop`` (derived): the isolated agent in error coordinates (``J = J0``, no disturbance, no
   neighbours, the reference at rest so ``sigma_e = sigma``, ``omega_e = omega`` on the shadow set):
   ``sigma_dot = G(sigma) omega``, ``omega_dot = J0^-1 (u - omega x J0 omega)``, ``z_dot``;
   for a law that declares it is the paper's eqs 13-19 (:meth:`fsmctl.symbolic.law.LawBuilder.paper_theorems`)
   also ``closed-loop-eq20`` (checked): ``sigma_ddot`` is the closed loop of eq 20 (Liang, Sun & Wang 2012) with
   no coordination, with the parameters the declaration names, and the broadcast is ``s`` of eq 13; a law that
   declares it falsely fails this check.
3. ``lyapunov``: ``V_dot = grad V . f`` along that closed loop, proved equal to the declared
   ``claimed_derivative`` and that one manifestly ``<= 0`` (proved), or sampled (evidence; fails when
   ``V_dot > 0`` at a sampled point or the claimed derivative differs from ``V_dot`` there), or
   ``not declared``.

For such a law the report's notes point to ``fsmctl prove`` (the paper's own claims).  Symbolic steps run
in a forked child with a time budget (:data:`SYMBOLIC_BUDGET`); numeric steps are seeded.

Library code: raises :class:`fsmctl.model.laws.LawError` (an input error) for a law it cannot check.

Size: one command's evidence, ``fsmctl prove --law``: the report type and the three checks (generated code
against SymPy, the closed loop, the Lyapunov claim) share the sampled inputs, the symbolic budget and the
report's kinds, and are read together when a check is added.
"""

from __future__ import annotations

import json
import math
import re
import textwrap
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import sympy as sp

from fsmctl.model.laws import LawCode, LawError, builtin_laws, resolve_law
from fsmctl.parallel import run_with_time_limit
from fsmctl.proofs.symbolic_identities import (
    identically_zero,
    resolve_branches_on_unit_ball,
    uniform_ball_points,
)
from fsmctl.symbolic.law import Law, LawVariants, contract_names, wheels_function_name
from fsmctl.symbolic.mrp import mrp_G, mrp_G_dot, mrp_G_inverse, skew

__all__ = [
    "CHECK_IDS",
    "KINDS",
    "LawCheck",
    "LawReport",
    "check_law",
    "load_law_variants",
]

CHECKED, DERIVED, PROVED, EVIDENCE, FAILS, NOT_DECLARED = (
    "checked", "derived", "proved", "evidence", "fails", "not declared"
)  # fmt: skip
KINDS: tuple[str, ...] = (CHECKED, DERIVED, PROVED, EVIDENCE, FAILS, NOT_DECLARED)
CHECK_IDS: tuple[str, ...] = (
    "generated-equals-symbolic",
    "wheels-realise-torque",
    "closed-loop",
    "closed-loop-eq20",
    "lyapunov",
)

TOLERANCE = 1e-9
"""relative error at which the generated code counts as equal to the symbolic law"""
SURFACE_BAND = 1e-6
"""points with a switching function within this of zero are excluded from the comparison"""
SYMBOLIC_BUDGET = 30.0
"""seconds each symbolic simplification may take (it runs in a forked child where possible)"""
LATEX_LIMIT = 4000
"""longer LaTeX is replaced by a note (the expression is too big to read)"""

SIGMA_BOUND, OMEGA_BOUND = 0.9, 0.5
SIGMA_D_BOUND, OMEGA_D_BOUND, OMEGA_D_DOT_BOUND = 0.9, 0.1, 0.01
Z_BOUND, T_MAX, K_MAX, RECEIVED_BOUND, U_MAX_RANGE = 1.0, 100.0, 20.0, 1.0, (0.5, 5.0)
J0_SPREAD = 0.1
"""J0 is one of the paper scenario's J0 with each (symmetric) entry scaled by 1 + U(-J0_SPREAD, J0_SPREAD)"""
NEAR_REFERENCE = 3e-4
"""a quarter of the points have sigma within this (per component) of sigma_d: small errors, Remark 6's band"""

ERROR_STAGES = ("sigma_e", "omega_r", "omega_e", "omega_r_dot")
"""the stages :meth:`fsmctl.symbolic.law.LawBuilder.error_state` declares"""


# ----------------------------------------------------------------------------------------------- report


@dataclass(frozen=True)
class LawCheck:
    """One check of a law: ``id``, ``kind`` (one of :data:`KINDS`), what was checked and how it went."""

    id: str
    kind: str
    statement: str
    detail: str
    latex: str | None = None
    passed: bool | None = None
    """True/False for a check that can pass or fail; None for derived expressions, evidence, not declared"""
    seconds: float = 0.0
    data: dict = field(default_factory=dict)
    """machine-readable numbers (errors, counts, points)"""

    def to_dict(self) -> dict:
        return {
            "id": self.id,
            "kind": self.kind,
            "statement": self.statement,
            "detail": self.detail,
            "latex": self.latex,
            "passed": self.passed,
            "seconds": round(self.seconds, 3),
            "data": _jsonable(self.data),
        }


@dataclass(frozen=True)
class LawReport:
    """The checks of one law (``fsmctl prove --law``), as :func:`check_law` returns them.

    Parameters
    ----------
    law : str
        The law's name.
    checks : tuple of LawCheck
        The checks, in the order they ran (:data:`CHECK_IDS`).
    spec : str
        What ``--law`` named (a built-in name or a script).
    error_model : str
        ``"paper"`` or ``"exact"``: the generated functions compared.
    source : str
        The derivation script the generated code came from, as records name it
        (:meth:`~fsmctl.model.laws.LawCode.script` with ``portable=True``: ``fsm.py in fsmctl._builtin_laws`` for a
        built-in law); empty when no generated code was checked.
    notes : tuple of str
        Further remarks (the seed, where the paper's own claims are checked).

    Examples
    --------
    An MRP PD law whose Lyapunov candidate ``V = 2K ln(1 + sigma^T sigma) + omega^T J0 omega / 2`` has
    ``V_dot = -P |omega|^2`` along the isolated agent's closed loop (Schaub & Junkins), proved by SymPy:

    >>> script = '''
    ... import sympy as sp
    ... from fsmctl.symbolic import LawBuilder
    ...
    ... def law(error_model):
    ...     b = LawBuilder("pdl", error_model, doc="MRP PD")
    ...     K = b.parameter("K", 2.0, minimum=0.0, exclusive_minimum=True)
    ...     P = b.parameter("P", 8.0, minimum=0.0, exclusive_minimum=True)
    ...     e = b.error_state()
    ...     b.broadcast("sigma_e", e.sigma_e)
    ...     b.torque(-K * e.sigma_e - P * e.omega_e)
    ...     s2, w = (b.sigma.T * b.sigma)[0], b.omega
    ...     b.lyapunov(2 * K * sp.log(1 + s2) + (w.T * b.J0 * w)[0] / 2, claimed_derivative=-P * (w.T * w)[0])
    ...     return b.build()
    ... '''
    >>> _ = open("pdl.py", "w").write(script)
    >>> report = check_law("pdl.py", checks=["closed-loop"])
    >>> report.name, report.ok, report.check("closed-loop").kind
    ('pdl', True, 'derived')
    >>> print(report.to_text().splitlines()[0])
    fsmctl prove --law pdl.py: law pdl (paper error kinematics)
    >>> report.to_dict()["checks"][0]["id"]
    'closed-loop'
    """

    law: str
    checks: tuple[LawCheck, ...]
    spec: str = ""
    error_model: str = "paper"
    source: str = ""
    notes: tuple[str, ...] = ()

    @property
    def name(self) -> str:
        """The law's name (same as :attr:`law`)."""
        return self.law

    @property
    def ok(self) -> bool:
        """No check failed (evidence and derived expressions do not fail; ``fails`` does)."""
        return all(c.passed is not False for c in self.checks)

    def check(self, check_id: str) -> LawCheck:
        """The check with this id.

        Parameters
        ----------
        check_id : str
            One of :data:`CHECK_IDS`.

        Returns
        -------
        LawCheck
            The check.

        Raises
        ------
        KeyError
            No check with this id ran.
        """
        for c in self.checks:
            if c.id == check_id:
                return c
        raise KeyError(check_id)

    def summary(self) -> str:
        """One line: how many checks of each kind, the time they took, and which failed.

        Returns
        -------
        str
            ``law NAME: N checks: ... (t s); nothing failed`` or ``...; FAILED: ids``.
        """
        counts: dict[str, int] = {}
        for c in self.checks:
            counts[c.kind] = counts.get(c.kind, 0) + 1
        parts = ", ".join(f"{n} {k}" for k, n in counts.items())
        bad = [c.id for c in self.checks if c.passed is False]
        tail = f"; FAILED: {', '.join(bad)}" if bad else "; nothing failed"
        total = sum(c.seconds for c in self.checks)
        return f"law {self.law}: {len(self.checks)} checks: {parts} ({total:.1f} s){tail}"

    def to_text(self, *, width: int = 120) -> str:
        """Plain text: one line per check (id, kind, pass/fail, seconds, statement), its detail indented below.

        Parameters
        ----------
        width : int
            Column at which the detail is wrapped.

        Returns
        -------
        str
            The table, the notes and :meth:`summary`.
        """
        w = max([len(c.id) for c in self.checks] + [5])
        k = max([len(c.kind) for c in self.checks] + [4])
        lines = [f"fsmctl prove --law {self.spec or self.law}: law {self.law} ({self.error_model} error kinematics)"]
        lines.append(f"{'check':{w}}  {'kind':{k}}  result  seconds  statement")
        lines.append("-" * min(width, w + k + 40))
        for c in self.checks:
            result = _RESULT[c.passed]
            lines.append(f"{c.id:{w}}  {c.kind:{k}}  {result:6}  {c.seconds:7.2f}  {c.statement}")
            for para in c.detail.splitlines():
                lines.extend(
                    textwrap.wrap(para, width=width, initial_indent="    ", subsequent_indent="      ") or [""]
                )
        lines += [f"note: {n}" for n in self.notes]
        lines.append(self.summary())
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """Strict JSON-able (no NaN/inf): ``law``, ``spec``, ``error_model``, ``ok``, ``checks``, ``notes``."""
        out = {
            "law": self.law,
            "spec": self.spec,
            "source": self.source,
            "error_model": self.error_model,
            "ok": self.ok,
            "checks": [c.to_dict() for c in self.checks],
            "notes": list(self.notes),
            "summary": self.summary(),
        }
        json.dumps(out, allow_nan=False)  # fail here, not in the caller's writer
        return out

    def to_markdown(self) -> str:
        """Markdown with the LaTeX of each checked statement (``$$ ... $$``)."""
        out = [f"# fsmctl prove --law {self.spec or self.law}", ""]
        source = f", from `{self.source}`" if self.source else ""
        out += [f"Law **{self.law}** ({self.error_model} error kinematics){source}.", ""]
        out += [
            "Kinds: **checked** (compared, pass/fail), **derived** (computed, shown), **proved** (SymPy), "
            "**evidence** (sampling only: not a proof), **fails** (counterexample), **not declared**.",
            "",
            "| check | kind | result | seconds |",
            "|---|---|---|---|",
        ]
        out += [f"| [`{c.id}`](#{c.id}) | {c.kind} | {_RESULT[c.passed]} | {c.seconds:.2f} |" for c in self.checks]
        out += ["", self.summary(), ""]
        for c in self.checks:
            out += [f"## {c.id}", "", f"{c.statement} Kind: **{c.kind}**.", ""]
            if c.latex:
                out += ["$$", c.latex, "$$", ""]
            out += [f"- {line}" for line in c.detail.splitlines()]
            out.append("")
        if self.notes:
            out += ["## notes", ""] + [f"- {n}" for n in self.notes] + [""]
        return "\n".join(out)


_RESULT = {True: "ok", False: "FAILS", None: "-"}


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple, np.ndarray)):
        return [_jsonable(v) for v in (x.tolist() if isinstance(x, np.ndarray) else x)]
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(float(x)) else str(float(x))
    if x is None or isinstance(x, str):
        return x
    return str(x)


# ----------------------------------------------------------------------------------------------- loading


def _builtin_variants(name: str) -> LawVariants | None:
    """The built-in law called ``name``, from its derivation script (its folder's ``source``), or None."""
    from fsmctl.codegen.laws import load_derivation_script

    law = builtin_laws().get(name)
    if law is None:
        return None
    return load_derivation_script(Path(law.script()))


def load_law_variants(spec: str) -> LawVariants:
    """The symbolic law (both error models) of a built-in name or a derivation script ``FILE.py``.

    A derived folder holds the generated code only, not the SymPy expressions: it raises
    :class:`~fsmctl.model.laws.LawError` (unless it is a built-in law's folder).

    Raises
    ------
    LawError
        Unknown name, missing file, or a derived folder.
    fsmctl.symbolic.law.LawDefinitionError
        The script fails to import or to build its law.
    """
    from fsmctl.codegen.laws import load_derivation_script

    text = str(spec)
    if "/" not in text and not text.endswith(".py"):
        variants = _builtin_variants(text)
        if variants is not None:
            return variants
    path = Path(text).expanduser()
    if path.is_dir():
        meta_file = path / "law.json"
        try:
            meta = json.loads(meta_file.read_text("utf-8"))
        except (OSError, ValueError):
            meta = None
        if meta is None:
            raise LawError(f"law {text!r}: not a law folder (no readable law.json)")
        code = resolve_law(path)
        if code.builtin:
            variants = _builtin_variants(code.name)
            if variants is not None:
                return variants
        source = code.script() or "its derivation script"
        raise LawError(
            f"law {text!r}: a derived folder holds only the generated code; `fsmctl prove --law` needs the "
            f"derivation script (law.json names it {source!r}): pass that FILE.py"
        )
    if path.suffix == ".py":
        if not path.is_file():
            raise LawError(f"law {text!r}: no such derivation script")
        return load_derivation_script(path)
    raise LawError.unknown(text, builtin_laws())


# ----------------------------------------------------------------------------------------------- helpers


_INDEXED = re.compile(r"^(\w+)\[([\d,]+)\]$")


def _symbol_latex(symbol: sp.Symbol) -> str:
    """``sigma[0]`` -> ``{\\sigma}_{0}``, ``J0[0,1]`` -> ``{J_{0}}_{01}`` (the contract's names, readable)."""
    m = _INDEXED.match(symbol.name)
    if not m:
        return sp.latex(symbol)
    return f"{{{sp.latex(sp.Symbol(m.group(1)))}}}_{{{m.group(2).replace(',', '')}}}"


def _latex(expr, limit: int = LATEX_LIMIT) -> str:
    names = {s: _symbol_latex(s) for s in sp.sympify(expr).free_symbols if isinstance(s, sp.Symbol)}
    text = sp.latex(expr, symbol_names=names)
    if len(text) > limit:
        return rf"\text{{({len(text):,} characters of LaTeX, not shown)}}"
    return text


def _unique_symbols(law: Law, names: Iterable[str]) -> list[sp.Symbol]:
    out, seen = [], set()
    for n in names:
        for s in law.symbols[n]:
            if s not in seen:
                seen.add(s)
                out.append(s)
    return out


def _paper_J0s() -> list[np.ndarray]:
    from fsmctl.model.scenario import paper_scenario

    return [np.array(a.J0, dtype=float) for a in paper_scenario("1").agents]


def _random_J0(rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` symmetric positive definite inertias near the paper scenario's (kg m^2)."""
    base = _paper_J0s()
    out = np.empty((n, 3, 3))
    for i in range(n):
        while True:
            f = rng.uniform(-J0_SPREAD, J0_SPREAD, size=(3, 3))
            J = base[rng.integers(len(base))] * (1 + (f + f.T) / 2)
            if np.linalg.eigvalsh(J).min() > 0:
                out[i] = J
                break
    return out


def _admissible(p, default: float, value: float) -> float:
    for _ in range(40):
        if p.problem(value) is None:
            return value
        value = (value + default) / 2
    return default


def _parameter_rows(law: Law, rng: np.random.Generator, n: int, perturbed: bool) -> np.ndarray:
    """``(n, n_params)``: the declared defaults, or (``perturbed``) random admissible values near them.

    A perturbed value is ``default * U(0.5, 1.5)`` (``U(0, 0.1)`` for a zero default) moved back towards the
    default until it is inside the declared range; an option takes a random choice; an untunable number keeps
    its default.
    """
    rows = np.empty((n, law.n_params))
    for i in range(n):
        row = []
        for p in law.parameters:
            if not perturbed:
                row.extend(p.default)
            elif p.choices:
                row.append(float(rng.integers(len(p.choices))))
            elif not p.tunable:
                row.extend(p.default)
            else:
                for d in p.default:
                    v = rng.uniform(0.0, 0.1) if d == 0 else d * rng.uniform(0.5, 1.5)
                    row.append(_admissible(p, d, v))
        rows[i] = row
    return rows


def _lambdify(symbols: Sequence[sp.Symbol], exprs: Sequence[sp.Expr]):
    """A vectorised numeric function of ``exprs``: arrays ``(n,)`` per symbol in, ``(len(exprs), n)`` out."""
    # use_imps=False: lambdify would otherwise walk the whole (unshared) tree looking for implemented functions
    f = sp.lambdify(list(symbols), list(exprs), modules="numpy", cse=lambda e: sp.cse(e, order="none"), use_imps=False)

    def call(values: dict, n: int) -> np.ndarray:
        args = [values[s] for s in symbols]
        with np.errstate(all="ignore"):
            out = f(*args)
        return np.array([np.broadcast_to(np.asarray(v, dtype=float), (n,)) for v in out]).reshape(len(exprs), n)

    return call


def _switching_functions(exprs: Iterable) -> list[sp.Expr]:
    """The arguments of ``sign``/``Heaviside`` and the gaps ``lhs - rhs`` of the inequalities of ``Piecewise``.

    Equalities (``Eq(fix, 1)``: an option chosen by a parameter) are not surfaces and are left out.
    """
    out: list[sp.Expr] = []

    def relational(cond):
        if isinstance(cond, (sp.StrictLessThan, sp.LessThan, sp.StrictGreaterThan, sp.GreaterThan)):
            out.append(cond.lhs - cond.rhs)
        elif isinstance(cond, (sp.And, sp.Or, sp.Not)):
            for a in cond.args:
                relational(a)

    for e in exprs:
        for a in e.atoms(sp.sign, sp.Heaviside):
            out.append(a.args[0])
        for pw in e.atoms(sp.Piecewise):
            for _, cond in pw.args:
                relational(cond)
    return list(dict.fromkeys(out))


# ------------------------------------------------------------------------------------- sampled inputs


@dataclass
class _Inputs:
    """Numeric values of a law's inputs at ``n`` points: ``values[symbol] -> (n,)`` and the packed arrays."""

    n: int
    values: dict
    arrays: dict
    """contract input name -> (n, ...) array, as the generated functions take them"""


def _sample_inputs(law: Law, rng: np.random.Generator, n: int) -> _Inputs:
    half = n // 2
    near = n // 4
    arrays = {
        "t": rng.uniform(0.0, T_MAX, size=(n, 1)),
        "sigma": uniform_ball_points(rng, n, 3, SIGMA_BOUND),
        "omega": uniform_ball_points(rng, n, 3, OMEGA_BOUND),
        "z": uniform_ball_points(rng, n, law.n_states, Z_BOUND),
        "sigma_d": uniform_ball_points(rng, n, 3, SIGMA_D_BOUND),
        "omega_d": uniform_ball_points(rng, n, 3, OMEGA_D_BOUND),
        "omega_d_dot": uniform_ball_points(rng, n, 3, OMEGA_D_DOT_BOUND),
        "J0": _random_J0(rng, n),
        "params": np.vstack([_parameter_rows(law, rng, half, False), _parameter_rows(law, rng, n - half, True)]),
        "k_sum": rng.uniform(0.0, K_MAX, size=(n, 1)),
        "received": rng.uniform(-RECEIVED_BOUND, RECEIVED_BOUND, size=(n, law.n_broadcast)),
        "k_received_sum": rng.uniform(0.0, K_MAX, size=(n, 1)),
        "u_max": rng.uniform(*U_MAX_RANGE, size=(n, 1)),
    }
    # a quarter of the points close to the reference, so that small errors (|sigma_e,k| ~ 1e-4: the band of a
    # Remark 6 device) are covered too
    arrays["sigma"][:near] = arrays["sigma_d"][:near] + rng.uniform(-NEAR_REFERENCE, NEAR_REFERENCE, size=(near, 3))
    return _Inputs(n, _symbol_values(law, arrays), arrays)


def _symbol_values(law: Law, arrays: dict) -> dict:
    values = {}
    for name, a in arrays.items():
        m = law.symbols[name]
        if name == "J0":
            for i in range(3):
                for j in range(3):
                    values.setdefault(m[i, j], a[:, i, j])
        else:
            for k, s in enumerate(m):
                values[s] = a[:, k]
    return values


REGION_TEXT = (
    f"|sigma| <= {SIGMA_BOUND}, |omega| <= {OMEGA_BOUND}, |z| <= {Z_BOUND}, |sigma_d| <= {SIGMA_D_BOUND}, "
    f"|omega_d| <= {OMEGA_D_BOUND}, |omega_d_dot| <= {OMEGA_D_DOT_BOUND}, t in [0, {T_MAX:g}], J0 = a paper "
    f"scenario J0 with entries scaled by 1 +- {J0_SPREAD} (SPD), k_sum, k_received_sum in [0, {K_MAX:g}], "
    f"received in [-{RECEIVED_BOUND:g}, {RECEIVED_BOUND:g}], u_max in [{U_MAX_RANGE[0]:g}, {U_MAX_RANGE[1]:g}]; "
    "half the points at the declared parameter defaults, half at random admissible values (options at random); "
    f"a quarter of the points near the reference (sigma = sigma_d + U(-{NEAR_REFERENCE:g}, {NEAR_REFERENCE:g}) per "
    "component)"
)


# ----------------------------------------------------------------------------- 1. generated == symbolic


def _as_outputs(value, n_out: int) -> list[np.ndarray]:
    if not isinstance(value, (tuple, list)):
        value = [value]
    if len(value) != n_out:
        raise LawError(f"a generated function returned {len(value)} outputs, expected {n_out}")
    return [np.asarray(v, dtype=float).ravel() for v in value]


def _check_generated(law: Law, code: LawCode, rng: np.random.Generator, samples: int, seed: int) -> LawCheck:
    statement = (
        f"the generated law_constants, law_local_{law.error_model.value} and law_control_{law.error_model.value} "
        "equal the symbolic law"
    )
    problems = []
    if code.name != law.name:
        problems.append(f"the generated code is of law {code.name!r}, the script's of {law.name!r}")
    for what in ("n_params", "n_states", "n_broadcast", "n_constants", "n_cache"):
        a, b = getattr(code, what), getattr(law, what)
        if a != b:
            problems.append(f"{what}: generated {a}, symbolic {b}")
    if problems:
        return LawCheck(
            "generated-equals-symbolic", CHECKED, statement,
            "the generated code does not match the law's declarations (derive it again): " + "; ".join(problems),
            passed=False,
        )  # fmt: skip
    local_name, control_name = contract_names(law.error_model)
    f_const, f_local, f_control = code.casadi("law_constants"), code.casadi(local_name), code.casadi(control_name)

    # the symbolic side: every output in the contract's inputs only (stages and constants substituted); the
    # applied torque u is the law's symbolic saturate(torque, u_max), evaluated on the symbolic torque
    from fsmctl.symbolic.controller import saturate

    cache = [s for _, m in law.cache for s in m]
    blocks = {
        "constants": list(law.symbols["constants"]),
        "broadcast": list(law.broadcast),
        "cache": cache,
        "u_commanded": list(law.torque),
        "z_dot": list(law.state_derivative),
    }
    t0 = time.perf_counter()
    flat = [e for exprs in blocks.values() for e in exprs]
    with sp.evaluate(False):  # keeps the substituted tree as built (SymPy's automatic evaluation takes long)
        expanded = list(law.expanded(sp.ImmutableMatrix(flat))) if flat else []
        surfaces = _switching_functions(
            [law.torque, law.broadcast, law.state_derivative]
            + [v for _, _, v in (*law.constants, *law.local_stages, *law.control_stages)]
        )
        surfaces_expanded = list(law.expanded(sp.ImmutableMatrix(surfaces))) if surfaces else []
    inputs = _unique_symbols(
        law, ("t", "sigma", "omega", "z", "sigma_d", "omega_d", "omega_d_dot", "J0", "params", "k_sum", "received",
              "k_received_sum", "u_max")
    )  # fmt: skip
    symbolic_fn = _lambdify(inputs, expanded)
    surface_fn = _lambdify(inputs, surfaces_expanded) if surfaces_expanded else None
    torque_syms = [sp.Symbol(f"_torque{k}", real=True) for k in range(3)]
    u_max = law.symbols["u_max"][0]
    saturate_fn = _lambdify([*torque_syms, u_max], list(saturate(sp.ImmutableMatrix(torque_syms), u_max)))
    t_lambdify = time.perf_counter() - t0

    x = _sample_inputs(law, rng, samples)
    sym = symbolic_fn(x.values, samples) if expanded else np.zeros((0, samples))
    k_u = len(blocks["constants"]) + len(blocks["broadcast"]) + len(cache)
    u_sym = saturate_fn({**dict(zip(torque_syms, sym[k_u : k_u + 3], strict=True)), u_max: x.values[u_max]}, samples)
    sym = np.vstack([sym[:k_u], u_sym, sym[k_u:]])
    blocks = {**{k: v for k, v in blocks.items() if k in ("constants", "broadcast", "cache")}, "u": torque_syms,
              "u_commanded": blocks["u_commanded"], "z_dot": blocks["z_dot"]}  # fmt: skip
    near = np.zeros(samples, dtype=bool)
    if surface_fn is not None:
        g = surface_fn(x.values, samples)
        near = np.any(np.abs(g) < SURFACE_BAND, axis=0) | ~np.all(np.isfinite(g), axis=0)

    # the generated side, point by point, chained as the engine chains them
    a = x.arrays
    gen_rows = []
    for i in range(samples):
        agent = [a["t"][i], a["sigma"][i], a["omega"][i], a["z"][i], a["sigma_d"][i], a["omega_d"][i],
                 a["omega_d_dot"][i], a["J0"][i], a["params"][i]]  # fmt: skip
        (constants,) = _as_outputs(f_const(a["params"][i]), 1)
        broadcast, cache_v = _as_outputs(f_local(*agent, constants), 2)
        u, uc, zd = _as_outputs(
            f_control(
                *agent, constants, cache_v, a["k_sum"][i], a["received"][i], a["k_received_sum"][i], a["u_max"][i]
            ),
            3,
        )
        gen_rows.append(np.concatenate([constants, broadcast, cache_v, u, uc, zd]))
    gen = np.array(gen_rows).T.reshape(len(flat) + 3, samples)

    # relative error per output block and point: ||gen - sym||_inf / max(||sym||_inf, 1e-12)
    worst = (0.0, "", -1)
    nonfinite = 0
    k = 0
    block_errors = {}
    for name, exprs in blocks.items():
        m = len(exprs)
        if m == 0:
            continue
        s, gv = sym[k : k + m], gen[k : k + m]
        k += m
        finite = np.all(np.isfinite(s), axis=0) & np.all(np.isfinite(gv), axis=0)
        both_nan = np.all(~np.isfinite(s), axis=0) & np.all(~np.isfinite(gv), axis=0)
        err = np.max(np.abs(gv - s), axis=0) / np.maximum(np.max(np.abs(s), axis=0), 1e-12)
        err = np.where(finite, err, np.where(both_nan, 0.0, np.inf))
        err[near] = 0.0
        nonfinite += int(np.sum(~finite & ~near))
        block_errors[name] = float(np.max(err))
        i = int(np.argmax(err))
        if err[i] > worst[0] or worst[2] < 0:
            worst = (float(err[i]), name, i)
    max_err, worst_block, worst_i = worst
    n_used = int(samples - near.sum())
    passed = bool(max_err <= TOLERANCE and n_used > 0)  # no point compared is no check
    lines = [
        f"{n_used} of {samples} random points (seed {seed}) compared; {int(near.sum())} excluded: within "
        f"{SURFACE_BAND:g} of one of the law's {len(surfaces)} switching surfaces g = 0 (g a sign argument or "
        "the gap of a Piecewise inequality), where the two sides may legitimately take different branches",
        f"region: {REGION_TEXT}",
        "symbolic side: Law.expanded (stages and constants substituted) evaluated by sympy.lambdify (numpy); "
        "generated side: law_constants -> law_local -> law_control chained as the engine does "
        f"({'compiled C' if _is_external(f_control) else 'CasADi'})",
        "max relative error (||generated - symbolic||_inf / max(||symbolic||_inf, 1e-12), per output): "
        + ", ".join(f"{name} {e:.2e}" for name, e in block_errors.items()),
        f"[{'ok' if passed else 'FAILS'}] max relative error {max_err:.3e} ({worst_block}) <= {TOLERANCE:g}",
        f"(lambdify of the symbolic law: {t_lambdify:.1f} s)",
    ]
    data = {"max_relative_error": max_err, "tolerance": TOLERANCE, "points": samples, "compared": n_used,
            "excluded_near_switching": int(near.sum()), "block_errors": block_errors, "seed": seed,
            "switching_functions": [_short(g) for g in surfaces]}  # fmt: skip
    if not passed and worst_i >= 0:
        point = {name: a[name][worst_i].tolist() for name in ("sigma", "omega", "z", "sigma_d", "omega_d", "params")}
        lines.append(f"worst point ({worst_block}): {point}")
        data["worst_point"] = point
    if nonfinite:
        lines.append(f"{nonfinite} output blocks were not finite on one side only")
    return LawCheck(
        "generated-equals-symbolic", CHECKED, statement, "\n".join(lines),
        latex=rf"\max_i \frac{{\|f_{{\mathrm{{gen}}}}(x_i) - f_{{\mathrm{{sym}}}}(x_i)\|_\infty}}"
        rf"{{\|f_{{\mathrm{{sym}}}}(x_i)\|_\infty}} = {_latex_float(max_err)} \le 10^{{-9}}",
        passed=passed, data=data,
    )  # fmt: skip


WHEEL_SPEED_BOUND = 300.0
"""|Omega_k| (rad/s) of the wheel speeds the wheel check samples"""
SPIN_INERTIA_RANGE = (0.01, 0.2)
"""spin inertias (kg m^2) the wheel check samples"""


def _spin_axes(rng: np.random.Generator, n_wheels: int) -> np.ndarray:
    """Random unit spin axes (3 x N) that span the body well (smallest singular value >= 0.3)."""
    while True:
        G = rng.normal(size=(3, n_wheels))
        G /= np.linalg.norm(G, axis=0)
        if np.linalg.svd(G, compute_uv=False)[-1] >= 0.3:
            return G


def _check_wheels(law: Law, code: LawCode, rng: np.random.Generator, samples: int, seed: int) -> LawCheck:
    """``-G u_w = u`` at sampled points: the law's wheel commands produce its applied body torque."""
    model = law.error_model.value
    name = wheels_function_name(law.error_model)
    statement = (
        f"the wheel commands u_w of {name} produce on the body the law's applied torque u of "
        f"law_control_{model}: -G u_w = sat(u_commanded, u_max)"
    )
    n = law.n_wheels
    if code.n_wheels != n:
        return LawCheck(
            "wheels-realise-torque", CHECKED, statement,
            f"the generated code commands {code.n_wheels} wheels, the law {n} (derive it again)", passed=False,
        )  # fmt: skip
    local_name, control_name = contract_names(law.error_model)
    f_const, f_local, f_control = code.casadi("law_constants"), code.casadi(local_name), code.casadi(control_name)
    f_wheels = code.casadi(name)
    x = _sample_inputs(law, rng, samples)
    a = x.arrays
    errors = np.empty(samples)
    largest_null = 0.0
    for i in range(samples):
        G = _spin_axes(rng, n)
        speed = rng.uniform(-WHEEL_SPEED_BOUND, WHEEL_SPEED_BOUND, size=n)
        spin = rng.uniform(*SPIN_INERTIA_RANGE, size=n)
        agent = [a["t"][i], a["sigma"][i], a["omega"][i], a["z"][i], a["sigma_d"][i], a["omega_d"][i],
                 a["omega_d_dot"][i], a["J0"][i], a["params"][i]]  # fmt: skip
        (constants,) = _as_outputs(f_const(a["params"][i]), 1)
        _, cache = _as_outputs(f_local(*agent, constants), 2)
        neighbours = [a["k_sum"][i], a["received"][i], a["k_received_sum"][i], a["u_max"][i]]
        u = _as_outputs(f_control(*agent, constants, cache, *neighbours), 3)[0]
        (u_w,) = _as_outputs(f_wheels(*agent, constants, cache, *neighbours, G, speed, spin), 1)
        scale = max(np.abs(u).max(), np.abs(u_w).max(), 1e-12)
        errors[i] = np.abs(-G @ u_w - u).max() / scale
        minimum_norm = -np.linalg.pinv(G) @ u
        largest_null = max(largest_null, float(np.abs(u_w - minimum_norm).max()))
    errors = np.where(np.isfinite(errors), errors, np.inf)
    worst = int(np.argmax(errors))
    max_err = float(errors[worst])
    passed = bool(max_err <= TOLERANCE)
    lines = [
        f"{samples} random points (seed {seed}); region: {REGION_TEXT}; spin axes: {n} random unit vectors spanning "
        f"the body (smallest singular value >= 0.3), wheel speeds |Omega_k| <= {WHEEL_SPEED_BOUND:g} rad/s, spin "
        f"inertias in [{SPIN_INERTIA_RANGE[0]:g}, {SPIN_INERTIA_RANGE[1]:g}] kg m^2",
        "u: the applied torque law_control returns (the law's torque limited by u_max, what an ideal actuator "
        f"applies); u_w: {name}; the wheels' own limits are the engine's, after",
        f"largest departure of u_w from the minimum-norm -pinv(G) u (null motion, or a wrong command): "
        f"{largest_null:.3e} N m",
        f"[{'ok' if passed else 'FAILS'}] max ||-G u_w - u||_inf / max(||u||_inf, ||u_w||_inf) = {max_err:.3e} "
        f"<= {TOLERANCE:g}",
    ]
    data = {"max_relative_error": max_err, "tolerance": TOLERANCE, "points": samples, "seed": seed,
            "largest_null_motion": largest_null}  # fmt: skip
    if not passed:
        point = {key: a[key][worst].tolist() for key in ("sigma", "omega", "z", "sigma_d", "omega_d", "params")}
        lines.append(f"worst point: {point}")
        data["worst_point"] = point
    return LawCheck(
        "wheels-realise-torque", CHECKED, statement, "\n".join(lines),
        latex=rf"\max_i \frac{{\|-G u_w(x_i) - u(x_i)\|_\infty}}{{\max(\|u\|_\infty, \|u_w\|_\infty)}} = "
        rf"{_latex_float(max_err)} \le 10^{{-9}}",
        passed=passed, data=data,
    )  # fmt: skip


def _short(expr, limit: int = 120) -> str:
    text = str(expr)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _is_external(f) -> bool:
    try:
        return f.class_name() == "External"
    except Exception:
        return False


def _latex_float(x: float) -> str:
    if x == 0:
        return "0"
    if not math.isfinite(x):
        return r"\infty"
    m, e = f"{x:.2e}".split("e")
    return rf"{m} \times 10^{{{int(e)}}}"


# ----------------------------------------------------------------------------------- 2. closed loop


@dataclass
class _ClosedLoop:
    law: Law
    rest: dict
    """input symbol -> 0 (the reference at rest, no neighbours)"""
    stages: dict
    """stage/constant symbol -> its value at rest (in the agent's inputs)"""
    lines: list[str]
    u: sp.ImmutableMatrix
    sigma_dot: sp.ImmutableMatrix
    omega_dot: sp.ImmutableMatrix
    z_dot: sp.ImmutableMatrix
    shadow: bool
    """sigma_e = sigma was established on |sigma| <= 1"""

    def at_rest(self, expr) -> sp.ImmutableMatrix:
        m = sp.ImmutableMatrix(expr) if isinstance(expr, sp.MatrixBase) else sp.ImmutableMatrix([sp.sympify(expr)])
        return m.xreplace(self.rest).xreplace(self.stages)

    @property
    def state(self) -> sp.ImmutableMatrix:
        law = self.law
        return sp.ImmutableMatrix.vstack(law.symbols["sigma"], law.symbols["omega"], law.symbols["z"])

    @property
    def f(self) -> sp.ImmutableMatrix:
        return sp.ImmutableMatrix.vstack(self.sigma_dot, self.omega_dot, self.z_dot)


def _closed_loop(law: Law) -> _ClosedLoop:
    sym = law.symbols
    rest = {s: sp.S.Zero for n in ("sigma_d", "omega_d", "omega_d_dot", "k_sum", "received", "k_received_sum")
            for s in sym[n]}  # fmt: skip
    sigma, omega, J0 = sym["sigma"], sym["omega"], sym["J0"]
    names = [n for n, _, _ in law.local_stages]
    error_state = all(n in names for n in ERROR_STAGES)
    stages: dict = {}
    lines: list[str] = []
    shadow = False
    for name, syms, value in (*law.constants, *law.local_stages, *law.control_stages):
        v = sp.ImmutableMatrix(value).xreplace(rest).xreplace(stages)
        if error_state and name == "sigma_e":
            reduced, how = resolve_branches_on_unit_ball(v, sigma)
            shadow = identically_zero(list(reduced - sigma))
            if shadow:
                v = sigma
                lines.append(
                    "[ok] at rest sigma_e = mrp_error(sigma, 0) = sigma on the shadow set |sigma| <= 1 "
                    f"(SymPy cancel after taking the branch that holds there: {'; '.join(how) or 'none'})"
                )
            else:
                lines.append("[--] sigma_e at rest could not be reduced to sigma; kept as derived")
        stages.update(zip(syms, v, strict=True))
    cl_rest = sp.ImmutableMatrix
    u = cl_rest(law.torque).xreplace(rest).xreplace(stages)
    z_dot = cl_rest(law.state_derivative).xreplace(rest).xreplace(stages)
    if error_state:
        for name, expected in (("omega_e", omega), ("omega_r", sp.zeros(3, 1)), ("omega_r_dot", sp.zeros(3, 1))):
            syms = next(s for n, s, _ in law.local_stages if n == name)
            value = sp.ImmutableMatrix([stages[s] for s in syms])
            ok = identically_zero(list(value - expected))
            lines.append(f"[{'ok' if ok else '--'}] at rest {name} = {'omega' if name == 'omega_e' else '0'}")
    sigma_dot = sp.ImmutableMatrix(mrp_G(sigma) * omega)
    omega_dot = sp.ImmutableMatrix(J0.adjugate() * (u - skew(omega) * J0 * omega) / J0.det())
    return _ClosedLoop(law, rest, stages, lines, sp.ImmutableMatrix(u), sigma_dot, omega_dot,
                       sp.ImmutableMatrix(z_dot), shadow)  # fmt: skip


def _check_closed_loop(cl: _ClosedLoop) -> LawCheck:
    law = cl.law
    latex = (
        r"\dot\sigma = G(\sigma)\,\omega,\qquad \dot\omega = J_0^{-1}\big(u - \omega^\times J_0\,\omega\big),"
        rf"\qquad u = {_latex(cl.u)}"
    )
    if law.n_states:
        latex += rf",\qquad \dot z = {_latex(cl.z_dot)}"
    lines = [
        "the isolated agent: J = J0, no disturbance, no neighbours (received = 0, k_sum = 0, k_received_sum = 0), "
        "the reference at rest (sigma_d = 0, omega_d = omega_d_dot = 0); the commanded torque u (the actuator "
        "limit is left out)",
        *cl.lines,
        f"u has {sp.count_ops(cl.u)} operations; omega_dot = adj(J0) (u - omega x J0 omega) / det(J0)",
    ]
    if law.n_states:
        lines.append(f"z_dot has {sp.count_ops(cl.z_dot)} operations")
    if _is_paper_law(law):
        lines.append("its readable form is eq 20, in sigma: see closed-loop-eq20")
    return LawCheck(
        "closed-loop", DERIVED,
        "the closed loop of the isolated agent in error coordinates (sigma_e = sigma, omega_e = omega)",
        "\n".join(lines), latex=latex, passed=None,
    )  # fmt: skip


def _is_paper_law(law: Law) -> bool:
    """Whether the law declares that it is the paper's eqs 13-19 (``LawBuilder.paper_theorems``)."""
    return law.paper_theorems is not None


def _parameter_column(law: Law, name: str) -> int:
    """The column of the scalar parameter ``name`` in the packed ``params``."""
    k = 0
    for q in law.parameters:
        if q.name == name:
            return k
        k += q.size
    raise KeyError(name)


def _check_eq20(cl: _ClosedLoop, rng: np.random.Generator, samples: int) -> LawCheck:
    """``sigma_ddot`` of the FSM closed loop is eq 20 with no coordination (and the broadcast s is eq 13)."""
    from fsmctl.symbolic.controller import closed_loop_acceleration, sliding_variable

    law = cl.law
    sym = law.symbols
    sigma, omega, J0 = sym["sigma"], sym["omega"], sym["J0"]
    by_name = law.parameter_symbols()
    p = {role: by_name[name] for role, name in law.paper_theorems.parameters}  # the declared roles
    statement = (
        "the law declares it is the paper's eqs 13-19 (LawBuilder.paper_theorems): sigma_ddot of the closed loop "
        "is eq 20 (no coordination) and the broadcast is s of eq 13"
    )
    if law.n_broadcast != 3:
        return LawCheck(
            "closed-loop-eq20", CHECKED, statement,
            f"[FAILS] the broadcast {law.broadcast_name} has {law.n_broadcast} components; eq 19 broadcasts s (3)",
            passed=False,
        )  # fmt: skip
    s = cl.at_rest(law.broadcast)
    G = mrp_G(sigma)
    sigma_dot = sp.ImmutableMatrix(G * omega)
    kw = {"boundary_layer": p["boundary_layer"], "fix": p["singularity_fix"], "epsilon": p["epsilon"]}
    eq20 = closed_loop_acceleration(sigma, sigma_dot, s, p["c1"], p["c2"], p["alpha"], p["delta"], sp.zeros(3, 1), **kw)
    eq13 = sliding_variable(sigma, sigma_dot, p["c1"], p["c2"], p["alpha"], kw["fix"], kw["epsilon"])
    Gd = mrp_G_dot(sigma, sigma_dot)
    # sigma_ddot = G_dot omega + G omega_dot = eq20  <=>  u - omega x J0 omega = J0 G^-1 (eq20 - G_dot omega)
    # (J0 and G are invertible); the right side is written with G^-1 = 16 G^T / (1 + |sigma|^2)^2
    residual = cl.u - skew(omega) * J0 * omega - J0 * mrp_G_inverse(sigma) * (eq20 - Gd * omega)
    surface = list(s - eq13)
    finished, value = run_with_time_limit(
        lambda: (identically_zero(surface), identically_zero(list(residual))), SYMBOLIC_BUDGET
    )
    symbolic = finished and isinstance(value, tuple) and all(value)
    lines = [
        "eq 20 (Liang, Sun & Wang 2012) with the coordination term 0: sigma_e_ddot = -(c1 sigma_e_dot + c2 alpha "
        "|sigma_e|^(alpha-1) o sigma_e_dot) - delta o sgn(s) (sat(s/phi) for a boundary layer), Remark 6 device "
        "per singularity_fix (fsmctl.symbolic.controller.closed_loop_acceleration)",
    ]
    if symbolic:
        lines.append(
            "[ok] symbolic: u - omega x J0 omega - J0 G^-1 (eq20 - G_dot omega) cancels to 0 for symbolic J0 and "
            "every parameter (Piecewise/sign/Abs/powers held as opaque symbols), so sigma_ddot = G_dot omega + "
            "G omega_dot = eq 20; and the broadcast s is eq 13"
        )
    else:
        if not finished:
            why = f"not within the time budget of {SYMBOLIC_BUDGET:g} s"
        elif isinstance(value, str):
            why = value
        else:
            names = ("s = eq 13", "the torque identity")
            why = "did not cancel: " + ", ".join(n for n, ok in zip(names, value, strict=True) if not ok)
        lines.append(f"[--] no symbolic identity ({why}); the numeric comparison below decides")

    # numeric: sigma_ddot from the closed loop vs eq 20 at sampled points (always run: it also cross-checks)
    inputs = _unique_symbols(law, ("t", "sigma", "omega", "z", "J0", "params"))
    exprs = list(cl.u) + list(eq20) + list(s - eq13) + list(s)
    f = _lambdify(inputs, exprs)
    x = _sample_inputs(law, rng, samples)
    x.arrays["sigma"][: samples // 4] = rng.uniform(-NEAR_REFERENCE, NEAR_REFERENCE, size=(samples // 4, 3))
    x = _Inputs(samples, _symbol_values(law, x.arrays), x.arrays)
    val = f(x.values, samples)
    u, target, ds, s_num = val[0:3], val[3:6], val[6:9], val[9:12]
    near = np.any(np.abs(s_num) < SURFACE_BAND, axis=0)
    sg = x.arrays["sigma"]
    eps = x.arrays["params"][:, _parameter_column(law, law.paper_theorems.parameter("epsilon"))]
    near |= np.any(np.abs(np.abs(sg) - eps[:, None]) < SURFACE_BAND, axis=1)
    G_fn = sp.lambdify([list(sigma), list(omega)], [mrp_G(sigma), mrp_G_dot(sigma, sigma_dot)], modules="numpy")
    errs = np.zeros(samples)
    for i in range(samples):
        if near[i]:
            continue
        Gi, Gdi = (np.asarray(m, dtype=float) for m in G_fn(sg[i], x.arrays["omega"][i]))
        w = x.arrays["omega"][i]
        Ji = x.arrays["J0"][i]
        wd = np.linalg.solve(Ji, u[:, i] - np.cross(w, Ji @ w))
        sdd = Gdi @ w + Gi @ wd
        errs[i] = np.max(np.abs(sdd - target[:, i])) / max(np.max(np.abs(target[:, i])), 1e-12)
    s_err = float(np.max(np.where(near, 0.0, np.max(np.abs(ds), axis=0))))
    max_err = float(np.max(errs))
    numeric_ok = max_err <= TOLERANCE and s_err <= TOLERANCE and not near.all()
    lines.append(
        f"[{'ok' if numeric_ok else 'FAILS'}] numeric: at {int(samples - near.sum())} of {samples} points "
        f"(|sigma| <= {SIGMA_BOUND}, a quarter with |sigma_k| <= {NEAR_REFERENCE:g}, |omega| <= {OMEGA_BOUND}, "
        f"J0 near the paper's, parameters at defaults and random admissible values; {int(near.sum())} within "
        f"{SURFACE_BAND:g} of s_k = 0 or |sigma_k| = epsilon excluded): max relative error of sigma_ddot "
        f"{max_err:.2e}, max |s - eq 13| {s_err:.2e}"
    )
    passed = bool(numeric_ok)
    return LawCheck(
        "closed-loop-eq20", CHECKED, statement,
        "\n".join(lines),
        latex=r"\ddot\sigma = \dot G\,\omega + G\,J_0^{-1}(u - \omega^\times J_0\omega) = -\big(c_1\dot\sigma"
        r" + c_2\alpha|\sigma|^{\alpha-1}\circ\dot\sigma\big) - \delta\circ\mathrm{sgn}(s)",
        passed=passed, data={"symbolic": bool(symbolic), "max_relative_error": max_err, "s_error": s_err},
    )  # fmt: skip


# -------------------------------------------------------------------------------------- 3. Lyapunov


def _positive_parameters(law: Law) -> dict:
    """Parameter symbol -> a symbol with the sign its declared range gives (for reading off a sign)."""
    out = {}
    params = law.symbols["params"]
    k = 0
    for p in law.parameters:
        for j in range(p.size):
            s = params[k + j]
            if p.minimum is not None and p.minimum >= 0 and not p.choices:
                positive = p.minimum > 0 or p.exclusive_minimum
                out[s] = sp.Symbol(s.name, positive=True) if positive else sp.Symbol(s.name, nonnegative=True)
        k += p.size
    return out


def _manifestly_nonpositive(expr, law: Law) -> bool:
    """``expr <= 0`` read off its structure: ``-expr`` expanded is a sum of non-negative terms (squares times
    parameters that are non-negative by their declared range), checked by SymPy's assumptions."""
    e = sp.sympify(expr).xreplace(_positive_parameters(law))
    for form in (-e, sp.expand(-e), sp.factor(-e)):  # as written first: -P |w + Ki z|^2 has cross terms expanded
        if form.is_nonnegative:
            return True
    return False


def _lyapunov_derivative(cl: _ClosedLoop, V) -> sp.Expr:
    """``V_dot = dV/dt + grad V . f``, with ``grad_omega V^T J0^-1`` simplified first (``J0 adj J0 = det J0 I``)."""
    law = cl.law
    sym = law.symbols
    sigma, omega, z, J0 = sym["sigma"], sym["omega"], sym["z"], sym["J0"]
    t = sym["t"][0]
    grad_w = sp.ImmutableMatrix([sp.diff(V, w) for w in omega])
    det = J0.det()
    row = (grad_w.T * J0.adjugate()).applyfunc(lambda e: sp.cancel(sp.expand(e) / det))
    torque_side = cl.u - skew(omega) * J0 * omega
    vdot = sp.diff(V, t) + sum(sp.diff(V, s) * f for s, f in zip(sigma, cl.sigma_dot, strict=True))
    vdot += (row * torque_side)[0]
    vdot += sum(sp.diff(V, s) * f for s, f in zip(z, cl.z_dot, strict=True))
    return vdot


def _check_lyapunov(cl: _ClosedLoop, rng: np.random.Generator, samples: int) -> LawCheck:
    law = cl.law
    ly = law.lyapunov
    statement = "V_dot <= 0 along the closed loop of the isolated agent for the declared Lyapunov candidate"
    if ly is None:
        return LawCheck(
            "lyapunov", NOT_DECLARED, "a Lyapunov candidate (LawBuilder.lyapunov)",
            f"law {law.name} declares no Lyapunov candidate: nothing to prove here"
            + ("; the paper's own stability claims (eqs 23-28, Theorems 1-2) are checked by `fsmctl prove`"
               if _is_paper_law(law) else ""),
        )  # fmt: skip
    V = cl.at_rest(ly.V)[0]
    claimed = None if ly.claimed_derivative is None else cl.at_rest(ly.claimed_derivative)[0]
    finished, vdot = run_with_time_limit(lambda: _lyapunov_derivative(cl, V), SYMBOLIC_BUDGET)
    if not finished or isinstance(vdot, str) or not isinstance(vdot, sp.Basic) or vdot.has(sp.Derivative):
        why = (
            f"V_dot could not be formed within the time budget of {SYMBOLIC_BUDGET:g} s"
            if not finished
            else "V is not differentiable everywhere (derivatives of |.|/sgn remain in V_dot)"
            if isinstance(vdot, sp.Basic)
            else f"V_dot could not be formed ({vdot})"
        )
        return LawCheck(
            "lyapunov", EVIDENCE, statement,
            f"nothing concluded: {why}; no proof and no numeric evidence is claimed for this candidate"
            + (f" ({ly.doc})" if ly.doc else ""),
        )  # fmt: skip
    lines = [
        "along sigma_dot = G(sigma) omega, omega_dot = J0^-1 (u - omega x J0 omega), z_dot of check closed-loop "
        "(reference at rest, no neighbours, J = J0, no disturbance, the commanded torque)",
    ]
    if ly.doc:
        lines.insert(0, f"candidate: {ly.doc}")
    latex = rf"V = {_latex(V)},\qquad \dot V = {_latex(vdot)}"
    kind, passed = EVIDENCE, None
    identity = manifest = False
    if claimed is not None:
        residual = vdot - claimed
        finished, value = run_with_time_limit(
            lambda: (identically_zero([residual]), _manifestly_nonpositive(claimed, law)), SYMBOLIC_BUDGET
        )
        identity = finished and isinstance(value, tuple) and value[0] is True
        manifest = finished and isinstance(value, tuple) and value[1] is True
        if identity:
            how = "(SymPy: expand, together, cancel; Piecewise/sign/Abs/powers held as opaque symbols)"
        elif not finished:
            how = f"not shown symbolically within the time budget of {SYMBOLIC_BUDGET:g} s"
        elif isinstance(value, str):
            how = f"not shown symbolically ({value})"
        else:
            how = "not shown symbolically: the residual V_dot - claimed does not cancel"
        lines.append(f"[{'ok' if identity else '--'}] V_dot - claimed = 0 {how}")
        if identity:
            latex = rf"V = {_latex(V)},\qquad \dot V = {_latex(claimed)}"
        else:
            latex += rf",\qquad \text{{claimed: }} \dot V = {_latex(claimed)}"
        lines.append(
            f"[{'ok' if manifest else '--'}] claimed V_dot = {_short(claimed, 200)} is "
            + ("manifestly <= 0 (a non-negative sum of squares times parameters >= 0 by their declared ranges, "
               "negated)" if manifest else "not manifestly <= 0 by its structure")
        )  # fmt: skip
    else:
        lines.append("no claimed_derivative declared: nothing to prove symbolically")

    # numeric: V_dot (and the claim) over the declared region, parameters at their defaults
    region = dict(ly.region)
    sigma_bound = min(region.get("sigma", 1.0), 1.0) if cl.shadow else region.get("sigma", 1.0)
    capped = sigma_bound < region.get("sigma", 1.0)
    omega_bound, z_bound = region.get("omega", 0.5), region.get("z", 1.0)
    inputs = _unique_symbols(law, ("t", "sigma", "omega", "z", "J0", "params"))
    exprs = [vdot, V] + ([claimed] if claimed is not None else [])
    f = _lambdify(inputs, exprs)
    arrays = {
        "t": rng.uniform(0.0, T_MAX, size=(samples, 1)),
        "sigma": uniform_ball_points(rng, samples, 3, sigma_bound),
        "omega": uniform_ball_points(rng, samples, 3, omega_bound),
        "z": uniform_ball_points(rng, samples, law.n_states, z_bound),
        "J0": _random_J0(rng, samples),
        "params": _parameter_rows(law, rng, samples, False),
    }
    val = f(_symbol_values(law, arrays), samples)
    vd, v = val[0], val[1]
    scale = max(1.0, float(np.nanmax(np.abs(vd))) if np.any(np.isfinite(vd)) else 1.0)
    tol = 1e-10 * scale
    finite = np.isfinite(vd)
    frac = float(np.mean(vd[finite] <= tol)) if finite.any() else 0.0
    vmax = float(np.nanmax(vd)) if finite.any() else float("nan")
    region_text = (
        f"|sigma| <= {sigma_bound:g}{' (capped: sigma_e = sigma on the shadow set only)' if capped else ''}, "
        f"|omega| <= {omega_bound:g}"
        + (f", |z| <= {z_bound:g}" if law.n_states else "")
        + ", parameters at their defaults, J0 near the paper scenario's"
    )
    data = {"max_vdot": vmax, "fraction_nonpositive": frac, "points": samples, "region": region_text,
            "identity": bool(identity), "manifestly_nonpositive": bool(manifest)}  # fmt: skip
    lines.append(
        f"sampled V_dot at {samples} points ({region_text}): max {vmax:.3e}, "
        f"{100 * frac:.1f}% <= 0 (tolerance {tol:.1e})"
    )
    nonzero = (np.linalg.norm(arrays["sigma"], axis=1) + np.linalg.norm(arrays["omega"], axis=1)) > 1e-9
    if np.all(v[nonzero] > 0):
        lines.append(f"V > 0 at all {int(nonzero.sum())} sampled points (numeric; positive definiteness not proved)")
    else:
        i = int(np.argmin(np.where(nonzero, v, np.inf)))
        lines.append(f"V <= 0 at a sampled point: V = {v[i]:.3e} at sigma = {arrays['sigma'][i].tolist()}, "
                     f"omega = {arrays['omega'][i].tolist()}: not a positive definite candidate")  # fmt: skip
    claim_wrong = False
    if claimed is not None:
        dc = np.abs(vd - val[2])
        worst = int(np.nanargmax(np.where(finite, dc, -np.inf)))
        if dc[worst] > 1e-8 * scale:
            claim_wrong = True
            lines.append(
                "[FAILS] the declared claimed_derivative is not V_dot: V_dot - claimed = "
                f"{vd[worst] - val[2][worst]:.3e} at sigma = {arrays['sigma'][worst].tolist()}, "
                f"omega = {arrays['omega'][worst].tolist()}"
            )
            data["claim_residual_point"] = {"sigma": arrays["sigma"][worst].tolist(),
                                            "omega": arrays["omega"][worst].tolist()}  # fmt: skip
    positive = finite & (vd > tol)
    if positive.any():
        i = int(np.argmax(np.where(positive, vd, -np.inf)))
        point = {name: arrays[name][i].tolist() for name in ("sigma", "omega", "z")}
        point["J0"] = arrays["J0"][i].tolist()
        lines.append(f"[FAILS] V_dot = {vd[i]:.3e} > 0 at {point}")
        data["counterexample"] = point
        kind, passed = FAILS, False
    elif claim_wrong:
        kind, passed = FAILS, False
    elif identity and manifest:
        kind, passed = PROVED, True
        where = "every state with |sigma| <= 1 (the shadow set)" if cl.shadow else "every state"
        lines.append(
            f"proved: V_dot = claimed <= 0 for {where}, every symmetric invertible J0 and every admissible "
            "parameter value; this gives stability (Lyapunov), not asymptotic stability by itself"
        )
    else:
        kind, passed = EVIDENCE, None
        lines.append(f"numeric evidence over the region {region_text}, not a proof")
    return LawCheck("lyapunov", kind, statement, "\n".join(lines), latex=latex, passed=passed, data=data)


# ---------------------------------------------------------------------------------------------- entry


def check_law(
    spec: str,
    *,
    error_model: str = "paper",
    samples: int = 200,
    seed: int = 0,
    checks: Iterable[str] | None = None,
) -> LawReport:
    """Check a law (a built-in name or a derivation script ``FILE.py``): see the module docstring.

    Parameters
    ----------
    spec : str
        What ``--law`` names; a derived folder is refused (it has no SymPy expressions).
    error_model : ``"paper"`` or ``"exact"``
        Which generated functions check 1 compares (the closed loop at rest is the same for both).
    samples : int
        Random points of each numeric comparison (seeded by ``seed``).
    seed : int
        Seed of the random points.
    checks : iterable of str, optional
        A subset of :data:`CHECK_IDS` (default: all that apply); the generated code is only resolved (and
        derived/compiled) when ``generated-equals-symbolic`` runs.

    Returns
    -------
    LawReport
        The checks that ran, in the order of :data:`CHECK_IDS`.

    Raises
    ------
    LawError
        Unknown law, a derived folder, a bad error model or option.

    Examples
    --------
    An MRP PD law whose Lyapunov candidate ``V = 2K ln(1 + sigma^T sigma) + omega^T J0 omega / 2`` has
    ``V_dot = -P |omega|^2`` along the isolated agent's closed loop (Schaub & Junkins), proved by SymPy:

    >>> script = '''
    ... import sympy as sp
    ... from fsmctl.symbolic import LawBuilder
    ...
    ... def law(error_model):
    ...     b = LawBuilder("pdl", error_model, doc="MRP PD")
    ...     K = b.parameter("K", 2.0, minimum=0.0, exclusive_minimum=True)
    ...     P = b.parameter("P", 8.0, minimum=0.0, exclusive_minimum=True)
    ...     e = b.error_state()
    ...     b.broadcast("sigma_e", e.sigma_e)
    ...     b.torque(-K * e.sigma_e - P * e.omega_e)
    ...     s2, w = (b.sigma.T * b.sigma)[0], b.omega
    ...     b.lyapunov(2 * K * sp.log(1 + s2) + (w.T * b.J0 * w)[0] / 2, claimed_derivative=-P * (w.T * w)[0])
    ...     return b.build()
    ... '''
    >>> _ = open("pdl.py", "w").write(script)
    >>> report = check_law("pdl.py", checks=["lyapunov"], samples=20)
    >>> c = report.check("lyapunov")
    >>> report.ok, c.kind, c.passed
    (True, 'proved', True)
    >>> print(c.detail.splitlines()[1])
    [ok] V_dot - claimed = 0 (SymPy: expand, together, cancel; Piecewise/sign/Abs/powers held as opaque symbols)
    """
    if error_model not in ("paper", "exact"):
        raise LawError(f"error model must be 'paper' or 'exact', got {error_model!r}")
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
        raise LawError(f"samples must be a positive integer, got {samples!r}")
    wanted = set(CHECK_IDS if checks is None else checks)
    unknown = wanted - set(CHECK_IDS)
    if unknown:
        raise LawError(f"unknown law check(s) {sorted(unknown)}; known: {', '.join(CHECK_IDS)}")
    variants = load_law_variants(spec)
    law = variants.paper if error_model == "paper" else variants.exact
    out: list[LawCheck] = []

    def timed(fn, *args) -> LawCheck:
        t0 = time.perf_counter()
        c = fn(*args)
        return LawCheck(c.id, c.kind, c.statement, c.detail, c.latex, c.passed, time.perf_counter() - t0, c.data)

    source = ""
    if "generated-equals-symbolic" in wanted:
        code = resolve_law(spec)
        source = code.script(portable=True)
        out.append(timed(_check_generated, law, code, np.random.default_rng([seed, 1]), samples, seed))
    if "wheels-realise-torque" in wanted and law.n_wheels:
        code = resolve_law(spec)
        source = source or code.script(portable=True)
        out.append(timed(_check_wheels, law, code, np.random.default_rng([seed, 4]), samples, seed))
    cl = None
    if wanted & {"closed-loop", "closed-loop-eq20", "lyapunov"}:
        t0 = time.perf_counter()
        cl = _closed_loop(law)
        build = time.perf_counter() - t0
        if "closed-loop" in wanted:
            c = timed(_check_closed_loop, cl)
            out.append(LawCheck(c.id, c.kind, c.statement, c.detail, c.latex, c.passed, c.seconds + build, c.data))
    if cl is not None and "closed-loop-eq20" in wanted and _is_paper_law(law):
        out.append(timed(_check_eq20, cl, np.random.default_rng([seed, 2]), samples))
    if cl is not None and "lyapunov" in wanted:
        out.append(timed(_check_lyapunov, cl, np.random.default_rng([seed, 3]), samples))
    notes = [f"seed {seed}, {samples} samples per numeric check"]
    if _is_paper_law(law):
        notes.append(
            "the paper's own claims (Lemmas 1-2, eqs 20-28, Theorems 1-3, Remarks 4 and 6, the errata) are "
            "checked by `fsmctl prove` (list them with `fsmctl prove --list`)"
        )
    return LawReport(
        law=law.name, checks=tuple(out), spec=str(spec), error_model=error_model, source=source, notes=tuple(notes)
    )
