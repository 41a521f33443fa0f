"""Formation error metrics (Liang et al. 2012, eqs 42-43) and run summaries.

Principal angles and relative attitudes are evaluated with the generated MRP
functions (``mrp_principal_angle``, ``mrp_error``), mapped over the samples by
CasADi (through NumPy buffers, :func:`fsmctl.model.casadi_eval.evaluate_mapped`), so no
MRP formula is re-typed here.  :func:`attitude_error_angle` is the same route for any two MRP signals (two
outputs of a python-control response): the angle of the rotation between them, which does not jump where an
MRP switches to its shadow set.

Memory.  The relative attitude metric (eq 43) involves every pair of agents at every
sample: ``T x n x n`` angles, 8 bytes each (200 agents over the paper's 100 s at 0.01 s:
10 001 x 200 x 200 doubles = 3.2 GB, ~40 GB with the intermediates).  :func:`streamed_raem_deg`
therefore evaluates it in blocks of samples whose working memory is bounded by ``working_bytes``
(default :data:`RAEM_WORKING_BYTES`, at least one sample: ``O(n^2)``, never ``O(T n^2)``), with
the same arithmetic per sample as the direct route, so the numbers are identical to
``raem_deg(relative_principal_angles(sigma_e))``.  The full ``(T, n, n)`` array is still
available (:func:`relative_principal_angles`), as is one sample (:func:`relative_angles_at`)
and one pair over time (:func:`pair_angles`).
"""

from __future__ import annotations

import ctypes

import numpy as np

from fsmctl.errors import InputError
from fsmctl.model.casadi_eval import evaluate_mapped
from fsmctl.model.generated_code import casadi_function, model_library

__all__ = [
    "MAP_BLOCK",
    "RAEM_WORKING_BYTES",
    "principal_angles",
    "attitude_error_angle",
    "relative_principal_angles",
    "relative_angles_at",
    "pair_angles",
    "relative_angles_bytes",
    "aaem_deg",
    "raem_deg",
    "streamed_raem_deg",
    "settling_time",
    "steady_state_max",
    "converged",
]

RAEM_WORKING_BYTES = 64 * 2**20
"""Default bound (bytes) on the working memory of :func:`streamed_raem_deg` (64 MiB)."""


MAP_BLOCK = 1 << 16
"""Most evaluations per mapped CasADi call.  A serial map of ``m`` evaluations holds ``O(m)`` memory (its work
vector, 9 doubles per ``mrp_error``, and its sparsity data, kept while the map is cached by
:func:`fsmctl.model.casadi_eval.evaluate_mapped`), so longer inputs are evaluated in blocks, the last one padded to a
power of two: at most 17 map sizes per function are ever built, each under ~10 MB."""


_C_LOOPS: dict[str, ctypes.CDLL] = {}


def _c_loops() -> ctypes.CDLL | None:
    """The compiled library's sample loops (``fsmctl/csrc/metrics.c``: the same generated functions that
    :func:`casadi_function` maps, called sample by sample: the same bits); None without a compiled library."""
    lib = model_library()  # the law's library where this process flies one: no other compiled for the metrics
    if lib is None:
        return None
    dll = _C_LOOPS.get(str(lib.path))
    if dll is None:
        dll = ctypes.CDLL(str(lib.path))
        dp = ctypes.POINTER(ctypes.c_double)
        dll.fsm_principal_angles.argtypes = [dp, ctypes.c_longlong, dp]
        dll.fsm_relative_angles.argtypes = [dp, ctypes.c_longlong, ctypes.c_int, dp]
        dll.fsm_principal_angles.restype = dll.fsm_relative_angles.restype = ctypes.c_int
        _C_LOOPS[str(lib.path)] = dll
    return dll


def _ptr(a: np.ndarray):
    return a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


def _mapped(name: str, m: int, args: list[np.ndarray]) -> np.ndarray:
    """The single output ``(m, rows)`` of the generated function ``name`` on ``m`` samples ``(m, ...)`` each.

    Same values as one ``evaluate_mapped(fn, m, args)`` call (the map evaluates sample by sample)."""
    fn = casadi_function(name)
    out = None
    for start in range(0, m, MAP_BLOCK):
        k = min(MAP_BLOCK, m - start)
        size = k if k == MAP_BLOCK else 1 << (k - 1).bit_length()
        chunk = [np.ascontiguousarray(a[start : start + k], dtype=float) for a in args]
        if size != k:  # zero MRPs: valid inputs, results discarded
            chunk = [np.concatenate([c, np.zeros((size - k, *c.shape[1:]))]) for c in chunk]
        (res,) = evaluate_mapped(fn, size, chunk)
        if out is None:
            out = np.empty((m, *res.shape[1:]))
        out[start : start + k] = res[:k]
    return out


