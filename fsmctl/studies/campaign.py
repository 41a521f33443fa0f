"""The campaign runner: the one home of fsmctl's parallel work (Monte Carlo, tuning, law and surface comparisons).

A study declares *what* to compute as :class:`Task` objects (a module-level function and its arguments, so that a
worker process or a Dask worker can run it) and hands them to a :class:`Runner`, which decides *where*:

* ``workers=1``: in this process, one after the other;
* ``workers > 1``: a local process pool (:func:`fsmctl.parallel.worker_pool`: workers with one BLAS thread
  each, :func:`~fsmctl.parallel.single_threaded_workers`, that die with this process), kept for the
  runner's life and replaced when a worker dies; at most ``2 * workers`` tasks are in flight at once, so the
  arguments and results waiting in memory do not grow with the number of tasks;
* ``threads=True``: a thread pool, for tasks whose work releases the GIL (the compiled loop) and whose arguments
  need not be pickled (a comparison's callbacks);
* ``dask=ADDRESS`` or a :class:`distributed.Client`: a Dask cluster (:func:`fsmctl.studies.cluster.connect_dask`
  checks the address first).

:meth:`Runner.run` returns the results in the order of the tasks, whatever finished first, so a study gives the
same numbers bit for bit on every backend and for any worker count (each task's result depends on its arguments
only: seeds travel inside them).  ``on_done(task, result)`` is called in this process as each task finishes (a
Monte Carlo chunk file is written there), inside :meth:`Runner.deferred` so that an interrupt waits for it.

Failures: a task whose worker process died (``BrokenProcessPool``; ``KilledWorker`` on Dask) is retried once in a
fresh pool; if it dies again it is run alone in a single-worker pool, or, when it declares :attr:`Task.parts`,
each part alone, and a part (or task) that still kills its worker gets ``task.lost(message)`` as its result.  Any
other exception of a task propagates (a study catches the failures it reports inside its task function).

Interrupts: entered, the runner turns ``SIGINT``/``SIGTERM`` into
:class:`~fsmctl.parallel.CampaignInterrupted` (:func:`~fsmctl.parallel.interrupt_guard`); leaving it
by an exception cancels the queued tasks and stops the workers; what ``on_done`` kept stays kept, so a study that
skips the tasks it finished before resumes exactly.  Progress: :meth:`Runner.progress` attaches a bar that every
finished task advances by its :attr:`Task.weight`.  Memory: :func:`check_memory` is the one check that a study's
results fit in memory before anything runs.

Examples
--------
>>> from fsmctl.studies.campaign import Runner, Task
>>> with Runner(workers=1) as runner:
...     runner.run([Task(k, pow, (2, k)) for k in range(4)])
[1, 2, 4, 8]
"""

from __future__ import annotations

import contextlib
import os
import sys
import time
from collections.abc import Callable, Hashable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any

from fsmctl.errors import ResourceLimitError
from fsmctl.parallel import (
    InterruptGuard,
    check_workers,
    interrupt_guard,
    single_threaded_workers,
    stop_pool,
    worker_pool,
)
from fsmctl.policy import DASK_TIMEOUT_S
from fsmctl.simulation.memory import available_memory, format_bytes
from fsmctl.studies.cluster import connect_dask

__all__ = ["Task", "Runner", "check_memory"]

WORKER_DIED = "the worker process died"
"""the message a task whose local worker died twice (and alone) is reported with"""


@dataclass(frozen=True)
class Task:
    """One unit of a campaign: ``fn(*args)``, run wherever the :class:`Runner` decides.

    Parameters
    ----------
    key : hashable
        The task's name in its campaign (a chunk number, a trial index).
    fn : callable
        A module-level function (picklable): its result must depend on ``args`` only.
    args : tuple, optional
        Its arguments (picklable for process pools and Dask).
    weight : int, optional
        Units of progress the task counts for (the runs of a Monte Carlo chunk).
    lost : callable, optional
        ``lost(message)``: the result that stands for the task when its worker keeps dying; without it the
        failure is raised (:class:`RuntimeError`).
    parts : tuple of Task, optional
        Smaller tasks whose results (lists) concatenate to this task's result: when the task kills its worker twice,
        the parts are run one by one, each alone, so that only the part that kills its worker is lost.

    Examples
    --------
    >>> from fsmctl.studies.campaign import Task
    >>> Task("square", pow, (3, 2)).weight
    1
    """

    key: Hashable
    fn: Callable[..., Any]
    args: tuple = ()
    weight: int = 1
    lost: Callable[[str], Any] | None = None
    parts: tuple[Task, ...] = ()

    def __call__(self) -> Any:
        """Run the task here."""
        return self.fn(*self.args)

    def failed(self, message: str) -> Any:
        """The result of a task that kept killing its worker (:attr:`lost`), or :class:`RuntimeError`."""
        if self.lost is None:
            raise RuntimeError(f"{self.key}: {message}")
        return self.lost(message)


