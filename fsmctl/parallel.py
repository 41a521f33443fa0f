"""Process pools and child processes for fsmctl's parallel work: the studies' campaigns (``fsmctl reproduce``,
``fsmctl montecarlo``, ``fsmctl tune``, through :mod:`fsmctl.studies.campaign`) and the proofs' (``fsmctl prove``
runs its heavy claims beside the others; a SymPy simplification that cannot be interrupted runs under a time limit,
:func:`run_with_time_limit`).  The one home of fsmctl's process plumbing, below every layer that starts processes.

Besides choosing the start method (:func:`process_pool_context`) and the workers' thread counts
(:func:`single_threaded_workers`), this module ties the workers' lives to their parent and turns the
parent's interrupts into an orderly shutdown:

* :func:`worker_pool` is a ``ProcessPoolExecutor`` whose workers die with the parent: on Linux the
  kernel sends them ``SIGKILL`` when the parent dies (``prctl(PR_SET_PDEATHSIG)``, set in each worker's
  initializer, followed by a check that the parent is still the one that started it, since it may have
  died before the call); everywhere a daemon thread in each worker polls ``os.getppid()`` every
  :data:`WATCHDOG_PERIOD_S` seconds and ends the worker when its parent has changed (it was re-parented
  to init or a subreaper).  Workers ignore ``SIGINT``, so a Ctrl-C in a terminal, which reaches the
  whole process group, is handled by the parent alone.  Leaving the ``with`` block by an exception
  (an interrupt, a disk-full error) cancels the queued tasks and terminates the workers instead of
  waiting for them.
* :func:`interrupt_guard` installs handlers for ``SIGINT`` and ``SIGTERM`` that raise
  :class:`CampaignInterrupted` (a :class:`KeyboardInterrupt`) in the main thread, so ``finally``
  blocks and :func:`worker_pool` stop the workers.  Code inside :meth:`InterruptGuard.deferred` (writing
  a result file) finishes before the interrupt is raised.  The exit code of an interrupted command is
  ``128 + signal``: 130 for ``SIGINT``, 143 for ``SIGTERM`` (what a shell reports for a process the
  signal ended).
"""

from __future__ import annotations

import contextlib
import ctypes
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from multiprocessing.context import BaseContext

from fsmctl.errors import InputError
from fsmctl.policy import default_workers

__all__ = [
    "WORKER_THREAD_VARIABLES",
    "WATCHDOG_PERIOD_S",
    "CampaignInterrupted",
    "InterruptGuard",
    "check_workers",
    "interrupt_guard",
    "process_pool_context",
    "resolve_workers",
    "run_with_time_limit",
    "single_threaded_workers",
    "stop_pool",
    "worker_lifeline",
    "worker_pool",
]

WORKER_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
"""thread counts of OpenBLAS, OpenMP and MKL, read from the environment when the library loads"""

WATCHDOG_PERIOD_S = 0.5
"""how often a worker checks that its parent is alive (the portable fallback of ``PR_SET_PDEATHSIG``)"""

ORPHAN_EXIT_CODE = 70
"""exit status of a worker that found its parent gone"""

_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def check_workers(workers: object, where: str) -> int:
    """The one check of a worker count given to a study (``tune``, ``reproduce``, ``compare_laws``, ...).

    Parameters
    ----------
    workers : object
        What the caller passed.
    where : str
        The function's name, for the message.

    Returns
    -------
    int
        ``workers``, a whole number >= 1.

    Raises
    ------
    InputError
        ``workers`` is not a whole number >= 1 (``True`` is not one).

    Examples
    --------
    >>> check_workers(2, "reproduce")
    2
    >>> check_workers(0, "reproduce")
    Traceback (most recent call last):
    ...
    fsmctl.errors.InputError: reproduce: workers must be a whole number >= 1, got 0
    """
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise InputError(f"{where}: workers must be a whole number >= 1, got {workers!r}")
    return workers


