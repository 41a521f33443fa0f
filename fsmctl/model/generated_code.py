"""Load the code that ``python -m derive`` generated, compiling it once.

``generated/`` (installed as the package data ``fsmctl._generated``) holds the
CasADi C sources of every per-agent function, their serialized CasADi
``Function`` objects, and ``manifest.json``.  On first use the C sources and
the whole-loop driver ``fsmctl/csrc/formation.c`` are compiled with the system
C compiler into one shared library, cached under a folder named by the sha256
of everything that went into it (sources, flags, compiler, CasADi version).
Functions are then loaded with :func:`casadi.external`; the driver is loaded
with :mod:`ctypes` by :mod:`fsmctl.simulation.simulator`.

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
A native build on a CPU with AVX-512 also gets ``-DFSM_LANES=8`` (:func:`lane_width`): the batched kernels, pow,
sin and cos take 8 agents per call instead of 4, with the same results bit for bit; ``FSMCTL_LANES=4`` or ``8``
chooses the width (benchmarks and tests compare them).

The first compile of a library (model + one law + driver) takes about ten seconds.  Right before it
starts, one INFO record is logged on the ``fsmctl.model.generated_code`` logger (a child of ``"fsmctl"``),
e.g. ``compiling the generated C for law 'fsm' (first use, about 10 s)`` (a law derived from a script, not built
in, is described by its declared doc and its script's name); nothing is logged when the library comes from the
cache.  The ``fsmctl`` command shows it on stderr; in Python or a notebook the standard :mod:`logging` rules
apply: unconfigured, Python shows only warnings, so the notice is shown once a handler takes ``"fsmctl"``'s INFO
records, e.g.::

    import logging
    logging.basicConfig()                               # a handler on the root logger (stderr)
    logging.getLogger("fsmctl").setLevel(logging.INFO)  # fsmctl's INFO records; other libraries stay at WARNING

Environment: ``FSMCTL_CACHE_DIR`` (default ``$XDG_CACHE_HOME/fsmctl`` or
``~/.cache/fsmctl``), ``CC`` (default: the first of ``cc``, ``gcc``, ``clang`` on the ``PATH``; a
``CC`` that is set is used as given, never replaced by another compiler), ``FSMCTL_NO_COMPILE``,
``FSMCTL_PORTABLE``, ``FSMCTL_LANES``.

The cache is verified, repaired and never fatal:

* **What is loaded is what was built.**  A library is compiled into a temporary file
  ``.tmp-<host>-<pid>-<random>-libfsmctl.so`` in its cache folder, renamed into place with
  :func:`os.replace` (other processes see a complete file or none), and then its sha256 is recorded
  beside it in ``libfsmctl.so.sha256`` (``sha256sum`` format, written the same atomic way).  Before a
  cached library is used, its sha256 is checked against that record (before anything maps it: a
  truncated mapped library kills the process with SIGBUS) and it is loaded once with :mod:`ctypes`
  (a damaged ELF raises :class:`OSError` there, not in the simulator).
* **Damage is repaired once.**  A cached library without a record, with another sha256, or that does
  not load is deleted and rebuilt, with a :class:`LibraryCacheWarning`.  If the rebuilt library fails
  the same checks, fsmctl falls back to the CasADi functions with a :class:`CompilerUnavailableWarning`.
* **An unusable cache folder** (cannot be created, is or lies under a file, is read-only) is replaced
  by a private temporary folder: the library is compiled there for this process only, deleted at
  exit, with a :class:`LibraryCacheWarning` (the run keeps the compiled speed but pays a compile).
  A read-only cache that already holds a valid library is simply used.  If the temporary folder
  fails too, fsmctl falls back to the CasADi functions with a :class:`CompilerUnavailableWarning`.
* **A compiler that fails** (``CC`` not found, non-zero exit, killed by a signal, timed out) means the
  CasADi functions, with one :class:`CompilerUnavailableWarning` that carries the compiler's message.
  (If the optional flags are rejected, the portable :data:`CFLAGS` are tried first, as always.)
* **Temporary files of killed builds are removed** whenever the cache is next used: those whose
  process on this host no longer exists, and any older than an hour (a build times out after ten
  minutes).  Private temporary folders (``fsmctl-build-<host>-<pid>-<random>``) of dead processes
  are removed the same way.
* **Concurrent builds** of one library are serialised by an exclusive ``flock`` on its cache folder
  (POSIX; where locking is unavailable, e.g. Windows or some network file systems, processes may
  compile the same library concurrently, and :func:`os.replace` still keeps every file whole).

Size: one concept, from ``generated/`` to a loaded library: the cache key, the locked and atomic build, the
recovery from builds a kill interrupted, and the loading share one cache layout and one lock protocol, and a
change to any of them must be read against the others.
"""

from __future__ import annotations

import atexit
import contextlib
import ctypes
import functools
import hashlib
import json
import logging
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import casadi as ca

from fsmctl.codegen.batched import LANE_WIDTHS
from fsmctl.errors import EnvironmentProblem
from fsmctl.model.generated_paths import GeneratedCodeError, cache_root, generated_dir

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows: no advisory locks, os.replace keeps files whole
    fcntl = None

