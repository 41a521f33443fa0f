"""The compiled-library cache (fsmctl/generated_code.py) survives damage and unusable environments.

A damaged library can kill the process that maps it (SIGBUS), so every case runs a short simulation
in a fresh ``python -c`` subprocess with its own ``FSMCTL_CACHE_DIR`` and ``TMPDIR`` under
``tmp_path``; the subprocess reports its backend, final state and the warnings of
``fsmctl.model.generated_code`` as JSON.  One good build (a module fixture) is copied into the cases that
need a built cache, so that only the cases that must compile do.  Oracle: the compiled run of that
good build; a rebuilt library must give the same final state and the CasADi fallback the same to 1e-12.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import platform
import random
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from fsmctl.model import generated_code

_PROGRAM = r"""
import json, sys, warnings
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    exec(sys.argv[1])
    import fsmctl
    from fsmctl.model.generated_code import compiled_library
    scenario = fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.05, "output_interval": 0.05})
    r = fsmctl.simulate(scenario)
    lib = compiled_library()
print("RESULT " + json.dumps({
    "backend": r.backend,
    "library": None if lib is None else str(lib.path),
    "state": [r.sigma[-1].tolist(), r.omega[-1].tolist()],
    "warnings": [[w.category.__name__, str(w.message)] for w in caught
                 if w.category.__module__ == "fsmctl.model.generated_code"],
}))
"""
# only the warnings of fsmctl.model.generated_code are counted: the scenario's own are another subject
_TIMEOUT_S = 300
_LIB = "libfsmctl.dll" if sys.platform == "win32" else "libfsmctl.so"


@dataclass
class Run:
    """What one subprocess run of :data:`_PROGRAM` reported."""

    returncode: int
    stderr: str
    backend: str | None = None
    library: str | None = None
    state: np.ndarray | None = None
    warnings: list[tuple[str, str]] | None = None

    def assert_clean(self) -> None:
        """Exit status 0, a result, and no traceback."""
        bus = " (SIGBUS)" if self.returncode == -getattr(signal, "SIGBUS", 0) else ""
        assert self.returncode == 0, f"exit status {self.returncode}{bus}:\n{self.stderr[-3000:]}"
        assert "Traceback" not in self.stderr, self.stderr[-3000:]
        assert self.backend is not None, self.stderr[-3000:]


def _run(cache: Path | str, tmp: Path, *, prelude: str = "", **env: str) -> Run:
    """Run :data:`_PROGRAM` with ``FSMCTL_CACHE_DIR=cache``, ``TMPDIR=tmp`` and ``env``."""
    tmp.mkdir(parents=True, exist_ok=True)
    environ = {k: v for k, v in os.environ.items() if k not in ("FSMCTL_NO_COMPILE", "CC")}
    environ.update(FSMCTL_CACHE_DIR=str(cache), TMPDIR=str(tmp), **env)
    proc = subprocess.run(
        [sys.executable, "-c", _PROGRAM, prelude],
        env=environ,
        capture_output=True,
        text=True,
        timeout=_TIMEOUT_S,
    )
    run = Run(proc.returncode, proc.stderr)
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")]
    if lines:
        out = json.loads(lines[-1].removeprefix("RESULT "))
        run.backend, run.library = out["backend"], out["library"]
        run.state = np.array(out["state"])
        run.warnings = [tuple(w) for w in out["warnings"]]
    return run


def _library(cache: Path) -> Path:
    """The one built library in ``cache``."""
    (lib,) = cache.glob(f"*/{_LIB}")
    return lib


def _record_matches(lib: Path) -> bool:
    """Whether ``lib`` matches the sha256 recorded beside it."""
    recorded = lib.with_name(lib.name + ".sha256").read_text().split()[0]
    return hashlib.sha256(lib.read_bytes()).hexdigest() == recorded


def _temp_files(cache: Path) -> list[Path]:
    """Files in the key folders of ``cache`` other than the libraries and their records."""
    return sorted(p for p in cache.glob("*/*") if p.name not in (_LIB, _LIB + ".sha256"))


def _dead_pid() -> int:
    """The pid of a process that has exited (and been reaped)."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> tuple[Path, Run]:
    """One good build: its cache folder and its (compiled) run, the oracle of every case."""
    base = tmp_path_factory.mktemp("good")
    run = _run(base / "cache", base / "tmp")
    run.assert_clean()
    if run.backend != "compiled":
        pytest.skip(f"no working C compiler here ({run.warnings}): nothing to cache")
    return base / "cache", run


