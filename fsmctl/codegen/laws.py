"""Generate a control law's code: the contract functions, their batched kernels, ``law.json`` and a manifest.

The same generator as the project's ``generated/`` (:func:`fsmctl.codegen.writer.write_generated`), so a law
folder has the same do-not-edit headers, serialized CasADi functions and sha256 manifest:

    law.json                        the law's parameters (units, ranges, defaults), states, broadcast, cache,
                                    and its declarations (discontinuity, presets, loop rates, paper theorems)
    c/law_constants.c/.h            per-agent constants
    c/law_local_{paper,exact}.c/.h  broadcast and cache (fsmctl.symbolic.law)
    c/law_control_{paper,exact}.c/.h  torque and law-state derivative
    c/law_loop_rates.c/.h           bounds on the loop's rates, if the law declares them
    c/law_wheels_{paper,exact}.c/.h the per-wheel motor torque commands, if the law commands its wheels
    c/law_trigger.c/.h              when the agent sends its broadcast, if the law declares a trigger
    c/law_batched.c/.h              the lane-batched kernels of the local and control functions
    casadi/*.casadi                 the same functions for the no-compiler fallback and the plug-in
    manifest.json

:func:`load_derivation_script` imports a derivation script (a file defining ``law(error_model)``).
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
import traceback
from pathlib import Path

from fsmctl.codegen.batched import UnsupportedInstructionError
from fsmctl.codegen.casadi_bridge import UnsupportedExpressionError
from fsmctl.codegen.formats import LAW_FILE, law_format
from fsmctl.codegen.writer import GeneratedFunction, build_functions, check_generated, write_generated
from fsmctl.symbolic.law import Law, LawDefinitionError, LawVariants, law_variants

__all__ = [
    "LAW_FILE",
    "law_functions",
    "write_law",
    "check_law",
    "load_derivation_script",
]


def law_functions(variants: LawVariants) -> list[GeneratedFunction]:
    """The CasADi functions of a law: constants, then local and control for each error model.

    The per-agent contract of :mod:`fsmctl.symbolic.law`: ``law_constants``, ``law_local_<model>`` and
    ``law_control_<model>`` for ``model`` in ``paper``, ``exact``, then ``law_loop_rates`` if the law declares
    :meth:`~fsmctl.symbolic.law.LawBuilder.loop_rates`, then ``law_wheels_paper`` and ``law_wheels_exact`` if it
    declares :meth:`~fsmctl.symbolic.law.LawBuilder.wheel_torques`, then ``law_trigger`` if it declares
    :meth:`~fsmctl.symbolic.law.LawBuilder.trigger`, then the script's ``EXTRA_FUNCTIONS``.

    Parameters
    ----------
    variants : LawVariants
        The law for both error models (:func:`load_derivation_script` or
        :func:`fsmctl.symbolic.law.law_variants`).

    Returns
    -------
    list of GeneratedFunction
        The translated functions, in that order.

    Raises
    ------
    LawDefinitionError
        An expression has no exact CasADi translation (e.g. an unsupported SymPy function).

    Examples
    --------
    >>> from fsmctl.symbolic.law import LawBuilder, law_variants
    >>> def law(error_model):
    ...     b = LawBuilder("p", error_model, doc="proportional, no coordination")
    ...     K = b.parameter("K", 2.0, unit="N m", minimum=0.0, doc="attitude gain")
    ...     e = b.error_state()
    ...     b.broadcast("sigma_e", e.sigma_e)
    ...     b.torque(-K * e.sigma_e)
    ...     return b.build()
    >>> variants = law_variants(law)
    >>> functions = law_functions(variants)
    >>> [f.spec.name for f in functions]
    ['law_constants', 'law_local_paper', 'law_control_paper', 'law_local_exact', 'law_control_exact']

    The applied torque is ``u = -K sigma_e`` limited to ``u_max`` per axis (here ``K = 2``, ``u_max = 0.5``,
    the reference at rest, empty cache and constants, no neighbours):

    >>> control = functions[2].function
    >>> print(control(0, [0.1, 0.2, 0.3], 0, [], 0, 0, 0, 0, [2.0], [], [0.1, 0.2, 0.3], 0, [0, 0, 0], 0, 0.5)[0])
    [-0.2, -0.4, -0.5]
    """
    specs = [variants.paper.constants_spec()]
    for law in variants:
        specs += [law.local_spec(), law.control_spec()]
    rates = variants.paper.loop_rates_spec()  # law_loop_rates(params), if the law declares loop_rates()
    specs += [] if rates is None else [rates]
    specs += [s for s in (law.wheels_spec() for law in variants) if s is not None]  # law_wheels_<model>, if any
    trigger = variants.paper.trigger_spec()  # law_trigger(t, broadcast, broadcast_sent, ...), if declared
    specs += ([] if trigger is None else [trigger]) + list(variants.extra)
    try:
        return build_functions(specs)
    except UnsupportedExpressionError as exc:
        raise LawDefinitionError(
            f"{variants.name}: {exc} (see fsmctl.codegen.casadi_bridge for what translates)"
        ) from exc


def _metadata(law: Law, source: str) -> dict:
    meta = law.metadata()
    return {"format": law_format(meta), "source": source, **meta}


def write_law(
    out_dir: Path | str, variants: LawVariants, *, source: str, generator: str = "python -m derive", functions=None
) -> dict:
    """Write a law's folder (see the module docstring) and return its manifest.

    What ``fsmctl derive FILE.py --out DIR`` writes (through :func:`fsmctl.model.laws.derive_script`).

    Parameters
    ----------
    out_dir : path
        The folder (created if missing; ``c/`` and ``casadi/`` inside it are replaced).
    variants : LawVariants
        The law for both error models.
    source : str
        What the do-not-edit headers and ``law.json`` name as the law's source (e.g. the script's name).
    generator : str
        What the headers name as the generator.
    functions : list of GeneratedFunction, optional
        Already translated functions (default :func:`law_functions` of ``variants``).

    Returns
    -------
    dict
        The manifest (also written to ``manifest.json``).

    Raises
    ------
    LawDefinitionError
        The graph holds an operation the SIMD kernels cannot print exactly.

    Examples
    --------
    >>> from fsmctl.symbolic.law import LawBuilder, law_variants
    >>> def law(error_model):
    ...     b = LawBuilder("p", error_model, doc="proportional, no coordination")
    ...     K = b.parameter("K", 2.0, unit="N m", minimum=0.0, doc="attitude gain")
    ...     e = b.error_state()
    ...     b.broadcast("sigma_e", e.sigma_e)
    ...     b.torque(-K * e.sigma_e)
    ...     return b.build()
    >>> variants = law_variants(law)
    >>> manifest = write_law("p_law", variants, source="p.py")
    >>> [f["name"] for f in manifest["functions"]]
    ['law_constants', 'law_local_paper', 'law_control_paper', 'law_local_exact', 'law_control_exact']
    >>> import json
    >>> json.load(open("p_law/law.json"))["parameters"][0]["unit"]
    'N m'
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    try:
        return write_generated(
            out,
            functions=law_functions(variants) if functions is None else functions,
            documents={LAW_FILE: _metadata(variants.paper, source)},
            generator=generator,
            source=source,
            batched_name="law_batched",
        )
    except UnsupportedInstructionError as exc:
        raise LawDefinitionError(
            f"{variants.name}: {exc}; the SIMD kernels know + - * / pow sqrt exp log sin cos tan asin acos atan "
            "atan2 sinh cosh tanh floor ceil abs sign min max, comparisons and Piecewise"
        ) from exc