def resolve_workers(workers: int | None, tasks: int, where: str) -> int:
    """The worker count of a study's entry point: the one rule of every library ``workers=`` default.

    Parameters
    ----------
    workers : int or None
        What the caller passed: a whole number >= 1 (checked by :func:`check_workers`), or ``None``: one worker
        per CPU this process may run on, at most one per task (:func:`fsmctl.policy.default_workers`).
    tasks : int
        The number of tasks the study can run at once (its runs, variants, claims, chunks, trials of a batch).
    where : str
        The function's name, for the message.

    Returns
    -------
    int
        A whole number >= 1.  It changes the speed only: a study's results are the same for any worker count.

    Raises
    ------
    InputError
        ``workers`` is neither ``None`` nor a whole number >= 1.

    Examples
    --------
    >>> from fsmctl.policy import default_workers
    >>> resolve_workers(3, 1, "reproduce"), resolve_workers(None, 1, "reproduce")
    (3, 1)
    >>> resolve_workers(None, 64, "reproduce") == default_workers(64)
    True
    >>> resolve_workers(0, 4, "tune")
    Traceback (most recent call last):
    ...
    fsmctl.errors.InputError: tune: workers must be a whole number >= 1, got 0
    """
    return default_workers(tasks) if workers is None else check_workers(workers, where)


def process_pool_context() -> BaseContext:
    """``spawn`` (clean workers) unless ``__main__`` is a plain script that spawned workers would re-run.

    Forking a process that has loaded CasADi, OpenBLAS and ctypes libraries (with their threads) is
    unsafe, so workers are spawned.  A script without an ``if __name__ == "__main__"`` guard (e.g. a
    jupytext notebook run with ``python``) would be executed again by every spawned worker; there
    ``fork`` is used where the platform has it.

    Returns
    -------
    multiprocessing.context.BaseContext
        The ``spawn`` or ``fork`` context.

    Examples
    --------
    >>> from fsmctl.parallel import process_pool_context
    >>> process_pool_context().get_start_method() in ("spawn", "fork")
    True
    """
    main_module = sys.modules.get("__main__")
    script = getattr(main_module, "__spec__", None) is None and getattr(main_module, "__file__", None)
    if script and "fork" in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("fork")
    return multiprocessing.get_context("spawn")


@contextlib.contextmanager
def single_threaded_workers() -> Iterator[dict[str, str]]:
    """Worker processes started inside this block use one BLAS/OpenMP thread each.

    Every worker of a campaign is one of as many processes as there are cores, so extra BLAS threads
    only compete for them (idle OpenBLAS threads showed up in profiles).  OpenBLAS, OpenMP and MKL read
    :data:`WORKER_THREAD_VARIABLES` once, when they load, which in a spawned worker is at its first
    ``import numpy``, before any of fsmctl's code runs there; so the variables are set here, in the
    parent's environment that the workers inherit.  A variable the user has set is left as it is, and
    the parent's environment is restored on exit (the parent's already loaded libraries keep their
    threads).  A forked worker (see :func:`process_pool_context`) inherits the libraries the parent has
    already loaded, with their thread counts (NumPy's OpenBLAS); only those it loads later (SciPy's)
    follow the variables.

    Keep the block open as long as the pool can start workers (``ProcessPoolExecutor`` starts them
    as tasks are submitted).  The environment is the parent's, process-wide: a BLAS library that the
    parent itself first loads inside the block (say a first ``import scipy``) also gets one thread, and
    two such blocks open at once in different threads of one process overlap (the first to close
    removes the variables while the other pool may still start workers).  Both only affect speed.

    Yields
    ------
    dict
        The variables that were added (name -> ``"1"``).
    Examples
    --------
    >>> import os
    >>> from fsmctl.parallel import single_threaded_workers
    >>> with single_threaded_workers() as added:
    ...     print(all(os.environ[name] == "1" for name in added))
    True
    """
    added = {name: "1" for name in WORKER_THREAD_VARIABLES if name not in os.environ}
    os.environ.update(added)
    try:
        yield added
    finally:
        for name, value in added.items():
            if os.environ.get(name) == value:
                del os.environ[name]


# ----------------------------------------------------------------------------- workers that die with their parent


