/* fsmctl's pow (fsm_pow.h): the scalar entry point, one lane of the batched computation, and a batched loop (for
 * the tests: fsm_pow_lanes(x, y, out, n) = fsm_pow_vec on blocks of FSM_LANES, the last block partial). */
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
