"""The catalogue of functions the runtime needs, defined once from the symbolic model.

Each :class:`FunctionSpec` names its inputs (matrices of symbols), optional
intermediate stages, and outputs (SymPy matrices).  :mod:`fsmctl.codegen.writer`
turns the catalogue into CasADi functions, C sources and a manifest; the
runtime (``fsmctl``) loads those and never re-types an equation.

Per-agent functions only: a formation of any size and topology is assembled at
run time from them.

Packed parameter vectors (their layouts are written to the manifest):

* ``gains = [c1, c2, alpha, boundary_layer, epsilon, fix_mode]``
  (eq 13, Remark 7, Remark 6; ``fix_mode`` takes :class:`SingularityFix` values);
* ``gain_constants = [epsilon^(alpha-1)]``, computed once per agent by ``sliding_constants``;
* ``params`` of :func:`disturbance_spec` / :func:`reference_spec` =
  ``[amplitude(3), frequency(3), phase(3), offset(3)]`` for
  ``v_k(t) = amplitude_k cos(frequency_k t + phase_k) + offset_k``.

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

import sympy as sp

from fsmctl.symbolic.controller import (
    closed_loop_acceleration,
    computed_torque_pieces,
    coordination_term,
    saturate,
    scalar_sliding_mode,
    share_fractional_powers,
    sliding_variable,
    surface_term_slope,
)
from fsmctl.symbolic.functions import FunctionSpec
from fsmctl.symbolic.hardware import (
    gyrostat_rhs,
    rate_gyro_measurement,
    star_tracker_measurement,
    wheel_acceleration,
    wheel_motor_torque,
)
from fsmctl.symbolic.model import ErrorModel, plant_rhs, reference_acceleration_in_body, reference_rate_in_body
from fsmctl.symbolic.mrp import mrp_error, mrp_G, mrp_kinematics, mrp_principal_angle, mrp_shadow, mrp_to_dcm
from fsmctl.symbolic.symbols import symmetric_matrix_symbols, vector_symbols

__all__ = [
    "error_state_spec",
    "GAINS_LAYOUT",
    "GAIN_CONSTANTS_LAYOUT",
    "SINUSOID_LAYOUT",
    "WHEEL_LAYOUT",
    "FunctionSpec",
    "function_catalogue",
]

GAINS_LAYOUT: tuple[str, ...] = ("c1", "c2", "alpha", "boundary_layer", "epsilon", "fix_mode")
GAIN_CONSTANTS_LAYOUT: tuple[str, ...] = ("epsilon_pow_alpha_minus_1",)
SINUSOID_LAYOUT: tuple[str, ...] = tuple(
    f"{field_}[{k}]" for field_ in ("amplitude", "frequency", "phase", "offset") for k in range(3)
)


def _scalar(name: str) -> sp.ImmutableMatrix:
    return sp.ImmutableMatrix([sp.Symbol(name, real=True)])


def _gains():
    g = vector_symbols("gains", len(GAINS_LAYOUT))
    return g, dict(zip(GAINS_LAYOUT, g, strict=True))


def _sinusoid(t, params):
    a, w, ph, c = (params[3 * i : 3 * i + 3, 0] for i in range(4))
    value = sp.ImmutableMatrix([a[k] * sp.cos(w[k] * t + ph[k]) + c[k] for k in range(3)])
    rate = sp.ImmutableMatrix([-a[k] * w[k] * sp.sin(w[k] * t + ph[k]) for k in range(3)])
    return value, rate


def disturbance_spec() -> FunctionSpec:
    t = _scalar("t")
    p = vector_symbols("params", 12)
    value, _ = _sinusoid(t[0], p)
    return FunctionSpec(
        name="disturbance_torque",
        doc="sinusoidal disturbance torque d_k(t) = a_k cos(w_k t + phi_k) + c_k (Case 1, eq 29's u_d)",
        inputs=(("t", t), ("params", p)),
        outputs=(("d", value),),
        batched=True,
    )


def sliding_constants_spec() -> FunctionSpec:
    gains, g = _gains()
    return FunctionSpec(
        name="sliding_constants",
        doc="per-agent constants of the sliding functions: gain_constants = [epsilon^(alpha-1)] (Remark 6 switch band)",
        inputs=(("gains", gains),),
        outputs=(("gain_constants", sp.ImmutableMatrix([g["epsilon"] ** (g["alpha"] - 1)])),),
    )


def reference_spec() -> FunctionSpec:
    t = _scalar("t")
    sigma_d = vector_symbols("sigma_d")
    p = vector_symbols("params", 12)
    omega_d, omega_d_dot = _sinusoid(t[0], p)
    return FunctionSpec(
        name="reference_rhs",
        doc="reference attitude: sigma_d_dot = G(sigma_d) omega_d(t) (eq 3) with a sinusoidal omega_d(t) (Sec. 4)",
        inputs=(("t", t), ("sigma_d", sigma_d), ("params", p)),
        outputs=(("sigma_d_dot", mrp_kinematics(sigma_d, omega_d)), ("omega_d", omega_d), ("omega_d_dot", omega_d_dot)),
    )


def plant_spec() -> FunctionSpec:
    sigma, omega, tau = vector_symbols("sigma"), vector_symbols("omega"), vector_symbols("tau")
    J = symmetric_matrix_symbols("J")
    sigma_dot, omega_dot = plant_rhs(J, sigma, omega, tau)
    return FunctionSpec(
        name="plant_rhs",
        doc="rigid spacecraft (eqs 3-4) with the true inertia J (read from its lower triangle); tau = control + disturbance",
        inputs=(("sigma", sigma), ("omega", omega), ("tau", tau), ("J", J)),
        outputs=(("sigma_dot", sigma_dot), ("omega_dot", omega_dot)),
        batched=True,
    )


def gyrostat_spec() -> FunctionSpec:
    sigma, omega = vector_symbols("sigma"), vector_symbols("omega")
    h, tau_w, tau = vector_symbols("h_wheels"), vector_symbols("tau_wheels"), vector_symbols("tau")
    J, J_spin = symmetric_matrix_symbols("J"), symmetric_matrix_symbols("J_spin")
    sigma_dot, omega_dot = gyrostat_rhs(J, J_spin, sigma, omega, h, tau_w, tau)
    return FunctionSpec(
        name="gyrostat_rhs",
        doc="rigid hub with balanced reaction wheels (Schaub & Junkins eq 4.146): (J - J_spin) omega_dot = "
        "-omega x (J omega + h_wheels) - tau_wheels + tau; J: whole spacecraft, J_spin = sum Js g g^T",
        inputs=(
            ("sigma", sigma),
            ("omega", omega),
            ("h_wheels", h),
            ("tau_wheels", tau_w),
            ("tau", tau),
            ("J", J),
            ("J_spin", J_spin),
        ),
        outputs=(("sigma_dot", sigma_dot), ("omega_dot", omega_dot)),
        batched=True,
    )


WHEEL_LAYOUT: tuple[str, ...] = ("speed_max", "viscous", "coulomb", "coulomb_band")


def wheel_specs() -> list[FunctionSpec]:
    u, Omega = _scalar("u_command"), _scalar("Omega")
    w = vector_symbols("wheel", len(WHEEL_LAYOUT))
    u_motor, u_net = wheel_motor_torque(u[0], Omega[0], *w)
    g, omega_dot = vector_symbols("g"), vector_symbols("omega_dot")
    J_s, net = _scalar("J_s"), _scalar("u_net")
    return [
        FunctionSpec(
            name="wheel_torque",
            doc="one reaction wheel: motor torque after the speed limit, and net torque on the wheel (friction "
            "included); wheel = [speed_max, viscous, coulomb, coulomb_band]",
            inputs=(("u_command", u), ("Omega", Omega), ("wheel", w)),
            outputs=(("u_motor", sp.ImmutableMatrix([u_motor])), ("u_net", sp.ImmutableMatrix([u_net]))),
            batched=True,
        ),
        FunctionSpec(
            name="wheel_acceleration",
            doc="spin acceleration of a wheel relative to the hub: Omega_dot = u_net / J_s - g^T omega_dot",
            inputs=(("g", g), ("J_s", J_s), ("u_net", net), ("omega_dot", omega_dot)),
            outputs=(("Omega_dot", sp.ImmutableMatrix([wheel_acceleration(g, J_s[0], net[0], omega_dot)])),),
            batched=True,
        ),
    ]


def sensor_spec() -> FunctionSpec:
    sigma, omega = vector_symbols("sigma"), vector_symbols("omega")
    dtheta, error = vector_symbols("dtheta"), vector_symbols("gyro_error")
    return FunctionSpec(
        name="sensor_measurement",
        doc="what the law sees: star-tracker attitude (true attitude rotated by the small body-frame rotation "
        "dtheta) and rate-gyro rate (true rate plus the gyro error)",
        inputs=(("sigma", sigma), ("omega", omega), ("dtheta", dtheta), ("gyro_error", error)),
        outputs=(
            ("sigma_measured", star_tracker_measurement(sigma, dtheta)),
            ("omega_measured", rate_gyro_measurement(omega, error)),
        ),
    )


def _slope_vector(sigma_e, g):
    """The gains of ``sigma_e_dot`` in eq 17 (``alpha |sigma_e|^(alpha-1)`` with the Remark 6 fix)."""
    return sp.ImmutableMatrix([surface_term_slope(x, g["alpha"], g["fix_mode"], g["epsilon"]) for x in sigma_e])


def _sliding_stages(error_model: ErrorModel):
    """Inputs and stages shared by the sliding-variable and full-control functions."""
    sigma, omega = vector_symbols("sigma"), vector_symbols("omega")
    sigma_d, omega_d, omega_d_dot = vector_symbols("sigma_d"), vector_symbols("omega_d"), vector_symbols("omega_d_dot")
    gains, g = _gains()
    q = _scalar("epsilon_pow_alpha_minus_1")
    sigma_e = vector_symbols("sigma_e")
    p = vector_symbols("abs_sigma_e_pow_alpha")
    omega_r = vector_symbols("omega_r")
    omega_e = vector_symbols("omega_e")
    slope = vector_symbols("slope")
    s = vector_symbols("s")
    omega_r_dot = vector_symbols("omega_r_dot")
    alpha, eps = g["alpha"], g["epsilon"]

    def share(m):
        return share_fractional_powers(m, sigma_e, alpha, eps, p, q[0])

    stages = (
        (sigma_e, mrp_error(sigma, sigma_d)),
        (p, sigma_e.applyfunc(lambda x: sp.Abs(x) ** alpha)),
        (omega_r, reference_rate_in_body(error_model, sigma_e, omega_d)),
        (omega_e, omega - omega_r),
        (slope, share(_slope_vector(sigma_e, g))),
        (
            s,
            share(sliding_variable(sigma_e, mrp_G(sigma_e) * omega_e, g["c1"], g["c2"], alpha, g["fix_mode"], eps)),
        ),
        (omega_r_dot, reference_acceleration_in_body(error_model, sigma_e, omega_e, omega_d, omega_d_dot)),
    )
    inputs = (
        ("sigma", sigma),
        ("omega", omega),
        ("sigma_d", sigma_d),
        ("omega_d", omega_d),
        ("omega_d_dot", omega_d_dot),
        ("gains", gains),
        ("gain_constants", q),
    )
    values = dict(sigma_e=sigma_e, omega_r=omega_r, omega_e=omega_e, s=s, omega_r_dot=omega_r_dot, slope=slope)
    return inputs, stages, values


def sliding_spec(error_model: ErrorModel) -> FunctionSpec:
    inputs, stages, v = _sliding_stages(error_model)
    return FunctionSpec(
        name=f"sliding_{error_model.value}",
        doc=(
            f"sliding variable s (eq 13) and the error state for the {error_model.value} error kinematics: "
            "sigma_e = sigma (x) sigma_d^-1 in the shadow set, omega_r = reference rate in the body frame, "
            "omega_e = omega - omega_r, omega_r_dot its body-frame derivative, slope = the gain "
            "alpha |sigma_e|^(alpha-1) of eq 17 after the Remark 6 fix"
        ),
        inputs=inputs,
        outputs=tuple((k, v[k]) for k in ("s", "sigma_e", "omega_e", "omega_r", "omega_r_dot", "slope")),
        stages=stages,
    )


def _control_core(sigma_e, omega_e, omega_r, omega_r_dot, s, slope, J0, g, delta, k_sum, received, u_max):
    """Eqs 16-19 in computed-torque form, with the eq 17 slope supplied by the sliding stage."""
    pieces = computed_torque_pieces(
        J0,
        sigma_e,
        omega_e,
        omega_r,
        omega_r_dot,
        s,
        g["c1"],
        g["c2"],
        g["alpha"],
        delta,
        coordination_term(s, k_sum, received),
        boundary_layer=g["boundary_layer"],
        fix=g["fix_mode"],
        epsilon=g["epsilon"],
    )
    rep = dict(zip(_slope_vector(sigma_e, g), slope, strict=True))
    pieces = type(pieces)(*(m.xreplace(rep) for m in (pieces.u_F, pieces.u_D, pieces.u_C)))
    leftover = set().union(*(m.free_symbols for m in (pieces.u_F, pieces.u_D, pieces.u_C))) & {g["alpha"]}
    if leftover:  # every fractional power must come from the slope input
        raise AssertionError("control_core still depends on alpha after slope substitution")
    return pieces, saturate(pieces.u, u_max)


def _control_inputs():
    J0 = symmetric_matrix_symbols("J0")
    delta = vector_symbols("delta")
    k_sum = _scalar("k_sum")
    received = vector_symbols("received")
    u_max = _scalar("u_max")
    return J0, delta, k_sum, received, u_max


def control_core_spec() -> FunctionSpec:
    sigma_e, omega_e, omega_r, omega_r_dot, s, slope = (
        vector_symbols(n) for n in ("sigma_e", "omega_e", "omega_r", "omega_r_dot", "s", "slope")
    )
    gains, g = _gains()
    J0, delta, k_sum, received, u_max = _control_inputs()
    pieces, u = _control_core(
        sigma_e, omega_e, omega_r, omega_r_dot, s, slope, J0, g, delta, k_sum[0], received, u_max[0]
    )
    return FunctionSpec(
        name="control_core",
        doc=(
            "FSM control (eqs 16-19) in computed-torque form from the error state of sliding_*: "
            "u = sat(-u^F - u^D - u^C); coordination = k_sum s - received with k_sum = sum_j k^i_ij and "
            "received = sum_j k^j_ij s_j; nominal inertia J0"
        ),
        inputs=(
            ("sigma_e", sigma_e),
            ("omega_e", omega_e),
            ("omega_r", omega_r),
            ("omega_r_dot", omega_r_dot),
            ("s", s),
            ("slope", slope),
            ("J0", J0),
            ("gains", gains),
            ("delta", delta),
            ("k_sum", k_sum),
            ("received", received),
            ("u_max", u_max),
        ),
        outputs=(("u", u), ("u_unsaturated", pieces.u)),
    )


def control_law_spec(error_model: ErrorModel) -> FunctionSpec:
    inputs, stages, v = _sliding_stages(error_model)
    g = dict(zip(GAINS_LAYOUT, dict(inputs)["gains"], strict=True))
    J0, delta, k_sum, received, u_max = _control_inputs()
    pieces, u = _control_core(
        v["sigma_e"],
        v["omega_e"],
        v["omega_r"],
        v["omega_r_dot"],
        v["s"],
        v["slope"],
        J0,
        g,
        delta,
        k_sum[0],
        received,
        u_max[0],
    )
    return FunctionSpec(
        name=f"control_law_{error_model.value}",
        doc=(
            f"one agent's FSM controller for the {error_model.value} error kinematics, from absolute states: "
            "torque u (saturated), sliding variable s (eq 13), sigma_e, and the pieces u^F, u^D, u^C of eqs 17-19"
        ),
        inputs=(*inputs, ("J0", J0), ("delta", delta), ("k_sum", k_sum), ("received", received), ("u_max", u_max)),
        outputs=(
            ("u", u),
            ("s", v["s"]),
            ("sigma_e", v["sigma_e"]),
            ("u_F", pieces.u_F),
            ("u_D", pieces.u_D),
            ("u_C", pieces.u_C),
            ("u_unsaturated", pieces.u),
        ),
        stages=stages,
    )


def closed_loop_spec() -> FunctionSpec:
    sigma_e, sigma_e_dot = vector_symbols("sigma_e"), vector_symbols("sigma_e_dot")
    gains, g = _gains()
    delta, coordination = vector_symbols("delta"), vector_symbols("coordination")
    s = sliding_variable(sigma_e, sigma_e_dot, g["c1"], g["c2"], g["alpha"], g["fix_mode"], g["epsilon"])
    acc = closed_loop_acceleration(
        sigma_e,
        sigma_e_dot,
        s,
        g["c1"],
        g["c2"],
        g["alpha"],
        delta,
        coordination,
        boundary_layer=g["boundary_layer"],
        fix=g["fix_mode"],
        epsilon=g["epsilon"],
    )
    return FunctionSpec(
        name="closed_loop",
        doc="closed loop (eq 20): sigma_e_ddot from sigma_e, sigma_e_dot and the coordination vector",
        inputs=(
            ("sigma_e", sigma_e),
            ("sigma_e_dot", sigma_e_dot),
            ("gains", gains),
            ("delta", delta),
            ("coordination", coordination),
        ),
        outputs=(("sigma_e_ddot", acc), ("s", s)),
    )


def error_state_spec(error_model: ErrorModel) -> FunctionSpec:
    sigma, omega = vector_symbols("sigma"), vector_symbols("omega")
    sigma_d, omega_d = vector_symbols("sigma_d"), vector_symbols("omega_d")
    sigma_e, omega_r, omega_e = vector_symbols("sigma_e"), vector_symbols("omega_r"), vector_symbols("omega_e")
    return FunctionSpec(
        name=f"error_state_{error_model.value}",
        doc=(
            f"true error state for the {error_model.value} error kinematics (what the metrics see): "
            "sigma_e = sigma (x) sigma_d^-1 in the shadow set, omega_e = omega - omega_r"
        ),
        inputs=(("sigma", sigma), ("omega", omega), ("sigma_d", sigma_d), ("omega_d", omega_d)),
        # the same stages as LawBuilder.error_state(), so the recorded error equals what the law computes, bit for bit
        stages=(
            (sigma_e, mrp_error(sigma, sigma_d)),
            (omega_r, reference_rate_in_body(error_model, sigma_e, omega_d)),
            (omega_e, omega - omega_r),
        ),
        outputs=(("sigma_e", sigma_e), ("omega_e", omega_e)),
    )


def mrp_specs() -> list[FunctionSpec]:
    sigma, sigma_d = vector_symbols("sigma"), vector_symbols("sigma_d")
    return [
        FunctionSpec(
            name="mrp_error",
            doc="attitude error sigma_e: [B R] = [B N][R N]^T, via Euler parameters, in the shadow set |sigma_e| <= 1",
            inputs=(("sigma", sigma), ("sigma_d", sigma_d)),
            outputs=(("sigma_e", mrp_error(sigma, sigma_d)),),
        ),
        FunctionSpec(
            name="mrp_shadow",
            doc="shadow-set switching: -sigma/|sigma|^2 when |sigma| > 1",
            inputs=(("sigma", sigma),),
            outputs=(("sigma_shadow", mrp_shadow(sigma)),),
        ),
        FunctionSpec(
            name="mrp_principal_angle",
            doc="Euler principal angle theta = 4 atan|sigma| (eq 2)",
            inputs=(("sigma", sigma),),
            outputs=(("theta", sp.ImmutableMatrix([mrp_principal_angle(sigma)])),),
        ),
        FunctionSpec(
            name="mrp_to_dcm",
            doc="direction-cosine matrix [BN] of an MRP",
            inputs=(("sigma", sigma),),
            outputs=(("R", mrp_to_dcm(sigma)),),
        ),
    ]


def scalar_sliding_mode_spec() -> FunctionSpec:
    x = _scalar("x")
    c = vector_symbols("c", 3)
    return FunctionSpec(
        name="scalar_sliding_mode",
        doc="scalar sliding mode of Sec. 3.3: x_dot = -c1 x - c2 sig(x)^alpha (FSM; TSM with c1 = 0; LSM with c2 = 0), c = [c1, c2, alpha]",
        inputs=(("x", x), ("c", c)),
        outputs=(("x_dot", sp.ImmutableMatrix([scalar_sliding_mode(x[0], c[0], c[1], c[2])])),),
    )


def function_catalogue() -> list[FunctionSpec]:
    """Every generated function, in a fixed order (the order of the manifest)."""
    return [
        *mrp_specs(),
        disturbance_spec(),
        reference_spec(),
        sliding_constants_spec(),
        plant_spec(),
        gyrostat_spec(),
        *wheel_specs(),
        sensor_spec(),
        error_state_spec(ErrorModel.PAPER),
        error_state_spec(ErrorModel.EXACT),
        sliding_spec(ErrorModel.PAPER),
        sliding_spec(ErrorModel.EXACT),
        control_core_spec(),
        control_law_spec(ErrorModel.PAPER),
        control_law_spec(ErrorModel.EXACT),
        closed_loop_spec(),
        scalar_sliding_mode_spec(),
    ]
