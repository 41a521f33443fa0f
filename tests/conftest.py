"""Shared fixtures: warnings policy and the paper scenario."""

from __future__ import annotations

import os
import warnings

import pytest

# The paper's J0_4 is a flat plate within rounding; nothing else should warn in tests.
warnings.filterwarnings("ignore", message=".*triangle inequality.*")
os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture(scope="session")
def paper_case1():
    from fsmctl import paper_scenario

    return paper_scenario("1")
