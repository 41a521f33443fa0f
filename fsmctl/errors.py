"""fsmctl's exception hierarchy: the one place that says which failures are the user's input or environment.

The command line maps these to exit codes (:mod:`fsmctl.cli.main`); library code raises them and never the
command line's own types:

==================================  =====================================================  ====
exception                           meaning                                                exit
==================================  =====================================================  ====
:class:`InputError`                 bad input: a scenario, an option, a file's contents     2
:class:`ResourceLimitError`         a run would need more memory (or disk) than there is    2
:class:`EnvironmentProblem`         the machine refuses: unwritable/full folder, bad        2
                                    scheduler address, unreadable file
``SimulationError`` (simulator)     the run itself failed (non-finite state, ...)           1
==================================  =====================================================  ====

``OSError`` raised while reading inputs or writing outputs is an environment problem too (exit 2).
"""

from __future__ import annotations

__all__ = ["FsmctlError", "InputError", "ResourceLimitError", "EnvironmentProblem"]


class FsmctlError(Exception):
    """Base class of fsmctl's own exceptions.

    Examples
    --------
    >>> import fsmctl
    >>> try:
    ...     fsmctl.paper_scenario("9")
    ... except FsmctlError as exc:
    ...     print(type(exc).__name__)
    ScenarioError
    """


class InputError(FsmctlError, ValueError):
    """Bad input (scenario, option, file contents); the message is one line that names what is wrong.

    Also a :class:`ValueError`; the command line exits 2 on it.

    Examples
    --------
    >>> import fsmctl
    >>> try:
    ...     fsmctl.paper_scenario("1").replace(simulation={"dt": -1.0})
    ... except InputError as exc:
    ...     print(exc)
    simulation.dt: must be > 0.0, got -1.0
    """


class ResourceLimitError(InputError):
    """A run would exceed the available memory or disk; the message gives the estimate and the limit.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.model.problem import pack
    >>> from fsmctl.simulation.simulator import check_output_memory
    >>> try:
    ...     check_output_memory(pack(fsmctl.paper_scenario("1")), available=10**6)
    ... except ResourceLimitError as exc:
    ...     print(str(exc)[:29], "raise output_interval" in str(exc))
    this run's results would need True
    """


class EnvironmentProblem(FsmctlError, OSError):
    """The environment cannot do what was asked (output folder not writable, disk full, scheduler address, an
    environment variable such as ``FSMCTL_LANES`` set to a value fsmctl does not know).

    Also an :class:`OSError` (with ``errno`` and ``filename``); the command line exits 2 on it.

    Examples
    --------
    >>> from fsmctl.outputs import write_text
    >>> _ = write_text("a-file", "x")
    >>> try:
    ...     write_text("a-file/inside.txt", "y")  # a file where a folder should be
    ... except EnvironmentProblem as exc:
    ...     print(exc.strerror)
    cannot write a-file/inside.txt: File exists
    """
