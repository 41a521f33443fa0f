/*
 * Whole-loop formation simulator: see formation.h.  Compiled by fsmctl together with the CasADi-generated
 * sources of the model (generated/c) and of one law into one shared library.  No model or control equation
 * is written here: every physical or control formula is a call into the generated code.
 */
#include "formation.h"

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "batched.h"
#include "disturbance_torque.h"
#include "error_state_exact.h"
#include "error_state_paper.h"
#include "gyrostat_rhs.h"
#include "law_batched.h"
#include "law_constants.h"
#include "law_control_exact.h"
#include "law_control_paper.h"
#include "law_local_exact.h"
#include "law_local_paper.h"
#ifdef FSM_LAW_WHEELS /* the law commands its wheels (law.json "wheels"; fsmctl.model.generated_code) */
#include "law_wheels_exact.h"
#include "law_wheels_paper.h"
#endif
#include "mrp_shadow.h"
#include "plant_rhs.h"
#include "reference_rhs.h"
#include "sensor_measurement.h"
#include "wheel_acceleration.h"
#include "wheel_net_torque.h"
#include "wheel_torque.h"
#ifdef FSM_LAW_TRIGGER /* a law that declares LawBuilder.trigger (fsmctl.model.generated_code.law_defines) */
#include "law_trigger.h"
#endif

typedef int (*casadi_fn)(const casadi_real **arg, casadi_real **res, casadi_int *iw, casadi_real *w, int mem);
typedef int (*casadi_work_fn)(casadi_int *sz_arg, casadi_int *sz_res, casadi_int *sz_iw, casadi_int *sz_w);
typedef const casadi_int *(*casadi_sparsity_fn)(casadi_int i);
typedef int (*batched_fn)(const double *const *arg, double *const *res, int lanes);

/* ------------------------------------------------------------------------------------------------ ABI */
#define FSM_FIELD(T, f) (long long)offsetof(T, f)
int fsm_abi(long long *out, int capacity) {
  const long long v[] = {
      FSM_ABI_VERSION, (long long)sizeof(fsm_problem), (long long)sizeof(fsm_output),
      FSM_FIELD(fsm_problem, n_agents), FSM_FIELD(fsm_problem, error_model), FSM_FIELD(fsm_problem, integrator),
      FSM_FIELD(fsm_problem, kernels), FSM_FIELD(fsm_problem, n_params), FSM_FIELD(fsm_problem, n_states),
      FSM_FIELD(fsm_problem, n_broadcast), FSM_FIELD(fsm_problem, n_links), FSM_FIELD(fsm_problem, t0),
      FSM_FIELD(fsm_problem, dt), FSM_FIELD(fsm_problem, n_steps), FSM_FIELD(fsm_problem, output_every),
      FSM_FIELD(fsm_problem, hold_steps), FSM_FIELD(fsm_problem, rtol), FSM_FIELD(fsm_problem, atol),
      FSM_FIELD(fsm_problem, h_min), FSM_FIELD(fsm_problem, max_steps), FSM_FIELD(fsm_problem, J_true),
      FSM_FIELD(fsm_problem, J0), FSM_FIELD(fsm_problem, params), FSM_FIELD(fsm_problem, u_max),
      FSM_FIELD(fsm_problem, dist_params), FSM_FIELD(fsm_problem, ref_params), FSM_FIELD(fsm_problem, link_receiver),
      FSM_FIELD(fsm_problem, link_sender), FSM_FIELD(fsm_problem, link_k_i), FSM_FIELD(fsm_problem, sched_period),
      FSM_FIELD(fsm_problem, sched_phase), FSM_FIELD(fsm_problem, sched_start), FSM_FIELD(fsm_problem, sched_count),
      FSM_FIELD(fsm_problem, sched_times), FSM_FIELD(fsm_problem, sched_values),
      FSM_FIELD(fsm_problem, n_wheels), FSM_FIELD(fsm_problem, sensors), FSM_FIELD(fsm_problem, links_imperfect),
      FSM_FIELD(fsm_problem, n_samples), FSM_FIELD(fsm_problem, wheel_axes), FSM_FIELD(fsm_problem, wheel_pinv),
      FSM_FIELD(fsm_problem, wheel_Js), FSM_FIELD(fsm_problem, wheel_torque_max), FSM_FIELD(fsm_problem, wheel_params),
      FSM_FIELD(fsm_problem, J_spin), FSM_FIELD(fsm_problem, sensor_dtheta), FSM_FIELD(fsm_problem, sensor_gyro),
      FSM_FIELD(fsm_problem, link_delay), FSM_FIELD(fsm_problem, link_lost), FSM_FIELD(fsm_problem, n_members),
      FSM_FIELD(fsm_problem, wheel_allocation), FSM_FIELD(fsm_problem, wheel_gate),
      FSM_FIELD(fsm_problem, wheel_command),
      FSM_FIELD(fsm_problem, trigger_every), FSM_FIELD(fsm_problem, zeno_checks), /* ABI 5 */
      FSM_FIELD(fsm_problem, controller), FSM_FIELD(fsm_problem, controller_context), /* ABI 6 */
      FSM_FIELD(fsm_output, capacity), FSM_FIELD(fsm_output, written), FSM_FIELD(fsm_output, t),
      FSM_FIELD(fsm_output, sigma_d), FSM_FIELD(fsm_output, sigma), FSM_FIELD(fsm_output, omega),
      FSM_FIELD(fsm_output, sigma_e), FSM_FIELD(fsm_output, omega_e), FSM_FIELD(fsm_output, u),
      FSM_FIELD(fsm_output, u_unsat), FSM_FIELD(fsm_output, broadcast), FSM_FIELD(fsm_output, z),
      FSM_FIELD(fsm_output, saturated_time), FSM_FIELD(fsm_output, u_total_variation),
      FSM_FIELD(fsm_output, u_unsat_max), FSM_FIELD(fsm_output, steps_taken), FSM_FIELD(fsm_output, steps_rejected),
      FSM_FIELD(fsm_output, fail_time), FSM_FIELD(fsm_output, fail_agent), FSM_FIELD(fsm_output, wheel_speed),
      FSM_FIELD(fsm_output, wheel_torque), FSM_FIELD(fsm_output, sigma_measured), FSM_FIELD(fsm_output, omega_measured),
      /* ABI 5 */
      FSM_FIELD(fsm_output, messages_sent), FSM_FIELD(fsm_output, messages_delivered),
      FSM_FIELD(fsm_output, events_per_output), FSM_FIELD(fsm_output, first_event), FSM_FIELD(fsm_output, last_event),
      FSM_FIELD(fsm_output, min_inter_event)};
  const int n = (int)(sizeof v / sizeof v[0]);
  for (int k = 0; k < n && k < capacity; ++k) out[k] = v[k];
  return n;
}

/* Nonzeros of a CasADi sparsity pattern: {nrow, ncol, 1} is the compact form of a dense pattern,
 * otherwise {nrow, ncol, colind[0] = 0, ..., colind[ncol], rows...}. */
static int sparsity_nnz(const casadi_int *sp) { return (int)(sp[2] == 1 ? sp[0] * sp[1] : sp[2 + sp[1]]); }

/* Law sizes, read from the generated functions' sparsity (law_local: 10 inputs, 2 outputs; law_control: 15, 3). */
enum { LI_T, LI_SIGMA, LI_OMEGA, LI_Z, LI_SD, LI_WD, LI_WDD, LI_J0, LI_PARAMS, LI_CONST, N_LOCAL_IN };
enum { CI_CACHE = N_LOCAL_IN, CI_KSUM, CI_RECV, CI_KRS, CI_UMAX, N_CONTROL_IN };

void fsm_law_sizes(long long *out) {
  out[0] = sparsity_nnz(law_local_paper_sparsity_in(LI_PARAMS));
  out[1] = sparsity_nnz(law_local_paper_sparsity_in(LI_Z));
  out[2] = sparsity_nnz(law_local_paper_sparsity_out(0));
  out[3] = sparsity_nnz(law_constants_sparsity_out(0));
  out[4] = sparsity_nnz(law_local_paper_sparsity_out(1));
}

/* The contract of fsmctl.symbolic.law, checked against the generated functions: argument counts and sizes. */
static int law_contract_ok(const fsm_problem *P, int *nk, int *nc) {
  casadi_sparsity_fn lin[2] = {law_local_paper_sparsity_in, law_local_exact_sparsity_in};
  casadi_sparsity_fn lout[2] = {law_local_paper_sparsity_out, law_local_exact_sparsity_out};
  casadi_sparsity_fn cin[2] = {law_control_paper_sparsity_in, law_control_exact_sparsity_in};
  casadi_sparsity_fn cout[2] = {law_control_paper_sparsity_out, law_control_exact_sparsity_out};
  if (law_local_paper_n_in() != N_LOCAL_IN || law_local_exact_n_in() != N_LOCAL_IN) return 0;
  if (law_control_paper_n_in() != N_CONTROL_IN || law_control_exact_n_in() != N_CONTROL_IN) return 0;
  if (law_local_paper_n_out() != 2 || law_local_exact_n_out() != 2) return 0;
  if (law_control_paper_n_out() != 3 || law_control_exact_n_out() != 3) return 0;
  *nk = sparsity_nnz(law_constants_sparsity_out(0));
  *nc = sparsity_nnz(law_local_paper_sparsity_out(1));
  if (sparsity_nnz(law_constants_sparsity_in(0)) != P->n_params) return 0;
  const int sizes[N_CONTROL_IN] = {1, 3, 3, P->n_states, 3, 3, 3, 9, P->n_params, *nk,
                                   *nc, 1, P->n_broadcast, 1, 1};
  for (int m = 0; m < 2; ++m) {
    for (int a = 0; a < N_CONTROL_IN; ++a) {
      if (sparsity_nnz(cin[m](a)) != sizes[a]) return 0;
      if (a < N_LOCAL_IN && sparsity_nnz(lin[m](a)) != sizes[a]) return 0;
    }
    if (sparsity_nnz(lout[m](0)) != P->n_broadcast || sparsity_nnz(lout[m](1)) != *nc) return 0;
    if (sparsity_nnz(cout[m](0)) != 3 || sparsity_nnz(cout[m](1)) != 3 || sparsity_nnz(cout[m](2)) != P->n_states)
      return 0;
  }
  return 1;
}

/* The law's trigger (event-triggered communication) as compiled: law_trigger(t, broadcast, broadcast_sent, params,
 * constants) -> margin, checked against the law's sizes; 0 in a build without it. */
int fsm_trigger_available(void) {
#ifdef FSM_LAW_TRIGGER
  return 1;
#else
  return 0;
#endif
}

static int trigger_contract_ok(const fsm_problem *P, int nk) {
#ifdef FSM_LAW_TRIGGER
  const int sizes[5] = {1, P->n_broadcast, P->n_broadcast, P->n_params, nk};
  if (law_trigger_n_in() != 5 || law_trigger_n_out() != 1 || sparsity_nnz(law_trigger_sparsity_out(0)) != 1) return 0;
  for (int a = 0; a < 5; ++a)
    if (sparsity_nnz(law_trigger_sparsity_in(a)) != sizes[a]) return 0;
  return 1;
#else
  (void)P, (void)nk;
  return 0;
#endif
}

/* Lane-batched evaluation.  Agents are taken FSM_LANES at a time ("groups"); each group owns one block of
 * rows x FSM_LANES doubles, element k of lane l of a row at row[FSM_LANES * k + l] (the layout of the
 * generated kernels).  The rows hold every argument and result of the per-agent functions, so law_local
 * writes the cache where law_control reads it, and the run constants (parameters, inertias) are packed
 * once.  Row offsets follow from the law's sizes.  Lanes past the last agent repeat it; their results are
 * never read.  Time and reference are the same for every group: the kernels read them from the shared rows
 * (law_row), and a group has no rows RW_T, RW_SD, RW_WD, RW_WDD of its own (size 0 in lane_rows). */
enum {
  RW_T, RW_SIGMA, RW_OMEGA, RW_Z, RW_SD, RW_WD, RW_WDD, RW_J0, RW_PARAMS, RW_CONST, /* law inputs, as LI_* */
  RW_CACHE, RW_KSUM, RW_RECV, RW_KRS, RW_UMAX,                                /* control inputs, as CI_* */
  RW_B, RW_U, RW_UU, RW_ZDOT,                                                 /* law outputs */
  RW_TAU, RW_JTRUE, RW_SIGMA_DOT, RW_OMEGA_DOT,                               /* plant */
  RW_HW, RW_TAUW, RW_JSPIN,                                                   /* gyrostat (wheels) */
  RW_END
};
#define LANE(g, row) ((g) + FSM_LANES * (row))
/* Lane rows of the wheel kernels (wheels of all agents, flattened, FSM_LANES at a time). */
enum { WL_U, WL_OM, WL_PAR, WL_UM = WL_PAR + 4, WL_UN, WL_G, WL_JS = WL_G + 3, WL_UNET, WL_WD, WL_OD = WL_WD + 3, WL_END };
/* Lane rows of the disturbance kernel (the agents whose disturbance parameters are distinct, FSM_LANES at a time). */
enum { DL_PAR, DL_D = DL_PAR + 12, DL_END = DL_D + 3 };
/* Lane rows every group shares (the same value in every lane): time and reference, filled once per evaluation. */
enum { CM_T, CM_SD, CM_WD = CM_SD + 3, CM_WDD = CM_WD + 3, CM_END = CM_WDD + 3 };


/* On a cache-line boundary (lane rows: see calloc_lines). */
#ifdef __GNUC__
#define FSM_LINE __attribute__((aligned(64)))
#else
#define FSM_LINE
#endif

/* The agent in lane l of group g: lanes past the last agent repeat it (their results are never read). */
static inline int lane_agent(int g, int l, int n) { return g * FSM_LANES + l < n ? g * FSM_LANES + l : n - 1; }
static inline int active_lanes(int g, int n) { return n - g * FSM_LANES < FSM_LANES ? n - g * FSM_LANES : FSM_LANES; }
static inline void to_lane(double *row, const double *src, int nnz, int l) {
  for (int k = 0; k < nnz; ++k) row[FSM_LANES * k + l] = src[k];
}
static inline void from_lane(double *dst, const double *row, int nnz, int l) {
  for (int k = 0; k < nnz; ++k) dst[k] = row[FSM_LANES * k + l];
}
static inline void from_lane3(double *dst, const double *row, int l) {
  dst[0] = row[l];
  dst[1] = row[FSM_LANES + l];
  dst[2] = row[2 * FSM_LANES + l];
}
/* Rows of one group from a source per lane (nnz values at src[l]): each row built in a register and stored as one
 * vector, which the kernels' vector loads read back at once (a row written lane by lane with scalar stores makes
 * every such load wait for the stores to retire: no store forwarding from several stores to one load). */
static inline void to_rows(double *row, const double *const *src, int nnz) {
  for (int k = 0; k < nnz; ++k) {
#ifdef __GNUC__
#if FSM_LANES == 8
    const fsm_pow_v v = {src[0][k], src[1][k], src[2][k], src[3][k], src[4][k], src[5][k], src[6][k], src[7][k]};
#else
    const fsm_pow_v v = {src[0][k], src[1][k], src[2][k], src[3][k]};
#endif
    memcpy(row + FSM_LANES * k, &v, sizeof v);
#else
    for (int l = 0; l < FSM_LANES; ++l) row[FSM_LANES * k + l] = src[l][k];
#endif
  }
}
/* The same values in every lane of a row (time, reference). */
static inline void broadcast_row(double *row, const double *src, int nnz) {
  for (int k = 0; k < nnz; ++k)
    for (int l = 0; l < FSM_LANES; ++l) row[FSM_LANES * k + l] = src[k];
}

