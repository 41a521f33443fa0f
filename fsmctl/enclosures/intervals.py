"""Rigorous enclosures of a CasADi ``SX`` function's outputs over boxes of its inputs.

:class:`IntervalFunction` walks the instruction list of an ``SXFunction`` once per call, every register holding
an interval ``[lo, hi]`` per box (NumPy arrays over many boxes at once), and returns an :class:`Enclosure` that
contains the true real-number value of every output at every point of each box.  The function is the graph *as
written*: its double constants are taken as exact reals and each operation as the real operation it names.

Soundness argument
------------------
* ``+ - * /`` and ``sqrt`` are correctly rounded in IEEE-754 binary64 (round to nearest), so the computed
  endpoint is within half an ulp of the exact one; moving it one ulp outward (``np.nextafter`` towards
  ``-inf``/``+inf``) gives a bound on the exact endpoint, including in the subnormal range and on overflow
  (an overflowed ``inf`` lower bound becomes ``DBL_MAX``, below the exact value).
* The transcendental functions (exp, log, sin, ..., pow, atan2, hypot) come from glibc's libm or from NumPy's
  SIMD kernels, and erf from SciPy; none is correctly rounded.  glibc's documented maxima (``libm-test-ulps``,
  x86-64) for these functions are 1-3 ulps; NumPy's AVX-512 kernels (Intel SVML) are documented at 4 ulps at
  most.  Each endpoint is widened by :data:`LIBM_ULPS` ulps (with a factor 2 to spare, see ``_dn``), then
  clamped to the known range of the function (``exp >= 0``, ``|sin| <= 1``, ``|atan| <= pi/2`` with
  outward-rounded pi...).
* Monotone functions map endpoints; the others (sq, even powers, cos, sin, cosh, fabs, atan2, ...) locate
  their extrema conservatively (a critical point is included whenever the rounded test cannot exclude it).
* Outside a function's domain (log or sqrt of negatives, division by an interval containing 0, a non-integer
  power of a possibly negative base, asin beyond [-1, 1]) the enclosure is ``[-inf, inf]``: a domain
  violation never yields a finite enclosure.  Any NaN is replaced by ``[-inf, inf]``.
* Discontinuous operations (sign, copysign, floor, ceil, fmod, remainder, comparisons, logic, if_else_zero)
  are tri-valued; when their outcome may change inside a box, the box's ``continuous`` flag is cleared.

Assumed: IEEE-754 round-to-nearest arithmetic in NumPy and the libm error bounds above.  The independent,
formally rigorous route is :meth:`IntervalFunction.enclose_arb`: the same semantics in python-flint's ``arb``
ball arithmetic (Arb's error bounds are proved), used as a cross-check.

Examples
--------
>>> import casadi
>>> x = casadi.SX.sym("x")
>>> f = IntervalFunction(casadi.Function("f", [x], [x * x - x]))
>>> e = f.enclose(np.array([0.0]), np.array([1.0]))
>>> bool(e.lo[0, 0] <= -0.25 and e.hi[0, 0] >= 0.0), bool(e.continuous[0])
(True, True)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial

import casadi
import flint
import numpy as np
from scipy import special

__all__ = ["LIBM_ULPS", "Enclosure", "IntervalFunction"]

LIBM_ULPS = 4
"""Ulps by which each endpoint of a libm/SIMD transcendental result is widened outward.

glibc documents (``libm-test-ulps``, x86-64) maximal errors of 1-3 ulps for exp, log, pow, sin, cos, tan,
atan, asin, acos, tanh, sinh, cosh, atan2, log1p, expm1, erf and hypot; NumPy dispatches float64 ufuncs to
Intel's SVML on AVX-512 machines, documented at a maximal error of 4 ulps.  Four ulps cover both."""

TRIG_ARGUMENT_LIMIT = 2.0**20
"""Largest argument magnitude for which sin/cos/tan locate their critical points; beyond it sin and cos
return [-1, 1] and tan returns [-inf, inf] (the rounded argument reduction is then not worth trusting)."""

_INF = math.inf
_DBL_MAX = float(np.finfo(float).max)
_ULP_FACTOR = 2.0**-51
_TINY = 2.0**-960  # see _dn
_PI_UP = math.nextafter(math.pi, _INF)  # math.pi < pi
_PI_HALF_UP = math.nextafter(math.pi / 2, _INF)
_TWO_OVER_PI = 2.0 / math.pi
_CRIT_SLACK = 1e-13  # relative slack on argument/(pi/2); its rounding error is below 1e-15 relative


@dataclass(frozen=True)
class Enclosure:
    """Bounds ``lo <= f <= hi`` of every output over each box, and whether f may jump inside the box.

    Attributes
    ----------
    lo, hi : numpy.ndarray
        Shape ``(n_out, N)``.
    continuous : numpy.ndarray
        Shape ``(N,)``: False when some discontinuous operation may switch inside the box.
    """

    lo: np.ndarray
    hi: np.ndarray
    continuous: np.ndarray