def check_law(reference: Path | str, variants: LawVariants, *, source: str, generator: str = "python -m derive"):
    """``(identical, report)``: whether ``reference`` is what :func:`write_law` writes now.

    What ``fsmctl derive FILE.py --out DIR --check`` runs; it writes nothing but a temporary folder.

    Parameters
    ----------
    reference : path
        The law folder to compare with.
    variants : LawVariants
        The law for both error models.
    source : str
        The source name the folder was written with.
    generator : str
        The generator name it was written with.

    Returns
    -------
    tuple of (bool, str)
        Whether the folder is current, and a report of the differences (a unified diff; empty when current).

    Examples
    --------
    >>> from fsmctl.symbolic.law import LawBuilder, law_variants
    >>> def law(error_model):
    ...     b = LawBuilder("p", error_model, doc="proportional, no coordination")
    ...     K = b.parameter("K", 2.0, unit="N m", minimum=0.0, doc="attitude gain")
    ...     e = b.error_state()
    ...     b.broadcast("sigma_e", e.sigma_e)
    ...     b.torque(-K * e.sigma_e)
    ...     return b.build()
    >>> variants = law_variants(law)
    >>> _ = write_law("p_law", variants, source="p.py")
    >>> check_law("p_law", variants, source="p.py")
    (True, '')
    >>> identical, report = check_law("p_law", variants, source="renamed.py")
    >>> identical, "differs: law.json" in report.splitlines()  # law.json names the source
    (False, True)
    """
    return check_generated(
        reference, write=lambda fresh, **kw: write_law(fresh, variants, source=source, generator=generator)
    )