typedef struct {
  int n, nz, nb, np, nk, nc, stride;     /* agents, law states, broadcast, params, constants, cache; state stride */
  int members;                           /* runs flown together (>= 1): the output layout, see fsm_problem */
  int batched;                           /* 1: lane-batched kernels for the per-agent functions */
  double common[CM_END * FSM_LANES] FSM_LINE; /* the shared lane rows (CM_*) */
  int n_groups;                          /* ceil(n / FSM_LANES) */
  int row[RW_END + 1];                   /* row offsets of the lane blocks */
  double *lanes;                         /* n_groups blocks of row[RW_END] x FSM_LANES doubles */
  void *lanes_raw, *dl_raw, *wl_raw;     /* what free() takes of lanes, dl, wl (calloc_lines) */
  const double **law_args;               /* n_groups x N_CONTROL_IN: the law kernels' argument rows (law_row), the
                                          * local kernel's the first N_LOCAL_IN; the state rows set per evaluation */
  /* The state x of the loops: sigma_d (3), then agent i's sigma, omega, z and wheel speeds at 3 + stride * i (the
   * layout of fsm_simulate's x0 and of fsm_rhs); or, with lane_state, in lane rows: sigma_d in the first FSM_LANES
   * doubles (3 used, the rest 0), then per group g a block of state_block = (6 + nz) x FSM_LANES doubles, the rows
   * sigma_0..2, omega_0..2, z_0..nz-1 (element (k, l) at block[FSM_LANES * k + l]), which the batched kernels read
   * and write in place.  RK4's updates are elementwise: the layout changes no number.  Lanes past the last agent
   * hold its initial state with rate 0 (zero_spare_lanes).  lane_state: batched kernels, no wheels, no sensors,
   * RK4 (alloc_workspace decides for fsm_simulate; fsm_rhs and Dormand-Prince, whose error norm sums over x in its
   * order, never). */
  int lane_state;
  size_t n_state, state_block;           /* doubles in x; per group (lane_state) */
  double *xa;                            /* stride doubles: one agent's state gathered from the rows (agent_state) */
  batched_fn local_x, control_x;
  casadi_fn local, control, error_state;
  double *b, *cache, *konst;             /* n x nb, n x nc, n x nk */
  double *recv, *ksum, *krs;             /* n x nb, n, n */
  double *u, *uu, *zdot;                 /* computed control (n x 3, n x 3, n x nz) */
  double *u_hold, *uu_hold, *zdot_hold;  /* held control (zero-order hold) */
  const double *u_apply, *uu_apply, *zdot_apply; /* what the plant and the law states see */
  double *d;                             /* disturbance torques, n x 3 */
  int *d_src;                            /* agent whose disturbance parameters agent i's equal, bit for bit (<= i) */
  double d_time;
  int d_valid;
  double *dl;                            /* disturbance lanes (batched): n_dgroups blocks of DL_END x FSM_LANES */
  int *d_lane;                           /* per lane of the disturbance groups: the agent it evaluates */
  int n_ddistinct, n_dgroups;            /* agents with d_src[i] == i; ceil(n_ddistinct / FSM_LANES) */
  int d_rows;                            /* 1: every agent's parameters distinct: disturbance group g is agent
                                          * group g, and the plant reads its rows DL_D (no gather from d) */
  double wd[3], wdd[3];
  double *k_val, *k_base, *k_lo, *k_hi;  /* per-link schedule cache */
  double *k_flo, *k_fhi;                 /* per link: where the cache needs no period check (see link_weight) */
  double *k_now;                         /* k^j of every link at k_time (all RK4 stages of a step share it) */
  int *in_start, *in_links;              /* links by receiver: in_links[in_start[i] .. in_start[i+1]) in link order */
  int *act_start, *act_src;              /* the links with k^j != 0 at k_time, by receiver in link order: where their */
  double *act_k;                         /* broadcast sits (in b, or link_val when imperfect) and their k^j */
  /* The same active links by receiver lane (batched kernels; see lane_links): group g's slots m < slot_n[g] at
   * slot_base[g] + m, each FSM_LANES sources (act_src) and weights (act_k), lane l's m-th active link where m <
   * slot_deg[g FSM_LANES + l] (else source 0, weight 0: never added) */
  int *slot_base, *slot_n, *slot_src;
  long long *slot_deg;
  double *slot_k;
  double k_time;
  int k_valid;
  double k_win_lo, k_win_hi;             /* link times where every link's cache check passes (see link_weights) */
  double *tau;                           /* n x 3 */
  /* flight hardware */
  int nw;                                /* wheels per agent */
  double *hw;                            /* one block for the hardware doubles below */
  double *uw, *uw_hold;                  /* wheel commands (n x nw): computed, held */
  const double *uw_apply;
  double *wscale, *wscale_hold;          /* n: distribution scale factor (> 1: a wheel at its torque limit) */
  const double *wscale_apply;
  double *u_motor, *u_net;               /* n x nw: motor torque after the speed limit, net torque (last evaluation) */
  double *h_w, *tau_w, *u_body;          /* n x 3: wheel momentum, torque on the wheels, -tau_w (last evaluation) */
  int *gated;                            /* n: a wheel held at its speed limit (last evaluation) */
  int gate_held;                         /* 1: inner stage of a step with the speed limit held (u_motor as decided) */
  double *sig_meas, *om_meas;            /* n x 3: what the law sees (sensors) */
  double *wl;                            /* lanes of the wheel kernels: ceil(n nw / FSM_LANES) blocks of WL_END rows */
  int n_wgroups;
  int *wheel_lane;                       /* per lane of the wheel groups: the flattened wheel index m */
  size_t *wheel_x, *wheel_wd;            /* per lane: offset of its Omega in x, of its agent's omega_dot in dx */
  /* a law that commands its wheels (law_wheels_<model>; NULL: the minimum-norm distribution) */
  casadi_fn law_wheels;
  double *lw_in;                         /* nc + nb: one agent's cache and received sum, gathered from the lanes */
  double *lw_w;                          /* ... followed by its own CasADi work array */
  casadi_int *lw_iw;
  long long q;                           /* the current control instant */
  int hist_len;                          /* slots of the broadcast history (max delay + 1) */
  double *b_hist, *b_first, *link_val;   /* hist_len x n x nb; n x nb (instant 0); n_links x nb (delivered) */
  int bad_agent;                         /* first agent whose commanded torque was non-finite (-2: none) */
  double bad_time;                       /* ... and when */
  int bad_rc;                            /* ... and the status it ends the run with (FSM_NONFINITE_CONTROL, FSM_ZENO) */
  /* event-triggered communication (trigger_every > 0) */
  const double *b_tx;                    /* what the links carry: b (periodic) or b_sent (event-triggered) */
  int b_in_lanes;                        /* 1: the neighbour sums read b_j from the lane rows RW_B (batched kernels,
                                          * periodic, perfect links); W->b is then written at compute_control 1 only */
  double *b_sent;                        /* n x nb: the last broadcast each agent sent */
  unsigned char *sent_now, *sent_hist;   /* n: sent at the current instant; hist_len x n (imperfect links) */
  long long *streak, *since_out;         /* n: consecutive checks with a message; messages since the last record */
  fsm_output *out;                       /* where the message counts go (NULL: not counted, e.g. fsm_rhs) */
  /* software in the loop (P->controller): one receiver's links */
  double *ext_k_own, *ext_k_sender;      /* n_links each */
  const double **ext_received;           /* n_links */
  casadi_int *iw;
  double *w;
} workspace;

static void free_workspace(workspace *W) {
  free(W->b);
  free(W->b_sent);
  free(W->sent_now);
  free(W->streak);
  free(W->in_start);
  free(W->in_links);
  free(W->act_start);
  free(W->act_src);
  free(W->act_k);
  free(W->slot_base);
  free(W->slot_src);
  free(W->slot_deg);
  free(W->slot_k);
  free(W->d_src);
  free(W->dl_raw);
  free(W->d_lane);
  free(W->wl_raw);
  free(W->wheel_lane);
  free(W->wheel_x);
  free(W->wheel_wd);
  free(W->hw);
  free(W->gated);
  free(W->lw_in);
  free(W->lw_iw);
  free(W->lanes_raw);
  free(W->law_args);
  free(W->xa);
  free(W->iw);
  free(W->w);
  free(W->ext_k_own);
  free(W->ext_received);
  memset(W, 0, sizeof(*W));
}

/* The batched kernels pay off with 256-bit vector registers (AVX: one register per 4 lanes; with AVX-512 the build
 * takes 8 lanes per call, fsmctl.model.generated_code.lane_width).  Without AVX the
 * compiler splits each 4-lane operation into SSE2 halves and the scalar functions are faster (measured with
 * FSMCTL_PORTABLE=1 builds), so "auto" picks the scalar path there.  Both paths give the same results, bit for
 * bit, except the sign of a zero from fmin/fmax of +0 and -0, which C99 leaves unspecified. */
int fsm_batched_available(void) {
#ifdef FSM_HAVE_BATCHED
  return 1;
#else
  return 0;
#endif
}

int fsm_lane_width(void) { return FSM_LANES; }

int fsm_batched_preferred(void) {
#if defined(__AVX__) && defined(FSM_HAVE_BATCHED)
  return 1;
#else
  return 0;
#endif
}

#ifndef FSM_HAVE_BATCHED
/* A compiler without the GCC/Clang vector extension compiles no kernels (the batched sources are empty);
 * these stand-ins are never called: alloc_workspace refuses FSM_KERNELS_BATCHED and "auto" means scalar. */
static int fsm_no_kernel(const double *const *arg, double *const *res, int lanes) {
  (void)arg, (void)res, (void)lanes;
  return 1;
}
#define law_local_paper_batched fsm_no_kernel
#define law_local_exact_batched fsm_no_kernel
#define law_control_paper_batched fsm_no_kernel
#define law_control_exact_batched fsm_no_kernel
#define plant_rhs_batched fsm_no_kernel
#define disturbance_torque_batched fsm_no_kernel
#define gyrostat_rhs_batched fsm_no_kernel
#define wheel_torque_batched fsm_no_kernel
#define wheel_acceleration_batched fsm_no_kernel
#define wheel_net_torque_batched fsm_no_kernel
#endif


/* count zeroed doubles from a cache-line boundary (64 bytes: a row of 8 lanes never straddles two lines, each
 * vector load and store of a row touches one); *raw receives the pointer free() takes. */
static double *calloc_lines(size_t count, void **raw) {
  *raw = calloc(count + 8, sizeof(double));
  return *raw ? (double *)(((uintptr_t)*raw + 63) & ~(uintptr_t)63) : NULL;
}

static void lane_rows(workspace *W) {
  /* RW_T, RW_SD, RW_WD, RW_WDD: none of their own (the kernels read the shared rows, law_row) */
  const int size[RW_END] = {0, 3, 3, W->nz, 0, 0, 0, 9, W->np, W->nk, W->nc, 1, W->nb, 1, 1,
                            W->nb, 3, 3, W->nz, 3, 9, 3, 3, 3, 3, 9};
  W->row[0] = 0;
  for (int r = 0; r < RW_END; ++r) W->row[r + 1] = W->row[r] + size[r];
}

static double *group_block(workspace *W, int g) { return W->lanes + (size_t)g * W->row[RW_END] * FSM_LANES; }
#define ROW(G, r) LANE(G, W->row[r])
/* Argument row r of a law or plant kernel for group G: the shared rows (time, reference), the state rows of the
 * group's block xg of x (lane_state; NULL: the group's rows RW_SIGMA, RW_OMEGA, RW_Z), or the group's own. */
static inline const double *law_row(workspace *W, double *G, const double *xg, int r) {
  switch (r) {
    case RW_T: return LANE(W->common, CM_T);
    case RW_SD: return LANE(W->common, CM_SD);
    case RW_WD: return LANE(W->common, CM_WD);
    case RW_WDD: return LANE(W->common, CM_WDD);
    case RW_SIGMA: return xg ? xg : ROW(G, r);
    case RW_OMEGA: return xg ? xg + 3 * FSM_LANES : ROW(G, r);
    case RW_Z: return xg ? xg + 6 * FSM_LANES : ROW(G, r);
    default: return ROW(G, r);
  }
}
/* Group g's block of the state x (lane_state). */
static inline size_t state_group(const workspace *W, int g) { return FSM_LANES + (size_t)g * W->state_block; }
/* Group g's block of x with lane_state, else NULL. */
static inline const double *lane_x(const workspace *W, const double *x, int g) {
  return W->lane_state ? x + state_group(W, g) : NULL;
}
/* Where agent i's state starts in x; its components are agent_step(W) apart. */
static inline size_t agent_at(const workspace *W, int i) {
  return W->lane_state ? state_group(W, i / FSM_LANES) + i % FSM_LANES : 3 + (size_t)W->stride * i;
}
static inline int agent_step(const workspace *W) { return W->lane_state ? FSM_LANES : 1; }
/* Agent i's state (stride doubles: sigma, omega, z, wheel speeds): its place in x, or gathered into W->xa from the
 * lane rows (lane_state; valid until the next call). */
static const double *agent_state(workspace *W, const double *x, int i) {
  const double *B = x + agent_at(W, i);
  if (!W->lane_state) return B;
  for (int k = 0; k < W->stride; ++k) W->xa[k] = B[FSM_LANES * k];
  return W->xa;
}
/* x0 (fsm_simulate's layout) into the loops' state x (zeroed, n_state doubles); lanes past the last agent repeat
 * it. */
static void state_from(workspace *W, const double *x0, double *x) {
  if (!W->lane_state) {
    memcpy(x, x0, sizeof(double) * W->n_state);
    return;
  }
  memcpy(x, x0, 3 * sizeof(double));
  for (int g = 0; g < W->n_groups; ++g)
    for (int l = 0; l < FSM_LANES; ++l)
      to_lane(x + state_group(W, g), x0 + 3 + (size_t)W->stride * lane_agent(g, l, W->n), W->stride, l);
}
/* The rates of the lanes past the last agent: 0 (their state stays its initial copy of the last agent; the
 * kernels' results there are never read, and a lane off fsmctl's pow fast path is not evaluated exactly). */
static void zero_spare_lanes(workspace *W, double *dx) {
  const int g = W->n_groups - 1, first = W->n - g * FSM_LANES;
  if (!W->lane_state || first == FSM_LANES) return;
  double *B = dx + state_group(W, g);
  for (int k = 0; k < W->stride; ++k)
    for (int l = first; l < FSM_LANES; ++l) B[FSM_LANES * k + l] = 0.0;
}
/* Where agent i's value of a lane row sits (batched kernels): lane i % FSM_LANES of row r of group i / FSM_LANES. */
static inline double *lane_slot(workspace *W, int r, int i) {
  double *G = group_block(W, i / FSM_LANES);
  return ROW(G, r) + i % FSM_LANES;
}