# --------------------------------------------------------------------------------------------- rounding
def _dn(x, ulps=1):
    """A double below every real within ``ulps`` ulps of ``x``, or within ``ulps * 2**-1011`` of it.

    ``(|x| + 2**-960) * ulps * 2**-51`` is at least ``2 * ulps`` ulps of a normal ``x`` and at least
    ``ulps * 2**-1011`` (covering any underflow to a subnormal or to 0); the rounding of the subtraction
    costs at most one ulp.  The slack stays a normal number: subnormal operands are 10x slower on x86.
    ``inf - inf`` (an overflowed lower bound: the exact value is above ``DBL_MAX``) becomes ``DBL_MAX``.
    ``x`` must be free of NaN.
    """
    return np.fmin(x - (np.abs(x) + _TINY) * (ulps * _ULP_FACTOR), _DBL_MAX)


def _up(x, ulps=1):
    """A double above every real within ``ulps`` ulps of ``x`` (or ``ulps * 2**-1011``); see :func:`_dn`."""
    return np.fmax(x + (np.abs(x) + _TINY) * (ulps * _ULP_FACTOR), -_DBL_MAX)


def _sound(lo, hi):
    """NaN bounds become the sound side (``-inf`` below, ``+inf`` above)."""
    return np.fmax(lo, -_INF), np.fmin(hi, _INF)


def _libm_dn(x):
    return _dn(np.fmax(x, -_INF), LIBM_ULPS)


def _libm_up(x):
    return _up(np.fmin(x, _INF), LIBM_ULPS)


def _libm(fn, a, b, lo_min=-_INF, hi_max=_INF):
    """Increasing libm function on [a, b]: widen by LIBM_ULPS and clamp to the known range."""
    lo, hi = _libm_dn(fn(a)), _libm_up(fn(b))
    return np.clip(lo, lo_min, hi_max), np.clip(hi, lo_min, hi_max)


def _whole(mask, lo, hi):
    """[-inf, inf] where mask (a domain violation or an unknown)."""
    return np.where(mask, -_INF, lo), np.where(mask, _INF, hi)


def _abs_range(a, b):
    """Exact range [m, M] of |x| over [a, b]."""
    m = np.where((a <= 0) & (b >= 0), 0.0, np.minimum(np.abs(a), np.abs(b)))
    return m, np.maximum(np.abs(a), np.abs(b))


# ------------------------------------------------------------------------- arithmetic (1-ulp rounding)
def _add(a, b, c, d):
    # invariants lo < +inf, hi > -inf: no inf - inf.  A sum of nonnegatives stays >= 0 (h = 0, max with
    # 0); otherwise h * DBL_MAX <= 2 * min(a, c) <= a + c is a harmless floor.
    h = np.minimum(np.minimum(a, c), 0.0)
    return np.maximum(_dn(a + c), h * _DBL_MAX), _up(b + d)


def _sub(a, b, c, d):
    return _dn(a - d), _up(b - c)


def _mul(a, b, c, d):
    p = (a * c, a * d, b * c, b * d)
    lo = np.minimum(np.minimum(p[0], p[1]), np.minimum(p[2], p[3]))
    hi = np.maximum(np.maximum(p[0], p[1]), np.maximum(p[2], p[3]))
    if np.isnan(lo).any() or np.isnan(hi).any():
        # 0 * inf: an exact-zero factor gives 0 whatever the (finite) other factor is.
        p = [np.where(np.isnan(q), 0.0, q) for q in p]
        lo = np.minimum(np.minimum(p[0], p[1]), np.minimum(p[2], p[3]))
        hi = np.maximum(np.maximum(p[0], p[1]), np.maximum(p[2], p[3]))
    return _dn(lo), _up(hi)


def _div(a, b, c, d):
    q = (a / c, a / d, b / c, b / d)
    lo, hi = _sound(
        np.fmin(np.fmin(q[0], q[1]), np.fmin(q[2], q[3])), np.fmax(np.fmax(q[0], q[1]), np.fmax(q[2], q[3]))
    )
    if np.isnan(q[0]).any() or np.isnan(q[1]).any() or np.isnan(q[2]).any() or np.isnan(q[3]).any():
        bad = np.isnan(q[0]) | np.isnan(q[1]) | np.isnan(q[2]) | np.isnan(q[3])  # inf / inf
        lo, hi = _whole(bad, lo, hi)
    lo, hi = _whole((c <= 0) & (d >= 0), _dn(lo), _up(hi))
    zero = (a == 0) & (b == 0) & ~((c == 0) & (d == 0))  # 0 / y = 0 wherever defined
    return np.where(zero, 0.0, lo), np.where(zero, 0.0, hi)


def _neg(a, b):
    return -b, -a


