"""The file names and format numbers of a generated folder, in one light module (no CasADi, no SymPy).

The writers (:func:`fsmctl.codegen.writer.write_generated`, :func:`fsmctl.codegen.laws.write_law`) write these
numbers; the readers (:mod:`fsmctl.model.laws`) refuse a folder whose number is another, so that a folder written
by an older or newer fsmctl is a clear error rather than a law flown with fields read wrongly.

Examples
--------
>>> from fsmctl.codegen.formats import LAW_FILE, LAW_FORMAT, MANIFEST_FILE, MANIFEST_FORMAT
>>> LAW_FILE, MANIFEST_FILE, LAW_FORMAT >= 1, MANIFEST_FORMAT >= 1
('law.json', 'manifest.json', True, True)
>>> law_format({"name": "fsm"}), law_format({"name": "fsm_wheels", "wheels": {"count": 4}})
(1, 2)
"""

from __future__ import annotations

__all__ = ["LAW_FILE", "LAW_FORMAT", "LAW_FORMAT_OLDEST", "MANIFEST_FILE", "MANIFEST_FORMAT", "law_format"]

MANIFEST_FILE = "manifest.json"
"""the manifest of a generated folder: versions, functions, the sha256 of every other file"""
MANIFEST_FORMAT = 1
"""the format number of ``manifest.json`` this fsmctl writes and reads"""
LAW_FILE = "law.json"
"""a law folder's description: parameters, states, broadcast, cache and declarations"""
LAW_FORMAT = 2
"""the newest format number of ``law.json`` this fsmctl writes and reads (2: the law commands its reaction wheels)"""
LAW_FORMAT_OLDEST = 1
"""the oldest format number of ``law.json`` this fsmctl reads (1: a law without wheel outputs)"""


def law_format(metadata: dict) -> int:
    """The format number a law folder is written with: the oldest that describes the law.

    A law without wheel outputs or a trigger is format 1 (its folder is unchanged since before either existed, and
    readable by an fsmctl that knows nothing of them); a law that commands its wheels or declares a trigger is
    format 2, which an older fsmctl refuses instead of flying the minimum-norm distribution of its body torque in
    place of its wheel commands, or broadcasting at every control evaluation in place of its trigger.

    Parameters
    ----------
    metadata : dict
        The law's description (:meth:`fsmctl.symbolic.law.Law.metadata`).

    Returns
    -------
    int
        1 or 2.
    """
    return 2 if metadata.get("wheels") is not None or metadata.get("trigger") is not None else 1