def _set_parent_death_signal(signum: int) -> bool:
    """Linux: ask the kernel to send ``signum`` to this process when its parent dies; False elsewhere."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, int(signum), 0, 0, 0) == 0
    except (OSError, AttributeError):  # no prctl in this libc
        return False


def _watch_parent(parent_pid: int, period: float) -> None:
    while True:
        time.sleep(period)
        if os.getppid() != parent_pid:
            os._exit(ORPHAN_EXIT_CODE)  # no cleanup: the parent that wanted the results is gone


def worker_lifeline(parent_pid: int, period: float = WATCHDOG_PERIOD_S) -> None:
    """Initializer of a pool worker: die with the parent (``parent_pid``) and leave interrupts to it.

    * ``SIGINT`` is ignored (the parent stops the workers; a Ctrl-C reaches the whole process group)
      and ``SIGTERM`` has its default action (the parent terminates workers with it);
    * Linux: ``PR_SET_PDEATHSIG`` = ``SIGKILL``, then the parent is checked once more, because it may
      have died between starting this process and the ``prctl`` call.  The kernel sends the signal when
      the *thread* that started the worker ends; :func:`worker_pool` starts workers in ``submit``, from
      the thread that runs the campaign and outlives the pool;
    * everywhere: a daemon thread checks ``os.getppid()`` every ``period`` seconds and ends the
      process with :data:`ORPHAN_EXIT_CODE` once the parent has changed.

    It changes the calling process's signal handling: call it only in a worker (:func:`worker_pool` does).

    Parameters
    ----------
    parent_pid : int
        The process id of the parent that started the worker.
    period : float, optional
        Seconds between two checks of the parent.
    """
    if hasattr(signal, "SIGINT"):
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "SIGTERM"):
        signal.signal(signal.SIGTERM, signal.SIG_DFL)  # a forked worker inherits the parent's handler
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})  # see worker_pool: blocked while starting
    if hasattr(signal, "SIGKILL"):
        _set_parent_death_signal(signal.SIGKILL)
    if os.getppid() != parent_pid:
        os._exit(ORPHAN_EXIT_CODE)
    threading.Thread(target=_watch_parent, args=(parent_pid, period), name="fsmctl-parent-watch", daemon=True).start()


@contextlib.contextmanager
def _sigint_blocked_in_new_processes() -> Iterator[None]:
    """Processes started inside this block (from this thread) begin with ``SIGINT`` blocked.

    A spawned worker imports NumPy and fsmctl before its initializer can ignore ``SIGINT``; a Ctrl-C
    in that window would print a worker traceback.  The signal mask is inherited through fork and exec,
    so a worker started with ``SIGINT`` blocked keeps a Ctrl-C pending until :func:`worker_lifeline`
    ignores (and so discards) it.  Only this thread's mask changes: the parent's own ``SIGINT`` is
    delivered to another thread meanwhile, or to this one when the block ends.
    """
    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


class _LifelinePool(ProcessPoolExecutor):
    """A ``ProcessPoolExecutor`` whose workers start with :func:`worker_lifeline` and ``SIGINT`` blocked."""

    def __init__(self, max_workers: int, mp_context: BaseContext):
        super().__init__(
            max_workers=max_workers, mp_context=mp_context, initializer=worker_lifeline, initargs=(os.getpid(),)
        )

    def submit(self, fn, /, *args, **kwargs):
        with _sigint_blocked_in_new_processes():  # workers are started here, as tasks are submitted
            return super().submit(fn, *args, **kwargs)


def stop_pool(executor: ProcessPoolExecutor, grace_s: float = 2.0) -> None:
    """Cancel the queued tasks and end the workers now: ``SIGTERM``, then ``SIGKILL`` after ``grace_s``.

    Parameters
    ----------
    executor : concurrent.futures.ProcessPoolExecutor
        The pool.
    grace_s : float, optional
        Seconds the workers get to end after ``SIGTERM``.

    Examples
    --------
    >>> from fsmctl.parallel import stop_pool, worker_pool
    >>> with worker_pool(1) as pool:
    ...     future = pool.submit(pow, 2, 10)
    ...     value = future.result()
    ...     stop_pool(pool)
    >>> value
    1024
    """
    processes = list((getattr(executor, "_processes", None) or {}).values())  # before shutdown clears it
    manager = getattr(executor, "_executor_manager_thread", None)  # likewise
    with contextlib.suppress(Exception):
        executor.shutdown(wait=False, cancel_futures=True)
    for p in processes:
        with contextlib.suppress(Exception):
            if p.is_alive():
                p.terminate()
    deadline = time.monotonic() + grace_s
    for p in processes:
        with contextlib.suppress(Exception):
            p.join(max(0.0, deadline - time.monotonic()))
    for p in processes:
        with contextlib.suppress(Exception):
            if p.is_alive():
                p.kill()
                p.join(1.0)
    # The pool's manager thread ends once it sees its workers gone.  Wait for it: left running, it closes its wakeup
    # pipe while the interpreter's exit hook may write to it (a race of Python < 3.12 that printed "OSError: [Errno 9]
    # Bad file descriptor" after a Ctrl-C's one-line message, seen once under CI load on Python 3.11.2).
    if manager is not None:
        with contextlib.suppress(Exception):
            manager.join(grace_s)


@contextlib.contextmanager
def worker_pool(max_workers: int, mp_context: BaseContext | None = None) -> Iterator[ProcessPoolExecutor]:
    """A process pool whose workers die with this process; leaving by an exception stops them at once.

    On a normal exit the pool is shut down as ``with ProcessPoolExecutor(...)`` would (waiting for the
    tasks); on an exception (:class:`CampaignInterrupted`, an error while handling a result) the queued
    tasks are cancelled and the workers terminated (:func:`stop_pool`), so nothing outlives the block.

    Parameters
    ----------
    max_workers : int
        Worker processes.
    mp_context : multiprocessing context, optional
        Default :func:`process_pool_context`.

    Yields
    ------
    concurrent.futures.ProcessPoolExecutor
        The pool (its workers start with :func:`worker_lifeline`).

    Examples
    --------
    >>> from fsmctl.parallel import worker_pool
    >>> with worker_pool(1) as pool:
    ...     print(pool.submit(pow, 2, 10).result())
    1024
    """
    executor = _LifelinePool(max_workers, mp_context or process_pool_context())
    try:
        yield executor
        executor.shutdown(wait=True)  # all tasks are done here, unless an interrupt arrives meanwhile
    except BaseException:
        stop_pool(executor)
        raise


# ----------------------------------------------------------------------------- a computation under a time limit


def run_with_time_limit(fn: Callable[[], object], seconds: float) -> tuple[bool, object]:
    """``(finished, value)`` of ``fn()`` run under a time limit.

    SymPy's simplifiers cannot be interrupted, so ``fn`` runs in a forked child process that is killed at the
    limit and dies with this process (:func:`worker_lifeline`: a ``SIGKILL`` of the parent, or its Ctrl-C, ends
    the child too); without ``fork`` (e.g. on Windows) it runs here, unguarded.

    Parameters
    ----------
    fn : callable
        The computation, without arguments; its value must pickle.
    seconds : float
        The time limit, in seconds.

    Returns
    -------
    finished : bool
        Whether ``fn`` returned (or raised) within the limit.
    value : object
        Its value; None when it did not finish; the string ``"error: <type>: <message>"`` when it raised (or
        ``"error: the worker died"``).

    Examples
    --------
    >>> import sympy as sp
    >>> x = sp.Symbol("x")
    >>> from fsmctl.parallel import run_with_time_limit
    >>> run_with_time_limit(lambda: sp.factor(x**2 - 1), 10.0)
    (True, (x - 1)*(x + 1))
    >>> run_with_time_limit(lambda: 1 / 0, 10.0)
    (True, 'error: ZeroDivisionError: division by zero')
    """
    try:
        ctx = multiprocessing.get_context("fork")
    except ValueError:
        try:
            return True, fn()
        except Exception as exc:
            return True, f"error: {type(exc).__name__}: {exc}"
    recv, send = ctx.Pipe(duplex=False)
    parent = os.getpid()

    def child():
        worker_lifeline(parent)  # dies with this process; a Ctrl-C is the parent's to handle
        try:
            value = fn()
        except BaseException as exc:
            value = f"error: {type(exc).__name__}: {exc}"
        send.send(value)
        send.close()

    proc = ctx.Process(target=child, daemon=True)
    with _sigint_blocked_in_new_processes():
        proc.start()
    send.close()
    try:
        if recv.poll(seconds):
            try:
                return True, recv.recv()
            except EOFError:
                return True, "error: the worker died"
        return False, None
    finally:
        recv.close()
        if proc.is_alive():
            proc.terminate()
        proc.join(5)


# ----------------------------------------------------------------------------- interrupts


class CampaignInterrupted(KeyboardInterrupt):
    """``SIGINT`` or ``SIGTERM`` arrived during a campaign; raised after the workers were stopped.

    A :class:`KeyboardInterrupt`: :func:`~fsmctl.studies.run_campaign` and ``fsmctl.studies.tune.tune`` raise it
    after keeping what was finished (a resumed campaign or study continues from there).

    Parameters
    ----------
    signum : int
        The signal.
    detail : str, optional
        What was kept (the campaign fills it in before the exception leaves it).

    Attributes
    ----------
    signum : int
        The signal.
    exit_code : int
        ``128 + signum``: 130 for ``SIGINT``, 143 for ``SIGTERM``.
    detail : str
        What was kept.

    Examples
    --------
    >>> import signal
    >>> from fsmctl.parallel import CampaignInterrupted
    >>> exc = CampaignInterrupted(signal.SIGTERM, "3 of 10 chunks kept")
    >>> exc.signal_name, exc.exit_code, exc.detail
    ('SIGTERM', 143, '3 of 10 chunks kept')
    """

    def __init__(self, signum: int, detail: str = ""):
        super().__init__(signum)
        self.signum = int(signum)
        self.detail = detail

    @property
    def signal_name(self) -> str:
        """The signal's name (``SIGINT``), or ``signal N`` for an unnamed one."""
        try:
            return signal.Signals(self.signum).name
        except ValueError:
            return f"signal {self.signum}"

    @property
    def exit_code(self) -> int:
        """``128 + signum``: the process's exit status (130 for ``SIGINT``, 143 for ``SIGTERM``)."""
        return 128 + self.signum

    def __str__(self) -> str:
        return f"interrupted by {self.signal_name}" + (f": {self.detail}" if self.detail else "")


