"""FMI 2.0 co-simulation FMUs of one spacecraft's controller and of its plant, and a small master that flies them.

* :func:`write_controller_fmu` (``fsmctl export --target fmu``): the exported C library of a law
  (:func:`fsmctl.export.write_c_library`, the C a flight computer compiles) behind FMI 2.0 co-simulation.
  Parameters: the law's (names, units, defaults, ranges from its ``law.json``; an option is an Integer, its index),
  ``J0``, ``torque_limit``, ``control_period``, ``law_state_substeps``.  Inputs: ``sigma``, ``omega``, ``sigma_d``,
  ``omega_d``, ``omega_d_dot``, and ``n_neighbours`` slots ``neighbour[j]`` (``broadcast``, ``k_own``, ``k_sender``;
  both weights 0: no link).  Outputs: ``torque``, ``torque_commanded``, ``broadcast``, the law state ``z`` (and
  ``wheel_torque`` from ``wheel_speed``, ``spin_axis``, ``spin_inertia`` for a law commanding its wheels).
  ``doStep(t, h)``, ``h = control_period * law_state_substeps``, is one control instant (broadcast, then step, from
  the inputs set before it); the outputs are the command held over ``[t, t + h]``.  The neighbours' broadcasts are
  those set before the step: in a formation of FMUs stepped together they arrive one control period late.
* :func:`write_plant_fmu`: one rigid spacecraft from the engine's generated C (``plant_rhs``, ``disturbance_torque``,
  ``mrp_shadow``: no equation typed by hand), RK4 at the fixed ``dt`` with the torque held over each step and the MRP
  shadow switch after each internal step, in the engine's arithmetic.
(:mod:`fsmctl.export.cosim` flies them together with FMPy.)

An FMU holds ``modelDescription.xml`` (units, causality, variability, initial, model structure),
``binaries/linux64/<id>.so`` and ``sources/`` (every C file; the vendored FMI 2.0 headers with their licence); its
GUID hashes the sources and the variable table.
"""

from __future__ import annotations

import hashlib
import math
import platform
import shutil
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from fsmctl.export.build import compile_export, compiler_path, run_compiler
from fsmctl.export.c_library import ExportError, with_defaults, write_c_library
from fsmctl.model import ActuatorSettings
from fsmctl.model.generated_code import driver_source_dir
from fsmctl.model.generated_paths import generated_dir
from fsmctl.model.laws import LawCode, resolve_law
from fsmctl.outputs import atomic_path
from fsmctl.policy import EXPORT_CONTROL_PERIOD
from fsmctl.version import __version__

__all__ = [
    "DEFAULT_NEIGHBOURS",
    "DEFAULT_PLANT_DT",
    "GRID_TOLERANCE",
    "PLANT_FLAGS",
    "FMUError",
    "write_controller_fmu",
    "write_plant_fmu",
]

DEFAULT_NEIGHBOURS = 5
"""Neighbour slots of a controller FMU: the paper's formation (six spacecraft) has up to five incoming links."""

DEFAULT_PLANT_DT = 0.001
"""s: the plant FMU's internal RK4 step (the paper scenario's ``simulation.dt``)."""

GRID_TOLERANCE = 1e-6
"""How far (relative to the internal step, or to the control period) a communication point or step size may be from
the FMU's grid: a master's accumulated time ``t0 + sum h`` is off by a few ulp, a wrong step by far more."""

PLANT_FLAGS = ("-std=c99", "-O2", "-ffp-contract=off", "-fno-math-errno", "-fPIC", "-shared")
"""Compiler flags of the plant FMU (the engine's arithmetic: no contraction; fsmctl's pow, sin and cos)."""

PLANT_IDENTIFIER = "fsmctl_plant"
"""The plant FMU's model identifier (its shared library's name)."""

_PLATFORM = "linux64"
_COMMON = ("fmu_common.c", "fmu_model.h", "fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h")
_GENERATED = ("plant_rhs", "disturbance_torque", "mrp_shadow")
_BASE_UNITS = {"s": {"s": 1}, "1/s": {"s": -1}, "1/s^2": {"s": -2}, "rad": {"rad": 1}, "rad/s": {"rad": 1, "s": -1},
               "rad/s^2": {"rad": 1, "s": -2}, "N m": {"kg": 1, "m": 2, "s": -2}, "N m s": {"kg": 1, "m": 2, "s": -1},
               "kg m^2": {"kg": 1, "m": 2}, "1/(kg m^2)": {"kg": -1, "m": -2}}  # fmt: skip