def principal_angles(sigma: np.ndarray) -> np.ndarray:
    """Principal rotation angles ``theta = 4 atan|sigma|`` (Liang et al. 2012, eq 2) of MRPs.

    Parameters
    ----------
    sigma : numpy.ndarray, shape (..., 3)
        MRPs (any branch: the angle is the rotation's, in [0, pi]).

    Returns
    -------
    numpy.ndarray, shape (...)
        Angles in rad.

    Examples
    --------
    >>> import numpy as np
    >>> principal_angles(np.array([[0.0, 0.0, np.tan(np.pi / 8)], [0.0, 0.0, 0.0]])).round(12).tolist()
    [1.570796326795, 0.0]
    """
    sigma = np.asarray(sigma, dtype=float)
    flat = sigma.reshape(-1, 3)
    if flat.shape[0] == 0:
        return np.zeros(sigma.shape[:-1])
    dll = _c_loops()
    if dll is not None:
        flat = np.ascontiguousarray(flat)
        theta = np.empty(flat.shape[0])
        if dll.fsm_principal_angles(_ptr(flat), flat.shape[0], _ptr(theta)) == 0:
            return theta.reshape(sigma.shape[:-1])
    theta = _mapped("mrp_principal_angle", flat.shape[0], [flat])  # (m, 1)
    return theta.reshape(sigma.shape[:-1])


