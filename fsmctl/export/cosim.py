"""The co-simulation master: a plant FMU and a controller FMU of :mod:`fsmctl.export.fmu` flown together with FMPy.

:func:`cosimulate` steps both ``FMU2Slave`` instances at a fixed communication step: the plant's outputs to the
controller, its ``doStep``, its torque to the plant, the plant's ``doStep`` (the engine's zero-order hold).  FMPy is
the extra ``fmu`` (``pip install 'fsmctl[fmu]'``): only running FMUs needs it.
"""

from __future__ import annotations

import importlib
import shutil
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fsmctl.errors import EnvironmentProblem
from fsmctl.export.fmu import GRID_TOLERANCE, FMUError, _positive

__all__ = ["CoSimulation", "CoSimulationError", "cosimulate"]


class CoSimulationError(FMUError):
    """An FMU refused a call during :func:`cosimulate` (the message carries the FMU's own one-line reason).

    Examples
    --------
    >>> from fsmctl.export import write_controller_fmu, write_plant_fmu
    >>> plant = write_plant_fmu("plant.fmu")
    >>> controller = write_controller_fmu("pid", "pid.fmu", error_model="paper")
    >>> try:
    ...     cosimulate(plant, controller, t_final=0.1, step=0.01, controller_parameters={"K": -1.0})
    ... except CoSimulationError as exc:
    ...     print("refused")
    refused
    """


@dataclass(frozen=True)
class CoSimulation:
    """What :func:`cosimulate` recorded.

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.export import write_controller_fmu, write_plant_fmu
    >>> run = cosimulate(write_plant_fmu("plant.fmu"), write_controller_fmu("pid", "pid.fmu", error_model="paper"),
    ...                  t_final=0.05, step=0.01, controller_parameters={"J0": 100 * np.eye(3)})
    >>> run.time.shape, run.torque.shape
    ((6,), (5, 3))

    Parameters
    ----------
    time : (n + 1,) array
        The communication points (s).
    sigma, omega : (n + 1, 3) arrays
        The plant's outputs there.
    torque : (n, 3) array
        The controller's torque, applied over ``[time[i], time[i + 1]]`` (N m).
    broadcast : (n, nb) array
        What the controller sent at ``time[i]``.
    z : (n, nz) array
        The law state after each control period.
    """

    time: np.ndarray
    sigma: np.ndarray
    omega: np.ndarray
    torque: np.ndarray
    broadcast: np.ndarray
    z: np.ndarray


def _fmpy():
    """FMPy (the extra ``fmu``): only running FMUs needs it, writing them does not."""
    try:
        fmpy = importlib.import_module("fmpy")
        for sub in ("fmpy.fmi2", "fmpy.logging"):  # attributes of fmpy once imported
            importlib.import_module(sub)
    except ImportError:
        raise EnvironmentProblem(
            "running an FMU needs FMPy, which is not installed: pip install 'fsmctl[fmu]' (writing FMUs does not)"
        ) from None
    return fmpy


class _Log:
    """The FMUs' log messages by instance name (FMPy's native formatting proxy keeps one logger per process, so
    every FMU of a co-simulation shares this one)."""

    def __init__(self) -> None:
        fmpy = _fmpy()
        fmi2 = fmpy.fmi2
        self.messages: dict[str, list[str]] = {}

        def log(env, name, status, category, message) -> None:
            self.messages.setdefault(name.decode(), []).append(message.decode("utf-8", "replace"))

        self.callbacks = fmi2.fmi2CallbackFunctions()
        self.callbacks.logger = fmi2.fmi2CallbackLoggerTYPE(log)
        self.callbacks.allocateMemory = fmi2.fmi2CallbackAllocateMemoryTYPE(fmpy.calloc)
        self.callbacks.freeMemory = fmi2.fmi2CallbackFreeMemoryTYPE(fmpy.free)
        fmpy.logging.addLoggerProxy(fmpy.byref(self.callbacks))


