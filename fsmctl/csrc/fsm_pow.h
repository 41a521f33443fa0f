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

/* 8 lanes: functions of their own, called by the kernels (measured on an AVX-512 core: inlining three calls into
 * law_local made the loop ~2 % slower, register spills; at 4 lanes inlining is ~2 % faster).  The bits are the
 * same either way: no arithmetic moves across the call. */
#if FSM_LANES == 8
#define FSM_POW_INLINE __attribute__((noinline, unused)) /* unused: files that never call them */
#else
#define FSM_POW_INLINE inline
#endif

/* for (k < K) */
#define FSM_POW_K(stmt) for (int k = 0; k < K; ++k) stmt

/* x[k]^y[k] in the lanes l < lanes of r[k], k < K (the other lanes are unspecified): K independent powers, their
 * statements interleaved so that the CPU overlaps their long dependency chains (K = 1: fsm_pow_vec; K = 2:
 * fsm_pow_vec2, which the batched kernels call for two independent powers side by side).  Each value is computed by
 * the same operations from the same operands whatever K, so every lane has the same bits.  K stops at 2: three
 * chains at once ran slower than two and one on an AVX-512 core (Monte Carlo chunk, 3-5 % more CPU:
 * fsmctl/codegen/batched.py's _POW_GROUP). */