__all__ = [
    "CompilerUnavailableWarning",
    "LibraryCacheWarning",
    "manifest",
    "layout",
    "compiled_library",
    "casadi_function",
    "law_sx_function",
    "model_sx_function",
    "backend",
    "compile_flags",
    "c_compiler",
    "law_defines",
    "driver_source_dir",
]

_log = logging.getLogger(__name__)
"""``fsmctl.model.generated_code``: the one INFO record before a library is compiled (see the module docstring)."""

CFLAGS = ("-O2", "-fPIC", "-shared", "-fno-math-errno", "-std=c99")
"""Portable flags: always used (the fallback when the optional flags below are rejected)."""
OPTIMIZE_FLAGS = ("-O3", "-ffp-contract=off", "-fno-semantic-interposition", "-fno-plt")
"""Optional: later ``-O3`` overrides ``-O2``; no FMA contraction (clang contracts by default); direct calls."""
NATIVE_FLAGS = ("-march=native",)
"""Optional: instructions of the build machine's CPU; the cache key includes what ``native`` resolves to."""


class CompilerUnavailableWarning(RuntimeWarning):
    """No usable compiled library: fsmctl runs the serialized CasADi functions (slower).

    Issued once per process, with the reason: no C compiler, ``CC`` not found, the compiler failed or
    crashed, or a damaged cached library could not be rebuilt into a working one.

    Examples
    --------
    Turn the fallback into an error, e.g. in a benchmark that must run compiled:

    >>> import warnings
    >>> from fsmctl.model import CompilerUnavailableWarning
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("error", CompilerUnavailableWarning)
    ...     try:
    ...         warnings.warn("no C compiler found", CompilerUnavailableWarning)
    ...     except CompilerUnavailableWarning as exc:
    ...         print("refused:", exc)
    refused: no C compiler found
    """


class LibraryCacheWarning(RuntimeWarning):
    """The library cache had a problem that fsmctl worked around; the compiled library is still used.

    Either a cached library was damaged (missing or wrong sha256 record, unloadable) and was rebuilt,
    or the cache folder cannot be used and the library was compiled in a private temporary folder.

    Examples
    --------
    >>> import warnings
    >>> from fsmctl.model import LibraryCacheWarning
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     warnings.warn("the cache folder is read-only", LibraryCacheWarning)
    >>> caught[0].category.__name__
    'LibraryCacheWarning'
    """


@functools.cache
def manifest() -> dict:
    """The parsed ``manifest.json`` of the generated code.

    Returns
    -------
    dict
        Versions, parameter layouts, every function's signature and the sha256 of every file.

    Examples
    --------
    >>> from fsmctl.model.generated_code import manifest
    >>> "mrp_error" in [f["name"] for f in manifest()["functions"]]
    True
    """
    return json.loads((generated_dir() / "manifest.json").read_text())


def layout(name: str) -> tuple[str, ...]:
    """A packed-parameter layout from the manifest (``wheel``, ``sinusoid_params``).

    Parameters
    ----------
    name : str
        The layout's name.

    Returns
    -------
    tuple of str
        The names of the packed entries, in order.

    Examples
    --------
    >>> from fsmctl.model.generated_code import layout
    >>> layout("wheel")
    ('speed_max', 'viscous', 'coulomb', 'coulomb_band')
    """
    return tuple(manifest()["layouts"][name])


def driver_source_dir() -> Path:
    """The folder of the hand-written C of the engine (``fsmctl/csrc``: formation.c/.h, fsm_pow, fsm_trig)."""
    return Path(__file__).resolve().parent.parent / "csrc"


def default_law_dir() -> Path:
    """The folder of the built-in law the engine flies when none is named (the paper's FSM law).

    Returns
    -------
    pathlib.Path
        ``generated_dir() / "laws" / "fsm"``.
    """
    return generated_dir() / "laws" / "fsm"


def _sources(law_dir: Path) -> list[Path]:
    gen = generated_dir()
    return (
        sorted((gen / "c").glob("*.c")) + sorted((law_dir / "c").glob("*.c")) + sorted(driver_source_dir().glob("*.c"))
    )


TRIGGER_DEFINE = "-DFSM_LAW_TRIGGER"
"""The engine's hook for a law that declares a trigger (:meth:`fsmctl.symbolic.law.LawBuilder.trigger`)."""
WHEELS_DEFINE = "-DFSM_LAW_WHEELS"
"""The engine's hook for a law that commands its wheels (:meth:`fsmctl.symbolic.law.LawBuilder.wheel_torques`)."""


def law_defines(law_dir: Path) -> tuple[str, ...]:
    """The preprocessor flags a law folder's ``law.json`` asks of the engine: :data:`WHEELS_DEFINE` for a law that
    commands its reaction wheels (its ``law_wheels_<model>`` are then compiled in and called), :data:`TRIGGER_DEFINE`
    for a law that declares a trigger; none otherwise (the library of such a law is the one built before either
    existed).

    Parameters
    ----------
    law_dir : pathlib.Path
        The law folder.

    Returns
    -------
    tuple of str
        The flags, in that order.

    Examples
    --------
    >>> from fsmctl.model.generated_code import default_law_dir, law_defines
    >>> law_defines(default_law_dir()), law_defines(default_law_dir().parent / "fsm_event")
    ((), ('-DFSM_LAW_TRIGGER',))
    """
    try:
        meta = json.loads((Path(law_dir) / "law.json").read_text("utf-8"))
    except (OSError, ValueError):
        return ()
    if not isinstance(meta, dict):
        return ()
    return tuple(
        flag for flag, key in ((WHEELS_DEFINE, "wheels"), (TRIGGER_DEFINE, "trigger")) if meta.get(key) is not None
    )