def _inv(a, b):
    one = np.ones_like(a)
    return _div(one, one, a, b)


def _sq(a, b):
    m, big = _abs_range(a, b)
    return np.maximum(_dn(m * m), 0.0), _up(big * big)


def _twice(a, b):
    return _dn(2.0 * a), _up(2.0 * b)  # exact but for overflow


def _sqrt(a, b):
    lo, hi = np.maximum(_dn(np.sqrt(np.maximum(a, 0.0))), 0.0), _up(np.sqrt(np.maximum(b, 0.0)))
    return _whole(a < 0, lo, hi)


def _fabs(a, b):
    return _abs_range(a, b)


def _fmin(a, b, c, d):
    return np.minimum(a, c), np.minimum(b, d)


def _fmax(a, b, c, d):
    return np.maximum(a, c), np.maximum(b, d)


# ------------------------------------------------------------------- transcendental (LIBM_ULPS rounding)
# increasing libm functions, clamped to their known ranges
_exp = partial(_libm, np.exp, lo_min=0.0)
_expm1 = partial(_libm, np.expm1, lo_min=-1.0)
_atan = partial(_libm, np.arctan, lo_min=-_PI_HALF_UP, hi_max=_PI_HALF_UP)
_tanh = partial(_libm, np.tanh, lo_min=-1.0, hi_max=1.0)
_sinh = partial(_libm, np.sinh)
_erf = partial(_libm, special.erf, lo_min=-1.0, hi_max=1.0)


def _log(a, b):
    lo, hi = _libm(np.log, np.maximum(a, 0.0), np.maximum(b, 0.0))
    lo = np.where(a == 0, -_INF, lo)
    return _whole((a < 0) | (b <= 0), lo, hi)


def _log1p(a, b):
    lo, hi = _libm(np.log1p, np.maximum(a, -1.0), np.maximum(b, -1.0))
    lo = np.where(a == -1.0, -_INF, lo)
    return _whole((a < -1.0) | (b <= -1.0), lo, hi)


def _cosh(a, b):
    m, big = _abs_range(a, b)
    return _libm(np.cosh, m, big, 1.0)


def _asin(a, b):
    lo, hi = _libm(np.arcsin, np.clip(a, -1.0, 1.0), np.clip(b, -1.0, 1.0), -_PI_HALF_UP, _PI_HALF_UP)
    return _whole((a < -1.0) | (b > 1.0), lo, hi)


def _acos(a, b):
    lo, hi = _libm(lambda v: -np.arccos(v), np.clip(a, -1.0, 1.0), np.clip(b, -1.0, 1.0), -_PI_UP, 0.0)
    return _whole((a < -1.0) | (b > 1.0), -hi, -lo)


def _critical(a, b):
    """Integer range [n_lo, n_hi] containing every k with k*pi/2 in [a, b] (conservatively widened)."""
    ta, tb = a * _TWO_OVER_PI, b * _TWO_OVER_PI
    n_lo = np.ceil(ta - _CRIT_SLACK * (1.0 + np.abs(ta)))
    n_hi = np.floor(tb + _CRIT_SLACK * (1.0 + np.abs(tb)))
    return n_lo, n_hi


def _contains_residue(n_lo, n_hi, r):
    """Whether some integer k = r (mod 4) lies in [n_lo, n_hi]."""
    first = n_lo + np.mod(r - n_lo, 4.0)
    return first <= n_hi


def _sincos(fn, a, b, max_residue, min_residue):
    fa, fb = fn(a), fn(b)
    lo, hi = _libm_dn(np.minimum(fa, fb)), _libm_up(np.maximum(fa, fb))
    n_lo, n_hi = _critical(a, b)
    hi = np.where(_contains_residue(n_lo, n_hi, max_residue), 1.0, hi)
    lo = np.where(_contains_residue(n_lo, n_hi, min_residue), -1.0, lo)
    wide = (b - a >= 6.0) | (np.abs(a) > TRIG_ARGUMENT_LIMIT) | (np.abs(b) > TRIG_ARGUMENT_LIMIT)
    return np.where(wide, -1.0, np.clip(lo, -1.0, 1.0)), np.where(wide, 1.0, np.clip(hi, -1.0, 1.0))


def _sin(a, b):
    # maxima of sin at k*pi/2 with k = 1 (mod 4), minima at k = 3 (mod 4)
    return _sincos(np.sin, a, b, 1.0, 3.0)


def _cos(a, b):
    return _sincos(np.cos, a, b, 0.0, 2.0)


def _tan(a, b):
    lo, hi = _libm_dn(np.tan(a)), _libm_up(np.tan(b))
    n_lo, n_hi = _critical(a, b)
    pole = _contains_residue(n_lo, n_hi, 1.0) | _contains_residue(n_lo, n_hi, 3.0)
    pole |= (b - a >= 3.0) | (np.abs(a) > TRIG_ARGUMENT_LIMIT) | (np.abs(b) > TRIG_ARGUMENT_LIMIT)
    return _whole(pole, lo, hi)


