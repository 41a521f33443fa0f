"""``fsmctl laws``: the control laws fsmctl can fly, with their parameters.

``fsmctl laws`` lists the built-in laws (:func:`fsmctl.model.laws.builtin_laws`); ``fsmctl laws L`` shows one
law, ``L`` being a built-in name, a derivation script ``FILE.py`` (derived on first use into the cache) or a
folder written by ``fsmctl derive`` (:func:`fsmctl.model.laws.resolve_law`).  For each: what it is, its
reference, what an agent broadcasts to its neighbours, its own states, and its parameters (name, default,
unit, admissible range, meaning): the names ``[controller]`` keys and ``--set NAME=VALUE`` use.

Exit codes (:data:`EXIT_CODES`, :mod:`fsmctl.cli.exit_codes`): 0 listed, 2 an unknown law or a script that does
not derive (one line).
"""

from __future__ import annotations

import argparse
import json

from fsmctl.cli.exit_codes import epilog

__all__ = ["add_parser", "run", "law_to_dict", "format_law", "parameter_table", "EXIT_CODES"]

EXIT_CODES = {
    0: "listed",
    2: "an unknown law, a derivation script that does not derive, or another usage or input error (one line on "
    "stderr, never a traceback)",
}
"""What ``fsmctl laws``' exit codes mean where they differ from :data:`fsmctl.cli.exit_codes.MEANINGS`."""


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``fsmctl laws`` (the built-in control laws, or one law, with their parameters).

    Parameters
    ----------
    subparsers : argparse subparsers action
        From :func:`fsmctl.cli.main.build_parser`.

    Returns
    -------
    argparse.ArgumentParser
        The ``laws`` parser, with ``func = run``.
    """
    p = subparsers.add_parser(
        "laws",
        help="list the built-in control laws and their parameters, or show one law",
        description="List the built-in control laws (doc, reference, broadcast, states and a table of parameters: "
        "name, default, unit, range, meaning), or show one law: a built-in name, a derivation script FILE.py or a "
        "folder written by fsmctl derive. Parameters are set by name in a scenario's [controller] table or with "
        "fsmctl simulate --set NAME=VALUE.",
        epilog=epilog(EXIT_CODES),
    )
    p.add_argument("law_name", nargs="?", default=None, metavar="NAME|FILE.py|DIR", help="show this law only")
    p.add_argument("--json", action="store_true", help="print JSON (a list of laws, or one law's object)")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``fsmctl laws``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options (``law_name``, ``json``).

    Returns
    -------
    int
        0; an unknown law or a script that does not derive raises :class:`fsmctl.model.laws.LawError`
        (an :class:`fsmctl.errors.InputError`, exit 2).
    """
    from fsmctl.model.laws import builtin_laws, resolve_law
    from fsmctl.outputs import jsonable

    if args.law_name is not None:
        law = resolve_law(args.law_name)
        if args.json:
            print(json.dumps(jsonable(law_to_dict(law)), indent=2, allow_nan=False))
        else:
            print(format_law(law))
        return 0
    laws = builtin_laws()
    if args.json:
        print(json.dumps(jsonable([law_to_dict(law) for law in laws.values()]), indent=2, allow_nan=False))
        return 0
    print(f"built-in laws: {', '.join(laws)}")
    for law in laws.values():
        print()
        print(format_law(law))
    print()
    print("fly one: fsmctl simulate --law NAME [--set PARAM=VALUE]; write your own: fsmctl derive FILE.py")
    return 0


def law_to_dict(law) -> dict:
    """A law as plain data (the ``--json`` output).

    Parameters
    ----------
    law : fsmctl.model.laws.LawCode
        From :func:`~fsmctl.model.laws.resolve_law` or :func:`~fsmctl.model.laws.builtin_laws`.

    Returns
    -------
    dict
        ``name``, ``doc``, ``reference``, ``source`` (its derivation script, :meth:`~fsmctl.model.laws.LawCode.script`:
        a built-in law's installed file), ``folder``, ``builtin``, ``broadcast`` (name, size),
        ``states`` (as declared), ``lyapunov`` (whether one is declared), the declarations ``discontinuity``
        (``where``, ``smoothed_by``, or None), ``presets`` (name, default, options, doc), ``loop_rates`` (their
        doc, or None), ``paper_theorems`` (the paper's symbol -> parameter name, or None) and ``trigger`` (its
        condition, check period and doc, or None: event-triggered communication), and ``parameters``
        (name, default, size, unit, minimum, maximum, exclusive bounds, range text, choices, tunable, doc).
    """
    return {
        "name": law.name,
        "doc": law.doc,
        "reference": law.reference,
        "source": law.script(),
        "folder": str(law.folder),
        "builtin": law.builtin,
        "broadcast": {"name": law.broadcast_name, "size": law.n_broadcast},
        "states": [dict(s) for s in law.states],
        "lyapunov": law.has_lyapunov,
        "discontinuity": None
        if law.discontinuity is None
        else {"where": law.discontinuity.where, "smoothed_by": law.discontinuity.smoothed_by},
        "presets": [
            {
                "name": g.name,
                "default": g.default,
                "options": {o: {k: list(v) for k, v in sets.items()} for o, sets in g.options.items()},
                "doc": g.doc,
            }
            for g in law.presets
        ],
        "loop_rates": law.loop_rates_doc,
        "paper_theorems": None if law.paper_theorems is None else dict(law.paper_theorems.parameters),
        "trigger": None
        if law.trigger is None
        else {"condition": law.trigger.condition, "period": law.trigger.period, "doc": law.trigger.doc},
        "parameters": [
            {
                "name": p.name,
                "default": p.default_text() if p.choices else (list(p.default) if p.size > 1 else p.default[0]),
                "size": p.size,
                "unit": p.unit,
                "minimum": p.minimum,
                "maximum": p.maximum,
                "exclusive_minimum": p.exclusive_minimum,
                "exclusive_maximum": p.exclusive_maximum,
                "range": p.range_text(),
                "choices": list(p.choices),
                "tunable": p.tunable,
                "doc": p.doc,
            }
            for p in law.parameters
        ],
    }