/* Pack the run constants (parameters, law constants, inertias) into the lane rows. */
static void pack_lane_constants(workspace *W, const fsm_problem *P) {
  for (int g = 0; g < W->n_groups; ++g) {
    double *G = group_block(W, g);
    for (int l = 0; l < FSM_LANES; ++l) {
      const int i = lane_agent(g, l, W->n);
      to_lane(ROW(G, RW_PARAMS), P->params + (size_t)W->np * i, W->np, l);
      to_lane(ROW(G, RW_CONST), W->konst + (size_t)W->nk * i, W->nk, l);
      to_lane(ROW(G, RW_J0), P->J0 + 9 * i, 9, l);
      to_lane(ROW(G, RW_UMAX), P->u_max + i, 1, l);
      to_lane(ROW(G, RW_JTRUE), P->J_true + 9 * i, 9, l);
      if (W->nw > 0) to_lane(ROW(G, RW_JSPIN), P->J_spin + 9 * i, 9, l);
    }
  }
}

/* The law's own wheel commands, when it declares them (compiled with -DFSM_LAW_WHEELS) and the scenario
 * flies reaction wheels; on an ideal actuator the law's body torque is flown and its wheel commands are unused.
 * Checks law_wheels_<model> against the problem (the control inputs, then 3 x nw axes, nw speeds, nw spin
 * inertias; nw commands out) and allocates its gather buffer and CasADi work arrays. */
static int law_wheels_setup(workspace *W, const fsm_problem *P) {
  W->law_wheels = NULL;
#ifdef FSM_LAW_WHEELS
  if (W->nw == 0) return FSM_OK;
  const int ex = P->error_model == 1;
  casadi_sparsity_fn win = ex ? law_wheels_exact_sparsity_in : law_wheels_paper_sparsity_in;
  casadi_sparsity_fn cin = ex ? law_control_exact_sparsity_in : law_control_paper_sparsity_in;
  if ((ex ? law_wheels_exact_n_in() : law_wheels_paper_n_in()) != N_CONTROL_IN + 3) return FSM_BAD_PROBLEM;
  if ((ex ? law_wheels_exact_n_out() : law_wheels_paper_n_out()) != 1) return FSM_BAD_PROBLEM;
  for (int a = 0; a < N_CONTROL_IN; ++a)
    if (sparsity_nnz(win(a)) != sparsity_nnz(cin(a))) return FSM_BAD_PROBLEM;
  if (sparsity_nnz(win(N_CONTROL_IN)) != 3 * W->nw || sparsity_nnz(win(N_CONTROL_IN + 1)) != W->nw ||
      sparsity_nnz(win(N_CONTROL_IN + 2)) != W->nw)
    return FSM_BAD_PROBLEM;
  if (sparsity_nnz((ex ? law_wheels_exact_sparsity_out : law_wheels_paper_sparsity_out)(0)) != W->nw)
    return FSM_BAD_PROBLEM;
  casadi_int a, r, iw, w;
  (ex ? law_wheels_exact_work : law_wheels_paper_work)(&a, &r, &iw, &w);
  W->lw_in = calloc((size_t)W->nc + (size_t)W->nb + (size_t)w + 1, sizeof(double));
  W->lw_iw = calloc((size_t)iw + 1, sizeof(casadi_int));
  if (!W->lw_in || !W->lw_iw) return FSM_NOMEM;
  W->lw_w = W->lw_in + W->nc + W->nb;
  W->law_wheels = ex ? law_wheels_exact : law_wheels_paper;
#endif
  return FSM_OK;
}

/* The workspace of one problem; integrating (fsm_simulate, not fsm_rhs) with RK4 on batched kernels without wheels
 * or sensors, the state lives in lane rows (lane_state). */
static int alloc_workspace(workspace *W, const fsm_problem *P, int integrating) {
  memset(W, 0, sizeof(*W));
  int n = P->n_agents, nk = 0, nc = 0;
  if (!law_contract_ok(P, &nk, &nc)) return FSM_BAD_PROBLEM;
  W->n = n;
  W->members = P->n_members > 1 ? P->n_members : 1;
  W->nz = P->n_states;
  W->nb = P->n_broadcast;
  W->np = P->n_params;
  W->nk = nk;
  W->nc = nc;
  W->nw = P->n_wheels;
  W->stride = 6 + P->n_states + P->n_wheels;
  W->n_state = 3 + (size_t)W->stride * n;
  W->xa = calloc((size_t)W->stride, sizeof(double));
  if (!W->xa) return FSM_NOMEM;
  W->local = P->error_model == 1 ? law_local_exact : law_local_paper;
  W->control = P->error_model == 1 ? law_control_exact : law_control_paper;
  W->error_state = P->error_model == 1 ? error_state_exact : error_state_paper;
  /* one block for all per-agent doubles */
  size_t N = (size_t)n, L = (size_t)P->n_links, nb = (size_t)W->nb, nz = (size_t)W->nz;
  size_t total = N * (nb * 2 + (size_t)nc + (size_t)nk + 2 + 3 * 6 + nz * 2) + L * 7;
  double *block = calloc(total > 0 ? total : 1, sizeof(double));
  if (!block) return FSM_NOMEM;
  double *p = block;
  W->b = p; p += N * nb;
  W->cache = p; p += N * (size_t)nc;
  W->konst = p; p += N * (size_t)nk;
  W->recv = p; p += N * nb;
  W->ksum = p; p += N;
  W->krs = p; p += N;
  W->u = p; p += 3 * N;
  W->uu = p; p += 3 * N;
  W->u_hold = p; p += 3 * N;
  W->uu_hold = p; p += 3 * N;
  W->d = p; p += 3 * N;
  W->tau = p; p += 3 * N;
  W->zdot = p; p += N * nz;
  W->zdot_hold = p; p += N * nz;
  W->k_val = p; p += L;
  W->k_base = p; p += L;
  W->k_lo = p; p += L;
  W->k_hi = p; p += L;
  W->k_flo = p; p += L;
  W->k_fhi = p; p += L;
  W->k_now = p; p += L;
  for (size_t e = 0; e < L; ++e) { /* empty: forces evaluation */
    W->k_lo[e] = W->k_flo[e] = INFINITY;
    W->k_hi[e] = W->k_fhi[e] = -INFINITY;
  }
  W->in_start = calloc(N + 1, sizeof(int));
  W->in_links = calloc(L > 0 ? L : 1, sizeof(int));
  W->act_start = calloc(N + 1, sizeof(int));
  W->act_src = calloc(L > 0 ? L : 1, sizeof(int));
  W->act_k = calloc(L > 0 ? L : 1, sizeof(double));
  W->d_src = calloc(N > 0 ? N : 1, sizeof(int));
  if (!W->in_start || !W->in_links || !W->act_start || !W->act_src || !W->act_k || !W->d_src) {
    free_workspace(W);
    return FSM_NOMEM;
  }
  { /* agents with the same disturbance (e.g. runs of one formation flown together) share its evaluation */
    int distinct[256], n_distinct = 0;
    for (size_t i = 0; i < N; ++i) {
      W->d_src[i] = (int)i;
      for (int m = 0; m < n_distinct; ++m)
        if (memcmp(P->dist_params + 12 * i, P->dist_params + 12 * (size_t)distinct[m], 12 * sizeof(double)) == 0) {
          W->d_src[i] = distinct[m];
          break;
        }
      if (W->d_src[i] == (int)i && n_distinct < 256) distinct[n_distinct++] = (int)i;
    }
  }
  for (size_t e = 0; e < L; ++e) W->in_start[P->link_receiver[e] + 1]++;
  for (size_t i = 0; i < N; ++i) W->in_start[i + 1] += W->in_start[i];
  {
    int *fill = calloc(N > 0 ? N : 1, sizeof(int));
    if (!fill) { free_workspace(W); return FSM_NOMEM; }
    for (size_t e = 0; e < L; ++e) {
      const int i = P->link_receiver[e];
      W->in_links[W->in_start[i] + fill[i]++] = (int)e;
    }
    free(fill);
  }
  { /* flight hardware */
    size_t nw = (size_t)W->nw;
    int max_delay = 0;
    if (P->links_imperfect)
      for (size_t e = 0; e < L; ++e) max_delay = P->link_delay[e] > max_delay ? P->link_delay[e] : max_delay;
    W->hist_len = max_delay + 1;
    size_t hist = P->links_imperfect ? (size_t)W->hist_len * N * nb + N * nb + L * nb : 0;
    size_t hw_total = N * (nw * 4 + 2 + 3 * 3) + (P->sensors ? 6 * N : 0) + hist;
    W->hw = calloc(hw_total > 0 ? hw_total : 1, sizeof(double));
    W->gated = calloc(N > 0 ? N : 1, sizeof(int));
    if (!W->hw || !W->gated) { free_workspace(W); return FSM_NOMEM; }
    double *h = W->hw;
    W->uw = h; h += N * nw;
    W->uw_hold = h; h += N * nw;
    W->u_motor = h; h += N * nw;
    W->u_net = h; h += N * nw;
    W->wscale = h; h += N;
    W->wscale_hold = h; h += N;
    W->h_w = h; h += 3 * N;
    W->tau_w = h; h += 3 * N;
    W->u_body = h; h += 3 * N;
    if (P->sensors) {
      W->sig_meas = h; h += 3 * N;
      W->om_meas = h; h += 3 * N;
    }
    if (P->links_imperfect) {
      W->b_hist = h; h += (size_t)W->hist_len * N * nb;
      W->b_first = h; h += N * nb;
      W->link_val = h; h += L * nb;
    }
    W->uw_apply = W->uw;
    W->wscale_apply = W->wscale;
  }
  W->b_tx = W->b;
  if (P->trigger_every > 0) { /* event-triggered communication */
    if (!trigger_contract_ok(P, nk)) { free_workspace(W); return FSM_BAD_PROBLEM; }
    const size_t H = P->links_imperfect ? (size_t)W->hist_len : 0;
    W->b_sent = calloc(N * nb > 0 ? N * nb : 1, sizeof(double));
    W->sent_now = calloc(N + H * N, 1);
    W->streak = calloc(2 * N, sizeof(long long));
    if (!W->b_sent || !W->sent_now || !W->streak) { free_workspace(W); return FSM_NOMEM; }
    W->sent_hist = P->links_imperfect ? W->sent_now + N : NULL;
    W->since_out = W->streak + N;
    W->b_tx = W->b_sent;
  }
  /* CasADi work arrays: the largest need of the functions used */
  casadi_work_fn works[] = {plant_rhs_work,         law_local_paper_work,   law_local_exact_work,
                            law_control_paper_work, law_control_exact_work, law_constants_work,
                            reference_rhs_work,     disturbance_torque_work, mrp_shadow_work,
                            error_state_paper_work, error_state_exact_work, gyrostat_rhs_work,
                            wheel_torque_work,      wheel_acceleration_work, sensor_measurement_work,
                            wheel_net_torque_work};
  casadi_int max_iw = 1, max_w = 1;
  for (size_t k = 0; k < sizeof(works) / sizeof(works[0]); ++k) {
    casadi_int a, r, iw, w;
    works[k](&a, &r, &iw, &w);
    if (iw > max_iw) max_iw = iw;
    if (w > max_w) max_w = w;
  }
#ifdef FSM_LAW_TRIGGER
  {
    casadi_int a, r, iw, w;
    law_trigger_work(&a, &r, &iw, &w);
    if (iw > max_iw) max_iw = iw;
    if (w > max_w) max_w = w;
  }
#endif
  W->batched = P->kernels == FSM_KERNELS_BATCHED || (P->kernels == FSM_KERNELS_AUTO && fsm_batched_preferred());
  if (P->controller) { /* an external controller, agent by agent */
    const size_t L = P->n_links > 0 ? (size_t)P->n_links : 1;
    W->batched = 0;
    W->ext_k_own = calloc(2 * L, sizeof(double));
    W->ext_received = calloc(L, sizeof(const double *));
    if (!W->ext_k_own || !W->ext_received) { free_workspace(W); return FSM_NOMEM; }
    W->ext_k_sender = W->ext_k_own + L;
  }
  if (W->batched && !fsm_batched_available()) { free_workspace(W); return FSM_BAD_PROBLEM; }
  if (W->batched) {
    lane_rows(W);
    W->local_x = P->error_model == 1 ? law_local_exact_batched : law_local_paper_batched;
    W->control_x = P->error_model == 1 ? law_control_exact_batched : law_control_paper_batched;
    W->n_groups = (n + FSM_LANES - 1) / FSM_LANES;
    W->lanes = calloc_lines((size_t)W->n_groups * W->row[RW_END] * FSM_LANES, &W->lanes_raw);
    if (!W->lanes) { free_workspace(W); return FSM_NOMEM; }
    W->b_in_lanes = !P->links_imperfect && P->trigger_every <= 0; /* the links carry this evaluation's b */
    /* the slots of the neighbour sums by lane: per group as many as its lanes' largest in-degree (at most L in all) */
    const int G = W->n_groups;
    W->slot_base = calloc(2 * (size_t)G + 1, sizeof(int));
    W->slot_deg = calloc((size_t)G * FSM_LANES, sizeof(long long));
    if (!W->slot_base || !W->slot_deg) { free_workspace(W); return FSM_NOMEM; }
    W->slot_n = W->slot_base + G + 1;
    for (int g = 0; g < G; ++g) {
      int most = 0;
      for (int l = 0; l < FSM_LANES; ++l) {
        const int i = lane_agent(g, l, n), deg = W->in_start[i + 1] - W->in_start[i];
        most = deg > most ? deg : most;
      }
      W->slot_base[g + 1] = W->slot_base[g] + most;
    }
    const size_t slots = (size_t)W->slot_base[G] * FSM_LANES;
    W->slot_src = calloc(slots > 0 ? slots : 1, sizeof(int));
    W->slot_k = calloc(slots > 0 ? slots : 1, sizeof(double));
    if (!W->slot_src || !W->slot_k) { free_workspace(W); return FSM_NOMEM; }
    if (integrating && W->nw == 0 && !P->sensors && P->integrator != 1) { /* RK4 on the state in lane rows */
      W->lane_state = 1;
      W->state_block = (size_t)(6 + W->nz) * FSM_LANES;
      W->n_state = FSM_LANES + (size_t)W->n_groups * W->state_block;
    }
  }
  W->iw = calloc((size_t)max_iw, sizeof(casadi_int));
  W->w = calloc((size_t)max_w, sizeof(double));
  if (!W->iw || !W->w) { free_workspace(W); return FSM_NOMEM; }
  for (int i = 0; i < n; ++i) { /* per-agent constants of the law */
    const double *arg[1] = {P->params + (size_t)W->np * i};
    double *res[1] = {W->konst + (size_t)nk * i};
    law_constants(arg, res, W->iw, W->w, 0);
  }
  if (W->batched) {
    pack_lane_constants(W, P);
    W->law_args = malloc(sizeof(const double *) * (size_t)W->n_groups * N_CONTROL_IN);
    if (!W->law_args) { free_workspace(W); return FSM_NOMEM; }
    for (int g = 0; g < W->n_groups; ++g)
      for (int a = 0; a < N_CONTROL_IN; ++a)
        W->law_args[g * N_CONTROL_IN + a] = law_row(W, group_block(W, g), NULL, RW_T + a);
  }
  if (W->batched) { /* disturbance lanes: the agents with distinct parameters, packed once */
    for (int i = 0; i < n; ++i) W->n_ddistinct += W->d_src[i] == i;
    W->d_rows = W->n_ddistinct == n;
    W->n_dgroups = (W->n_ddistinct + FSM_LANES - 1) / FSM_LANES;
    const size_t slots = (size_t)W->n_dgroups * FSM_LANES;
    W->dl = calloc_lines(slots * DL_END, &W->dl_raw);
    W->d_lane = calloc(slots > 0 ? slots : 1, sizeof(int));
    if (!W->dl || !W->d_lane) { free_workspace(W); return FSM_NOMEM; }
    size_t m = 0;
    for (int i = 0; i < n; ++i)
      if (W->d_src[i] == i) W->d_lane[m++] = i;
    for (; m < slots; ++m) W->d_lane[m] = W->d_lane[W->n_ddistinct - 1]; /* lanes past the last repeat it */
    for (int g = 0; g < W->n_dgroups; ++g)
      for (int l = 0; l < FSM_LANES; ++l)
        to_lane(W->dl + (size_t)g * DL_END * FSM_LANES + FSM_LANES * DL_PAR,
                P->dist_params + 12 * (size_t)W->d_lane[g * FSM_LANES + l], 12, l);
  }
  if (W->batched && W->nw > 0) { /* wheel lanes: the constant rows are packed once */
    const int total = n * W->nw;
    W->n_wgroups = (total + FSM_LANES - 1) / FSM_LANES;
    const size_t slots = (size_t)W->n_wgroups * FSM_LANES;
    W->wl = calloc_lines(slots * WL_END, &W->wl_raw);
    W->wheel_lane = calloc(slots, sizeof(int));
    W->wheel_x = calloc(slots, sizeof(size_t));
    W->wheel_wd = calloc(slots, sizeof(size_t));
    if (!W->wl || !W->wheel_lane || !W->wheel_x || !W->wheel_wd) { free_workspace(W); return FSM_NOMEM; }
    for (int g = 0; g < W->n_wgroups; ++g) {
      double *L = W->wl + (size_t)g * WL_END * FSM_LANES;
      for (int l = 0; l < FSM_LANES; ++l) {
        const int m = g * FSM_LANES + l < total ? g * FSM_LANES + l : total - 1;
        const int i = m / W->nw, k = m % W->nw;
        W->wheel_lane[g * FSM_LANES + l] = m;
        W->wheel_x[g * FSM_LANES + l] = 3 + (size_t)W->stride * i + 6 + W->nz + k;
        W->wheel_wd[g * FSM_LANES + l] = 6 + (size_t)W->stride * i;
        to_lane(L + FSM_LANES * WL_PAR, P->wheel_params + 4 * (size_t)m, 4, l);
        to_lane(L + FSM_LANES * WL_G, P->wheel_axes + 3 * (size_t)m, 3, l);
        to_lane(L + FSM_LANES * WL_JS, P->wheel_Js + m, 1, l);
      }
    }
  }
  {
    const int rc = law_wheels_setup(W, P);
    if (rc != FSM_OK) { free_workspace(W); return rc; }
  }
  W->u_apply = W->u;
  W->uu_apply = W->uu;
  W->zdot_apply = W->zdot;
  W->bad_agent = -2;
  W->bad_time = NAN;
  W->bad_rc = FSM_NONFINITE_CONTROL;
  return FSM_OK;
}

