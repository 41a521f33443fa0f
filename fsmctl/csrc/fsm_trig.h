/*
 * fsmctl's sin and cos: the one implementation that every compiled path of fsmctl uses.
 *
 * fsmctl.model.generated_code compiles every source of the library with `-include fsm_trig.h` (next to fsm_pow.h),
 * so `sin` and `cos` in the CasADi-generated scalar C (the disturbance d_i(t) and the reference omega_d(t)) mean
 * fsm_sin1 and fsm_cos1 (one lane of fsm_sincos_vec, inlined; fsmctl_sin and fsmctl_cos are the same as exported
 * functions), and the lane-batched kernels evaluate FSM_LANES lanes at once with it: a scalar call and a lane of a
 * batched call give the same bits.  Each run's own disturbance (a Monte Carlo campaign draws one per run) costs
 * three cosines per agent and time; with the C library's cos called lane by lane they were a sixth of a campaign's
 * compiled loop.  Only the CasADi virtual machine (the fallback without a C compiler) uses its own sin and cos; they
 * agree to about 1 ulp.
 *
 * Method (no tables; plain IEEE + - * /, so the result does not depend on the CPU's instruction set):
 * x = n pi/2 + r with n = nearest integer to x 2/pi and r = rh + rl in double-double, by Cody and Waite's reduction
 * with pi/2 in three parts (the first two of 33 bits: n P1 and n P2 are exact for |n| < 2^20, x - n P1 is exact
 * by Sterbenz's lemma, x - n P1 - n P2 is summed exactly by TwoSum); then sin r and cos r by the kernels of
 * fdlibm (__kernel_sin, __kernel_cos: the rl correction included), and the quadrant n mod 4 picks and signs one.
 * Measured error (2^19 samples per range against long double sinl/cosl, |x| <= 2 pi, <= 100 and < 2^20): at most
 * 0.76 ulp, the fdlibm kernels' uncompensated final rounding (glibc's sin and cos: 0.51 on the same samples);
 * tests/test_fsm_trig.py checks 0.8 ulp against sinl/cosl and against mpmath.
 * Lanes outside the fast path call the C library's sin or cos, whose special cases (C99 Annex F) they keep: zeros,
 * |x| >= 2^20, infinities and NaN, and the rare arguments within 2^-10 of a nonzero multiple of pi/2, where the
 * reduction's absolute error (< 2^-100) would no longer be negligible against |r|.
 *
 * The polynomial coefficients and the kernels' evaluation order are fdlibm's (as in musl's __sin.c and __cos.c):
 * Copyright (C) 1993 by Sun Microsystems, Inc. All rights reserved.
 * Developed at SunSoft, a Sun Microsystems, Inc. business.
 * Permission to use, copy, modify, and distribute this software is freely granted, provided that this notice
 * is preserved.
 */
#ifndef FSMCTL_FSM_TRIG_H
#define FSMCTL_FSM_TRIG_H

#include <math.h>

#include "fsm_pow.h" /* FSM_LANES and its vector types */

double fsmctl_sin(double x);
double fsmctl_cos(double x);

#ifdef __GNUC__
#pragma GCC diagnostic ignored "-Wpsabi" /* static helpers: the vector-ABI note does not apply */
typedef fsm_pow_v fsm_trig_v; /* FSM_LANES doubles (fsm_pow.h) */
typedef fsm_pow_m fsm_trig_m;

/* the lanes l < lanes off the fast path (mask fast clear) get the C library's sin or cos: out of line, so that the
 * fast path stays one straight run of vector code */
static fsm_trig_v __attribute__((noinline, cold)) fsm_trig_off_path(fsm_trig_v x, int want_sin, fsm_trig_v res,
                                                                    fsm_trig_m fast, int lanes) {
  for (int l = 0; l < lanes; ++l)
    if (!fast[l]) res[l] = want_sin ? sin(x[l]) : cos(x[l]);
  return res;
}

