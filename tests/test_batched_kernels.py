"""Lane-batched kernels (fsmctl/codegen/batched.py) equal the scalar CasADi C bit for bit, for every law.

Three levels: each kernel (the model's ``plant_rhs`` and every built-in law's ``law_local_*``/``law_control_*``)
against its scalar CasADi-generated function (both from the law's compiled library) on random and edge-case
inputs, lane by lane; and whole simulations with
``kernels="batched"`` against ``kernels="scalar"`` (agent counts that do and do not fill the
lanes, both error models, zero-order hold, the adaptive integrator); and the same runs at both lane widths
(``FSMCTL_LANES=4`` and ``8``, each in its own process: a build per width) with identical bits.
"""

from __future__ import annotations

import ctypes
import dataclasses
import itertools
import os
import re
import subprocess
import warnings

import casadi as ca
import numpy as np
import pytest
from formations import with_agents

import fsmctl
from fsmctl.codegen.batched import LANE_WIDTHS, UnsupportedInstructionError, batched_header, batched_source, kernel_name
from fsmctl.model.generated_code import compiled_library, manifest
from fsmctl.model.laws import builtin_laws, derive_script
from fsmctl.model.problem import pack
from fsmctl.model.topology import Link, Schedule, Topology, ring
from fsmctl.simulation.simulator import SimulationError, batched_kernels_preferred, simulate_packed

LAWS = builtin_laws()
BATCHED = [("fsm", f["name"]) for f in manifest()["functions"] if "batched_kernel" in f] + [
    (law.name, f["name"])
    for law in LAWS.values()
    for f in __import__("json").loads((law.folder / "manifest.json").read_text())["functions"]
    if "batched_kernel" in f
]
SPECIAL = np.array([0.0, -0.0, 1.0, -1.0, 1e-300, -1e-300, 1e-4, np.inf, -np.inf, np.nan, 0.5, 2.0, 1e300])
_P = ctypes.POINTER(ctypes.c_double)


def _law_library(law: str):
    lib = compiled_library(LAWS[law].folder)
    if lib is None:
        pytest.skip("no C compiler: the compiled library is not available")
    dll = ctypes.CDLL(str(lib.path))
    assert dll.fsm_lane_width() == lib.lanes in LANE_WIDTHS
    return dll


@pytest.fixture(scope="module")
def library():
    return _law_library("fsm")


def _sizes(law: str, name: str) -> tuple[list[int], list[int]]:
    functions = (
        manifest()["functions"]
        + __import__("json").loads((LAWS[law].folder / "manifest.json").read_text())["functions"]
    )
    entry = next(f for f in functions if f["name"] == name)
    return [int(np.prod(io["shape"])) for io in entry["inputs"]], [int(np.prod(io["shape"])) for io in entry["outputs"]]


def _scalar(library, name: str, inputs: list[np.ndarray], n_out: list[int]) -> list[np.ndarray]:
    fn = getattr(library, name)
    work = getattr(library, f"{name}_work")
    sizes = [ctypes.c_longlong() for _ in range(4)]
    work(*(ctypes.byref(s) for s in sizes))
    outs = [np.zeros(m) for m in n_out]
    keep = [np.ascontiguousarray(x) for x in inputs]  # alive until the call returns
    args = (_P * len(keep))(*[x.ctypes.data_as(_P) for x in keep])
    res = (_P * len(outs))(*[o.ctypes.data_as(_P) for o in outs])
    iw = (ctypes.c_longlong * max(1, sizes[2].value))()
    w = (ctypes.c_double * max(1, sizes[3].value))()
    assert fn(args, res, iw, w, 0) == 0
    return outs