class InterruptGuard:
    """The state behind :func:`interrupt_guard` (``active`` is False when no handler could be installed).

    Examples
    --------
    >>> from fsmctl.parallel import interrupt_guard
    >>> with interrupt_guard() as guard:
    ...     with guard.deferred():
    ...         pass  # write a result file here: an interrupt waits until the block ends
    >>> guard.received is None
    True
    """

    def __init__(self) -> None:
        self.active = False
        self.received: int | None = None
        """the first signal that arrived"""
        self._pending: int | None = None
        self._depth = 0
        self._closing = False

    def _handler(self, signum: int, frame) -> None:
        if self.received is None:
            self.received = signum
        if self._closing:
            return  # a second Ctrl-C while the workers are being stopped: already on the way out
        if self._depth:
            self._pending = signum
            return
        self._closing = True
        raise CampaignInterrupted(signum)

    @contextlib.contextmanager
    def deferred(self) -> Iterator[None]:
        """An interrupt that arrives inside this block is raised when it ends (a file is not left half-written)."""
        self._depth += 1
        try:
            yield
        finally:
            self._depth -= 1
        if not self._depth and self._pending is not None and not self._closing:
            signum, self._pending = self._pending, None
            self._closing = True
            raise CampaignInterrupted(signum)

    def closing(self) -> None:
        """From now on signals are only recorded (the caller is already shutting down)."""
        self._closing = True


