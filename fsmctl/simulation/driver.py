"""The ctypes binding of the compiled whole-loop driver (``fsmctl/csrc/formation.c``).

The structures ``fsm_problem`` / ``fsm_output`` as :class:`ctypes.Structure`, the ABI check, the per-law library
(:func:`_driver`, compiled on first use and cached) and :class:`_CProblem`, which keeps the packed arrays alive
while C holds pointers into them.  :mod:`fsmctl.simulation.simulator` flies runs through it.
"""

from __future__ import annotations

import ctypes
import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fsmctl.model.generated_code import compiled_library, default_law_dir
from fsmctl.model.generated_paths import GeneratedCodeError
from fsmctl.model.problem import PackedProblem
from fsmctl.policy import ZENO_CONSECUTIVE_CHECKS
from fsmctl.simulation.failures import SimulationError

# ----------------------------------------------------------------------------- ctypes binding

_dp = ctypes.POINTER(ctypes.c_double)
_ip = ctypes.POINTER(ctypes.c_int)
_llp = ctypes.POINTER(ctypes.c_longlong)


class _Problem(ctypes.Structure):
    """Mirror of ``fsm_problem`` (fsmctl/csrc/formation.h); checked against the library at load (:func:`_check_abi`)."""

    _fields_ = [
        ("n_agents", ctypes.c_int),
        ("error_model", ctypes.c_int),
        ("integrator", ctypes.c_int),
        ("kernels", ctypes.c_int),
        ("n_params", ctypes.c_int),
        ("n_states", ctypes.c_int),
        ("n_broadcast", ctypes.c_int),
        ("n_links", ctypes.c_int),
        ("t0", ctypes.c_double),
        ("dt", ctypes.c_double),
        ("n_steps", ctypes.c_longlong),
        ("output_every", ctypes.c_longlong),
        ("hold_steps", ctypes.c_longlong),
        ("rtol", ctypes.c_double),
        ("atol", ctypes.c_double),
        ("h_min", ctypes.c_double),
        ("max_steps", ctypes.c_longlong),
        ("J_true", _dp),
        ("J0", _dp),
        ("params", _dp),
        ("u_max", _dp),
        ("dist_params", _dp),
        ("ref_params", _dp),
        ("link_receiver", _ip),
        ("link_sender", _ip),
        ("link_k_i", _dp),
        ("sched_period", _dp),
        ("sched_phase", _dp),
        ("sched_start", _ip),
        ("sched_count", _ip),
        ("sched_times", _dp),
        ("sched_values", _dp),
        ("n_wheels", ctypes.c_int),
        ("sensors", ctypes.c_int),
        ("links_imperfect", ctypes.c_int),
        ("n_samples", ctypes.c_longlong),
        ("wheel_axes", _dp),
        ("wheel_pinv", _dp),
        ("wheel_Js", _dp),
        ("wheel_torque_max", _dp),
        ("wheel_params", _dp),
        ("J_spin", _dp),
        ("sensor_dtheta", _dp),
        ("sensor_gyro", _dp),
        ("link_delay", _ip),
        ("link_lost", ctypes.POINTER(ctypes.c_ubyte)),
        ("n_members", ctypes.c_int),
        # wheels as Basilisk flies them (ABI 5)
        ("wheel_allocation", ctypes.c_int),
        ("wheel_gate", ctypes.c_int),
        ("wheel_command", _dp),
        # event-triggered communication (ABI 5)
        ("trigger_every", ctypes.c_longlong),
        ("zeno_checks", ctypes.c_longlong),
        # software in the loop (ABI 6)
        ("controller", ctypes.c_void_p),
        ("controller_context", ctypes.c_void_p),
    ]


class _Output(ctypes.Structure):
    """Mirror of ``fsm_output`` (fsmctl/csrc/formation.h); checked against the library at load."""

    _fields_ = [
        ("capacity", ctypes.c_longlong),
        ("written", ctypes.c_longlong),
        ("t", _dp),
        ("sigma_d", _dp),
        ("sigma", _dp),
        ("omega", _dp),
        ("sigma_e", _dp),
        ("omega_e", _dp),
        ("u", _dp),
        ("u_unsat", _dp),
        ("broadcast", _dp),
        ("z", _dp),
        ("saturated_time", _dp),
        ("u_total_variation", _dp),
        ("u_unsat_max", _dp),
        ("steps_taken", ctypes.c_longlong),
        ("steps_rejected", ctypes.c_longlong),
        ("fail_time", ctypes.c_double),
        ("fail_agent", ctypes.c_int),
        ("wheel_speed", _dp),
        ("wheel_torque", _dp),
        ("sigma_measured", _dp),
        ("omega_measured", _dp),
        # event-triggered communication (ABI 5)
        ("messages_sent", _llp),
        ("messages_delivered", _llp),
        ("events_per_output", _llp),
        ("first_event", _dp),
        ("last_event", _dp),
        ("min_inter_event", _dp),
    ]