def _atan2(yl, yh, xl, xh):
    # The angle of a rectangle avoiding the origin and the cut {y = 0, x < 0} is extreme at its corners.
    yl0, yh0 = yl + 0.0, yh + 0.0  # -0.0 -> +0.0: y = 0 is on the upper side (atan2(0, x < 0) = pi)
    v = (np.arctan2(yl0, xl), np.arctan2(yl0, xh), np.arctan2(yh0, xl), np.arctan2(yh0, xh))
    lo = _libm_dn(np.minimum(np.minimum(v[0], v[1]), np.minimum(v[2], v[3])))
    hi = _libm_up(np.maximum(np.maximum(v[0], v[1]), np.maximum(v[2], v[3])))
    y_zero = (yl <= 0) & (yh >= 0)
    jump = ((yl < 0) & (yh >= 0) & (xl < 0)) | (y_zero & (xl <= 0) & (xh >= 0))
    lo, hi = np.where(jump, -_PI_UP, np.maximum(lo, -_PI_UP)), np.where(jump, _PI_UP, np.minimum(hi, _PI_UP))
    return lo, hi, jump


def _hypot(a, b, c, d):
    # increasing in |x| and |y|
    m1, big1 = _abs_range(a, b)
    m2, big2 = _abs_range(c, d)
    lo, hi = _libm_dn(np.hypot(m1, m2)), _libm_up(np.hypot(big1, big2))
    return np.maximum(lo, 0.0), hi


def _int_pow(a, b, n):
    """x**n for integer-valued n: even powers through |x|, odd powers monotone on each side of 0."""
    m, big = _abs_range(a, b)
    even = np.mod(n, 2.0) == 0
    negative = n < 0
    pm, pbig = np.power(m, n), np.power(big, n)
    pa, pb = np.copysign(np.power(np.abs(a), n), a), np.copysign(np.power(np.abs(b), n), b)
    lo = np.where(even, np.where(negative, pbig, pm), np.where(negative, pb, pa))
    hi = np.where(even, np.where(negative, pm, pbig), np.where(negative, pa, pb))
    lo, hi = _libm_dn(lo), _libm_up(hi)
    lo = np.where(even, np.maximum(lo, 0.0), lo)
    lo, hi = np.where(n == 0, 1.0, lo), np.where(n == 0, 1.0, hi)  # pow(x, 0) = 1
    return _whole(negative & (a <= 0) & (b >= 0), lo, hi)


def _real_pow(a, b, c, d):
    """x**y for x >= 0: x**y = exp(y log x) is extreme at the corners of the box."""
    a0, b0 = np.maximum(a, 0.0), np.maximum(b, 0.0)
    v = (np.power(a0, c), np.power(a0, d), np.power(b0, c), np.power(b0, d))
    lo = np.minimum(np.minimum(v[0], v[1]), np.minimum(v[2], v[3]))
    hi = np.maximum(np.maximum(v[0], v[1]), np.maximum(v[2], v[3]))
    lo, hi = _libm_dn(lo), _libm_up(hi)
    # x > 0, or x >= 0 with y > 0 (0**y = 0); otherwise x may leave the domain
    return _whole(~((a > 0) | ((a >= 0) & (c > 0))), np.maximum(lo, 0.0), hi)


def _pow(a, b, c, d):
    integer = (c == d) & (np.floor(c) == c) & (np.abs(c) < 2.0**53)
    if integer.all():
        return _int_pow(a, b, c)
    if not integer.any():
        return _real_pow(a, b, c, d)
    il, ih = _int_pow(a, b, c)
    rl, rh = _real_pow(a, b, c, d)
    return np.where(integer, il, rl), np.where(integer, ih, rh)


# ------------------------------------------------ discontinuous operations: (lo, hi, may_switch)
def _sign(a, b):
    lo = np.where(a > 0, 1.0, np.where(a == 0, 0.0, -1.0))  # sign is non-decreasing
    hi = np.where(b > 0, 1.0, np.where(b == 0, 0.0, -1.0))
    return lo, hi, lo != hi


def _copysign(xl, xh, yl, yh):
    # copysign(x, y) = |x| for y >= 0 (y = 0 counts as positive), -|x| for y < 0
    m, big = _abs_range(xl, xh)
    pos, neg = yl >= 0, yh < 0
    lo = np.where(pos, m, -big)
    hi = np.where(pos, big, np.where(neg, -m, big))
    return lo, hi, ~pos & ~neg & (big > 0)


def _floor(a, b):
    lo, hi = np.floor(a), np.floor(b)
    return lo, hi, lo != hi


def _ceil(a, b):
    lo, hi = np.ceil(a), np.ceil(b)
    return lo, hi, lo != hi


