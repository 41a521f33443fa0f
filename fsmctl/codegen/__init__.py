"""The code-generation layer: SymPy -> CasADi -> C, the generated folders and their manifests.

* :func:`to_casadi_function`: an exact translation of SymPy matrices into a CasADi ``Function``;
* :func:`build_functions`, :class:`GeneratedFunction`, :func:`write_generated`, :func:`check_generated`: the
  generator of the project's ``generated/`` (``python -m derive``) and of every law folder;
* :func:`load_derivation_script`, :func:`law_functions`, :func:`write_law`, :func:`check_law`: a control law's
  folder, what ``fsmctl derive FILE.py`` (and ``--check``) runs.

* :func:`c99_function`: a CasADi graph as library-free strict C99 (what ``fsmctl export`` prints).

The lane-batched SIMD kernels (:mod:`fsmctl.codegen.batched`) are written by the same generator.  Names load
on first use (SPEC 1 lazy loading): ``import fsmctl.codegen`` does not import CasADi or SymPy.
"""

from __future__ import annotations

import lazy_loader

_ATTRS = {
    "casadi_bridge": ["to_casadi_function"],
    "writer": ["GeneratedFunction", "build_functions", "write_generated", "check_generated"],
    "laws": ["load_derivation_script", "law_functions", "write_law", "check_law"],
    "c99": ["c99_function"],
}

__all__ = [name for names in _ATTRS.values() for name in names]

__getattr__, _lazy_dir, _lazy_all = lazy_loader.attach(__name__, submod_attrs=_ATTRS)


def __dir__() -> list[str]:
    """The public names, loaded or not (for tab completion and ``dir(fsmctl.codegen)``)."""
    return sorted(set(__all__) | set(_lazy_all))
