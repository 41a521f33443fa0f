"""The symbolic model, re-exported from :mod:`derive` (the single SymPy source) for users and notebooks.

``from fsmctl.symbolic import lagrange_model, mrp_G, errata`` gives the same objects as the
``derive`` package that writes ``generated/``; nothing is re-derived here.  Importing this module
imports SymPy (the simulator and the CLI do not need it).
"""

from __future__ import annotations

from fsmctl.symbolic.controller import SingularityFix, closed_loop_acceleration, control_law_pieces, sliding_variable
from fsmctl.proofs.errata import errata
from fsmctl.symbolic.model import lagrange_model
from fsmctl.symbolic.mrp import mrp_G, mrp_G_inverse
from fsmctl.symbolic.symbols import vector_symbols
from fsmctl.symbolic.theorem3 import settling_time_closed_forms

__all__ = [
    "SingularityFix",
    "closed_loop_acceleration",
    "control_law_pieces",
    "errata",
    "lagrange_model",
    "mrp_G",
    "mrp_G_inverse",
    "settling_time_closed_forms",
    "sliding_variable",
    "vector_symbols",
]
