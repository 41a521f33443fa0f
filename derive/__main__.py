"""``python -m derive``: derive, verify and generate the project's code.

Runs the symbolic proofs of :mod:`fsmctl.proofs.identities` and the errata checks of
:func:`fsmctl.proofs.errata.all_errata` (any failure stops with exit code 1), translates the model's function
catalogue (``derive/catalogue.py``) to CasADi and writes ``generated/``, then derives every built-in law
(``derive/laws/*.py``, the same kind of derivation script a user writes) into ``generated/laws/<name>/``.

``--check`` regenerates into a temporary folder instead and exits 1 with a diff when ``generated/`` (or any
built-in law) is stale.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import time
from pathlib import Path

from derive.catalogue import SINUSOID_LAYOUT, WHEEL_LAYOUT, function_catalogue
from derive.laws import BUILTIN_LAWS
from fsmctl.codegen.laws import write_law
from fsmctl.codegen.writer import build_functions, check_generated, write_generated
from fsmctl.proofs.errata import all_errata
from fsmctl.proofs.identities import all_identities
from fsmctl.symbolic.law import law_variants

DEFAULT_OUTPUT = Path(__file__).resolve().parent.parent / "generated"

INIT = '''"""CasADi-generated code for fsmctl.

DO NOT EDIT: every file in this folder is written by ``python -m derive`` from
the symbolic model in ``derive/`` (and ``laws/<name>/`` from ``derive/laws/<name>.py``);
``manifest.json`` files list them with their sha256.  Installed as the package data ``fsmctl._generated``.
"""
'''


LAW_SOURCES: dict[str, str] = {}
"""law name -> its derivation script (filled by :func:`builtin_law_variants`)."""


def builtin_law_variants():
    """``{name: LawVariants}`` of the built-in laws, from their derivation scripts."""
    out = {}
    for module_name in BUILTIN_LAWS:
        module = importlib.import_module(f"derive.laws.{module_name}")
        variants = law_variants(module.law, getattr(module, "EXTRA_FUNCTIONS", ()))
        out[variants.name] = variants
        LAW_SOURCES[variants.name] = f"derive/laws/{module_name}.py"
    return out


def write_everything(out: Path, *, functions, identities, errata_found, laws) -> int:
    """Write the model folder and every law folder; return the number of functions written."""
    write_generated(
        out,
        functions=functions,
        layouts={
            "wheel": list(WHEEL_LAYOUT),
            "sinusoid_params": list(SINUSOID_LAYOUT),
        },
        documents={
            "identities.json": [
                {"id": r.id, "equations": r.equations, "statement": r.statement, "holds": r.holds, "method": r.method}
                for r in identities
            ],
            "errata.json": [e.to_dict() for e in errata_found],
        },
        init_text=INIT,
    )
    count = len(functions)
    for name, variants in laws.items():
        manifest = write_law(out / "laws" / name, variants, source=LAW_SOURCES[name])
        count += len(manifest["functions"])
    return count


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m derive",
        description="Derive the formation model and the built-in laws, prove the identities, generate CasADi code.",
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

    found = all_errata()  # the errata of the proofs, then those of the re-audit against the print
    for e in found:
        say(f"  {'erratum' if e.checked else 'UNCHECKED':9} {e.id:24} eq {e.equation}")
    unchecked = [e for e in found if not e.checked]
    if unchecked:
        for e in unchecked:
            print(f"erratum {e.id} (eq {e.equation}) could not be confirmed", file=sys.stderr)
        return 1

    functions = build_functions(function_catalogue())
    laws = builtin_law_variants()
    say(f"  laws: {', '.join(laws)}")
    kwargs = dict(functions=functions, identities=identities, errata_found=found, laws=laws)
    if args.check:
        ok, report = check_generated(args.out, write=lambda fresh: write_everything(fresh, **kwargs))
        if not ok:
            sys.stdout.write(report)
            print(f"{args.out} is stale: run `python -m derive` to regenerate", file=sys.stderr)
            return 1
        print(
            f"{args.out} is current ({len(functions)} model functions, {len(laws)} laws, {time.perf_counter() - t0:.1f} s)"
        )
        return 0
    count = write_everything(args.out, **kwargs)
    print(f"wrote {count} functions ({len(laws)} laws) to {args.out} ({time.perf_counter() - t0:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