def _batched(library, name: str, inputs: list[np.ndarray], n_out: list[int], lanes: int) -> list[np.ndarray]:
    fn = getattr(library, kernel_name(name))
    outs = [np.zeros((m, library.fsm_lane_width())) for m in n_out]
    keep = [np.ascontiguousarray(x) for x in inputs]
    args = (_P * len(keep))(*[x.ctypes.data_as(_P) for x in keep])
    res = (_P * len(outs))(*[o.ctypes.data_as(_P) for o in outs])
    assert fn(args, res, lanes) == 0
    return outs


def _same_bits(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Equal as IEEE bit patterns (so +0 != -0); any NaN equals any NaN (payloads are not part of the contract)."""
    return (a.view(np.int64) == b.view(np.int64)) | (np.isnan(a) & np.isnan(b))


def _zero_tie_allowed(name: str, output: int, lane_inputs: list[np.ndarray]) -> bool:
    """The one documented latitude: a law's limited ``u`` = fmin(u_max, fmax(-u_max, .)) at ``u_max = 0``
    (input 14 of ``law_control_*``), where C99 leaves the sign of ``fmax(-0.0, +0.0)`` unspecified."""
    return name.startswith("law_control_") and output == 0 and lane_inputs[14][0] == 0


@pytest.mark.parametrize(("law", "name"), BATCHED, ids=[f"{law}-{name}" for law, name in BATCHED])
def test_batched_kernel_equals_scalar_function_bit_for_bit(law, name):
    every_law = {(law_name, f"law_{part}_{model}") for law_name in LAWS for part in ("local", "control")
                 for model in ("paper", "exact")}  # fmt: skip
    assert set(BATCHED) >= {("fsm", "plant_rhs"), *every_law}  # the kernels are printed for every law
    library = _law_library(law)
    n_in, n_out = _sizes(law, name)
    rng = np.random.default_rng(sum(map(ord, name)))
    width = library.fsm_lane_width()
    compared = 0
    for trial in range(300):
        inputs = []
        for m in n_in:
            x = rng.normal(size=(m, width)) * rng.choice([1e-3, 1.0, 30.0])
            if trial % 3:  # edge cases: zeros of both signs, tiny, huge, inf, nan
                mask = rng.random((m, width)) < 0.25
                x[mask] = rng.choice(SPECIAL, size=int(mask.sum()))
            if trial % 5 == 0:  # ties for fmin/fmax/sign and the Remark 6 band
                x = np.round(x, 1)
            inputs.append(x)
        lanes = width if trial % 4 else 1 + (trial // 4) % width  # every trial % 4 == 0: 1, 2, ..., width lanes
        batched = _batched(library, name, inputs, n_out, lanes)
        for lane in range(lanes):
            lane_inputs = [x[:, lane] for x in inputs]
            scalar = _scalar(library, name, lane_inputs, n_out)
            for k, (got, want) in enumerate(zip(batched, scalar, strict=True)):
                same = _same_bits(got[:, lane], want)
                if _zero_tie_allowed(name, k, lane_inputs):
                    same |= (got[:, lane] == 0) & (want == 0)
                assert same.all(), (
                    f"{name} output {k} lane {lane} trial {trial}: batched {got[:, lane]} != scalar {want}"
                )
                compared += 1
    assert compared > 1000


def _with_agents(scenario, n: int, **sections):
    """``scenario``'s agents repeated to ``n`` (on a ring when the count changes)."""
    agents = [scenario.agents[i % len(scenario.agents)] for i in range(n)]
    return with_agents(scenario, agents, None if n == scenario.n_agents else ring(n, 8.0, 1.5), **sections)


def _own_disturbances(scenario, n: int, shared: int):
    """``n`` agents whose first ``n - shared`` have disturbances of their own (amplitudes, frequencies, phases:
    the driver evaluates those FSM_LANES at a time) and whose last ``shared`` copy agent 1's (evaluated once)."""
    agents = []
    for i in range(n):
        a = scenario.agents[i % len(scenario.agents)]
        if i < n - shared:
            k = 1.0 + 0.37 * i
            d = dataclasses.replace(
                a.disturbance,
                amplitude=tuple(0.2 * k * (1, -1, 1)[j] for j in range(3)),
                frequency=tuple(0.3 * k + 0.1 * j for j in range(3)),
                phase=tuple(1.7 * i + 0.5 * j for j in range(3)),
            )
        else:
            d = agents[0].disturbance
        agents.append(dataclasses.replace(a, disturbance=d))
    return with_agents(scenario, agents, ring(n, 8.0, 1.5), simulation={"t_final": 1.0, "output_interval": 0.01})


def _flying(scenario, law: str, n: int, **simulation):
    """``scenario``'s agents repeated to ``n`` on a ring, flying the built-in ``law`` (whose states the engine
    integrates in its lane rows), 1 s."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the paper's parameters that ``law`` has not
        s = scenario.replace(controller={"law": law})
    return _with_agents(s, n, simulation={"t_final": 1.0, "output_interval": 0.01, **simulation})


CASES = {
    "case1-6-agents": lambda p: p.replace(simulation={"t_final": 2.0, "output_interval": 0.01}),
    "9-agents-own-disturbances": lambda p: _own_disturbances(p, 9, shared=0),  # the plant reads the kernel's rows
    "7-agents-law-states": lambda p: _flying(p, "adaptive_fsm", 7),  # rates written into the lane rows of x
    "11-agents-law-states-hold": lambda p: _flying(p, "pid", 11, control_period=0.01),  # held rates into the rows
    "7-agents-own-and-shared-disturbances": lambda p: _own_disturbances(p, 7, shared=2),
    "one-agent": lambda p: _with_agents(p, 1, simulation={"t_final": 1.0, "output_interval": 0.01}),
    "3-agents-sgn": lambda p: _with_agents(
        p, 3, controller={"boundary_layer": 0.0}, simulation={"t_final": 1.0, "output_interval": 0.01}
    ),
    "7-agents-no-limit": lambda p: _with_agents(
        p, 7, controller={"torque_limit": float("inf")}, simulation={"t_final": 1.0, "output_interval": 0.01}
    ),
    "5-agents-exact-kinematics": lambda p: _with_agents(
        p, 5, controller={"error_model": "exact"}, simulation={"t_final": 1.0, "output_interval": 0.01}
    ),
    "9-agents-zero-order-hold": lambda p: _with_agents(
        p, 9, simulation={"t_final": 1.0, "output_interval": 0.01, "control_period": 0.01}
    ),
    "dopri45-boundary-layer": lambda p: p.replace(
        controller={"boundary_layer": 0.05, "torque_limit": float("inf")},
        simulation={"t_final": 2.0, "output_interval": 0.05, "integrator": "dopri45", "rtol": 1e-8, "atol": 1e-10},
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_batched_and_scalar_simulations_are_bit_identical(library, paper_case1, case):
    p = pack(CASES[case](paper_case1))
    batched = simulate_packed(p, kernels="batched")
    scalar = simulate_packed(p, kernels="scalar")
    keys = ("t", "sigma_d", "sigma", "omega", "sigma_e", "omega_e", "broadcast", "z", "u", "u_unsat")
    for key in (*keys, "saturated_time", "u_total_variation", "u_unsat_max"):
        assert batched[key].shape == scalar[key].shape
        assert _same_bits(np.asarray(batched[key]), np.asarray(scalar[key])).all(), f"{case}: {key} differs"
    assert batched["steps_taken"] == scalar["steps_taken"]
    assert batched["steps_rejected"] == scalar["steps_rejected"]
    assert np.isfinite(batched["sigma"]).all()


# A law whose broadcast has 4 components (the neighbour sums go three components at a time: 3 + 1)
WIDE_BROADCAST_LAW = """
import sympy as sp
from fsmctl.symbolic.law import LawBuilder


def law(error_model):
    b = LawBuilder("pd_wide", error_model, doc="PD with consensus on sigma_e and on omega_e^2 (test law)")
    K = b.parameter("K", 2.0, unit="N m", minimum=0.0, doc="attitude gain")
    P = b.parameter("P", 20.0, unit="N m s", minimum=0.0, doc="rate gain")
    e = b.error_state()
    w2 = (e.omega_e.T * e.omega_e)[0, 0]
    b.broadcast("sigma_e_and_rate", sp.Matrix([*e.sigma_e, w2]))
    r = b.received
    consensus = b.k_sum * e.sigma_e - sp.Matrix(r[0:3])
    b.torque(-K * e.sigma_e - P * e.omega_e - K * consensus - 0.5 * (b.k_received_sum * w2 - r[3]) * e.omega_e)
    return b.build()
"""


def _uneven_links(n: int) -> Topology:
    """Receivers with 0 to 5 links (so the lanes of a group sum over different numbers of neighbours), whose weights
    switch to 0 and back at different times (the active links change during the run, lane by lane)."""
    links = []
    for i in range(n):
        for m in range(i % 6):
            j = (i + 1 + 2 * m) % n
            if j == i:
                continue
            period = 0.3 + 0.07 * ((i + m) % 4)
            links.append(Link(i, j, 8.0, Schedule((0.0, 0.1 + 0.03 * m), (1.5 + 0.25 * m, 0.0), period), 0.011 * i))
    return Topology(n, tuple(links))


@pytest.fixture(scope="module")
def wide_broadcast_law(tmp_path_factory):
    folder = tmp_path_factory.mktemp("wide_broadcast")
    (folder / "pd_wide.py").write_text(WIDE_BROADCAST_LAW)
    return str(derive_script(folder / "pd_wide.py", out=folder / "pd_wide"))


@pytest.mark.parametrize("links", ["ideal", "delayed-lossy"])
@pytest.mark.parametrize("law", ["fsm", "wide"])
def test_neighbour_sums_by_lane_equal_the_receiver_by_receiver_sums(
    library, paper_case1, wide_broadcast_law, law, links
):
    """The batched kernels' neighbour sums (a lane per receiver) and the scalar path's (receiver by receiver) give
    the same bits, for receivers with different numbers of active links in one lane group, links that switch off and
    on, a broadcast of 3 and of 4 components, and the links' own values (delayed and lossy links)."""
    n = 11  # two groups of 8 lanes, three of 4
    agents = [paper_case1.agents[i % paper_case1.n_agents] for i in range(n)]
    sections = {"simulation": {"t_final": 1.0, "output_interval": 0.01}}
    if links != "ideal":
        sections = {
            "simulation": {"t_final": 1.0, "output_interval": 0.01, "control_period": 0.01},
            "links": {"delay": 0.02, "loss_probability": 0.2},
        }
    scenario = with_agents(paper_case1, agents, _uneven_links(n), **sections)
    if law == "wide":
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the paper's parameters that the test law has not
            scenario = scenario.replace(controller={"law": wide_broadcast_law})
    p = pack(scenario)
    assert p.n_broadcast == (3 if law == "fsm" else 4)
    batched = simulate_packed(p, kernels="batched")
    scalar = simulate_packed(p, kernels="scalar")
    for key in ("sigma", "omega", "broadcast", "u", "u_unsat"):
        assert _same_bits(np.asarray(batched[key]), np.asarray(scalar[key])).all(), f"{key} differs"
    assert np.isfinite(batched["sigma"]).all()
    assert np.abs(np.asarray(batched["u"])).max() > 0


@pytest.mark.parametrize("rate", [1e100, -1e100])
@pytest.mark.parametrize("agents", [(10,), (9, 11), (2, 10)])
def test_a_non_finite_command_in_any_lane_group_stops_the_run_at_the_first_such_agent(
    library, paper_case1, rate, agents
):
    """11 agents fill two groups of 4 or 8 lanes and part of a third.  A huge angular rate gives a finite command at
    a step's first stage and a non-finite one at its second (the stage's state overflows), where the batched
    kernels check the lanes a group at a time: the run stops with the scalar kernels' message, naming the first
    such agent and the stage's time (no links, so no neighbour's command follows it)."""
    s = _with_agents(paper_case1, 11, simulation={"t_final": 0.05, "output_interval": 0.01})
    p = pack(dataclasses.replace(s, topology=dataclasses.replace(s.topology, links=())))
    x0 = p.x0.copy()
    for agent in agents:
        x0[p.agent_slice(agent - 1).start + 4] = rate
    messages = []
    for kernels in ("batched", "scalar"):
        with pytest.raises(SimulationError, match="non-finite torque command") as exc:
            simulate_packed(dataclasses.replace(p, x0=x0), kernels=kernels)
        messages.append(str(exc.value))
    assert messages[0] == messages[1]
    assert f"at t = {p.dt / 2:g} s in agent {agents[0]} " in messages[0], messages[0]


def _build_defines(macro: str) -> bool | None:
    """Whether the library's compiler, with the library's flags, predefines ``macro`` (None: cannot tell)."""
    from fsmctl.model.generated_code import c_compiler

    cc, flags = c_compiler(), [f for f in compiled_library().flags if f not in ("-shared", "-fPIC")]
    try:
        proc = subprocess.run([cc, *flags, "-dM", "-E", "-x", "c", os.devnull], capture_output=True, text=True)
    except OSError:
        return None
    return f"#define {macro} " in proc.stdout if proc.returncode == 0 and proc.stdout else None


def test_auto_picks_batched_kernels_exactly_when_the_build_has_avx(library, paper_case1):
    s = paper_case1.replace(simulation={"t_final": 0.2, "output_interval": 0.1})
    auto = simulate_packed(pack(s))
    assert auto["kernels"] == ("batched" if batched_kernels_preferred() else "scalar")
    avx, vectors = _build_defines("__AVX__"), _build_defines("__GNUC__")
    if avx is not None and vectors is not None:
        assert batched_kernels_preferred() == (avx and vectors)
    r = fsmctl.simulate(s)
    assert np.array_equal(r.sigma, auto["sigma"]) and np.array_equal(r.u, auto["u"])


def test_unknown_kernel_choice_is_a_clear_error(paper_case1):
    with pytest.raises(ValueError, match="kernels must be one of"):
        simulate_packed(pack(paper_case1.replace(simulation={"t_final": 0.01})), kernels="simd")


def test_printer_refuses_an_operation_without_a_lane_rule():
    x = ca.SX.sym("x")
    f = ca.Function("f", [x], [ca.erf(x)])
    with pytest.raises(UnsupportedInstructionError, match="OP_ERF"):
        batched_source([("f", f)], "f.h")


def test_printer_writes_exact_constants_and_every_lane_rule():
    x, y = ca.SX.sym("x"), ca.SX.sym("y")
    expr = ca.vertcat(
        x + 0.1, x - y, x * y, x / y, -x, x**2, 2 * x, 1 / x, x <= y, x == y, x < y, x != y,
        ca.logic_not(x), ca.logic_and(x, y), ca.logic_or(x, y), ca.if_else(x, y, 0), ca.fabs(x), ca.sign(x),
        ca.fmin(x, y), ca.fmax(x, y), x**y, ca.sqrt(x), ca.sin(x), ca.cos(x), ca.exp(x), ca.log(x),
        -1e-300 * x, ca.inf * x,
    )  # fmt: skip
    source = batched_source([("g", ca.Function("g", [x, y], [expr]))], "g.h")
    assert "fsm_splat(0.1)" in source and "fsm_splat((-1e-300))" in source and "fsm_splat(INFINITY)" in source
    helpers = ("fsm_fmin", "fsm_fmax", "fsm_sign", "fsm_fabs", "fsm_if_else_zero", "fsm_pow", "fsm_sqrt", "fsm_cos")
    for helper in helpers:
        assert f"{helper}(" in source.split("int g_batched")[1], helper
    assert "FSM_LANES * 0" in source and "vector_size" not in source  # the width is the build's, not the text's


def test_printer_starts_the_long_chains_first():
    """Three pows of independent operands, each followed in CasADi's order by cheap work on its result: the printer
    puts the three side by side, two of them as one interleaved call (the CPU then overlaps their dependency chains)
    and the third alone, after their operands; a function without library calls keeps CasADi's order."""
    s = ca.SX.sym("s", 3)
    alpha = ca.SX.sym("alpha")
    parts = [ca.fabs(s[k] * (k + 2.0) + 1.0) ** alpha * s[k] + 3.0 * s[k] for k in range(3)]
    body = batched_source([("f", ca.Function("f", [s, alpha], [ca.vertcat(*parts)]))], "f.h").split("int f_batched")[1]
    statements = [line.strip() for line in body.splitlines() if line.startswith("  ")]
    statements = [line for line in statements if not line.startswith(("if (", "return"))]
    calls = [line for line in statements if line.startswith("fsm_pow2(")]
    alone = [k for k, line in enumerate(statements) if "fsm_pow(" in line]
    assert len(calls) == 1 and len(alone) == 1 and "fsm_pow3(" not in body, statements
    assert abs(alone[0] - statements.index(calls[0])) == 1, statements  # side by side
    outputs = re.findall(r"&(v\d+)", calls[0])
    assert len(outputs) == 2 and f"fsm_v {', '.join(outputs)};" in statements, statements
    defined: set[str] = set()
    for line in statements:  # every operand is defined above its use (the C compiler would refuse it otherwise)
        if line.startswith("fsm_v "):
            continue  # the declaration of the interleaved call's results
        if line.startswith("fsm_pow2("):
            assert set(re.findall(r"\b(v\d+)\b,", line.split("&")[0])) <= defined, line
            defined.update(outputs)
            continue
        used = set(re.findall(r"\bv\d+\b", line.split("=", 1)[-1] if line.startswith("const") else line))
        assert used <= defined, line
        if line.startswith("const"):
            defined.add(line.split()[2])
    x = ca.SX.sym("x", 2)
    f = ca.Function("g", [x], [ca.vertcat(x[0] * x[1] + 1.0, x[0] / x[1])])
    plain = batched_source([("g", f)], "g.h").split("int g_batched")[1]
    printed = [int(v) for v in re.findall(r"const fsm_v v(\d+) =", plain)]
    assert printed == sorted(printed)  # program order


@pytest.mark.parametrize("width", LANE_WIDTHS)
def test_kernels_printed_for_several_lane_groups_give_each_group_the_one_group_bits(tmp_path, width):
    """``groups=3`` prints each instruction once per group, side by side (the three groups' nine independent pows as
    four interleaved pairs and one alone): each group's results are those of the one-group kernel on that group's
    inputs, bit for bit, on random and special inputs; a group reading another group's inputs or writing its results
    would fail."""
    from fsmctl.model.generated_code import c_compiler, compile_flags, driver_source_dir, math_include_args

    cc = c_compiler()
    if cc is None:
        pytest.skip("no C compiler")
    s, alpha, y = ca.SX.sym("s", 3), ca.SX.sym("alpha"), ca.SX.sym("y", 2)
    pows = [ca.fabs(s[k] * (k + 2.0) + 1.0) ** alpha * s[k] for k in range(3)]
    rest = [ca.fmin(y[0], y[1]), ca.sign(y[0]) / (1.0 + y[1] ** 2), ca.cos(s[0]) + ca.sqrt(ca.fabs(y[1]))]
    f = ca.Function("f", [s, alpha, y], [ca.vertcat(*pows), ca.vertcat(*rest)])
    interleaved = batched_source([("f", f)], "f3.h", groups=3)
    kernel = interleaved.split("int f_batched_x3(")[1]
    assert kernel.count("fsm_pow2(") == 4 and kernel.count("fsm_pow(") == 1
    (tmp_path / "f1.h").write_text(batched_header(["f"], guard="F1_H"))
    (tmp_path / "f1.c").write_text(batched_source([("f", f)], "f1.h"))
    (tmp_path / "f3.h").write_text(batched_header(["f"], guard="F3_H", groups=3))
    (tmp_path / "f3.c").write_text(interleaved)
    flags = (*(x for x in compile_flags(cc)[0] if not x.startswith("-DFSM_LANES=")), f"-DFSM_LANES={width}")
    math = [str(driver_source_dir() / x) for x in ("fsm_pow.c", "fsm_trig.c")]
    so = tmp_path / "f.so"
    cmd = [cc, *flags, f"-I{tmp_path}", f"-I{driver_source_dir()}", *math_include_args(), str(tmp_path / "f1.c"),
           str(tmp_path / "f3.c"), *math, "-o", str(so), "-lm"]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    lib = ctypes.CDLL(str(so))
    if not hasattr(lib, "f_batched_x3"):
        pytest.skip(f"{cc} has no vector extension: no batched kernels to compare")
    rng = np.random.default_rng(31)
    sizes = [3, 1, 2]
    inputs = [[rng.uniform(-2.0, 2.0, (n, width)) for n in sizes] for _ in range(3)]
    inputs[1][2][:, 0] = [np.nan, -0.0]  # special values in one group's lane 0
    inputs[2][0][:, 1] = [0.0, np.inf, -1.0 / 3.0]
    one, three = (
        [[np.zeros((3, width)) for _ in range(2)] for _ in range(3)],
        [[np.zeros((3, width)) for _ in range(2)] for _ in range(3)],
    )
    _PP = ctypes.POINTER(_P)

    def pointers(arrays):
        return (_P * len(arrays))(*(a.ctypes.data_as(_P) for a in arrays))

    for g in range(3):
        assert lib.f_batched(pointers(inputs[g]), pointers(one[g]), width) == 0
    args = [pointers(inputs[g]) for g in range(3)]
    results = [pointers(three[g]) for g in range(3)]
    assert lib.f_batched_x3((_PP * 3)(*(ctypes.cast(a, _PP) for a in args)),
                            (_PP * 3)(*(ctypes.cast(r, _PP) for r in results)), width) == 0  # fmt: skip
    for g in range(3):
        for k in range(2):
            assert _same_bits(three[g][k], one[g][k]).all(), (g, k, three[g][k], one[g][k])
    assert not _same_bits(one[0][0], one[1][0]).all()  # the groups' inputs differ, so a mixed-up group would show
    with pytest.raises(ValueError, match="groups must be an integer >= 1"):
        batched_source([("f", f)], "f.h", groups=0)


@pytest.mark.parametrize("width", LANE_WIDTHS)
def test_every_lane_rule_equals_casadis_scalar_c_on_special_values(tmp_path, width):
    """Each operation the printer knows, compiled both ways with the library's compiler and flags, on every pair
    of special values (signed zeros, subnormals, huge, infinities, NaN): bit-identical, except fmin/fmax ties of
    +0 and -0 (unspecified in C99)."""
    from fsmctl.model.generated_code import c_compiler, compile_flags, driver_source_dir, math_include_args

    cc = c_compiler()
    if cc is None:
        pytest.skip("no C compiler")
    x, y = ca.SX.sym("x"), ca.SX.sym("y")
    exprs = {
        "add": x + y, "sub": x - y, "mul": x * y, "div": x / y, "neg": -x, "sq": x**2, "twice": 2 * x,
        "inv": 1 / x, "le": x <= y, "eq": x == y, "lt": x < y, "ne": x != y, "not": ca.logic_not(x),
        "and": ca.logic_and(x, y), "or": ca.logic_or(x, y), "if_else_zero": ca.if_else(x, y, 0),
        "fabs": ca.fabs(x), "sign": ca.sign(x), "fmin": ca.fmin(x, y), "fmax": ca.fmax(x, y), "pow": x**y,
        "constpow": x**3, "sqrt": ca.sqrt(x), "sin": ca.sin(x), "cos": ca.cos(x), "exp": ca.exp(x),
        "log": ca.log(x), "const": 0.1 * x - 1e-300, "tan": ca.tan(x), "asin": ca.asin(x), "acos": ca.acos(x),
        "atan": ca.atan(x), "sinh": ca.sinh(x), "cosh": ca.cosh(x), "tanh": ca.tanh(x), "floor": ca.floor(x),
        "ceil": ca.ceil(x), "atan2": ca.atan2(x, y),
    }  # fmt: skip
    names = list(exprs)
    g = ca.Function("g", [x, y], [ca.vertcat(*exprs.values())])
    gen = ca.CodeGenerator("g.c", {"with_header": False})
    gen.add(g)
    gen.generate(str(tmp_path) + "/")
    (tmp_path / "g_b.h").write_text(batched_header(["g"]))
    (tmp_path / "g_b.c").write_text(batched_source([("g", g)], "g_b.h"))
    flags, _ = compile_flags(cc)
    flags = (*(f for f in flags if not f.startswith("-DFSM_LANES=")), f"-DFSM_LANES={width}")
    so = tmp_path / "g.so"
    math = [str(driver_source_dir() / f) for f in ("fsm_pow.c", "fsm_trig.c")]  # fsmctl's pow, sin, cos: as the library
    sources = [str(tmp_path / "g.c"), str(tmp_path / "g_b.c"), *math]
    cmd = [
        cc,
        *flags,
        f"-I{tmp_path}",
        f"-I{driver_source_dir()}",
        *math_include_args(),
        *sources,
        "-o",
        str(so),
        "-lm",
    ]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    lib = ctypes.CDLL(str(so))
    if not hasattr(lib, "g_batched"):
        pytest.skip(f"{cc} has no vector extension: no batched kernels to compare")
    special = [0.0, -0.0, 1.0, -1.0, 0.5, -2.0, 3.0, 5e-324, -5e-324, 1e308, np.inf, -np.inf, np.nan]
    pairs = np.array(list(itertools.product(special, special)))
    m, checked = len(names), 0
    for start in range(0, len(pairs), width):
        chunk = pairs[start : start + width]
        xb, yb = np.zeros(width), np.zeros(width)
        xb[: len(chunk)], yb[: len(chunk)] = chunk[:, 0], chunk[:, 1]
        out = np.zeros((m, width))
        lib.g_batched(
            (_P * 2)(xb.ctypes.data_as(_P), yb.ctypes.data_as(_P)), (_P * 1)(out.ctypes.data_as(_P)), len(chunk)
        )
        for lane, (a, b) in enumerate(chunk):
            xs, ys, want = np.array([a]), np.array([b]), np.zeros(m)
            args = (_P * 2)(xs.ctypes.data_as(_P), ys.ctypes.data_as(_P))
            iw, w = (ctypes.c_longlong * max(1, g.sz_iw()))(), (ctypes.c_double * g.sz_w())()
            assert lib.g(args, (_P * 1)(want.ctypes.data_as(_P)), iw, w, 0) == 0
            got = out[:, lane]
            same = _same_bits(got, want)
            ties = np.isin(names, ["fmin", "fmax"]) & (a == 0) & (b == 0)
            same |= ties & (got == 0) & (want == 0)
            bad = [f"{names[k]}({a!r}, {b!r}): batched {got[k]!r}, scalar {want[k]!r}" for k in np.where(~same)[0]]
            assert not bad, bad
            checked += m
    assert checked == m * len(pairs)