def _modulo(a, b, c, d, rounding, bound_lo, bound_hi):
    """x - n*y with n = rounding(x / y): exact affine rule where n is constant on the box."""
    ql, qh = _div(a, b, c, d)
    nl, nh = rounding(ql), rounding(qh)
    const = (nl == nh) & np.isfinite(nl)
    pl, ph = _mul(np.where(const, nl, 0.0), np.where(const, nh, 0.0), c, d)
    rl, rh = _sub(a, b, pl, ph)
    lo = np.where(const, np.maximum(rl, bound_lo), bound_lo)
    hi = np.where(const, np.minimum(rh, bound_hi), bound_hi)
    zero = (c <= 0) & (d >= 0)
    lo, hi = _whole(zero, lo, hi)
    return lo, hi, ~const | zero


def _fmod(a, b, c, d):
    # C fmod: truncated quotient; |r| < |y| with the sign of x
    big = np.maximum(np.abs(c), np.abs(d))
    return _modulo(a, b, c, d, np.trunc, np.where(a >= 0, 0.0, -big), np.where(b <= 0, 0.0, big))


def _remainder(a, b, c, d):
    # C remainder: quotient rounded half to even (np.rint); |r| <= |y| / 2
    half = _up(0.5 * np.maximum(np.abs(c), np.abs(d)))
    return _modulo(a, b, c, d, np.rint, -half, half)


def _tri(true, false):
    """Tri-valued truth: [1, 1], [0, 0] or [0, 1] (uncertain, may switch)."""
    unknown = ~true & ~false
    return np.where(true, 1.0, 0.0), np.where(false, 0.0, 1.0), unknown


def _truth(a, b):
    return (a > 0) | (b < 0), (a == 0) & (b == 0)


def _lt(a, b, c, d):
    return _tri(b < c, a >= d)


def _le(a, b, c, d):
    return _tri(b <= c, a > d)


def _eq(a, b, c, d):
    return _tri((a == b) & (c == d) & (a == c), (b < c) | (a > d))


def _ne(a, b, c, d):
    return _tri((b < c) | (a > d), (a == b) & (c == d) & (a == c))


def _not(a, b):
    true, false = _truth(a, b)
    return _tri(false, true)


def _and(a, b, c, d):
    t1, f1 = _truth(a, b)
    t2, f2 = _truth(c, d)
    return _tri(t1 & t2, f1 | f2)


def _or(a, b, c, d):
    t1, f1 = _truth(a, b)
    t2, f2 = _truth(c, d)
    return _tri(t1 | t2, f1 & f2)


def _if_else_zero(a, b, xl, xh):
    true, false = _truth(a, b)
    lo = np.where(true, xl, np.where(false, 0.0, np.minimum(xl, 0.0)))
    hi = np.where(true, xh, np.where(false, 0.0, np.maximum(xh, 0.0)))
    return lo, hi, ~true & ~false & ~((xl == 0) & (xh == 0))


def _table(names: str, prefix: str) -> dict[int, Callable]:
    """Map ``casadi.OP_<NAME>`` to this module's function ``<prefix><name>`` for each name."""
    return {getattr(casadi, "OP_" + name.upper()): globals()[prefix + name] for name in names.split()}


_UNARY = _table("neg inv sq twice sqrt exp log sin cos tan atan asin acos tanh sinh cosh fabs log1p expm1 erf", "_")
_BINARY = _table("add sub mul div pow fmin fmax hypot", "_") | {casadi.OP_CONSTPOW: _pow}
_UNARY_SWITCH = _table("sign floor ceil not", "_")
_BINARY_SWITCH = _table("atan2 copysign fmod remainder lt le eq ne and or if_else_zero", "_")


# ------------------------------------------------------------------------------ ball arithmetic (arb)
def _arb_nan() -> flint.arb:
    return flint.arb.nan()


def _arb_tri(true: bool, false: bool) -> flint.arb:
    if true:
        return flint.arb(1)
    return flint.arb(0) if false else flint.arb(0).union(flint.arb(1))


def _arb_truth(x: flint.arb) -> tuple[bool, bool]:
    return bool(x != 0), bool(x == 0)


def _arb_nonnegative(x: flint.arb) -> flint.arb:
    """A ball for a quantity known to be >= 0 (a square): cut off the negative part of the ball."""
    return x if x >= 0 else flint.arb(0).union(x.upper())


def _arb_pow(x: flint.arb, y: flint.arb) -> flint.arb:
    if y.is_exact() and y.is_integer():
        n = int(y.unique_fmpz())
        if n == 0:
            return flint.arb(1)
        return _arb_nan() if n < 0 and x.contains(0) else x**n
    if x > 0:
        return x**y
    if x >= 0 and y > 0:
        return flint.arb(0) if x.is_zero() else x**y
    return _arb_nan()


def _arb_copysign(x: flint.arb, y: flint.arb) -> flint.arb:
    if y >= 0:
        return abs(x)
    return -abs(x) if y < 0 else abs(x).union(-abs(x))