class _Slave:
    """One FMU instance through FMPy, its variables by (structured) name; errors carry the FMU's logged reason."""

    def __init__(self, fmu: str | Path, instance: str, log: _Log) -> None:
        self.path = Path(fmu)
        if not self.path.is_file():
            raise FMUError(f"{self.path}: no such FMU")
        fmpy = _fmpy()
        self.md = fmpy.read_model_description(str(self.path))
        self.folder = fmpy.extract(str(self.path))
        self.instance, self.log = instance, log
        self.vr = {v.name: (v.valueReference, v.type) for v in self.md.modelVariables}
        self.fmu = fmpy.fmi2.FMU2Slave(
            guid=self.md.guid,
            unzipDirectory=self.folder,
            modelIdentifier=self.md.coSimulation.modelIdentifier,
            instanceName=instance,
        )
        self.call("instantiate", callbacks=log.callbacks)

    def call(self, method: str, *args, **kwargs):
        try:
            return getattr(self.fmu, method)(*args, **kwargs)
        except Exception as exc:  # FMPy raises Exception and FMICallException
            messages = self.log.messages.get(self.instance)
            reason = messages[-1] if messages else str(exc)
            raise CoSimulationError(f"{self.path.name}: {method} failed: {reason}") from None

    def refs(self, name: str) -> tuple[list[int], str]:
        """The value references of ``name`` (a scalar) or of ``name[...]`` (a vector or matrix, in order)."""
        if name in self.vr:
            return [self.vr[name][0]], self.vr[name][1]
        rows = [(vr, kind) for n, (vr, kind) in self.vr.items() if n.startswith(name + "[")]
        if not rows:
            raise FMUError(f"{self.path.name} has no variable {name!r}")
        return [vr for vr, _ in rows], rows[0][1]

    def set(self, name: str, value) -> None:
        refs, kind = self.refs(name)
        try:
            values = np.asarray(value, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            what = "an option's index (an Integer)" if kind == "Integer" else "numbers"
            raise FMUError(f"{name}: {self.path.name} takes {what}, got {value!r}") from None
        if values.size != len(refs):
            raise FMUError(f"{name}: {self.path.name} takes {len(refs)} values, got {values.size}")
        if kind == "Integer":
            self.call("setInteger", refs, [int(v) for v in values])
        else:
            self.call("setReal", refs, [float(v) for v in values])

    def get(self, name: str) -> np.ndarray:
        refs, _ = self.refs(name)
        return np.asarray(self.call("getReal", refs), dtype=float) if refs else np.zeros(0)

    def close(self) -> None:
        try:
            self.fmu.terminate()
            self.fmu.freeInstance()
        except Exception:  # closing after a failure: the first error is the one reported
            pass
        shutil.rmtree(self.folder, ignore_errors=True)


def _start(slave: _Slave, t_start: float, parameters: Mapping[str, object]) -> None:
    slave.call("setupExperiment", startTime=t_start)
    for name, value in parameters.items():
        slave.set(name, value)
    slave.call("enterInitializationMode")
    slave.call("exitInitializationMode")


def _steps(t_final: float, step: float, t_start: float) -> int:
    step = _positive("step", step)
    span = float(t_final) - float(t_start)
    n = round(span / step)
    if n < 1 or abs(n * step - span) > GRID_TOLERANCE * step:
        raise FMUError(f"t_final - t_start = {span:g} s must be a positive multiple of step = {step:g} s")
    return n


def cosimulate(
    plant_fmu: str | Path,
    controller_fmu: str | Path,
    *,
    t_final: float,
    step: float,
    t_start: float = 0.0,
    plant_parameters: Mapping[str, object] | None = None,
    controller_parameters: Mapping[str, object] | None = None,
    reference: Mapping[str, object] | None = None,
) -> CoSimulation:
    """Fly one spacecraft: the plant FMU and a controller FMU, stepped together at a fixed communication step.

    At each communication point ``t``: the plant's ``sigma``, ``omega`` (and the constant ``reference``) are the
    controller's inputs, the controller's ``doStep(t, step)`` commands the torque held over ``[t, t + step]``, the
    plant's ``doStep(t, step)`` flies it.  This is the engine's zero-order hold at the control period ``step``.

    Parameters
    ----------
    plant_fmu, controller_fmu : path
        From :func:`write_plant_fmu` and :func:`write_controller_fmu`.
    t_final, step, t_start : float
        The flight (s): ``t_final - t_start`` a multiple of ``step``; ``step`` must be the controller's
        ``control_period * law_state_substeps`` and a multiple of the plant's ``dt``.
    plant_parameters, controller_parameters : mapping, optional
        FMU parameters by name; a vector or matrix by its base name (``"J"``, ``"sigma0"``, ``"delta"``).
    reference : mapping, optional
        Constant controller inputs ``sigma_d``, ``omega_d``, ``omega_d_dot`` (default: at rest at the origin).

    Returns
    -------
    CoSimulation
        The recorded flight.

    Raises
    ------
    FMUError
        A bad option (unknown variable, wrong size, a flight that is not a multiple of the step).
    CoSimulationError
        An FMU refused a call (its own one-line reason).

    Examples
    --------
    >>> from fsmctl.export import write_controller_fmu, write_plant_fmu
    >>> plant = write_plant_fmu("plant.fmu", sigma0=(0.1, 0.0, 0.0))
    >>> controller = write_controller_fmu("pid", "pid.fmu", n_neighbours=0, control_period=0.01)
    >>> run = cosimulate(plant, controller, t_final=1.0, step=0.01, controller_parameters={"J0": 100 * np.eye(3)})
    >>> run.sigma.shape, bool(abs(run.sigma[-1, 0]) < 0.1)
    ((101, 3), True)
    """
    n = _steps(t_final, step, t_start)
    step, t_start = float(step), float(t_start)
    reference = {"sigma_d": np.zeros(3), "omega_d": np.zeros(3), "omega_d_dot": np.zeros(3), **(reference or {})}
    plant = controller = None
    try:
        log = _Log()
        plant = _Slave(plant_fmu, "plant", log)
        controller = _Slave(controller_fmu, "controller", log)
        _start(plant, t_start, plant_parameters or {})
        _start(controller, t_start, controller_parameters or {})
        for name, value in reference.items():
            controller.set(name, value)
        nb, nz = (sum(n.startswith(f"{k}[") for n in controller.vr) for k in ("broadcast", "z"))
        record = {k: np.empty((n + 1, 3)) for k in ("sigma", "omega")}
        torque, broadcast, z = np.empty((n, 3)), np.empty((n, nb)), np.empty((n, nz))
        time = t_start + step * np.arange(n + 1)
        for i in range(n + 1):
            record["sigma"][i], record["omega"][i] = plant.get("sigma"), plant.get("omega")
            if i == n:
                break
            controller.set("sigma", record["sigma"][i])
            controller.set("omega", record["omega"][i])
            controller.call("doStep", time[i], step)
            torque[i], broadcast[i] = controller.get("torque"), controller.get("broadcast")
            z[i] = controller.get("z") if nz else z[i]
            plant.set("u", torque[i])
            plant.call("doStep", time[i], step)
    finally:
        for slave in (controller, plant):
            if slave is not None:
                slave.close()
    return CoSimulation(time, record["sigma"], record["omega"], torque, broadcast, z)
