"""Connecting to a Dask distributed scheduler (``--dask ADDRESS``) for :mod:`fsmctl.studies.campaign`.

An address is checked before :class:`distributed.Client` sees it (:func:`connect_dask`): it must be one that
distributed accepts (a scheme of one of its comm backends: ``tcp``, the default, ``tls``, ``inproc``, ``ws``, ...;
``host:port`` with the port for ``tcp``), else :class:`~fsmctl.errors.InputError`; a ``tcp://`` endpoint must answer
with a Dask handshake within the timeout (read here with bounded sizes: distributed's own reader trusts the first 8
bytes as a length), any other scheme must accept a connection through distributed's ``connect``; otherwise
:class:`~fsmctl.errors.EnvironmentProblem`.  Only the campaign runner calls this module.
"""

from __future__ import annotations

import errno
import socket
import struct
import time
from typing import Any

from fsmctl.errors import EnvironmentProblem, InputError
from fsmctl.policy import DASK_TIMEOUT_S

__all__ = ["connect_dask"]

_DASK_HANDSHAKE_MAX_BYTES = 1 << 16  # a scheduler's handshake is ~60 bytes


def _recv_exact(sock: socket.socket, n: int, deadline: float) -> bytes:
    buf = bytearray()
    while len(buf) < n:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            raise TimeoutError
        sock.settimeout(remaining)
        part = sock.recv(n - len(buf))
        if not part:
            raise ConnectionResetError(errno.ECONNRESET, "closed the connection")
        buf += part
    return bytes(buf)


def _dask_handshake(sock: socket.socket, deadline: float) -> str | None:
    """Read the handshake a Dask scheduler sends on connect; None if it is one, else what is wrong.

    distributed's TCP framing: an 8-byte length ``N``, then ``N`` bytes holding the frame count, the
    frame lengths (8 bytes each) and the frames; the first frame is a msgpack mapping with ``python``
    and ``pickle-protocol``.  Reading it here, with bounded sizes and a deadline, keeps distributed's own
    reader from trusting a garbage length (it allocates whatever the first 8 bytes say: exabytes for
    ``HTTP/1.1``) or waiting forever on a silent endpoint.
    """
    head = _recv_exact(sock, 8, deadline)
    (n,) = struct.unpack("Q", head)
    if not 16 <= n <= _DASK_HANDSHAKE_MAX_BYTES:
        return f"its first bytes {head[:8]!r} are not a Dask message header"
    body = _recv_exact(sock, n, deadline)
    (n_frames,) = struct.unpack_from("Q", body)
    if not 1 <= n_frames <= 64 or 8 * (1 + n_frames) > n:
        return "its first message is not in Dask's frame format"
    lengths = struct.unpack_from(f"{n_frames}Q", body, 8)
    start = 8 * (1 + n_frames)
    if start + sum(lengths) != n:
        return "its first message is not in Dask's frame format"
    try:
        import msgpack

        info = msgpack.loads(body[start : start + lengths[0]], raw=False)
    except Exception:
        return "its first message is not a Dask handshake"
    if not isinstance(info, dict) or "python" not in info or "pickle-protocol" not in info:
        return "its first message is not a Dask handshake"
    return None


def _probe_dask_comm(address: str, timeout_s: float) -> None:
    """Open and close a connection to ``address`` with distributed's own ``connect`` (a fresh event loop).

    Runs in a thread of its own, so it works whether or not the caller's thread runs an event loop (a
    notebook).  The connection arguments are the ones a :class:`distributed.Client` without ``security``
    uses (:class:`distributed.security.Security` from the Dask configuration).  Raises what ``connect``
    raises.
    """
    import asyncio
    import threading

    from distributed.comm import connect
    from distributed.security import Security

    async def probe() -> None:
        comm = await connect(address, timeout=timeout_s, **Security().get_connection_args("client"))
        await comm.close()

    failure: list[BaseException] = []

    def target() -> None:
        try:
            asyncio.run(probe())
        except BaseException as exc:  # handed to the caller's thread
            failure.append(exc)

    thread = threading.Thread(target=target, name="fsmctl-dask-probe", daemon=True)
    thread.start()
    thread.join(timeout_s + 5.0)  # connect() gives up after timeout_s; the margin covers closing
    if thread.is_alive():
        raise TimeoutError
    if failure:
        raise failure[0]


