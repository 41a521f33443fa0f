"""Root pytest configuration: the doctests of ``fsmctl/`` (the API reference's Examples) run here.

``pytest`` collects ``fsmctl/`` with ``--doctest-modules`` (``pyproject.toml``). Each example runs in a fresh
temporary working folder, with the non-interactive matplotlib backend, so examples that write files leave
nothing behind.
"""

from __future__ import annotations

import os

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")

# user-law scripts shipped as data (run by fsmctl derive / the explanations), not modules with examples
collect_ignore_glob = ["fsmctl/studies/explain_laws/*"]


@pytest.fixture(autouse=True)
def _doctest_in_a_temporary_folder(request, tmp_path, monkeypatch):
    """Run each doctest in its own temporary working folder, with NumPy printing plain numbers."""
    if type(request.node).__name__ != "DoctestItem":
        yield
        return
    import numpy as np

    monkeypatch.chdir(tmp_path)
    # NumPy >= 2 prints scalars as np.float64(...); examples show the numbers (legacy 1.25 printing)
    with np.printoptions(legacy="1.25"):
        yield