/* sin x (want_sin != 0) or cos x in the lanes l < lanes (the others are unspecified) */
static inline fsm_trig_v fsm_sincos_vec(fsm_trig_v x, int want_sin, int lanes) {
  const double INVPIO2 = 0x1.45f306dc9c883p-1; /* 2/pi */
  const double PIO2_1 = 0x1.921fb544p+0;       /* the first 33 bits of pi/2 */
  const double PIO2_2 = 0x1.0b4611a6p-34;      /* the next 33 bits */
  const double PIO2_2T = 0x1.3198a2e037073p-69; /* pi/2 - PIO2_1 - PIO2_2 */
  /* n = x 2/pi rounded to the nearest integer (|x| < 2^20 on the fast path) */
  const fsm_trig_v shift = fsm_pow_splat(0x1.8p52);
  const fsm_trig_v n = (x * INVPIO2 + shift) - shift;
  /* r = x - n pi/2 = rh + rl */
  const fsm_trig_v r1 = x - n * PIO2_1; /* exact: n P1 has <= 53 bits, and n P1 / 2 <= x <= 2 n P1 for n >= 1 */
  const fsm_trig_v w = n * PIO2_2;       /* exact */
  const fsm_trig_v s = r1 - w, sb = s - r1;
  const fsm_trig_v e = (r1 - (s - sb)) + (-w - sb); /* TwoSum: r1 - w = s + e exactly */
  const fsm_trig_v rest = e - n * PIO2_2T;
  const fsm_trig_v rh = s + rest, rl = rest - (rh - s); /* Fast2Sum: |s| >= |rest| on the fast path */
  /* the kernels on |r| <= pi/4 (fdlibm) */
  const fsm_trig_v z = rh * rh, zz = z * z;
  const fsm_trig_v cr = z * (0x1.555555555554cp-5 + z * (-0x1.6c16c16c15177p-10 + z * 0x1.a01a019cb159p-16)) +
                        zz * zz * (-0x1.27e4f809c52adp-22 + z * (0x1.1ee9ebdb4b1c4p-29 - z * 0x1.8fae9be8838d4p-37));
  const fsm_trig_v hz = 0.5 * z, cw = 1.0 - hz;
  const fsm_trig_v kc = cw + (((1.0 - cw) - hz) + (z * cr - rh * rl));
  const fsm_trig_v sr = 0x1.111111110f8a6p-7 + z * (-0x1.a01a019c161d5p-13 + z * 0x1.71de357b1fe7dp-19) +
                        z * zz * (-0x1.ae5e68a2b9cebp-26 + z * 0x1.5d93a5acfd57cp-33);
  const fsm_trig_v v = z * rh;
  const fsm_trig_v ks = rh - ((z * (0.5 * rl - v * sr) - rl) - v * -0x1.5555555555549p-3);
  /* the quadrant: sin x = cos(x - pi/2), so sin takes quadrant n + 3 */
  const fsm_trig_m q = __builtin_convertvector(n, fsm_trig_m) + (want_sin ? 3 : 0);
  const fsm_trig_m odd = (q & 1) != 0, negative = ((q + 1) & 2) != 0;
  const fsm_trig_m sign = (fsm_trig_m)fsm_pow_splat(-0.0) & negative;
  fsm_trig_v res = (fsm_trig_v)((((fsm_trig_m)ks & odd) | ((fsm_trig_m)kc & ~odd)) ^ sign);
  /* the fast path: 0 < |x| < 2^20, and |r| >= 2^-10 unless n = 0 (then r = x exactly) */
  const fsm_trig_v ax = (fsm_trig_v)((fsm_trig_m)x & 0x7fffffffffffffffLL);
  const fsm_trig_v arh = (fsm_trig_v)((fsm_trig_m)rh & 0x7fffffffffffffffLL);
  const fsm_trig_m fast = (ax < 0x1p20) & (x != 0.0) & ((n == 0.0) | (arh >= 0x1p-10));
  if (__builtin_expect(fsm_pow_any_off(fast, lanes), 0)) res = fsm_trig_off_path(x, want_sin, res, fast, lanes);
  return res;
}

/* one lane, inlined where the generated scalar C calls sin or cos: a sin and a cos of the same argument (the
 * reference's omega_d and omega_d_dot) share the reduction and the kernels after inlining */
static inline double fsm_sin1(double x) { return fsm_sincos_vec(fsm_pow_splat(x), 1, 1)[0]; }
static inline double fsm_cos1(double x) { return fsm_sincos_vec(fsm_pow_splat(x), 0, 1)[0]; }
#else
static inline double fsm_sin1(double x) { return sin(x); }
static inline double fsm_cos1(double x) { return cos(x); }
#endif /* __GNUC__ */

/* from here on, sin and cos are fsmctl's */
#define sin fsm_sin1
#define cos fsm_cos1

#endif /* FSMCTL_FSM_TRIG_H */