class FMUError(ExportError):
    """An FMU cannot be written or flown as asked (an option out of range, an unsupported platform).

    Examples
    --------
    >>> try:
    ...     write_plant_fmu("plant.fmu", dt=-1.0)
    ... except FMUError as exc:
    ...     print(exc)
    dt: must be a finite number > 0 s, got -1.0
    """


# ----------------------------------------------------------------------------- the variable table


@dataclass(frozen=True)
class _Variable:
    name: str
    kind: str  # "Real" or "Integer"
    vr: int
    causality: str
    variability: str
    start: float | None
    unit: str = "1"
    description: str = ""
    minimum: float | None = None
    maximum: float | None = None


@dataclass
class _Table:
    variables: list[_Variable] = field(default_factory=list)
    blocks: dict[str, int] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=lambda: {"Real": 0, "Integer": 0})

    def block(self, key: str, names: Sequence[str], causality: str, variability: str, starts, **info) -> None:
        """Add one block of variables of one kind; ``FSMFMU_VR_<KEY>`` is its first value reference."""
        kind = info.pop("kind", "Real")
        self.blocks[key] = self.counts[kind]
        for name, start in zip(names, np.broadcast_to(np.asarray(starts, dtype=float), (len(names),)), strict=True):
            value = None if causality == "output" else float(start)
            self.variables.append(_Variable(name, kind, self.counts[kind], causality, variability, value, **info))
            self.counts[kind] += 1


def _names(base: str, size: int) -> list[str]:
    return [base] if size == 1 else [f"{base}[{k + 1}]" for k in range(size)]


def _matrix_names(base: str, rows: int, columns: int) -> list[str]:
    return [f"{base}[{i + 1},{j + 1}]" for i in range(rows) for j in range(columns)]


def _c_double(x: float) -> str:
    return repr(x) if np.isfinite(x) else ("(0.0 / 0.0)" if np.isnan(x) else f"({np.sign(x):+.0f}.0 / 0.0)")


def _variables_header(table: _Table, guid: str, extra: Mapping[str, int]) -> str:
    lines = ["/* fmu_variables.h: written by fsmctl.export.fmu with modelDescription.xml (do not edit) */"]
    lines += ["#ifndef FSMCTL_FMU_VARIABLES_H", "#define FSMCTL_FMU_VARIABLES_H", ""]
    lines.append(f'#define FSMFMU_GUID "{guid}"')
    lines.append(f"#define FSMFMU_GRID_TOLERANCE {GRID_TOLERANCE!r}")
    for key, value in extra.items():
        lines.append(f"#define FSMFMU_{key} {value}")
    for kind in ("Real", "Integer"):
        n = table.counts[kind]
        lines += [f"#define FSMFMU_N_{kind.upper()} {n}", f"#define FSMFMU_N_{kind.upper()}_ALLOC {max(n, 1)}"]
    for key, vr in table.blocks.items():
        lines.append(f"#define FSMFMU_VR_{key} {vr}")
    access = {"parameter": 1, "input": 2}
    for kind, ctype in (("Real", "double"), ("Integer", "int")):
        rows = [v for v in table.variables if v.kind == kind]
        starts = ", ".join(_c_double(v.start or 0.0) if kind == "Real" else str(int(v.start or 0)) for v in rows)
        codes = ", ".join(str(access.get(v.causality, 0)) for v in rows)
        name = kind.lower()
        lines.append(f"#ifdef FSMFMU_TABLES\nstatic const {ctype} fsmfmu_{name}_start[] = {{{starts or '0'}}};")
        lines.append(f"static const signed char fsmfmu_{name}_access[] = {{{codes or '0'}}};\n#endif")
    lines += ["", "#endif", ""]
    return "\n".join(lines)


def _xml_double(x: float) -> str:
    """``x`` as an ``xs:double`` (``INF``, ``-INF``, ``NaN``; shortest round-trip digits otherwise)."""
    x = float(x)
    return repr(x) if np.isfinite(x) else ("NaN" if np.isnan(x) else ("INF" if x > 0 else "-INF"))


