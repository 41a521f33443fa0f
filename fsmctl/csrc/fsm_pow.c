/* fsmctl's pow (fsm_pow.h): the scalar entry point, one lane of the batched computation, and batched loops (for
 * the tests: fsm_pow_lanes(x, y, out, n) = fsm_pow_vec on blocks of FSM_LANES, the last block partial;
 * fsm_pow_lanes2(x, y, out, n) = fsm_pow_vec2 on blocks of 2 FSM_LANES). */
#include <string.h>

#include "fsm_pow.h"

#undef pow

double fsmctl_pow(double x, double y) {
#ifdef __GNUC__
  return fsm_pow_vec(fsm_pow_splat(x), fsm_pow_splat(y), 1)[0];
#else
  return pow(x, y);
#endif
}

void fsm_pow_lanes(const double *x, const double *y, double *out, long long n) {
  for (long long i = 0; i < n; i += FSM_LANES) {
    const int lanes = n - i < FSM_LANES ? (int)(n - i) : FSM_LANES;
#ifdef __GNUC__
    fsm_pow_v vx = fsm_pow_splat(0.0), vy = fsm_pow_splat(0.0);
    memcpy(&vx, x + i, sizeof(double) * lanes);
    memcpy(&vy, y + i, sizeof(double) * lanes);
    const fsm_pow_v r = fsm_pow_vec(vx, vy, lanes);
    memcpy(out + i, &r, sizeof(double) * lanes);
#else
    for (int l = 0; l < lanes; ++l) out[i + l] = pow(x[i + l], y[i + l]);
#endif
  }
}

void fsm_pow_lanes2(const double *x, const double *y, double *out, long long n) {
  for (long long i = 0; i < n; i += 2LL * FSM_LANES) {
#ifdef __GNUC__
    fsm_pow_v vx[2], vy[2], r[2];
    for (int j = 0; j < 2; ++j) vx[j] = vy[j] = fsm_pow_splat(1.0); /* padding: on the fast path */
    const long long count = n - i < 2LL * FSM_LANES ? n - i : 2LL * FSM_LANES;
    memcpy(vx, x + i, sizeof(double) * (size_t)count);
    memcpy(vy, y + i, sizeof(double) * (size_t)count);
    fsm_pow_vec2(vx[0], vy[0], vx[1], vy[1], &r[0], &r[1], FSM_LANES);
    memcpy(out + i, r, sizeof(double) * (size_t)count);
#else
    for (long long l = i; l < n && l < i + 2LL * FSM_LANES; ++l) out[l] = pow(x[l], y[l]);
#endif
  }
}