/* k^j_ij(t) of link e: piecewise constant, optionally periodic.  The cache keeps the period
 * start `base` and the segment bounds; a cached answer is used only when the same arithmetic as a
 * fresh evaluation (r = t + phase - base compared with the breakpoints) confirms it, so caching
 * never changes a result, even at a switching instant. */
static double link_weight(workspace *W, const fsm_problem *P, int e, double t) {
  const double period = P->sched_period[e];
  const double tau = t + P->sched_phase[e];
  if (W) {
    double r = tau - W->k_base[e];
    if (r >= W->k_flo[e] && r < W->k_fhi[e]) return W->k_val[e]; /* inside the segment, away from its period's ends */
    if (r >= W->k_lo[e] && r < W->k_hi[e] && (period <= 0 || floor(tau / period) * period == W->k_base[e]))
      return W->k_val[e];
  }
  int start = P->sched_start[e], count = P->sched_count[e];
  const double *b = P->sched_times + start, *v = P->sched_values + start;
  double base = period > 0 ? floor(tau / period) * period : 0.0;
  double r = tau - base;
  int m = 0;
  while (m + 1 < count && r >= b[m + 1]) ++m;
  if (W) {
    W->k_val[e] = v[m];
    W->k_base[e] = base;
    W->k_lo[e] = m == 0 ? -INFINITY : b[m];
    W->k_hi[e] = m + 1 < count ? b[m + 1] : INFINITY;
    /* Where the period check cannot fail: base = fl(k period) with k = floor(tau / period), and for r at least mg
     * away from both ends of the period, tau / period = k + r / period to within |tau| / period * 3e-16, so the
     * floor is k again and floor(tau / period) * period == base.  mg leaves a factor 3000 on that rounding. */
    const double mg = period > 0 ? 1e-12 * (fabs(tau) + period) : 0.0;
    W->k_flo[e] = period > 0 ? fmax(W->k_lo[e], mg) : W->k_lo[e];
    W->k_fhi[e] = period > 0 ? fmin(W->k_hi[e], period - mg) : W->k_hi[e];
  }
  return v[m];
}

double fsm_link_weight(const fsm_problem *P, int e, double t) { return link_weight(NULL, P, e, t); }

/* The link times [k_win_lo, k_win_hi) from t_link on where link_weight's first check (r in [k_flo, k_fhi): its
 * cached value) passes for every link, so that no weight can differ from k_now: r = (t + phase) - base is
 * non-decreasing in t, so a check that passes at t_link passes up to where r reaches k_fhi, which lies past
 * k_fhi + base - phase less a margin far above the rounding of r.  Empty when a check fails at t_link. */
static void link_window(workspace *W, const fsm_problem *P, double t_link) {
  double hi = INFINITY;
  for (int e = 0; e < P->n_links; ++e) {
    const double phase = P->sched_phase[e], r = t_link + phase - W->k_base[e];
    if (!(r >= W->k_flo[e] && r < W->k_fhi[e])) {
      hi = -INFINITY;
      break;
    }
    if (isinf(W->k_fhi[e])) continue;
    const double margin = 1e-12 * (fabs(t_link) + fabs(phase) + fabs(W->k_base[e]) + fabs(W->k_fhi[e]) + 1.0);
    hi = fmin(hi, W->k_fhi[e] + W->k_base[e] - phase - margin);
  }
  W->k_win_lo = t_link;
  W->k_win_hi = hi;
}

/* The active links (act_*) by receiver lane, for the neighbour sums of the batched kernels (aggregate_lanes): group
 * g's slot m holds lane l's m-th active link (lanes past the last agent repeat it), for m up to the group's largest
 * number of active links; a lane with fewer has source 0 and weight 0 there, and slot_deg masks them out. */
static void lane_links(workspace *W) {
  for (int g = 0; g < W->n_groups; ++g) {
    int most = 0;
    for (int l = 0; l < FSM_LANES; ++l) {
      const int i = lane_agent(g, l, W->n), first = W->act_start[i], deg = W->act_start[i + 1] - first;
      W->slot_deg[g * FSM_LANES + l] = deg;
      most = deg > most ? deg : most;
      for (int m = 0; m < W->slot_base[g + 1] - W->slot_base[g]; ++m) {
        const size_t at = ((size_t)W->slot_base[g] + m) * FSM_LANES + l;
        W->slot_src[at] = m < deg ? W->act_src[first + m] : 0;
        W->slot_k[at] = m < deg ? W->act_k[first + m] : 0.0;
      }
    }
    W->slot_n[g] = most;
  }
}

/* The neighbour aggregation (eq 19 for any broadcast b), the one place it is written: with the link weights
 * k^j_ij(t_link) (cached per t_link: the four RK4 stages of a step share them),
 * received_i = sum_j k^j_ij b_j, k_sum_i = sum_j k^i_ij, k_received_sum_i = sum_j k^j_ij, into recv, ksum, krs, or
 * with the batched kernels into the lane rows RW_RECV, RW_KSUM, RW_KRS (lanes past the last agent repeat it;
 * ksum and krs also agent by agent, recv not: aggregate_lanes sums a lane per receiver, the same operations). */
static void link_weights(workspace *W, const fsm_problem *P, double t_link) {
  const int n = W->n, nb = W->nb;
  if (W->k_valid && t_link >= W->k_win_lo && t_link < W->k_win_hi) { /* no link's weight differs from k_now */
    W->k_time = t_link;
    return;
  }
  if (!W->k_valid || W->k_time != t_link) {
    int changed = !W->k_valid;
    for (int e = 0; e < P->n_links; ++e) {
      const double k = link_weight(W, P, e, t_link);
      if (memcmp(&k, W->k_now + e, sizeof k) != 0) changed = 1;
      W->k_now[e] = k;
    }
    W->k_time = t_link;
    W->k_valid = 1;
    link_window(W, P, t_link);
    if (changed) { /* the sums over each receiver's links, in link order (the weights rarely change) */
      int c = 0;
      for (int i = 0; i < n; ++i) {
        double ks = 0.0, kr = 0.0;
        W->act_start[i] = c;
        for (int m = W->in_start[i]; m < W->in_start[i + 1]; ++m) {
          const int e = W->in_links[m];
          ks += P->link_k_i[e];
          kr += W->k_now[e];
          if (W->k_now[e] != 0.0) { /* the active links: a link switched off adds nothing, not even 0 * b */
            W->act_k[c] = W->k_now[e];
            W->act_src[c++] = W->b_in_lanes ? (int)(lane_slot(W, RW_B, P->link_sender[e]) - W->lanes)
                                            : nb * (P->links_imperfect ? e : P->link_sender[e]);
          }
        }
        W->ksum[i] = ks;
        W->krs[i] = kr;
      }
      W->act_start[n] = c;
      if (W->batched) lane_links(W);
      if (W->batched)
        for (int i = 0; i < W->n_groups * FSM_LANES; ++i) {
          const int a = i < n ? i : n - 1; /* lanes past the last agent repeat it */
          *lane_slot(W, RW_KSUM, i) = W->ksum[a];
          *lane_slot(W, RW_KRS, i) = W->krs[a];
        }
    }
  }
}

#ifdef __GNUC__
/* p[ix[l]] in lane l (lane by lane: measured as fast as AVX-512's gather in aggregate_lanes) */
static inline fsm_pow_v gather_lanes(const double *p, const int *ix) {
  fsm_pow_v v;
  for (int l = 0; l < FSM_LANES; ++l) v[l] = p[ix[l]];
  return v;
}

/* aggregate's sums for the batched kernels, FSM_LANES receivers at once, straight into the lane rows RW_RECV: lane l
 * of group g adds its m-th active link at slot m (lane_links), so each lane performs the very operations of the
 * receiver-by-receiver loop, 0 + k b_1 + k b_2 + ... in link order (a lane with fewer links keeps its sum: masked,
 * never + 0 k b), and every sum has the same bits. */
static void aggregate_lanes(workspace *W, const double *src, int st) {
  const int nb = W->nb;
  for (int g = 0; g < W->n_groups; ++g) {
    double *R = ROW(group_block(W, g), RW_RECV);
    fsm_pow_m deg;
    memcpy(&deg, W->slot_deg + (size_t)g * FSM_LANES, sizeof deg);
    for (int k0 = 0; k0 < nb; k0 += 3) { /* components k0, k1, k2: three independent chains of sums */
      const int k1 = k0 + 1 < nb ? k0 + 1 : k0, k2 = k0 + 2 < nb ? k0 + 2 : k0; /* past nb: k0's again, not stored */
      const int *ix = W->slot_src + (size_t)W->slot_base[g] * FSM_LANES;
      const double *kp = W->slot_k + (size_t)W->slot_base[g] * FSM_LANES;
      fsm_pow_v a0 = fsm_pow_splat(0.0), a1 = a0, a2 = a0;
      for (int m = 0; m < W->slot_n[g]; ++m, ix += FSM_LANES, kp += FSM_LANES) {
        const fsm_pow_m on = deg > (long long)m; /* the lanes with an m-th active link */
        fsm_pow_v kj;
        memcpy(&kj, kp, sizeof kj);
        const fsm_pow_v s0 = a0 + kj * gather_lanes(src + (size_t)k0 * st, ix),
                        s1 = a1 + kj * gather_lanes(src + (size_t)k1 * st, ix),
                        s2 = a2 + kj * gather_lanes(src + (size_t)k2 * st, ix);
        a0 = (fsm_pow_v)(((fsm_pow_m)s0 & on) | ((fsm_pow_m)a0 & ~on));
        a1 = (fsm_pow_v)(((fsm_pow_m)s1 & on) | ((fsm_pow_m)a1 & ~on));
        a2 = (fsm_pow_v)(((fsm_pow_m)s2 & on) | ((fsm_pow_m)a2 & ~on));
      }
      memcpy(R + FSM_LANES * k0, &a0, sizeof a0);
      if (k1 > k0) memcpy(R + FSM_LANES * k1, &a1, sizeof a1);
      if (k2 > k0) memcpy(R + FSM_LANES * k2, &a2, sizeof a2);
    }
  }
}
#endif

static void aggregate(workspace *W, const fsm_problem *P, double t_link) {
  const int n = W->n, nb = W->nb;
  link_weights(W, P, t_link);
  /* b_tx: b, or b_sent when event-triggered; or b_j's lane in the rows RW_B (component stride FSM_LANES) */
  const double *src = W->b_in_lanes ? W->lanes : P->links_imperfect ? W->link_val : W->b_tx;
  const int st = W->b_in_lanes ? FSM_LANES : 1;
#ifdef __GNUC__
  if (W->batched) { /* the same sums, a lane per receiver (the kernels read them from the rows; recv is not used) */
    aggregate_lanes(W, src, st);
    return;
  }
#endif
  /* Receiver by receiver, its active links in link order: the same sums 0 + k b_1 + k b_2 + ... as adding link by
   * link into recv, with the partial sums in registers (no store-to-load chain through memory). */
  for (int i = 0; i < n; ++i) {
    double *ri = W->recv + (size_t)nb * i;
    if (nb == 3) {
      double a0 = 0.0, a1 = 0.0, a2 = 0.0;
      for (int m = W->act_start[i]; m < W->act_start[i + 1]; ++m) {
        const double kj = W->act_k[m], *bj = src + W->act_src[m];
        a0 += kj * bj[0];
        a1 += kj * bj[st];
        a2 += kj * bj[2 * st];
      }
      ri[0] = a0, ri[1] = a1, ri[2] = a2;
      continue;
    }
    for (int k = 0; k < nb; ++k) ri[k] = 0.0;
    for (int m = W->act_start[i]; m < W->act_start[i + 1]; ++m) {
      const double kj = W->act_k[m], *bj = src + W->act_src[m];
      for (int k = 0; k < nb; ++k) ri[k] += kj * bj[k * st];
    }
  }
  if (W->batched) /* the sums into the lane rows RW_RECV (lanes past the last agent repeat it) */
    for (int g = 0; g < W->n_groups; ++g) {
      const double *rl[FSM_LANES];
      for (int l = 0; l < FSM_LANES; ++l) rl[l] = W->recv + (size_t)nb * lane_agent(g, l, n);
      to_rows(ROW(group_block(W, g), RW_RECV), rl, nb);
    }
}