def _model_description(table: _Table, *, name: str, identifier: str, guid: str, description: str, sources,
                       step: float) -> str:  # fmt: skip
    root = ET.Element(
        "fmiModelDescription",
        fmiVersion="2.0",
        modelName=name,
        guid=guid,
        description=description,
        generationTool=f"fsmctl {__version__}",
        variableNamingConvention="structured",
        numberOfEventIndicators="0",
    )
    cs = ET.SubElement(
        root,
        "CoSimulation",
        modelIdentifier=identifier,
        # a controller steps one control period at a time; the plant any multiple of its dt
        canHandleVariableCommunicationStepSize="false" if "CONTROL_PERIOD" in table.blocks else "true",
        canBeInstantiatedOnlyOncePerProcess="false",
        canNotUseMemoryManagementFunctions="false",
        canGetAndSetFMUstate="false",
        canSerializeFMUstate="false",
        providesDirectionalDerivative="false",
    )
    files = ET.SubElement(cs, "SourceFiles")
    for source in sources:
        ET.SubElement(files, "File", name=source)
    units = ET.SubElement(root, "UnitDefinitions")
    for unit in sorted({v.unit for v in table.variables} - {"1"}):
        element = ET.SubElement(units, "Unit", name=unit)
        if unit in _BASE_UNITS:
            ET.SubElement(element, "BaseUnit", {k: str(e) for k, e in _BASE_UNITS[unit].items()})
    ET.SubElement(root, "DefaultExperiment", startTime="0.0", stopTime=repr(100 * step), stepSize=repr(step))
    variables = ET.SubElement(root, "ModelVariables")
    outputs = []
    for index, v in enumerate(table.variables, start=1):
        attributes = {"name": v.name, "valueReference": str(v.vr), "causality": v.causality}
        attributes["variability"] = v.variability
        if v.causality == "parameter":
            attributes["initial"] = "exact"
        elif v.causality == "output":
            attributes["initial"] = "calculated"
            outputs.append(index)
        if v.description:
            attributes["description"] = v.description
        scalar = ET.SubElement(variables, "ScalarVariable", attributes)
        typed = {}
        if v.start is not None:
            typed["start"] = _xml_double(v.start) if v.kind == "Real" else str(int(v.start))
        if v.kind == "Real" and v.unit != "1":
            typed["unit"] = v.unit
        for key, bound in (("min", v.minimum), ("max", v.maximum)):
            if bound is not None:
                typed[key] = _xml_double(bound) if v.kind == "Real" else str(int(bound))
        ET.SubElement(scalar, v.kind, typed)
    structure = ET.SubElement(root, "ModelStructure")
    for section in ("Outputs", "InitialUnknowns"):
        element = ET.SubElement(structure, section)
        for index in outputs:
            ET.SubElement(element, "Unknown", index=str(index))
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _guid(folder: Path, table: _Table) -> str:
    """A hash of every source file and of the variable table, as ``{8-4-4-4-12}`` hex digits."""
    h = hashlib.sha256()
    for path in sorted(folder.iterdir()):
        h.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    h.update(repr(table.variables).encode())
    d = h.hexdigest()
    return "{" + "-".join((d[:8], d[8:12], d[12:16], d[16:20], d[20:32])) + "}"


def _copy_common(sources: Path) -> None:
    fmu_dir = resources.files("fsmctl") / "csrc" / "fmu"
    for name in (*_COMMON, "LICENSE-FMI.txt"):
        (sources / name).write_bytes((fmu_dir / name).read_bytes())


def _check_platform() -> None:
    if platform.system() != "Linux" or platform.machine() not in ("x86_64", "AMD64"):
        raise FMUError(f"FMUs are built for linux64 only, this is {platform.system()} {platform.machine()}")


def _zip(stage: Path, path: Path) -> Path:
    """Zip ``stage`` into ``path`` atomically (sorted entries, fixed dates: the same inputs give the same bytes)."""
    with atomic_path(path) as tmp, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        for file in sorted(p for p in stage.rglob("*") if p.is_file()):
            info = zipfile.ZipInfo(file.relative_to(stage).as_posix(), date_time=(2000, 1, 1, 0, 0, 0))
            info.external_attr = 0o644 << 16
            info.compress_type = zipfile.ZIP_DEFLATED
            z.writestr(info, file.read_bytes())
    return path