static inline __attribute__((always_inline)) void fsm_pow_k(const fsm_pow_v *x, const fsm_pow_v *y, fsm_pow_v *r,
                                                            const int K, int lanes) {
  const double LN2_HI = 0x1.62e42fefa3800p-1, LN2_LO = 0x1.ef35793c76730p-45; /* LN2_HI: 42 bits */
  fsm_pow_m bits[2], ex[2], big[2];
  fsm_pow_v m[2], e[2], f[2], d[2], dl[2], inv[2], f2[2], uh[2], pe[2], p[2], ul[2], t[2];
  /* log x = e log 2 + log m */
  FSM_POW_K(bits[k] = (fsm_pow_m)x[k]);
  FSM_POW_K(ex[k] = (bits[k] >> 52) - 1023);
  FSM_POW_K(m[k] = (fsm_pow_v)((bits[k] & 0x000fffffffffffffLL) | 0x3ff0000000000000LL)); /* [1, 2) */
  FSM_POW_K(big[k] = m[k] > 0x1.6a09e667f3bcdp+0);                                       /* m > sqrt(2) */
  FSM_POW_K(m[k] = (fsm_pow_v)(((fsm_pow_m)(m[k] * 0.5) & big[k]) | ((fsm_pow_m)m[k] & ~big[k])));
  FSM_POW_K(ex[k] = ex[k] - big[k]); /* big is -1 where m was halved */
  FSM_POW_K(e[k] = __builtin_convertvector(ex[k], fsm_pow_v));
  FSM_POW_K(f[k] = m[k] - 1.0); /* exact */
  FSM_POW_K(d[k] = 2.0 + f[k]);
  FSM_POW_K(dl[k] = f[k] - (d[k] - 2.0)); /* 2 + f = d + dl exactly */
  FSM_POW_K(inv[k] = 1.0 / d[k]);
  FSM_POW_K(f2[k] = 2.0 * f[k]);
  FSM_POW_K(uh[k] = f2[k] * inv[k]);
  FSM_POW_K(p[k] = fsm_pow_two_prod(uh[k], d[k], &pe[k]));
  FSM_POW_K(ul[k] = (((f2[k] - p[k]) - pe[k]) - uh[k] * dl[k]) * inv[k]); /* uh + ul = 2 f / (2 + f) */
  FSM_POW_K(t[k] = uh[k] * uh[k]);
  /* c1 + c2 t + ... + c11 t^10 (c_k = 1 / (4^k (2k+1))), Estrin's scheme (a short dependency chain) */
  fsm_pow_v t2[2], t4[2], t8[2], c01[2], c23[2], c45[2], c67[2], c89[2], c03[2], c47[2], c8a[2], c[2];
  FSM_POW_K(t2[k] = t[k] * t[k]);
  FSM_POW_K(t4[k] = t2[k] * t2[k]);
  FSM_POW_K(t8[k] = t4[k] * t4[k]);
  FSM_POW_K(c01[k] = 0x1.5555555555555p-4 + 0x1.999999999999ap-7 * t[k]);
  FSM_POW_K(c23[k] = 0x1.2492492492492p-9 + 0x1.c71c71c71c71cp-12 * t[k]);
  FSM_POW_K(c45[k] = 0x1.745d1745d1746p-14 + 0x1.3b13b13b13b14p-16 * t[k]);
  FSM_POW_K(c67[k] = 0x1.1111111111111p-18 + 0x1.e1e1e1e1e1e1ep-21 * t[k]);
  FSM_POW_K(c89[k] = 0x1.af286bca1af28p-23 + 0x1.8618618618618p-25 * t[k]);
  FSM_POW_K(c03[k] = c01[k] + c23[k] * t2[k]);
  FSM_POW_K(c47[k] = c45[k] + c67[k] * t2[k]);
  FSM_POW_K(c8a[k] = c89[k] + 0x1.642c8590b2164p-27 * t2[k]);
  FSM_POW_K(c[k] = (c03[k] + c47[k] * t4[k]) + c8a[k] * t8[k]);
  FSM_POW_K(c[k] = (uh[k] * t[k]) * c[k]); /* u^3/12 + u^5/80 + ... */
  fsm_pow_v a[2], s0[2], bb[2], s0e[2], lh[2], ll[2];
  FSM_POW_K(a[k] = e[k] * LN2_HI);
  FSM_POW_K(s0[k] = a[k] + uh[k]);
  FSM_POW_K(bb[k] = s0[k] - a[k]);
  FSM_POW_K(s0e[k] = ((a[k] - (s0[k] - bb[k])) + (uh[k] - bb[k])) + ((ul[k] + c[k]) + e[k] * LN2_LO));
  FSM_POW_K(lh[k] = s0[k] + s0e[k]);
  FSM_POW_K(ll[k] = s0e[k] - (lh[k] - s0[k])); /* log x = lh + ll, |ll| <= ulp(lh) */
  /* z = y log x */
  fsm_pow_v ze[2], zh[2], zl[2];
  FSM_POW_K(zh[k] = fsm_pow_two_prod(y[k], lh[k], &ze[k]));
  FSM_POW_K(zl[k] = ze[k] + y[k] * ll[k]);
  /* exp z = 2^n exp(rh + rl) */
  const fsm_pow_v shift = fsm_pow_splat(0x1.8p52);
  fsm_pow_v n[2], r0[2], r0l[2], rh[2], rb[2], rl[2], r2e[2], r2[2];
  FSM_POW_K(n[k] = (zh[k] * 0x1.71547652b82fep+0 + shift) - shift);
  FSM_POW_K(r0[k] = zh[k] - n[k] * LN2_HI);   /* exact */
  FSM_POW_K(r0l[k] = zl[k] - n[k] * LN2_LO); /* |r0l| < 2^-33 */
  FSM_POW_K(rh[k] = r0[k] + r0l[k]);
  FSM_POW_K(rb[k] = rh[k] - r0[k]);
  FSM_POW_K(rl[k] = (r0[k] - (rh[k] - rb[k])) + (r0l[k] - rb[k])); /* r = rh + rl, |rl| <= ulp(rh) */
  FSM_POW_K(r2[k] = fsm_pow_two_prod(rh[k], rh[k], &r2e[k]));
  /* 1/3! + r/4! + ... + r^11/14!, Estrin's scheme */
  fsm_pow_v r4[2], r8[2], q01[2], q23[2], q45[2], q67[2], q89[2], qab[2], q03[2], q47[2], q8b[2], q[2];
  FSM_POW_K(r4[k] = r2[k] * r2[k]);
  FSM_POW_K(r8[k] = r4[k] * r4[k]);
  FSM_POW_K(q01[k] = 0x1.5555555555555p-3 + 0x1.5555555555555p-5 * rh[k]);
  FSM_POW_K(q23[k] = 0x1.1111111111111p-7 + 0x1.6c16c16c16c17p-10 * rh[k]);
  FSM_POW_K(q45[k] = 0x1.a01a01a01a01ap-13 + 0x1.a01a01a01a01ap-16 * rh[k]);
  FSM_POW_K(q67[k] = 0x1.71de3a556c734p-19 + 0x1.27e4fb7789f5cp-22 * rh[k]);
  FSM_POW_K(q89[k] = 0x1.ae64567f544e4p-26 + 0x1.1eed8eff8d898p-29 * rh[k]);
  FSM_POW_K(qab[k] = 0x1.6124613a86d09p-33 + 0x1.93974a8c07c9dp-37 * rh[k]);
  FSM_POW_K(q03[k] = q01[k] + q23[k] * r2[k]);
  FSM_POW_K(q47[k] = q45[k] + q67[k] * r2[k]);
  FSM_POW_K(q8b[k] = q89[k] + qab[k] * r2[k]);
  FSM_POW_K(q[k] = (q03[k] + q47[k] * r4[k]) + q8b[k] * r8[k]);
  FSM_POW_K(q[k] = (rh[k] * r2[k]) * q[k]); /* r^3/6 + r^4/24 + ... */
  fsm_pow_v s1[2], s1e[2], h[2], s2[2], s2e[2], tail[2];
  FSM_POW_K(s1[k] = 1.0 + rh[k]);
  FSM_POW_K(s1e[k] = rh[k] - (s1[k] - 1.0)); /* |rh| < 1: exact */
  FSM_POW_K(h[k] = 0.5 * r2[k]);
  FSM_POW_K(s2[k] = s1[k] + h[k]);
  FSM_POW_K(s2e[k] = h[k] - (s2[k] - s1[k])); /* |h| < s1: exact */
  FSM_POW_K(tail[k] = ((((s1e[k] + s2e[k]) + 0.5 * r2e[k]) + q[k]) + rl[k]) + rl[k] * rh[k]);
  /* the fast path: x positive normal, |y| < 16, |zh| < 708 (the result is normal) */
  fsm_pow_m fast[2], scale[2], one[2], two[2];
  fsm_pow_v ay[2], az[2], nf[2], res[2];
  FSM_POW_K(ay[k] = (fsm_pow_v)((fsm_pow_m)y[k] & 0x7fffffffffffffffLL));
  FSM_POW_K(az[k] = (fsm_pow_v)((fsm_pow_m)zh[k] & 0x7fffffffffffffffLL));
  FSM_POW_K(fast[k] = (bits[k] >= 0x0010000000000000LL) & (bits[k] < 0x7ff0000000000000LL) & (ay[k] < 16.0) &
                      (az[k] < 708.0));
  FSM_POW_K(nf[k] = (fsm_pow_v)((fsm_pow_m)n[k] & fast[k])); /* n, or 0 off the fast path */
  FSM_POW_K(scale[k] = (__builtin_convertvector(nf[k], fsm_pow_m) + 1023) << 52);
  FSM_POW_K(res[k] = (s2[k] + tail[k]) * (fsm_pow_v)scale[k]);
  FSM_POW_K(one[k] = y[k] == 1.0); /* exact, as the C library's: x^1 = x, x^2 = x x */
  FSM_POW_K(two[k] = y[k] == 2.0);
  FSM_POW_K(res[k] = (fsm_pow_v)(((fsm_pow_m)x[k] & one[k]) | ((fsm_pow_m)(x[k] * x[k]) & two[k]) |
                                 ((fsm_pow_m)res[k] & ~(one[k] | two[k]))));
  FSM_POW_K(r[k] = __builtin_expect(fsm_pow_any_off(fast[k], lanes), 0)
                       ? fsm_pow_off_path(x[k], y[k], res[k], fast[k], lanes)
                       : res[k]);
}
#undef FSM_POW_K

/* x^y in the lanes l < lanes (the others are unspecified) */
static FSM_POW_INLINE fsm_pow_v fsm_pow_vec(fsm_pow_v x, fsm_pow_v y, int lanes) {
  fsm_pow_v r;
  fsm_pow_k(&x, &y, &r, 1, lanes);
  return r;
}

/* x0^y0 and x1^y1 at once, interleaved: the same bits as fsm_pow_vec of each */
static FSM_POW_INLINE void fsm_pow_vec2(fsm_pow_v x0, fsm_pow_v y0, fsm_pow_v x1, fsm_pow_v y1, fsm_pow_v *r0,
                                        fsm_pow_v *r1, int lanes) {
  const fsm_pow_v x[2] = {x0, x1}, y[2] = {y0, y1};
  fsm_pow_v r[2];
  fsm_pow_k(x, y, r, 2, lanes);
  *r0 = r[0], *r1 = r[1];
}
#endif /* __GNUC__ */

/* from here on, pow is fsmctl's */
#define pow fsmctl_pow

#endif /* FSMCTL_FSM_POW_H */