/* The commanded torques just computed must be finite. */
static void check_commands(workspace *W, double t) {
  for (int i = 0; i < W->n; ++i) {
    const double *uu = W->uu + 3 * i;
    /* A non-finite command (e.g. the Remark 6 term alpha|sigma_e|^(alpha-1) times 0 at sigma_e = 0 with
     * singularity_fix = none) must not pass silently: the limit would turn NaN into -u_max.  Flag it; the
     * loops stop with FSM_NONFINITE_CONTROL. */
    if (W->bad_agent == -2 && !(isfinite(uu[0]) && isfinite(uu[1]) && isfinite(uu[2]))) {
      W->bad_agent = i;
      W->bad_time = t;
    }
  }
}

/* What the law sees at control instant W->q: the generated sensor_measurement of the true state with that
 * instant's noise (the truth when sensors are off). */
static void measure(workspace *W, const fsm_problem *P, const double *x) {
  const int n = W->n, S = W->stride;
  for (int i = 0; i < n; ++i) {
    const double *xi = x + 3 + (size_t)S * i;
    const size_t o = ((size_t)W->q * n + i) * 3;
    const double *arg[4] = {xi, xi + 3, P->sensor_dtheta + o, P->sensor_gyro + o};
    double *res[2] = {W->sig_meas + 3 * i, W->om_meas + 3 * i};
    sensor_measurement(arg, res, W->iw, W->w, 0);
  }
}

/* The links at control instant W->q (after every agent computed its broadcast W->b): record the broadcasts,
 * then each link delivers the sender's broadcast of instant q - delay (before instant 0: of instant 0), unless
 * its packet of instant q is lost; the receiver keeps the value it last received.  Event-triggered
 * (W->sent_hist): the broadcasts recorded are those sent (b_sent), and a link delivers only the message its sender
 * sent at instant q - delay (none before instant 0: the link holds the instant-0 value from the start). */
static void deliver_links(workspace *W, const fsm_problem *P) {
  const int n = W->n, nb = W->nb, H = W->hist_len;
  const long long q = W->q;
  const size_t row = (size_t)n * nb;
  memcpy(W->b_hist + (size_t)(q % H) * row, W->b_tx, sizeof(double) * row);
  if (W->sent_hist) memcpy(W->sent_hist + (size_t)(q % H) * n, W->sent_now, (size_t)n);
  if (q == 0) {
    memcpy(W->b_first, W->b_tx, sizeof(double) * row);
    for (int e = 0; e < P->n_links; ++e)
      memcpy(W->link_val + (size_t)nb * e, W->b_first + (size_t)nb * P->link_sender[e], sizeof(double) * nb);
  }
  for (int e = 0; e < P->n_links; ++e) {
    if (P->link_lost[(size_t)q * P->n_links + e]) continue;
    const long long from = q - P->link_delay[e];
    if (W->sent_hist) { /* event-triggered: only a message sent at instant q - delay arrives now */
      if (from < 0 || !W->sent_hist[(size_t)(from % H) * n + P->link_sender[e]]) continue;
      if (W->out) W->out->messages_delivered[e]++;
    }
    const double *src = from >= 0 ? W->b_hist + (size_t)(from % H) * row : W->b_first;
    memcpy(W->link_val + (size_t)nb * e, src + (size_t)nb * P->link_sender[e], sizeof(double) * nb);
  }
}

/* Event-triggered communication at control instant W->q (after every agent computed its broadcast W->b), the one
 * place the rule is written (tests/oracle_numpy.py transcribes it): at a check instant (q a multiple of
 * trigger_every) agent i sends when law_trigger(t, b_i, b_sent_i, params_i, constants_i) > 0, and always at instant
 * 0; a message sets b_sent_i = b_i, which the links carry until the next one.  Counts the messages (per agent, per
 * link with ideal links: deliver_links counts them with imperfect ones), their times and, per agent, the checks in a
 * row with a message: zeno_checks of them stop the run (FSM_ZENO). */
static void event_trigger(workspace *W, const fsm_problem *P, double t) {
  const int n = W->n, nb = W->nb;
  const long long q = W->q;
  memset(W->sent_now, 0, (size_t)n);
  if (q % P->trigger_every != 0) return;
  for (int i = 0; i < n; ++i) {
    const double *bi = W->b + (size_t)nb * i;
    double *si = W->b_sent + (size_t)nb * i;
    int fire = q == 0;
#ifdef FSM_LAW_TRIGGER
    if (!fire) {
      double margin = 0.0;
      const double *arg[5] = {&t, bi, si, P->params + (size_t)W->np * i, W->konst + (size_t)W->nk * i};
      double *res[1] = {&margin};
      law_trigger(arg, res, W->iw, W->w, 0);
      fire = margin > 0.0;
    }
#endif
    W->streak[i] = fire ? W->streak[i] + 1 : 0;
    if (!fire) continue;
    memcpy(si, bi, sizeof(double) * nb);
    W->sent_now[i] = 1;
    fsm_output *O = W->out;
    if (O) {
      if (O->messages_sent[i] > 0) {
        const double gap = t - O->last_event[i];
        if (gap < O->min_inter_event[i]) O->min_inter_event[i] = gap;
      } else {
        O->first_event[i] = t;
      }
      O->last_event[i] = t;
      O->messages_sent[i]++;
      W->since_out[i]++;
    }
    if (P->zeno_checks > 0 && W->streak[i] >= P->zeno_checks && W->bad_agent == -2) {
      W->bad_agent = i;
      W->bad_time = t;
      W->bad_rc = FSM_ZENO;
    }
  }
  if (W->out && !P->links_imperfect)
    for (int e = 0; e < P->n_links; ++e)
      if (W->sent_now[P->link_sender[e]]) W->out->messages_delivered[e]++;
}

/* The per-wheel motor torque commands of a law that commands its wheels, law_wheels_<model>, into uw
 * (n x nw), for every agent at (t, x): the inputs of law_control (the law sees the measurements when sensed; the
 * batched kernels left the cache and the received sum in the lane rows) and the agent's wheel axes, speeds
 * Omega (true, from x) and spin inertias. */
static void law_wheel_commands(workspace *W, const fsm_problem *P, double t, const double *x, int sensed) {
  const int n = W->n, nw = W->nw, nb = W->nb, nc = W->nc, S = W->stride;
  for (int i = 0; i < n; ++i) {
    const double *xi = x + 3 + (size_t)S * i;
    const double *si = sensed ? W->sig_meas + 3 * i : xi, *wi = sensed ? W->om_meas + 3 * i : xi + 3;
    const double *cache = W->cache + (size_t)nc * i, *recv = W->recv + (size_t)nb * i;
    if (W->batched) {
      from_lane(W->lw_in, lane_slot(W, RW_CACHE, i), nc, 0);
      from_lane(W->lw_in + nc, lane_slot(W, RW_RECV, i), nb, 0);
      cache = W->lw_in;
      recv = W->lw_in + nc;
    }
    const size_t iw0 = (size_t)nw * i;
    const double *arg[N_CONTROL_IN + 3] = {&t, si, wi, xi + 6, x, W->wd, W->wdd, P->J0 + 9 * i,
                                           P->params + (size_t)W->np * i, W->konst + (size_t)W->nk * i, cache,
                                           W->ksum + i, recv, W->krs + i, P->u_max + i, P->wheel_axes + 3 * iw0,
                                           xi + 6 + W->nz, P->wheel_Js + iw0};
    double *res[1] = {W->uw + iw0};
    W->law_wheels(arg, res, W->lw_iw, W->lw_w, 0);
  }
}

/* The wheel commands, the one place these rules are written (fsmctl.model.actuators is their NumPy transcription):
 * minimum-norm wheel torques -pinv(G_s) u for the law's body torque u (or the law's own per-wheel commands,
 * law_wheel_commands, when the law declares them), plus the open-loop command of the current
 * control instant (wheel_command, if any), then the torque limit u_max,k:
 *   FSM_WHEEL_SCALED:  all divided by one factor max(1, max_k |u_w,k| / u_max,k), so that the body torque keeps its
 *                      direction and the most loaded wheel sits at its limit;
 *   FSM_WHEEL_CLIPPED: each clipped to [-u_max,k, u_max,k] on its own (Basilisk's ConfigureRWRequests).
 * wscale[i] is max(1, max_k |u_w,k| / u_max,k) before the limit under either rule (> 1: a wheel at its limit). */
static void wheel_commands(workspace *W, const fsm_problem *P, double t, const double *x, int sensed) {
  const int n = W->n, nw = W->nw;
  if (W->law_wheels) law_wheel_commands(W, P, t, x, sensed); /* the law's own commands in uw */
  const double *cmd = P->wheel_command ? P->wheel_command + (size_t)W->q * n * nw : NULL;
  for (int i = 0; i < n; ++i) {
    const double *u = W->u + 3 * i, *lim = P->wheel_torque_max + (size_t)nw * i;
    double *uw = W->uw + (size_t)nw * i;
    double r = 0.0;
    for (int k = 0; k < nw; ++k) {
      const double *pk = P->wheel_pinv + ((size_t)nw * i + k) * 3;
      if (!W->law_wheels) uw[k] = -(pk[0] * u[0] + pk[1] * u[1] + pk[2] * u[2]);
      if (cmd) uw[k] += cmd[(size_t)nw * i + k];
      r = fmax(r, fabs(uw[k]) / lim[k]);
    }
    const double scale = fmax(1.0, r);
    if (P->wheel_allocation == FSM_WHEEL_CLIPPED) {
      for (int k = 0; k < nw; ++k) {
        if (uw[k] > lim[k])
          uw[k] = lim[k];
        else if (uw[k] < -lim[k])
          uw[k] = -lim[k];
      }
    } else if (scale > 1.0) {
      for (int k = 0; k < nw; ++k) uw[k] /= scale;
    }
    W->wscale[i] = scale;
  }
}

/* Inner stages of a step with the speed limit decided at its start (FSM_GATE_STEP_START): the motor torques u_motor
 * stay as wheel_torques set them at the step's first stage (batched: also in the lane row WL_UM), the net torques
 * (the generated wheel_net_torque: friction at this x) and the wheels' momentum and reaction are recomputed. */
static void wheel_net_torques(workspace *W, const fsm_problem *P, const double *x) {
  const int n = W->n, nw = W->nw, S = W->stride, nz = W->nz;
  if (W->batched) {
    const int total = n * nw;
    for (int g = 0; g < W->n_wgroups; ++g) {
      double *L = W->wl + (size_t)g * WL_END * FSM_LANES;
      const int m0 = g * FSM_LANES, lanes = total - m0 < FSM_LANES ? total - m0 : FSM_LANES;
      for (int l = 0; l < FSM_LANES; ++l) L[FSM_LANES * WL_OM + l] = x[W->wheel_x[m0 + l]];
      const double *arg[3] = {L + FSM_LANES * WL_UM, L + FSM_LANES * WL_OM, L + FSM_LANES * WL_PAR};
      double *res[1] = {L + FSM_LANES * WL_UNET};
      wheel_net_torque_batched(arg, res, lanes);
      for (int l = 0; l < lanes; ++l) W->u_net[m0 + l] = L[FSM_LANES * WL_UNET + l];
    }
  }
  for (int i = 0; i < n; ++i) {
    const double *Om = x + 3 + (size_t)S * i + 6 + nz;
    double *hw = W->h_w + 3 * i, *tw = W->tau_w + 3 * i;
    hw[0] = hw[1] = hw[2] = tw[0] = tw[1] = tw[2] = 0.0;
    for (int k = 0; k < nw; ++k) {
      const size_t ik = (size_t)nw * i + k;
      const double *g = P->wheel_axes + 3 * ik;
      if (!W->batched) {
        const double *arg[3] = {W->u_motor + ik, Om + k, P->wheel_params + 4 * ik};
        double *res[1] = {W->u_net + ik};
        wheel_net_torque(arg, res, W->iw, W->w, 0);
      }
      const double hk = P->wheel_Js[ik] * Om[k], tk = W->u_net[ik];
      for (int c = 0; c < 3; ++c) {
        hw[c] += hk * g[c];
        tw[c] += tk * g[c];
      }
    }
    for (int c = 0; c < 3; ++c) W->u_body[3 * i + c] = -tw[c];
  }
}

/* The wheels' torques at state x (motor torque after the speed limit, net torque with friction: the generated
 * wheel_torque), their momentum and reaction: h_w = sum Js Omega g, tau_w = sum u_net g, u_body = -tau_w. */
static void wheel_torques(workspace *W, const fsm_problem *P, const double *x, const double *uwa) {
  const int n = W->n, nw = W->nw, S = W->stride, nz = W->nz;
  if (W->gate_held) {
    wheel_net_torques(W, P, x);
    return;
  }
  if (W->batched) { /* the generated kernel, FSM_LANES wheels per call (lanes past the last repeat it) */
    const int total = n * nw;
    for (int g = 0; g < W->n_wgroups; ++g) {
      double *L = W->wl + (size_t)g * WL_END * FSM_LANES;
      const int m0 = g * FSM_LANES, lanes = total - m0 < FSM_LANES ? total - m0 : FSM_LANES;
      for (int l = 0; l < FSM_LANES; ++l) {
        L[FSM_LANES * WL_U + l] = uwa[W->wheel_lane[m0 + l]];
        L[FSM_LANES * WL_OM + l] = x[W->wheel_x[m0 + l]];
      }
      const double *arg[3] = {L + FSM_LANES * WL_U, L + FSM_LANES * WL_OM, L + FSM_LANES * WL_PAR};
      double *res[2] = {L + FSM_LANES * WL_UM, L + FSM_LANES * WL_UNET};
      wheel_torque_batched(arg, res, lanes);
      for (int l = 0; l < lanes; ++l) {
        W->u_motor[m0 + l] = L[FSM_LANES * WL_UM + l];
        W->u_net[m0 + l] = L[FSM_LANES * WL_UNET + l];
      }
    }
  }
  for (int i = 0; i < n; ++i) {
    const double *Om = x + 3 + (size_t)S * i + 6 + nz;
    double *hw = W->h_w + 3 * i, *tw = W->tau_w + 3 * i;
    hw[0] = hw[1] = hw[2] = tw[0] = tw[1] = tw[2] = 0.0;
    W->gated[i] = 0;
    for (int k = 0; k < nw; ++k) {
      const size_t ik = (size_t)nw * i + k;
      const double *g = P->wheel_axes + 3 * ik;
      if (!W->batched) {
        const double *arg[3] = {uwa + ik, Om + k, P->wheel_params + 4 * ik};
        double *res[2] = {W->u_motor + ik, W->u_net + ik};
        wheel_torque(arg, res, W->iw, W->w, 0);
      }
      if (W->u_motor[ik] != uwa[ik]) W->gated[i] = 1;
      const double hk = P->wheel_Js[ik] * Om[k], tk = W->u_net[ik];
      for (int c = 0; c < 3; ++c) {
        hw[c] += hk * g[c];
        tw[c] += tk * g[c];
      }
    }
    for (int c = 0; c < 3; ++c) W->u_body[3 * i + c] = -tw[c];
  }
}

