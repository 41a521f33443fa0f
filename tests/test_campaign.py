"""The campaign runner (fsmctl.studies.campaign): one home of the studies' parallel work.

Independent oracle: every task's result is its function applied to its arguments here, in this process; the runner
must return exactly those, in task order, whatever backend ran them and whichever worker died.
"""

from __future__ import annotations

import os
import signal

import pytest

from fsmctl.errors import ResourceLimitError
from fsmctl.parallel import CampaignInterrupted
from fsmctl.studies.campaign import WORKER_DIED, Runner, Task, check_memory

DIE = -1


def _square_or_die(x: int) -> list[int]:
    """A list (parts concatenate) of ``x * x``; the worker process dies at ``DIE``."""
    if x == DIE:
        os._exit(3)
    return [x * x]


def _chunk(xs: list[int]) -> list[int]:
    return [y for x in xs for y in _square_or_die(x)]


def _chunk_task(key: int, xs: list[int]) -> Task:
    parts = tuple(Task((key, x), _chunk, ([x],), lost=lambda message, x=x: [f"{x}: {message}"]) for x in xs)
    return Task(key, _chunk, (xs,), weight=len(xs), parts=parts)


@pytest.mark.parametrize(
    ("workers", "threads"), [(1, False), (2, True), (2, False)], ids=["serial", "threads", "processes"]
)
def test_results_in_task_order_on_every_backend(workers, threads):
    xs = [[3, 1], [4], [1, 5], [9, 2], [6]]
    seen, units = [], []
    with Runner(workers=workers, threads=threads, name="t") as runner:
        bar = runner.progress(sum(map(len, xs)), enabled=True)  # counts (on the captured stderr)
        out = runner.run([_chunk_task(k, x) for k, x in enumerate(xs)], on_done=lambda t, r: seen.append(t.key))
        units.append(bar.n)
    assert out == [_chunk(x) for x in xs]  # the oracle: the function here
    assert sorted(seen) == list(range(len(xs))) and units == [8]


def test_a_task_that_kills_its_worker_loses_only_the_part_that_does():
    """Retried in a fresh pool, then part by part, each alone: the other parts' results are kept."""
    xs = [[1, 2], [3, DIE, 4], [5]]
    with Runner(workers=2, name="t") as runner:
        out = runner.run([_chunk_task(k, x) for k, x in enumerate(xs)])
        again = runner.run([_chunk_task(0, [6, 7])])  # the runner replaced its broken pool
    assert out == [[1, 4], [9, f"{DIE}: {WORKER_DIED}", 16], [25]]
    assert again == [[36, 49]]


def test_a_lost_task_without_a_stand_in_is_an_error():
    with Runner(workers=2, name="t") as runner, pytest.raises(RuntimeError, match=WORKER_DIED):
        runner.run([Task("a", _square_or_die, (2,)), Task("b", _square_or_die, (DIE,))])


def _terminate_self(x: int) -> int:
    if x == 2:
        os.kill(os.getpid(), signal.SIGTERM)
    return x


def test_sigterm_stops_the_campaign_keeping_what_finished():
    kept = []
    with pytest.raises(CampaignInterrupted) as info, Runner(workers=1, name="t") as runner:
        runner.run([Task(k, _terminate_self, (k,)) for k in range(5)], on_done=lambda t, r: kept.append(r))
    assert info.value.exit_code == 143 and kept == [0, 1]


def test_memory_is_checked_before_anything_runs():
    with pytest.raises(ResourceLimitError, match=r"^the results would need ~2 GB of memory but only 1 GB .*: fewer"):
        check_memory("the results", 2 * 10**9, available=10**9, advice="fewer")
    assert check_memory("the results", 10**9, available=10**9) == 10**9