def _finish(stage: Path, table: _Table, *, extra: Mapping[str, int], name: str, identifier: str,
            description: str, step: float, compiled: Sequence[str]) -> str:  # fmt: skip
    """Write ``fmu_variables.h`` and ``modelDescription.xml`` for ``table``; return the GUID."""
    sources = stage / "sources"
    guid = _guid(sources, table)
    (sources / "fmu_variables.h").write_text(_variables_header(table, guid, extra))
    text = _model_description(
        table, name=name, identifier=identifier, guid=guid, description=description, sources=compiled, step=step
    )
    (stage / "modelDescription.xml").write_text(text)
    (stage / "binaries" / _PLATFORM).mkdir(parents=True)
    return guid


def _positive(name: str, value: float, unit: str = "s") -> float:
    value = float(value)
    if not (np.isfinite(value) and value > 0):
        raise FMUError(f"{name}: must be a finite number > 0 {unit}, got {value}")
    return value


def _vector(name: str, value, size: int) -> np.ndarray:
    array = np.asarray(value, dtype=float).reshape(-1)
    if array.size != size or not np.all(np.isfinite(array)):
        raise FMUError(f"{name}: must be {size} finite numbers, got {np.asarray(value).tolist()}")
    return array


# ----------------------------------------------------------------------------- the plant


def _plant_table(dt: float, J, sigma0, omega0, disturbance) -> _Table:
    t = _Table()
    p = ("parameter", "fixed")
    J = _vector("inertia", J, 9).reshape(3, 3)
    if not (np.array_equal(J, J.T) and np.all(np.linalg.eigvalsh(J) > 0)):
        raise FMUError(f"inertia: must be symmetric positive definite, got {J.tolist()}")
    t.block("J", _matrix_names("J", 3, 3), *p, J.reshape(-1), unit="kg m^2",
            description="true inertia (body frame; symmetric positive definite)")  # fmt: skip
    t.block("SIGMA0", _names("sigma0", 3), *p, _vector("sigma0", sigma0, 3), description="initial attitude (MRP)")
    t.block("OMEGA0", _names("omega0", 3), *p, _vector("omega0", omega0, 3), unit="rad/s",
            description="initial body rate (body frame)")  # fmt: skip
    dist = _vector("disturbance", disturbance, 12)
    t.block("DISTURBANCE", _names("disturbance_amplitude", 3), *p, dist[0:3], unit="N m",
            description="d_k(t) = amplitude_k cos(frequency_k t + phase_k) + offset_k")  # fmt: skip
    t.block("DISTURBANCE_FREQUENCY", _names("disturbance_frequency", 3), *p, dist[3:6], unit="rad/s")
    t.block("DISTURBANCE_PHASE", _names("disturbance_phase", 3), *p, dist[6:9], unit="rad")
    t.block("DISTURBANCE_OFFSET", _names("disturbance_offset", 3), *p, dist[9:12], unit="N m")
    t.block("DT", ["dt"], *p, dt, unit="s", minimum=0.0,
            description="internal fixed RK4 step; doStep sizes must be multiples of it")  # fmt: skip
    t.block("U", _names("u", 3), "input", "continuous", 0.0, unit="N m",
            description="control torque (body frame), held over each doStep")  # fmt: skip
    t.block("SIGMA", _names("sigma", 3), "output", "continuous", 0.0, description="attitude (MRP, |sigma| <= 1)")
    t.block("OMEGA", _names("omega", 3), "output", "continuous", 0.0, unit="rad/s", description="body rate")
    return t


def _plant_sources(sources: Path) -> list[str]:
    """Copy the engine's generated C and fsmctl's math; return the files to compile."""
    gen, csrc = generated_dir() / "c", driver_source_dir()
    compiled = []
    for name in _GENERATED:
        for suffix in (".c", ".h"):
            shutil.copyfile(gen / f"{name}{suffix}", sources / f"{name}{suffix}")
        wrapper = sources / f"{name}_fsm.c"
        wrapper.write_text(
            f"/* {name}.c (generated/c, unchanged) with fsmctl's pow, sin and cos, as the engine compiles it */\n"
            f'#include "fsm_pow.h"\n#include "fsm_trig.h"\n#include "{name}.c"\n'
        )
        compiled.append(wrapper.name)
    for name in ("fsm_pow", "fsm_trig"):
        for suffix in (".c", ".h"):
            shutil.copyfile(csrc / f"{name}{suffix}", sources / f"{name}{suffix}")
        compiled.append(f"{name}.c")
    shutil.copyfile(resources.files("fsmctl") / "csrc" / "fmu" / "plant_model.c", sources / "plant_model.c")
    return ["fmu_common.c", "plant_model.c", *compiled]