def _table(header: tuple[str, ...], rows: list[tuple[str, ...]], indent: str = "    ") -> list[str]:
    widths = [max(len(r[k]) for r in (header, *rows)) for k in range(len(header) - 1)]
    out = []
    for r in (header, *rows):
        out.append(indent + "  ".join(c.ljust(w) for c, w in zip(r, widths, strict=False)) + "  " + r[-1])
    return [line.rstrip() for line in out]


def format_law(law) -> str:
    """A law as text: what it is, its reference, broadcast, states and its table of parameters.

    Parameters
    ----------
    law : fsmctl.model.laws.LawCode
        The law.

    Returns
    -------
    str
        Several lines, no trailing newline.
    """
    where = "built in" if law.builtin else str(law.folder)
    lines = [f"{law.name}: {law.doc}" if law.doc else law.name]
    if law.reference:
        lines.append(f"  reference: {law.reference}")
    lines.append(f"  source:    {law.script() or '?'} ({where})")
    lines.append(f"  broadcast: {law.broadcast_name} ({law.n_broadcast} values sent to the neighbours)")
    if law.states:
        states = "; ".join(
            f"{s['name']} ({s['size']}{', ' + s['unit'] if s.get('unit') else ''}, initial "
            f"{', '.join(f'{v:g}' for v in s['initial'])}){': ' + s['doc'] if s.get('doc') else ''}"
            for s in law.states
        )
        lines.append(f"  states:    {states}")
    else:
        lines.append("  states:    none")
    lines.append(f"  lyapunov:  {'declared (fsmctl prove --law checks it)' if law.has_lyapunov else 'none declared'}")
    d = law.discontinuity
    if d is not None:
        smooth = f" unless {d.smoothed_by} > 0" if d.smoothed_by is not None else ""
        lines.append(f"  discontinuous: at {d.where}{smooth}")
    for g in law.presets:
        options = ", ".join(
            o
            + (
                " (" + ", ".join(f"{k} = {', '.join(f'{x:g}' for x in v)}" for k, v in sets.items()) + ")"
                if sets
                else ""
            )
            for o, sets in g.options.items()
        )
        lines.append(f"  presets:   {g.name} = {options}; default {g.default}{': ' + g.doc if g.doc else ''}")
    if law.loop_rates_doc is not None:
        lines.append(f"  loop rates: {law.loop_rates_doc}")
    if law.paper_theorems is not None:
        lines.append(
            "  paper:     eqs 13-19 of Liang et al. 2012: Theorems 1-2 apply (fsmctl prove --law checks eq 20)"
        )
    if law.trigger is not None:
        every = "every control instant" if law.trigger.period is None else f"every {law.trigger.period:g} s"
        lines.append(f"  trigger:   sends when {law.trigger.condition} (checked {every}; needs a control period)")
    if not law.parameters:
        lines.append("  parameters: none")
        return "\n".join(lines)
    lines.append(f"  parameters ({len(law.parameters)}; {law.n_params} numbers in the packed vector):")
    lines += parameter_table(law.parameters)
    return "\n".join(lines)


def parameter_table(parameters, indent: str = "    ") -> list[str]:
    """The lines of a parameter table: name, default, unit, range, doc.

    Parameters
    ----------
    parameters : sequence
        :class:`fsmctl.model.laws.LawParameterInfo` or :class:`fsmctl.symbolic.law.LawParameter` objects.
    indent : str
        Prefix of every line.

    Returns
    -------
    list of str
        A header line, then one line per parameter.
    """
    rows = [(p.name, p.default_text(), p.unit or "-", p.range_text(), p.doc) for p in parameters]
    return _table(("name", "default", "unit", "range", "doc"), rows, indent)
