"""Compile an exported C library: with the strict flags of the export's promise, into objects or a shared library.

One place where fsmctl runs a C compiler on an export (the tests' strict-flag checks, the software-in-the-loop
check, the FMUs, the benchmarks).  The compiler is the engine's (:func:`fsmctl.model.generated_code.c_compiler`:
``$CC``, else ``cc``, ``gcc`` or ``clang``) unless one is given.
"""

from __future__ import annotations

import subprocess
from collections.abc import Sequence
from pathlib import Path

from fsmctl.errors import EnvironmentProblem
from fsmctl.export.c_library import CLibrary, ExportError, strict_flags
from fsmctl.model.generated_code import c_compiler

__all__ = ["BUILD_TIMEOUT_S", "BuildError", "compile_export", "compiler_path", "run_compiler"]

BUILD_TIMEOUT_S = 300.0
"""The longest a compiler call on an export may take (s)."""


class BuildError(ExportError):
    """The compiler refused the exported code (its first error line is in the message).

    Examples
    --------
    >>> from fsmctl.export import write_c_library
    >>> lib = write_c_library("pid", "pid_c", control_period=0.01)
    >>> _ = (lib.folder / "pid_law.c").write_text("not C")
    >>> try:
    ...     compile_export(lib, "pid.so")
    ... except BuildError as exc:
    ...     print(str(exc).split(":")[0])
    cc refused the export in pid_c
    """


def compiler_path(compiler: str | None = None) -> str:
    """``compiler``, else the engine's (:func:`fsmctl.model.generated_code.c_compiler`).

    Parameters
    ----------
    compiler : str, optional
        A compiler to use as given.

    Returns
    -------
    str
        The compiler's path (or the name given).

    Raises
    ------
    EnvironmentProblem
        No C compiler.

    Examples
    --------
    >>> Path(compiler_path("gcc")).name
    'gcc'
    """
    cc = compiler or c_compiler()
    if not cc:
        raise EnvironmentProblem("no C compiler found (install gcc or clang, or set CC)")
    return cc


def run_compiler(command: Sequence[str], what: str) -> None:
    """Run one compiler command line; the compiler's first error line becomes a :class:`BuildError`.

    Parameters
    ----------
    command : sequence of str
        The command line (the compiler first).
    what : str
        What is compiled, for the message (``"the export in DIR"``).

    Raises
    ------
    BuildError
        The compiler refused the sources.
    EnvironmentProblem
        The compiler could not be run.

    Examples
    --------
    >>> import tempfile
    >>> src = Path(tempfile.mkdtemp()) / "bad.c"
    >>> _ = src.write_text("not C")
    >>> try:
    ...     run_compiler([compiler_path(), "-c", str(src), "-o", str(src.with_suffix(".o"))], "bad.c")
    ... except BuildError as exc:
    ...     print(str(exc).split(":")[0].split()[-1])
    bad.c
    """
    try:
        done = subprocess.run(list(command), capture_output=True, text=True, timeout=BUILD_TIMEOUT_S)
    except (OSError, subprocess.SubprocessError) as exc:
        raise EnvironmentProblem(f"{command[0]}: could not run the compiler ({exc})") from None
    if done.returncode != 0:
        first = next((ln for ln in done.stderr.splitlines() if "error" in ln), done.stderr.strip()[:300])
        raise BuildError(f"{Path(command[0]).name} refused {what}: {first}")


def compile_export(
    library: CLibrary,
    output: str | Path,
    *,
    compiler: str | None = None,
    shared: bool = True,
    extra_flags: Sequence[str] = (),
    extra_sources: Sequence[Path] = (),
    include_dirs: Sequence[Path] = (),
) -> Path:
    """Compile ``library``'s sources (and ``extra_sources``) with its strict flags.

    Parameters
    ----------
    library : CLibrary
        What :func:`fsmctl.export.write_c_library` wrote.
    output : path
        The shared library (``shared``) or the folder of the object files.
    compiler : str, optional
        The compiler (default: the engine's).
    shared : bool
        A position-independent shared library (for ctypes), else one object file per source in ``output``.
    extra_flags, extra_sources, include_dirs
        Added to the command line (e.g. ``-O2``, ``-ffreestanding``, a test harness).

    Returns
    -------
    pathlib.Path
        ``output``.

    Raises
    ------
    BuildError
        The compiler failed (a warning is an error: ``-Werror``).
    EnvironmentProblem
        No C compiler.

    Examples
    --------
    >>> from fsmctl.export import write_c_library, compile_export
    >>> lib = write_c_library("fsm", "fsm_c", control_period=0.01, precision="float32")
    >>> compile_export(lib, "objects", shared=False, extra_flags=["-O2", "-ffreestanding"]).name
    'objects'
    >>> sorted(p.name for p in Path("objects").iterdir())
    ['fsm.o', 'fsm_law.o', 'fsm_math.o']
    """
    cc = compiler_path(compiler)
    output = Path(output)
    flags = [*strict_flags(library.precision), *extra_flags, f"-I{library.folder}", *(f"-I{d}" for d in include_dirs)]
    sources = [str(s) for s in (*library.sources, *extra_sources)]
    if shared:
        output.parent.mkdir(parents=True, exist_ok=True)
        commands = [[cc, *flags, "-fPIC", "-shared", *sources, "-o", str(output)]]
    else:
        output.mkdir(parents=True, exist_ok=True)
        commands = [[cc, *flags, "-c", s, "-o", str(output / (Path(s).stem + ".o"))] for s in sources]
    for command in commands:
        run_compiler(command, f"the export in {library.folder}")
    return output
