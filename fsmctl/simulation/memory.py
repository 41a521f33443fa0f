"""Memory available to a new allocation, as the simulator's checks and :class:`~fsmctl.simulation.result.SimulationResult`
read it before allocating (:func:`available_memory`).
"""

from __future__ import annotations


def available_memory() -> int | None:
    """Bytes of memory a new allocation can use, or None when unknown (then nothing is checked).

    ``psutil.virtual_memory().available`` when psutil is importable, else ``MemAvailable`` of
    ``/proc/meminfo``; lowered to the room left under a cgroup v2 limit (``memory.max - memory.current``
    of ``/sys/fs/cgroup``, i.e. a container's limit) when there is one.
    """
    avail = None
    try:
        import psutil
    except ImportError:
        try:
            with open("/proc/meminfo") as fh:
                for line in fh:
                    if line.startswith("MemAvailable:"):
                        avail = int(line.split()[1]) * 1024
                        break
        except (OSError, ValueError, IndexError):
            avail = None
    else:
        try:
            avail = int(psutil.virtual_memory().available)
        except Exception:  # psutil unsupported on this platform: no check
            avail = None
    try:
        with open("/sys/fs/cgroup/memory.max") as fh:
            limit = fh.read().strip()
        if limit != "max":
            with open("/sys/fs/cgroup/memory.current") as fh:
                room = int(limit) - int(fh.read().strip())
            avail = room if avail is None else min(avail, room)
    except (OSError, ValueError):
        pass
    return avail


def format_bytes(x: float) -> str:
    """A byte count for messages, three significant digits (``1.5 GB``, ``300 kB``, ``12 B``).

    Parameters
    ----------
    x : float
        A number of bytes.

    Returns
    -------
    str
        The count with a decimal (SI) unit.

    Examples
    --------
    >>> format_bytes(1.5e9), format_bytes(3e5), format_bytes(12)
    ('1.5 GB', '300 kB', '12 B')
    """
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if abs(x) >= scale:
            return f"{x / scale:.3g} {unit}"
    return f"{x:.0f} B"