def check_memory(what: str, needed: int, *, available: int | None = None, advice: str = "") -> int:
    """Refuse (:class:`~fsmctl.errors.ResourceLimitError`) a campaign whose results would not fit in memory.

    The one memory check of the studies, made before anything is drawn, flown or written: ``needed`` (the study's
    estimate of its peak, e.g. :func:`fsmctl.studies.montecarlo.check_campaign_memory`) against ``available``
    (default: :func:`fsmctl.simulation.simulator.available_memory`; no check when that is unknown).

    Parameters
    ----------
    what : str
        What needs it, for the message (``"montecarlo: the results of 1,000 runs"``).
    needed : int
        Bytes.
    available : int, optional
        Bytes available; default: what the machine has now.
    advice : str, optional
        What the user can do, appended to the message.

    Returns
    -------
    int
        ``needed``.

    Raises
    ------
    fsmctl.errors.ResourceLimitError
        ``needed > available``.

    Examples
    --------
    >>> from fsmctl.studies.campaign import check_memory
    >>> check_memory("the results", 10**6, available=10**9)
    1000000
    >>> check_memory("the results", 10**12, available=10**9, advice="fewer runs")
    Traceback (most recent call last):
    ...
    fsmctl.errors.ResourceLimitError: the results would need ~1 TB of memory but only 1 GB is available: fewer runs
    """
    if available is None:
        available = available_memory()
    if available is not None and needed > available:
        raise ResourceLimitError(
            f"{what} would need ~{format_bytes(needed)} of memory but only {format_bytes(available)} is available"
            + (f": {advice}" if advice else "")
        )
    return needed


