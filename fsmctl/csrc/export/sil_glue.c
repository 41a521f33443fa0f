/*
 * Software in the loop: an exported library (@P@.h) as the engine's external controller (fsm_controller_fn of
 * fsmctl/csrc/formation.h), one @P@_controller per agent.  Compiled by fsmctl.export.sil with the exported sources;
 * not part of an export.
 */
#include <stddef.h>

#include "@P@.h"
#include "@P@_law.h"
#include "formation.h"

typedef struct {
  int n, max_links;
  long long z_mismatches; /* instants where the controller's own law state differed from the engine's (float64) */
  long long failures;
  int last_status;
  @P@_controller *agents;
  @P@_real *scratch; /* max_links x (N_BROADCAST + 2) */
} sil_context;

size_t @P@_sil_bytes(int n, int max_links) {
  const int links = max_links > 0 ? max_links : 1;
  return sizeof(sil_context) + sizeof(@P@_controller) * (size_t)n +
         sizeof(@P@_real) * (size_t)links * (size_t)(@PU@_N_BROADCAST + 2);
}

/* memory: @P@_sil_bytes(n, max_links) bytes, aligned for doubles; params n x N_PARAMETERS, J0 n x 9, u_max n */
int @P@_sil_init(void *memory, int n, int max_links, const double *params, const double *J0, const double *u_max,
                 double control_period, int substeps) {
  sil_context *c = (sil_context *)memory;
  char *p = (char *)memory + sizeof(sil_context);
  int i, k;
  c->n = n;
  c->max_links = max_links > 0 ? max_links : 1;
  c->z_mismatches = 0;
  c->failures = 0;
  c->last_status = 0;
  c->agents = (@P@_controller *)(void *)p;
  c->scratch = (@P@_real *)(void *)(p + sizeof(@P@_controller) * (size_t)n);
  for (i = 0; i < n; ++i) {
    @P@_config config;
    @P@_real packed[@PU@_N_PARAMETERS_ALLOC];
    int status;
    @P@_default_config(&config);
    for (k = 0; k < @PU@_N_PARAMETERS; ++k) packed[k] = (@P@_real)params[(size_t)@PU@_N_PARAMETERS * (size_t)i + (size_t)k];
    @P@_unpack_parameters(packed, &config.parameters);
    for (k = 0; k < 9; ++k) config.J0[k] = (@P@_real)J0[9 * (size_t)i + (size_t)k];
    config.torque_limit = (@P@_real)u_max[i];
    config.control_period = (@P@_real)control_period;
    config.law_state_substeps = substeps;
    status = @P@_init(&c->agents[i], &config);
    if (status != @PU@_STATUS_OK) return status;
  }
  return 0;
}

static void to_real(@P@_real *dst, const double *src, int n) {
  int k;
  for (k = 0; k < n; ++k) dst[k] = (@P@_real)src[k];
}

static void to_double(double *dst, const @P@_real *src, int n) {
  int k;
  for (k = 0; k < n; ++k) dst[k] = (double)src[k];
}

static int fail(sil_context *c, int status) {
  c->failures++;
  c->last_status = status;
  return status;
}

int @P@_sil_controller(void *context, int phase, int agent, const fsm_controller_input *in, double *broadcast,
                       double *u, double *u_commanded, double *z_dot) {
  sil_context *c = (sil_context *)context;
  @P@_controller *a = &c->agents[agent];
  int k, status;
  if (phase == FSM_CONTROLLER_BROADCAST) {
    @P@_input input;
    @P@_real b[@PU@_N_BROADCAST];
    input.t = (@P@_real)in->t;
    to_real(input.sigma, in->sigma, 3);
    to_real(input.omega, in->omega, 3);
    to_real(input.sigma_d, in->sigma_d, 3);
    to_real(input.omega_d, in->omega_d, 3);
    to_real(input.omega_d_dot, in->omega_d_dot, 3);
    if (sizeof(@P@_real) == sizeof(double))
      for (k = 0; k < @PU@_N_STATES; ++k)
        if ((double)a->z[k] != in->z[k]) {
          c->z_mismatches++;
          break;
        }
    status = @P@_broadcast(a, &input, b);
    if (status != @PU@_STATUS_OK) return fail(c, status);
    to_double(broadcast, b, @PU@_N_BROADCAST);
    return 0;
  }
  {
    @P@_neighbours nb;
    @P@_command command;
    @P@_real *bs = c->scratch, *ko = bs + (size_t)c->max_links * (size_t)@PU@_N_BROADCAST, *ks = ko + c->max_links;
    if (in->n_links > c->max_links) return fail(c, @PU@_STATUS_BAD_INPUT);
    for (k = 0; k < in->n_links; ++k) {
      to_real(bs + (size_t)k * (size_t)@PU@_N_BROADCAST, in->received[k], @PU@_N_BROADCAST);
      ko[k] = (@P@_real)in->k_own[k];
      ks[k] = (@P@_real)in->k_sender[k];
    }
    nb.count = in->n_links;
    nb.broadcast = bs;
    nb.k_own = ko;
    nb.k_sender = ks;
    status = @P@_step(a, &nb, &command);
    if (status != @PU@_STATUS_OK) return fail(c, status);
    to_double(u, command.torque, 3);
    to_double(u_commanded, command.torque_commanded, 3);
    to_double(z_dot, command.z_dot, @PU@_N_STATES);
    return 0;
  }
}

long long @P@_sil_z_mismatches(const void *context) { return ((const sil_context *)context)->z_mismatches; }
long long @P@_sil_failures(const void *context) { return ((const sil_context *)context)->failures; }
int @P@_sil_last_status(const void *context) { return ((const sil_context *)context)->last_status; }
