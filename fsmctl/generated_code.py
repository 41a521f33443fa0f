"""Load the code that ``python -m derive`` generated, compiling it once.

``generated/`` (installed as the package data ``fsmctl._generated``) holds the
CasADi C sources of every per-agent function, their serialized CasADi
``Function`` objects, and ``manifest.json``.  On first use the C sources and
the whole-loop driver ``fsmctl/csrc/formation.c`` are compiled with the system
C compiler into one shared library, cached under a folder named by the sha256
of everything that went into it (sources, flags, compiler, CasADi version).
Functions are then loaded with :func:`casadi.external`; the driver is loaded
with :mod:`ctypes` by :mod:`fsmctl.simulator`.

Without a working compiler (or with ``FSMCTL_NO_COMPILE=1``) the serialized
functions are loaded instead, with a :class:`CompilerUnavailableWarning`: the
same derivation, evaluated by CasADi's virtual machine, slower.

Compile flags: the portable :data:`CFLAGS` plus, when the compiler accepts them,
:data:`OPTIMIZE_FLAGS` (``-O3``, direct calls between the generated functions
instead of PLT indirections: ~15 % faster whole-loop runs, bit-identical results
because ``-std=c99`` keeps floating-point contraction off) and
:data:`NATIVE_FLAGS` (``-march=native``).  A library built for the local CPU is
not safe in a cache shared across machines, so the cache key includes the
compiler's resolution of ``-march=native`` (the concrete ``-march``/feature
list, e.g. ``-march=znver3 -mavx2 ...``): another CPU gets its own build.
``FSMCTL_PORTABLE=1`` drops the native and optimisation flags (plain ``CFLAGS``).

Environment: ``FSMCTL_CACHE_DIR`` (default ``$XDG_CACHE_HOME/fsmctl`` or
``~/.cache/fsmctl``), ``CC`` (default ``cc``), ``FSMCTL_NO_COMPILE``, ``FSMCTL_PORTABLE``.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import threading
import warnings
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import casadi as ca

__all__ = [
    "CompilerUnavailableWarning",
    "GeneratedCodeError",
    "generated_dir",
    "manifest",
    "layout",
    "compiled_library",
    "casadi_function",
    "backend",
    "compile_flags",
]

CFLAGS = ("-O2", "-fPIC", "-shared", "-fno-math-errno", "-std=c99")
"""Portable flags: always used (the fallback when the optional flags below are rejected)."""
OPTIMIZE_FLAGS = ("-O3", "-ffp-contract=off", "-fno-semantic-interposition", "-fno-plt")
"""Optional: later ``-O3`` overrides ``-O2``; no FMA contraction (clang contracts by default); direct calls."""
NATIVE_FLAGS = ("-march=native",)
"""Optional: instructions of the build machine's CPU; the cache key includes what ``native`` resolves to."""


class CompilerUnavailableWarning(RuntimeWarning):
    """No C compiler: fsmctl runs the serialized CasADi functions (slower)."""


class GeneratedCodeError(RuntimeError):
    """``generated/`` is missing, inconsistent with its manifest, or failed to compile."""


def generated_dir() -> Path:
    """The folder of generated code (``generated/`` of the source tree or the installed package data)."""
    try:
        path = Path(str(resources.files("fsmctl._generated")))
    except ModuleNotFoundError as exc:  # pragma: no cover - broken installation
        raise GeneratedCodeError("fsmctl._generated is not installed; run `python -m derive`") from exc
    if not (path / "manifest.json").is_file():
        raise GeneratedCodeError(f"{path}/manifest.json not found; run `python -m derive` to generate code")
    return path


@functools.cache
def manifest() -> dict:
    """The parsed ``manifest.json`` of the generated code."""
    return json.loads((generated_dir() / "manifest.json").read_text())


def layout(name: str) -> tuple[str, ...]:
    """A packed-parameter layout from the manifest (``gains``, ``gain_constants``, ``sinusoid_params``)."""
    return tuple(manifest()["layouts"][name])


def _driver_dir() -> Path:
    return Path(__file__).resolve().parent / "csrc"


def _sources() -> list[Path]:
    gen = generated_dir()
    return sorted((gen / "c").glob("*.c")) + sorted(_driver_dir().glob("*.c"))


