/*
 * The formation error metrics' sample loops (fsmctl.simulation.metrics): the generated mrp_principal_angle and
 * mrp_error called sample by sample, exactly as CasADi's serial map of the same compiled functions calls them
 * (same functions, same inputs: the same bits), without the per-call overhead of the map and its NumPy buffers.
 * No MRP formula is written here.  Each returns 0, or nonzero when a generated function does.
 */
#include <stddef.h>

#include "mrp_error.h"
#include "mrp_principal_angle.h"

/* theta[k] = mrp_principal_angle(sigma[3k..3k+2]) for k < m. */
int fsm_principal_angles(const double *sigma, long long m, double *theta) {
  casadi_int iw[mrp_principal_angle_SZ_IW + 1];
  double w[mrp_principal_angle_SZ_W + 1];
  for (long long k = 0; k < m; ++k) {
    const double *arg[mrp_principal_angle_SZ_ARG] = {sigma + 3 * k};
    double *res[mrp_principal_angle_SZ_RES] = {theta + k};
    if (mrp_principal_angle(arg, res, iw, w, 0)) return 1;
  }
  return 0;
}

/* The pairwise principal angles of a block of samples: sigma_e (T, n, 3) -> out (T, n, n), out[t][i][j] =
 * out[t][j][i] = mrp_principal_angle(mrp_error(sigma_e[t][i], sigma_e[t][j])) for i < j (the angle of the relative
 * attitude and of its inverse are equal: each unordered pair is evaluated once), out[t][i][i] untouched. */
int fsm_relative_angles(const double *sigma_e, long long T, int n, double *out) {
  casadi_int iw_e[mrp_error_SZ_IW + 1], iw_a[mrp_principal_angle_SZ_IW + 1];
  double w_e[mrp_error_SZ_W + 1], w_a[mrp_principal_angle_SZ_W + 1];
  for (long long t = 0; t < T; ++t) {
    const double *s = sigma_e + 3 * n * t;
    double *o = out + (long long)n * n * t;
    for (int i = 0; i < n; ++i) {
      for (int j = i + 1; j < n; ++j) {
        double rel[3], theta;
        const double *arg_e[mrp_error_SZ_ARG] = {s + 3 * i, s + 3 * j};
        double *res_e[mrp_error_SZ_RES] = {rel};
        const double *arg_a[mrp_principal_angle_SZ_ARG] = {rel};
        double *res_a[mrp_principal_angle_SZ_RES] = {&theta};
        if (mrp_error(arg_e, res_e, iw_e, w_e, 0) || mrp_principal_angle(arg_a, res_a, iw_a, w_a, 0)) return 1;
        o[i * n + j] = theta;
        o[j * n + i] = theta;
      }
    }
  }
  return 0;
}
