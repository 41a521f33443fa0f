"""The catalogue of the model's functions the runtime needs, defined once from the symbolic model.

Each :class:`FunctionSpec` names its inputs (matrices of symbols), optional
intermediate stages, and outputs (SymPy matrices).  :mod:`fsmctl.codegen.writer`
turns the catalogue into CasADi functions, C sources and a manifest; the
runtime (``fsmctl``) loads those and never re-types an equation.

Per-agent functions only: a formation of any size and topology is assembled at
run time from them.  The plant, the reference, the disturbance, the hardware and the
error state are here; the control laws, the paper's among them, are generated once each in
their own folders (``derive/laws/``, ``generated/laws/<name>/``).

Packed parameter vectors (their layouts are written to the manifest):

* ``params`` of :func:`disturbance_spec` / :func:`reference_spec` =
  ``[amplitude(3), frequency(3), phase(3), offset(3)]`` for
  ``v_k(t) = amplitude_k cos(frequency_k t + phase_k) + offset_k``.

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

import sympy as sp

from fsmctl.symbolic.functions import FunctionSpec
from fsmctl.symbolic.hardware import (
    gyrostat_rhs,
    rate_gyro_measurement,
    star_tracker_measurement,
    wheel_acceleration,
    wheel_friction,
    wheel_motor_torque,
)
from fsmctl.symbolic.model import ErrorModel, plant_rhs, reference_rate_in_body
from fsmctl.symbolic.mrp import mrp_error, mrp_kinematics, mrp_principal_angle, mrp_shadow, mrp_to_dcm
from fsmctl.symbolic.symbols import symmetric_matrix_symbols, vector_symbols

__all__ = [
    "error_state_spec",
    "SINUSOID_LAYOUT",
    "WHEEL_LAYOUT",
    "FunctionSpec",
    "function_catalogue",
]

SINUSOID_LAYOUT: tuple[str, ...] = tuple(
    f"{field_}[{k}]" for field_ in ("amplitude", "frequency", "phase", "offset") for k in range(3)
)


def _scalar(name: str) -> sp.ImmutableMatrix:
    return sp.ImmutableMatrix([sp.Symbol(name, real=True)])


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
    u_held = _scalar("u_motor")
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
            name="wheel_net_torque",
            doc="one reaction wheel: net torque on the wheel for a motor torque already past the speed limit (the "
            "limit decided at the start of the step and held: actuator.speed_gate = 'step_start'), friction "
            "included; wheel = [speed_max, viscous, coulomb, coulomb_band] (speed_max unused)",
            inputs=(("u_motor", u_held), ("Omega", Omega), ("wheel", w)),
            outputs=(("u_net", sp.ImmutableMatrix([u_held[0] + wheel_friction(Omega[0], *w[1:])])),),
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


def function_catalogue() -> list[FunctionSpec]:
    """Every generated function, in a fixed order (the order of the manifest)."""
    return [
        *mrp_specs(),
        disturbance_spec(),
        reference_spec(),
        plant_spec(),
        gyrostat_spec(),
        *wheel_specs(),
        sensor_spec(),
        error_state_spec(ErrorModel.PAPER),
        error_state_spec(ErrorModel.EXACT),
    ]
