/*
 * @P@_math: fsmctl's elementary functions for an exported law (see @P@_math.h).  Portable C99: IEEE 754 binary64
 * doubles and a 64-bit unsigned long long are assumed (checked below); no library function is called.
 * Copied by `fsmctl export` from fsmctl/csrc/export/export_math.c (do not edit the copy).
 *
 * pow: the operations of fsm_pow_vec (fsmctl/csrc/fsm_pow.h, one lane), whose method and measured error are
 * documented there: x = 2^e m, log m by the atanh series in double-double, z = y log x (Dekker's exact product, the
 * splitting form: the same bits as the FMA form), exp z = 2^n exp(r).  Compile with -ffp-contract=off (GCC's default
 * in -std=c99 mode): a fused multiply-add would change the bits.
 */
#include "@P@_math.h"

typedef union {
  double d;
  unsigned long long u;
} @P@_bits;

/* binary64 doubles and 64-bit long longs, or a compile error */
typedef char @P@_math_sizes_ok[(sizeof(double) == 8 && sizeof(unsigned long long) == 8) ? 1 : -1];

static double from_bits(unsigned long long u) {
  @P@_bits b;
  b.u = u;
  return b.d;
}

static unsigned long long to_bits(double d) {
  @P@_bits b;
  b.d = d;
  return b.u;
}

static const double LN2_HI = 0x1.62e42fefa3800p-1, LN2_LO = 0x1.ef35793c76730p-45; /* LN2_HI: 42 bits */

/* a b = p + *e exactly (|a|, |b| < 2^995, no underflow): Dekker and Veltkamp's splitting */
static double two_prod(double a, double b, double *e) {
  const double split = 134217729.0; /* 2^27 + 1 */
  const double p = a * b;
  const double ca = split * a, cb = split * b;
  const double ah = ca - (ca - a), bh = cb - (cb - b);
  const double al = a - ah, bl = b - bh;
  *e = (((ah * bh - p) + ah * bl) + al * bh) + al * bl;
  return p;
}

/* log x = *lh + *ll for x = (bits of a positive normal double) * 2^offset */
static void log_dd(unsigned long long bits, long long offset, double *lh, double *ll) {
  long long ex = (long long)(bits >> 52) - 1023 + offset;
  double m = from_bits((bits & 0x000fffffffffffffULL) | 0x3ff0000000000000ULL); /* [1, 2) */
  if (m > 0x1.6a09e667f3bcdp+0) {                                             /* m > sqrt(2) */
    m = m * 0.5;
    ex = ex + 1;
  }
  {
    const double e = (double)ex;
    const double f = m - 1.0;                          /* exact */
    const double d = 2.0 + f, dl = f - (d - 2.0);      /* 2 + f = d + dl exactly */
    const double inv = 1.0 / d, f2 = 2.0 * f;
    const double uh = f2 * inv;
    double pe;
    const double p = two_prod(uh, d, &pe);
    const double ul = (((f2 - p) - pe) - uh * dl) * inv; /* uh + ul = 2 f / (2 + f) */
    const double t = uh * uh;
    const double t2 = t * t, t4 = t2 * t2, t8 = t4 * t4;
    const double c01 = 0x1.5555555555555p-4 + 0x1.999999999999ap-7 * t;
    const double c23 = 0x1.2492492492492p-9 + 0x1.c71c71c71c71cp-12 * t;
    const double c45 = 0x1.745d1745d1746p-14 + 0x1.3b13b13b13b14p-16 * t;
    const double c67 = 0x1.1111111111111p-18 + 0x1.e1e1e1e1e1e1ep-21 * t;
    const double c89 = 0x1.af286bca1af28p-23 + 0x1.8618618618618p-25 * t;
    const double c03 = c01 + c23 * t2, c47 = c45 + c67 * t2, c8a = c89 + 0x1.642c8590b2164p-27 * t2;
    double c = (c03 + c47 * t4) + c8a * t8;
    double a, s0, bb, s0e;
    c = (uh * t) * c; /* u^3/12 + u^5/80 + ... */
    a = e * LN2_HI;
    s0 = a + uh;
    bb = s0 - a;
    s0e = ((a - (s0 - bb)) + (uh - bb)) + ((ul + c) + e * LN2_LO);
    *lh = s0 + s0e;
    *ll = s0e - (*lh - s0); /* |ll| <= ulp(lh) */
  }
}

