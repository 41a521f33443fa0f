/*
 * @P@: one spacecraft's controller (init, broadcast, step) around the law's generated functions (@P@_law.c).
 * Copied by `fsmctl export` from fsmctl/csrc/export/controller.c (do not edit the copy); the API is in @P@.h.
 *
 * The formation-level rules the engine (fsmctl/csrc/formation.c) applies around a law, for one agent, in the
 * engine's arithmetic order (so that in double precision the results are its bits):
 *   - the neighbour aggregation, Liang et al. 2012 eq 19 for any broadcast b: received = sum_j k^j_ij b_j over
 *     the links that are on (k^j_ij != 0), k_sum = sum_j k^i_ij, k_received_sum = sum_j k^j_ij, in link order;
 *   - the law state z held derivative over the control period: law_state_substeps classical Runge-Kutta steps of
 *     control_period (exact for a held derivative: z + substeps h z_dot, in the engine's RK4 arithmetic).
 */
#include "@P@.h"
#include "@P@_law.h"

static int is_finite(@P@_real x) { return x - x == 0; } /* false for NaN and +-inf */

static int all_finite(const @P@_real *x, int n) {
  int k;
  for (k = 0; k < n; ++k)
    if (!is_finite(x[k])) return 0;
  return 1;
}

const char *@P@_status_text(int status) {
  switch (status) {
  case @PU@_STATUS_OK: return "ok";
  case @PU@_STATUS_BAD_PARAMETER: return "a law parameter is outside its declared range";
  case @PU@_STATUS_BAD_CONFIG: return "J0, torque_limit, control_period or law_state_substeps is invalid";
  case @PU@_STATUS_BAD_INPUT: return "an input is not finite or the neighbour count is negative";
  case @PU@_STATUS_NONFINITE: return "the law commanded a non-finite torque";
  case @PU@_STATUS_NOT_READY: return "step() needs broadcast() first, once per control instant";
  default: return "unknown status";
  }
}

/* a failed call: its status, and the words P_error_text gives until the next call that succeeds */
static int fail(@P@_controller *controller, int status) {
  controller->error = @P@_status_text(status);
  return status;
}

const char *@P@_error_text(const @P@_controller *controller) {
  return controller->error ? controller->error : "ok";
}

/* J0 symmetric positive definite (Sylvester's criterion), finite */
static int inertia_ok(const @P@_real *J) {
  @P@_real m2, m3;
  if (!all_finite(J, 9)) return 0;
  if (J[1] != J[3] || J[2] != J[6] || J[5] != J[7]) return 0;
  m2 = J[0] * J[4] - J[1] * J[3];
  m3 = J[0] * (J[4] * J[8] - J[5] * J[7]) - J[1] * (J[3] * J[8] - J[5] * J[6]) + J[2] * (J[3] * J[7] - J[4] * J[6]);
  return J[0] > 0 && m2 > 0 && m3 > 0;
}

static int config_problem(const @P@_config *config) {
  const @P@_real limit = config->torque_limit, h = config->control_period;
  if (!inertia_ok(config->J0)) return 1;
  if (!(limit > 0)) return 2; /* +inf: no limit */
  if (!(h > 0) || !is_finite(h)) return 3;
  if (config->law_state_substeps < 1) return 4;
  return 0;
}

int @P@_init(@P@_controller *controller, const @P@_config *config) {
  static const char *const config_errors[] = {
      "ok", "J0: must be finite, symmetric and positive definite", "torque_limit: must be > 0 (+inf: no limit)",
      "control_period: must be finite and > 0", "law_state_substeps: must be >= 1"};
  const @P@_real *arg[1];
  @P@_real *res[1];
  int k, why;
  controller->error = 0;
  controller->ready = 0;
  controller->stepped = 0;
  @P@_pack_parameters(&config->parameters, controller->params);
  controller->error = @P@_check_parameters(controller->params);
  if (controller->error) return @PU@_STATUS_BAD_PARAMETER;
  why = config_problem(config);
  if (why) {
    controller->error = config_errors[why];
    return @PU@_STATUS_BAD_CONFIG;
  }
  controller->config = *config;
  arg[0] = controller->params;
  res[0] = controller->constants;
  @P@_law_constants(arg, res);
  for (k = 0; k < @PU@_N_STATES; ++k) controller->z[k] = @P@_initial_state[k];
  return @PU@_STATUS_OK;
}

int @P@_reset_state(@P@_controller *controller, const @P@_real z[@PU@_N_STATES_ALLOC]) {
  int k;
  if (!all_finite(z, @PU@_N_STATES)) return @PU@_STATUS_BAD_INPUT;
  for (k = 0; k < @PU@_N_STATES; ++k) controller->z[k] = z[k];
  return @PU@_STATUS_OK;
}

static void law_arguments(@P@_controller *c, const @P@_real **arg) {
  const @P@_input *in = &c->input;
  arg[0] = &in->t;
  arg[1] = in->sigma;
  arg[2] = in->omega;
  arg[3] = c->z;
  arg[4] = in->sigma_d;
  arg[5] = in->omega_d;
  arg[6] = in->omega_d_dot;
  arg[7] = c->config.J0;
  arg[8] = c->params;
  arg[9] = c->constants;
  arg[10] = c->cache;
  arg[11] = &c->k_sum;
  arg[12] = c->received;
  arg[13] = &c->k_received_sum;
  arg[14] = &c->config.torque_limit;
}

