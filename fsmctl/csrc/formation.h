/*
 * Whole-loop simulator of an n-spacecraft formation flying any control law of fsmctl's law contract
 * (fsmctl.symbolic.law).  Hand-written, law-agnostic driver: it contains no model or control equation.
 * It calls the generated per-agent functions
 *   - of the model (generated/c): plant_rhs, reference_rhs, disturbance_torque, mrp_shadow, error_state_*;
 *   - of one law (generated/laws/<law>/c, or a user's derived folder): law_constants, law_local_<model>,
 *     law_control_<model>;
 * (plant_rhs and the law's functions through their lane-batched kernels, FSM_LANES agents per call, same
 * results) and does the formation-level bookkeeping around them, each rule once: the time loop (fixed-step
 * RK4 or adaptive Dormand-Prince 5(4)), the neighbour aggregation over the time-varying directed topology
 * (received_i = sum_j k^j_ij(t) b_j, k_sum_i = sum_j k^i_ij, k_received_sum_i = sum_j k^j_ij(t), Liang et al.
 * 2012 eq 19 for any broadcast b), the switching schedules, zero-order-hold sampling, MRP shadow switching after each step, output decimation and run statistics.
 *
 * Flight hardware (each off by default; off, the loop is the ideal-torque loop, bit for bit):
 *   - reaction wheels (n_wheels > 0): at each control evaluation the law's torque is distributed to the wheels
 *     (minimum-norm), the open-loop per-wheel commands of that instant (wheel_command) are added, and the torque
 *     limit is applied, scaled (one factor for all wheels) or clipped (each wheel): wheel_commands, the one
 *     place these rules are written (fsmctl.model.actuators is their NumPy transcription).  The commands are held
 *     with the control, and the plant is the generated gyrostat_rhs with the generated per-wheel wheel_torque
 *     (speed limit, friction) and wheel_acceleration; with wheel_gate = FSM_GATE_STEP_START the speed limit is
 *     decided at the start of each integrator step and held over it (the generated wheel_net_torque adds the
 *     friction at the inner stages);
 *   - sensors (sensors = 1): at control instant q the law sees the generated sensor_measurement of the true state
 *     with the noise sensor_dtheta[q], sensor_gyro[q] (drawn in Python, fsmctl.model.noise); the metrics and
 *     records of sigma/omega see the truth;
 *   - imperfect links (links_imperfect = 1): at instant q link e delivers the sender's broadcast of instant
 *     q - link_delay[e] (before instant 0: its value at instant 0), unless link_lost[q][e], when the receiver
 *     keeps the last value it received on that link.
 *
 * Event-triggered communication (trigger_every > 0; a law declaring LawBuilder.trigger, compiled with
 * -DFSM_LAW_TRIGGER): at every trigger_every-th control instant each agent evaluates the law's generated
 * law_trigger(t, b_i, b_sent_i, params_i, constants_i) and sends when it is > 0 (at instant 0 always): then
 * b_sent_i = b_i.  The links carry b_sent (held between messages) instead of the live broadcast; with imperfect links
 * a link delivers at instant q the message its sender sent at instant q - link_delay[e], if it sent one then and
 * link_lost[q][e] is 0.  An agent that sends at zeno_checks consecutive checks stops the run (FSM_ZENO).
 *
 * State layout: x = [sigma_d (3), then for each agent i: sigma_i (3), omega_i (3), z_i (n_states), Omega_i (n_wheels)].
 * The ABI (struct sizes and field offsets, FSM_ABI_VERSION) is exported by fsm_abi() and checked by Python at load.
 */
#ifndef FSMCTL_FORMATION_H
#define FSMCTL_FORMATION_H

