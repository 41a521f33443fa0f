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


# ----------------------------------------------------------------------------- the library's workers= defaults


def _entry_points():
    from fsmctl.proofs.claims import run_claims
    from fsmctl.studies.compare import compare_laws
    from fsmctl.studies.montecarlo.run import run_campaign
    from fsmctl.studies.reproduce import reproduce
    from fsmctl.studies.surfaces import compare_surfaces
    from fsmctl.studies.tune.search import tune

    return [run_claims, reproduce, compare_laws, compare_surfaces, run_campaign, tune]


def test_every_library_entry_point_defaults_to_the_one_rule():
    """``workers=None`` (one per CPU, at most one per task), stated the same way in each docstring."""
    import inspect

    for fn in _entry_points():
        assert inspect.signature(fn).parameters["workers"].default is None, fn.__qualname__
        doc = " ".join(fn.__doc__.split())
        assert "Default: one per CPU, at most one per" in doc, fn.__qualname__
        assert ":func:`fsmctl.policy.default_workers` of" in doc, fn.__qualname__
        assert "The results do not depend on it." in doc, fn.__qualname__


def test_the_default_is_default_workers_of_the_tasks(monkeypatch):
    """compare_laws asks for one worker per run; run_claims for one per group of claims (here one group)."""
    import fsmctl
    from fsmctl.proofs import ProofContext, run_claims
    from fsmctl.studies.compare import compare_laws

    asked = []

    def spy(tasks=None):
        asked.append(tasks)
        return 1

    monkeypatch.setattr("fsmctl.parallel.default_workers", spy)  # the one rule, for the studies and the proofs
    s = fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.2, "output_interval": 0.1})
    assert [r["label"] for r in compare_laws(s, ["fsm", "pid"], tolerances_deg=(1.0,)).table] == ["fsm", "pid"]
    assert [r.id for r in run_claims(["lemma2-sqrt-sum"], ProofContext(fsmctl.paper_scenario()))] == ["lemma2-sqrt-sum"]
    assert asked == [2, 1]


def test_an_explicit_worker_count_is_checked(tmp_path):
    import fsmctl
    from fsmctl.errors import InputError
    from fsmctl.proofs import ProofContext, run_claims
    from fsmctl.studies import CampaignSettings, run_campaign

    with pytest.raises(InputError, match="run_claims: workers must be a whole number >= 1, got 0"):
        run_claims(["lemma2-sqrt-sum"], ProofContext(fsmctl.paper_scenario()), workers=0)
    settings = CampaignSettings(runs=2, seed=1, t_final=0.5, steady_window=0.2, chunk_size=2)
    with pytest.raises(InputError, match="run_campaign: workers must be a whole number >= 1, got 0"):
        run_campaign(settings, tmp_path / "mc", workers=0, progress=False, figures=False)
    assert not (tmp_path / "mc").exists()