int @P@_broadcast(@P@_controller *controller, const @P@_input *input, @P@_real broadcast[@PU@_N_BROADCAST]) {
  const @P@_real *arg[15];
  @P@_real *res[2];
  const @P@_input *in = input;
  if (!is_finite(in->t) || !all_finite(in->sigma, 3) || !all_finite(in->omega, 3) || !all_finite(in->sigma_d, 3) ||
      !all_finite(in->omega_d, 3) || !all_finite(in->omega_d_dot, 3))
    return fail(controller, @PU@_STATUS_BAD_INPUT);
  controller->input = *input;
  controller->error = 0;
  law_arguments(controller, arg);
  res[0] = broadcast;
  res[1] = controller->cache;
  @P@_law_local(arg, res);
  controller->ready = 1;
  controller->stepped = 0;
  return @PU@_STATUS_OK;
}

/* eq 19 for one agent, in link order (the engine's aggregate()) */
static void aggregate(@P@_controller *c, const @P@_neighbours *nb) {
  int j, k;
  @P@_real ks = 0, kr = 0;
  for (k = 0; k < @PU@_N_BROADCAST; ++k) c->received[k] = 0;
  for (j = 0; j < nb->count; ++j) {
    const @P@_real kj = nb->k_sender[j];
    const @P@_real *bj = nb->broadcast + (long)j * @PU@_N_BROADCAST;
    ks += nb->k_own[j];
    kr += kj;
    if (kj != 0) /* a link switched off adds nothing, not even 0 * b */
      for (k = 0; k < @PU@_N_BROADCAST; ++k) c->received[k] += kj * bj[k];
  }
  c->k_sum = ks;
  c->k_received_sum = kr;
}

/* z over the control period with the held derivative (the engine's RK4 step, every stage equal) */
static void advance(@P@_controller *c, const @P@_real *z_dot) {
  const @P@_real h = c->config.control_period;
  int m, k;
  for (m = 0; m < c->config.law_state_substeps; ++m)
    for (k = 0; k < @PU@_N_STATES; ++k) {
      const @P@_real d = z_dot[k];
      c->z[k] = c->z[k] + h / 6 * ((d + 2 * (d + d)) + d);
    }
}

int @P@_step(@P@_controller *controller, const @P@_neighbours *neighbours, @P@_command *command) {
  const @P@_real *arg[15];
  @P@_real *res[3];
  int k;
  if (!controller->ready) return fail(controller, @PU@_STATUS_NOT_READY);
  if (neighbours->count < 0) return fail(controller, @PU@_STATUS_BAD_INPUT);
  for (k = 0; k < neighbours->count; ++k)
    if (!is_finite(neighbours->k_own[k]) || !is_finite(neighbours->k_sender[k]) ||
        !all_finite(neighbours->broadcast + (long)k * @PU@_N_BROADCAST, @PU@_N_BROADCAST))
      return fail(controller, @PU@_STATUS_BAD_INPUT);
  controller->ready = 0;
  controller->error = 0;
  aggregate(controller, neighbours);
  law_arguments(controller, arg);
  res[0] = command->torque;
  res[1] = command->torque_commanded;
  res[2] = command->z_dot;
  @P@_law_control(arg, res);
  for (k = 0; k < @PU@_N_STATES; ++k) controller->z_used[k] = controller->z[k];
  controller->stepped = 1;
  if (!all_finite(command->torque_commanded, 3)) return fail(controller, @PU@_STATUS_NONFINITE);
  advance(controller, command->z_dot);
  for (k = 0; k < @PU@_N_STATES; ++k) command->z[k] = controller->z[k];
  return @PU@_STATUS_OK;
}

#if @PU@_N_WHEELS > 0
int @P@_wheel_commands(const @P@_controller *controller, const @P@_real spin_axes[3 * @PU@_N_WHEELS],
                       const @P@_real wheel_speed[@PU@_N_WHEELS], const @P@_real spin_inertia[@PU@_N_WHEELS],
                       @P@_real u_wheels[@PU@_N_WHEELS]) {
  const @P@_real *arg[18];
  @P@_real *res[1];
  @P@_controller *c = (@P@_controller *)controller; /* the arguments are read only */
  if (!controller->stepped) return @PU@_STATUS_NOT_READY;
  law_arguments(c, arg);
  arg[3] = c->z_used; /* the law state step() used */
  arg[15] = spin_axes;
  arg[16] = wheel_speed;
  arg[17] = spin_inertia;
  res[0] = u_wheels;
  @P@_law_wheels(arg, res);
  return all_finite(u_wheels, @PU@_N_WHEELS) ? @PU@_STATUS_OK : @PU@_STATUS_NONFINITE;
}
#endif

#if @PU@_HAS_TRIGGER
@P@_real @P@_trigger_margin(const @P@_controller *controller, @P@_real t,
                            const @P@_real broadcast[@PU@_N_BROADCAST],
                            const @P@_real broadcast_sent[@PU@_N_BROADCAST]) {
  const @P@_real *arg[5];
  @P@_real margin = 0;
  @P@_real *res[1];
  arg[0] = &t;
  arg[1] = broadcast;
  arg[2] = broadcast_sent;
  arg[3] = controller->params;
  arg[4] = controller->constants;
  res[0] = &margin;
  @P@_law_trigger(arg, res);
  return margin;
}
#endif