def write_plant_fmu(
    path: str | Path,
    *,
    dt: float = DEFAULT_PLANT_DT,
    inertia=((100.0, 0.0, 0.0), (0.0, 100.0, 0.0), (0.0, 0.0, 100.0)),
    sigma0=(0.0, 0.0, 0.0),
    omega0=(0.0, 0.0, 0.0),
    disturbance=(0.0,) * 12,
) -> Path:
    """Write an FMI 2.0 co-simulation FMU of one rigid spacecraft (the engine's plant).

    Parameters
    ----------
    path : path
        The ``.fmu`` file (written atomically).
    dt : float
        The default internal RK4 step (s; the FMU parameter ``dt``).
    inertia : 3x3 array
        The default true inertia ``J`` (kg m^2, symmetric positive definite).
    sigma0, omega0 : 3 floats
        The default initial attitude (MRP) and body rate (rad/s).
    disturbance : 12 floats
        The default disturbance parameters, the engine's ``dist_params``: amplitude (N m), frequency (rad/s), phase
        (rad), offset (N m), three each.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    FMUError
        A value out of range, or not on linux64.
    BuildError
        The compiler refused the sources.

    Examples
    --------
    >>> from fmpy import read_model_description
    >>> fmu = write_plant_fmu("plant.fmu", dt=0.001, sigma0=(0.1, 0.2, 0.3))
    >>> md = read_model_description(fmu)
    >>> md.coSimulation.modelIdentifier, [u.variable.name for u in md.outputs][:3]
    ('fsmctl_plant', ['sigma[1]', 'sigma[2]', 'sigma[3]'])
    """
    _check_platform()
    table = _plant_table(_positive("dt", dt), inertia, sigma0, omega0, disturbance)
    cc = compiler_path()
    with tempfile.TemporaryDirectory(prefix="fsmctl-fmu-") as tmp:
        stage = Path(tmp)
        sources = stage / "sources"
        sources.mkdir()
        _copy_common(sources)
        compiled = _plant_sources(sources)
        description = "one rigid spacecraft (fsmctl's plant: generated rigid-body dynamics, disturbance, RK4 at dt)"
        _finish(stage, table, extra={}, name="fsmctl plant", identifier=PLANT_IDENTIFIER, description=description,
                step=10 * float(dt), compiled=compiled)  # fmt: skip
        so = stage / "binaries" / _PLATFORM / f"{PLANT_IDENTIFIER}.so"
        command = [cc, *PLANT_FLAGS, f"-I{sources}", *(str(sources / c) for c in compiled), "-o", str(so), "-lm"]
        run_compiler(command, "the plant FMU's sources")
        return _zip(stage, Path(path))


# ----------------------------------------------------------------------------- the controller


def _law_parameters(t: _Table, law: LawCode) -> list[tuple[int, int]]:
    """The law's parameters as FMU parameters; per packed scalar: (1 if Integer, its value reference)."""
    packing = []
    for parameter in law.parameters:
        names = _names(parameter.name, parameter.size)
        doc = f"{parameter.doc} (range {parameter.range_text()})".strip()
        if parameter.choices:
            options = ", ".join(f"{k}: {c}" for k, c in enumerate(parameter.choices))
            t.block(parameter.name, names, "parameter", "fixed", parameter.default, kind="Integer",
                    description=f"{doc}; {options}", minimum=0, maximum=len(parameter.choices) - 1)  # fmt: skip
            packing += [(1, t.blocks[parameter.name] + k) for k in range(parameter.size)]
            continue
        t.block(parameter.name, names, "parameter", "fixed", parameter.default, unit=parameter.unit or "1",
                description=doc, minimum=parameter.minimum, maximum=parameter.maximum)  # fmt: skip
        packing += [(0, t.blocks[parameter.name] + k) for k in range(parameter.size)]
    return packing


def _wheel_defaults(n_wheels: int) -> tuple[np.ndarray, np.ndarray]:
    """Default spin axes (axis k at [3k, 3k + 2]) and spin inertias: the scenario's default wheels when they are as
    many, else the body axes in turn."""
    wheels = ActuatorSettings(kind="reaction_wheels")
    if wheels.n_wheels == n_wheels:
        axes = np.asarray(wheels.spin_axes(), dtype=float).T.reshape(-1)
        return axes, np.broadcast_to(np.asarray(wheels.spin_inertia, dtype=float), (n_wheels,))
    return np.eye(3)[np.arange(n_wheels) % 3].reshape(-1), np.full(n_wheels, 0.01)


