/*
 * fsmctl's pow: the one implementation of x^y that every compiled path of fsmctl uses.
 *
 * fsmctl.model.generated_code compiles every source of the library with `-include fsm_pow.h`, so `pow` in the
 * CasADi-generated scalar C, the lane-batched kernels and the driver all mean fsmctl_pow, whose lanes are computed by
 * fsm_pow_vec: a scalar call and a lane of a batched call give the same bits (the library's pow used to be glibc's,
 * called lane by lane; this one evaluates FSM_LANES lanes at once with SIMD arithmetic).
 *
 * FSM_LANES, the width of fsmctl's vectors (this pow's and the batched kernels' of fsmctl/codegen/batched.py), is
 * defined here: 4 (one 256-bit register) unless the build sets it (-DFSM_LANES=8 on CPUs with AVX-512:
 * fsmctl.model.generated_code.compile_flags).  Each lane's operations are the same at every width, so the width
 * never changes a result.  Only the CasADi virtual machine
 * (the fallback without a C compiler) uses its own pow; it agrees to about 1 ulp.
 *
 * Method (no tables; plain IEEE + - * / and exact products, fma(a, b, -a b) where the CPU has FMA, else Dekker's
 * splitting: the same bits either way, so the result does not depend on the CPU's instruction set):
 * x = 2^e m with m in [sqrt(2)/2, sqrt(2)); log m = u + u^3/12 + u^5/80 + ... (u = 2 (m-1)/(m+1), the atanh series,
 * |u| < 0.35) with u in double-double; z = y log x in double-double (Dekker's exact product); exp z = 2^n exp(r),
 * r = z - n log 2 in [-0.35, 0.35], exp r = 1 + r + r^2/2 + r^3 Q(r) with the leading terms summed exactly; y = 1
 * and y = 2 exactly (x, x x).  Measured error (2^20 samples per range against long double powl and 3000 against
 * mpmath): at most 0.54 ulp for x in (0, 1], y in (0, 1) (the laws' |sigma_e|^alpha), at most 0.82 ulp for
 * |y| < 16 (tests/test_fsm_pow.py).
 * Lanes outside the fast path (x not positive normal, |y| >= 16, or x^y outside [2^-1021, 2^1021]: zeros,
 * subnormals, infinities, NaN, negative bases, overflow and underflow) call the C library's pow, whose special
 * cases (C99 Annex F) they keep.
 */
#ifndef FSMCTL_FSM_POW_H
#define FSMCTL_FSM_POW_H

#include <math.h>

#ifndef FSM_LANES
#define FSM_LANES 4
#endif
#if FSM_LANES != 4 && FSM_LANES != 8
#error "FSM_LANES must be 4 or 8 (fsmctl.codegen.batched.LANE_WIDTHS)"
#endif

double fsmctl_pow(double x, double y);

#ifdef __GNUC__
#pragma GCC diagnostic ignored "-Wpsabi" /* static helpers: the vector-ABI note does not apply */
#if defined(__AVX__)
#include <immintrin.h>
#endif
typedef double fsm_pow_v __attribute__((vector_size(8 * FSM_LANES)));
typedef long long fsm_pow_m __attribute__((vector_size(8 * FSM_LANES)));

static inline fsm_pow_v fsm_pow_splat(double c) {
#if FSM_LANES == 8
  fsm_pow_v v = {c, c, c, c, c, c, c, c};
#else
  fsm_pow_v v = {c, c, c, c};
#endif
  return v;
}

/* a b = p + *e exactly (|a|, |b| < 2^995, no underflow): with FMA e = fma(a, b, -p), else Dekker/Veltkamp's
 * splitting; both give the exact error, so the same bits */
static inline fsm_pow_v fsm_pow_two_prod(fsm_pow_v a, fsm_pow_v b, fsm_pow_v *e) {
#if defined(__FMA__) && defined(__AVX512F__) && FSM_LANES == 8
  fsm_pow_v p = a * b;
  *e = (fsm_pow_v)_mm512_fmsub_pd((__m512d)a, (__m512d)b, (__m512d)p);
  return p;
#elif defined(__FMA__) && defined(__AVX__) && FSM_LANES == 4
  fsm_pow_v p = a * b;
  *e = (fsm_pow_v)_mm256_fmsub_pd((__m256d)a, (__m256d)b, (__m256d)p);
  return p;
#elif defined(__FMA__) && defined(__AVX__) /* 8 lanes in two 256-bit halves */
  fsm_pow_v p = a * b;
  typedef double half __attribute__((vector_size(32)));
  half ah, bh, ph, r0, r1;
  __builtin_memcpy(&ah, &a, 32), __builtin_memcpy(&bh, &b, 32), __builtin_memcpy(&ph, &p, 32);
  r0 = (half)_mm256_fmsub_pd((__m256d)ah, (__m256d)bh, (__m256d)ph);
  __builtin_memcpy(&ah, (const double *)&a + 4, 32), __builtin_memcpy(&bh, (const double *)&b + 4, 32);
  __builtin_memcpy(&ph, (const double *)&p + 4, 32);
  r1 = (half)_mm256_fmsub_pd((__m256d)ah, (__m256d)bh, (__m256d)ph);
  __builtin_memcpy(e, &r0, 32), __builtin_memcpy((double *)e + 4, &r1, 32);
  return p;
#else
  const fsm_pow_v split = fsm_pow_splat(134217729.0); /* 2^27 + 1 */
  fsm_pow_v p = a * b;
  fsm_pow_v ca = split * a, cb = split * b;
  fsm_pow_v ah = ca - (ca - a), bh = cb - (cb - b);
  fsm_pow_v al = a - ah, bl = b - bh;
  *e = (((ah * bh - p) + ah * bl) + al * bh) + al * bl;
  return p;
#endif
}

