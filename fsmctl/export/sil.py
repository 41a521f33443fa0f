"""Software in the loop: the engine flies a scenario with an exported C library as every agent's controller.

:func:`verify_export` compiles the exported sources (with their strict flags) together with a small harness
(``fsmctl/csrc/export/sil_glue.c``: one ``P_controller`` per agent behind the engine's external-controller hook,
``fsm_controller_fn`` of fsmctl/csrc/formation.h) and flies the scenario twice at the same control period (zero-order
hold): with the engine's own law and with the exported object code in the loop.  In float64 the two runs must be
identical, bit for bit (every recorded array, and the library's own law state equal to the engine's at every
instant); in float32 the differences are measured and reported, with whether each run converges.
"""

from __future__ import annotations

import ctypes
import json
import tempfile
import warnings
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from fsmctl.errors import InputError
from fsmctl.export.build import compile_export
from fsmctl.export.c_library import CLibrary, ExportError, file_sha256, read_c_library
from fsmctl.model.generated_code import driver_source_dir
from fsmctl.model.laws import LawSwitchWarning
from fsmctl.model.problem import pack
from fsmctl.model.scenario import Scenario
from fsmctl.policy import EXPORT_CONTROL_PERIOD
from fsmctl.simulation import ExternalController, SimulationResult, attitude_error_angle, simulate

__all__ = ["COMPARED_ARRAYS", "ExportCheck", "sil_scenario", "verify_export"]

COMPARED_ARRAYS = ("sigma", "omega", "sigma_e", "omega_e", "u", "u_unsaturated", "broadcast", "z")
"""The recorded arrays the check compares (besides the time grid)."""


@dataclass(frozen=True)
class ExportCheck:
    """The outcome of :func:`verify_export`.

    Parameters
    ----------
    library : CLibrary
        The exported library that flew.
    scenario : Scenario
        The scenario both runs flew (the library's law and error model, its control period).
    reference, in_the_loop : SimulationResult
        The engine's own law, and the exported object code in the loop.
    z_mismatches : int
        Control instants where the library's own law state differed from the engine's (float64 only).
    files_match_manifest : bool
        Whether every file of the library still has the sha256 of its ``manifest.json``.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.export import write_c_library
    >>> lib = write_c_library("fsm", "fsm_c", control_period=0.01, precision="float32", error_model="paper")
    >>> check = verify_export(lib, fsmctl.paper_scenario("1").replace(simulation={"t_final": 1.0}))
    >>> check.bit_identical, check.max_torque_error < 5.0, check.report_lines()[1].split(",")[0]
    (False, True, '  largest torque difference ...')
    """

    library: CLibrary
    scenario: Scenario
    reference: SimulationResult
    in_the_loop: SimulationResult
    z_mismatches: int
    files_match_manifest: bool

    @property
    def differing_arrays(self) -> tuple[str, ...]:
        """The recorded arrays that are not bit-identical (NaN equal to NaN; ``time`` first if it differs)."""
        names = ("time", *COMPARED_ARRAYS)
        return tuple(
            name
            for name in names
            if not np.array_equal(getattr(self.reference, name), getattr(self.in_the_loop, name), equal_nan=True)
        )

    @property
    def bit_identical(self) -> bool:
        """Every recorded array equal bit for bit and the law state equal at every instant."""
        return not self.differing_arrays and self.z_mismatches == 0

    @property
    def max_torque_error(self) -> float:
        """The largest difference of an applied torque component between the runs (N m)."""
        return float(np.max(np.abs(self.in_the_loop.u - self.reference.u)))

    @property
    def max_attitude_error_deg(self) -> float:
        """The largest angle between the two runs' attitudes of an agent at an output time (deg)."""
        if np.array_equal(self.in_the_loop.sigma, self.reference.sigma):
            return 0.0  # (the angle formula's rounding is ~1e-14 deg for equal attitudes)
        angle = attitude_error_angle(self.in_the_loop.sigma, self.reference.sigma, degrees=True)
        return float(np.max(angle))

    @property
    def converged(self) -> tuple[bool, bool]:
        """Whether the reference and the in-the-loop run converge (``SimulationResult.summary()['converged']``)."""
        return bool(self.reference.summary()["converged"]), bool(self.in_the_loop.summary()["converged"])

    @property
    def passed(self) -> bool:
        """float64: bit-identical; float32: finite throughout, converging exactly when the engine's run does."""
        if self.library.precision == "float64":
            return self.bit_identical
        ref, sil = self.converged
        return bool(np.all(np.isfinite(self.in_the_loop.u))) and sil == ref

    def report_lines(self) -> list[str]:
        """What ``fsmctl export --verify`` prints."""
        lib, s = self.library, self.scenario
        hold = s.simulation.control_period
        lines = [
            f"software in the loop: {s.label}, {s.n_agents} agents, {s.simulation.t_final:g} s, control period "
            f"{hold:g} s ({_steps(round(hold / s.simulation.dt))} of {s.simulation.dt:g} s), law {lib.law.name} "
            f"({lib.error_model} error kinematics) as {lib.precision} C from {lib.folder}"
        ]
        if not self.files_match_manifest:
            lines.append("  the library's files differ from its manifest.json (edited after the export)")
        if lib.precision == "float64":
            verdict = "bit-identical" if self.bit_identical else "NOT bit-identical"
            detail = "" if self.bit_identical else f" (differs: {', '.join(self.differing_arrays) or 'law state'})"
            lines.append(f"  {verdict} to the engine's own law{detail}")
        lines.append(
            f"  largest torque difference {self.max_torque_error:.3g} N m, largest attitude difference "
            f"{self.max_attitude_error_deg:.3g} deg"
        )
        ref, sil = self.converged
        a, b = self.reference.summary(), self.in_the_loop.summary()
        lines.append(
            f"  converges: engine {'yes' if ref else 'no'}, exported code {'yes' if sil else 'no'}; steady AAEM "
            f"(the last {a['steady_window_s']:g} s): engine {a['aaem_steady_max_deg']:.3g} deg, exported code "
            f"{b['aaem_steady_max_deg']:.3g} deg"
        )
        return lines