def _arb_modulo(x: flint.arb, y: flint.arb, remainder: bool) -> flint.arb:
    q = x / y
    if not q.is_finite():
        return _arb_nan()
    # trunc(q) lies between floor(q) and ceil(q); round(q) between ceil(q - 1/2) and floor(q + 1/2)
    n = (q - 0.5).ceil().union((q + 0.5).floor()) if remainder else q.floor().union(q.ceil())
    return x - n * y


def _arb_if_else_zero(c: flint.arb, x: flint.arb) -> flint.arb:
    true, false = _arb_truth(c)
    if true:
        return x
    return flint.arb(0) if false else x.union(flint.arb(0))


def _arb_logic(c: flint.arb, d: flint.arb, conjunction: bool) -> flint.arb:
    t1, f1 = _arb_truth(c)
    t2, f2 = _arb_truth(d)
    if conjunction:
        return _arb_tri(t1 and t2, f1 or f2)
    return _arb_tri(t1 or t2, f1 and f2)


_ARB_METHODS = "exp sin cos tan atan tanh sinh cosh expm1 erf floor ceil"  # casadi OP name = arb method


def _arb_domain(x: flint.arb, ok: bool, fn: Callable) -> flint.arb:
    return fn(x) if ok else _arb_nan()


_ARB_UNARY = {getattr(casadi, "OP_" + n.upper()): getattr(flint.arb, n) for n in _ARB_METHODS.split()} | {
    casadi.OP_NEG: lambda x: -x,
    casadi.OP_INV: lambda x: 1 / x,
    casadi.OP_SQ: lambda x: _arb_nonnegative(x**2),
    casadi.OP_TWICE: lambda x: 2 * x,
    casadi.OP_SQRT: lambda x: _arb_domain(x, x >= 0, flint.arb.sqrt),
    casadi.OP_LOG: lambda x: _arb_domain(x, x > 0, flint.arb.log),
    casadi.OP_LOG1P: lambda x: _arb_domain(x, x > -1, flint.arb.log1p),
    casadi.OP_ASIN: lambda x: _arb_domain(x, x >= -1 and x <= 1, flint.arb.asin),
    casadi.OP_ACOS: lambda x: _arb_domain(x, x >= -1 and x <= 1, flint.arb.acos),
    casadi.OP_FABS: abs,
    casadi.OP_SIGN: flint.arb.sgn,
    casadi.OP_NOT: lambda x: _arb_tri(_arb_truth(x)[1], _arb_truth(x)[0]),
}
_ARB_BINARY = {
    casadi.OP_ADD: lambda x, y: x + y,
    casadi.OP_SUB: lambda x, y: x - y,
    casadi.OP_MUL: lambda x, y: x * y,
    casadi.OP_DIV: lambda x, y: x / y,
    casadi.OP_POW: _arb_pow,
    casadi.OP_CONSTPOW: _arb_pow,
    casadi.OP_FMIN: lambda x, y: x.min(y),
    casadi.OP_FMAX: lambda x, y: x.max(y),
    casadi.OP_HYPOT: lambda x, y: _arb_nonnegative(x**2 + y**2).sqrt(),
    casadi.OP_ATAN2: flint.arb.atan2,
    casadi.OP_COPYSIGN: _arb_copysign,
    casadi.OP_FMOD: lambda x, y: _arb_modulo(x, y, False),
    casadi.OP_REMAINDER: lambda x, y: _arb_modulo(x, y, True),
    casadi.OP_LT: lambda x, y: _arb_tri(x < y, x >= y),
    casadi.OP_LE: lambda x, y: _arb_tri(x <= y, x > y),
    casadi.OP_EQ: lambda x, y: _arb_tri(x == y, x != y),
    casadi.OP_NE: lambda x, y: _arb_tri(x != y, x == y),
    casadi.OP_AND: lambda x, y: _arb_logic(x, y, True),
    casadi.OP_OR: lambda x, y: _arb_logic(x, y, False),
    casadi.OP_IF_ELSE_ZERO: _arb_if_else_zero,
}


def _arb_to_floats(x: flint.arb) -> tuple[float, float]:
    """Doubles ``lo <= x <= hi`` (rounded outward); ``(-inf, inf)`` for a non-finite ball."""
    if not x.is_finite():
        return -_INF, _INF
    lo, hi = float(x.lower()), float(x.upper())
    for _ in range(8):
        if flint.arb(lo) <= x:
            break
        lo = math.nextafter(lo, -_INF)
    else:
        lo = -_INF
    for _ in range(8):
        if flint.arb(hi) >= x:
            break
        hi = math.nextafter(hi, _INF)
    else:
        hi = _INF
    return lo, hi