@contextlib.contextmanager
def interrupt_guard() -> Iterator[InterruptGuard]:
    """Turn ``SIGINT`` and ``SIGTERM`` into :class:`CampaignInterrupted` inside the block (main thread only).

    The previous handlers are restored on exit.  Outside the main thread (where Python cannot install
    handlers) the guard is inactive and the process keeps its handlers.  The first signal raises; later
    ones, while the campaign shuts down, are recorded and ignored.

    Yields
    ------
    InterruptGuard
        The guard (``active``, ``received``, :meth:`InterruptGuard.deferred`).

    Examples
    --------
    The handlers are installed inside the block and the previous ones are back after it:

    >>> import signal
    >>> from fsmctl.parallel import interrupt_guard
    >>> before = signal.getsignal(signal.SIGTERM)
    >>> with interrupt_guard() as guard:
    ...     installed = signal.getsignal(signal.SIGTERM) is not before
    >>> guard.active == installed, signal.getsignal(signal.SIGTERM) is before
    (True, True)
    """
    guard = InterruptGuard()
    if threading.current_thread() is not threading.main_thread():
        yield guard
        return
    names = [n for n in ("SIGINT", "SIGTERM") if hasattr(signal, n)]
    previous = {}
    try:
        for n in names:
            sig = getattr(signal, n)
            previous[sig] = signal.signal(sig, guard._handler)
        guard.active = True
        yield guard
    finally:
        guard.closing()
        for sig, handler in previous.items():
            signal.signal(sig, handler if handler is not None else signal.SIG_DFL)
