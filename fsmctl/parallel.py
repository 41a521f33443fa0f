"""Process pools for fsmctl's campaigns (``fsmctl reproduce``, ``fsmctl montecarlo``)."""

from __future__ import annotations

import multiprocessing
import sys
from multiprocessing.context import BaseContext

__all__ = ["process_pool_context"]


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