/* whether a lane l < lanes is off the fast path (mask ok clear): one test of the whole vector where the CPU has one */
static inline int fsm_pow_any_off(fsm_pow_m ok, int lanes) {
#if FSM_LANES == 8
  const fsm_pow_m lane = {0, 1, 2, 3, 4, 5, 6, 7};
#else
  const fsm_pow_m lane = {0, 1, 2, 3};
#endif
  const fsm_pow_m off = ~ok & (lane < lanes);
#if defined(__AVX512F__) && FSM_LANES == 8
  return _mm512_test_epi64_mask((__m512i)off, (__m512i)off) != 0;
#elif defined(__AVX__) && FSM_LANES == 4
  return !_mm256_testz_si256((__m256i)off, (__m256i)off);
#else
  long long any = 0;
  for (int l = 0; l < FSM_LANES; ++l) any |= off[l];
  return any != 0;
#endif
}

/* the lanes l < lanes off the fast path (mask fast clear) get the C library's pow: out of line, so that the fast
 * path stays one straight run of vector code */
static fsm_pow_v __attribute__((noinline, cold)) fsm_pow_off_path(fsm_pow_v x, fsm_pow_v y, fsm_pow_v res,
                                                                   fsm_pow_m fast, int lanes) {
  for (int l = 0; l < lanes; ++l)
    if (!fast[l]) res[l] = pow(x[l], y[l]);
  return res;
}

/* 8 lanes: a function of its own, called by the kernels (measured on an AVX-512 core: inlining its three calls
 * into law_local made the loop ~2 % slower, register spills; at 4 lanes inlining is ~2 % faster).  The bits are the
 * same either way: no arithmetic moves across the call. */
#if FSM_LANES == 8
#define FSM_POW_INLINE __attribute__((noinline, unused)) /* unused: files that never call it */
#else
#define FSM_POW_INLINE inline
#endif

