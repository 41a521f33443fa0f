"""The symbolic layer: the model, the paper's law and the law API, in pure SymPy (no NumPy, no I/O).

This is what derivation scripts import (``from fsmctl.symbolic.law import LawBuilder``) and what
``derive/`` builds ``generated/`` from.  The most used names are re-exported here; the errata and the
proved identities are in :mod:`fsmctl.proofs`.  Importing this package imports SymPy (the simulator and the
command line do not need it).
"""

from __future__ import annotations

from fsmctl.symbolic.controller import SingularityFix, closed_loop_acceleration, control_law_pieces, sliding_variable
from fsmctl.symbolic.law import LawBuilder
from fsmctl.symbolic.model import ErrorModel, lagrange_model
from fsmctl.symbolic.mrp import mrp_G, mrp_G_inverse
from fsmctl.symbolic.symbols import vector_symbols
from fsmctl.symbolic.theorem3 import settling_time_closed_forms

__all__ = [
    "SingularityFix",
    "closed_loop_acceleration",
    "control_law_pieces",
    "LawBuilder",
    "ErrorModel",
    "lagrange_model",
    "mrp_G",
    "mrp_G_inverse",
    "settling_time_closed_forms",
    "sliding_variable",
    "vector_symbols",
]
