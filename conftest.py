"""Root pytest configuration: the doctests of ``fsmctl/`` (the API reference's Examples) run here.

``pytest`` collects ``fsmctl/`` with ``--doctest-modules`` (``pyproject.toml``). Each example runs in a fresh
temporary working folder, with the non-interactive matplotlib backend, so examples that write files leave
nothing behind.
"""

from __future__ import annotations

import copy
import functools
import os
from pathlib import Path

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


@functools.cache
def _one_second_runs() -> dict:
    """The reproduction plan's runs flown for 1 s each, once per session (several examples read them)."""
    from fsmctl import simulate
    from fsmctl.studies.paper_runs import run_plan, run_record, run_scenario

    def one_second(spec):
        scenario = run_scenario("paper", spec, fast=True).replace(simulation={"t_final": 1.0})
        return run_record(spec, scenario, simulate(scenario, progress=False))

    return {spec.key: one_second(spec) for spec in run_plan()}


def one_second_records() -> dict:
    """A copy of the plan's 1 s runs (an example may change its records)."""
    return copy.deepcopy(_one_second_runs())


def one_second_reproduction():
    """The :class:`fsmctl.studies.report.Reproduction` of the 1 s runs, writing into ``./out`` (the class's own
    Example assembles it step by step)."""
    from pathlib import Path

    from fsmctl import paper_scenario
    from fsmctl.studies.claims import evaluate_claims
    from fsmctl.studies.momentum import angular_momentum_bound
    from fsmctl.studies.report import Reproduction

    records = one_second_records()
    bounds = angular_momentum_bound(paper_scenario("1"))
    claims = evaluate_claims(records, bounds)
    return Reproduction(
        Path("out"), True, ["paper case 1"], records, bounds, claims, inertia_check=[], files=[], wall_time_s=0.0
    )


@pytest.fixture(scope="session", autouse=True)
def _shared_doctest_setup(doctest_namespace):
    """Names the Examples of several modules share (their setup is written once, here)."""
    doctest_namespace["one_second_records"] = one_second_records
    doctest_namespace["one_second_reproduction"] = one_second_reproduction
    # the documented example laws and scenarios (docs/examples/): Examples that certify or fly them name files there
    doctest_namespace["EXAMPLES"] = Path(__file__).resolve().parent / "docs" / "examples"
