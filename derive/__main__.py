"""``python -m derive``: derive, verify and generate code.

Runs the symbolic proofs of :mod:`derive.verify` and the errata checks of
:mod:`derive.errata` (any failure stops with exit code 1), translates the
function catalogue to CasADi and writes ``generated/``.

``--check`` regenerates into a temporary folder instead and exits 1 with a
diff when ``generated/`` is stale.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from .codegen import DEFAULT_OUTPUT, build_functions, check_generated, write_generated
from .errata import errata
from .verify import all_identities


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m derive",
        description="Derive the FSM formation model (Liang et al. 2012), prove its identities, generate CasADi code.",
    )
    p.add_argument("--out", type=Path, default=DEFAULT_OUTPUT, help="output folder (default: %(default)s)")
    p.add_argument(
        "--check", action="store_true", help="do not write; exit 1 with a diff if the output folder is stale"
    )
    p.add_argument("-q", "--quiet", action="store_true", help="print only failures and the final line")
    return p


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    say = (lambda *a: None) if args.quiet else (lambda *a: print(*a, flush=True))
    t0 = time.perf_counter()

    identities = all_identities()
    for r in identities:
        say(f"  {'proved' if r.holds else 'FAILED':6}  {r.id:32} eq {r.equations:12} {r.seconds:5.1f} s")
    failed = [r for r in identities if not r.holds]
    if failed:
        for r in failed:
            print(f"identity {r.id} (eq {r.equations}) does not hold: {r.statement}", file=sys.stderr)
        return 1

    found = errata()
    for e in found:
        say(f"  {'erratum' if e.checked else 'UNCHECKED':9} {e.id:24} eq {e.equation}")
    unchecked = [e for e in found if not e.checked]
    if unchecked:
        for e in unchecked:
            print(f"erratum {e.id} (eq {e.equation}) could not be confirmed", file=sys.stderr)
        return 1

    functions = build_functions()
    kwargs = dict(functions=functions, identities=identities, errata=found)
    if args.check:
        ok, report = check_generated(args.out, **kwargs)
        if not ok:
            sys.stdout.write(report)
            print(f"{args.out} is stale: run `python -m derive` to regenerate", file=sys.stderr)
            return 1
        print(f"{args.out} is current ({len(functions)} functions, {time.perf_counter() - t0:.1f} s)")
        return 0
    manifest = write_generated(args.out, **kwargs)
    print(
        f"wrote {len(manifest['sha256']) + 1} files for {len(functions)} functions to {args.out} "
        f"({time.perf_counter() - t0:.1f} s)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
