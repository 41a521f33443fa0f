"""The symbolic layer: the model, the paper's law and the law API, in pure SymPy (no NumPy, no I/O).

This is what derivation scripts import (``from fsmctl.symbolic import LawBuilder``, or the module path
``fsmctl.symbolic.law``) and what ``derive/`` builds ``generated/`` from.  The public API (Liang, Sun & Wang
2012 in the paper's symbols):

* writing a law: :class:`LawBuilder` (the per-agent contract), :class:`Law`, :class:`ErrorState`,
  :class:`LawDefinitionError`, :func:`fast_sliding_surface` (the paper's surface, eq 13, inside a law);
* the model: :func:`mrp_G` (eq 5), :func:`mrp_G_inverse`, :func:`mrp_kinematics` (eq 3), :func:`mrp_error`
  (Sec. 2.2), :func:`mrp_to_dcm`, :func:`skew` (eq 6), :func:`lagrange_model` (eq 9);
* the paper's law: :func:`sliding_variable` (eq 13), :func:`control_law_pieces` (eqs 16-19),
  :func:`closed_loop_acceleration` (eq 20), :func:`saturate`, :func:`settling_time_closed_forms`
  (Theorem 3, eqs 34-36);
* symbols and generated functions: :func:`vector_symbols`, :func:`symmetric_matrix_symbols`,
  :class:`FunctionSpec` (what :mod:`fsmctl.codegen` translates).

Error models and Remark 6's devices are passed as strings (``"paper"``/``"exact"``;
``"none"``/``"switch"``/``"clamp"``); the enums :class:`fsmctl.symbolic.model.ErrorModel` and
:class:`fsmctl.symbolic.controller.SingularityFix` are documented in place.  The errata and the proved
identities are in :mod:`fsmctl.proofs`.  Names load on first use (SPEC 1 lazy loading), so
``import fsmctl.symbolic`` stays light; using any of them imports SymPy (the simulator and the command line
do not need it).
"""

from __future__ import annotations

import lazy_loader

_ATTRS = {
    "law": ["LawBuilder", "Law", "ErrorState", "LawDefinitionError"],
    "surfaces": ["fast_sliding_surface"],
    "functions": ["FunctionSpec"],
    # ErrorModel and SingularityFix stay importable from here (notebook 01 does) but are not in __all__:
    # every function takes their strings, and the enums are documented in their modules
    "model": ["lagrange_model", "ErrorModel"],
    "mrp": ["mrp_G", "mrp_G_inverse", "mrp_error", "mrp_kinematics", "mrp_to_dcm", "skew"],
    "controller": [
        "SingularityFix",
        "sliding_variable",
        "control_law_pieces",
        "closed_loop_acceleration",
        "saturate",
    ],
    "theorem3": ["settling_time_closed_forms"],
    "symbols": ["vector_symbols", "symmetric_matrix_symbols"],
}

__all__ = [name for names in _ATTRS.values() for name in names if name not in ("ErrorModel", "SingularityFix")]

__getattr__, _lazy_dir, _lazy_all = lazy_loader.attach(__name__, submod_attrs=_ATTRS)


def __dir__() -> list[str]:
    """The public names, loaded or not (for tab completion and ``dir(fsmctl.symbolic)``)."""
    return sorted(set(__all__) | set(_lazy_all))
