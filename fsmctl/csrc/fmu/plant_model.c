/*
 * fsmctl plant FMU: one rigid spacecraft (the engine's plant), for the common FMI 2.0 layer (fmu_common.c).
 * Copied into the FMU by fsmctl.export.fmu.write_plant_fmu (do not edit the copy).
 *
 * No equation is written here: the rigid-body dynamics (plant_rhs), the disturbance torque (disturbance_torque) and
 * the MRP shadow map (mrp_shadow) are the engine's CasADi-generated C (generated/c/, from derive/), compiled with
 * fsmctl's pow, sin and cos (fsm_pow.h, fsm_trig.h), called exactly as fsmctl/csrc/formation.c calls them:
 *   - the state x = (sigma, omega); the torque u is held over each doStep (an input);
 *   - classical Runge-Kutta steps of the fixed internal step dt on the grid t_k = t0 + k dt (the stages at t_k,
 *     t0 + (k + 1/2) dt, t0 + (k + 1) dt, the disturbance evaluated at each stage's time, tau = u + d), the update
 *     x += dt/6 (k1 + 2 (k2 + k3) + k4), then the shadow switch where |sigma|^2 > 1;
 *   - doStep(t, h) takes round(h / dt) internal steps; t must be on the grid and h a multiple of dt.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "disturbance_torque.h"
#include "fmu_model.h"
#include "fmu_variables.h"
#include "mrp_shadow.h"
#include "plant_rhs.h"

#define WORK 64 /* CasADi work arrays: more than any of the three functions asks (checked at initialization) */

typedef struct {
  double x[6];
  double J[9];
  double dist[12];
  double dt, t0;
  long long k; /* internal steps taken: the state is at t0 + k dt */
  casadi_int iw[WORK];
  double w[WORK];
  char message[200]; /* the last refusal, with its numbers */
} plant;

size_t fsmfmu_model_bytes(void) { return sizeof(plant); }

static int finite(const double *x, int n) {
  int k;
  for (k = 0; k < n; ++k)
    if (!(x[k] - x[k] == 0)) return 0;
  return 1;
}

static int work_fits(int (*work)(casadi_int *, casadi_int *, casadi_int *, casadi_int *)) {
  casadi_int n_arg, n_res, n_iw, n_w;
  if (work(&n_arg, &n_res, &n_iw, &n_w)) return 0;
  return n_arg <= 4 && n_res <= 2 && n_iw <= WORK && n_w <= WORK;
}

/* J symmetric positive definite (Sylvester's criterion) */
static int inertia_ok(const double *J) {
  double m2, m3;
  if (!finite(J, 9) || J[1] != J[3] || J[2] != J[6] || J[5] != J[7]) return 0;
  m2 = J[0] * J[4] - J[1] * J[3];
  m3 = J[0] * (J[4] * J[8] - J[5] * J[7]) - J[1] * (J[3] * J[8] - J[5] * J[6]) + J[2] * (J[3] * J[7] - J[4] * J[6]);
  return J[0] > 0 && m2 > 0 && m3 > 0;
}

static void outputs(const plant *p, double *r) {
  memcpy(r + FSMFMU_VR_SIGMA, p->x, 3 * sizeof(double));
  memcpy(r + FSMFMU_VR_OMEGA, p->x + 3, 3 * sizeof(double));
}

int fsmfmu_model_init(void *model, double *r, const int *integers, double t0, const char **why) {
  plant *p = (plant *)model;
  (void)integers;
  if (!work_fits(plant_rhs_work) || !work_fits(disturbance_torque_work) || !work_fits(mrp_shadow_work)) {
    *why = "the generated functions need more work memory than the FMU has";
    return 1;
  }
  memcpy(p->J, r + FSMFMU_VR_J, sizeof p->J);
  memcpy(p->dist, r + FSMFMU_VR_DISTURBANCE, sizeof p->dist);
  memcpy(p->x, r + FSMFMU_VR_SIGMA0, 3 * sizeof(double));
  memcpy(p->x + 3, r + FSMFMU_VR_OMEGA0, 3 * sizeof(double));
  p->dt = r[FSMFMU_VR_DT];
  p->t0 = t0;
  p->k = 0;
  if (!inertia_ok(p->J)) {
    *why = "J: must be finite, symmetric and positive definite";
    return 1;
  }
  if (!(p->dt > 0) || !finite(&p->dt, 1)) {
    *why = "dt: must be finite and > 0";
    return 1;
  }
  if (!finite(p->dist, 12) || !finite(p->x, 6)) {
    *why = "the disturbance parameters and the initial state must be finite";
    return 1;
  }
  outputs(p, r);
  return 0;
}