def _check_dask_endpoint(address: str, timeout_s: float) -> None:
    """Pre-flight of a scheduler address, so that a bad one is a one-line error at once.

    The address must be one that distributed accepts: a scheme that one of its registered comm backends
    serves (``tcp``, ``tls``, ``inproc``, ``ws``, ... and those that plug-ins register), default ``tcp``,
    and a location in that scheme's syntax (``host:port`` for ``tcp``, port included); otherwise
    :class:`~fsmctl.errors.InputError`.  A ``tcp://`` endpoint must then accept a connection and send a
    Dask handshake, read here with bounded sizes (distributed's own reader allocates whatever the first 8
    bytes say); any other scheme must accept a connection through distributed's ``connect``.  Otherwise
    :class:`~fsmctl.errors.EnvironmentProblem` (nothing listening, no answer within ``timeout_s``, an
    answer that is not Dask's, a backend that cannot work here, such as ``tls`` without certificates).

    Without this check, an address that distributed refuses by a ``ValueError`` or ``TypeError`` leaves a
    half-started :class:`distributed.Client` whose finalizer waits twice the timeout and prints a traceback.
    """
    import warnings

    from distributed.comm.addressing import parse_address
    from distributed.comm.registry import get_backend

    with warnings.catch_warnings(record=True) as caught:  # a deprecated backend (ucx) warns when it loads
        warnings.simplefilter("always")
        try:
            scheme, loc = parse_address(address)
            backend = get_backend(scheme)
            host_port = backend.get_address_host_port(loc) if scheme == "tcp" else None
        except (ValueError, TypeError) as exc:
            raise InputError(f"--dask {address}: not a scheduler address ({exc})") from None
        except ImportError as exc:  # a plug-in's backend that does not load
            raise EnvironmentProblem(errno.ENOENT, f"--dask {address}: {type(exc).__name__}: {exc}") from None
    what = f"--dask {address}: cannot connect to a Dask scheduler"
    if host_port is None:
        try:
            with warnings.catch_warnings(record=True) as more:
                warnings.simplefilter("always")
                _probe_dask_comm(address, timeout_s)
        except ValueError as exc:  # the backend's own address syntax (inproc://host/pid/n)
            raise InputError(f"--dask {address}: not a scheduler address ({exc})") from None
        except TimeoutError:
            raise EnvironmentProblem(errno.ETIMEDOUT, f"{what} (no answer within {timeout_s:g} s)") from None
        except Exception as exc:  # OSError, or a backend that cannot work here (TypeError: tls without ssl context)
            notes = [str(w.message).splitlines()[0] for w in (*caught, *more)]
            text = " ".join(f"{type(exc).__name__}: {exc}".split())[:300]
            raise EnvironmentProblem(
                getattr(exc, "errno", None) or errno.EPROTO, f"{what} ({'; '.join([text, *notes])})"
            ) from None
        return
    host, port = host_port
    deadline = time.monotonic() + timeout_s
    try:
        sock = socket.create_connection((host, int(port)), timeout=timeout_s)
    except TimeoutError:
        raise EnvironmentProblem(errno.ETIMEDOUT, f"{what} (no answer within {timeout_s:g} s)") from None
    except OSError as exc:
        raise EnvironmentProblem(exc.errno or errno.EIO, f"{what} ({exc.strerror or exc})") from None
    with sock:
        try:
            problem = _dask_handshake(sock, deadline)
        except TimeoutError:
            problem = f"it accepted the connection but sent no Dask handshake within {timeout_s:g} s"
        except OSError as exc:
            problem = f"it {exc.strerror or exc} before sending a Dask handshake"
    if problem is not None:
        raise EnvironmentProblem(
            errno.EPROTO, f"--dask {address}: the endpoint answers but is not a Dask scheduler ({problem})"
        )


def connect_dask(address_or_client: Any, timeout_s: float = DASK_TIMEOUT_S) -> tuple[Any, bool]:
    """``(client, owned)``: the given :class:`distributed.Client`, or a new one to the checked address.

    Parameters
    ----------
    address_or_client : str or distributed.Client
        A scheduler address (checked first, see the module docstring) or a client.
    timeout_s : float, optional
        Seconds the scheduler gets to accept the connection and answer.

    Returns
    -------
    tuple
        The client and whether it was created here (then the caller closes it).

    Raises
    ------
    fsmctl.errors.InputError
        Not an address distributed accepts.
    fsmctl.errors.EnvironmentProblem
        No ``distributed`` package, or the address is not a reachable Dask scheduler.

    Examples
    --------
    >>> from fsmctl.studies.cluster import connect_dask
    >>> connect_dask(42)
    Traceback (most recent call last):
    ...
    fsmctl.errors.InputError: --dask: expected a scheduler address or a distributed.Client, got 42
    """
    try:
        from distributed import Client
    except ImportError:
        raise EnvironmentProblem(
            errno.ENOPKG if hasattr(errno, "ENOPKG") else errno.ENOENT,
            "--dask needs the 'distributed' package (pip install 'fsmctl[dask]')",
        ) from None
    if isinstance(address_or_client, Client):
        return address_or_client, False
    if not isinstance(address_or_client, str) or not address_or_client.strip():
        raise InputError(f"--dask: expected a scheduler address or a distributed.Client, got {address_or_client!r}")
    address = address_or_client.strip()
    _check_dask_endpoint(address, timeout_s)
    import dask

    try:
        with dask.config.set({"distributed.comm.timeouts.connect": f"{timeout_s}s"}):
            client = Client(address, timeout=f"{timeout_s}s", set_as_default=False)
    except Exception as exc:  # MemoryError, ValueError, OSError, TimeoutError: the endpoint is not usable
        text = " ".join(f"{type(exc).__name__}: {exc}".split())[:300]
        raise EnvironmentProblem(
            getattr(exc, "errno", None) or errno.EPROTO,
            f"--dask {address}: cannot connect to a Dask scheduler ({text})",
        ) from None
    return client, True
