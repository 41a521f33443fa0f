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

Environment: ``FSMCTL_CACHE_DIR`` (default ``$XDG_CACHE_HOME/fsmctl`` or
``~/.cache/fsmctl``), ``CC`` (default ``cc``), ``FSMCTL_NO_COMPILE``.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
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
]

CFLAGS = ("-O2", "-fPIC", "-shared", "-fno-math-errno", "-std=c99")


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


@dataclass(frozen=True)
class CompiledLibrary:
    path: Path
    key: str


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


@functools.cache
def compiled_library() -> CompiledLibrary | None:
    """Compile (once, cached by content hash) and return the shared library, or None without a compiler."""
    if os.environ.get("FSMCTL_NO_COMPILE"):
        return None
    cc = _compiler()
    if cc is None:
        return None
    _check_hashes()
    sources = _sources()
    h = hashlib.sha256()
    for p in sources + [*_driver_dir().glob("*.h")]:
        h.update(p.name.encode())
        h.update(p.read_bytes())
    h.update(" ".join(CFLAGS).encode())
    h.update(_compiler_id(cc).encode())
    h.update(ca.__version__.encode())
    h.update(sys.platform.encode())
    key = h.hexdigest()[:24]
    target_dir = _cache_root() / key
    suffix = ".dll" if sys.platform == "win32" else ".so"
    target = target_dir / f"libfsmctl{suffix}"
    with _lock:
        if not target.is_file():
            target_dir.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=target_dir, suffix=suffix)
            os.close(fd)
            cmd = [
                cc,
                *CFLAGS,
                f"-I{generated_dir() / 'c'}",
                f"-I{_driver_dir()}",
                *map(str, sources),
                "-o",
                tmp,
                "-lm",
            ]
            try:
                proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
            except (OSError, subprocess.SubprocessError) as exc:
                Path(tmp).unlink(missing_ok=True)
                warnings.warn(f"C compiler {cc} could not run ({exc})", CompilerUnavailableWarning, stacklevel=2)
                return None
            if proc.returncode != 0:
                Path(tmp).unlink(missing_ok=True)
                raise GeneratedCodeError(f"compiling the generated code failed:\n{' '.join(cmd)}\n{proc.stderr[-4000:]}")
            os.replace(tmp, target)  # atomic: concurrent processes see a complete file or none
    return CompiledLibrary(target, key)


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
    return ca.Function.load(str(generated_dir() / "casadi" / f"{name}.casadi"))
