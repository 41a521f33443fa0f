"""Export: a law to a flight computer (strict C99), to other simulators (FMI), results to CCSDS messages.

A layer between :mod:`fsmctl.studies` and the engine (:mod:`fsmctl.simulation`): it reads laws
(:mod:`fsmctl.model`), prints their CasADi graphs (:mod:`fsmctl.codegen.c99`) and flies the engine with the exported
code in the loop.
"""

from fsmctl.export.build import BuildError, compile_export
from fsmctl.export.c_library import (
    ERROR_MODELS,
    EXPORT_FORMAT,
    PRECISIONS,
    CLibrary,
    ExportError,
    read_c_library,
    strict_flags,
    write_c_library,
)
from fsmctl.export.sil import ExportCheck, verify_export

__all__ = [
    "ERROR_MODELS",
    "EXPORT_FORMAT",
    "PRECISIONS",
    "CLibrary",
    "ExportError",
    "strict_flags",
    "write_c_library",
    "read_c_library",
    "BuildError",
    "compile_export",
    "ExportCheck",
    "verify_export",
]
