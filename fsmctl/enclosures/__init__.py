"""Rigorous enclosures: interval and ball arithmetic over CasADi graphs, and a branch and bound on them.

:mod:`fsmctl.enclosures.intervals` evaluates a CasADi ``SX`` function on boxes with outward rounding (NumPy,
many boxes at once) or in ball arithmetic (python-flint's ``arb``); :mod:`fsmctl.enclosures.branch_bound` proves
a sign or bounds a maximum over a box by splitting it.  Used by ``fsmctl certify`` and by Theorem 2's certified
bound in ``fsmctl prove``.
"""
