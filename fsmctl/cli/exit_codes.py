"""The exit codes of ``fsmctl`` and what each one means: the one source of the ``exit codes:`` epilogs.

:func:`fsmctl.cli.main.main` decides the codes (this module only names and explains them); every subcommand's
parser ends with :func:`epilog`, which lists every code with its generic meaning (:data:`MEANINGS`) or the
subcommand's own wording of it, so ``fsmctl X --help`` and the documentation pages generated from the parser
(sphinx-argparse) say the same.  :func:`table` gives the same rows as data, for a documentation table.

====  =========================================================================================
0     success (what success is depends on the command: the run finished, the report was written,
      every check of ``fsmctl prove`` came out as documented, ...)
1     the command reports a failure (a check of ``fsmctl prove`` differs from the documented finding,
      or with ``--strict`` any check fails; a simulation failed; a folder is stale), or an internal
      error (one line; ``--debug`` shows the traceback)
2     usage, input or environment error: one line on stderr, never a traceback
130   interrupted (SIGINT, Ctrl-C): finished outputs are kept, partial files are not written
143   terminated (SIGTERM): as for 130
====  =========================================================================================

The expected result: a command exits 0 when its result is the expected one.  For ``fsmctl prove`` that is the
documented finding (the verdict each claim has on the paper's scenario, recorded with the claim:
:attr:`fsmctl.proofs.claims.Claim.expected`), so Theorem 2's delta failing for the paper, a finding (``docs/findings.md``),
exits 0; ``--strict`` exits 1 on any failed check.  A user's law (``prove --law``) has no documented finding: any
failed check exits 1.
"""

from __future__ import annotations

from collections.abc import Mapping

__all__ = [
    "EXIT_OK",
    "EXIT_FAILED",
    "EXIT_INPUT",
    "EXIT_INTERRUPTED",
    "EXIT_TERMINATED",
    "MEANINGS",
    "INTERNAL_ERROR",
    "epilog",
    "table",
]

EXIT_OK, EXIT_FAILED, EXIT_INPUT, EXIT_INTERRUPTED, EXIT_TERMINATED = 0, 1, 2, 130, 143

INTERNAL_ERROR = "an internal error (a bug: one line on stderr; --debug shows the traceback)"
"""How every command's code 1 ends: :func:`fsmctl.cli.main.main` returns 1 for an unexpected exception."""

MEANINGS: dict[int, str] = {
    EXIT_OK: "success",
    EXIT_FAILED: INTERNAL_ERROR,
    EXIT_INPUT: "usage, input or environment error: a bad option, scenario file or law, an unreadable input, an "
    "unusable output folder, not enough memory (one line on stderr, never a traceback)",
    EXIT_INTERRUPTED: "interrupted (SIGINT, Ctrl-C): finished outputs are kept, partial files are not written",
    EXIT_TERMINATED: "terminated (SIGTERM): as for 130",
}
"""The generic meaning of every exit code :func:`fsmctl.cli.main.main` can return, in increasing order."""


def table(specific: Mapping[int, str] | None = None) -> list[tuple[int, str]]:
    """Every exit code with its meaning for one command.

    Parameters
    ----------
    specific : mapping of int to str, optional
        The command's own wording of a code (0: what success is; 1: the failure it reports, before
        :data:`INTERNAL_ERROR`); codes not given keep their generic meaning (:data:`MEANINGS`).

    Returns
    -------
    list of (int, str)
        One row per code of :data:`MEANINGS`, in increasing order.

    Raises
    ------
    ValueError
        ``specific`` names a code :func:`fsmctl.cli.main.main` never returns.

    Examples
    --------
    >>> [code for code, _ in table()]
    [0, 1, 2, 130, 143]
    >>> table({1: "a claim fails"})[1]
    (1, 'a claim fails, or an internal error (a bug: one line on stderr; --debug shows the traceback)')
    """
    specific = dict(specific or {})
    unknown = set(specific) - set(MEANINGS)
    if unknown:
        raise ValueError(f"fsmctl never exits with {sorted(unknown)}; its codes are {sorted(MEANINGS)}")
    rows = []
    for code, generic in MEANINGS.items():
        text = specific.get(code, generic)
        if code == EXIT_FAILED and code in specific:
            text = f"{text}, or {INTERNAL_ERROR}"
        rows.append((code, text))
    return rows


def epilog(specific: Mapping[int, str] | None = None, *, text: str = "") -> str:
    """A subcommand's epilog: ``text`` (if any), then the ``exit codes:`` list of :func:`table`.

    The list is a bullet list (``- CODE: meaning``, one line each), read the same by ``--help``
    (:class:`fsmctl.cli.options.HelpFormatter` wraps each item) and by reStructuredText (sphinx-argparse renders
    the epilog of each command page).

    Parameters
    ----------
    specific : mapping of int to str, optional
        The command's own wording of some codes (see :func:`table`).
    text : str
        What comes before the exit codes (paragraphs separated by blank lines; indented lines are kept as
        they are by :class:`fsmctl.cli.options.HelpFormatter`).

    Returns
    -------
    str
        The epilog, one line per code.

    Examples
    --------
    >>> print(epilog({0: "listed"}).splitlines()[:3])
    ['exit codes:', '', '- 0: listed']
    """
    lines = [f"- {code}: {meaning}" for code, meaning in table(specific)]
    block = "exit codes:\n\n" + "\n".join(lines)
    return f"{text.rstrip()}\n\n{block}" if text.strip() else block