/* Spin accelerations of the wheels (the generated wheel_acceleration) once omega_dot is known. */
static void wheel_rates(workspace *W, const fsm_problem *P, double *dx) {
  const int n = W->n, nw = W->nw, S = W->stride, nz = W->nz;
  if (W->batched) { /* rows WL_G, WL_JS (constant) and WL_UNET (wheel_torques) are in place */
    const int total = n * nw;
    for (int g = 0; g < W->n_wgroups; ++g) {
      double *L = W->wl + (size_t)g * WL_END * FSM_LANES;
      const int m0 = g * FSM_LANES, lanes = total - m0 < FSM_LANES ? total - m0 : FSM_LANES;
      for (int l = 0; l < FSM_LANES; ++l) to_lane(L + FSM_LANES * WL_WD, dx + W->wheel_wd[m0 + l], 3, l);
      const double *arg[4] = {L + FSM_LANES * WL_G, L + FSM_LANES * WL_JS, L + FSM_LANES * WL_UNET,
                              L + FSM_LANES * WL_WD};
      double *res[1] = {L + FSM_LANES * WL_OD};
      wheel_acceleration_batched(arg, res, lanes);
      for (int l = 0; l < lanes; ++l) dx[W->wheel_x[m0 + l]] = L[FSM_LANES * WL_OD + l];
    }
    return;
  }
  for (int i = 0; i < n; ++i) {
    const double *omega_dot = dx + 6 + (size_t)S * i;
    double *Om_dot = dx + 9 + (size_t)S * i + nz;
    for (int k = 0; k < nw; ++k) {
      const size_t ik = (size_t)nw * i + k;
      const double *arg[4] = {P->wheel_axes + 3 * ik, P->wheel_Js + ik, W->u_net + ik, omega_dot};
      double *res[1] = {Om_dot + k};
      wheel_acceleration(arg, res, W->iw, W->w, 0);
    }
  }
}

/* The true state into the lane rows RW_SIGMA, RW_OMEGA of group g (after the law saw measurements there). */
static void reload_state_lanes(workspace *W, double *G, int g, const double *x) {
  const double *si[FSM_LANES], *wi[FSM_LANES];
  for (int l = 0; l < FSM_LANES; ++l) {
    si[l] = x + 3 + (size_t)W->stride * lane_agent(g, l, W->n);
    wi[l] = si[l] + 3;
  }
  to_rows(ROW(G, RW_SIGMA), si, 3);
  to_rows(ROW(G, RW_OMEGA), wi, 3);
}

/* The plant with reaction wheels: wheel torques at x (commands uwa), then the generated gyrostat_rhs with the
 * disturbance as the external torque (the control acts through the wheels). */
static void plant_with_wheels(workspace *W, const fsm_problem *P, const double *x, double *dx, const double *uwa,
                              int sensed) {
  const int n = W->n, S = W->stride;
  wheel_torques(W, P, x, uwa);
  for (int m = 0; m < 3 * n; ++m) W->tau[m] = W->d[m];
  if (W->batched) {
    for (int g = 0; g < W->n_groups; ++g) {
      double *G = group_block(W, g);
      for (int l = 0; l < FSM_LANES; ++l) {
        const int i = lane_agent(g, l, n);
        to_lane(ROW(G, RW_TAU), W->tau + 3 * i, 3, l);
        to_lane(ROW(G, RW_HW), W->h_w + 3 * i, 3, l);
        to_lane(ROW(G, RW_TAUW), W->tau_w + 3 * i, 3, l);
      }
      if (sensed) reload_state_lanes(W, G, g, x);
      const double *arg[7] = {ROW(G, RW_SIGMA), ROW(G, RW_OMEGA), ROW(G, RW_HW), ROW(G, RW_TAUW),
                              ROW(G, RW_TAU),   ROW(G, RW_JTRUE), ROW(G, RW_JSPIN)};
      double *res[2] = {ROW(G, RW_SIGMA_DOT), ROW(G, RW_OMEGA_DOT)};
      gyrostat_rhs_batched(arg, res, active_lanes(g, n));
      for (int l = 0; l < FSM_LANES && g * FSM_LANES + l < n; ++l) {
        const int i = g * FSM_LANES + l;
        from_lane(dx + 3 + (size_t)S * i, ROW(G, RW_SIGMA_DOT), 3, l);
        from_lane(dx + 6 + (size_t)S * i, ROW(G, RW_OMEGA_DOT), 3, l);
      }
    }
    return;
  }
  for (int i = 0; i < n; ++i) {
    const double *xi = x + 3 + (size_t)S * i;
    const double *arg[7] = {xi, xi + 3, W->h_w + 3 * i, W->tau_w + 3 * i, W->tau + 3 * i, P->J_true + 9 * i,
                            P->J_spin + 9 * i};
    double *res[2] = {dx + 3 + (size_t)S * i, dx + 6 + (size_t)S * i};
    gyrostat_rhs(arg, res, W->iw, W->w, 0);
  }
}

/* The commanded torques of the lane rows RW_UU (batched kernels), agent by agent: as check_commands. */
static void check_commands_lanes(workspace *W, double t) {
  if (W->bad_agent != -2) return;
#ifdef FSM_HAVE_BATCHED
  int any = 0; /* a whole group at once; the first agent is looked for only when one is off */
  for (int g = 0; g < W->n_groups && !any; ++g) {
    const double *uu = ROW(group_block(W, g), RW_UU);
    fsm_pow_m finite = (fsm_pow_m)fsm_pow_splat(0.0) == 0; /* every lane true */
    for (int k = 0; k < 3; ++k) {
      fsm_pow_v v;
      memcpy(&v, uu + FSM_LANES * k, sizeof v);
      finite &= (fsm_pow_v)((fsm_pow_m)v & 0x7fffffffffffffffLL) <= DBL_MAX; /* false for inf and NaN */
    }
    any = fsm_pow_any_off(finite, active_lanes(g, W->n));
  }
  if (!any) return;
#endif
  for (int i = 0; i < W->n && W->bad_agent == -2; ++i) {
    const double *uu = lane_slot(W, RW_UU, i);
    if (!(isfinite(uu[0]) && isfinite(uu[FSM_LANES]) && isfinite(uu[2 * FSM_LANES]))) {
      W->bad_agent = i;
      W->bad_time = t;
    }
  }
}

/* Formation right-hand side at (t, x).  compute_control = 0 keeps the held torque and law-state rates; 1 computes
 * the control and keeps it in u, uu, zdot (what stage_one, the records and statistics read); 2 computes it for
 * this evaluation only (the inner stages of a step: with the batched kernels and no wheels it then stays in the
 * lane rows).  The piecewise-constant link weights k^j_ij are evaluated at t_link (= t, except in the RK4 loop:
 * see simulate_rk4). */
/* Software in the loop: the external controller's two phases for every agent (what the law would compute). */
static void external_broadcast(workspace *W, const fsm_problem *P, double t, const double *x, int sensed) {
  for (int i = 0; i < W->n; ++i) {
    const double *xi = x + 3 + (size_t)W->stride * i;
    const double *si = sensed ? W->sig_meas + 3 * i : xi, *wi = sensed ? W->om_meas + 3 * i : xi + 3;
    const fsm_controller_input in = {t, si, wi, xi + 6, x, W->wd, W->wdd, 0, NULL, NULL, NULL};
    if (P->controller(P->controller_context, FSM_CONTROLLER_BROADCAST, i, &in, W->b + (size_t)W->nb * i, NULL, NULL,
                      NULL) != 0 &&
        W->bad_agent == -2) {
      W->bad_agent = i;
      W->bad_time = t;
      W->bad_rc = FSM_CONTROLLER_FAILED;
    }
  }
}

static void external_control(workspace *W, const fsm_problem *P, double t, double t_link, const double *x,
                             int sensed) {
  const int nb = W->nb;
  const double *src = P->links_imperfect ? W->link_val : W->b_tx; /* as aggregate() */
  link_weights(W, P, t_link);
  for (int i = 0; i < W->n; ++i) {
    const double *xi = x + 3 + (size_t)W->stride * i;
    const double *si = sensed ? W->sig_meas + 3 * i : xi, *wi = sensed ? W->om_meas + 3 * i : xi + 3;
    int c = 0;
    for (int m = W->in_start[i]; m < W->in_start[i + 1]; ++m, ++c) {
      const int e = W->in_links[m];
      W->ext_k_own[c] = P->link_k_i[e];
      W->ext_k_sender[c] = W->k_now[e];
      W->ext_received[c] = src + (size_t)nb * (P->links_imperfect ? e : P->link_sender[e]);
    }
    const fsm_controller_input in = {t, si, wi, xi + 6, x, W->wd, W->wdd, c, W->ext_k_own, W->ext_k_sender,
                                     W->ext_received};
    if (P->controller(P->controller_context, FSM_CONTROLLER_STEP, i, &in, NULL, W->u + 3 * i, W->uu + 3 * i,
                      W->zdot + (size_t)W->nz * i) != 0 &&
        W->bad_agent == -2) {
      W->bad_agent = i;
      W->bad_time = t;
      W->bad_rc = FSM_CONTROLLER_FAILED;
    }
  }
}

/* Every agent's broadcast b (and the cache law_control reads) at (t, x): the batched kernels group by group (their
 * state rows packed from x, or read in place with lane_state), the external controller's first phase, or the
 * scalar functions agent by agent.  compute_control as eval_rhs. */
static void law_broadcasts(workspace *W, const fsm_problem *P, double t, const double *x, int sensed,
                           int compute_control) {
  const int n = W->n, S = W->stride, nz = W->nz, nb = W->nb, nc = W->nc;
  if (W->batched) {
    for (int g = 0; g < W->n_groups; ++g) {
      double *G = group_block(W, g);
      const double *xg = lane_x(W, x, g); /* lane_state: the kernels read the state rows in place */
      if (!xg) {
        const double *si[FSM_LANES], *wi[FSM_LANES], *zi[FSM_LANES];
        for (int l = 0; l < FSM_LANES; ++l) {
          const int i = lane_agent(g, l, n);
          const double *xi = x + 3 + (size_t)S * i;
          si[l] = sensed ? W->sig_meas + 3 * i : xi; /* the law sees the measurements */
          wi[l] = sensed ? W->om_meas + 3 * i : xi + 3;
          zi[l] = xi + 6;
        }
        to_rows(ROW(G, RW_SIGMA), si, 3);
        to_rows(ROW(G, RW_OMEGA), wi, 3);
        to_rows(ROW(G, RW_Z), zi, nz);
      }
      if (!compute_control) continue; /* the rows hold x for the plant */
      const double **arg = W->law_args + (size_t)g * N_CONTROL_IN;
      arg[LI_SIGMA] = law_row(W, G, xg, RW_SIGMA); /* the state rows of this x (lane_state) or the group's */
      arg[LI_OMEGA] = law_row(W, G, xg, RW_OMEGA);
      arg[LI_Z] = law_row(W, G, xg, RW_Z);
      double *res[2] = {ROW(G, RW_B), ROW(G, RW_CACHE)};
      W->local_x(arg, res, active_lanes(g, n));
      if (W->b_in_lanes && compute_control != 1) continue; /* b_j for the records: stage one's */
      for (int l = 0; l < FSM_LANES && g * FSM_LANES + l < n; ++l)
        from_lane(W->b + (size_t)nb * (g * FSM_LANES + l), ROW(G, RW_B), nb, l); /* b_j for the links */
    }
  } else if (compute_control && P->controller) {
    external_broadcast(W, P, t, x, sensed);
  } else if (compute_control) {
    for (int i = 0; i < n; ++i) {
      const double *xi = x + 3 + (size_t)S * i;
      const double *si = sensed ? W->sig_meas + 3 * i : xi, *wi = sensed ? W->om_meas + 3 * i : xi + 3;
      const double *arg[N_LOCAL_IN] = {&t, si, wi, xi + 6, x, W->wd, W->wdd, P->J0 + 9 * i,
                                       P->params + (size_t)W->np * i, W->konst + (size_t)W->nk * i};
      double *res[2] = {W->b + (size_t)nb * i, W->cache + (size_t)nc * i};
      W->local(arg, res, W->iw, W->w, 0);
    }
  }
}

/* law_control for lane group g (batched kernels): u, uu and the law states' rates into its rows (the rates straight
 * into dx with lane_state); unless they stay in the lanes (in_lanes), also into u, uu, zdot agent by agent. */
static void control_group(workspace *W, int g, double *dx, int in_lanes) {
  double *G = group_block(W, g);
  const double *const *arg = W->law_args + (size_t)g * N_CONTROL_IN; /* state rows set by law_broadcasts */
  double *zdot = W->lane_state ? dx + state_group(W, g) + 6 * FSM_LANES : ROW(G, RW_ZDOT);
  double *res[3] = {ROW(G, RW_U), ROW(G, RW_UU), zdot};
  W->control_x(arg, res, active_lanes(g, W->n));
  if (in_lanes) return;
  for (int l = 0; l < FSM_LANES && g * FSM_LANES + l < W->n; ++l) {
    const int i = g * FSM_LANES + l;
    from_lane3(W->u + 3 * i, ROW(G, RW_U), l);
    from_lane3(W->uu + 3 * i, ROW(G, RW_UU), l);
    from_lane(W->zdot + (size_t)W->nz * i, zdot, W->nz, l);
  }
}

/* The scalar law_control agent by agent (no batched kernels, no external controller). */
static void control_agents(workspace *W, const fsm_problem *P, double t, const double *x, int sensed) {
  const int nb = W->nb, nz = W->nz, nc = W->nc;
  for (int i = 0; i < W->n; ++i) {
    const double *xi = x + 3 + (size_t)W->stride * i;
    const double *si = sensed ? W->sig_meas + 3 * i : xi, *wi = sensed ? W->om_meas + 3 * i : xi + 3;
    const double *arg[N_CONTROL_IN] = {&t, si, wi, xi + 6, x, W->wd, W->wdd, P->J0 + 9 * i,
                                       P->params + (size_t)W->np * i, W->konst + (size_t)W->nk * i,
                                       W->cache + (size_t)nc * i, W->ksum + i, W->recv + (size_t)nb * i,
                                       W->krs + i, P->u_max + i};
    double *res[3] = {W->u + 3 * i, W->uu + 3 * i, W->zdot + (size_t)nz * i};
    W->control(arg, res, W->iw, W->w, 0);
  }
}

/* d_i(t), cached by time: stage 4 of a step (t_k+1) serves stage 1 of the next, stage 2 serves stage 3.  Each
 * distinct disturbance is evaluated once (batched: FSM_LANES of them per kernel call, into the rows DL_D); agents
 * whose parameters equal an earlier agent's copy its torque. */
static void disturbances(workspace *W, const fsm_problem *P, double t) {
  const int n = W->n;
  if (W->d_valid && W->d_time == t) return;
  if (W->batched) {
    for (int g = 0; g < W->n_dgroups; ++g) {
      double *D = W->dl + (size_t)g * DL_END * FSM_LANES;
      const int lanes = active_lanes(g, W->n_ddistinct);
      const double *arg[2] = {LANE(W->common, CM_T), LANE(D, DL_PAR)};
      double *res[1] = {LANE(D, DL_D)};
      disturbance_torque_batched(arg, res, lanes);
      if (W->d_rows && W->nw == 0) continue; /* the plant reads the rows DL_D, nothing reads d */
      for (int l = 0; l < lanes; ++l) from_lane3(W->d + 3 * W->d_lane[g * FSM_LANES + l], LANE(D, DL_D), l);
    }
  } else {
    for (int i = 0; i < n; ++i) {
      if (W->d_src[i] != i) continue;
      const double *arg[2] = {&t, P->dist_params + 12 * i};
      double *res[1] = {W->d + 3 * i};
      disturbance_torque(arg, res, W->iw, W->w, 0);
    }
  }
  for (int i = 0; i < n; ++i)
    if (W->d_src[i] != i) memcpy(W->d + 3 * i, W->d + 3 * W->d_src[i], 3 * sizeof(double));
  W->d_time = t;
  W->d_valid = 1;
}