def load_derivation_script(path: Path | str) -> LawVariants:
    """Import a derivation script and build its law for both error models.

    The script defines ``law(error_model) -> Law`` (see :mod:`fsmctl.symbolic.law`) and may define
    ``EXTRA_FUNCTIONS`` (``FunctionSpec`` objects generated beside the contract, e.g. for plots).

    Parameters
    ----------
    path : path
        The script (a ``.py`` file).

    Returns
    -------
    LawVariants
        ``.paper`` and ``.exact``: the law built for each error model (checked to agree).

    Raises
    ------
    LawDefinitionError
        The file is missing, is not Python, or defines no ``law``; or the script raises an exception or calls
        ``sys.exit`` while it is imported or in ``law(error_model)`` (one line naming the script and the line).
        A :class:`KeyboardInterrupt` propagates.

    Examples
    --------
    >>> _ = open("p.py", "w").write(
    ...     "from fsmctl.symbolic import LawBuilder\\n"
    ...     "def law(error_model):\\n"
    ...     "    b = LawBuilder('p', error_model, doc='proportional')\\n"
    ...     "    e = b.error_state()\\n"
    ...     "    b.broadcast('sigma_e', e.sigma_e)\\n"
    ...     "    b.torque(-b.parameter('K', 2.0) * e.sigma_e)\\n"
    ...     "    return b.build()\\n"
    ... )
    >>> variants = load_derivation_script("p.py")
    >>> variants.name, variants.exact.error_model.value, [p.name for p in variants.paper.parameters]
    ('p', 'exact', ['K'])
    >>> load_derivation_script("missing.py")
    Traceback (most recent call last):
    ...
    fsmctl.symbolic.law.LawDefinitionError: missing.py: no such derivation script

    A script that exits ends neither the command nor the caller's interpreter:

    >>> _ = open("quits.py", "w").write("import sys\\nsys.exit(0)\\n")
    >>> load_derivation_script("quits.py")
    Traceback (most recent call last):
    ...
    fsmctl.symbolic.law.LawDefinitionError: quits.py:2: importing the script called sys.exit(0); a derivation script defines law(error_model) and must not exit
    """
    path = Path(path)
    if not path.is_file():
        raise LawDefinitionError(f"{path}: no such derivation script")
    if path.suffix != ".py":
        raise LawDefinitionError(f"{path}: a derivation script is a .py file")
    digest = hashlib.sha256(str(path.resolve()).encode()).hexdigest()[:12]
    name = f"fsmctl_user_law_{digest}"
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise LawDefinitionError(f"{path}: cannot be imported")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        # compiled from its text, not through the import system's bytecode cache: a .pyc is trusted while the
        # source keeps its size and its modification time in whole seconds, so an edit within one second (4.0 ->
        # 5.0) would run the old law; and no __pycache__ is written beside the user's script
        exec(compile(path.read_bytes(), str(path), "exec", dont_inherit=True), module.__dict__)
    except LawDefinitionError:
        raise
    except SyntaxError as exc:
        raise LawDefinitionError(f"{path}:{exc.lineno}: syntax error: {exc.msg}") from exc
    except (Exception, SystemExit) as exc:  # KeyboardInterrupt propagates (Ctrl-C: exit 130)
        raise _script_failed(path, "importing the script", exc) from exc
    finally:
        sys.modules.pop(name, None)
    build = getattr(module, "law", None)
    if not callable(build):
        raise LawDefinitionError(f"{path}: defines no function law(error_model) (see fsmctl.symbolic.law)")
    try:
        return law_variants(build, getattr(module, "EXTRA_FUNCTIONS", ()))
    except LawDefinitionError:
        raise
    except (Exception, SystemExit) as exc:
        raise _script_failed(path, "law(error_model)", exc) from exc


def _script_failed(path: Path, stage: str, exc: BaseException) -> LawDefinitionError:
    """One line for an exception or an exit raised in a derivation script: the script, its line, what happened.

    The line is that of the innermost frame of the script itself in the traceback (none if the script's code is not
    on it).  A ``sys.exit`` becomes an error too: a script ends neither ``fsmctl`` nor the caller's interpreter.
    """
    line = None
    script = os.path.realpath(path)
    for frame, lineno in traceback.walk_tb(exc.__traceback__):
        if os.path.realpath(frame.f_code.co_filename) == script:
            line = lineno
    where = f"{path}:{line}" if line is not None else f"{path}"
    if isinstance(exc, SystemExit):
        return LawDefinitionError(
            f"{where}: {stage} called sys.exit({exc.code!r}); a derivation script defines law(error_model) and "
            "must not exit"
        )
    return LawDefinitionError(f"{where}: {stage} failed: {type(exc).__name__}: {exc}")