/* x^y in the lanes l < lanes (the others are unspecified) */
static FSM_POW_INLINE fsm_pow_v fsm_pow_vec(fsm_pow_v x, fsm_pow_v y, int lanes) {
  const double LN2_HI = 0x1.62e42fefa3800p-1, LN2_LO = 0x1.ef35793c76730p-45; /* LN2_HI: 42 bits */
  const fsm_pow_m bits = (fsm_pow_m)x;
  /* log x = e log 2 + log m */
  fsm_pow_m ex = (bits >> 52) - 1023;
  fsm_pow_v m = (fsm_pow_v)((bits & 0x000fffffffffffffLL) | 0x3ff0000000000000LL); /* [1, 2) */
  const fsm_pow_m big = m > 0x1.6a09e667f3bcdp+0;                                  /* m > sqrt(2) */
  m = (fsm_pow_v)(((fsm_pow_m)(m * 0.5) & big) | ((fsm_pow_m)m & ~big));
  ex = ex - big; /* big is -1 where m was halved */
  const fsm_pow_v e = __builtin_convertvector(ex, fsm_pow_v);
  const fsm_pow_v f = m - 1.0;                       /* exact */
  const fsm_pow_v d = 2.0 + f, dl = f - (d - 2.0); /* 2 + f = d + dl exactly */
  const fsm_pow_v inv = 1.0 / d, f2 = 2.0 * f;
  const fsm_pow_v uh = f2 * inv;
  fsm_pow_v pe;
  const fsm_pow_v p = fsm_pow_two_prod(uh, d, &pe);
  const fsm_pow_v ul = (((f2 - p) - pe) - uh * dl) * inv; /* uh + ul = 2 f / (2 + f) */
  const fsm_pow_v t = uh * uh;
  /* c1 + c2 t + ... + c11 t^10 (c_k = 1 / (4^k (2k+1))), Estrin's scheme (a short dependency chain) */
  const fsm_pow_v t2 = t * t, t4 = t2 * t2, t8 = t4 * t4;
  const fsm_pow_v c01 = 0x1.5555555555555p-4 + 0x1.999999999999ap-7 * t;
  const fsm_pow_v c23 = 0x1.2492492492492p-9 + 0x1.c71c71c71c71cp-12 * t;
  const fsm_pow_v c45 = 0x1.745d1745d1746p-14 + 0x1.3b13b13b13b14p-16 * t;
  const fsm_pow_v c67 = 0x1.1111111111111p-18 + 0x1.e1e1e1e1e1e1ep-21 * t;
  const fsm_pow_v c89 = 0x1.af286bca1af28p-23 + 0x1.8618618618618p-25 * t;
  const fsm_pow_v c03 = c01 + c23 * t2, c47 = c45 + c67 * t2, c8a = c89 + 0x1.642c8590b2164p-27 * t2;
  fsm_pow_v c = (c03 + c47 * t4) + c8a * t8;
  c = (uh * t) * c; /* u^3/12 + u^5/80 + ... */
  const fsm_pow_v a = e * LN2_HI;
  const fsm_pow_v s0 = a + uh, bb = s0 - a;
  const fsm_pow_v s0e = ((a - (s0 - bb)) + (uh - bb)) + ((ul + c) + e * LN2_LO);
  const fsm_pow_v lh = s0 + s0e, ll = s0e - (lh - s0); /* log x = lh + ll, |ll| <= ulp(lh) */
  /* z = y log x */
  fsm_pow_v ze;
  const fsm_pow_v zh = fsm_pow_two_prod(y, lh, &ze);
  const fsm_pow_v zl = ze + y * ll;
  /* exp z = 2^n exp(rh + rl) */
  const fsm_pow_v shift = fsm_pow_splat(0x1.8p52);
  const fsm_pow_v n = (zh * 0x1.71547652b82fep+0 + shift) - shift;
  const fsm_pow_v r0 = zh - n * LN2_HI, r0l = zl - n * LN2_LO; /* r0 exact; |r0l| < 2^-33 */
  const fsm_pow_v rh = r0 + r0l, rb = rh - r0;
  const fsm_pow_v rl = (r0 - (rh - rb)) + (r0l - rb); /* r = rh + rl, |rl| <= ulp(rh) */
  fsm_pow_v r2e;
  const fsm_pow_v r2 = fsm_pow_two_prod(rh, rh, &r2e);
  /* 1/3! + r/4! + ... + r^11/14!, Estrin's scheme */
  const fsm_pow_v r4 = r2 * r2, r8 = r4 * r4;
  const fsm_pow_v q01 = 0x1.5555555555555p-3 + 0x1.5555555555555p-5 * rh;
  const fsm_pow_v q23 = 0x1.1111111111111p-7 + 0x1.6c16c16c16c17p-10 * rh;
  const fsm_pow_v q45 = 0x1.a01a01a01a01ap-13 + 0x1.a01a01a01a01ap-16 * rh;
  const fsm_pow_v q67 = 0x1.71de3a556c734p-19 + 0x1.27e4fb7789f5cp-22 * rh;
  const fsm_pow_v q89 = 0x1.ae64567f544e4p-26 + 0x1.1eed8eff8d898p-29 * rh;
  const fsm_pow_v qab = 0x1.6124613a86d09p-33 + 0x1.93974a8c07c9dp-37 * rh;
  const fsm_pow_v q03 = q01 + q23 * r2, q47 = q45 + q67 * r2, q8b = q89 + qab * r2;
  fsm_pow_v q = (q03 + q47 * r4) + q8b * r8;
  q = (rh * r2) * q; /* r^3/6 + r^4/24 + ... */
  const fsm_pow_v s1 = 1.0 + rh, s1e = rh - (s1 - 1.0);      /* |rh| < 1: exact */
  const fsm_pow_v h = 0.5 * r2, s2 = s1 + h, s2e = h - (s2 - s1); /* |h| < s1: exact */
  const fsm_pow_v tail = ((((s1e + s2e) + 0.5 * r2e) + q) + rl) + rl * rh;
  /* the fast path: x positive normal, |y| < 16, |zh| < 708 (the result is normal) */
  const fsm_pow_v ay = (fsm_pow_v)((fsm_pow_m)y & 0x7fffffffffffffffLL);
  const fsm_pow_v az = (fsm_pow_v)((fsm_pow_m)zh & 0x7fffffffffffffffLL);
  const fsm_pow_m fast = (bits >= 0x0010000000000000LL) & (bits < 0x7ff0000000000000LL) & (ay < 16.0) & (az < 708.0);
  const fsm_pow_v nf = (fsm_pow_v)((fsm_pow_m)n & fast); /* n, or 0 off the fast path */
  const fsm_pow_m scale = (__builtin_convertvector(nf, fsm_pow_m) + 1023) << 52;
  fsm_pow_v res = (s2 + tail) * (fsm_pow_v)scale;
  const fsm_pow_m one = y == 1.0, two = y == 2.0; /* exact, as the C library's: x^1 = x, x^2 = x x */
  res = (fsm_pow_v)(((fsm_pow_m)x & one) | ((fsm_pow_m)(x * x) & two) | ((fsm_pow_m)res & ~(one | two)));
  if (__builtin_expect(fsm_pow_any_off(fast, lanes), 0)) res = fsm_pow_off_path(x, y, res, fast, lanes);
  return res;
}
#endif /* __GNUC__ */

/* from here on, pow is fsmctl's */
#define pow fsmctl_pow

#endif /* FSMCTL_FSM_POW_H */