/* rows[c FSM_LANES + l] = v[3 i + c] for the agent i of lane l of group g (lanes past the last agent repeat it) */
static void gather3(double *rows, const double *v, int g, int n) {
  const double *p[FSM_LANES];
  for (int l = 0; l < FSM_LANES; ++l) p[l] = v + 3 * lane_agent(g, l, n);
  to_rows(rows, p, 3);
}

/* plant_rhs for lane group g (batched kernels, no wheels): tau = u + d lane by lane (u from the lanes when
 * in_lanes, else from ua agent by agent; d from the disturbance rows or gathered), then the attitude and rate
 * derivatives into dx (in place with lane_state, with the held law-state rates za when the control is held). */
static void plant_group(workspace *W, int g, const double *x, double *dx, const double *ua, const double *za,
                        int in_lanes, int compute_control, int sensed) {
  const int n = W->n, S = W->stride, nz = W->nz;
  double *G = group_block(W, g);
  double *tau = ROW(G, RW_TAU);
  double dgather[3 * FSM_LANES] FSM_LINE, urows[3 * FSM_LANES] FSM_LINE; /* tau_i = u_i + d_i, lane by lane */
  const double *drow = W->d_rows ? LANE(W->dl + (size_t)g * DL_END * FSM_LANES, DL_D) : dgather;
  if (!W->d_rows) gather3(dgather, W->d, g, n);
  if (!in_lanes) gather3(urows, ua, g, n); /* u from the held or computed commands, else the lanes' */
  const double *urow = in_lanes ? ROW(G, RW_U) : urows;
  for (int k = 0; k < 3 * FSM_LANES; ++k) tau[k] = urow[k] + drow[k];
  if (sensed) reload_state_lanes(W, G, g, x); /* rows RW_SIGMA, RW_OMEGA hold this x unless sensed */
  const double *xg = lane_x(W, x, g);
  const double *arg[4] = {law_row(W, G, xg, RW_SIGMA), law_row(W, G, xg, RW_OMEGA), ROW(G, RW_TAU),
                          ROW(G, RW_JTRUE)};
  if (xg) { /* lane_state: the rates straight into dx; held law-state rates into its rows */
    double *dxg = dx + state_group(W, g);
    double *res[2] = {dxg, dxg + 3 * FSM_LANES};
    plant_rhs_batched(arg, res, active_lanes(g, n));
    if (!compute_control && nz > 0) {
      const double *zl[FSM_LANES];
      for (int l = 0; l < FSM_LANES; ++l) zl[l] = za + (size_t)nz * lane_agent(g, l, n);
      to_rows(dxg + 6 * FSM_LANES, zl, nz);
    }
    return;
  }
  double *res[2] = {ROW(G, RW_SIGMA_DOT), ROW(G, RW_OMEGA_DOT)};
  plant_rhs_batched(arg, res, active_lanes(g, n));
  for (int l = 0; l < FSM_LANES && g * FSM_LANES + l < n; ++l) {
    const int i = g * FSM_LANES + l;
    from_lane3(dx + 3 + (size_t)S * i, ROW(G, RW_SIGMA_DOT), l);
    from_lane3(dx + 6 + (size_t)S * i, ROW(G, RW_OMEGA_DOT), l);
    if (in_lanes) from_lane(dx + 9 + (size_t)S * i, ROW(G, RW_ZDOT), nz, l);
  }
}

/* The scalar plant_rhs agent by agent (no batched kernels, no wheels). */
static void plant_agents(workspace *W, const fsm_problem *P, const double *x, double *dx, const double *ua) {
  const int n = W->n, S = W->stride;
  for (int m = 0; m < 3 * n; ++m) W->tau[m] = ua[m] + W->d[m];
  for (int i = 0; i < n; ++i) {
    const double *xi = x + 3 + (size_t)S * i;
    const double *arg[4] = {xi, xi + 3, W->tau + 3 * i, P->J_true + 9 * i};
    double *res[2] = {dx + 3 + (size_t)S * i, dx + 6 + (size_t)S * i};
    plant_rhs(arg, res, W->iw, W->w, 0);
  }
}

static void eval_rhs(workspace *W, const fsm_problem *P, double t, double t_link, const double *x, double *dx,
                     int compute_control) {
  const int n = W->n, S = W->stride, nz = W->nz;
  const int sensed = P->sensors && compute_control; /* the law sees measurements at this evaluation */
  /* batched, no wheels, inner stage: u, uu, zdot are read from the lane rows */
  const int in_lanes = W->batched && W->nw == 0 && compute_control == 2;
  /* batched, no wheels: each group's control, then its plant, while its rows are in the cache */
  const int fused = W->batched && W->nw == 0;
  if (sensed) measure(W, P, x);
  {
    const double *arg[3] = {&t, x, P->ref_params};
    double *res[3] = {dx, W->wd, W->wdd};
    reference_rhs(arg, res, W->iw, W->w, 0);
  }
  if (W->batched) {
    broadcast_row(LANE(W->common, CM_T), &t, 1);
    broadcast_row(LANE(W->common, CM_SD), x, 3);
    broadcast_row(LANE(W->common, CM_WD), W->wd, 3);
    broadcast_row(LANE(W->common, CM_WDD), W->wdd, 3);
  }
  law_broadcasts(W, P, t, x, sensed, compute_control);
  if (compute_control) {
    if (P->trigger_every > 0) event_trigger(W, P, t); /* what the agents send (b_sent) */
    if (P->links_imperfect) deliver_links(W, P);
    if (P->controller)
      external_control(W, P, t, t_link, x, sensed); /* it writes u, uu and zdot (never batched) */
    else
      aggregate(W, P, t_link); /* batched: into the lane rows */
    if (W->batched && !fused)
      for (int g = 0; g < W->n_groups; ++g) control_group(W, g, dx, in_lanes);
    else if (!W->batched && !P->controller)
      control_agents(W, P, t, x, sensed);
  }
  disturbances(W, P, t);
  const double *ua = compute_control ? W->u : W->u_apply;
  const double *za = compute_control ? W->zdot : W->zdot_apply;
  if (fused)
    for (int g = 0; g < W->n_groups; ++g) {
      if (compute_control) control_group(W, g, dx, in_lanes);
      plant_group(W, g, x, dx, ua, za, in_lanes, compute_control, sensed);
    }
  if (compute_control) {
    if (in_lanes)
      check_commands_lanes(W, t);
    else
      check_commands(W, t);
    if (W->nw > 0) wheel_commands(W, P, t, x, sensed);
  }
  if (W->nw > 0)
    plant_with_wheels(W, P, x, dx, compute_control ? W->uw : W->uw_apply, sensed);
  else if (!W->batched)
    plant_agents(W, P, x, dx, ua);
  if (nz > 0 && !in_lanes && !W->lane_state)
    for (int i = 0; i < n; ++i) memcpy(dx + 9 + (size_t)S * i, za + (size_t)nz * i, sizeof(double) * nz);
  if (W->nw > 0) wheel_rates(W, P, dx);
  zero_spare_lanes(W, dx);
}

/* The reference's and every agent's MRP to its shadow set where |sigma| > 1. */
static void shadow_all(workspace *W, double *x) {
  for (int b = 0; b < W->n + 1; ++b) {
    const int st = b > 0 ? agent_step(W) : 1; /* the components' stride in x */
    double *sig = b > 0 ? x + agent_at(W, b - 1) : x;
    double s[3] = {sig[0], sig[st], sig[2 * st]}, tmp[3];
    if (s[0] * s[0] + s[1] * s[1] + s[2] * s[2] > 1.0) {
      const double *arg[1] = {s};
      double *res[1] = {tmp};
      mrp_shadow(arg, res, W->iw, W->w, 0);
      sig[0] = tmp[0], sig[st] = tmp[1], sig[2 * st] = tmp[2];
    }
  }
}

/* -1 if the reference's state is not finite, else the first agent whose state is not, else -2. */
static int first_nonfinite(const workspace *W, const double *x) {
  const size_t N = W->n_state;
  unsigned long long any = 0; /* a branch-free pass first (it vectorises): an exponent of all ones is inf or NaN */
  for (size_t k = 0; k < N; ++k) {
    unsigned long long bits;
    memcpy(&bits, x + k, sizeof bits);
    any |= (bits & 0x7ff0000000000000ULL) == 0x7ff0000000000000ULL;
  }
  if (!any) return -2;
  if (!(isfinite(x[0]) && isfinite(x[1]) && isfinite(x[2]))) return -1;
  for (int i = 0; i < W->n; ++i) {
    const double *xi = x + agent_at(W, i);
    const int st = agent_step(W);
    for (int k = 0; k < W->stride; ++k)
      if (!isfinite(xi[st * k])) return i;
  }
  return -2;
}

/* One output row: the true state, the true error state (the model's error_state_* function: what the metrics
 * see, whatever the law computes), what each agent broadcasts, its law states and the applied torque. */
static void record(fsm_output *O, workspace *W, double t, const double *x) {
  if (O->written >= O->capacity) return;
  const int n = W->n, nb = W->nb, nz = W->nz, per = n / W->members;
  long long r = O->written++;
  O->t[r] = t;
  memcpy(O->sigma_d + 3 * r, x, 3 * sizeof(double));
  for (int i = 0; i < n; ++i) {
    /* row r of agent i: member-major when runs fly together (one run: m = 0, per = n) */
    const size_t slot = ((size_t)(i / per) * (size_t)O->capacity + (size_t)r) * (size_t)per + (size_t)(i % per);
    size_t o = slot * 3;
    const double *xi = agent_state(W, x, i);
    memcpy(O->sigma + o, xi, 3 * sizeof(double));
    memcpy(O->omega + o, xi + 3, 3 * sizeof(double));
    const double *arg[4] = {xi, xi + 3, x, W->wd};
    double *res[2] = {O->sigma_e + o, O->omega_e + o};
    W->error_state(arg, res, W->iw, W->w, 0);
    memcpy(O->broadcast + slot * nb, W->b + (size_t)nb * i, sizeof(double) * nb);
    memcpy(O->z + slot * nz, xi + 6, sizeof(double) * nz);
    memcpy(O->u + o, (W->nw > 0 ? W->u_body : W->u_apply) + 3 * i, 3 * sizeof(double));
    memcpy(O->u_unsat + o, W->uu_apply + 3 * i, 3 * sizeof(double));
    if (W->nw > 0) {
      const size_t ow = slot * W->nw;
      if (O->wheel_speed) memcpy(O->wheel_speed + ow, xi + 6 + nz, sizeof(double) * W->nw);
      if (O->wheel_torque) memcpy(O->wheel_torque + ow, W->u_motor + (size_t)W->nw * i, sizeof(double) * W->nw);
    }
    if (W->sig_meas && O->sigma_measured) memcpy(O->sigma_measured + o, W->sig_meas + 3 * i, 3 * sizeof(double));
    if (W->om_meas && O->omega_measured) memcpy(O->omega_measured + o, W->om_meas + 3 * i, 3 * sizeof(double));
    if (W->since_out && O->events_per_output) { /* messages since the previous row */
      O->events_per_output[slot] = W->since_out[i];
      W->since_out[i] = 0;
    }
  }
}

/* Run statistics of the applied torque u (unsaturated uu) held over an interval of length h; with wheels, u is
 * their reaction on the body at the interval's start and a wheel at its torque limit (scale > 1) or speed limit
 * counts as saturated. */
static void accumulate(fsm_output *O, const workspace *W, const fsm_problem *P, const double *u, const double *uu,
                       const double *wheel_sat, double h, double *u_prev, int first) {
  const int n = W->n;
  for (int i = 0; i < n; ++i) {
    int sat = W->nw > 0 && wheel_sat[i] != 0.0;
    double tv = 0.0;
    for (int k = 0; k < 3; ++k) {
      double au = fabs(uu[3 * i + k]);
      if (au > P->u_max[i]) sat = 1;
      if (au > O->u_unsat_max[i]) O->u_unsat_max[i] = au;
      double ua = u[3 * i + k];
      if (!first) tv += fabs(ua - u_prev[3 * i + k]);
      u_prev[3 * i + k] = ua;
    }
    if (sat) O->saturated_time[i] += h;
    O->u_total_variation[i] += tv;
  }
}

/* Per agent: 1 if a wheel is at its torque limit (scale > 1) or speed limit at the last evaluation, else 0. */
static void wheel_saturation(const workspace *W, double *flags) {
  if (W->nw == 0) return; /* accumulate reads the flags only with wheels */
  for (int i = 0; i < W->n; ++i) flags[i] = W->wscale_apply[i] > 1.0 || W->gated[i];
}

/* Evaluate stage 1 at (t, x): control if due, hold bookkeeping. */
static void stage_one(workspace *W, const fsm_problem *P, double t, double t_link, const double *x, double *k1,
                      int sample) {
  if (P->hold_steps <= 0) {
    eval_rhs(W, P, t, t_link, x, k1, 1);
    W->u_apply = W->u;
    W->uu_apply = W->uu;
    W->zdot_apply = W->zdot;
    W->uw_apply = W->uw;
    W->wscale_apply = W->wscale;
    return;
  }
  if (sample) {
    eval_rhs(W, P, t, t_link, x, k1, 1);
    memcpy(W->u_hold, W->u, sizeof(double) * 3 * W->n);
    memcpy(W->uu_hold, W->uu, sizeof(double) * 3 * W->n);
    memcpy(W->zdot_hold, W->zdot, sizeof(double) * (size_t)W->nz * W->n);
    memcpy(W->uw_hold, W->uw, sizeof(double) * (size_t)W->nw * W->n);
    memcpy(W->wscale_hold, W->wscale, sizeof(double) * W->n);
  } else {
    eval_rhs(W, P, t, t_link, x, k1, 0);
  }
  W->u_apply = W->u_hold;
  W->uu_apply = W->uu_hold;
  W->zdot_apply = W->zdot_hold;
  W->uw_apply = W->uw_hold;
  W->wscale_apply = W->wscale_hold;
}

