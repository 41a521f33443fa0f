"""What a law declares through LawBuilder for the engine and the tools, and how they use it.

``discontinuous`` (the dopri45 warning), ``preset_group`` (named parameter presets), ``loop_rates`` (the RK4
step-size report) and ``paper_theorems`` (Theorems 1-2 and the proof check's eq 20): each declared, written to
``law.json``, read back into :class:`fsmctl.model.LawCode`, used, and rejected when malformed.  Also: the
paper's parameter set is declared once (:mod:`fsmctl.symbolic.fsm_parameters`).
"""

from __future__ import annotations

import dataclasses
import math
import textwrap
import warnings

import numpy as np
import pytest

import fsmctl
from fsmctl.model import LawPresetGroup, builtin_laws, parameter_matrix, resolve_law
from fsmctl.model.laws import LawSwitchWarning
from fsmctl.proofs.law_check import check_law
from fsmctl.simulation import DiscontinuousControlWarning, step_size_report
from fsmctl.studies import available_constraints
from fsmctl.symbolic import LawBuilder, LawDefinitionError
from fsmctl.symbolic.fsm_parameters import declare_fsm_parameters

SURFACE_LAWS = ("fsm", "adaptive_fsm", "super_twisting")

# a user's law on the paper's surface with every declaration; TORQUE is replaced to make a false claim
SCRIPT = textwrap.dedent(
    """
    from fsmctl.symbolic import LawBuilder
    from fsmctl.symbolic.controller import computed_torque_pieces, coordination_term
    from fsmctl.symbolic.fsm_parameters import declare_fsm_parameters, declare_surface_presets, fsm_loop_rates
    from fsmctl.symbolic.surfaces import fast_sliding_surface

    def law(error_model):
        b = LawBuilder("NAME", error_model, doc="the paper's law, written by a user")
        p = declare_fsm_parameters(b, c1=0.9, boundary_layer=0.02)
        b.paper_theorems(c1=p.c1, c2=p.c2, alpha=p.alpha, boundary_layer=p.boundary_layer, epsilon=p.epsilon,
                         singularity_fix=p.singularity_fix, delta=p.delta)
        b.discontinuous("sgn(s) of u^D", smoothed_by="boundary_layer")
        b.loop_rates(**fsm_loop_rates(p))
        declare_surface_presets(b, p)
        surface = fast_sliding_surface(b, p.c1, p.c2, p.alpha, p.epsilon, p.singularity_fix)
        e, s = surface.error, surface.s
        b.broadcast("s", s, unit="1/s")
        pieces = computed_torque_pieces(
            b.J0, e.sigma_e, e.omega_e, e.omega_r, e.omega_r_dot, s, p.c1, p.c2, p.alpha, p.delta,
            coordination_term(s, b.k_sum, b.received), boundary_layer=p.boundary_layer, fix=p.singularity_fix,
            epsilon=p.epsilon,
        )
        b.torque(TORQUE)
        return b.build()
    """
)


def _script(tmp_path, name: str, torque: str = "surface.with_shared_slope(pieces.u)"):
    path = tmp_path / f"{name}.py"
    path.write_text(SCRIPT.replace("NAME", name).replace("TORQUE", torque))
    return path


@pytest.fixture(scope="module")
def short():
    return fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.05, "integrator": "dopri45"})


# ----------------------------------------------------------------------------- discontinuous


def test_pid_with_dopri45_gives_no_warning_about_a_sgn_it_does_not_have(short):
    sgn = short.replace(controller={"boundary_layer": 0.0})  # the paper's law with sgn(s) (Case 1 has phi > 0)
    with pytest.warns(DiscontinuousControlWarning, match="sgn"):
        fsmctl.simulate(sgn)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DiscontinuousControlWarning)
        fsmctl.simulate(sgn.replace(controller={"law": "pid"}))  # the same file flown with --law pid
    assert resolve_law("pid").discontinuity is None