def c_compiler() -> str | None:
    """The C compiler's path: ``$CC`` if set (None if it is not found), else ``cc``, ``gcc`` or ``clang``."""
    cc = os.environ.get("CC")
    if cc:
        return shutil.which(cc)
    return shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")


@functools.cache
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

    Parameters
    ----------
    cc : str or None, optional
        The C compiler; None for the default (``$CC``, else ``cc``, ``gcc`` or ``clang``).

    Returns
    -------
    flags : tuple of str
        :data:`CFLAGS`, plus :data:`OPTIMIZE_FLAGS` and :data:`NATIVE_FLAGS` when available and
        ``FSMCTL_PORTABLE`` is not set, plus ``-DFSM_LANES=8`` where :func:`lane_width` says 8.
    target : str
        ``"portable"`` when no CPU-specific flag is used, else the machine and what ``-march=native`` resolves to.

    Examples
    --------
    >>> from fsmctl.model.generated_code import CFLAGS, compile_flags
    >>> flags, target = compile_flags()
    >>> flags[: len(CFLAGS)] == CFLAGS
    True
    """
    cc = cc or c_compiler()
    if cc is None or os.environ.get("FSMCTL_PORTABLE"):
        return (*CFLAGS, *_lane_flags("portable")), "portable"
    native = _native_target(cc)
    if native is None:
        return (*CFLAGS, *OPTIMIZE_FLAGS, *_lane_flags("portable")), "portable"
    return (*CFLAGS, *OPTIMIZE_FLAGS, *NATIVE_FLAGS, *_lane_flags(native)), native


LANES_VARIABLE = "FSMCTL_LANES"
"""Environment variable that chooses the lane width of a build (one of :data:`fsmctl.codegen.batched.LANE_WIDTHS`)."""


def lane_width(target: str) -> int:
    """``FSM_LANES`` of a build for ``target`` (the CPU part of :func:`compile_flags`' answer).

    8 (one 512-bit register per kernel call) when the CPU has AVX-512F, else 4 (one 256-bit register, and for a
    portable build); :data:`LANES_VARIABLE` overrides both.  It is read when a process first loads a library: set it
    before the first run.  The width changes the speed, never a result: each lane
    performs the same operations (``tests/test_batched_kernels.py`` flies the same runs at both widths).

    Raises
    ------
    fsmctl.errors.EnvironmentProblem
        ``FSMCTL_LANES`` is set to something else than a width of :data:`fsmctl.codegen.batched.LANE_WIDTHS`.

    Examples
    --------
    >>> from fsmctl.model.generated_code import lane_width
    >>> lane_width("x86_64 -march=skylake-avx512 -mavx2 -mavx512f") in (4, 8)  # 8 unless FSMCTL_LANES says 4
    True
    """
    env = os.environ.get(LANES_VARIABLE, "").strip()
    if env:
        if env not in {str(w) for w in LANE_WIDTHS}:
            allowed = " or ".join(map(str, LANE_WIDTHS))
            raise EnvironmentProblem(f"{LANES_VARIABLE}={env!r}: the lane width must be {allowed}")
        return int(env)
    if target == "portable":
        return LANE_WIDTHS[0]
    return LANE_WIDTHS[1] if "-mavx512f" in target.split() or "+avx512f" in target else LANE_WIDTHS[0]


def _lane_flags(target: str) -> tuple[str, ...]:
    """``-DFSM_LANES=w`` unless ``w`` is fsm_pow.h's default (the first of :data:`LANE_WIDTHS`)."""
    width = lane_width(target)
    return () if width == LANE_WIDTHS[0] else (f"-DFSM_LANES={width}",)


@dataclass(frozen=True)
class CompiledLibrary:
    """A verified compiled library in the cache.

    Parameters
    ----------
    path : pathlib.Path
        The shared library.
    key : str
        Its cache key (the sha256 prefix of everything that went into it).
    flags : tuple of str, optional
        The compiler flags it was built with.
    """

    path: Path
    key: str
    flags: tuple[str, ...] = CFLAGS
    """compiler flags the library was built with"""

    @property
    def lanes(self) -> int:
        """``FSM_LANES`` of this build (agents per call of its batched kernels): from its ``-DFSM_LANES`` flag, else
        fsm_pow.h's default; the driver checks the library agrees when it loads it."""
        widths = [int(f.split("=", 1)[1]) for f in self.flags if f.startswith("-DFSM_LANES=")]
        return widths[-1] if widths else LANE_WIDTHS[0]


_lock = threading.Lock()


def _check_hashes(folder: Path | None = None) -> None:
    """Every C file of a generated folder (the model's, or a law's) matches its manifest."""
    gen = generated_dir() if folder is None else folder
    shown = "generated" if folder is None else str(folder)
    listed = manifest() if folder is None else json.loads((folder / "manifest.json").read_text())
    for rel, digest in listed["sha256"].items():
        p = gen / rel
        if not p.is_file():
            raise GeneratedCodeError(f"{shown}/{rel} listed in the manifest is missing; regenerate it")
        if rel.startswith("c/") and hashlib.sha256(p.read_bytes()).hexdigest() != digest:
            raise GeneratedCodeError(
                f"{shown}/{rel} does not match its sha256 in manifest.json (edited by hand?); regenerate it"
            )


def _library_key(sources: list[Path], flags: tuple[str, ...], target: str, cc: str) -> str:
    h = hashlib.sha256()
    for p in sources + sorted(driver_source_dir().glob("*.h")):
        h.update(p.name.encode())
        h.update(p.read_bytes())
    h.update(" ".join(flags).encode())
    h.update(target.encode())
    h.update(_compiler_id(cc).encode())
    h.update(ca.__version__.encode())
    h.update(sys.platform.encode())
    return h.hexdigest()[:24]


# ----------------------------------------------------------------------------- cache files

_LIB_NAME = "libfsmctl" + (".dll" if sys.platform == "win32" else ".so")
_RECORD_SUFFIX = ".sha256"
_BUILD_TIMEOUT_S = 600.0
_STALE_AFTER_S = 3600.0
"""A temporary file older than this is a leftover whatever its pid (a build times out after 600 s)."""
_LOCK_TIMEOUT_S = 900.0
"""How long to wait for another process's build of the same library before building alongside it."""
_TEMP_FILE = re.compile(r"^\.tmp-(?P<host>[A-Za-z0-9_.]*)-(?P<pid>\d+)-")
_PRIVATE_DIR = re.compile(r"^fsmctl-build-(?P<host>[A-Za-z0-9_.]*)-(?P<pid>\d+)-")
_loaded: dict[str, ctypes.CDLL] = {}
"""Libraries verified and loaded by this process (kept so that later loads of the path reuse the handle)."""
_fallback_explained = threading.Event()
"""Set once :func:`compiled_library` has warned why the CasADi functions are used."""


_Attempts = list[tuple[tuple[str, ...], str]]
"""``(flags, cache key)`` pairs to try in order."""


class _Unusable(Exception):
    """Internal: no compiled library can be used in this process; the message says why."""


@dataclass(frozen=True)
class _BuildResult:
    """The outcome of one compiler run."""

    ok: bool
    message: str = ""
    compiler_ran: bool = True
    """False when the compiler could not be started or timed out (no point trying other flags)."""


@functools.cache
def _host_tag() -> str:
    """This machine's name as it appears in temporary file names (no ``-``, at most 64 characters)."""
    return re.sub(r"[^A-Za-z0-9_.]", "_", platform.node() or "host")[:64]


def _record_path(library: Path) -> Path:
    """The sha256 record written beside ``library`` once it is in place."""
    return library.with_name(library.name + _RECORD_SUFFIX)


def _sha256_file(path: Path) -> str:
    """The hex sha256 of a file's contents."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _temp_file(folder: Path, name: str) -> Path:
    """A new empty file ``.tmp-<host>-<pid>-<random>-<name>`` in ``folder`` (recognisable if left behind).

    Raises
    ------
    OSError
        ``folder`` does not exist or is not writable.
    """
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".tmp-{_host_tag()}-{os.getpid()}-", suffix=f"-{name}")
    os.close(fd)
    return Path(tmp)


def _fsync(path: Path) -> None:
    """Flush ``path`` to disk, best effort (so that a power cut cannot leave a renamed but empty file)."""
    with contextlib.suppress(OSError), open(path, "rb+") as f:
        os.fsync(f.fileno())


def _write_atomically(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file and :func:`os.replace`."""
    tmp = _temp_file(path.parent, path.name)
    try:
        tmp.write_text(text)
        tmp.chmod(0o644)  # readable by everyone who may read the library (mkstemp makes it private)
        _fsync(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def _read_record(library: Path) -> str:
    """The sha256 recorded for ``library`` when it was built.

    Raises
    ------
    OSError
        There is no readable record.
    ValueError
        The record is not a sha256.
    """
    words = _record_path(library).read_text().split()
    if not words or not re.fullmatch(r"[0-9a-f]{64}", words[0]):
        raise ValueError("its sha256 record is malformed")
    return words[0]


def _damage(library: Path) -> str | None:
    """Why ``library`` must not be used (None: it matches its record and loads).

    The sha256 is checked before the library is mapped (a truncated mapped library raises SIGBUS); a
    library that passes is loaded with :mod:`ctypes` and kept loaded, so that the loads of
    :mod:`fsmctl.simulation.simulator` and :func:`casadi.external` reuse the verified mapping.
    """
    try:
        recorded = _read_record(library)
    except FileNotFoundError:
        return "no sha256 was recorded for it: built by an older fsmctl, or its build was interrupted"
    except (OSError, ValueError) as exc:
        return f"its sha256 record cannot be used: {exc}"
    try:
        actual = _sha256_file(library)
    except OSError as exc:
        return f"it cannot be read: {exc}"
    if actual != recorded:
        return f"its sha256 is {actual[:12]}..., not the {recorded[:12]}... recorded when it was built"
    try:
        _loaded[str(library)] = ctypes.CDLL(str(library))
    except OSError as exc:
        return f"it cannot be loaded: {exc}"
    return None


def _remove_library(library: Path) -> None:
    """Delete a library and its record.

    Raises
    ------
    OSError
        They exist and cannot be deleted (read-only cache).
    """
    library.unlink(missing_ok=True)
    _record_path(library).unlink(missing_ok=True)


# ----------------------------------------------------------------------------- leftovers of killed builds


def _pid_alive(pid: int) -> bool:
    """Whether process ``pid`` exists on this machine (True when that cannot be told)."""
    if pid <= 0:
        return False
    if sys.platform == "win32":  # pragma: no cover - os.kill(pid, 0) would terminate the process there
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # PermissionError: it exists, owned by another user
        return True
    return True


def _is_stale_temp_file(entry: os.DirEntry, host: str, pid: int) -> bool:
    """A temporary file is stale if older than :data:`_STALE_AFTER_S`, or if its process here is gone."""
    try:
        age = time.time() - entry.stat(follow_symlinks=False).st_mtime
    except OSError:
        return False
    return age > _STALE_AFTER_S or (host == _host_tag() and not _pid_alive(pid))


def _entries(folder: Path | str) -> list[os.DirEntry]:
    """The entries of ``folder`` ([] if it cannot be listed)."""
    try:
        with os.scandir(folder) as it:
            return list(it)
    except OSError:
        return []


def _is_folder(entry: os.DirEntry) -> bool:
    """Whether ``entry`` is a folder (not a link to one); False if that cannot be told."""
    try:
        return entry.is_dir(follow_symlinks=False)
    except OSError:
        return False


def _remove_stale_temp_files(root: Path) -> None:
    """Delete the temporary files that killed builds left in the cache ``root`` and its key folders."""
    folders = [root, *(Path(e.path) for e in _entries(root) if _is_folder(e))]
    for folder in folders:
        for entry in _entries(folder):
            match = _TEMP_FILE.match(entry.name)
            if match and _is_stale_temp_file(entry, match["host"], int(match["pid"])):
                with contextlib.suppress(OSError):
                    os.unlink(entry.path)


def _remove_dead_private_dirs() -> None:
    """Delete the private build folders (see :func:`_private_dir`) of processes on this host that are gone."""
    for entry in _entries(tempfile.gettempdir()):
        match = _PRIVATE_DIR.match(entry.name)
        if match and match["host"] == _host_tag() and not _pid_alive(int(match["pid"])):
            shutil.rmtree(entry.path, ignore_errors=True)


def _private_dir() -> Path:
    """A new temporary folder for this process's library, deleted at exit.

    Raises
    ------
    OSError
        No temporary folder can be created.
    """
    _remove_dead_private_dirs()
    path = Path(tempfile.mkdtemp(prefix=f"fsmctl-build-{_host_tag()}-{os.getpid()}-"))
    atexit.register(shutil.rmtree, path, ignore_errors=True)
    return path


# ----------------------------------------------------------------------------- building


@contextlib.contextmanager
def _folder_lock(folder: Path) -> Iterator[None]:
    """Hold an exclusive ``flock`` on ``folder`` while building or checking its library (best effort).

    Without advisory locks (Windows, some network file systems) or after :data:`_LOCK_TIMEOUT_S`, the
    body runs unlocked: concurrent builds then only waste time, since files are replaced atomically.
    """
    fd = _acquire_lock(folder)
    try:
        yield
    finally:
        if fd is not None:
            os.close(fd)  # releases the lock


def _acquire_lock(folder: Path) -> int | None:
    """A descriptor of ``folder`` holding an exclusive ``flock`` on it, or None if no lock was taken."""
    if fcntl is None:  # pragma: no cover - Windows
        return None
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return None
    deadline = time.monotonic() + _LOCK_TIMEOUT_S
    while True:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return fd
        except BlockingIOError:
            if time.monotonic() > deadline:
                break
            time.sleep(0.05)
        except OSError:  # e.g. NFS without flock emulation
            break
    os.close(fd)
    return None


def math_include_args() -> list[str]:
    """Compiler arguments that make every source's ``pow``, ``sin`` and ``cos`` fsmctl's (``fsmctl/csrc/fsm_pow.h``
    and ``fsm_trig.h``, defined in ``fsm_pow.c`` and ``fsm_trig.c``): the scalar and the batched paths of the
    library give the same bits."""
    return ["-include", str(driver_source_dir() / "fsm_pow.h"), "-include", str(driver_source_dir() / "fsm_trig.h")]


def _build(cc: str, flags: tuple[str, ...], sources: list[Path], target: Path) -> _BuildResult:
    """Compile into ``target``: a temporary file, :func:`os.replace`, then the sha256 record.

    Raises
    ------
    OSError
        The folder of ``target`` cannot be written (the compiler's own failures are in the result).
    """
    tmp = _temp_file(target.parent, target.name)
    includes = [f"-I{d}" for d in dict.fromkeys(p.parent for p in sources)]
    cmd = [cc, *flags, *includes, *math_include_args(), *map(str, sources), "-o", str(tmp), "-lm"]
    try:
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=_BUILD_TIMEOUT_S)
        except (OSError, subprocess.SubprocessError) as exc:
            return _BuildResult(False, f"the C compiler {cc} could not run ({exc})", compiler_ran=False)
        if proc.returncode != 0:
            how = f"killed by signal {-proc.returncode}" if proc.returncode < 0 else f"exit status {proc.returncode}"
            shown = [
                cc,
                *flags,
                f"<{len(sources)} sources of generated/c, the law and fsmctl/csrc>",
                "-o",
                str(tmp),
                "-lm",
            ]
            detail = proc.stderr[-4000:].strip() or "(no message from the compiler)"
            return _BuildResult(False, f"compiling the generated code failed ({how}): {' '.join(shown)}\n{detail}")
        tmp.chmod(0o755)  # loadable by everyone who shares the cache (mkstemp made the file private)
        _fsync(tmp)
        digest = _sha256_file(tmp)
        os.replace(tmp, target)  # atomic: concurrent processes see a complete file or none
        _write_atomically(_record_path(target), f"{digest}  {target.name}\n")
        return _BuildResult(True)
    finally:
        tmp.unlink(missing_ok=True)


def _cached(library: Path) -> str | None:
    """Check a cached ``library``: None if it is verified and loaded, else why not (a damaged one is deleted).

    Returns ``""`` when nothing is cached yet, else the damage (see :func:`_damage`).

    Raises
    ------
    OSError
        A damaged library cannot be deleted.
    """
    if not library.exists() and not _record_path(library).exists():
        return ""
    problem = _damage(library)
    if problem is not None:
        _remove_library(library)
    return problem


def _check_built(library: Path) -> None:
    """Verify a library just built; an unusable one is deleted.

    Raises
    ------
    _Unusable
        It does not match its record or does not load.
    """
    problem = _damage(library)
    if problem is not None:
        with contextlib.suppress(OSError):
            _remove_library(library)
        raise _Unusable(f"the freshly compiled library {library} cannot be used ({problem})")


def _library_in(
    root: Path, cc: str, sources: list[Path], attempts: _Attempts, announce: Callable[[], None] = lambda: None
) -> CompiledLibrary:
    """The verified library in ``root`` for the first of ``attempts`` (``(flags, key)``) that builds.

    ``announce`` is called right before the compiler runs (not when a cached library is used).

    A damaged cached library is deleted and rebuilt (once); that is reported in one warning: a
    :class:`LibraryCacheWarning` if the rebuild works, else in the message of :class:`_Unusable`.

    Raises
    ------
    OSError
        ``root`` cannot be used (cannot be created or written).
    _Unusable
        The compiler fails, or what it built does not verify.
    """
    damaged = ""
    message = "no compile flags to try"
    try:
        for flags, key in attempts:
            folder = root / key
            folder.mkdir(parents=True, exist_ok=True)
            with _folder_lock(folder):
                library = folder / _LIB_NAME
                problem = _cached(library)
                if problem is None:
                    return CompiledLibrary(library, key, flags)
                if problem and not damaged:
                    damaged = f"the cached compiled library {library} was unusable ({problem})"
                announce()
                result = _build(cc, flags, sources, library)
                if result.ok:
                    _check_built(library)
                    if damaged:
                        warnings.warn(f"{damaged}; rebuilt it", LibraryCacheWarning, stacklevel=4)
                    return CompiledLibrary(library, key, flags)
                if not result.compiler_ran:
                    raise _Unusable(result.message)
                message = result.message
        raise _Unusable(message)
    except _Unusable as exc:
        if damaged:
            raise _Unusable(f"{damaged}; deleted it, but rebuilding it failed: {exc}") from None
        raise


def _library_anywhere(
    cc: str, sources: list[Path], attempts: _Attempts, announce: Callable[[], None] = lambda: None
) -> CompiledLibrary:
    """The library from the cache or, if the cache cannot be used, from a private temporary folder.

    ``announce`` is passed to :func:`_library_in` (called before each compiler run).

    Raises
    ------
    _Unusable
        No library can be built or loaded anywhere.
    """
    try:
        root = cache_root()
    except RuntimeError as exc:  # Path.home(): no home folder to hold the default cache
        problem = f"there is no folder for the compiled-library cache ({exc})"
    else:
        _remove_stale_temp_files(root)
        try:
            return _library_in(root, cc, sources, attempts, announce)
        except OSError as exc:
            problem = f"the compiled-library cache {root} cannot be used ({exc})"
    try:
        library = _library_in(_private_dir(), cc, sources, attempts, announce)
    except OSError as exc:
        raise _Unusable(f"{problem}, nor can a temporary folder ({exc})") from None
    except _Unusable as exc:
        raise _Unusable(f"{problem}; compiling in a temporary folder instead: {exc}") from None
    warnings.warn(
        f"{problem}: compiled the library in a private temporary folder, {library.path.parent}, for this process "
        "only (deleted at exit); set FSMCTL_CACHE_DIR to a writable folder to compile it once",
        LibraryCacheWarning,
        stacklevel=3,  # the caller of compiled_library()
    )
    return library


def _warn_unavailable(reason: str) -> None:
    """The one warning that the CasADi functions replace the compiled library, and why."""
    _fallback_explained.set()
    warnings.warn(
        f"{reason}\nfsmctl uses the serialized CasADi functions of generated/casadi instead "
        "(same derivation, evaluated by CasADi's virtual machine, about 10-50x slower)",
        CompilerUnavailableWarning,
        stacklevel=3,
    )


def compiled_library(law_dir: Path | None = None) -> CompiledLibrary | None:
    """Compile (once, cached by content hash) and return the verified shared library, or None.

    The library holds the model's generated functions, one law's (``law_dir``, default the paper's FSM law)
    and the whole-loop driver.  Compiling takes about 10 s; right before the compiler runs, one INFO record is
    logged on the ``fsmctl.model.generated_code`` logger (nothing when the library comes from the cache).

    Tries :func:`compile_flags` first and falls back to the portable :data:`CFLAGS` if the compiler
    rejects the optional flags; the cache key covers sources, flags, CPU target, compiler and CasADi.
    The returned library matches the sha256 recorded when it was built and has been loaded once;
    damage is repaired by one rebuild and an unusable cache by a private build (see the module
    docstring).

    Parameters
    ----------
    law_dir : pathlib.Path or None, optional
        The law folder (``LawCode.folder``); None for the paper's FSM law.

    Returns
    -------
    CompiledLibrary or None
        The library (``path``, cache ``key``, ``flags``), or None when the CasADi functions are to be used: no
        compiler or ``FSMCTL_NO_COMPILE`` (silently; :func:`casadi_function` warns), or a failure, with a
        :class:`CompilerUnavailableWarning`.

    Raises
    ------
    GeneratedCodeError
        ``generated/`` does not match its manifest (regenerate it with ``python -m derive``).

    Examples
    --------
    >>> from fsmctl.model import compiled_library
    >>> lib = compiled_library()
    >>> lib is None or (lib.path.name.startswith("libfsmctl") and lib.flags[:2] == ("-O2", "-fPIC"))
    True
    """
    return _compiled_library((law_dir or default_law_dir()).resolve())


def _compile_notice(law_dir: Path) -> Callable[[], None]:
    """A callable that logs, on its first call only, that the generated C of ``law_dir``'s law is compiled.

    One record per library, however many compiler runs it takes (optional flags rejected, private folder).
    """
    said = threading.Event()

    def announce() -> None:
        if said.is_set():
            return
        said.set()
        try:  # the name the law declares (a derived script's folder is named by a hash)
            declared = json.loads((law_dir / "law.json").read_text("utf-8"))
            name = str(declared["name"])
        except (OSError, ValueError, KeyError, TypeError):
            declared, name = {}, law_dir.name
        if generated_dir().resolve() in law_dir.resolve().parents:  # a built-in law: `fsmctl laws` describes it
            _log.info("compiling the generated C for law %r (first use, about 10 s)", name)
            return
        # a law of a derivation script (the user's, or a variant a study flies): say what it is and where it is from
        about = "; ".join(str(declared[k]) for k in ("doc", "source") if declared.get(k))
        _log.info("compiling the generated C for law %r (%s; first use, about 10 s)", name, about or law_dir)

    return announce


@functools.cache
def _compiled_library(law_dir: Path) -> CompiledLibrary | None:
    if os.environ.get("FSMCTL_NO_COMPILE"):
        return None
    cc = c_compiler()
    if cc is None:
        if os.environ.get("CC"):
            _warn_unavailable(f"the C compiler CC={os.environ['CC']!r} was not found")
        return None
    _check_hashes()
    _check_hashes(law_dir)
    sources = _sources(law_dir)
    flags, target_cpu = compile_flags(cc)
    options = [(flags, target_cpu)] + ([(CFLAGS, "portable")] if flags != CFLAGS else [])
    law_flags = law_defines(law_dir)
    options = [((*fl, *law_flags), tgt) for fl, tgt in options]
    attempts = [(fl, _library_key(sources, fl, tgt, cc)) for fl, tgt in options]
    with _lock:
        try:
            lib = _library_anywhere(cc, sources, attempts, _compile_notice(law_dir))
        except _Unusable as exc:
            _warn_unavailable(str(exc))
            return None
        _libraries.setdefault(law_dir, lib)
        return lib


_libraries: dict[Path, CompiledLibrary] = {}
"""The libraries :func:`compiled_library` has returned in this process, by law folder (:func:`model_library`)."""


def model_library() -> CompiledLibrary | None:
    """A compiled library for the model's own functions and the metrics' sample loops.

    Every law's library holds the model's generated functions and ``fsmctl/csrc/metrics.c``, compiled from the same
    sources with the same flags, so any of them gives the same bits: one this process already has (the law it flies)
    is used, and only a process that has none compiles the paper law's (:func:`compiled_library`), so that a run of
    another law does not compile the paper law's library for its metrics.

    Returns
    -------
    CompiledLibrary or None
        The library, or None when the CasADi functions are to be used (see :func:`compiled_library`).

    Examples
    --------
    >>> from fsmctl.model.generated_code import model_library
    >>> lib = model_library()
    >>> lib is None or lib.path.is_file()
    True
    """
    known = dict(_libraries)  # a copy: another thread may be adding one
    default = default_law_dir().resolve()
    if default in known:
        return known[default]
    return next(iter(known.values()), None) or compiled_library()


@functools.cache
def _warn_fallback() -> None:
    if _fallback_explained.is_set():  # compiled_library() already said why, in one warning
        return
    warnings.warn(
        "no C compiler found (or FSMCTL_NO_COMPILE set): using the serialized CasADi functions of generated/casadi "
        "(same derivation, evaluated by CasADi's virtual machine, about 10-50x slower)",
        CompilerUnavailableWarning,
        stacklevel=3,
    )


def backend() -> str:
    """How the generated functions are evaluated in this process.

    Returns
    -------
    str
        ``"compiled"`` (C, shared library) or ``"casadi-vm"`` (serialized functions, without a C compiler or with
        ``FSMCTL_NO_COMPILE=1``).

    Examples
    --------
    >>> from fsmctl.model import backend, compiled_library
    >>> backend() == ("compiled" if compiled_library() is not None else "casadi-vm")
    True
    """
    return "compiled" if compiled_library() is not None else "casadi-vm"


@functools.cache
def casadi_function(name: str) -> ca.Function:
    """A generated per-agent function of the model by name (see ``manifest()['functions']``).

    Parameters
    ----------
    name : str
        The function's name.

    Returns
    -------
    casadi.Function
        The compiled function, or the serialized one (with a :class:`CompilerUnavailableWarning`).

    Raises
    ------
    KeyError
        No generated function has that name.

    Examples
    --------
    The MRP attitude error ``sigma_e`` of ``sigma`` relative to ``sigma_d``:

    >>> from fsmctl.model.generated_code import casadi_function
    >>> f = casadi_function("mrp_error")
    >>> f.name_in(), f.name_out()
    (['sigma', 'sigma_d'], ['sigma_e'])
    >>> float(f([0.1, 0.0, 0.0], [0.1, 0.0, 0.0])[0])
    0.0
    """
    names = [f["name"] for f in manifest()["functions"]]
    if name not in names:
        raise KeyError(f"no generated function {name!r}; available: {', '.join(names)}")
    lib = model_library()  # the law's library where this process flies one (every library holds the model's)
    if lib is not None:
        return ca.external(name, str(lib.path))
    _warn_fallback()
    return ca.Function.deserialize((generated_dir() / "casadi" / f"{name}.casadi").read_text())


@functools.cache
def model_sx_function(name: str) -> ca.Function:
    """A generated per-agent function of the model as its serialized CasADi ``SX`` graph.

    What automatic differentiation needs (the compiled function of :func:`casadi_function` takes numbers only);
    the same graph the C code was generated from.

    Parameters
    ----------
    name : str
        The function's name (see ``manifest()['functions']``).

    Returns
    -------
    casadi.Function
        The deserialized ``SXFunction``.

    Raises
    ------
    KeyError
        No generated function has that name.

    Examples
    --------
    >>> import casadi as ca
    >>> from fsmctl.model.generated_code import model_sx_function
    >>> f = model_sx_function("mrp_error")
    >>> sigma = ca.SX.sym("sigma", 3)
    >>> ca.jacobian(f(sigma, ca.DM.zeros(3)), sigma).shape
    (3, 3)
    """
    names = [f["name"] for f in manifest()["functions"]]
    if name not in names:
        raise KeyError(f"no generated function {name!r}; available: {', '.join(names)}")
    return ca.Function.deserialize((generated_dir() / "casadi" / f"{name}.casadi").read_text())


@functools.cache
def _law_casadi_function(law_dir: Path, name: str) -> ca.Function:
    lib = compiled_library(law_dir)
    if lib is not None:
        return ca.external(name, str(lib.path))
    _warn_fallback()
    return ca.Function.deserialize((law_dir / "casadi" / f"{name}.casadi").read_text())


@functools.cache
def _law_sx_function(law_dir: Path, name: str) -> ca.Function:
    path = law_dir / "casadi" / f"{name}.casadi"
    if not path.is_file():
        raise KeyError(f"law folder {law_dir}: no generated function {name!r}")
    return ca.Function.deserialize(path.read_text())


def law_sx_function(law_dir: Path, name: str) -> ca.Function:
    """A law's generated function as its serialized CasADi ``SX`` graph, callable on CasADi symbols.

    What automatic differentiation and symbolic composition need (the compiled function of
    :func:`law_casadi_function` takes numbers only); the same graph the C code was generated from.

    Parameters
    ----------
    law_dir : pathlib.Path
        The law folder.
    name : str
        The function's name (``law_constants``, ``law_local_paper``, ...; the folder's ``manifest.json``).

    Returns
    -------
    casadi.Function
        The deserialized ``SXFunction``.

    Raises
    ------
    KeyError
        The folder has no function of that name.

    Examples
    --------
    The paper's sliding variable (Liang et al. 2012, eq 13) as a function of the attitude, differentiated:

    >>> import casadi as ca
    >>> from fsmctl.model.generated_code import default_law_dir, law_sx_function
    >>> f = law_sx_function(default_law_dir(), "law_local_paper")
    >>> f.name_in()[:3], f.name_out()
    (['t', 'sigma', 'omega'], ['broadcast', 'cache'])
    """
    return _law_sx_function(Path(law_dir).resolve(), name)


def law_casadi_function(law_dir: Path, name: str) -> ca.Function:
    """A law's generated function (``law_constants``, ``law_local_paper``, ...) from its folder.

    Parameters
    ----------
    law_dir : pathlib.Path
        The law folder.
    name : str
        The function's name.

    Returns
    -------
    casadi.Function
        The compiled function, or the serialized one (with a :class:`CompilerUnavailableWarning`).
    """
    return _law_casadi_function(Path(law_dir).resolve(), name)


def _clear_libraries() -> None:
    """Forget the libraries of this process (a test that moves the cache): the memo and :func:`model_library`'s."""
    _compiled_library.cache_clear()
    _libraries.clear()


compiled_library.cache_clear = _clear_libraries  # type: ignore[attr-defined]
