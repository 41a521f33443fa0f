"""fsmctl's sin and cos (fsmctl/csrc/fsm_trig.h), those of every compiled path: accurate, lanes equal scalar calls.

The compiled library exports the scalar ``fsmctl_sin``/``fsmctl_cos`` (what the CasADi-generated scalar C calls:
the disturbance and the reference) and ``fsm_trig_lanes`` (the four-lane computation of the batched kernels).
Two independent references: long double ``sinl``/``cosl`` (64-bit significand, its own error ~1/2000 of a double
ulp) on many samples, and mpmath at 120 bits on fewer.  The C library's own sin/cos (Python's ``math``) is the
reference for the lanes that fall back to it, bit for bit.
"""

from __future__ import annotations

import ctypes
import math

import mpmath
import numpy as np
import pytest

from fsmctl.model.generated_code import compiled_library

_DP = ctypes.POINTER(ctypes.c_double)
_BOUND_ULP = 0.8
"""The measured maximum is 0.76 ulp (2^19 samples per range; fdlibm's kernels, whose final rounding of
1 - z/2 + ... and x + x^3 S(x^2) is not compensated); glibc's sin/cos are at 0.51 on the same samples."""


@pytest.fixture(scope="module")
def lib():
    compiled = compiled_library()
    if compiled is None:
        pytest.skip("no compiled library (the CasADi functions use the VM's sin and cos)")
    dll = ctypes.CDLL(str(compiled.path))
    for name in ("fsmctl_sin", "fsmctl_cos"):
        getattr(dll, name).argtypes = [ctypes.c_double]
        getattr(dll, name).restype = ctypes.c_double
    dll.fsm_trig_lanes.argtypes = [_DP, _DP, ctypes.c_longlong, ctypes.c_int]
    dll.fsm_trig_lanes.restype = None
    return dll


def _lanes(lib, x, want_sin: bool) -> np.ndarray:
    x = np.ascontiguousarray(x, dtype=float)
    out = np.empty_like(x)
    lib.fsm_trig_lanes(x.ctypes.data_as(_DP), out.ctypes.data_as(_DP), x.size, int(want_sin))
    return out


def _ulp(ref: np.ndarray) -> np.ndarray:
    _, e = np.frexp(np.abs(ref))
    return np.ldexp(np.ones_like(ref), (np.maximum(e, -1021) - 53).astype(np.int32))


_RANGES = {
    "one_turn": (0.0, 2 * math.pi),  # the reference and the disturbance early in a run
    "disturbance": (0.0, 200.0),  # w t + phi over a 100 s run with w up to ~2 rad/s
    "fast_path_end": (0.0, 2.0**20),  # the whole fast path
}


@pytest.mark.skipif(np.finfo(np.longdouble).nmant < 63, reason="needs x87 long double for the reference")
@pytest.mark.parametrize("name", sorted(_RANGES))
@pytest.mark.parametrize("want_sin", [False, True], ids=["cos", "sin"])
def test_accuracy_and_lanes_equal_scalar(lib, name, want_sin):
    lo, hi = _RANGES[name]
    rng = np.random.default_rng(14)
    x = rng.uniform(lo, hi, 1 << 16)
    x = np.concatenate([x, -x])
    r = _lanes(lib, x, want_sin)
    xl = x.astype(np.longdouble)
    ref = np.sin(xl) if want_sin else np.cos(xl)
    err = np.abs((r.astype(np.longdouble) - ref) / _ulp(ref)).astype(float)
    assert err.max() <= _BOUND_ULP
    scalar = lib.fsmctl_sin if want_sin else lib.fsmctl_cos
    assert all(scalar(float(a)) == v for a, v in zip(x[:2000], r[:2000], strict=True))


@pytest.mark.parametrize("want_sin", [False, True], ids=["cos", "sin"])
def test_against_mpmath(lib, want_sin):
    """An oracle that does not share the x87 hardware: 120-bit mpmath, arguments spread over 2^-30 .. 2^20."""
    rng = np.random.default_rng(2012)
    x = np.exp(rng.uniform(math.log(2.0**-30), math.log(2.0**20), 1500)) * rng.choice([-1.0, 1.0], 1500)
    r = _lanes(lib, x, want_sin)
    with mpmath.workprec(120):
        f = mpmath.sin if want_sin else mpmath.cos
        ref = np.array([float(f(mpmath.mpf(float(v)))) for v in x])
        err = [
            abs((mpmath.mpf(float(got)) - f(mpmath.mpf(float(v)))) / mpmath.mpf(float(u)))
            for got, v, u in zip(r, x, _ulp(ref), strict=True)
        ]
    assert float(max(err)) <= _BOUND_ULP


def test_special_values_and_fallbacks_are_the_c_librarys(lib):
    """Zeros keep their sign, NaN and infinities give NaN, and the lanes off the fast path (|x| >= 2^20, and
    arguments within 2^-10 of a nonzero multiple of pi/2, where the reduction's error would matter) are the C
    library's results bit for bit."""
    near = [k * math.pi / 2 for k in range(1, 400)]  # the doubles nearest to k pi/2: |r| ~ 1e-16
    near += [math.nextafter(v, math.inf) for v in near[:50]] + [1e6 * math.pi, 1234567.0, 2.0**20, 1e300]
    x = np.array([0.0, -0.0, 5e-324, -5e-324, 1e-300, *near])
    for want_sin, ref in ((False, math.cos), (True, math.sin)):
        r = _lanes(lib, x, want_sin)
        expected = np.array([ref(float(v)) for v in x])
        assert (r.view(np.int64) == expected.view(np.int64)).all(), "sin" if want_sin else "cos"
    with np.errstate(invalid="ignore"):
        for want_sin in (False, True):
            assert np.isnan(_lanes(lib, np.array([np.inf, -np.inf, np.nan]), want_sin)).all()
    assert math.copysign(1.0, lib.fsmctl_sin(-0.0)) == -1.0 and lib.fsmctl_cos(-0.0) == 1.0


def test_partial_blocks_and_quadrants(lib):
    """Every quadrant (n mod 4, both signs) and blocks of 1..3 lanes: the same bits as whole blocks of four."""
    x = np.array([0.3 + k * math.pi / 2 for k in range(-8, 9)])
    for want_sin in (False, True):
        whole = _lanes(lib, x, want_sin)
        ref = np.sin(x) if want_sin else np.cos(x)
        np.testing.assert_allclose(whole, ref, rtol=2e-16, atol=0)
        for k in range(1, 4):
            assert np.array_equal(_lanes(lib, x[:k], want_sin), whole[:k])