def test_the_warning_names_the_law_s_declared_discontinuity_and_smoothing_parameter(short):
    fsm = resolve_law("fsm").discontinuity
    assert (fsm.where, fsm.smoothed_by) == ("sgn(s) of the switching term u^D (eq 18)", "boundary_layer")
    with pytest.warns(DiscontinuousControlWarning) as record:
        fsmctl.simulate(short.replace(controller={"boundary_layer": 0.0}))
    (message,) = [str(w.message) for w in record if issubclass(w.category, DiscontinuousControlWarning)]
    assert "law fsm" in message and fsm.where in message and "boundary_layer = 0" in message
    assert "boundary_layer > 0" in message
    with warnings.catch_warnings():
        warnings.simplefilter("error", DiscontinuousControlWarning)
        fsmctl.simulate(short.replace(controller={"boundary_layer": 0.01}))  # smoothed: no warning


def test_a_law_no_parameter_smooths_warns_whatever_its_parameters(short):
    st = resolve_law("super_twisting").discontinuity
    assert st.smoothed_by is None and "d/dt w" in st.where
    assert st.discontinuous(np.zeros((3, resolve_law("super_twisting").n_params)))
    with pytest.warns(
        LawSwitchWarning,
        match=r"ignored \(not parameters of super_twisting of the same unit and size\): boundary_layer",
    ):
        s = short.replace(controller={"law": "super_twisting"})  # the paper's boundary_layer = 0.001 is dropped
    with pytest.warns(DiscontinuousControlWarning, match="law super_twisting, discontinuous at sgn") as record:
        fsmctl.simulate(s)
    assert not any("boundary_layer" in str(w.message) for w in record)


def test_discontinuity_of_a_parameter_matrix_is_any_agent():
    d = resolve_law("fsm").discontinuity
    P = parameter_matrix(resolve_law("fsm"), fsmctl.paper_scenario("1").replace(controller={"boundary_layer": 0.1}))
    assert not d.discontinuous(P) and not d.discontinuous(P[0])
    P[2, d.column] = 0.0
    assert d.discontinuous(P) and not d.discontinuous(P[0])


# ----------------------------------------------------------------------------- presets


def test_the_surface_presets_of_sec_3_3_on_every_law_built_on_the_surface():
    for name in SURFACE_LAWS:
        g = resolve_law(name).preset_group("surface")
        assert isinstance(g, LawPresetGroup)
        assert g.default == "fsm"
        assert {k: dict(v) for k, v in g.options.items()} == {"fsm": {}, "tsm": {"c1": (0.0,)}, "lsm": {"c2": (0.0,)}}
    assert resolve_law("pid").presets == ()
    with pytest.raises(KeyError):
        resolve_law("pid").preset_group("surface")


# ----------------------------------------------------------------------------- loop rates


def test_step_size_report_uses_the_declared_rates_per_agent():
    s = fsmctl.paper_scenario("1").replace(controller={"boundary_layer": 0.02})
    P = parameter_matrix(resolve_law("fsm"), s)
    c1, c2, alpha, phi, eps = P[0, :5]
    assert P[0, 5] == 1.0  # switch
    report = step_size_report(s)
    assert math.isclose(report["surface"], c1 + c2 * (2 - alpha) * eps ** (alpha - 1), rel_tol=1e-12)
    assert math.isclose(report["layer"], P[:, 6:9].max() / phi, rel_tol=1e-12)
    assert resolve_law("pid").loop_rates(np.zeros(4)) is None
    pid = step_size_report(s.replace(controller={"law": "pid"}))  # no declaration: the finite-difference estimate
    assert pid["layer"] == 0.0 and 0 < pid["surface"] < math.inf


