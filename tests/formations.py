"""Scenario helpers shared by the simulator tests (not a test module)."""

from __future__ import annotations

import dataclasses


def with_agents(scenario, agents, topology=None, **sections):
    """A validated scenario with other agents (and, for a different count, another topology)."""
    s = dataclasses.replace(scenario, agents=tuple(agents), topology=topology or scenario.topology)
    return s.replace(**sections) if sections else s
