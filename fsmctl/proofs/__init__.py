"""Proof check of Liang, Sun & Wang (2012), Section 3, and of any law's declared claims: ``fsmctl prove``.

* the paper's claims (Lemmas 1-2, eqs 7-41, Theorems 1-3, Remarks 4 and 6): :func:`run_claims` with a
  :class:`ProofContext`, the ids :func:`claim_ids`, the registry :data:`CLAIMS`, the :data:`VERDICTS`, each
  outcome a :class:`ClaimResult`; reports :func:`format_table` and :func:`write_report`;
* the errata of the printed paper, each confirmed symbolically: :func:`all_errata` (every one: those of the
  proofs, :func:`errata`, then those of the re-audit against the printed text), :class:`Erratum`;
* Theorem 1 on a concrete time-varying topology (eqs 25-27): :func:`analyze_topology`, :func:`eta_interval`;
* Theorem 2's switching gain (eqs 29-33): :func:`delta_requirements` over a :class:`Region`;
* any law written with :class:`fsmctl.symbolic.LawBuilder` (``fsmctl prove --law``): :func:`check_law`,
  which returns a :class:`LawReport`;
* a rigorous Lyapunov certificate of a law over a :class:`StateRegion` with an :class:`Uncertainty`
  (``fsmctl certify``): :func:`certify_law` (its budget :class:`SearchSettings`), which returns a
  :class:`Certificate`, re-checked from its file by :func:`check_certificate` (a :class:`CertificateCheck`; a
  file that is not a certificate raises :class:`CertificateError`).

The modules :mod:`~fsmctl.proofs.identities` (the model identities ``python -m derive`` proves) and
:mod:`~fsmctl.proofs.seed_audit` (the re-audit against the printed text) are documented in place.  Names load
on first use (SPEC 1 lazy loading), so ``import fsmctl.proofs`` stays light.
"""

from __future__ import annotations

import lazy_loader

_ATTRS = {
    "claims": ["CLAIMS", "VERDICTS", "ClaimResult", "ProofContext", "claim_ids", "run_claims"],
    "report": ["format_table", "write_report"],
    "errata": ["Erratum", "all_errata", "errata"],
    "theorem1": ["analyze_topology", "eta_interval"],
    "theorem2": ["Region", "delta_requirements"],
    "law_check": ["check_law", "LawReport"],
    "certificate": ["certify_law", "check_certificate", "Certificate", "CertificateCheck", "CertificateError"],
    "certify_problem": ["StateRegion", "Uncertainty"],
    "certify": ["SearchSettings"],
}

__all__ = [name for names in _ATTRS.values() for name in names]

__getattr__, _lazy_dir, _lazy_all = lazy_loader.attach(__name__, submod_attrs=_ATTRS)


def __dir__() -> list[str]:
    """The public names, loaded or not (for tab completion and ``dir(fsmctl.proofs)``)."""
    return sorted(set(__all__) | set(_lazy_all))
