"""Export: a law to a flight computer (strict C99), to other simulators (FMI), results to CCSDS messages.

A layer between :mod:`fsmctl.studies` and the engine (:mod:`fsmctl.simulation`): it reads laws (:mod:`fsmctl.model`),
prints their CasADi graphs as C99 (:mod:`fsmctl.codegen.c99`) and flies the engine with the exported code in the loop.

* :func:`write_c_library`, :func:`read_c_library`, :class:`CLibrary`: one spacecraft's controller as a strict C99
  library (``fsmctl export --target c``);
* :func:`compile_export`: the export compiled at its strict flags;
* :func:`verify_export`, :class:`ExportCheck`: software in the loop (``fsmctl export --verify``);
* :func:`write_controller_fmu`, :func:`write_plant_fmu`, :func:`cosimulate`: FMI 2.0 co-simulation FMUs of the
  controller (the same C) and of the plant (the engine's generated C), flown together with FMPy
  (``fsmctl export --target fmu``);
* :func:`write_aem`, :func:`read_aem`, :class:`AttitudeEphemeris`: attitude histories as CCSDS Attitude Ephemeris
  Messages (``fsmctl export --target aem``).

Names load on first use (SPEC 1 lazy loading).
"""

from __future__ import annotations

import lazy_loader

_ATTRS = {
    "c_library": [
        "ERROR_MODELS",
        "EXPORT_FORMAT",
        "PRECISIONS",
        "CLibrary",
        "ExportError",
        "read_c_library",
        "with_defaults",
        "strict_flags",
        "write_c_library",
    ],
    "build": ["BuildError", "compile_export"],
    "sil": ["ExportCheck", "sil_scenario", "verify_export"],
    "cosim": ["CoSimulation", "CoSimulationError", "cosimulate"],
    "fmu": [
        "FMUError",
        "write_controller_fmu",
        "write_plant_fmu",
        "DEFAULT_NEIGHBOURS",
        "DEFAULT_PLANT_DT",
        "GRID_TOLERANCE",
        "PLANT_FLAGS",
    ],
    "aem": [
        "AemError",
        "AttitudeEphemeris",
        "EmptyResultError",
        "NotAnAemError",
        "UnknownAgentError",
        "aem_quaternions",
        "mrp_from_aem_quaternions",
        "read_aem",
        "write_aem",
    ],
}

__all__ = [name for names in _ATTRS.values() for name in names]

__getattr__, _lazy_dir, _lazy_all = lazy_loader.attach(__name__, submod_attrs=_ATTRS)


def __dir__() -> list[str]:
    """The public names, loaded or not (for tab completion and ``dir(fsmctl.export)``)."""
    return sorted(set(__all__) | set(_lazy_all))
