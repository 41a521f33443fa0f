/*
 * fsmctl controller FMU: one spacecraft's controller, the exported C library @P@ (@P@.h: `fsmctl export --target c`),
 * for the common FMI 2.0 layer (fmu_common.c).  Copied by fsmctl.export.fmu.write_controller_fmu with the library's
 * prefix (do not edit the copy).
 *
 * fmi2ExitInitializationMode: @P@_init with the FMU's parameters (the law's, J0, torque_limit, control_period,
 * law_state_substeps).  fmi2DoStep(t, h), h = control_period * law_state_substeps: one control instant at t,
 *   1. @P@_broadcast from the inputs (sigma, omega, the reference) set before the step: output `broadcast`;
 *   2. @P@_step with the neighbour inputs set before the step (neighbour slot j: its broadcast, k_own, k_sender;
 *      a slot with k_own = k_sender = 0 is no link): outputs torque, torque_commanded, the law state z after the
 *      period (and the wheel commands, for a law that commands its wheels).
 * The outputs are the command held over [t, t + h] (zero-order hold): a master applies them to the plant's step
 * from t.  Neighbours' broadcasts are whatever was set before the step; in a formation of FMUs stepped together
 * they are the neighbours' broadcasts of the previous instant (one control period late).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "@P@.h"
#include "@P@_law.h"
#include "fmu_model.h"
#include "fmu_parameters.h"
#include "fmu_variables.h"

typedef struct {
  @P@_controller controller;
  @P@_real broadcast[FSMFMU_N_NEIGHBOURS_ALLOC * @PU@_N_BROADCAST];
  @P@_real k_own[FSMFMU_N_NEIGHBOURS_ALLOC], k_sender[FSMFMU_N_NEIGHBOURS_ALLOC];
  double period;
  char message[200]; /* the last refusal, with its numbers */
} model;

size_t fsmfmu_model_bytes(void) { return sizeof(model); }

static void to_real(@P@_real *dst, const double *src, int n) {
  int k;
  for (k = 0; k < n; ++k) dst[k] = (@P@_real)src[k];
}

static void to_double(double *dst, const @P@_real *src, int n) {
  int k;
  for (k = 0; k < n; ++k) dst[k] = (double)src[k];
}

int fsmfmu_model_init(void *memory, double *r, const int *integers, double t0, const char **why) {
  model *m = (model *)memory;
  @P@_config config;
  @P@_real packed[@PU@_N_PARAMETERS_ALLOC];
  int k, status;
  (void)t0;
  @P@_default_config(&config);
  for (k = 0; k < @PU@_N_PARAMETERS; ++k)
    packed[k] = fsmfmu_parameter_integer[k] ? (@P@_real)integers[fsmfmu_parameter_vr[k]]
                                            : (@P@_real)r[fsmfmu_parameter_vr[k]];
  @P@_unpack_parameters(packed, &config.parameters);
  to_real(config.J0, r + FSMFMU_VR_J0, 9);
  config.torque_limit = (@P@_real)r[FSMFMU_VR_TORQUE_LIMIT];
  config.control_period = (@P@_real)r[FSMFMU_VR_CONTROL_PERIOD];
  config.law_state_substeps = integers[FSMFMU_VR_LAW_STATE_SUBSTEPS];
  m->period = r[FSMFMU_VR_CONTROL_PERIOD] * (double)config.law_state_substeps;
  status = @P@_init(&m->controller, &config);
  if (status != @PU@_STATUS_OK) {
    *why = @P@_error_text(&m->controller);
    return 1;
  }
  for (k = 0; k < 3; ++k) r[FSMFMU_VR_TORQUE + k] = r[FSMFMU_VR_TORQUE_COMMANDED + k] = 0;
  for (k = 0; k < @PU@_N_BROADCAST; ++k) r[FSMFMU_VR_BROADCAST + k] = 0;
  to_double(r + FSMFMU_VR_Z, m->controller.z, @PU@_N_STATES);
  return 0;
}

static void read_input(const double *r, double t, @P@_input *in) {
  in->t = (@P@_real)t;
  to_real(in->sigma, r + FSMFMU_VR_SIGMA, 3);
  to_real(in->omega, r + FSMFMU_VR_OMEGA, 3);
  to_real(in->sigma_d, r + FSMFMU_VR_SIGMA_D, 3);
  to_real(in->omega_d, r + FSMFMU_VR_OMEGA_D, 3);
  to_real(in->omega_d_dot, r + FSMFMU_VR_OMEGA_D_DOT, 3);
}

static void read_neighbours(model *m, const double *r, @P@_neighbours *nb) {
  to_real(m->broadcast, r + FSMFMU_VR_NEIGHBOUR_BROADCAST, FSMFMU_N_NEIGHBOURS * @PU@_N_BROADCAST);
  to_real(m->k_own, r + FSMFMU_VR_NEIGHBOUR_K_OWN, FSMFMU_N_NEIGHBOURS);
  to_real(m->k_sender, r + FSMFMU_VR_NEIGHBOUR_K_SENDER, FSMFMU_N_NEIGHBOURS);
  nb->count = FSMFMU_N_NEIGHBOURS;
  nb->broadcast = m->broadcast;
  nb->k_own = m->k_own;
  nb->k_sender = m->k_sender;
}

#if @PU@_N_WHEELS > 0
static int wheels(model *m, double *r) {
  @P@_real axes[3 * @PU@_N_WHEELS], speed[@PU@_N_WHEELS], inertia[@PU@_N_WHEELS], u[@PU@_N_WHEELS];
  int status;
  to_real(axes, r + FSMFMU_VR_SPIN_AXES, 3 * @PU@_N_WHEELS);
  to_real(speed, r + FSMFMU_VR_WHEEL_SPEED, @PU@_N_WHEELS);
  to_real(inertia, r + FSMFMU_VR_SPIN_INERTIA, @PU@_N_WHEELS);
  status = @P@_wheel_commands(&m->controller, axes, speed, inertia, u);
  to_double(r + FSMFMU_VR_WHEEL_TORQUE, u, @PU@_N_WHEELS);
  return status;
}
#endif

int fsmfmu_model_step(void *memory, double *r, const int *integers, double t, double h, const char **why) {
  model *m = (model *)memory;
  @P@_input in;
  @P@_neighbours nb;
  @P@_command command;
  @P@_real b[@PU@_N_BROADCAST];
  int status;
  (void)integers;
  if (!(fabs(h - m->period) <= FSMFMU_GRID_TOLERANCE * m->period)) {
    snprintf(m->message, sizeof m->message,
             "doStep: the step size must be control_period * law_state_substeps = %.15g s (one control instant per "
             "step), got %.15g s", m->period, h);
    *why = m->message;
    return 1;
  }
  read_input(r, t, &in);
  status = @P@_broadcast(&m->controller, &in, b);
  if (status == @PU@_STATUS_OK) {
    read_neighbours(m, r, &nb);
    status = @P@_step(&m->controller, &nb, &command);
  }
#if @PU@_N_WHEELS > 0
  if (status == @PU@_STATUS_OK) status = wheels(m, r);
#endif
  if (status != @PU@_STATUS_OK) {
    *why = @P@_status_text(status);
    return 1;
  }
  to_double(r + FSMFMU_VR_BROADCAST, b, @PU@_N_BROADCAST);
  to_double(r + FSMFMU_VR_TORQUE, command.torque, 3);
  to_double(r + FSMFMU_VR_TORQUE_COMMANDED, command.torque_commanded, 3);
  to_double(r + FSMFMU_VR_Z, command.z, @PU@_N_STATES);
  return 0;
}
