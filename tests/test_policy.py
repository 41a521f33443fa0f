"""fsmctl.policy: the default worker count and the steady window, against independent oracles.

The worker count is the CPUs this process may run on (``os.sched_getaffinity`` on Linux, a container's or a batch
scheduler's CPU set), capped by the tasks; the steady window is the last 40 % of the horizon, at most 40 s (the
paper's last 40 s of its 100 s horizon, Liang, Sun & Wang 2012, Section 4).
"""

from __future__ import annotations

import os
import sys

import pytest

from fsmctl import policy


@pytest.mark.skipif(not hasattr(os, "sched_getaffinity"), reason="CPU affinity is a Linux call")
def test_default_workers_is_the_cpus_this_process_may_use():
    assert policy.default_workers() == len(os.sched_getaffinity(0))


def test_default_workers_follows_a_restricted_cpu_set_and_caps_by_tasks(monkeypatch):
    """A process pinned to 3 of the machine's CPUs (taskset, a container) gets 3 workers, never more than tasks."""
    if sys.version_info >= (3, 13):
        monkeypatch.setattr(os, "process_cpu_count", lambda: 3)
    else:
        monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 5, 9}, raising=False)
    monkeypatch.setattr(os, "cpu_count", lambda: 64)
    assert policy.default_workers() == 3
    assert [policy.default_workers(tasks=n) for n in (1, 2, 3, 10)] == [1, 2, 3, 3]
    assert policy.default_workers(tasks=0) == 1  # at least one worker


@pytest.mark.parametrize(("horizon", "window"), [(100.0, 40.0), (10.0, 4.0), (300.0, 40.0), (0.5, 0.2)])
def test_the_steady_window(horizon, window):
    assert policy.default_steady_window(horizon) == pytest.approx(window, rel=1e-15)


def test_every_policy_name_is_documented_in_the_module_table():
    """The module docstring's table lists every constant (its meaning and unit live there and in its docstring)."""
    doc = policy.__doc__
    for name in policy.__all__:
        if name.isupper():
            assert f":data:`{name}`" in doc, name
