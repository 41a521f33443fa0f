"""Writing result files: atomically, strictly, with one clear error when the machine refuses.

Every file fsmctl writes goes through here, so the rules exist once:

* **atomic**: a file is written to a temporary sibling and renamed over the target, so a reader (or a
  resumed campaign) sees the complete old file, the complete new file, or none; never a torn one.  A
  target that exists and is not a regular file (``/dev/stdout``, ``/dev/full``, a FIFO) is written in
  place instead: renaming over a device would replace it.
* **strict JSON**: NaN becomes ``null`` and infinities ``"inf"``/``"-inf"`` (:func:`jsonable`), and ``allow_nan=False`` guarantees
  that no ``NaN`` token (which is not JSON) is ever written.
* **one error**: an ``OSError`` while creating a folder or writing a file becomes
  :class:`~fsmctl.errors.EnvironmentProblem` naming the path and the reason (read-only, no space, ...);
  the command line prints it as one line and exits 2.
* **no empty folders**: :func:`output_folder` removes a folder it created when the command fails before
  writing anything into it.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import stat
import tempfile
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from fsmctl.errors import EnvironmentProblem

__all__ = [
    "atomic_path",
    "write_text",
    "write_json",
    "jsonable",
    "output_folder",
    "environment_problem",
    "temporary_files",
]

_TEMP_MARK = ".tmp"
"""temporary files are named ``.<stem>.<random>.tmp<pid><suffix>`` (hidden, with the writer's pid)"""


def temporary_files(folder: str | os.PathLike) -> list[Path]:
    """Temporary files of :func:`atomic_path` in ``folder`` (left behind only by a killed process).

    Parameters
    ----------
    folder : str or os.PathLike
        The folder to look in.

    Returns
    -------
    list of Path
        The temporary files, sorted (empty when the folder cannot be read).

    Examples
    --------
    >>> with atomic_path("x.txt") as tmp:
    ...     _ = tmp.write_text("partial")
    ...     print(len(temporary_files(".")))
    1
    >>> temporary_files(".")
    []
    """
    try:
        return sorted(p for p in Path(folder).glob(f".*{_TEMP_MARK}*") if p.is_file())
    except OSError:
        return []


def environment_problem(action: str, path: str | os.PathLike, exc: OSError) -> EnvironmentProblem:
    """``EnvironmentProblem("cannot <action> <path>: <reason>")``, keeping the errno.

    Parameters
    ----------
    action : str
        What was being done (``"write"``, ``"read"``).
    path : str or os.PathLike
        The file or folder.
    exc : OSError
        The error the machine gave.

    Returns
    -------
    EnvironmentProblem
        One line naming the path and the reason; ``errno`` and ``filename`` set.

    Examples
    --------
    >>> import errno
    >>> err = environment_problem("write", "out/x.nc", OSError(errno.ENOSPC, "No space left on device"))
    >>> err.strerror, err.errno == errno.ENOSPC, err.filename
    ('cannot write out/x.nc: No space left on device', True, 'out/x.nc')
    """
    reason = exc.strerror or str(exc)
    err = EnvironmentProblem(exc.errno, f"cannot {action} {path}: {reason}")
    err.filename = os.fspath(path)
    return err


def _in_place(path: Path) -> bool:
    try:
        return not stat.S_ISREG(path.stat().st_mode)
    except FileNotFoundError:
        return False
    except OSError:
        return False


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success it is renamed to ``path`` (atomic on POSIX).

    On any exception the temporary file is removed and ``path`` is untouched.  ``OSError`` becomes
    :class:`~fsmctl.errors.EnvironmentProblem`.  A non-regular existing target is yielded as is.

    Parameters
    ----------
    path : str or os.PathLike
        The target file (missing parent folders are created).

    Yields
    ------
    Path
        The temporary sibling to write (same suffix as ``path``).

    Raises
    ------
    EnvironmentProblem
        The folder or the file cannot be written (read-only, no space, ...).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "x.txt"
    >>> with atomic_path(target) as tmp:
    ...     _ = tmp.write_text("done")
    >>> target.read_text()
    'done'
    """
    path = Path(path)
    if _in_place(path):
        try:
            yield path
        except OSError as exc:
            raise environment_problem("write", path, exc) from None
        return
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        # the suffix is kept, so writers that choose a format by it (NetCDF, savefig) see the real one
        fd, name = tempfile.mkstemp(
            prefix=f".{path.stem}.", suffix=f"{_TEMP_MARK}{os.getpid()}{path.suffix}", dir=path.parent
        )
        os.close(fd)
    except OSError as exc:
        raise environment_problem("write", path, exc) from None
    tmp = Path(name)
    try:
        yield tmp
        os.chmod(tmp, _default_mode())  # mkstemp's file is private (0600): a file written here is like any other
        fd = os.open(tmp, os.O_RDONLY)  # on disk before the rename makes it visible
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise environment_problem("write", path, exc) from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _default_mode() -> int:
    """The mode a new file gets here: ``0o666`` less the process's umask (as ``open`` would create it)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8) atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Target file.
    text : str
        Its content.

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> write_text("note.txt", "one line").read_text()
    'one line'
    """
    with atomic_path(path) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
    return Path(path)


def jsonable(value: Any) -> Any:
    """A copy of ``value`` that strict JSON can hold: NaN -> None, +-inf -> "inf"/"-inf", NumPy -> Python, paths -> str.

    Parameters
    ----------
    value : object
        Mappings, sequences, NumPy arrays and scalars, paths, and anything JSON holds as is.

    Returns
    -------
    object
        Plain Python values (dicts with string keys, lists, numbers, strings, None).

    Examples
    --------
    >>> import numpy as np
    >>> jsonable({"x": np.array([1.0, np.nan, np.inf]), 2: np.int64(3)})
    {'x': [1.0, None, 'inf'], '2': 3}
    """
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, set, frozenset)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        x = float(value)
        if math.isnan(x):
            return None
        return x if math.isfinite(x) else ("inf" if x > 0 else "-inf")
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    return value


def write_json(path: str | os.PathLike, payload: Any, *, indent: int = 2) -> Path:
    """Write ``jsonable(payload)`` as strict JSON (never a ``NaN`` token), atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Target file.
    payload : object
        Anything :func:`jsonable` converts.
    indent : int
        JSON indentation.

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> print(write_json("r.json", {"aaem_deg": float("nan")}).read_text())
    {
      "aaem_deg": null
    }
    """
    return write_text(path, json.dumps(jsonable(payload), indent=indent, allow_nan=False) + "\n")


@contextlib.contextmanager
def output_folder(path: str | os.PathLike) -> Iterator[Path]:
    """Create ``path`` (and parents) for a command's outputs, checking that it can be written to.

    If the block fails and the folder was created here and is still empty, it is removed, so failed runs
    leave no empty folders behind.  ``OSError`` (read-only file system, a file in the way, no space)
    becomes :class:`~fsmctl.errors.EnvironmentProblem` with one line naming the folder.

    Parameters
    ----------
    path : str or os.PathLike
        The output folder.

    Yields
    ------
    Path
        The folder, created and writable.

    Raises
    ------
    EnvironmentProblem
        The folder cannot be created or written to.

    Examples
    --------
    >>> import pathlib
    >>> try:
    ...     with output_folder("runs/case1") as out:
    ...         raise RuntimeError("the command failed before writing")
    ... except RuntimeError:
    ...     pass
    >>> pathlib.Path("runs").exists()
    False
    """
    path = Path(path)
    created: list[Path] = []
    try:
        for parent in reversed([path, *path.parents]):
            if not parent.exists():
                parent.mkdir()
                created.append(parent)
        if not path.is_dir():
            raise NotADirectoryError(20, "not a directory")
        probe = tempfile.NamedTemporaryFile(dir=path, prefix=".fsmctl-write-check.", delete=True)
        probe.close()
    except OSError as exc:
        _remove_empty(created)
        raise environment_problem("write to output folder", path, exc) from None
    try:
        yield path
    except BaseException:
        _remove_empty(created)
        raise


def _remove_empty(created: list[Path]) -> None:
    for folder in reversed(created):
        with contextlib.suppress(OSError):
            folder.rmdir()  # only succeeds when empty