ABI_VERSION = 6
"""``FSM_ABI_VERSION`` of fsmctl/csrc/formation.h that these mirrors describe."""

_PROGRESS = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_longlong, ctypes.c_longlong)
_RC = {
    1: "a state became non-finite",
    2: "aborted",
    3: "out of memory",
    4: "the packed problem is inconsistent (or the law's code does not match its description)",
    5: "the adaptive step size fell below h_min",
    6: "the adaptive integrator exceeded its step budget",
    7: "the control law returned a non-finite torque command",
    8: "the event trigger fired at every check (Zeno behaviour)",
    9: "the external controller (software in the loop) reported a failure",
}


def _expected_abi() -> list[int]:
    """``fsm_abi()`` as these ctypes mirrors see it: version, sizes, then every field offset."""
    return [
        ABI_VERSION,
        ctypes.sizeof(_Problem),
        ctypes.sizeof(_Output),
        *(getattr(_Problem, name).offset for name, _ in _Problem._fields_),
        *(getattr(_Output, name).offset for name, _ in _Output._fields_),
    ]


def _check_abi(dll: ctypes.CDLL, where: str) -> None:
    """The library's struct layout must be the one mirrored here (a stale or foreign library is refused)."""
    expected = _expected_abi()
    buf = (ctypes.c_longlong * (len(expected) + 8))()
    count = dll.fsm_abi(buf, len(buf))
    got = list(buf[: min(count, len(buf))])
    if count != len(expected) or got != expected:
        raise SimulationError(
            f"{where}: the compiled driver's struct layout (fsm_abi: {got[:3]}, {count} entries) does not match "
            f"fsmctl's ({expected[:3]}, {len(expected)} entries); clear the cache ({where}) and retry"
        )


@functools.cache
def _driver_for(law_dir: Path) -> ctypes.CDLL | None:
    lib = compiled_library(law_dir)
    if lib is None:
        return None
    dll = ctypes.CDLL(str(lib.path))
    dll.fsm_abi.argtypes = [ctypes.POINTER(ctypes.c_longlong), ctypes.c_int]
    dll.fsm_abi.restype = ctypes.c_int
    _check_abi(dll, str(lib.path))
    dll.fsm_simulate.argtypes = [ctypes.POINTER(_Problem), _dp, ctypes.POINTER(_Output), _PROGRESS, ctypes.c_longlong]
    dll.fsm_simulate.restype = ctypes.c_int
    dll.fsm_rhs.argtypes = [ctypes.POINTER(_Problem), ctypes.c_double, _dp, _dp, _dp]
    dll.fsm_rhs.restype = ctypes.c_int
    dll.fsm_link_weight.argtypes = [ctypes.POINTER(_Problem), ctypes.c_int, ctypes.c_double]
    dll.fsm_link_weight.restype = ctypes.c_double
    dll.fsm_law_sizes.argtypes = [ctypes.POINTER(ctypes.c_longlong)]
    dll.fsm_law_sizes.restype = None
    for name in ("fsm_batched_available", "fsm_batched_preferred", "fsm_trigger_available", "fsm_lane_width"):
        getattr(dll, name).argtypes = []
        getattr(dll, name).restype = ctypes.c_int
    if dll.fsm_lane_width() != lib.lanes:
        raise GeneratedCodeError(
            f"{lib.path}: built for {lib.lanes} lanes (its flags) but its driver says {dll.fsm_lane_width()}; "
            "delete the cache folder and run again"
        )
    return dll


def _driver(law=None) -> ctypes.CDLL | None:
    """The compiled driver for a law (a :class:`~fsmctl.model.laws.LawCode`, default the paper's FSM law)."""
    folder = default_law_dir() if law is None else law.folder
    return _driver_for(Path(folder).resolve())


_driver.cache_clear = _driver_for.cache_clear  # type: ignore[attr-defined]


def lane_width(law=None) -> int:
    """Agents per call of the compiled library's batched kernels (``FSM_LANES``: 4, or 8 on CPUs with AVX-512).

    The width is chosen when the library is compiled (:func:`fsmctl.model.generated_code.lane_width`;
    ``FSMCTL_LANES=4`` or ``8`` overrides it) and never changes a result, only the speed.

    Parameters
    ----------
    law : LawCode, optional
        The law whose library is asked (default the paper's FSM law; every law's library is built the same way).

    Returns
    -------
    int
        4 or 8; 0 without a C compiler (the CasADi fallback has no lanes).

    Raises
    ------
    fsmctl.errors.EnvironmentProblem
        ``FSMCTL_LANES`` is set to something else than 4 or 8 (when the library is first loaded in this process).

    Examples
    --------
    >>> from fsmctl.simulation.driver import lane_width
    >>> lane_width() in (0, 4, 8)
    True
    """
    dll = _driver(law)
    return int(dll.fsm_lane_width()) if dll is not None else 0


