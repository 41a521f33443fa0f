/*
 * @P@_math: the elementary functions of an exported fsmctl law, in portable C99 without the C library's libm.
 *
 * Copied by `fsmctl export` from fsmctl/csrc/export/export_math.h (do not edit the copy).
 *   @P@_math_pow   x^y: fsmctl's pow (fsmctl/csrc/fsm_pow.h), the same operations in the same order on one lane,
 *                  so the fast path (x positive normal, |y| < 16, the result normal) gives the engine's bits; off
 *                  it, the C99 Annex F special cases exactly and the same algorithm otherwise (the engine calls
 *                  the C library there: equal to within an ulp, not always bit for bit).
 *   @P@_math_sqrt  the correctly rounded square root (IEEE 754), so the bits of every sqrt instruction and libm.
 *   @P@_math_exp   e^x: the exponential of @P@_math_pow's algorithm (within an ulp; the engine uses the C library).
 * All are functions of doubles; the float32 export evaluates them in double and rounds the result.
 */
#ifndef @PU@_MATH_H
#define @PU@_MATH_H

double @P@_math_pow(double x, double y);
double @P@_math_sqrt(double x);
double @P@_math_exp(double x);

#endif /* @PU@_MATH_H */
