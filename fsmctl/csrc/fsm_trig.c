/* fsmctl's sin and cos (fsm_trig.h): the exported scalar entry points (fsm_sin1 and fsm_cos1, one lane of the
 * batched computation) and a batched loop (for the tests: fsm_trig_lanes(x, out, n, want_sin) = fsm_sincos_vec on
 * blocks of FSM_LANES, the last block partial). */
#include <string.h>

#include "fsm_trig.h"

#undef sin
#undef cos

double fsmctl_sin(double x) { return fsm_sin1(x); }

double fsmctl_cos(double x) { return fsm_cos1(x); }

void fsm_trig_lanes(const double *x, double *out, long long n, int want_sin) {
  for (long long i = 0; i < n; i += FSM_LANES) {
    const int lanes = n - i < FSM_LANES ? (int)(n - i) : FSM_LANES;
#ifdef __GNUC__
    fsm_trig_v vx = fsm_pow_splat(0.0);
    memcpy(&vx, x + i, sizeof(double) * lanes);
    const fsm_trig_v r = fsm_sincos_vec(vx, want_sin, lanes);
    memcpy(out + i, &r, sizeof(double) * lanes);
#else
    for (int l = 0; l < lanes; ++l) out[i + l] = want_sin ? sin(x[i + l]) : cos(x[i + l]);
#endif
  }
}