# ------------------------------------------------------------------------------------------- program
_CONST, _INPUT, _OUTPUT, _ASSIGN, _UN, _BIN, _UN_SW, _BIN_SW = range(8)
_KIND = {op: _UN for op in _UNARY} | {op: _BIN for op in _BINARY}
_KIND |= {op: _UN_SW for op in _UNARY_SWITCH} | {op: _BIN_SW for op in _BINARY_SWITCH}
_FUNCTIONS = _UNARY | _BINARY | _UNARY_SWITCH | _BINARY_SWITCH
_OP_NAMES = {getattr(casadi, name): name for name in dir(casadi) if name.startswith("OP_")}


def _dense_offsets(sparsities: list) -> tuple[list[list[int]], int]:
    """For each argument, the dense (column-major) position of each nonzero in the concatenation."""
    positions, offset = [], 0
    for sp in sparsities:
        rows, cols = sp.get_triplet()
        positions.append([offset + r + c * sp.size1() for r, c in zip(rows, cols, strict=True)])
        offset += sp.numel()
    return positions, offset


def _constant_bounds(c: float) -> tuple[float, float]:
    if math.isnan(c):
        return -_INF, _INF
    if math.isinf(c):
        return (_DBL_MAX, _INF) if c > 0 else (-_INF, -_DBL_MAX)
    return c, c