def _copy_good(good: tuple[Path, Run], dest: Path) -> Path:
    """A copy of the good cache at ``dest``; returns the library in it."""
    shutil.copytree(good[0], dest)
    return _library(dest)


def test_a_build_records_the_sha256_of_its_library_and_leaves_no_temporary_file(good):
    cache, run = good
    assert run.warnings == []
    lib = _library(cache)
    assert run.library == str(lib)
    assert _record_matches(lib)
    assert _temp_files(cache) == []


# ----------------------------------------------------------------------------- damaged libraries


def _truncate(lib: Path) -> None:
    data = lib.read_bytes()
    lib.write_bytes(data[: len(data) // 2])


def _garbage(lib: Path) -> None:
    lib.write_bytes(random.Random(0).randbytes(lib.stat().st_size))


def _flip_one_byte(lib: Path) -> None:
    data = bytearray(lib.read_bytes())
    data[len(data) // 2] ^= 0xFF
    lib.write_bytes(bytes(data))


def _drop_record(lib: Path) -> None:
    lib.with_name(lib.name + ".sha256").unlink()


def _garbage_with_matching_record(lib: Path) -> None:
    _garbage(lib)
    digest = hashlib.sha256(lib.read_bytes()).hexdigest()
    lib.with_name(lib.name + ".sha256").write_text(f"{digest}  {lib.name}\n")


@pytest.mark.parametrize(
    "damage",
    [
        pytest.param(_truncate, id="truncated-library"),  # today: SIGBUS, exit 135, no message
        pytest.param(_garbage, id="garbage-library"),  # today: OSError invalid ELF header
        pytest.param(_flip_one_byte, id="one-byte-changed-after-a-good-build"),  # today: loaded as is
        pytest.param(_drop_record, id="library-without-sha256-record"),
        pytest.param(_garbage_with_matching_record, id="unloadable-library-matching-its-record"),  # ctypes OSError
    ],
)
def test_a_damaged_library_is_detected_and_rebuilt(good, tmp_path, damage):
    """The recorded sha256 is checked when a new process starts; damage means one rebuild and a warning."""
    lib = _copy_good(good, tmp_path / "cache")
    damage(lib)
    damaged = lib.read_bytes()
    run = _run(tmp_path / "cache", tmp_path / "tmp")
    run.assert_clean()
    assert run.backend == "compiled"
    assert run.library == str(lib)
    assert np.abs(run.state - good[1].state).max() <= 1e-12
    assert [w[0] for w in run.warnings] == ["LibraryCacheWarning"], run.warnings
    assert str(lib) in run.warnings[0][1] and "rebuilt" in run.warnings[0][1]
    assert lib.read_bytes() != damaged or damage is _drop_record
    assert _record_matches(lib)
    assert _temp_files(tmp_path / "cache") == []


def _default_compiler(monkeypatch) -> str:
    """The compiler the subprocesses use without ``CC`` (the good build's)."""
    with monkeypatch.context() as m:
        m.delenv("CC", raising=False)
        return generated_code.c_compiler()


def _wrapper(tmp_path: Path, real: str, body: str) -> str:
    """A compiler script that runs ``body`` after answering the cache key's queries like ``real``.

    ``--version`` and ``-march=native`` go to the compiler the good build used, so that the cache key,
    and hence the cached library, are the same.
    """
    if sys.platform == "win32" or shutil.which("sh") is None:
        pytest.skip("no POSIX shell to write a compiler wrapper with")
    script = tmp_path / "cc-wrapper"
    script.write_text(f'#!/bin/sh\ncase "$1" in --version|-march=native) exec "{real}" "$@";; esac\n{body}\n')
    script.chmod(0o755)
    return str(script)


def test_a_damaged_library_that_cannot_be_rebuilt_means_casadi_with_one_warning(good, tmp_path, monkeypatch):
    lib = _copy_good(good, tmp_path / "cache")
    _truncate(lib)
    cc = _wrapper(tmp_path, _default_compiler(monkeypatch), "exit 1")  # the same cache key, but builds fail
    run = _run(tmp_path / "cache", tmp_path / "tmp", CC=cc)
    run.assert_clean()
    assert run.backend == "casadi-vm"
    assert np.abs(run.state - good[1].state).max() < 1e-12
    assert [w[0] for w in run.warnings] == ["CompilerUnavailableWarning"], run.warnings
    assert str(lib) in run.warnings[0][1] and "rebuilding it failed" in run.warnings[0][1]
    assert not lib.exists(), "the damaged library is deleted"


def test_concurrent_first_runs_share_one_build(good, tmp_path, monkeypatch):
    """Two processes start on an empty cache: one compiles, the other waits for and verifies its library."""
    log = tmp_path / "compiles.log"
    real = _default_compiler(monkeypatch)
    cc = _wrapper(tmp_path, real, f'echo "$$" >> "{log}"\nexec "{real}" "$@"')
    environ = {k: v for k, v in os.environ.items() if k not in ("FSMCTL_NO_COMPILE", "CC")}
    environ.update(FSMCTL_CACHE_DIR=str(tmp_path / "cache"), CC=cc)
    code = "from fsmctl.model.generated_code import compiled_library; assert compiled_library() is not None"
    procs = [
        subprocess.Popen(
            [sys.executable, "-W", "error::RuntimeWarning", "-c", code], env=environ, stderr=subprocess.PIPE, text=True
        )
        for _ in range(2)
    ]
    errors = [proc.communicate(timeout=_TIMEOUT_S)[1] for proc in procs]
    assert [proc.returncode for proc in procs] == [0, 0], errors
    assert len(log.read_text().split()) == 1, "compiled once"
    assert _record_matches(_library(tmp_path / "cache"))
    assert _temp_files(tmp_path / "cache") == []


# ----------------------------------------------------------------------------- unusable cache folders


def _regular_file(tmp_path: Path) -> Path:
    (tmp_path / "a-file").write_text("not a folder")
    return tmp_path / "a-file"


def _read_only_folder(tmp_path: Path) -> Path:
    if os.geteuid() == 0:
        pytest.skip(
            "running as root: permission bits do not stop root's writes, so a read-only folder cannot be "
            "simulated (the cache-path-cannot-be-created case covers an unwritable cache)"
        )
    folder = tmp_path / "read-only"
    folder.mkdir(mode=0o500)
    return folder


def _uncreatable(tmp_path: Path) -> Path:
    """A folder that cannot be created, even by root: under /proc, or else under a regular file."""
    if Path("/proc/self").is_dir():
        return Path("/proc/fsmctl-test-cache")
    return _regular_file(tmp_path) / "cache"


@pytest.mark.parametrize(
    "make_cache",
    [
        pytest.param(_regular_file, id="cache-path-is-a-file"),
        pytest.param(_read_only_folder, id="read-only-cache-folder"),
        pytest.param(_uncreatable, id="cache-path-cannot-be-created"),
    ],
)
def test_an_unusable_cache_means_a_private_build_with_a_warning(good, tmp_path, make_cache):
    """The library is compiled in a private temporary folder (deleted at exit); today: a traceback."""
    cache = make_cache(tmp_path)
    try:
        run = _run(cache, tmp_path / "tmp")
    finally:
        if cache.is_dir() and cache.parent == tmp_path:
            cache.chmod(0o700)
    run.assert_clean()
    assert run.backend == "compiled"
    assert np.abs(run.state - good[1].state).max() <= 1e-12
    assert [w[0] for w in run.warnings] == ["LibraryCacheWarning"], run.warnings
    assert str(cache) in run.warnings[0][1] and "temporary folder" in run.warnings[0][1]
    assert run.library is not None and Path(run.library).is_relative_to(tmp_path / "tmp")
    assert not Path(run.library).exists(), "the private build folder is deleted at exit"


def test_no_usable_folder_at_all_falls_back_to_casadi_with_one_warning(good, tmp_path):
    """Cache and temporary folder both unusable: the CasADi functions, the same result."""
    prelude = "import tempfile\ndef _refuse(*a, **k):\n    raise PermissionError(13, 'refused by the test')\ntempfile.mkdtemp = _refuse"
    run = _run(_regular_file(tmp_path), tmp_path / "tmp", prelude=prelude)
    run.assert_clean()
    assert run.backend == "casadi-vm"
    assert np.abs(run.state - good[1].state).max() < 1e-12
    assert [w[0] for w in run.warnings] == ["CompilerUnavailableWarning"], run.warnings
    assert "refused by the test" in run.warnings[0][1]


# ----------------------------------------------------------------------------- failing compilers


def _false(tmp_path: Path) -> str:
    false = shutil.which("false")
    if false is None:
        pytest.skip("no `false` program")
    return false


def _missing(tmp_path: Path) -> str:
    return str(tmp_path / "no-such-compiler")


def _crashing(tmp_path: Path) -> str:
    if shutil.which("sh") is None or sys.platform == "win32":
        pytest.skip("no POSIX shell to write a crashing compiler with")
    cc = tmp_path / "crashing-cc"
    cc.write_text("#!/bin/sh\nkill -SEGV $$\n")
    cc.chmod(0o755)
    return str(cc)


@pytest.mark.parametrize(
    "make_cc",
    [
        pytest.param(_false, id="CC=false"),  # today: GeneratedCodeError traceback
        pytest.param(_missing, id="CC-missing"),  # today: silently replaced by gcc
        pytest.param(_crashing, id="CC-crashes"),  # today: GeneratedCodeError traceback
    ],
)
def test_a_failing_compiler_falls_back_to_casadi_with_one_warning(good, tmp_path, make_cc):
    cc = make_cc(tmp_path)
    run = _run(tmp_path / "cache", tmp_path / "tmp", CC=cc)
    run.assert_clean()
    assert run.backend == "casadi-vm" and run.library is None
    assert np.abs(run.state - good[1].state).max() < 1e-12
    assert [w[0] for w in run.warnings] == ["CompilerUnavailableWarning"], run.warnings
    assert cc in run.warnings[0][1]
    assert _temp_files(tmp_path / "cache") == []


# ----------------------------------------------------------------------------- leftovers of killed builds


def test_stale_temporary_files_are_removed_and_a_live_build_s_are_kept(good, tmp_path):
    lib = _copy_good(good, tmp_path / "cache")
    host = getattr(generated_code, "_host_tag", platform.node)()  # the machine's name, as in file names
    me = os.getpid()
    names = {
        "dead process": f".tmp-{host}-{_dead_pid()}-abcdefgh-{_LIB}",
        "older than an hour": f".tmp-elsewhere-{me}-ijklmnop-{_LIB}",
        "record of a dead process": f".tmp-{host}-{_dead_pid()}-qrstuvwx-{_LIB}.sha256",
        "live build": f".tmp-{host}-{me}-yzabcdef-{_LIB}",
        "fresh, another host": f".tmp-elsewhere-1-ghijklmn-{_LIB}",
        "not a temporary file": "notes.txt",
    }
    for name in names.values():
        (lib.parent / name).write_bytes(b"\x7fELF half")
    two_hours_ago = time.time() - 7200
    os.utime(lib.parent / names["older than an hour"], (two_hours_ago, two_hours_ago))
    run = _run(tmp_path / "cache", tmp_path / "tmp")
    run.assert_clean()
    assert run.backend == "compiled" and run.warnings == []
    kept = {what for what, name in names.items() if (lib.parent / name).exists()}
    assert kept == {"live build", "fresh, another host", "not a temporary file"}


@pytest.mark.skipif(sys.platform == "win32", reason="needs process groups")
def test_the_temporary_file_of_a_build_killed_half_way_is_removed_by_the_next_run(good, tmp_path):
    cache = tmp_path / "cache"
    environ = {k: v for k, v in os.environ.items() if k not in ("FSMCTL_NO_COMPILE", "CC")}
    environ.update(FSMCTL_CACHE_DIR=str(cache))
    code = "from fsmctl.model.generated_code import compiled_library; compiled_library()"
    proc = subprocess.Popen([sys.executable, "-c", code], env=environ, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while not _temp_files(cache) and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)  # the process and its compiler, half-way
        proc.wait()
    left = _temp_files(cache)
    if not left:
        pytest.skip("the build finished before it could be killed")
    assert f"-{proc.pid}-" in left[0].name, "temporary files are named with the building process's pid"
    run = _run(cache, tmp_path / "tmp")
    run.assert_clean()
    assert run.backend == "compiled" and run.warnings == []
    assert _temp_files(cache) == []
    assert np.abs(run.state - good[1].state).max() <= 1e-12