#ifdef __cplusplus
extern "C" {
#endif

#define FSM_ABI_VERSION 6

/* Software in the loop (ABI 6): an external controller evaluated at the control instants instead of the law's
 * generated functions (fsmctl.export's check flies an exported C library this way).  Phase FSM_CONTROLLER_BROADCAST:
 * agent i's broadcast from what it sees (write `broadcast`); phase FSM_CONTROLLER_STEP, after the links: its applied
 * torque, commanded torque and law-state derivative (write `u`, `u_commanded`, `z_dot`) from its incoming links in
 * link order (k^i_ij, k^j_ij(t), the broadcast each link delivers).  A nonzero return stops the run
 * (FSM_CONTROLLER_FAILED at that time and agent). */
typedef struct {
  double t;
  const double *sigma, *omega, *z;             /* what the law sees (the measurements with sensors) and its state */
  const double *sigma_d, *omega_d, *omega_d_dot;
  int n_links;                                 /* incoming links */
  const double *k_own, *k_sender;              /* n_links each */
  const double *const *received;               /* n_links pointers to n_broadcast numbers */
} fsm_controller_input;
typedef int (*fsm_controller_fn)(void *context, int phase, int agent, const fsm_controller_input *in,
                                 double *broadcast, double *u, double *u_commanded, double *z_dot);
enum { FSM_CONTROLLER_BROADCAST = 0, FSM_CONTROLLER_STEP = 1 };

typedef struct {
  int n_agents;
  int error_model;          /* 0: paper kinematics (eqs 7-8), 1: exact */
  int integrator;           /* 0: RK4 fixed step, 1: Dormand-Prince 5(4) adaptive */
  int kernels;              /* FSM_KERNELS_*: how the per-agent functions are evaluated; results are the same */
  int n_params;             /* per agent, must equal the law's */
  int n_states;             /* law states per agent, must equal the law's */
  int n_broadcast;          /* must equal the law's */
  int n_links;
  double t0;
  double dt;                /* RK4 step; initial step for the adaptive method */
  long long n_steps;        /* RK4: number of steps; adaptive: t_final = t0 + n_steps*dt */
  long long output_every;   /* outputs at t0 + k*output_every*dt */
  long long hold_steps;     /* 0: control evaluated at every stage; h > 0: zero-order hold with period h*dt */
  double rtol, atol, h_min; /* adaptive method only */
  long long max_steps;      /* adaptive method only: give up after this many accepted+rejected steps */
  const double *J_true;     /* n x 9, row-major, the plant's inertia J0 + Delta_J */
  const double *J0;         /* n x 9, nominal inertia used by the controller */
  const double *params;     /* n x n_params: the law's parameters */
  const double *u_max;      /* n: per-component torque limit of the actuator (may be +inf; 0: open loop) */
  const double *dist_params;/* n x 12: disturbance sinusoid */
  const double *ref_params; /* 12: omega_d sinusoid */
  const int *link_receiver; /* i of k^i_ij, k^j_ij: agent i receives b_j */
  const int *link_sender;   /* j */
  const double *link_k_i;   /* k^i_ij (constant) */
  const double *sched_period;  /* per link: period of k^j_ij(t); <= 0 for aperiodic */
  const double *sched_phase;   /* per link: k^j_ij(t) = schedule(t + phase) */
  const int *sched_start;      /* per link: first breakpoint in sched_times/sched_values */
  const int *sched_count;      /* per link: number of segments */
  const double *sched_times;   /* segment m holds on [times[m], times[m+1]) (last: up to the period / +inf) */
  const double *sched_values;
  /* flight hardware (ABI 3) */
  int n_wheels;                  /* reaction wheels per agent; 0: the ideal torque source (per-axis clip u_max) */
  int sensors;                   /* 1: the law sees sensor_measurement(x, sensor_dtheta[q], sensor_gyro[q]) */
  int links_imperfect;           /* 1: delayed and lossy links (link_delay, link_lost) */
  long long n_samples;           /* control instants covered by sensor_* and link_lost */
  const double *wheel_axes;      /* n x n_wheels x 3: spin axis g of each wheel (unit, body frame) */
  const double *wheel_pinv;      /* n x n_wheels x 3: rows of pinv(G_s), the minimum-norm distribution */
  const double *wheel_Js;        /* n x n_wheels: spin inertia */
  const double *wheel_torque_max;/* n x n_wheels: motor torque limit (may be +inf) */
  const double *wheel_params;    /* n x n_wheels x 4: [speed_max, viscous, coulomb, coulomb_band] */
  const double *J_spin;          /* n x 9: sum_k Js_k g_k g_k^T */
  const double *sensor_dtheta;   /* n_samples x n x 3: star-tracker error rotation (rad) */
  const double *sensor_gyro;     /* n_samples x n x 3: gyro error (rad/s) */
  const int *link_delay;         /* n_links: delay in control instants */
  const unsigned char *link_lost;/* n_samples x n_links: 1 = the packet of that instant is lost */
  /* runs flown together (ABI 4; appended) */
  int n_members;                 /* <= 1: one run; m > 1: the agents are m runs of n_agents / m agents each (a
                                    block-diagonal formation) and the per-agent output arrays are member-major:
                                    m x capacity x (n_agents / m) x ... (each run's outputs contiguous) */
  /* wheels as Basilisk flies them (ABI 5) */
  int wheel_allocation;          /* torque-limit rule: FSM_WHEEL_SCALED (one factor for all wheels) or
                                    FSM_WHEEL_CLIPPED (each wheel clipped to +-wheel_torque_max, Basilisk's) */
  int wheel_gate;                /* speed limit: FSM_GATE_CONTINUOUS (at every evaluation) or FSM_GATE_STEP_START
                                    (decided at the start of each integrator step and held over it, Basilisk's) */
  const double *wheel_command;   /* NULL, or n_samples x n x n_wheels: open-loop motor torque of each wheel (N m,
                                    positive spins it up along g) added at control instant q before the limit rule */
  /* event-triggered communication (ABI 5) */
  long long trigger_every;       /* 0: periodic broadcasting (every control evaluation); m > 0: the law's trigger is
                                    checked at every m-th control instant (needs hold_steps > 0 and a library
                                    compiled with the law's trigger) */
  long long zeno_checks;         /* > 0: an agent that sends at this many consecutive checks stops the run (FSM_ZENO) */
  /* software in the loop (ABI 6) */
  fsm_controller_fn controller;  /* NULL: the law's generated functions; else this controller at the control instants
                                    (needs hold_steps > 0; the per-agent functions then run agent by agent) */
  void *controller_context;      /* its first argument */
} fsm_problem;

enum { FSM_WHEEL_SCALED = 0, FSM_WHEEL_CLIPPED = 1 };
enum { FSM_GATE_CONTINUOUS = 0, FSM_GATE_STEP_START = 1 };

enum {
  FSM_KERNELS_AUTO = 0,    /* batched where the build has AVX (fsm_batched_preferred), else scalar */
  FSM_KERNELS_BATCHED = 1, /* lane-batched kernels, FSM_LANES agents per call */
  FSM_KERNELS_SCALAR = 2   /* the scalar CasADi functions, agent by agent */
};

typedef struct {
  long long capacity;       /* number of output rows allocated */
  long long written;        /* rows written */
  double *t;                /* capacity */
  double *sigma_d;          /* capacity x 3 */
  double *sigma, *omega, *sigma_e, *omega_e, *u, *u_unsat; /* capacity x n x 3; u: the control torque on the body
                            (ideal: the clipped command; wheels: their reaction -sum_k g_k u_net,k), u_unsat: the law's command */
  double *broadcast;        /* capacity x n x n_broadcast */
  double *z;                /* capacity x n x n_states */
  double *saturated_time;   /* n: time with a saturated component (wheels: or a wheel at its torque or speed limit) */
  double *u_total_variation;/* n: sum over steps of |u(t_k) - u(t_k-1)|_1 */
  double *u_unsat_max;      /* n: max |u_unsat| component */
  long long steps_taken;    /* accepted steps */
  long long steps_rejected; /* adaptive only */
  double fail_time;         /* time of the first non-finite state */
  int fail_agent;           /* agent with the first non-finite state (-1: reference) */
  /* flight hardware (ABI 3; appended, so that the structs of ABI 2 are prefixes of these) */
  double *wheel_speed;      /* capacity x n x n_wheels: Omega (rad/s); NULL when n_wheels = 0 */
  double *wheel_torque;     /* capacity x n x n_wheels: motor torque after the speed limit (N m) */
  double *sigma_measured, *omega_measured; /* capacity x n x 3: what the law saw last; NULL: not recorded */
  /* event-triggered communication (ABI 5; appended): written when trigger_every > 0 */
  long long *messages_sent;      /* n: messages each agent sent (its first at instant 0) */
  long long *messages_delivered; /* n_links: messages each link delivered to its receiver (not lost, arrived) */
  long long *events_per_output;  /* capacity x n: messages sent since the previous output row (row 0: at t0) */
  double *first_event, *last_event; /* n: times of each agent's first and last message (s) */
  double *min_inter_event;       /* n: shortest time between two consecutive messages (+inf: fewer than two) */
} fsm_output;

/* Progress callback: called every `every` steps with (steps done, steps planned), right after the output sample of
 * that instant (if it is on the output grid) was recorded and before the next step; a nonzero return aborts, and the
 * outputs and run statistics then cover the run up to that instant exactly (RK4: `every` steps; dopri45: every
 * `every` accepted steps). */
typedef int (*fsm_progress_fn)(long long done, long long planned);

enum {
  FSM_OK = 0,
  FSM_NONFINITE = 1,
  FSM_ABORTED = 2,
  FSM_NOMEM = 3,
  FSM_BAD_PROBLEM = 4,
  FSM_STEP_TOO_SMALL = 5,
  FSM_TOO_MANY_STEPS = 6,
  FSM_NONFINITE_CONTROL = 7, /* the control law returned a non-finite torque command (fail_time, fail_agent) */
  FSM_ZENO = 8,              /* an agent sent at zeno_checks consecutive trigger checks (fail_time, fail_agent) */
  FSM_CONTROLLER_FAILED = 9  /* the external controller returned nonzero (fail_time, fail_agent) */
};

/* The ABI: out[0] = FSM_ABI_VERSION, out[1] = sizeof(fsm_problem), out[2] = sizeof(fsm_output), then the
 * offset of every field of fsm_problem and of fsm_output in declaration order.  Returns the number of entries
 * (writes at most `capacity`). */
int fsm_abi(long long *out, int capacity);
/* The law's sizes as compiled: [n_params, n_states, n_broadcast, n_constants, n_cache]. */
void fsm_law_sizes(long long *out);
int fsm_batched_available(void); /* 1 if this build has the batched kernels (GCC/Clang vector extension) */
int fsm_batched_preferred(void); /* 1 if FSM_KERNELS_AUTO means batched in this build (available and AVX) */
int fsm_lane_width(void);       /* FSM_LANES of this build: agents per call of the batched kernels (4 or 8) */
int fsm_trigger_available(void); /* 1 if this build has the law's event trigger (compiled with -DFSM_LAW_TRIGGER) */
int fsm_simulate(const fsm_problem *P, const double *x0, fsm_output *O, fsm_progress_fn progress, long long every);

/* One evaluation of the formation right-hand side (control computed at this state; link weights at t).
 * Returns FSM_NONFINITE_CONTROL (dx still filled) if a commanded torque is non-finite.  u_out: n x 3 applied
 * torque (after the actuator limit), may be NULL. */
int fsm_rhs(const fsm_problem *P, double t, const double *x, double *dx, double *u_out);

/* Value of link e's k^j_ij at time t (for tests and plots). */
double fsm_link_weight(const fsm_problem *P, int e, double t);

#ifdef __cplusplus
}
#endif
#endif
