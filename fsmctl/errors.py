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
    """Base class of fsmctl's own exceptions."""


class InputError(FsmctlError, ValueError):
    """Bad input (scenario, option, file contents); the message is one line that names what is wrong."""


class ResourceLimitError(InputError):
    """A run would exceed the available memory or disk; the message gives the estimate and the limit."""


class EnvironmentProblem(FsmctlError, OSError):
    """The environment cannot do what was asked (output folder not writable, disk full, scheduler address)."""
