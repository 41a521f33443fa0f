"""Shared fixtures: warnings policy and the paper scenario."""

from __future__ import annotations

import os
import warnings

import pytest
from hypothesis import settings

# Property tests draw the same examples on every machine and every run (no random seed, no example database
# carried between runs): what a fresh clone runs is what CI ran.  Explicit @settings keep this unless they say
# otherwise (they inherit from the loaded profile).  No deadline: the first example of a property test may load or
# compile generated code (seconds on a fresh machine's empty cache), which says nothing about the property.
settings.register_profile("fsmctl", derandomize=True, database=None, deadline=None)
settings.load_profile("fsmctl")

# The paper's J0_4 is a flat plate within rounding; nothing else should warn in tests.
warnings.filterwarnings("ignore", message=".*triangle inequality.*")
os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture(scope="session")
def paper_case1():
    from fsmctl import paper_scenario

    return paper_scenario("1")