class Runner:
    """Runs :class:`Task` lists in this process, on a local process pool, in threads or on a Dask cluster.

    Use it as a context manager (it installs the interrupt handlers and owns the pool or the Dask client); one
    runner may run several task lists (a tuning study's batches) on the same workers.

    Parameters
    ----------
    workers : int, optional
        Local workers (1: in this process).
    dask : str or distributed.Client, optional
        A Dask scheduler's address, or a client; replaces the local workers.
    dask_timeout : float, optional
        Seconds a Dask scheduler gets to answer.
    threads : bool, optional
        Local workers are threads, not processes (tasks that release the GIL and need not be pickled).
    name : str, optional
        The campaign's name (Dask keys, the progress bar).
    interrupts : bool, optional
        Turn ``SIGINT``/``SIGTERM`` into :class:`~fsmctl.parallel.CampaignInterrupted` inside the block.

    Examples
    --------
    >>> from fsmctl.studies.campaign import Runner, Task
    >>> seen = []
    >>> with Runner(workers=2, threads=True) as runner:
    ...     out = runner.run([Task(k, divmod, (k, 3)) for k in range(5)], on_done=lambda t, r: seen.append(t.key))
    >>> out, sorted(seen)
    ([(0, 0), (0, 1), (0, 2), (1, 0), (1, 1)], [0, 1, 2, 3, 4])
    """

    def __init__(
        self,
        *,
        workers: int = 1,
        dask: Any = None,
        dask_timeout: float = DASK_TIMEOUT_S,
        threads: bool = False,
        name: str = "campaign",
        interrupts: bool = True,
    ):
        self.workers = check_workers(workers, name)
        self.name = name
        self.threads = threads
        self._dask, self._dask_timeout = dask, dask_timeout
        self._interrupts = interrupts
        self.client: Any = None
        self._own_client = False
        self._pool: Any = None
        self._bar: Any = None
        self._stack = contextlib.ExitStack()
        self.guard = InterruptGuard()

    # ------------------------------------------------------------------ life

    def __enter__(self) -> Runner:
        if self._interrupts:
            self.guard = self._stack.enter_context(interrupt_guard())
        self._stack.callback(self._close)
        return self

    def __exit__(self, *exc) -> bool:
        if exc[0] is not None:
            self.guard.closing()
        return bool(self._stack.__exit__(*exc))

    def start(self) -> Runner:
        """Connect to the Dask cluster now (a bad address is an error before any work); idempotent."""
        if self._dask is not None and self.client is None:
            self.client, self._own_client = connect_dask(self._dask, self._dask_timeout)
        return self

    def _close(self) -> None:
        if self._bar is not None:
            self._bar.close()
        if self._own_client:
            with contextlib.suppress(Exception):
                self.client.close(timeout=self._dask_timeout)

    @property
    def backend(self) -> str:
        """``"dask"``, ``"processes"``, ``"threads"`` or ``"serial"``."""
        if self._dask is not None:
            return "dask"
        if self.workers <= 1:
            return "serial"
        return "threads" if self.threads else "processes"

    @property
    def slots(self) -> int:
        """Tasks the runner runs at once: its local workers, or the threads of the Dask cluster's workers (at least 1).

        A study that can split its work into fewer, larger tasks (the tuner's candidates flown together) splits it
        into about this many.

        Examples
        --------
        >>> from fsmctl.studies.campaign import Runner
        >>> Runner(workers=2, threads=True).slots
        2
        """
        if self._dask is not None:
            self.start()
            return max(1, sum(self.client.nthreads().values()))
        return self.workers

    def deferred(self) -> contextlib.AbstractContextManager:
        """An interrupt that arrives inside this block waits for its end (a file is not left half-written)."""
        return self.guard.deferred()

    def progress(
        self,
        total: int,
        *,
        initial: int = 0,
        unit: str = "run",
        enabled: bool | None = None,
        desc: str | None = None,
    ) -> Any:
        """Attach a progress bar (on stderr; default: when stderr is a terminal) that finished tasks advance.

        A study of several stages (``fsmctl reproduce``: the runs, then the explanations) attaches one bar per
        stage: attaching a bar closes the previous one.

        Parameters
        ----------
        total, initial : int
            Units in all and already done (a resumed campaign); a stage that learns of more work as it goes grows
            the bar's ``total``.
        unit : str
            What a unit is.
        enabled : bool, optional
            Show it; default: when stderr is a terminal.
        desc : str, optional
            The bar's label; default: the runner's name.

        Returns
        -------
        tqdm.tqdm
            The bar (closed with the runner, or when the next bar is attached).

        Examples
        --------
        >>> from fsmctl.studies.campaign import Runner, Task
        >>> with Runner(workers=1, name="demo") as runner:
        ...     runs = runner.progress(2, enabled=False)
        ...     _ = runner.run([Task(k, abs, (-k,)) for k in range(2)])
        ...     overlays = runner.progress(1, unit="figure", enabled=False, desc="figures")
        >>> runs.total, overlays.total
        (2, 1)
        """
        from tqdm.auto import tqdm

        if enabled is None:
            enabled = sys.stderr.isatty()
        if self._bar is not None:
            self._bar.close()
        self._bar = tqdm(
            total=total, initial=initial, unit=unit, desc=desc or self.name, disable=not enabled, file=sys.stderr
        )
        return self._bar

    def share(self, value: Any, *, broadcast: bool = True) -> Any:
        """``value`` as tasks should receive it: scattered once to the Dask cluster, itself elsewhere.

        Parameters
        ----------
        value : object
            What many tasks receive (a study's context); sent once instead of once per task.
        broadcast : bool, optional
            Copy it to every Dask worker now (else a worker fetches it when a task needs it).

        Returns
        -------
        object
            A Dask future of it, or ``value`` itself (not on Dask, or None).
        """
        self.start()
        if self.client is None or value is None:
            return value
        return self.client.scatter([value], broadcast=broadcast, hash=False)[0]  # one object, even a sequence

    # ------------------------------------------------------------------ running

    def run(self, tasks: Sequence[Task], *, on_done: Callable[[Task, Any], None] | None = None) -> list:
        """Run ``tasks`` and return their results in the order of ``tasks``.

        Parameters
        ----------
        tasks : sequence of Task
            What to run.
        on_done : callable, optional
            ``on_done(task, result)``, in this process as each task finishes (inside :meth:`deferred`).

        Returns
        -------
        list
            The results, in the order of ``tasks``.
        """
        tasks = list(tasks)
        results: dict[int, Any] = {}

        def finished(i: int, result: Any) -> None:
            results[i] = result
            if on_done is not None:
                with self.deferred():
                    on_done(tasks[i], result)
            if self._bar is not None:
                self._bar.update(tasks[i].weight)

        backend = self.backend
        if backend == "serial" or (backend == "threads" and len(tasks) <= 1):
            for i, task in enumerate(tasks):
                finished(i, task())
        elif backend == "threads":
            with ThreadPoolExecutor(max_workers=min(self.workers, len(tasks))) as pool:
                for i, result in enumerate(pool.map(Task.__call__, tasks)):
                    finished(i, result)
        elif backend == "dask":
            self._run_dask(tasks, finished)
        else:
            self._run_processes(tasks, finished)
        return [results[i] for i in range(len(tasks))]

    def _local_pool(self) -> Any:
        if self._pool is None:
            self._stack.enter_context(single_threaded_workers())  # every pool of the runner starts its workers here
            self._pool = self._stack.enter_context(worker_pool(self.workers))
        return self._pool

    def _run_processes(self, tasks: list[Task], finished: Callable[[int, Any], None]) -> None:
        pending = list(range(len(tasks)))
        for _attempt in range(2):
            if not pending:
                return
            pending = self._pool_round(tasks, pending, finished)
            if pending:  # a worker died: a fresh pool for the retry (the broken one is stopped now)
                stop_pool(self._pool)
                self._pool = self._stack.enter_context(worker_pool(self.workers))
        for i in pending:  # still dying: alone, part by part; what kills its worker alone is lost
            task = tasks[i]
            if task.parts:
                finished(i, [row for part in task.parts for row in _alone(part)])
            else:
                finished(i, _alone(task))

    def _pool_round(self, tasks: list[Task], indices: list[int], finished: Callable[[int, Any], None]) -> list[int]:
        """Run ``indices`` on the pool (at most ``2 * workers`` in flight); the indices whose worker died."""
        pool = self._local_pool()
        queue, died = iter(indices), []
        in_flight: dict[Future, int] = {}

        def submit() -> None:
            for i in queue:
                in_flight[pool.submit(tasks[i].fn, *tasks[i].args)] = i
                if len(in_flight) >= 2 * self.workers:
                    return

        submit()
        while in_flight:
            done, _ = wait(in_flight, return_when=FIRST_COMPLETED)
            for f in sorted(done, key=in_flight.__getitem__):
                i = in_flight.pop(f)
                try:
                    result = f.result()
                except BrokenProcessPool:
                    died.append(i)
                    continue
                finished(i, result)
            if not died:
                submit()
        return sorted(died + list(queue))

    def _run_dask(self, tasks: list[Task], finished: Callable[[int, Any], None]) -> None:
        from distributed import as_completed

        try:
            from distributed import KilledWorker
        except ImportError:  # older distributed
            from distributed.scheduler import KilledWorker

        self.start()
        stamp = f"fsmctl-{self.name}-{os.getpid()}-{time.time_ns()}"
        futures = {
            self.client.submit(task.fn, *task.args, pure=False, key=f"{stamp}-{i}"): i for i, task in enumerate(tasks)
        }
        try:
            for f in as_completed(list(futures), loop=self.client.loop):  # the client need not be the default one
                i = futures[f]
                try:
                    result = f.result()
                except KilledWorker as exc:
                    result = tasks[i].failed(f"{type(exc).__name__}: {exc}".splitlines()[0][:500])
                finished(i, result)
        except BaseException:
            with contextlib.suppress(Exception):
                self.client.cancel(list(futures), force=True)
            raise


def _alone(task: Task) -> Any:
    """Run ``task`` in a single-worker pool of its own; its :meth:`Task.failed` result if it kills the worker."""
    with worker_pool(1) as pool:
        try:
            return pool.submit(task.fn, *task.args).result()
        except BrokenProcessPool:
            return task.failed(WORKER_DIED)