def test_finite_difference_loop_rate_is_the_worst_agent_s_by_automatic_differentiation():
    """A law without declared rates (pid): the report's ``surface`` is the worst agent's ``a + sqrt(b)`` of its
    linearisation at its initial state (``a = ||J0^-1 du/domega||``, ``b = ||J0^-1 du/dsigma|| / 4``; the engine
    evaluates every agent's finite differences in one mapped call).  Oracle: the same rate per agent from the law's
    SX graph differentiated exactly (CasADi's jacobian), agent by agent.  Agent 3 gets a quarter of its inertia, so
    the worst agent is not the first: a mix-up of agents or columns gives agent 1's (or another's) rate."""
    import casadi as ca

    from fsmctl.model.generated_code import casadi_function, law_sx_function
    from fsmctl.model.problem import pack

    base = fsmctl.paper_scenario("1").replace(controller={"law": "pid"})
    agents = list(base.agents)
    agents[2] = dataclasses.replace(agents[2], J0=tuple(tuple(0.25 * v for v in row) for row in agents[2].J0))
    s = dataclasses.replace(base, agents=tuple(agents)).replace(simulation={"t_final": 1.0})
    p = pack(s)
    local, control = (law_sx_function(p.law.folder, f"law_{f}_paper") for f in ("local", "control"))
    constants = p.law.casadi("law_constants")
    _, wd, wdd = casadi_function("reference_rhs")(0.0, p.x0[:3], p.ref_params)
    rates = []
    for i in range(p.n_agents):
        x = ca.SX.sym("x", 6)
        xi = p.x0[p.agent_slice(i)]
        args = [0.0, x[0:3], x[3:6], xi[6 : 6 + p.n_states], p.x0[:3], wd, wdd, p.J0[i], p.params[i]]
        args.append(constants(p.params[i]))
        _, cache = local(*args)
        _, u, _ = control(*args, cache, 0.0, np.zeros(p.n_broadcast), 0.0, np.inf)
        jac = np.asarray(ca.Function("torque_jacobian", [x], [ca.jacobian(u, x)])(xi[:6]), dtype=float)
        Jinv = np.linalg.inv(p.J0[i])
        a = np.linalg.norm(Jinv @ jac[:, 3:6], 2)
        rates.append(a + math.sqrt(np.linalg.norm(Jinv @ jac[:, 0:3], 2) / 4.0))
    assert int(np.argmax(rates)) == 2 and rates[2] > 1.5 * max(rates[:2] + rates[3:])  # agent 3 decides
    report = step_size_report(s)
    assert math.isclose(report["surface"], max(rates), rel_tol=1e-4)  # finite differences with h = 1e-6


def test_a_law_not_finite_at_one_agent_s_start_names_that_agent():
    """The check at the initial state evaluates every agent in one mapped call and names the first agent whose law
    is not finite: with the printed law (``singularity_fix = "none"``, NaN at ``sigma_e = 0``) only agent 4 starts
    on the reference, which starts at ``sigma_d = 0`` so that its ``sigma_e`` is exactly 0 in every component (no
    rounding of the error composition can make it a tiny finite number)."""
    from fsmctl.model.laws import LawError

    paper = fsmctl.paper_scenario("1").replace(reference={"sigma0": (0.0, 0.0, 0.0)})
    agents = list(paper.agents)
    wd0 = tuple(float(v) for v in paper.reference.omega(0.0))
    agents[3] = dataclasses.replace(agents[3], sigma0=paper.reference.sigma0, omega0=wd0)
    s = dataclasses.replace(paper, agents=tuple(agents)).replace(
        controller={"singularity_fix": "none"}, simulation={"t_final": 0.5}
    )
    with pytest.raises(LawError, match=r"torque is not finite at the initial state of agent 4 "):
        fsmctl.simulate(s)


# ----------------------------------------------------------------------------- paper theorems and the order