def _controller_table(
    law: LawCode, n_neighbours: int, control_period: float, torque_limit: float
) -> tuple[_Table, list]:
    t = _Table()
    packing = _law_parameters(t, law)
    p = ("parameter", "fixed")
    t.block("J0", _matrix_names("J0", 3, 3), *p, np.eye(3).reshape(-1) * 100.0, unit="kg m^2",
            description="nominal inertia (body frame; symmetric positive definite)")  # fmt: skip
    t.block("TORQUE_LIMIT", ["torque_limit"], *p, torque_limit, unit="N m", minimum=0.0,
            description="per-axis torque limit u_max (> 0; inf: none)")  # fmt: skip
    t.block("CONTROL_PERIOD", ["control_period"], *p, control_period, unit="s", minimum=0.0,
            description="h: each doStep (of control_period * law_state_substeps) is one control instant")  # fmt: skip
    t.block("LAW_STATE_SUBSTEPS", ["law_state_substeps"], *p, 1, kind="Integer", minimum=1,
            description="RK4 steps of control_period the law state advances per doStep (1 on a flight computer)")  # fmt: skip
    if law.n_wheels:
        axes, inertia = _wheel_defaults(law.n_wheels)
        t.block("SPIN_AXES", _matrix_names("spin_axis", law.n_wheels, 3), *p, axes,
                description="wheel k's spin axis (body frame, unit; default: fsmctl's pyramid layout)")  # fmt: skip
        t.block("SPIN_INERTIA", _names("spin_inertia", law.n_wheels), *p, inertia, unit="kg m^2", minimum=0.0)
    i = ("input", "continuous")
    t.block("SIGMA", _names("sigma", 3), *i, 0.0, description="measured attitude (MRP of body relative to inertial)")
    t.block("OMEGA", _names("omega", 3), *i, 0.0, unit="rad/s", description="measured body rate (body frame)")
    t.block("SIGMA_D", _names("sigma_d", 3), *i, 0.0, description="reference attitude (MRP)")
    t.block("OMEGA_D", _names("omega_d", 3), *i, 0.0, unit="rad/s", description="reference rate")
    t.block("OMEGA_D_DOT", _names("omega_d_dot", 3), *i, 0.0, unit="rad/s^2", description="reference acceleration")
    nb, unit = law.n_broadcast, law.broadcast_unit or "1"
    names = [f"neighbour[{j + 1}].broadcast[{k + 1}]" for j in range(n_neighbours) for k in range(nb)]
    t.block("NEIGHBOUR_BROADCAST", names, *i, 0.0, unit=unit, description=f"a neighbour's {law.broadcast_name}")
    t.block("NEIGHBOUR_K_OWN", [f"neighbour[{j + 1}].k_own" for j in range(n_neighbours)], *i, 0.0,
            description="the link's k^i_ij (Liang et al. 2012 eq 19; 0 with k_sender = 0: no link)")  # fmt: skip
    t.block("NEIGHBOUR_K_SENDER", [f"neighbour[{j + 1}].k_sender" for j in range(n_neighbours)], *i, 0.0,
            description="the link's k^j_ij(t) at this instant (0: the link is off)")  # fmt: skip
    if law.n_wheels:
        t.block("WHEEL_SPEED", _names("wheel_speed", law.n_wheels), *i, 0.0, unit="rad/s")
    o = ("output", "discrete")
    t.block("TORQUE", _names("torque", 3), *o, 0.0, unit="N m", description="torque command (limited), held")
    t.block("TORQUE_COMMANDED", _names("torque_commanded", 3), *o, 0.0, unit="N m", description="before the limit")
    t.block("BROADCAST", [f"broadcast[{k + 1}]" for k in range(nb)], *o, 0.0, unit=unit,
            description=f"what this spacecraft sends: {law.broadcast_name}")  # fmt: skip
    t.block("Z", [f"z[{k + 1}]" for k in range(law.n_states)], *o, 0.0,
            description="the law state after the control period")  # fmt: skip
    if law.n_wheels:
        t.block("WHEEL_TORQUE", _names("wheel_torque", law.n_wheels), *o, 0.0, unit="N m")
    return t, packing


