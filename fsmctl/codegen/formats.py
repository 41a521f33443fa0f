"""The file names and format numbers of a generated folder, in one light module (no CasADi, no SymPy).

The writers (:func:`fsmctl.codegen.writer.write_generated`, :func:`fsmctl.codegen.laws.write_law`) write these
numbers; the readers (:mod:`fsmctl.model.laws`) refuse a folder whose number is another, so that a folder written
by an older or newer fsmctl is a clear error rather than a law flown with fields read wrongly.

Examples
--------
>>> from fsmctl.codegen.formats import LAW_FILE, LAW_FORMAT, MANIFEST_FILE, MANIFEST_FORMAT
>>> LAW_FILE, MANIFEST_FILE, LAW_FORMAT >= 1, MANIFEST_FORMAT >= 1
('law.json', 'manifest.json', True, True)
"""

from __future__ import annotations

__all__ = ["LAW_FILE", "LAW_FORMAT", "MANIFEST_FILE", "MANIFEST_FORMAT"]

MANIFEST_FILE = "manifest.json"
"""the manifest of a generated folder: versions, functions, the sha256 of every other file"""
MANIFEST_FORMAT = 1
"""the format number of ``manifest.json`` this fsmctl writes and reads"""
LAW_FILE = "law.json"
"""a law folder's description: parameters, states, broadcast, cache and declarations"""
LAW_FORMAT = 1
"""the format number of ``law.json`` this fsmctl writes and reads"""