def test_only_the_paper_s_law_declares_the_paper_s_theorems_and_it_is_listed_first():
    laws = builtin_laws()
    declared = [name for name, law in laws.items() if law.paper_theorems is not None]
    assert declared == ["fsm", "fsm_wheels"]  # fsm_wheels: the paper's body torque, flown through its wheels
    assert dict(laws["fsm"].paper_theorems.parameters) == {
        r: r for r in ("c1", "c2", "alpha", "boundary_layer", "epsilon", "singularity_fix", "delta")
    }
    assert list(laws) == ["fsm", "fsm_wheels", *sorted(set(laws) - {"fsm", "fsm_wheels"})]
    base = fsmctl.paper_scenario("1")
    assert available_constraints("fsm", base)["theorem1"] == ""
    assert "does not declare" in available_constraints("super_twisting", base)["theorem2"]


def test_a_user_law_s_declarations_round_trip_through_law_json(tmp_path):
    law = resolve_law(_script(tmp_path, "user_fsm"))
    assert law.paper_theorems is not None and law.paper_theorems.parameters["epsilon"] == "epsilon"
    assert law.discontinuity.where == "sgn(s) of u^D" and law.discontinuity.smoothed_by == "boundary_layer"
    assert law.discontinuity.column == 3
    assert law.preset_group("surface").options["lsm"] == {"c2": (0.0,)}
    defaults = np.array([v for p in law.parameters for v in p.default])
    surface, layer = law.loop_rates(defaults)
    assert math.isclose(surface, 0.9 + 0.8 * 1.3 * 1e-4**-0.3, rel_tol=1e-12)
    assert math.isclose(layer, 0.005 / 0.02, rel_tol=1e-12)
    plain = resolve_law("pid")
    assert (plain.discontinuity, plain.presets, plain.loop_rates_doc, plain.paper_theorems) == (None, (), None, None)


def test_the_proof_check_verifies_the_declaration(tmp_path):
    true = check_law(str(_script(tmp_path, "true_fsm")), checks=["closed-loop-eq20"], samples=20)
    assert true.check("closed-loop-eq20").passed is True
    false = check_law(
        str(_script(tmp_path, "false_fsm", "2 * surface.with_shared_slope(pieces.u)")),
        checks=["closed-loop-eq20"],
        samples=20,
    )
    c = false.check("closed-loop-eq20")
    assert c.passed is False and "FAILS" in c.detail and not false.ok
    pid = check_law("pid", checks=["closed-loop-eq20"], samples=5)  # declares nothing: the check does not apply
    assert [c.id for c in pid.checks] == []


# ----------------------------------------------------------------------------- the parameter set, once


def test_the_paper_s_parameters_are_declared_alike_by_every_law_on_the_surface():
    fsm = {p.name: p for p in resolve_law("fsm").parameters}
    for name in SURFACE_LAWS[1:]:
        for p in resolve_law(name).parameters:
            if p.name in fsm:
                assert p == fsm[p.name], (name, p.name)
    assert [p.name for p in resolve_law("super_twisting").parameters][:5] == [
        "c1", "c2", "alpha", "epsilon", "singularity_fix"
    ]  # fmt: skip


def test_the_helper_takes_a_law_s_own_defaults():
    b = LawBuilder("x", doc="x")
    p = declare_fsm_parameters(b, c1=1.5, delta=(0.1, 0.2, 0.3), boundary_layer=None)
    assert p.boundary_layer is None and p.delta.shape == (3, 1)
    e = b.error_state()
    b.broadcast("s", e.sigma_e)
    b.torque(-p.c1 * e.sigma_e)
    law = b.build()
    assert law.parameter("c1").default == (1.5,) and law.parameter("delta").default == (0.1, 0.2, 0.3)
    with pytest.raises(LawDefinitionError, match="alpha: default"):
        declare_fsm_parameters(LawBuilder("y", doc="y"), alpha=1.0)


# ----------------------------------------------------------------------------- bad declarations


def _builder():
    b = LawBuilder("bad", doc="bad declarations")
    p = declare_fsm_parameters(b)
    return b, p


