"""Process pools for fsmctl's campaigns (``fsmctl reproduce``, ``fsmctl montecarlo``)."""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import sys
from collections.abc import Iterator
from multiprocessing.context import BaseContext

__all__ = ["WORKER_THREAD_VARIABLES", "process_pool_context", "single_threaded_workers"]

WORKER_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
"""thread counts of OpenBLAS, OpenMP and MKL, read from the environment when the library loads"""


def process_pool_context() -> BaseContext:
    """``spawn`` (clean workers) unless ``__main__`` is a plain script that spawned workers would re-run.

    Forking a process that has loaded CasADi, OpenBLAS and ctypes libraries (with their threads) is
    unsafe, so workers are spawned.  A script without an ``if __name__ == "__main__"`` guard (e.g. a
    jupytext notebook run with ``python``) would be executed again by every spawned worker; there
    ``fork`` is used where the platform has it.
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
    """
    added = {name: "1" for name in WORKER_THREAD_VARIABLES if name not in os.environ}
    os.environ.update(added)
    try:
        yield added
    finally:
        for name, value in added.items():
            if os.environ.get(name) == value:
                del os.environ[name]
