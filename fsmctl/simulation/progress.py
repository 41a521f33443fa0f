"""The compiled loop's progress callback: the progress bar, and Ctrl-C / SIGTERM while C runs.

Nothing may raise inside a ctypes callback, so SIGINT and SIGTERM are deferred (:class:`_DeferredSignals`) while
the loop runs and delivered once C has returned; the callback (:func:`_progress_callback`) polls them and stops
the loop.
"""

from __future__ import annotations

import signal
import sys
import threading

from fsmctl.model.problem import PackedProblem
from fsmctl.simulation.driver import _PROGRESS


class _DeferredSignals:
    """Context manager: while the compiled loop runs, ``SIGINT`` and ``SIGTERM`` only record themselves.

    Python runs signal handlers between bytecodes of the main thread, and while C runs the next bytecodes
    are those of the progress callback: a handler that raises (the default ``SIGINT`` handler's
    :class:`KeyboardInterrupt`, the command line's ``SIGTERM`` handler) raises inside the ctypes callback,
    typically at its first line, before its ``try`` (or inside tqdm).  ctypes then prints "Exception ignored on
    calling ctypes callback function" with the traceback, discards the exception and hands C an undefined
    return value (observed: the loop stopped, the run was reported as "simulation failed: aborted" and
    ``fsmctl simulate`` exited 1 instead of 130 or 143).  This handler raises nothing; the callback polls
    :attr:`pending` and asks C to stop, and :meth:`deliver` runs the original handler of the signal that
    arrived (``SIGINT`` by default: raise :class:`KeyboardInterrupt`; ``fsmctl``'s ``SIGTERM`` handler: exit
    143) once C has returned.

    Installed only in the main thread (the only one that receives signals) and only over a Python-level
    handler; a signal that is ignored (``SIG_IGN``, e.g. ``SIGINT`` in pool workers) or left to the OS
    (``SIG_DFL``: ``SIGTERM`` outside the command line ends the process) stays so.
    """

    SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM") if hasattr(signal, n))

    def __init__(self):
        self.pending: tuple | None = None
        self._previous: dict = {}

    def _record(self, signum, frame):
        if self.pending is None:
            self.pending = (signum, frame)

    def __enter__(self) -> _DeferredSignals:
        if threading.current_thread() is threading.main_thread():
            for sig in self.SIGNALS:
                previous = signal.getsignal(sig)
                if callable(previous):
                    try:
                        signal.signal(sig, self._record)
                    except (ValueError, OSError):  # pragma: no cover - e.g. an embedded interpreter
                        continue
                    self._previous[sig] = previous
        return self

    def __exit__(self, *exc) -> None:
        for sig, previous in self._previous.items():
            signal.signal(sig, previous)

    def deliver(self) -> None:
        """Run the handler that was deferred (after C returned); :class:`KeyboardInterrupt` if it returns."""
        if self.pending is not None:
            (signum, frame), self.pending = self.pending, None
            previous = self._previous.get(signum)
            if previous is not None:
                previous(signum, frame)
            raise KeyboardInterrupt  # the loop was stopped: the run is not complete


def _progress_callback(total: int, enabled: bool, label: str, guard: _DeferredSignals | None = None, watch=None):
    """The ctypes progress callback; a nonzero return stops the loop.

    Nothing may escape a ctypes callback (ctypes would print it and carry on), so every exception is caught
    and kept in ``state["error"]``; a deferred SIGINT (``guard.pending``) stops the loop too.  ``watch(done)``
    (optional) runs after the bar's update; its nonzero return stops the loop (a monitor's early stop).
    """
    state = {"bar": None, "interrupted": False, "error": None}
    if enabled:
        from tqdm.auto import tqdm

        state["bar"] = tqdm(total=total, desc=label, unit="step", unit_scale=True, leave=False, file=sys.stderr)

    def cb(done, planned):
        try:
            if guard is not None and guard.pending is not None:
                state["interrupted"] = True
                return 1
            bar = state["bar"]
            if bar is not None:
                bar.update(int(done) - bar.n)
            return 0 if watch is None else watch(int(done))
        except BaseException as exc:  # re-raised by simulate_packed once C has returned
            state["interrupted"] = isinstance(exc, KeyboardInterrupt)
            state["error"] = exc
            return 1

    return _PROGRESS(cb), state


_CALLBACK_AGENT_STEPS = 50_000
"""The progress callback (which also polls for Ctrl-C) runs at least every this many agent-steps
(~20 ms of compiled loop), and at most 200 times per run for small formations."""


def _callback_every(p: PackedProblem) -> int:
    return max(1, min(max(1, p.n_steps // 200), _CALLBACK_AGENT_STEPS // max(1, p.n_agents)))
