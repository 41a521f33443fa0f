"""Proof check of Liang, Sun & Wang (2012), Section 3: the engine behind ``fsmctl prove``.

* :mod:`fsmctl.proofs.claims`: the registry of claims and their symbolic checks;
* :mod:`fsmctl.proofs.theorem1`: Theorem 1's gain/eta conditions for a concrete, time-varying topology;
* :mod:`fsmctl.proofs.theorem2`: the exact uncertainty of Theorem 2 and the delta a scenario needs;
* :mod:`fsmctl.proofs.report`: text table, JSON and Markdown/LaTeX report;
* :mod:`fsmctl.cli.prove`: the ``fsmctl prove`` subcommand.
"""

from __future__ import annotations

from fsmctl.proofs.claims import CLAIMS, VERDICTS, ClaimResult, ProofContext, claim_ids, run_claims

__all__ = ["CLAIMS", "VERDICTS", "ClaimResult", "ProofContext", "claim_ids", "run_claims"]