/* exp(zh + zl) = m 2^n with m near 1 (|zh| < 746): returns m, sets *n */
static double exp_dd(double zh, double zl, long long *n_out) {
  const double shift = 0x1.8p52;
  const double n = (zh * 0x1.71547652b82fep+0 + shift) - shift;
  const double r0 = zh - n * LN2_HI, r0l = zl - n * LN2_LO; /* r0 exact; |r0l| < 2^-33 */
  const double rh = r0 + r0l, rb = rh - r0;
  const double rl = (r0 - (rh - rb)) + (r0l - rb); /* r = rh + rl, |rl| <= ulp(rh) */
  double r2e;
  const double r2 = two_prod(rh, rh, &r2e);
  const double r4 = r2 * r2, r8 = r4 * r4;
  const double q01 = 0x1.5555555555555p-3 + 0x1.5555555555555p-5 * rh;
  const double q23 = 0x1.1111111111111p-7 + 0x1.6c16c16c16c17p-10 * rh;
  const double q45 = 0x1.a01a01a01a01ap-13 + 0x1.a01a01a01a01ap-16 * rh;
  const double q67 = 0x1.71de3a556c734p-19 + 0x1.27e4fb7789f5cp-22 * rh;
  const double q89 = 0x1.ae64567f544e4p-26 + 0x1.1eed8eff8d898p-29 * rh;
  const double qab = 0x1.6124613a86d09p-33 + 0x1.93974a8c07c9dp-37 * rh;
  const double q03 = q01 + q23 * r2, q47 = q45 + q67 * r2, q8b = q89 + qab * r2;
  double q = (q03 + q47 * r4) + q8b * r8;
  q = (rh * r2) * q; /* r^3/6 + r^4/24 + ... */
  {
    const double s1 = 1.0 + rh, s1e = rh - (s1 - 1.0);          /* |rh| < 1: exact */
    const double h = 0.5 * r2, s2 = s1 + h, s2e = h - (s2 - s1); /* |h| < s1: exact */
    const double tail = ((((s1e + s2e) + 0.5 * r2e) + q) + rl) + rl * rh;
    *n_out = (long long)n;
    return s2 + tail;
  }
}

/* 2^k for -1022 <= k <= 1023 */
static double pow2(long long k) { return from_bits((unsigned long long)(k + 1023) << 52); }

/* m 2^n for -1100 < n < 1100: two exact scalings where one would leave the normal range (a subnormal result is
 * rounded twice) */
static double scaled(double m, long long n) {
  if (n > 1000) return (m * pow2(n - 1000)) * 0x1p1000;
  if (n < -1000) return (m * pow2(n + 1000)) * 0x1p-1000;
  return m * pow2(n);
}

static double infinity(void) { return from_bits(0x7ff0000000000000ULL); }
static double not_a_number(void) { return from_bits(0x7ff8000000000000ULL); }

/* x^y for x > 0 finite (normal or subnormal), y finite and nonzero, not on the fast path */
static double positive_pow(double x, double y) {
  unsigned long long bits = to_bits(x);
  long long offset = 0, n;
  double lh, ll, ze, zh, zl, m;
  const double ay = y < 0.0 ? -y : y;
  if (ay > 0x1p64) return (x > 1.0) == (y > 0.0) ? infinity() : 0.0; /* |y log x| > 2^11 for x != 1 */
  if (bits < 0x0010000000000000ULL) {                                   /* subnormal: x 2^54 is exact */
    bits = to_bits(x * 0x1p54);
    offset = -54;
  }
  log_dd(bits, offset, &lh, &ll);
  zh = two_prod(y, lh, &ze);
  zl = ze + y * ll;
  if (zh > 710.0) return infinity();
  if (zh < -746.0) return 0.0;
  m = exp_dd(zh, zl, &n);
  return scaled(m, n);
}

/* whether y (finite) is an integer, and whether it is an odd one */
static int is_integer(double y, int *odd) {
  const double ay = y < 0.0 ? -y : y;
  long long k;
  *odd = 0;
  if (ay >= 0x1p53) return 1; /* even */
  k = (long long)y;
  if ((double)k != y) return 0;
  *odd = (int)(k & 1);
  return 1;
}