def _cache_root() -> Path:
    if os.environ.get("FSMCTL_CACHE_DIR"):
        return Path(os.environ["FSMCTL_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "fsmctl"


def _compiler() -> str | None:
    cc = os.environ.get("CC", "cc")
    return shutil.which(cc) or shutil.which("gcc") or shutil.which("clang")


def _compiler_id(cc: str) -> str:
    try:
        return subprocess.run([cc, "--version"], capture_output=True, text=True, timeout=30).stdout.splitlines()[0]
    except (OSError, subprocess.SubprocessError, IndexError):
        return cc


@functools.cache
def _native_target(cc: str) -> str | None:
    """What ``-march=native`` means on this machine for ``cc`` (None if the compiler does not support it).

    ``cc -march=native -### -c`` prints the driver's command line with ``native`` expanded to the
    concrete CPU and feature flags (gcc: ``"-march=znver3" -mavx2 ...``; clang: ``-target-cpu``
    and ``-target-feature`` entries), which is exactly what decides the generated instructions.
    """
    try:
        proc = subprocess.run(
            [cc, "-march=native", "-###", "-x", "c", "-c", os.devnull, "-o", os.devnull],
            capture_output=True,
            text=True,
            timeout=30,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    if proc.returncode != 0:
        return None
    lines = [ln for ln in proc.stderr.splitlines() if "march" in ln or "target-cpu" in ln or "target-feature" in ln]
    words = " ".join(lines).replace('"', " ").split()
    keep = [w for w in words if w.startswith(("-march=", "-m", "+", "-target-cpu")) or w.isidentifier()]
    target = " ".join(w for w in keep if not w.startswith("-mtune")) or None
    if target is None:
        return None
    return f"{platform.machine()} {target}"


def compile_flags(cc: str | None = None) -> tuple[tuple[str, ...], str]:
    """The flags the library is (first) compiled with and the CPU target they depend on (for the cache key).

    Returns ``(flags, target)``; ``target`` is ``"portable"`` when no CPU-specific flag is used.
    """
    cc = cc or _compiler()
    if cc is None or os.environ.get("FSMCTL_PORTABLE"):
        return CFLAGS, "portable"
    native = _native_target(cc)
    if native is None:
        return (*CFLAGS, *OPTIMIZE_FLAGS), "portable"
    return (*CFLAGS, *OPTIMIZE_FLAGS, *NATIVE_FLAGS), native


@dataclass(frozen=True)
class CompiledLibrary:
    path: Path
    key: str
    flags: tuple[str, ...] = CFLAGS
    """compiler flags the library was built with"""


_lock = threading.Lock()


def _check_hashes() -> None:
    gen = generated_dir()
    for rel, digest in manifest()["sha256"].items():
        p = gen / rel
        if not p.is_file():
            raise GeneratedCodeError(f"generated/{rel} listed in the manifest is missing; run `python -m derive`")
        if rel.startswith("c/") and hashlib.sha256(p.read_bytes()).hexdigest() != digest:
            raise GeneratedCodeError(
                f"generated/{rel} does not match its sha256 in manifest.json (edited by hand?); run `python -m derive`"
            )


def _library_key(sources: list[Path], flags: tuple[str, ...], target: str, cc: str) -> str:
    h = hashlib.sha256()
    for p in sources + sorted(_driver_dir().glob("*.h")):
        h.update(p.name.encode())
        h.update(p.read_bytes())
    h.update(" ".join(flags).encode())
    h.update(target.encode())
    h.update(_compiler_id(cc).encode())
    h.update(ca.__version__.encode())
    h.update(sys.platform.encode())
    return h.hexdigest()[:24]


def _build(cc: str, flags: tuple[str, ...], sources: list[Path], target: Path) -> tuple[bool, str]:
    """Compile into ``target`` atomically; ``(ok, message)``."""
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=target.parent, suffix=target.suffix)
    os.close(fd)
    cmd = [cc, *flags, f"-I{generated_dir() / 'c'}", f"-I{_driver_dir()}", *map(str, sources), "-o", tmp, "-lm"]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    except (OSError, subprocess.SubprocessError) as exc:
        Path(tmp).unlink(missing_ok=True)
        return False, f"C compiler {cc} could not run ({exc})"
    if proc.returncode != 0:
        Path(tmp).unlink(missing_ok=True)
        return False, f"compiling the generated code failed:\n{' '.join(cmd)}\n{proc.stderr[-4000:]}"
    os.replace(tmp, target)  # atomic: concurrent processes see a complete file or none
    return True, ""


@functools.cache
def compiled_library() -> CompiledLibrary | None:
    """Compile (once, cached by content hash) and return the shared library, or None without a compiler.

    Tries :func:`compile_flags` first and falls back to the portable :data:`CFLAGS` if the compiler
    rejects the optional flags; the cache key covers sources, flags, CPU target, compiler and CasADi.
    """
    if os.environ.get("FSMCTL_NO_COMPILE"):
        return None
    cc = _compiler()
    if cc is None:
        return None
    _check_hashes()
    sources = _sources()
    suffix = ".dll" if sys.platform == "win32" else ".so"
    flags, target_cpu = compile_flags(cc)
    attempts = [(flags, target_cpu)] + ([(CFLAGS, "portable")] if flags != CFLAGS else [])
    with _lock:
        message = ""
        for k, (fl, tgt) in enumerate(attempts):
            key = _library_key(sources, fl, tgt, cc)
            target = _cache_root() / key / f"libfsmctl{suffix}"
            if target.is_file():
                return CompiledLibrary(target, key, fl)
            ok, message = _build(cc, fl, sources, target)
            if ok:
                return CompiledLibrary(target, key, fl)
            if message.startswith("C compiler") and k == len(attempts) - 1:
                warnings.warn(message, CompilerUnavailableWarning, stacklevel=2)
                return None
        raise GeneratedCodeError(message)


@functools.cache
def _warn_fallback() -> None:
    warnings.warn(
        "no C compiler found (or FSMCTL_NO_COMPILE set): using the serialized CasADi functions of generated/casadi "
        "(same derivation, evaluated by CasADi's virtual machine, about 10-50x slower)",
        CompilerUnavailableWarning,
        stacklevel=3,
    )


def backend() -> str:
    """``"compiled"`` (C, shared library) or ``"casadi-vm"`` (serialized functions)."""
    return "compiled" if compiled_library() is not None else "casadi-vm"


@functools.cache
def casadi_function(name: str) -> ca.Function:
    """A generated per-agent function by name (see ``manifest()['functions']``)."""
    names = [f["name"] for f in manifest()["functions"]]
    if name not in names:
        raise KeyError(f"no generated function {name!r}; available: {', '.join(names)}")
    lib = compiled_library()
    if lib is not None:
        return ca.external(name, str(lib.path))
    _warn_fallback()
    return ca.Function.deserialize((generated_dir() / "casadi" / f"{name}.casadi").read_text())