static int validate(const fsm_problem *P) {
  if (P->kernels != FSM_KERNELS_AUTO && P->kernels != FSM_KERNELS_BATCHED && P->kernels != FSM_KERNELS_SCALAR) return 0;
  if (P->n_agents < 1 || !(P->dt > 0) || P->n_steps < 0 || P->output_every < 1 || P->n_links < 0) return 0;
  if (P->n_params < 0 || P->n_states < 0 || P->n_broadcast < 0) return 0;
  if (P->n_members > 1 && P->n_agents % P->n_members != 0) return 0;
  for (int e = 0; e < P->n_links; ++e) {
    if (P->link_receiver[e] < 0 || P->link_receiver[e] >= P->n_agents) return 0;
    if (P->link_sender[e] < 0 || P->link_sender[e] >= P->n_agents) return 0;
    if (P->sched_count[e] < 1) return 0;
  }
  if (P->integrator == 1 && !(P->rtol > 0 && P->atol > 0 && P->h_min > 0 && P->max_steps > 0)) return 0;
  if (P->n_wheels < 0) return 0;
  if (P->n_wheels > 0 && !(P->wheel_axes && P->wheel_pinv && P->wheel_Js && P->wheel_torque_max && P->wheel_params &&
                           P->J_spin))
    return 0;
  if (P->wheel_allocation != FSM_WHEEL_SCALED && P->wheel_allocation != FSM_WHEEL_CLIPPED) return 0;
  if (P->wheel_gate != FSM_GATE_CONTINUOUS && P->wheel_gate != FSM_GATE_STEP_START) return 0;
  /* a motor torque held over a step must be constant over it: commands held between control instants */
  if (P->n_wheels > 0 && P->wheel_gate == FSM_GATE_STEP_START && P->hold_steps <= 0) return 0;
  if (P->wheel_command && (P->n_wheels <= 0 || P->hold_steps <= 0 || P->n_samples < P->n_steps / P->hold_steps + 1))
    return 0;
  if (P->trigger_every < 0 || P->zeno_checks < 0) return 0;
  if (P->controller && P->hold_steps <= 0) return 0; /* an external controller runs at the control instants */
  if (P->trigger_every > 0 && (P->hold_steps <= 0 || !fsm_trigger_available())) return 0; /* checked at instants */
  if (P->sensors || P->links_imperfect) { /* they act at the control instants */
    if (P->hold_steps <= 0 || P->n_samples < P->n_steps / P->hold_steps + 1) return 0;
    if (P->sensors && !(P->sensor_dtheta && P->sensor_gyro)) return 0;
    if (P->links_imperfect) {
      if (!P->link_lost || !P->link_delay) return 0;
      for (int e = 0; e < P->n_links; ++e)
        if (P->link_delay[e] < 0) return 0;
    }
  }
  return 1;
}

static int simulate_rk4(workspace *W, const fsm_problem *P, double *x, fsm_output *O, double *buf,
                        fsm_progress_fn progress, long long every) {
  const int n = W->n;
  const size_t N = W->n_state;
  double *k1 = buf, *k2 = k1 + N, *k3 = k2 + N, *k4 = k3 + N, *xt = k4 + N, *u_prev = xt + N, *sat0 = u_prev + 3 * n;
  const double dt = P->dt, t0 = P->t0;
  const int continuous = P->hold_steps <= 0;
  const int step_gate = W->nw > 0 && P->wheel_gate == FSM_GATE_STEP_START;
  /* The link weights k^j_ij(t) are piecewise constant in t.  All four stages of the step over [t_k, t_k+1]
   * use their value at the step midpoint, i.e. the value that holds on the step when no switch lies strictly
   * inside it.  A switch on the step grid (every switch of the paper's Table 2 when dt divides 0.1 s) is then
   * integrated exactly; evaluating each stage at its own time would put the new weight into the last stage
   * of the step that ends at the switch and cost an O(dt) global error per switch.  Recorded outputs at t_k
   * are consistent with this: they use the weight that holds just after t_k (segments are left-closed). */
  for (long long k = 0; k <= P->n_steps; ++k) {
    const double t = t0 + (double)k * dt, t_link = t0 + ((double)k + 0.5) * dt;
    int sample = continuous || (k % P->hold_steps == 0);
    if (!continuous && sample) W->q = k / P->hold_steps;
    W->gate_held = 0;
    stage_one(W, P, t, t_link, x, k1, sample);
    W->gate_held = step_gate; /* the speed limit decided at the step's start holds over its other stages */
    if (W->bad_agent != -2) break;
    if (k % P->output_every == 0) record(O, W, t, x);
    /* after the record: a caller stopping here gets the outputs and statistics up to t_k exactly */
    if (progress && every > 0 && k > 0 && k % every == 0 && progress(k, P->n_steps)) return FSM_ABORTED;
    if (k == P->n_steps) break;
    wheel_saturation(W, sat0);
    accumulate(O, W, P, W->nw > 0 ? W->u_body : W->u_apply, W->uu_apply, sat0, dt, u_prev, k == 0);
    const double th = t0 + ((double)k + 0.5) * dt, t1 = t0 + (double)(k + 1) * dt;
    for (size_t m = 0; m < N; ++m) xt[m] = x[m] + 0.5 * dt * k1[m];
    eval_rhs(W, P, th, t_link, xt, k2, continuous ? 2 : 0);
    for (size_t m = 0; m < N; ++m) xt[m] = x[m] + 0.5 * dt * k2[m];
    eval_rhs(W, P, th, t_link, xt, k3, continuous ? 2 : 0);
    for (size_t m = 0; m < N; ++m) xt[m] = x[m] + dt * k3[m];
    eval_rhs(W, P, t1, t_link, xt, k4, continuous ? 2 : 0);
    if (W->bad_agent != -2) break;
    for (size_t m = 0; m < N; ++m) x[m] += dt / 6.0 * (k1[m] + 2.0 * (k2[m] + k3[m]) + k4[m]);
    shadow_all(W, x);
    int bad = first_nonfinite(W, x);
    if (bad != -2) {
      O->fail_time = t1;
      O->fail_agent = bad;
      return FSM_NONFINITE;
    }
    O->steps_taken++;
  }
  if (W->bad_agent != -2) {
    O->fail_time = W->bad_time;
    O->fail_agent = W->bad_agent;
    return W->bad_rc;
  }
  return FSM_OK;
}

/* Dormand-Prince 5(4) coefficients */
static const double C2 = 1.0 / 5, C3 = 3.0 / 10, C4 = 4.0 / 5, C5 = 8.0 / 9;
static const double A21 = 1.0 / 5;
static const double A31 = 3.0 / 40, A32 = 9.0 / 40;
static const double A41 = 44.0 / 45, A42 = -56.0 / 15, A43 = 32.0 / 9;
static const double A51 = 19372.0 / 6561, A52 = -25360.0 / 2187, A53 = 64448.0 / 6561, A54 = -212.0 / 729;
static const double A61 = 9017.0 / 3168, A62 = -355.0 / 33, A63 = 46732.0 / 5247, A64 = 49.0 / 176,
                    A65 = -5103.0 / 18656;
static const double B1 = 35.0 / 384, B3 = 500.0 / 1113, B4 = 125.0 / 192, B5 = -2187.0 / 6784, B6 = 11.0 / 84;
static const double E1 = 71.0 / 57600, E3 = -71.0 / 16695, E4 = 71.0 / 1920, E5 = -17253.0 / 339200,
                    E6 = 22.0 / 525, E7 = -1.0 / 40;

static int simulate_dopri(workspace *W, const fsm_problem *P, double *x, fsm_output *O, double *buf,
                          fsm_progress_fn progress, long long every) {
  const int n = W->n;
  const size_t N = W->n_state;
  double *k1 = buf, *k2 = k1 + N, *k3 = k2 + N, *k4 = k3 + N, *k5 = k4 + N, *k6 = k5 + N, *k7 = k6 + N,
         *xt = k7 + N, *xn = xt + N, *u_prev = xn + N, *u_snap = u_prev + 3 * n, *uu_snap = u_snap + 3 * n,
         *sat0 = uu_snap + 3 * n;
  const double t0 = P->t0, t_end = t0 + (double)P->n_steps * P->dt;
  const double out_dt = (double)P->output_every * P->dt;
  const double hold_dt = P->hold_steps > 0 ? (double)P->hold_steps * P->dt : 0.0;
  const int continuous = P->hold_steps <= 0;
  const int step_gate = W->nw > 0 && P->wheel_gate == FSM_GATE_STEP_START;
  long long m_out = 0, q_hold = 0, attempts = 0;
  double t = t0, h = P->dt;
  int first = 1;
  long long next_report = every;
  for (;;) {
    const double eps_t = 1e-12 * fmax(1.0, fabs(t));
    int sample = 0;
    if (!continuous && fabs(t - (t0 + (double)q_hold * hold_dt)) <= eps_t) { sample = 1; W->q = q_hold++; }
    W->gate_held = 0;
    stage_one(W, P, t, t, x, k1, continuous || sample || first);
    W->gate_held = step_gate; /* as in simulate_rk4: every trial step from x holds the limit decided at x */
    if (W->bad_agent != -2) break;
    memcpy(u_snap, W->nw > 0 ? W->u_body : W->u_apply, sizeof(double) * 3 * n); /* the torque on the body */
    wheel_saturation(W, sat0); /* at the step's start, as the torque */
    memcpy(uu_snap, W->uu_apply, sizeof(double) * 3 * n);
    if (fabs(t - (t0 + (double)m_out * out_dt)) <= eps_t) { record(O, W, t, x); m_out++; }
    if (progress && every > 0 && O->steps_taken >= next_report) { /* after the record, as in simulate_rk4 */
      next_report += every;
      long long done = (long long)((t - t0) / P->dt);
      if (progress(done, P->n_steps)) return FSM_ABORTED;
    }
    if (t >= t_end - eps_t) break;
    /* next event: output time, sample time, end */
    double t_next = fmin(t_end, t0 + (double)m_out * out_dt);
    if (!continuous) t_next = fmin(t_next, t0 + (double)q_hold * hold_dt);
    int rejected_in_row = 0;
    for (;;) {
      if (++attempts > P->max_steps) return FSM_TOO_MANY_STEPS;
      W->bad_agent = -2; /* a non-finite command in a trial stage only matters if the step is accepted */
      double hs = fmin(h, t_next - t);
      int lands = hs >= t_next - t - eps_t;
      if (lands) hs = t_next - t;
      for (size_t m = 0; m < N; ++m) xt[m] = x[m] + hs * A21 * k1[m];
      eval_rhs(W, P, t + C2 * hs, t + C2 * hs, xt, k2, continuous ? 2 : 0);
      for (size_t m = 0; m < N; ++m) xt[m] = x[m] + hs * (A31 * k1[m] + A32 * k2[m]);
      eval_rhs(W, P, t + C3 * hs, t + C3 * hs, xt, k3, continuous ? 2 : 0);
      for (size_t m = 0; m < N; ++m) xt[m] = x[m] + hs * (A41 * k1[m] + A42 * k2[m] + A43 * k3[m]);
      eval_rhs(W, P, t + C4 * hs, t + C4 * hs, xt, k4, continuous ? 2 : 0);
      for (size_t m = 0; m < N; ++m) xt[m] = x[m] + hs * (A51 * k1[m] + A52 * k2[m] + A53 * k3[m] + A54 * k4[m]);
      eval_rhs(W, P, t + C5 * hs, t + C5 * hs, xt, k5, continuous ? 2 : 0);
      for (size_t m = 0; m < N; ++m)
        xt[m] = x[m] + hs * (A61 * k1[m] + A62 * k2[m] + A63 * k3[m] + A64 * k4[m] + A65 * k5[m]);
      eval_rhs(W, P, t + hs, t + hs, xt, k6, continuous ? 2 : 0);
      for (size_t m = 0; m < N; ++m)
        xn[m] = x[m] + hs * (B1 * k1[m] + B3 * k3[m] + B4 * k4[m] + B5 * k5[m] + B6 * k6[m]);
      eval_rhs(W, P, t + hs, t + hs, xn, k7, continuous ? 2 : 0);
      double err = 0.0;
      for (size_t m = 0; m < N; ++m) {
        double e = hs * (E1 * k1[m] + E3 * k3[m] + E4 * k4[m] + E5 * k5[m] + E6 * k6[m] + E7 * k7[m]);
        double sc = P->atol + P->rtol * fmax(fabs(x[m]), fabs(xn[m]));
        err += (e / sc) * (e / sc);
      }
      err = sqrt(err / (double)N);
      if (!isfinite(err)) err = 1e10;
      double factor = err > 0 ? 0.9 * pow(err, -0.2) : 5.0;
      factor = fmin(5.0, fmax(0.2, factor));
      if (err <= 1.0 && W->bad_agent != -2) break; /* cannot happen with a finite err; kept for safety */
      if (err <= 1.0) {
        accumulate(O, W, P, u_snap, uu_snap, sat0, hs, u_prev, first);
        first = 0;
        memcpy(x, xn, sizeof(double) * N);
        t = lands ? t_next : t + hs;
        double h_new = hs * (rejected_in_row ? fmin(1.0, factor) : factor);
        h = (lands && hs < h) ? fmax(h, h_new) : h_new; /* a step shortened to land on an event keeps h */
        break;
      }
      O->steps_rejected++;
      rejected_in_row = 1;
      h = hs * factor;
      if (h < P->h_min) {
        if (W->bad_agent != -2) break;
        O->fail_time = t;
        return FSM_STEP_TOO_SMALL;
      }
    }
    if (W->bad_agent != -2) break;
    shadow_all(W, x);
    int bad = first_nonfinite(W, x);
    if (bad != -2) {
      O->fail_time = t;
      O->fail_agent = bad;
      return FSM_NONFINITE;
    }
    O->steps_taken++;
  }
  if (W->bad_agent != -2) {
    O->fail_time = W->bad_time;
    O->fail_agent = W->bad_agent;
    return W->bad_rc;
  }
  return FSM_OK;
}

int fsm_simulate(const fsm_problem *P, const double *x0, fsm_output *O, fsm_progress_fn progress, long long every) {
  if (!validate(P)) return FSM_BAD_PROBLEM;
  workspace W;
  int rc = alloc_workspace(&W, P, 1);
  if (rc != FSM_OK) return rc;
  const int n = P->n_agents;
  const size_t N = W.n_state; /* a multiple of FSM_LANES with lane_state: every buffer below starts a line */
  void *raw = NULL;
  double *buf = calloc_lines(N * 11 + 10 * (size_t)n, &raw);
  if (!buf) { free_workspace(&W); return FSM_NOMEM; }
  double *x = buf;
  state_from(&W, x0, x);
  for (int i = 0; i < n; ++i) {
    O->saturated_time[i] = 0.0;
    O->u_total_variation[i] = 0.0;
    O->u_unsat_max[i] = 0.0;
  }
  O->written = 0;
  O->steps_taken = 0;
  O->steps_rejected = 0;
  O->fail_time = NAN;
  O->fail_agent = -2;
  if (P->trigger_every > 0) { /* the message counts (event-triggered communication) */
    if (!O->messages_sent || !O->messages_delivered || !O->first_event || !O->last_event || !O->min_inter_event) {
      free(raw);
      free_workspace(&W);
      return FSM_BAD_PROBLEM;
    }
    for (int i = 0; i < n; ++i) {
      O->messages_sent[i] = 0;
      O->first_event[i] = O->last_event[i] = NAN;
      O->min_inter_event[i] = INFINITY;
    }
    for (int e = 0; e < P->n_links; ++e) O->messages_delivered[e] = 0;
    W.out = O;
  }
  shadow_all(&W, x);
  if (P->integrator == 1)
    rc = simulate_dopri(&W, P, x, O, buf + N, progress, every);
  else
    rc = simulate_rk4(&W, P, x, O, buf + N, progress, every);
  free(raw);
  free_workspace(&W);
  return rc;
}

int fsm_rhs(const fsm_problem *P, double t, const double *x, double *dx, double *u_out) {
  if (!validate(P)) return FSM_BAD_PROBLEM;
  workspace W;
  int rc = alloc_workspace(&W, P, 0);
  if (rc != FSM_OK) return rc;
  eval_rhs(&W, P, t, t, x, dx, 1);
  if (u_out) memcpy(u_out, W.nw > 0 ? W.u_body : W.u, sizeof(double) * 3 * P->n_agents); /* on the body */
  rc = W.bad_agent == -2 ? FSM_OK : FSM_NONFINITE_CONTROL;
  free_workspace(&W);
  return rc;
}
