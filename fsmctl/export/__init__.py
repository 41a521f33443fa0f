"""Export: a law to a flight computer (strict C99), to other simulators (FMI), results to CCSDS messages.

A layer between :mod:`fsmctl.studies` and the engine (:mod:`fsmctl.simulation`): it reads laws
(:mod:`fsmctl.model`), prints their CasADi graphs (:mod:`fsmctl.codegen.c99`) and flies the engine with the exported
code in the loop.
"""

from fsmctl.export.c_library import (
    ERROR_MODELS,
    EXPORT_FORMAT,
    PRECISIONS,
    CLibrary,
    ExportError,
    strict_flags,
    write_c_library,
)

__all__ = [
    "ERROR_MODELS",
    "EXPORT_FORMAT",
    "PRECISIONS",
    "CLibrary",
    "ExportError",
    "strict_flags",
    "write_c_library",
]