def _error_angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(m, 3), (m, 3) -> (m,)``: the principal angle of ``a (x) b^-1`` (the generated ``mrp_error``, then
    :func:`principal_angles`): the one route of every relative angle here."""
    if a.shape[0] == 0:
        return np.zeros(0)
    return principal_angles(_mapped("mrp_error", a.shape[0], [a, b]))


def attitude_error_angle(sigma_a, sigma_b, *, axis: int = -1, degrees: bool = False) -> np.ndarray:
    """Principal angle of the rotation between two attitudes given as MRPs: continuous where sigma switches set.

    The outputs ``sigma`` of fsmctl's systems are MRPs in the shadow set ``|sigma| <= 1``: at ``|sigma| = 1``
    (a rotation of 180 deg) they switch to ``-sigma / |sigma|^2``, a jump of 2, so ``sigma_a - sigma_b`` jumps by 2
    (by up to 4 when both switch) while the attitudes move continuously.  This angle does not: it is the principal angle ``theta`` (Liang et
    al. 2012, eq 2) of the relative attitude ``sigma_a (x) sigma_b^-1``, the formula of the simulator's
    ``theta_e`` and of the relative angles of RAEM (eq 43): the generated ``mrp_error`` and
    ``mrp_principal_angle``.  Either MRP may be in either set.

    Parameters
    ----------
    sigma_a, sigma_b : array_like
        MRPs, the three components along ``axis``; the other axes (time, agents, ...) broadcast against each
        other.  A python-control response holds a signal as ``(3, T)`` rows: pass ``axis=0``.
    axis : int
        The axis of length 3 holding the MRP components, in both arrays.
    degrees : bool
        Return degrees instead of radians.

    Returns
    -------
    numpy.ndarray
        The angle, in ``[0, pi]`` rad (``[0, 180]`` deg), with the broadcast shape of the two inputs without
        ``axis``.

    Raises
    ------
    fsmctl.errors.InputError
        An input that is not a numeric array, that has no axis ``axis`` of length 3, holds a value that is
        not finite, or does not broadcast against the other; an ``axis`` that is not an integer.

    Examples
    --------
    One attitude on both sides of the switch: 179 deg and 181 deg about z, the second written in the shadow
    set (``|sigma| <= 1``, as the outputs are).  The MRPs differ by ~2, the attitudes by 2 deg:

    >>> import numpy as np
    >>> mrp_z = lambda deg: np.array([0.0, 0.0, np.tan(np.radians(deg) / 4)])
    >>> shadow = lambda s: -s / (s @ s)
    >>> a, b = mrp_z(179.0), shadow(mrp_z(181.0))
    >>> (a - b).round(3).tolist()
    [0.0, 0.0, 1.983]
    >>> round(float(attitude_error_angle(a, b, degrees=True)), 9)
    2.0

    Over time, with signals as python-control rows ``(3, T)``:

    >>> t = np.linspace(0.0, 2.0, 5)  # a spin at 180 deg/s about z: 0, 90, 180, 270, 360 deg
    >>> spin = np.stack([np.zeros(5), np.zeros(5), np.tan(np.radians(180.0 * t) / 4)])
    >>> attitude_error_angle(spin, np.zeros((3, 1)), axis=0, degrees=True).round(9).tolist()
    [0.0, 90.0, 180.0, 90.0, 0.0]
    """
    if isinstance(axis, bool) or not isinstance(axis, (int, np.integer)):
        raise InputError(f"attitude_error_angle: axis must be an integer, got {axis!r}")
    arrays = []
    for name, value in (("sigma_a", sigma_a), ("sigma_b", sigma_b)):
        try:
            x = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"attitude_error_angle: {name} must be an array of numbers (MRPs)") from None
        try:
            x = np.moveaxis(x, axis, -1)
        except np.exceptions.AxisError:
            raise InputError(
                f"attitude_error_angle: {name} of shape {x.shape} has no axis {axis!r} (MRP components)"
            ) from None
        if x.shape[-1] != 3:
            rows = [k for k, size in enumerate(np.shape(value)) if size == 3]
            hint = f"; its axis {rows[0]} has 3: pass axis={rows[0]} (python-control rows are (3, T))" if rows else ""
            raise InputError(
                f"attitude_error_angle: {name} has {x.shape[-1]} components along axis {axis}, an MRP has 3 "
                f"(shape {np.shape(value)}){hint}"
            )
        if not np.isfinite(x).all():
            raise InputError(f"attitude_error_angle: {name} holds a value that is not finite (NaN or inf)")
        arrays.append(x)
    try:
        shape = np.broadcast_shapes(arrays[0].shape, arrays[1].shape)
    except ValueError:
        raise InputError(
            f"attitude_error_angle: the shapes {np.shape(sigma_a)} and {np.shape(sigma_b)} do not broadcast "
            f"(components along axis {axis})"
        ) from None
    a, b = (np.broadcast_to(x, shape).reshape(-1, 3) for x in arrays)
    theta = _error_angles(a, b).reshape(shape[:-1])
    return np.degrees(theta) if degrees else theta


def _per_sample_bytes(n: int) -> int:
    """Working bytes of one sample of the pairwise computation: the pair inputs, the relative MRPs and
    their angles (3 + 3 + 3 + 1 doubles per unordered pair) and two ``(n, n)`` arrays (angles, squares);
    the mapped evaluations add a constant (:data:`MAP_BLOCK`)."""
    pairs = n * (n - 1) // 2
    return 8 * (10 * pairs + 2 * n * n)


def relative_angles_bytes(n_samples: int, n_agents: int) -> int:
    """Peak bytes of :func:`relative_principal_angles` on ``(n_samples, n_agents, 3)`` errors (result included)."""
    return int(n_samples) * _per_sample_bytes(int(n_agents))


def _relative_block(sigma_e: np.ndarray, iu: np.ndarray, ju: np.ndarray) -> np.ndarray:
    """``(T, n, 3) -> (T, n, n)``: the pairwise principal angles of a block of samples."""
    T, n, _ = sigma_e.shape
    out = np.zeros((T, n, n))
    if iu.size == 0 or T == 0:
        return out
    dll = _c_loops()
    if dll is not None:
        block = np.ascontiguousarray(sigma_e, dtype=float)
        if dll.fsm_relative_angles(_ptr(block), T, n, _ptr(out)) == 0:
            return out
        out[:] = 0.0
    # theta_ij = theta_ji (the inverse rotation has the same angle): evaluate each unordered pair once
    theta = _error_angles(sigma_e[:, iu, :].reshape(-1, 3), sigma_e[:, ju, :].reshape(-1, 3)).reshape(T, iu.size)
    out[:, iu, ju] = theta
    out[:, ju, iu] = theta
    return out


def relative_principal_angles(sigma_e: np.ndarray) -> np.ndarray:
    """Principal angle between every pair of agents: ``(T, n, 3) -> (T, n, n)`` rad (the theta_ij of eq 43).

    The relative attitude of i with respect to j is ``sigma_ei (x) sigma_ej^-1``
    (equal to ``sigma_i (x) sigma_j^-1``: the reference cancels).

    Cost: ``T n^2`` doubles for the result and about as much again while it is computed
    (:func:`relative_angles_bytes`); for the metric use :func:`streamed_raem_deg`, for one sample
    :func:`relative_angles_at`, for one pair :func:`pair_angles`.

    Parameters
    ----------
    sigma_e : numpy.ndarray, shape (T, n, 3)
        Attitude errors (MRPs) of ``n`` agents at ``T`` samples.

    Returns
    -------
    numpy.ndarray, shape (T, n, n)
        ``theta_ij`` in rad, symmetric, zero diagonal.

    Examples
    --------
    >>> import numpy as np
    >>> quarter = np.tan(np.pi / 8)  # a 90 deg turn about z
    >>> theta = relative_principal_angles(np.array([[[0, 0, 0], [0, 0, quarter]]]))
    >>> np.degrees(theta[0]).round(9).tolist()
    [[0.0, 90.0], [90.0, 0.0]]
    """
    sigma_e = np.asarray(sigma_e, dtype=float)
    n = sigma_e.shape[1]
    iu, ju = np.triu_indices(n, k=1)
    return _relative_block(sigma_e, iu, ju)


def relative_angles_at(sigma_e_k: np.ndarray) -> np.ndarray:
    """The ``(n, n)`` matrix of relative principal angles (rad) of one sample ``(n, 3)`` of attitude errors."""
    sigma_e_k = np.asarray(sigma_e_k, dtype=float)
    if sigma_e_k.ndim != 2 or sigma_e_k.shape[1] != 3:
        raise ValueError(f"relative_angles_at: expected (n, 3) attitude errors, got shape {sigma_e_k.shape}")
    return relative_principal_angles(sigma_e_k[None])[0]


def pair_angles(sigma_e: np.ndarray, i: int, j: int) -> np.ndarray:
    """``theta_ij(t)`` (rad), shape ``(T,)``: the relative principal angle of agents ``i`` and ``j`` (0-based)."""
    sigma_e = np.asarray(sigma_e, dtype=float)
    n = sigma_e.shape[1]
    for name, k in (("i", i), ("j", j)):
        if not 0 <= k < n:
            raise IndexError(f"pair_angles: {name} = {k} is not an agent index 0..{n - 1}")
    if i == j:
        return np.zeros(sigma_e.shape[0])
    if sigma_e.shape[0] == 0:
        return np.zeros(0)
    i, j = min(i, j), max(i, j)  # as in relative_principal_angles: theta_ij = theta_ji, evaluated for i < j
    return _error_angles(sigma_e[:, i, :], sigma_e[:, j, :])


def streamed_raem_deg(sigma_e: np.ndarray, *, working_bytes: int = RAEM_WORKING_BYTES) -> np.ndarray:
    """Relative attitude error metric (eq 43) of ``(T, n, 3)`` attitude errors, in blocks of samples; ``(T,)`` deg.

    Equal (bit for bit) to ``raem_deg(relative_principal_angles(sigma_e))``: each block is computed by the
    same code, and eq 43 is a per-sample reduction.  The working memory stays below ``working_bytes``, or one
    sample's worth (``~56 n^2`` bytes) when that is larger.
    """
    sigma_e = np.asarray(sigma_e, dtype=float)
    if sigma_e.ndim != 3 or sigma_e.shape[2] != 3:
        raise ValueError(f"streamed_raem_deg: expected (T, n, 3) attitude errors, got shape {sigma_e.shape}")
    T, n, _ = sigma_e.shape
    out = np.zeros(T)
    if n < 2 or T == 0:
        return out
    iu, ju = np.triu_indices(n, k=1)
    block = max(1, min(T, int(working_bytes) // _per_sample_bytes(n)))
    for start in range(0, T, block):
        stop = min(T, start + block)
        out[start:stop] = raem_deg(_relative_block(sigma_e[start:stop], iu, ju))
    return out


def aaem_deg(theta_e: np.ndarray) -> np.ndarray:
    """Absolute attitude error metric AAEM (Liang et al. 2012, eq 42): ``(180/pi) sqrt(mean_i theta_ei^2)``.

    Parameters
    ----------
    theta_e : numpy.ndarray, shape (..., n)
        Principal angles of the agents' attitude errors, rad (:func:`principal_angles` of ``sigma_e``).

    Returns
    -------
    numpy.ndarray, shape (...)
        AAEM in degrees (the paper's 1/6 is 1/n).

    Examples
    --------
    >>> import numpy as np
    >>> float(aaem_deg(np.radians([3.0, 4.0, 0.0, 0.0, 0.0, 0.0])) ** 2 * 6)  # (9 + 16) deg^2
    25.0...
    """
    return np.degrees(np.sqrt(np.mean(np.square(theta_e), axis=-1)))


def raem_deg(theta_ij: np.ndarray) -> np.ndarray:
    """Relative attitude error metric (eq 43): ``(180/pi) sqrt(sum_{i != j} theta_ij^2 / (n (n-1)))``.

    For the paper's n = 6 the divisor is 30, as printed.

    Parameters
    ----------
    theta_ij : numpy.ndarray, shape (..., n, n)
        Relative principal angles, rad (:func:`relative_principal_angles`); the diagonal is zero.

    Returns
    -------
    numpy.ndarray, shape (...)
        RAEM in degrees (zero for fewer than two agents).

    Examples
    --------
    >>> import numpy as np
    >>> float(raem_deg(np.radians([[0.0, 6.0], [6.0, 0.0]])))  # sqrt((36 + 36) / 2)
    6.0...
    """
    n = theta_ij.shape[-1]
    if n < 2:
        return np.zeros(theta_ij.shape[:-2])
    return np.degrees(np.sqrt(np.sum(np.square(theta_ij), axis=(-2, -1)) / (n * (n - 1))))


def settling_time(time: np.ndarray, metric: np.ndarray, tolerance: float) -> float:
    """First time after which ``metric`` stays at or below ``tolerance`` (NaN if it never settles).

    A NaN sample counts as not settled.

    Parameters
    ----------
    time : numpy.ndarray, shape (T,)
        Sample times, s.
    metric : numpy.ndarray, shape (T,)
        A metric such as AAEM or RAEM (eqs 42-43), deg.
    tolerance : float
        The settling band, in the metric's unit.

    Returns
    -------
    float
        The time of the first sample of the final run of samples within the band (``time[0]`` if every sample
        is; NaN if the last one is not).

    Examples
    --------
    >>> import numpy as np
    >>> settling_time(np.array([0.0, 1.0, 2.0, 3.0]), np.array([5.0, 0.5, 2.0, 0.5]), 1.0)
    3.0
    """
    above = np.nonzero(~(np.asarray(metric) <= tolerance))[0]
    if above.size == 0:
        return float(time[0])
    last = above[-1]
    return float(time[last + 1]) if last + 1 < len(time) else float("nan")


def steady_state_max(time: np.ndarray, metric: np.ndarray, window: float) -> float:
    """``max metric`` over the final ``window`` seconds."""
    time = np.asarray(time)
    return float(np.max(np.asarray(metric)[time >= time[-1] - window - 1e-12]))


def converged(time: np.ndarray, aaem: np.ndarray, raem: np.ndarray, tolerance_deg: float) -> bool:
    """Whether a run has converged: AAEM and RAEM (eqs 42-43) each settle within ``tolerance_deg``.

    The one definition (:data:`fsmctl.policy.CONVERGED_RULE`): each metric stays at or below the tolerance from some
    time until the end of the run (:func:`settling_time` is finite for both); a NaN sample is not settled.

    Parameters
    ----------
    time : numpy.ndarray, shape (T,)
        Sample times, s.
    aaem, raem : numpy.ndarray, shape (T,)
        The metrics, deg.
    tolerance_deg : float
        The tolerance, deg (:data:`fsmctl.policy.TOLERANCE_DEG` for ``simulate`` and a default Monte Carlo campaign).

    Returns
    -------
    bool
        True when both have settled by the last sample.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.array([0.0, 1.0, 2.0])
    >>> converged(t, np.array([5.0, 0.5, 0.2]), np.array([4.0, 2.0, 0.9]), 1.0)
    True
    >>> converged(t, np.array([5.0, 0.5, 0.2]), np.array([4.0, 0.5, 1.5]), 1.0)
    False
    """
    return all(np.isfinite(settling_time(time, metric, tolerance_deg)) for metric in (aaem, raem))