def _steps(k: int) -> str:
    return f"{k} step" if k == 1 else f"{k} steps"


def sil_scenario(scenario: Scenario, library: CLibrary, control_period: float | None = None) -> Scenario:
    """``scenario`` flying the library's law and error model with zero-order hold at ``control_period``.

    Parameters
    ----------
    scenario : Scenario
        What to fly.
    library : CLibrary
        The export (its law replaces the scenario's, with the law's own parameters; its error model too).
    control_period : float, optional
        The period (s); default the scenario's when it has one, else :data:`fsmctl.policy.EXPORT_CONTROL_PERIOD`.

    Returns
    -------
    Scenario
        The scenario both runs of :func:`verify_export` fly.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.export import write_c_library
    >>> lib = write_c_library("pid", "pid_c", control_period=0.01, error_model="exact")
    >>> s = sil_scenario(fsmctl.paper_scenario("1"), lib)
    >>> s.law.name, s.controller.error_model, s.simulation.control_period
    ('pid', 'exact', 0.01)
    """
    period = control_period or scenario.simulation.control_period or EXPORT_CONTROL_PERIOD
    law = library.law.name if library.law.builtin else library.law.folder
    held = scenario.replace(controller={"error_model": library.error_model}, simulation={"control_period": period})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LawSwitchWarning)  # the exported law's own parameters apply
        return held.with_law(law) if scenario.controller.law != library.law.name else held


def _glue(library: CLibrary, folder: Path) -> Path:
    template = (resources.files("fsmctl") / "csrc" / "export" / "sil_glue.c").read_text()
    P = library.prefix
    path = folder / f"{P}_sil_glue.c"
    path.write_text(template.replace("@PU@", P.upper()).replace("@P@", P))
    return path


