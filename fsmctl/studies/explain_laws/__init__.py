"""Derivation scripts of the law variants that ``fsmctl reproduce``'s explanations fly (:mod:`fsmctl.studies.explain`).

They are data, not imported by fsmctl: a scenario names one by path (``[controller] law = ".../fsm_unswitched.py"``)
and :func:`fsmctl.model.laws.resolve_law` derives it on first use into the law cache.

``fsm_unswitched.py``
    the paper's FSM law with the error MRP not switched to the shadow set (``SHADOW_SWITCH = False``).
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["UNSWITCHED_LAW", "law_script"]

UNSWITCHED_LAW = "fsm_unswitched.py"


def law_script(name: str = UNSWITCHED_LAW) -> Path:
    """The absolute path of one of the derivation scripts in this folder.

    Parameters
    ----------
    name : str
        File name (``"fsm_unswitched.py"``).

    Returns
    -------
    Path
        The script (it exists).
    """
    path = Path(__file__).resolve().parent / name
    if not path.is_file():
        raise FileNotFoundError(path)
    return path
