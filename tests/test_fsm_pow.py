"""fsmctl's pow (fsmctl/csrc/fsm_pow.h), the pow of every compiled path: accurate, lanes equal scalar calls.

The compiled library exports the scalar ``fsmctl_pow`` (what the CasADi-generated scalar C calls) and
``fsm_pow_lanes`` (the four-lane computation of the batched kernels); the reference is long double ``powl``
(64-bit significand: its own error is ~1/2000 of a double ulp).
"""

from __future__ import annotations

import ctypes
import math

import numpy as np
import pytest

from fsmctl.model.generated_code import compiled_library

_DP = ctypes.POINTER(ctypes.c_double)


@pytest.fixture(scope="module")
def lib():
    compiled = compiled_library()
    if compiled is None:
        pytest.skip("no compiled library (the CasADi functions use the VM's pow)")
    dll = ctypes.CDLL(str(compiled.path))
    dll.fsmctl_pow.argtypes = [ctypes.c_double, ctypes.c_double]
    dll.fsmctl_pow.restype = ctypes.c_double
    dll.fsm_pow_lanes.argtypes = [_DP, _DP, _DP, ctypes.c_longlong]
    dll.fsm_pow_lanes.restype = None
    dll.fsm_pow_lanes2.argtypes = [_DP, _DP, _DP, ctypes.c_longlong]
    dll.fsm_pow_lanes2.restype = None
    return dll


def _lanes(lib, x, y):
    x, y = np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(y, dtype=float)
    out = np.empty_like(x)
    lib.fsm_pow_lanes(x.ctypes.data_as(_DP), y.ctypes.data_as(_DP), out.ctypes.data_as(_DP), x.size)
    return out


def _ulp_error(r, x, y):
    ref = np.power(x.astype(np.longdouble), y.astype(np.longdouble))
    _, e = np.frexp(np.abs(ref))
    ulp = np.ldexp(np.ones_like(ref), (e - 53).astype(np.int32))
    return np.abs((r.astype(np.longdouble) - ref) / ulp).astype(float)


_RANGES = {
    "law": ((1e-12, 1.0), (0.0, 1.0), 0.55),  # |sigma_e|^alpha: x in (0, 1], 0 < alpha < 1
    "wide_x": ((1e-300, 1e300), (-1.0, 1.0), 0.55),
    "wide_y": ((1e-3, 1e3), (-16.0, 16.0), 0.9),
}


@pytest.mark.skipif(np.finfo(np.longdouble).nmant < 63, reason="needs x87 long double for the reference")
@pytest.mark.parametrize("name", sorted(_RANGES))
def test_accuracy_and_lanes_equal_scalar(lib, name):
    (xlo, xhi), (ylo, yhi), bound = _RANGES[name]
    rng = np.random.default_rng(14)
    n = 1 << 16
    x = np.exp(rng.uniform(math.log(xlo), math.log(xhi), n))
    y = rng.uniform(ylo, yhi, n)
    r = _lanes(lib, x, y)
    assert _ulp_error(r, x, y).max() <= bound
    assert all(lib.fsmctl_pow(float(a), float(b)) == v for a, b, v in zip(x[:2000], y[:2000], r[:2000], strict=True))


def test_exact_cases_and_special_values(lib):
    x = np.array([0.3, 7.5, 1e-200, 1.0, 2.0, 4.0, 0.0, 0.0, -0.0, -2.0, -2.0, np.inf, np.nan, 1.0, 5e-324, 2.0, 0.5])
    y = np.array([1.0, 2.0, 1.0, 0.7, 0.5, 0.5, 0.7, -0.5, 3.0, 3.0, 0.5, 0.7, 0.7, np.nan, 0.5, 2000.0, 2000.0])
    r = _lanes(lib, x, y)
    with np.errstate(all="ignore"):
        expected = np.power(x, y)  # IEEE special cases and exact results, as C99 Annex F
    np.testing.assert_array_equal(r[:3], [0.3, 56.25, 1e-200])
    np.testing.assert_array_equal(r[3:], expected[3:])
    np.testing.assert_array_equal([lib.fsmctl_pow(float(a), float(b)) for a, b in zip(x, y, strict=True)], r)


def test_two_powers_at_once_give_each_ones_bits(lib):
    # fsm_pow_vec2 (what the batched kernels call for independent powers side by side) interleaves the chains of two
    # vectors: every lane must equal fsm_pow_vec's, off the fast path too (zeros, negatives,
    # subnormals, infinities, NaN, y = 1 and 2, |y| >= 16 scattered so that some vectors of a call have such lanes
    # and others not)
    rng = np.random.default_rng(31)
    n = 2 * 8 * 6000
    x = np.exp(rng.uniform(math.log(1e-12), math.log(10.0), n))
    y = rng.uniform(-1.0, 1.0, n)
    special_x = [0.0, -0.0, -2.0, np.inf, np.nan, 5e-324, 1e-310, 1.0, 2.0, 1e300]
    special_y = [1.0, 2.0, 0.5, -0.5, 16.0, -20.0, np.nan, 3.0, 2000.0, 0.7]
    where = rng.choice(n, size=n // 50, replace=False)
    x[where] = rng.choice(special_x, size=where.size)
    y[where] = rng.choice(special_y, size=where.size)
    one = _lanes(lib, x, y)
    for size in (n, n - 5, n - 11):  # whole blocks, and partial last blocks (ending in either vector of the pair)
        out = np.empty(size)
        xs, ys = np.ascontiguousarray(x[:size]), np.ascontiguousarray(y[:size])
        lib.fsm_pow_lanes2(xs.ctypes.data_as(_DP), ys.ctypes.data_as(_DP), out.ctypes.data_as(_DP), size)
        np.testing.assert_array_equal(out.view(np.int64), one[:size].view(np.int64), err_msg=f"size = {size}")