def _parameters_header(packing: list[tuple[int, int]]) -> str:
    kinds = ", ".join(str(k) for k, _ in packing) or "0"
    vrs = ", ".join(str(vr) for _, vr in packing) or "0"
    return (
        "/* fmu_parameters.h: where each packed law parameter is (written by fsmctl.export.fmu; do not edit) */\n"
        f"static const int fsmfmu_parameter_integer[] = {{{kinds}}};\n"
        f"static const int fsmfmu_parameter_vr[] = {{{vrs}}};\n"
    )


def write_controller_fmu(
    law: str | Path | LawCode,
    path: str | Path,
    *,
    precision: str = "float64",
    error_model: str = "exact",
    control_period: float = EXPORT_CONTROL_PERIOD,
    n_neighbours: int = DEFAULT_NEIGHBOURS,
    prefix: str | None = None,
    parameters: Mapping[str, object] | None = None,
    torque_limit: float = math.inf,
) -> Path:
    """Write an FMI 2.0 co-simulation FMU of one spacecraft's controller, built from the exported C library.

    Parameters
    ----------
    law : str, path or LawCode
        A built-in law's name, a law folder or script, or a resolved law.
    path : path
        The ``.fmu`` file (written atomically).
    precision : {"float64", "float32"}
        The arithmetic of the exported library (the FMU's variables are doubles either way).
    error_model : {"exact", "paper"}
        The error kinematics of the exported law.
    control_period : float
        The default of the FMU parameter ``control_period`` (s).
    n_neighbours : int
        The neighbour slots (incoming links) the FMU has inputs for (>= 0).
    prefix : str, optional
        The C prefix (default: the law's name); the model identifier is ``<prefix>_controller``.
    parameters : mapping, optional
        Start values that replace the law's declared defaults (:func:`fsmctl.export.with_defaults`).
    torque_limit : float
        The start value of ``torque_limit`` (N m; ``inf``: none).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    FMUError, ExportError
        An option out of range (a law that cannot be exported, a negative neighbour count), not on linux64.
    BuildError
        The compiler refused the sources.

    Examples
    --------
    >>> from fmpy import read_model_description
    >>> fmu = write_controller_fmu("pid", "pid_controller.fmu", n_neighbours=1)
    >>> md = read_model_description(fmu)
    >>> md.coSimulation.modelIdentifier, [u.variable.name for u in md.outputs][:2]
    ('pid_controller', ['torque[1]', 'torque[2]'])
    """
    _check_platform()
    if isinstance(n_neighbours, bool) or not isinstance(n_neighbours, int | np.integer) or n_neighbours < 0:
        raise FMUError(f"n_neighbours: must be an integer >= 0, got {n_neighbours!r}")
    code = with_defaults(law if isinstance(law, LawCode) else resolve_law(law), parameters)
    period = _positive("control_period", control_period)
    if not (torque_limit > 0):
        raise FMUError(f"torque_limit: must be > 0 N m (inf: none), got {torque_limit!r}")
    with tempfile.TemporaryDirectory(prefix="fsmctl-fmu-") as tmp:
        stage = Path(tmp)
        sources = stage / "sources"
        lib = write_c_library(
            code, sources, control_period=period, precision=precision, error_model=error_model, prefix=prefix
        )
        P = lib.prefix
        _copy_common(sources)
        template = (resources.files("fsmctl") / "csrc" / "fmu" / "controller_model.c").read_text()
        (sources / f"{P}_fmu.c").write_text(template.replace("@PU@", P.upper()).replace("@P@", P))
        table, packing = _controller_table(code, int(n_neighbours), period, float(torque_limit))
        (sources / "fmu_parameters.h").write_text(_parameters_header(packing))
        identifier = f"{P}_controller"
        compiled = [s.name for s in lib.sources] + ["fmu_common.c", f"{P}_fmu.c"]
        description = (
            f"one spacecraft's controller: the law '{code.name}' ({precision}, {error_model} error kinematics)"
        )
        _finish(stage, table, extra={"N_NEIGHBOURS": int(n_neighbours), "N_NEIGHBOURS_ALLOC": max(1, n_neighbours)},
                name=f"fsmctl {code.name} controller", identifier=identifier, description=description,
                step=period, compiled=compiled)  # fmt: skip
        so = stage / "binaries" / _PLATFORM / f"{identifier}.so"
        extra = [sources / "fmu_common.c", sources / f"{P}_fmu.c"]
        compile_export(lib, so, extra_flags=["-O2"], extra_sources=extra)
        return _zip(stage, Path(path))