class IntervalFunction:
    """A CasADi SX function evaluated on boxes: ``y = f(x)``.

    ``x`` is the concatenation of all inputs (each dense, column-major, in input order), ``y`` the
    concatenation of all outputs (dense, column-major; structurally zero entries are exactly 0).

    Parameters
    ----------
    function : casadi.Function
        An ``SXFunction`` (convert an ``MXFunction`` with ``.expand()``).

    Raises
    ------
    TypeError
        If ``function`` is not an ``SXFunction``.
    NotImplementedError
        If the graph holds an operation without an interval rule (named in the message).

    Examples
    --------
    >>> import casadi
    >>> x = casadi.SX.sym("x", 2)
    >>> f = IntervalFunction(casadi.Function("f", [x], [casadi.sin(x[0]) * x[1]]))
    >>> (f.n_in, f.n_out)
    (2, 1)
    >>> lo, hi = f.enclose_arb([0.0, 1.0], [0.5, 2.0])
    >>> bool(lo[0] <= 0.0 and hi[0] >= 2 * math.sin(0.5))
    True
    """

    def __init__(self, function: casadi.Function) -> None:
        if not isinstance(function, casadi.Function) or not function.is_a("SXFunction"):
            raise TypeError("IntervalFunction needs a casadi SXFunction (use .expand() on an MXFunction)")
        self._function = function
        in_pos, self.n_in = _dense_offsets([function.sparsity_in(i) for i in range(function.n_in())])
        out_pos, self.n_out = _dense_offsets([function.sparsity_out(i) for i in range(function.n_out())])
        self.n_instructions = function.n_instructions()
        self._n_work = function.sz_w()
        self._program = [self._compile(function, k, in_pos, out_pos) for k in range(self.n_instructions)]

    @staticmethod
    def _compile(function: casadi.Function, k: int, in_pos: list, out_pos: list) -> tuple:
        op = function.instruction_id(k)
        ins, outs = function.instruction_input(k), function.instruction_output(k)
        if op == casadi.OP_CONST:
            return (_CONST, op, None, outs[0], 0, 0, _constant_bounds(function.instruction_constant(k)))
        if op == casadi.OP_INPUT:
            return (_INPUT, op, None, outs[0], in_pos[ins[0]][ins[1]], 0, None)
        if op == casadi.OP_OUTPUT:
            return (_OUTPUT, op, None, out_pos[outs[0]][outs[1]], ins[0], 0, None)
        if op == casadi.OP_ASSIGN:
            return (_ASSIGN, op, None, outs[0], ins[0], 0, None)
        if op not in _KIND:
            raise NotImplementedError(f"no interval rule for CasADi operation {_OP_NAMES.get(op, op)}")
        second = ins[1] if len(ins) > 1 else 0
        return (_KIND[op], op, _FUNCTIONS[op], outs[0], ins[0], second, None)

    def _boxes(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
        if lo.ndim == 1:
            lo, hi = lo[:, None], hi.reshape(-1, 1)
        if lo.shape != hi.shape or lo.ndim != 2 or lo.shape[0] != self.n_in:
            raise ValueError(f"boxes must have shape ({self.n_in}, N); got {lo.shape} and {hi.shape}")
        if not np.all(lo <= hi):
            raise ValueError("every box needs lo <= hi (and no NaN)")
        if np.any(lo == _INF) or np.any(hi == -_INF):
            raise ValueError("a box bound lo = +inf or hi = -inf holds no real point")
        return np.ascontiguousarray(lo), np.ascontiguousarray(hi)

    def enclose(self, lo: np.ndarray, hi: np.ndarray) -> Enclosure:
        """Enclose every output over each box ``[lo[:, j], hi[:, j]]`` (NumPy, outward rounding).

        Parameters
        ----------
        lo, hi : numpy.ndarray
            Shape ``(n_in, N)`` (or ``(n_in,)`` for one box), ``lo <= hi``.

        Returns
        -------
        Enclosure
            ``lo``, ``hi`` of shape ``(n_out, N)`` and the ``continuous`` flags.

        Raises
        ------
        ValueError
            On a shape mismatch, ``lo > hi`` or NaN bounds.
        """
        lo, hi = self._boxes(lo, hi)
        n = lo.shape[1]
        reg_lo: list = [None] * self._n_work
        reg_hi: list = [None] * self._n_work
        out_lo, out_hi = np.zeros((self.n_out, n)), np.zeros((self.n_out, n))
        switch = np.zeros(n, dtype=bool)
        with np.errstate(all="ignore"):
            for kind, _, fn, o, i0, i1, c in self._program:
                if kind == _BIN:
                    reg_lo[o], reg_hi[o] = fn(reg_lo[i0], reg_hi[i0], reg_lo[i1], reg_hi[i1])
                elif kind == _UN:
                    reg_lo[o], reg_hi[o] = fn(reg_lo[i0], reg_hi[i0])
                elif kind == _CONST:
                    reg_lo[o], reg_hi[o] = np.full(n, c[0]), np.full(n, c[1])
                elif kind == _INPUT:
                    reg_lo[o], reg_hi[o] = lo[i0], hi[i0]
                elif kind == _OUTPUT:
                    out_lo[o], out_hi[o] = reg_lo[i0], reg_hi[i0]
                elif kind == _ASSIGN:
                    reg_lo[o], reg_hi[o] = reg_lo[i0], reg_hi[i0]
                elif kind == _BIN_SW:
                    reg_lo[o], reg_hi[o], may = fn(reg_lo[i0], reg_hi[i0], reg_lo[i1], reg_hi[i1])
                    switch |= may
                else:
                    reg_lo[o], reg_hi[o], may = fn(reg_lo[i0], reg_hi[i0])
                    switch |= may
        return Enclosure(lo=out_lo, hi=out_hi, continuous=~switch)

    def _run_arb(self, inputs: list) -> list:
        reg: list = [None] * self._n_work
        out = [flint.arb(0)] * self.n_out
        for kind, op, _, o, i0, i1, c in self._program:
            if kind in (_BIN, _BIN_SW):
                reg[o] = _ARB_BINARY[op](reg[i0], reg[i1])
            elif kind in (_UN, _UN_SW):
                reg[o] = _ARB_UNARY[op](reg[i0])
            elif kind == _CONST:
                reg[o] = flint.arb(c[0]) if c[0] == c[1] else flint.arb(c[0]).union(flint.arb(c[1]))
            elif kind == _INPUT:
                reg[o] = inputs[i0]
            elif kind == _OUTPUT:
                out[o] = reg[i0]
            else:
                reg[o] = reg[i0]
        return out

    def enclose_arb(
        self, lo: Sequence[float], hi: Sequence[float], precision: int = 128
    ) -> tuple[np.ndarray, np.ndarray]:
        """Enclose every output over one box in ``arb`` ball arithmetic, rounded outward to doubles.

        Parameters
        ----------
        lo, hi : sequence of float
            The box, length ``n_in``.
        precision : int
            Working precision in bits.

        Returns
        -------
        tuple of numpy.ndarray
            ``(lo, hi)``, each of length ``n_out``.
        """
        box_lo, box_hi = self._boxes(np.asarray(lo, dtype=float), np.asarray(hi, dtype=float))
        previous = flint.ctx.prec
        try:
            flint.ctx.prec = precision
            balls = [flint.arb(a).union(flint.arb(b)) for a, b in zip(box_lo[:, 0], box_hi[:, 0], strict=True)]
            bounds = [_arb_to_floats(v) for v in self._run_arb(balls)]
        finally:
            flint.ctx.prec = previous
        return np.array([b[0] for b in bounds]), np.array([b[1] for b in bounds])

    def evaluate_ball(self, x: Sequence[float], precision: int = 256) -> list:
        """Evaluate at one point in ``arb`` ball arithmetic: each ball contains the exact output value.

        Parameters
        ----------
        x : sequence of float
            The point, length ``n_in`` (each double taken as exact).
        precision : int
            Working precision in bits.

        Returns
        -------
        list of flint.arb
            The ``n_out`` outputs.
        """
        point = np.asarray(x, dtype=float)
        if point.shape != (self.n_in,) or not np.all(np.isfinite(point)):
            raise ValueError(f"x must be {self.n_in} finite numbers")
        previous = flint.ctx.prec
        try:
            flint.ctx.prec = precision
            return self._run_arb([flint.arb(float(v)) for v in point])
        finally:
            flint.ctx.prec = previous