/* C99 Annex F's special cases, then positive_pow */
static double special_pow(double x, double y) {
  int odd = 0, integer;
  double ax, r;
  if (y == 0.0 || x == 1.0) return 1.0;
  if (x != x || y != y) return x + y;
  ax = x < 0.0 ? -x : x;
  if (y - y != 0.0) { /* y infinite */
    if (ax == 1.0) return 1.0;
    return (ax < 1.0) == (y > 0.0) ? 0.0 : infinity();
  }
  integer = is_integer(y, &odd);
  if (x == 0.0) {
    if (y > 0.0) return odd ? x : 0.0;
    return odd ? 1.0 / x : infinity();
  }
  if (x - x != 0.0) { /* x infinite */
    if (x > 0.0) return y > 0.0 ? x : 0.0;
    if (y > 0.0) return odd ? x : infinity();
    return odd ? -0.0 : 0.0;
  }
  if (x < 0.0) {
    if (!integer) return not_a_number();
    r = positive_pow(-x, y);
    return odd ? -r : r;
  }
  return positive_pow(x, y);
}

double @P@_math_pow(double x, double y) {
  const unsigned long long bits = to_bits(x);
  const double ay = y < 0.0 ? -y : y;
  double lh, ll, ze, zh, zl, m;
  long long n;
  if (!(bits >= 0x0010000000000000ULL && bits < 0x7ff0000000000000ULL && ay < 16.0)) return special_pow(x, y);
  log_dd(bits, 0, &lh, &ll);
  zh = two_prod(y, lh, &ze);
  zl = ze + y * ll;
  if (!((zh < 0.0 ? -zh : zh) < 708.0)) return special_pow(x, y);
  if (y == 1.0) return x;     /* exact, as the C library's: x^1 = x */
  if (y == 2.0) return x * x; /* x^2 = x x */
  m = exp_dd(zh, zl, &n);
  return m * pow2(n);
}

double @P@_math_exp(double x) {
  double m;
  long long n;
  if (x != x) return x;
  if (x > 710.0) return infinity();
  if (x < -746.0) return 0.0;
  m = exp_dd(x, 0.0, &n);
  return scaled(m, n);
}

/* sign of m - a b, exactly (a b within a factor 2 of m: m - p is exact by Sterbenz's lemma) */
static double residual(double m, double a, double b) {
  double e;
  const double p = two_prod(a, b, &e);
  return (m - p) - e;
}

double @P@_math_sqrt(double x) {
  unsigned long long bits = to_bits(x);
  long long e, odd, half, scale = 0;
  double m, y;
  int i;
  if (!(x > 0.0)) return x == 0.0 ? x : not_a_number(); /* +-0, negative, NaN */
  if (bits >= 0x7ff0000000000000ULL) return x;         /* +inf */
  if (bits < 0x0010000000000000ULL) {                   /* subnormal: x 2^54 is exact, its root 2^27 too */
    bits = to_bits(x * 0x1p54);
    scale = -27;
  }
  e = (long long)(bits >> 52) - 1023;
  odd = e & 1;
  half = (e - odd) / 2;
  m = from_bits((bits & 0x000fffffffffffffULL) | 0x3ff0000000000000ULL); /* [1, 2) */
  if (odd) m = 2.0 * m;                                                 /* x = m 4^half, m in [1, 4) */
  y = (m + 2.0) / 3.0;                                                  /* within 6 % of sqrt(m) */
  for (i = 0; i < 5; ++i) y = 0.5 * (y + m / y);                       /* Newton: within an ulp */
  /* Tuckerman's test (y, its neighbours and m share the grid of ulp(y)^2): y is sqrt(m) rounded to nearest iff
   * y- y < m <= y y+ */
  for (i = 0; i < 4; ++i) {
    const double below = from_bits(to_bits(y) - 1), above = from_bits(to_bits(y) + 1);
    if (!(residual(m, below, y) > 0.0))
      y = below;
    else if (residual(m, y, above) > 0.0)
      y = above;
    else
      break;
  }
  return y * pow2(half + scale);
}