/* dx = f(t, x) with the torque u + d(t) (the engine's eval_rhs for one agent without wheels) */
static void rhs(plant *p, double t, const double *x, const double *u, double *dx) {
  double d[3], tau[3];
  int k;
  {
    const double *arg[2];
    double *res[1];
    arg[0] = &t;
    arg[1] = p->dist;
    res[0] = d;
    disturbance_torque(arg, res, p->iw, p->w, 0);
  }
  for (k = 0; k < 3; ++k) tau[k] = u[k] + d[k];
  {
    const double *arg[4];
    double *res[2];
    arg[0] = x;
    arg[1] = x + 3;
    arg[2] = tau;
    arg[3] = p->J;
    res[0] = dx;
    res[1] = dx + 3;
    plant_rhs(arg, res, p->iw, p->w, 0);
  }
}

static void shadow(plant *p) {
  double *sig = p->x, tmp[3];
  if (sig[0] * sig[0] + sig[1] * sig[1] + sig[2] * sig[2] > 1.0) {
    const double *arg[1];
    double *res[1];
    arg[0] = sig;
    res[0] = tmp;
    mrp_shadow(arg, res, p->iw, p->w, 0);
    memcpy(sig, tmp, sizeof tmp);
  }
}

/* one classical Runge-Kutta step from t0 + k dt (the engine's simulate_rk4) */
static void rk4_step(plant *p, const double *u) {
  double k1[6], k2[6], k3[6], k4[6], xt[6];
  const double dt = p->dt, t0 = p->t0;
  const double t = t0 + (double)p->k * dt, th = t0 + ((double)p->k + 0.5) * dt, t1 = t0 + (double)(p->k + 1) * dt;
  int m;
  rhs(p, t, p->x, u, k1);
  for (m = 0; m < 6; ++m) xt[m] = p->x[m] + 0.5 * dt * k1[m];
  rhs(p, th, xt, u, k2);
  for (m = 0; m < 6; ++m) xt[m] = p->x[m] + 0.5 * dt * k2[m];
  rhs(p, th, xt, u, k3);
  for (m = 0; m < 6; ++m) xt[m] = p->x[m] + dt * k3[m];
  rhs(p, t1, xt, u, k4);
  for (m = 0; m < 6; ++m) p->x[m] += dt / 6.0 * (k1[m] + 2.0 * (k2[m] + k3[m]) + k4[m]);
  shadow(p);
  p->k++;
}

int fsmfmu_model_step(void *model, double *r, const int *integers, double t, double h, const char **why) {
  plant *p = (plant *)model;
  const double *u = r + FSMFMU_VR_U;
  const double steps = floor(h / p->dt + 0.5), slack = FSMFMU_GRID_TOLERANCE * p->dt;
  long long n, s;
  (void)integers;
  if (!finite(u, 3)) {
    *why = "u: the torque input must be finite";
    return 1;
  }
  if (!(fabs(t - (p->t0 + (double)p->k * p->dt)) <= slack)) {
    *why = "doStep: the communication point is not where the previous step ended (no rollback)";
    return 1;
  }
  if (!(steps >= 1) || !(fabs(steps * p->dt - h) <= slack) || steps > 1e12) {
    snprintf(p->message, sizeof p->message,
             "doStep: the step size must be a positive multiple of the internal step dt = %.15g s, got %.15g s", p->dt, h);
    *why = p->message;
    return 1;
  }
  n = (long long)steps;
  for (s = 0; s < n; ++s) rk4_step(p, u);
  outputs(p, r);
  if (!finite(p->x, 6)) {
    *why = "the plant's state became non-finite";
    return 1;
  }
  return 0;
}