def _load(library: CLibrary, folder: Path) -> ctypes.CDLL:
    so = compile_export(
        library,
        folder / f"lib{library.prefix}_sil.so",
        extra_flags=["-O2"],
        extra_sources=[_glue(library, folder)],
        include_dirs=[driver_source_dir()],
    )
    dll = ctypes.CDLL(str(so))
    P = library.prefix
    getattr(dll, f"{P}_sil_bytes").restype = ctypes.c_size_t
    getattr(dll, f"{P}_sil_bytes").argtypes = [ctypes.c_int, ctypes.c_int]
    dp = ctypes.POINTER(ctypes.c_double)
    getattr(dll, f"{P}_sil_init").argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_int, dp, dp, dp]
    getattr(dll, f"{P}_sil_init").argtypes += [ctypes.c_double, ctypes.c_int]
    for name in ("z_mismatches", "failures"):
        getattr(dll, f"{P}_sil_{name}").restype = ctypes.c_longlong
        getattr(dll, f"{P}_sil_{name}").argtypes = [ctypes.c_void_p]
    return dll


def _controller(library: CLibrary, dll: ctypes.CDLL, scenario: Scenario) -> tuple[ExternalController, object]:
    p = pack(scenario)
    n = p.n_agents
    max_links = int(np.bincount(np.asarray(p.link_receiver, dtype=int), minlength=n).max()) if p.n_links else 0
    P = library.prefix
    memory = ctypes.create_string_buffer(getattr(dll, f"{P}_sil_bytes")(n, max_links))
    arrays = [np.ascontiguousarray(a, dtype=float) for a in (p.params, p.J0, p.u_max)]
    dp = ctypes.POINTER(ctypes.c_double)
    status = getattr(dll, f"{P}_sil_init")(
        memory, n, max_links, *(a.ctypes.data_as(dp) for a in arrays), p.dt, int(p.hold_steps)
    )
    if status != 0:
        raise ExportError(f"the exported {P}_init refused the scenario's configuration (status {status})")
    function = ctypes.cast(getattr(dll, f"{P}_sil_controller"), ctypes.c_void_p).value
    context = ctypes.cast(memory, ctypes.c_void_p).value
    return ExternalController(function, context, owner=(dll, memory, arrays)), memory


def _files_match(library: CLibrary) -> bool:
    listed = json.loads((library.folder / "manifest.json").read_text()).get("sha256", {})
    return all(
        (library.folder / name).is_file() and file_sha256(library.folder / name) == digest
        for name, digest in listed.items()
    )


def verify_export(
    library: CLibrary | str | Path, scenario: Scenario, *, control_period: float | None = None
) -> ExportCheck:
    """Fly ``scenario`` with the exported library in the loop and compare with the engine's own law.

    Parameters
    ----------
    library : CLibrary or path
        An export (:func:`fsmctl.export.write_c_library`) or its folder; its files are compiled as they are now.
    scenario : Scenario
        What to fly (e.g. :func:`fsmctl.paper_scenario`); its law is replaced by the library's (with the law's own
        parameters), its error model by the library's.
    control_period : float, optional
        The zero-order-hold period (s, a multiple of ``simulation.dt``; default: the scenario's, else
        :data:`fsmctl.policy.EXPORT_CONTROL_PERIOD`).

    Returns
    -------
    ExportCheck
        Both runs and their comparison (``passed``, ``bit_identical``, ``report_lines()``).

    Raises
    ------
    ExportError
        The library does not compile or refuses the scenario's parameters.
    InputError
        A control period the scenario cannot fly.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.export import write_c_library, verify_export
    >>> lib = write_c_library("pid", "pid_c", control_period=0.01, error_model="paper")
    >>> check = verify_export(lib, fsmctl.paper_scenario("1").replace(simulation={"t_final": 2.0}))
    >>> check.bit_identical, check.z_mismatches
    (True, 0)
    """
    lib = library if isinstance(library, CLibrary) else read_c_library(library)
    flown = sil_scenario(scenario, lib, control_period)
    if flown.simulation.integrator != "rk4":
        raise InputError("software in the loop flies fixed-step RK4 (simulation.integrator = 'rk4')")
    reference = simulate(flown, progress=False)
    with tempfile.TemporaryDirectory(prefix="fsmctl-sil-") as tmp:
        dll = _load(lib, Path(tmp))
        controller, memory = _controller(lib, dll, flown)
        in_the_loop = simulate(flown, progress=False, controller_in_the_loop=controller)
        mismatches = int(getattr(dll, f"{lib.prefix}_sil_z_mismatches")(memory))
    return ExportCheck(lib, flown, reference, in_the_loop, mismatches, _files_match(lib))