def batched_kernels_preferred() -> bool:
    """Whether ``kernels="auto"`` uses the lane-batched kernels (the compiled library has AVX); False without C."""
    dll = _driver()
    return bool(dll is not None and dll.fsm_batched_preferred())


def _ptr(a: np.ndarray, ctype=ctypes.c_double):
    return a.ctypes.data_as(ctypes.POINTER(ctype))


_KERNELS = {"auto": 0, "batched": 1, "scalar": 2}


@dataclass(frozen=True)
class ExternalController:
    """A controller in C that the engine calls at the control instants instead of the law's generated functions.

    Software in the loop: :mod:`fsmctl.export` flies an exported C library this way (``fsm_controller_fn`` of
    fsmctl/csrc/formation.h, called per agent for the broadcast, then, after the links, for the torque).

    Parameters
    ----------
    function : int
        The address of an ``fsm_controller_fn``.
    context : int
        Its first argument (an address).
    owner : object
        What keeps the function's library and the context alive while the engine holds their addresses.

    Examples
    --------
    :func:`fsmctl.export.verify_export` builds one from an exported C library and flies it with
    ``fsmctl.simulate(scenario, controller_in_the_loop=controller)``; the fields are plain addresses:

    >>> import ctypes
    >>> from fsmctl.simulation import ExternalController
    >>> context = ctypes.create_string_buffer(64)
    >>> c = ExternalController(function=0, context=ctypes.addressof(context), owner=context)
    >>> c.context == ctypes.addressof(context)
    True
    """

    function: int
    context: int
    owner: object = None


class _CProblem:
    """Keeps the arrays alive while C holds pointers into them."""

    def __init__(
        self,
        p: PackedProblem,
        max_steps: int = 0,
        kernels: str = "auto",
        members: int = 1,
        controller: ExternalController | None = None,
    ):
        self._keep = {"controller": controller}

        ctypes_of = {np.float64: ctypes.c_double, np.int32: ctypes.c_int, np.uint8: ctypes.c_ubyte}

        def f(name, arr, dtype=np.float64):
            a = np.ascontiguousarray(arr, dtype=dtype)
            if a.size == 0:
                a = np.zeros(1, dtype=dtype)
            self._keep[name] = a
            return _ptr(a, ctypes_of[dtype])

        hw = p.hardware

        self.struct = _Problem(
            n_agents=p.n_agents,
            error_model=p.error_model,
            integrator=p.integrator,
            n_params=p.law.n_params,
            n_states=p.n_states,
            n_broadcast=p.n_broadcast,
            t0=p.t0,
            dt=p.dt,
            n_steps=p.n_steps,
            output_every=p.output_every,
            hold_steps=p.hold_steps,
            rtol=p.rtol,
            atol=p.atol,
            h_min=1e-12 * max(1.0, p.dt * p.n_steps),
            max_steps=max_steps or 200 * p.n_steps + 10_000,
            J_true=f("J_true", p.J_true),
            J0=f("J0", p.J0),
            params=f("params", p.params),
            u_max=f("u_max", p.u_max),
            dist_params=f("dist", p.dist_params),
            ref_params=f("ref", p.ref_params),
            n_links=p.n_links,
            link_receiver=f("lr", p.link_receiver, np.int32),
            link_sender=f("ls", p.link_sender, np.int32),
            link_k_i=f("lk", p.link_k_i),
            sched_period=f("sp", p.sched_period),
            sched_phase=f("sph", p.sched_phase),
            sched_start=f("ss", p.sched_start, np.int32),
            sched_count=f("sc", p.sched_count, np.int32),
            sched_times=f("st", p.sched_times),
            sched_values=f("sv", p.sched_values),
            kernels=_KERNELS[kernels],
            n_wheels=hw.n_wheels,
            sensors=int(hw.sensors),
            links_imperfect=int(hw.links_imperfect),
            n_samples=hw.n_samples,
            wheel_axes=f("wa", hw.wheel_axes),
            wheel_pinv=f("wp", hw.wheel_pinv),
            wheel_Js=f("wj", hw.wheel_Js),
            wheel_torque_max=f("wt", hw.wheel_torque_max),
            wheel_params=f("wpar", hw.wheel_params),
            J_spin=f("jspin", hw.J_spin),
            sensor_dtheta=f("sdt", hw.sensor_dtheta),
            sensor_gyro=f("sgy", hw.sensor_gyro),
            link_delay=f("ld", hw.link_delay, np.int32),
            link_lost=f("ll", hw.link_lost, np.uint8),
            n_members=members,
            wheel_allocation=hw.wheel_allocation,
            wheel_gate=hw.wheel_gate,
            wheel_command=None if hw.wheel_command is None else f("wcmd", hw.wheel_command),
            trigger_every=p.trigger_every,
            zeno_checks=ZENO_CONSECUTIVE_CHECKS if p.trigger_every else 0,
            controller=None if controller is None else controller.function,
            controller_context=None if controller is None else controller.context,
        )