@pytest.mark.parametrize(
    ("declare", "message"),
    [
        (lambda b, p: b.discontinuous(""), "say where"),
        (lambda b, p: b.discontinuous("sgn(s)", smoothed_by="phi"), "'phi' is not a parameter declared"),
        (lambda b, p: b.discontinuous("sgn(s)", smoothed_by=p.singularity_fix), "must be a scalar numeric"),
        (lambda b, p: b.discontinuous("sgn(s)", smoothed_by=p.epsilon), "must be a scalar numeric"),
        (lambda b, p: [b.discontinuous("a"), b.discontinuous("b")], "declared twice"),
        (lambda b, p: b.preset_group("c1", default="a", options={"a": {}}), "clashes with the parameter"),
        (lambda b, p: b.preset_group("torque_limit", default="a", options={"a": {}}), "every law shares"),
        (lambda b, p: b.preset_group("g", default="z", options={"a": {}}), "default 'z' is not one of"),
        (lambda b, p: b.preset_group("g", default="a", options={"a": {"K": 1}}), "'K' is not a parameter"),
        (
            lambda b, p: b.preset_group("g", default="a", options={"a": {}, "b": {p.alpha: 1.0}}),
            "alpha: must be < 1, got 1",
        ),
        (lambda b, p: b.preset_group("g", default="a", options={"a": {p.c1: 1.0}}), "changes the default of c1"),
        (lambda b, p: b.preset_group("g", default="a", options={"a": {}, "b": {p.delta: [1, 2]}}), "2 numbers"),
        (lambda b, p: b.preset_group("g", default="a", options={"a": {}, "b": {p.singularity_fix: "x"}}), "'x'"),
        (lambda b, p: b.preset_group("g", default="a", options={}), "non-empty"),
        (lambda b, p: [b.preset_group("g", default="a", options={"a": {}}), b.parameter("g", 1.0)], "preset group"),
        (lambda b, p: b.parameter("enabled", 1.0), "every law shares"),
        (lambda b, p: b.loop_rates(surface=p.c1 + b.sigma[0]), "parameters only"),
        (lambda b, p: b.loop_rates(surface=p.delta), "must be a scalar"),
        (lambda b, p: b.paper_theorems(c1=p.c1, c3=p.c2), "missing alpha, .*; unknown c3"),
        (
            lambda b, p: b.paper_theorems(
                c1=p.c1,
                c2=p.c2,
                alpha=p.alpha,
                boundary_layer=p.boundary_layer,
                epsilon=p.epsilon,
                singularity_fix=p.singularity_fix,
                delta=p.c1,
            ),
            "delta=c1\\): must be a numeric parameter of 3 components",
        ),
        (
            lambda b, p: b.paper_theorems(
                c1=p.c2 * 2,
                c2=p.c2,
                alpha=p.alpha,
                boundary_layer=p.boundary_layer,
                epsilon=p.epsilon,
                singularity_fix=p.singularity_fix,
                delta=p.delta,
            ),
            "is not a parameter declared",
        ),
    ],
)
def test_bad_declarations_are_rejected_in_one_line(declare, message):
    b, p = _builder()
    with pytest.raises(LawDefinitionError, match=message) as info:
        declare(b, p)
    assert "\n" not in str(info.value) and str(info.value).startswith("bad")


def test_fsmctl_laws_shows_the_declarations():
    from fsmctl.cli.laws import format_law, law_to_dict

    text = format_law(resolve_law("fsm"))
    assert "discontinuous: at sgn(s) of the switching term u^D (eq 18) unless boundary_layer > 0" in text
    assert "presets:   surface = fsm, tsm (c1 = 0), lsm (c2 = 0); default fsm" in text
    assert "Theorems 1-2 apply" in text and "Theorems" not in format_law(resolve_law("pid"))
    d = law_to_dict(resolve_law("adaptive_fsm"))
    assert d["discontinuity"]["smoothed_by"] is None and d["paper_theorems"] is None
    assert d["presets"][0]["options"]["tsm"] == {"c1": [0.0]}
