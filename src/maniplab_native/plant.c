/* maniplab's plant in C: the friction/limit automaton around MuJoCo's step (see plant.h).

   Each joint is in one mode: SLIP (it moves, with its Coulomb/Stribeck friction applied), STICK
   (held at rest by stiction) or AT_LOWER / AT_UPPER (held on a limit).

   Holding is exact, not a stiff spring: a held joint gets an armature of `hold_inertia` (a large
   multiple of the arm's largest inertia) on the plant's working model, so MuJoCo's own
   factorisation of M solves the constrained dynamics (the free joints' accelerations
   M_FF^-1 (tau_F - b_F), the paper's eq. 8, to ~1e-12 relative) in every RK4 stage; the force
   that holds the joint is read back as -I qacc (at t, for the decisions) and -I dqvel/h (over the
   step, for the record). Mode changes take effect at step boundaries; events inside a step are
   put on the nearer boundary where the step's start predicts them (a velocity reaching zero or
   the stick velocity), else on its end.

   A pinned cylinder's rod friction (newtons on the rod) joins its joint's own through the
   moment arm r of the joint's actuator (ds/dq, MuJoCo's actuator moment) at each step's start
   pose: the plant evaluates the position stage first, reads r there, and only then sets the
   forces and finishes the forward pass (arms without rod friction keep the one mj_forward). */
#include "plant.h"

#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

struct ml_plant {
  mjModel* m;
  mjData* d;
  int n, substeps, integrator;
  double h;                  /* MuJoCo's step, s */
  double hold;               /* armature of a held joint */
  /* per joint (n) */
  double *lower, *upper, *cmd_limit;
  double *coulomb, *stiction, *stribeck, *stick_velocity, *breakaway, *slip_acc;
  int* can_stick;
  /* rod friction (plant.h), per joint (n); breakaway, slip_acc and stick_velocity of its joints
     change with the lever every step */
  int nrod;
  int *rods, *has_rod;       /* the joints with rod friction; 1 for each */
  double *rod_coulomb, *rod_stiction, *rod_stribeck, *rod_viscous, *rod_stick;
  double *pin_breakaway, *pin_stick; /* the joint's own Fc + Fs (0 without) and stick velocity */
  double* lever;             /* |r| at the step's start */
  double* rod_damping;       /* -Fv r^2 v at the prepared step's start (the record's) */
  double* armature;          /* the model's own armature */
  /* joint lists */
  int nslip, nsticky, nlimited;
  int *slip, *sticky, *limited;
  int nbounds;
  int *bound_adr, *bound_joint;
  double* bound_value;
  /* the automaton's state */
  int* modes;
  double* direction;         /* sign of a break-away's coming motion */
  int nheld;
  int* held;                 /* the joints held in the working model's armature */
  /* the step */
  double *u, *q0, *v0, *act0, *fric, *limit, *q1, *v1;
  double* bristles;          /* the friction actuators' force at the step's start (LuGre's) */
  double* command;           /* a run's sample command before clipping */
  /* the record of the last step (plant.h: ml_plant_record) */
  double *rq, *rqd, *ract, *ru, *rfric, *rlimit;
  signed char* rmode;
  /* Python */
  ml_actuator_fn python_actuator;
  ml_check_fn python_check;
  int callback_failed;
  int bad_kind, bad_index;   /* the first bad value this step: mjWARN_BADQPOS/QVEL/QACC, or -1 */
  ml_error error;
};

/* The plant with Python actuators the calling thread steps (see the dispatcher below). */
static __thread ml_plant* t_plant = NULL;

/* --- memory ------------------------------------------------------------------------------- */
static double* copy_or_zero(const double* src, int size) {
  double* out = (double*)calloc(size > 0 ? size : 1, sizeof(double));
  if (out && src) memcpy(out, src, size * sizeof(double));
  return out;
}

static int* new_ints(int size) { return (int*)calloc(size > 0 ? size : 1, sizeof(int)); }

void ml_plant_free(ml_plant* p) {
  if (!p) return;
  if (t_plant == p) t_plant = NULL; /* a call left by a MuJoCo error, which does not return */
  double* doubles[] = {p->lower, p->upper, p->cmd_limit, p->coulomb, p->stiction, p->stribeck,
                       p->stick_velocity, p->breakaway, p->slip_acc, p->armature, p->bound_value,
                       p->direction, p->u, p->command, p->q0, p->v0, p->act0, p->fric, p->limit, p->q1, p->v1, p->bristles,
                       p->rq, p->rqd, p->ract, p->ru, p->rfric, p->rlimit, p->rod_coulomb,
                       p->rod_stiction, p->rod_stribeck, p->rod_viscous, p->rod_stick,
                       p->pin_breakaway, p->pin_stick, p->lever, p->rod_damping};
  int* ints[] = {p->can_stick, p->slip, p->sticky, p->limited, p->bound_adr, p->bound_joint,
                 p->modes, p->held, p->rods, p->has_rod};
  for (size_t i = 0; i < sizeof(doubles) / sizeof(doubles[0]); i++) free(doubles[i]);
  for (size_t i = 0; i < sizeof(ints) / sizeof(ints[0]); i++) free(ints[i]);
  free(p->rmode);
  free(p);
}

ml_plant* ml_plant_new(mjModel* m, mjData* d, const ml_plant_config* c) {
  int n = c->n, na = (int)m->na;
  if (n < 1 || n != m->nv || n > m->nu || c->substeps < 1) return NULL;
  ml_plant* p = (ml_plant*)calloc(1, sizeof(ml_plant));
  if (!p) return NULL;
  p->m = m;
  p->d = d;
  p->bad_kind = -1;
  p->n = n;
  p->substeps = c->substeps;
  p->integrator = m->opt.integrator;
  p->h = m->opt.timestep;
  p->hold = c->hold_inertia;
  p->lower = copy_or_zero(c->lower, n);
  p->upper = copy_or_zero(c->upper, n);
  p->cmd_limit = copy_or_zero(c->command_limit, n);
  p->coulomb = copy_or_zero(c->coulomb, n);
  p->stiction = copy_or_zero(c->stiction, n);
  p->stribeck = copy_or_zero(c->stribeck, n);
  p->stick_velocity = copy_or_zero(c->stick_velocity, n);
  p->breakaway = copy_or_zero(NULL, n);
  p->slip_acc = copy_or_zero(NULL, n);
  p->can_stick = new_ints(n);
  p->armature = copy_or_zero(m->dof_armature, n);
  p->slip = new_ints(n);
  p->sticky = new_ints(n);
  p->limited = new_ints(n);
  p->nbounds = c->nbounds;
  p->bound_adr = new_ints(c->nbounds);
  p->bound_joint = new_ints(c->nbounds);
  p->bound_value = copy_or_zero(c->bound_value, c->nbounds);
  p->modes = new_ints(n);
  p->direction = copy_or_zero(NULL, n);
  p->held = new_ints(n);
  p->u = copy_or_zero(NULL, n);
  p->command = copy_or_zero(NULL, n);
  p->q0 = copy_or_zero(NULL, n);
  p->v0 = copy_or_zero(NULL, n);
  p->act0 = copy_or_zero(NULL, na);
  p->fric = copy_or_zero(NULL, n);
  p->limit = copy_or_zero(NULL, n);
  p->q1 = copy_or_zero(NULL, n);
  p->v1 = copy_or_zero(NULL, n);
  p->bristles = copy_or_zero(NULL, n);
  p->rq = copy_or_zero(NULL, n);
  p->rqd = copy_or_zero(NULL, n);
  p->ract = copy_or_zero(NULL, na);
  p->ru = copy_or_zero(NULL, n);
  p->rfric = copy_or_zero(NULL, n);
  p->rlimit = copy_or_zero(NULL, n);
  p->rmode = (signed char*)calloc(n, 1);
  p->rods = new_ints(n);
  p->has_rod = new_ints(n);
  p->rod_coulomb = copy_or_zero(c->rod ? c->rod_coulomb : NULL, n);
  p->rod_stiction = copy_or_zero(c->rod ? c->rod_stiction : NULL, n);
  p->rod_stribeck = copy_or_zero(c->rod ? c->rod_stribeck : NULL, n);
  p->rod_viscous = copy_or_zero(c->rod ? c->rod_viscous : NULL, n);
  p->rod_stick = copy_or_zero(c->rod ? c->rod_stick_velocity : NULL, n);
  p->pin_breakaway = copy_or_zero(NULL, n);
  p->pin_stick = copy_or_zero(c->stick_velocity, n);
  p->lever = copy_or_zero(NULL, n);
  p->rod_damping = copy_or_zero(NULL, n);
  if (!p->rmode || !p->rlimit || !p->held || !p->bound_value || !p->bristles || !p->rod_damping) {
    ml_plant_free(p);
    return NULL;
  }
  for (int i = 0; i < c->nbounds; i++) {
    p->bound_adr[i] = c->bound_adr[i];
    p->bound_joint[i] = c->bound_joint[i];
  }
  for (int j = 0; j < n; j++) {
    if (c->rod && c->rod[j] && j < m->nu && m->actuator_outnum[j] == 1) {
      p->rods[p->nrod++] = j;
      p->has_rod[j] = 1;
    }
    if (c->slip[j]) {
      p->slip[p->nslip++] = j;
      p->breakaway[j] = p->coulomb[j] + p->stiction[j];
      p->pin_breakaway[j] = p->breakaway[j];
      p->can_stick[j] = p->breakaway[j] > 0.0
                        || (p->has_rod[j] && p->rod_coulomb[j] + p->rod_stiction[j] > 0.0);
      if (p->can_stick[j]) p->sticky[p->nsticky++] = j;
    }
    p->slip_acc[j] = p->breakaway[j] / p->hold;
    if (isfinite(p->lower[j]) || isfinite(p->upper[j])) p->limited[p->nlimited++] = j;
    p->direction[j] = 1.0;
  }
  /* MuJoCo factorises the mass matrix of a "simple" dof (one it found decoupled when compiling)
     once, from the armature of that time: for holding to act, none is simple */
  for (int j = 0; j < n; j++) m->dof_simplenum[j] = 0;
  return p;
}

void ml_plant_set_python(ml_plant* p, ml_actuator_fn actuator, ml_check_fn check) {
  p->python_actuator = actuator;
  p->python_check = check;
}

/* --- Python actuators through MuJoCo's callbacks -------------------------------------------- */
/* MuJoCo's mjcb_act_dyn and mjcb_act_bias are process-global. This library installs one
   dispatcher pair for the process and never removes it: a call is answered by the Python
   actuators of the plant the calling thread is stepping (set by `enter` for the length of each
   ml_plant_* call, so plants in several threads need no lock), and any other model is left as
   MuJoCo leaves it: the callback installed before the dispatcher is called, or, without one (or
   while this thread compiles a model: ml_mjcb_suspend), 0 as MuJoCo does without callbacks
   (act_dot stays 0, bias 0). When someone replaces the dispatcher (mujoco.set_mjcb_act_dyn),
   the next plant call or MuJoCo step of a plant with Python actuators installs it again,
   chaining to the new callback. */
enum { DYN = 0, BIAS = 1 };

static __thread int t_suspended = 0;       /* this thread compiles a model */
static mjfAct chained[2] = {NULL, NULL};   /* called for other models: what was installed before */
static pthread_mutex_t install_mutex = PTHREAD_MUTEX_INITIALIZER;

static mjtNum python_callback(ml_plant* p, int kind, int id) {
  double out = 0.0;
  if (p->callback_failed) return 0.0;
  if (p->python_actuator(kind, id, &out) != 0) {
    p->callback_failed = 1;
    return 0.0;
  }
  return out;
}

static mjtNum dispatch(int kind, const mjModel* m, const mjData* d, int id) {
  ml_plant* p = t_plant;
  if (p && p->m == m && p->d == d) return python_callback(p, kind, id);
  if (t_suspended) return 0.0;
  mjfAct next = __atomic_load_n(&chained[kind], __ATOMIC_ACQUIRE);
  return next ? next(m, d, id) : 0.0;
}

static mjtNum dispatch_dyn(const mjModel* m, const mjData* d, int id) {
  return dispatch(DYN, m, d, id);
}

static mjtNum dispatch_bias(const mjModel* m, const mjData* d, int id) {
  return dispatch(BIAS, m, d, id);
}

/* Put `dispatcher` into `*global`, chaining to what is there. Installers are serialised by the
   mutex; the compare-and-swap catches a callback set meanwhile by code that does not take it. */
static void install_one(mjfAct* global, mjfAct* chain, mjfAct dispatcher) {
  mjfAct seen = __atomic_load_n(global, __ATOMIC_ACQUIRE);
  while (seen != dispatcher) {
    __atomic_store_n(chain, seen, __ATOMIC_RELEASE);
    if (__atomic_compare_exchange_n(global, &seen, dispatcher, 0, __ATOMIC_ACQ_REL,
                                    __ATOMIC_ACQUIRE)) {
      break;
    }
  }
}

static int installed(void) {
  return __atomic_load_n(&mjcb_act_dyn, __ATOMIC_ACQUIRE) == dispatch_dyn
         && __atomic_load_n(&mjcb_act_bias, __ATOMIC_ACQUIRE) == dispatch_bias;
}

void ml_mjcb_install(void) {
  if (installed()) return;
  pthread_mutex_lock(&install_mutex);
  install_one(&mjcb_act_dyn, &chained[DYN], dispatch_dyn);
  install_one(&mjcb_act_bias, &chained[BIAS], dispatch_bias);
  pthread_mutex_unlock(&install_mutex);
}

int ml_mjcb_suspend(int on) {
  int previous = t_suspended;
  t_suspended = on != 0;
  return previous;
}

/* MuJoCo's profiling timers (d->timer) are off while plants step: the Python bindings install a
   clock as mjcb_time on import, and reading it twice in every stage of every step took 7 to 10 %
   of a pinned arm's run. The first plant call to start saves the callback and clears it, the last
   to end puts it back (unless someone set another meanwhile). */
static pthread_mutex_t timer_mutex = PTHREAD_MUTEX_INITIALIZER;
static int timer_users = 0;
static mjfTime timer_saved = NULL;

static void timers_off(void) {
  pthread_mutex_lock(&timer_mutex);
  if (timer_users++ == 0) {
    timer_saved = mjcb_time;
    mjcb_time = NULL;
  }
  pthread_mutex_unlock(&timer_mutex);
}

static void timers_on(void) {
  pthread_mutex_lock(&timer_mutex);
  if (--timer_users == 0 && mjcb_time == NULL) mjcb_time = timer_saved;
  pthread_mutex_unlock(&timer_mutex);
}

/* The start of a plant call: a plant with Python actuators becomes the one this thread steps.
   Returns the previous one (the plant whose controller calls this one), for `leave`. */
static ml_plant* enter(ml_plant* p) {
  ml_plant* previous = t_plant;
  timers_off();
  if (p->python_actuator) {
    t_plant = p;
    ml_mjcb_install();
  }
  return previous;
}

static void leave(ml_plant* previous) {
  t_plant = previous;
  timers_on();
}

/* --- friction ------------------------------------------------------------------------------- */
/* Coulomb + Stribeck force on a slipping joint (no viscous part: MuJoCo's joint damping). At
   v = 0 (a joint that just broke away) it opposes the coming motion `direction`. */
static double slip_force(double v, double direction, double coulomb, double stiction,
                         double stribeck) {
  double r = v / stribeck;
  double magnitude = coulomb + stiction * exp(-r * r);
  if (v > 0.0) return -magnitude;
  if (v < 0.0) return magnitude;
  return -magnitude * direction;
}

/* The rod friction's levers |r| at the pose MuJoCo's position stage just evaluated (actuator j's
   moment on dof j, from the sparse rows of mj_transmission), and what follows from them for each
   joint with rod friction: its break-away (the joint's own Fc + Fs plus the rod's times |r|),
   the acceleration that breaks it away, and its stick velocity (the smaller of the joint's own
   and the rod's sv/|r|, each where that friction can stick). */
static void levers(ml_plant* p) {
  const mjModel* m = p->m;
  const mjData* d = p->d;
  for (int i = 0; i < p->nrod; i++) {
    int j = p->rods[i], row = m->actuator_outadr[j];
    int start = d->moment_rowadr[row], end = start + d->moment_rownnz[row];
    double r = 0.0;
    for (int k = start; k < end; k++) {
      if (d->moment_colind[k] == j) r = d->actuator_moment[k];
    }
    double a = fabs(r), rod = a * (p->rod_coulomb[j] + p->rod_stiction[j]);
    p->lever[j] = a;
    if (!p->can_stick[j]) continue;
    p->breakaway[j] = p->pin_breakaway[j] + rod;
    p->slip_acc[j] = p->breakaway[j] / p->hold;
    double sv = p->pin_breakaway[j] > 0.0 ? p->pin_stick[j] : INFINITY;
    if (rod > 0.0) sv = fmin(sv, p->rod_stick[j] / a);
    p->stick_velocity[j] = sv < INFINITY ? sv : p->pin_stick[j];
  }
}

/* Whether a slipping joint sticks after a step from v0 to v1: its velocity changed sign, or fell
   below the stick velocity while decelerating. */
static int sticks(double v0, double v1, double stick_velocity) {
  double a1 = fabs(v1);
  return v0 * v1 < 0.0 || (a1 < stick_velocity && a1 < fabs(v0));
}

/* The slipping joints' friction for the step, into p->fric and qfrc_applied. It is evaluated at
   the step's predicted mid-point velocity v + a h/2 (a: the last step's final acceleration,
   MuJoCo's qacc_warmstart, part of the saved state), which makes smooth slip phases second order
   in h; a velocity that would change sign within the step is taken as half the start velocity. */
static void set_forces(ml_plant* p) {
  const double* acc = p->d->qacc_warmstart;
  double half = 0.5 * p->h;
  for (int j = 0; j < p->n; j++) p->fric[j] = 0.0;
  for (int i = 0; i < p->nslip; i++) {
    int j = p->slip[i];
    if (p->modes[j] != ML_SLIP) continue;
    double v = p->v0[j];
    if (v != 0.0) {
      double mid = v + half * acc[j];
      v = mid * v > 0.0 ? mid : 0.5 * v;
    }
    p->fric[j] = slip_force(v, p->direction[j], p->coulomb[j], p->stiction[j], p->stribeck[j]);
    if (p->has_rod[j]) { /* the rod's, at the rod's speed v|r|, times |r| */
      double a = p->lever[j];
      p->fric[j] += slip_force(v * a, p->direction[j], a * p->rod_coulomb[j],
                               a * p->rod_stiction[j], p->rod_stribeck[j]);
    }
  }
  memcpy(p->d->qfrc_applied, p->fric, p->n * sizeof(double));
}

/* Make the joints not slipping immovable for MuJoCo (armature + hold on each). */
static void hold(ml_plant* p) {
  int changed = 0, k = 0;
  for (int j = 0; j < p->n; j++) {
    if (p->modes[j] != ML_SLIP) {
      if (k >= p->nheld || p->held[k] != j) changed = 1;
      p->held[k++] = j;
    }
  }
  if (!changed && k == p->nheld) return;
  p->nheld = k;
  memcpy(p->m->dof_armature, p->armature, p->n * sizeof(double));
  for (int i = 0; i < k; i++) p->m->dof_armature[p->held[i]] += p->hold;
}

/* Transitions of the held joints from their holding forces h = -hold qacc: a stop is released
   when it had to pull (AT_UPPER with h > 0, AT_LOWER with h < 0), the joint becoming STICK if it
   can stick, else SLIP; STICK breaks away (-> SLIP) when |h| exceeds Fc + Fs, moving against h.
   Limits are decided first: when any releases, break-aways wait for the next evaluation (their
   holding forces were computed with that one-sided constraint wrongly in place). Returns 1 if a
   mode changed. */
static int release(ml_plant* p, const double* acc) {
  int changed = 0, released = 0;
  for (int i = 0; i < p->nheld; i++) {
    int j = p->held[i];
    double h = -p->hold * acc[j];
    if ((p->modes[j] == ML_AT_UPPER && h > 0.0) || (p->modes[j] == ML_AT_LOWER && h < 0.0)) {
      p->modes[j] = p->can_stick[j] ? ML_STICK : ML_SLIP;
      changed = 1;
      released = 1;
    }
  }
  if (released) return changed;
  for (int i = 0; i < p->nheld; i++) {
    int j = p->held[i];
    double h = -p->hold * acc[j];
    if (p->modes[j] == ML_STICK && fabs(h) > p->breakaway[j]) {
      p->modes[j] = ML_SLIP;
      p->direction[j] = h > 0.0 ? -1.0 : 1.0;
      changed = 1;
    }
  }
  return changed;
}

/* Whether a held joint's acceleration says it breaks away or pulls on its stop. */
static int leaves(const ml_plant* p, int j, double a) {
  switch (p->modes[j]) {
    case ML_STICK:
      return a > p->slip_acc[j] || a < -p->slip_acc[j];
    case ML_AT_UPPER:
      return a < 0.0;
    default:
      return a > 0.0;
  }
}

/* The automaton at the step's start, on the dynamics MuJoCo just evaluated there: slipping joints
   that decelerate to zero within the step (or below the stick velocity by its middle) stick now;
   held joints whose holding force breaks away or pulls on a stop are released. After any change
   the forces are set anew and MuJoCo evaluates the new held set, until nothing changes (at most
   2n + 2 evaluations). */
static void settle(ml_plant* p) {
  mjModel* m = p->m;
  mjData* d = p->d;
  double h = p->h, half = 0.5 * p->h;
  for (int iter = 0; iter < 2 * p->n + 2; iter++) {
    const double* acc = d->qacc;
    int changed = 0;
    for (int i = 0; i < p->nsticky; i++) {
      int j = p->sticky[i];
      if (p->modes[j] != ML_SLIP) continue;
      double v = p->v0[j], a = acc[j], sv = p->stick_velocity[j];
      int hit;
      if (v > 0.0) {
        hit = a < 0.0 && (v + a * h <= 0.0 || v + a * half < sv);
      } else if (v < 0.0) {
        hit = a > 0.0 && (v + a * h >= 0.0 || v + a * half > -sv);
      } else {
        hit = a * p->direction[j] < 0.0;
      }
      if (hit) {
        p->modes[j] = ML_STICK;
        p->v0[j] = 0.0;
        changed = 1;
      }
    }
    for (int i = 0; i < p->nheld; i++) {
      int j = p->held[i];
      if (leaves(p, j, acc[j])) {
        changed = release(p, acc) || changed;
        break;
      }
    }
    if (!changed) break;
    memcpy(d->qvel, p->v0, p->n * sizeof(double));
    set_forces(p);
    hold(p);
    mj_forward(m, d);
  }
}

/* --- the step ------------------------------------------------------------------------------- */
static void integrate(const mjModel* m, mjData* d, int integrator) {
  switch (integrator) {
    case mjINT_RK4:
      mj_RungeKutta(m, d, 4);
      break;
    case mjINT_EULER:
      mj_Euler(m, d);
      break;
    default:
      mj_implicit(m, d);
  }
}

/* The force on each joint of the actuators after the n joint actuators (LuGre's bristles, on
   their joints), as MuJoCo just evaluated it. */
static void friction_actuators(ml_plant* p) {
  const mjModel* m = p->m;
  const mjData* d = p->d;
  for (int j = 0; j < p->n; j++) p->bristles[j] = 0.0;
  for (int i = p->n; i < m->nu; i++) {
    if (m->actuator_trntype[i] != mjTRN_JOINT) continue;
    int dof = m->jnt_dofadr[m->actuator_trnid[2 * i]];
    if (dof < p->n) p->bristles[dof] += m->actuator_gear[6 * i] * d->actuator_force[i];
  }
}

/* Notes the first NaN, infinite or huge (> mjMAXVAL) value of x[0..len) as a bad value of kind
   `kind`, unless one is noted already. This is the test of mj_checkPos/Vel/Acc, made here instead
   because MuJoCo's own warning also prints and appends to MUJOCO_LOG.TXT in the user's folder;
   the plant stops with its own message instead (and never lets MuJoCo reset the data). */
static void note_bad(ml_plant* p, int kind, const mjtNum* x, int len) {
  if (p->bad_kind != -1) return;
  for (int i = 0; i < len; i++) {
    if (!(fabs(x[i]) <= mjMAXVAL)) {
      p->bad_kind = kind;
      p->bad_index = i;
      return;
    }
  }
}

/* The start of one MuJoCo step: forces, holds, the forward pass, the automaton's decisions. */
static void start(ml_plant* p) {
  mjModel* m = p->m;
  mjData* d = p->d;
  int n = p->n;
  memcpy(p->q0, d->qpos, n * sizeof(double));
  memcpy(p->v0, d->qvel, n * sizeof(double));
  memcpy(p->act0, d->act, m->na * sizeof(double));
  memcpy(d->ctrl, p->u, n * sizeof(double));
  for (int i = n; i < m->nu; i++) d->ctrl[i] = 0.0;
  if (p->python_actuator) ml_mjcb_install(); /* in case someone replaced it meanwhile */
  p->bad_kind = -1; /* q and q̇ were checked at the last step's end (check), or set from Python */
  if (p->nrod) {
    /* mj_forward in two: the position stage gives the levers at this pose, then the forces */
    hold(p);
    mj_fwdPosition(m, d);
    if (m->nsensor) mj_sensorPos(m, d);
    if (m->opt.enableflags & mjENBL_ENERGY) mj_energyPos(m, d);
    levers(p);
    set_forces(p);
    mj_forwardSkip(m, d, mjSTAGE_POS, 0);
  } else {
    set_forces(p);
    hold(p);
    mj_forward(m, d);
  }
  if (p->nsticky || p->nlimited) settle(p);
  if (m->nu > n) friction_actuators(p);
  note_bad(p, mjWARN_BADQACC, d->qacc, m->nv);
}

/* Events at the step's end: the holding forces over the step (-hold dqvel/h, the RK4 average:
   stiction's into the friction, a stop's into the limit force), held joints put back at rest,
   slipping joints that reversed or slowed below the stick velocity stuck, joints past a limit put
   on it. Whether a held joint breaks away or leaves its stop is decided at the next start. */
static void events(ml_plant* p) {
  mjData* d = p->d;
  int n = p->n, moved = p->nheld > 0;
  double *q1 = p->q1, *v1 = p->v1;
  memcpy(q1, d->qpos, n * sizeof(double));
  memcpy(v1, d->qvel, n * sizeof(double));
  for (int j = 0; j < n; j++) p->limit[j] = 0.0;
  double scale = -p->hold / p->h;
  for (int i = 0; i < p->nheld; i++) {
    int j = p->held[i];
    double f = scale * v1[j]; /* v1 - 0 = the step's average acceleration times h */
    q1[j] = p->q0[j];
    v1[j] = 0.0;
    if (p->modes[j] == ML_STICK) {
      p->fric[j] += f;
    } else {
      p->limit[j] = f;
    }
  }
  for (int i = 0; i < p->nsticky; i++) {
    int j = p->sticky[i];
    if (p->modes[j] == ML_SLIP && sticks(p->v0[j], v1[j], p->stick_velocity[j])) {
      v1[j] = 0.0;
      p->modes[j] = ML_STICK;
      moved = 1;
    }
  }
  for (int i = 0; i < p->nlimited; i++) {
    int j = p->limited[i];
    if (q1[j] < p->lower[j]) {
      q1[j] = p->lower[j];
      v1[j] = 0.0;
      p->modes[j] = ML_AT_LOWER;
      moved = 1;
    } else if (q1[j] > p->upper[j]) {
      q1[j] = p->upper[j];
      v1[j] = 0.0;
      p->modes[j] = ML_AT_UPPER;
      moved = 1;
    }
  }
  if (moved) {
    memcpy(d->qpos, q1, n * sizeof(double));
    memcpy(d->qvel, v1, n * sizeof(double));
  }
}

static int fail(ml_plant* p, int status, int joint, int index) {
  p->error.status = status;
  p->error.joint = joint;
  p->error.index = index;
  p->error.time = p->d->time;
  return status;
}

/* The instability checks after a step: NaN, infinite or huge values (as MuJoCo's checks define
   them), actuator states beyond their bounds, the Python check. */
static int check(ml_plant* p) {
  mjData* d = p->d;
  note_bad(p, mjWARN_BADQPOS, d->qpos, p->m->nq); /* what mj_step checks before its forward pass */
  note_bad(p, mjWARN_BADQVEL, d->qvel, p->m->nv);
  if (p->bad_kind != -1) {
    return fail(p, ML_UNSTABLE_MOTION, p->bad_index < p->n ? p->bad_index : -1, p->bad_kind);
  }
  for (int i = 0; i < p->nbounds; i++) {
    double x = d->act[p->bound_adr[i]], bound = p->bound_value[i];
    if (!(-bound <= x && x <= bound)) {
      return fail(p, ML_STATE_BOUND, p->bound_joint[i], p->bound_adr[i]);
    }
  }
  if (p->callback_failed) return fail(p, ML_CALLBACK_ERROR, -1, -1);
  if (p->python_check) {
    int joint = p->python_check();
    if (joint != -1) return fail(p, joint < -1 ? ML_CALLBACK_ERROR : ML_STATE_BOUND, joint, -1);
  }
  return ML_OK;
}

/* The end of one MuJoCo step: integrate, the automaton's events, the checks. */
static int finish(ml_plant* p) {
  integrate(p->m, p->d, p->integrator);
  events(p);
  for (int j = 0; j < p->n; j++) p->rfric[j] = p->fric[j] + p->bristles[j];
  for (int i = 0; i < p->nrod; i++) p->rfric[p->rods[i]] += p->rod_damping[p->rods[i]];
  memcpy(p->rlimit, p->limit, p->n * sizeof(double));
  return check(p);
}

static void clip(ml_plant* p, const double* u) {
  for (int j = 0; j < p->n; j++) {
    double x = u[j], lim = p->cmd_limit[j];
    p->u[j] = (-lim <= x && x <= lim) ? x : (x > 0.0 ? lim : -lim);
  }
}

static int prepare(ml_plant* p, const double* u) {
  int n = p->n;
  for (int j = 0; j < n; j++) {
    if (!isfinite(u[j])) return fail(p, ML_BAD_COMMAND, j, -1);  /* clip would make NaN a limit */
  }
  clip(p, u);
  start(p);
  for (int i = 0; i < p->nrod; i++) { /* the rod's viscous force at the step's start (MuJoCo's) */
    int j = p->rods[i];
    p->rod_damping[j] = -p->rod_viscous[j] * p->lever[j] * p->lever[j] * p->v0[j];
  }
  memcpy(p->rq, p->q0, n * sizeof(double));
  memcpy(p->rqd, p->v0, n * sizeof(double));
  memcpy(p->ract, p->act0, p->m->na * sizeof(double));
  memcpy(p->ru, p->u, n * sizeof(double));
  for (int j = 0; j < n; j++) p->rmode[j] = (signed char)p->modes[j];
  return p->callback_failed ? fail(p, ML_CALLBACK_ERROR, -1, -1) : ML_OK;
}

static int advance(ml_plant* p) {
  int status = finish(p);
  for (int i = 1; i < p->substeps && status == ML_OK; i++) {
    start(p);
    status = finish(p);
  }
  return status;
}

/* --- the public calls ------------------------------------------------------------------------- */
void ml_plant_resync(ml_plant* p) {
  mjData* d = p->d;
  for (int j = 0; j < p->n; j++) {
    double q = d->qpos[j], v = d->qvel[j];
    if (q <= p->lower[j] && v <= 0.0) {
      p->modes[j] = ML_AT_LOWER;
    } else if (q >= p->upper[j] && v >= 0.0) {
      p->modes[j] = ML_AT_UPPER;
    } else {
      p->modes[j] = p->can_stick[j] && v == 0.0 ? ML_STICK : ML_SLIP;
    }
    if (p->modes[j] == ML_AT_LOWER || p->modes[j] == ML_AT_UPPER) d->qvel[j] = 0.0;
    p->direction[j] = 1.0;
  }
  p->bad_kind = -1;
  p->callback_failed = 0;
}

int ml_plant_prepare(ml_plant* p, const double* u) {
  ml_plant* previous = enter(p);
  int status = prepare(p, u);
  leave(previous);
  return status;
}

int ml_plant_advance(ml_plant* p) {
  ml_plant* previous = enter(p);
  int status = advance(p);
  leave(previous);
  return status;
}

static void record_row(const ml_plant* p, ml_run* r, double t) {
  int n = p->n, na = (int)p->m->na, row = r->rows;
  r->t[row] = t;
  memcpy(r->q + (size_t)row * n, p->rq, n * sizeof(double));
  memcpy(r->qd + (size_t)row * n, p->rqd, n * sizeof(double));
  memcpy(r->act + (size_t)row * na, p->ract, na * sizeof(double));
  memcpy(r->ctrl + (size_t)row * n, p->ru, n * sizeof(double));
  memcpy(r->mode + (size_t)row * n, p->rmode, n);
  if (r->ee_pos && r->ee_body >= 0) {
    memcpy(r->ee_pos + (size_t)row * 3, p->d->xpos + 3 * r->ee_body, 3 * sizeof(double));
  }
  int ns = (int)p->m->npluginstate;
  if (r->plugin_state && ns) {
    memcpy(r->plugin_state + (size_t)row * ns, p->d->plugin_state, ns * sizeof(double));
  }
}

static void record_forces(const ml_plant* p, ml_run* r, int row) {
  int n = p->n;
  memcpy(r->fric + (size_t)row * n, p->rfric, n * sizeof(double));
  memcpy(r->limit + (size_t)row * n, p->rlimit, n * sizeof(double));
}

/* A run's counts and times as the loop needs them (the caller checks them with a message; this
   keeps the loop from dividing by zero or indexing outside its tables whoever calls it). */
static int valid_run(const ml_plant* p, const ml_run* r) {
  return r->steps >= 0 && r->every >= 1 && r->k >= 0 && r->max_steps >= 0 && isfinite(r->t0) &&
         isfinite(r->dt) && r->dt > 0.0 && isfinite(r->period) && r->period >= 0.0 &&
         r->inputs_k0 >= 0 && r->inputs_k0 <= r->k && r->rows >= 0 &&
         (r->columns == 0 || r->columns == p->n || r->columns == p->n + 1);
}

static int run(ml_plant* p, ml_run* r) {
  int n = p->n, taken = 0;
  double* u = p->command;
  if (!valid_run(p, r)) return fail(p, ML_BAD_RUN, -1, -1);
  for (; r->k <= r->steps; r->k++) {
    int64_t k = r->k;
    double t = r->t0 + k * r->dt;
    if (r->max_steps && taken >= r->max_steps) return ML_PAUSED;
    if (r->controller && k < r->steps && t >= r->next_call - 1e-9 * r->dt) {
      if (r->controller(r->controller_context, t, p->m, p->d, r->held) != 0) {
        p->error.time = t;
        return fail(p, ML_CONTROLLER_ERROR, -1, -1);
      }
      r->next_call = r->period > 0.0 ? r->next_call + r->period : t;
    }
    int columns = r->columns > n ? r->columns : n;
    const double* in = r->inputs ? r->inputs + (size_t)(k - r->inputs_k0) * columns : NULL;
    for (int j = 0; j < n; j++) {
      u[j] = in ? r->held[j] + in[j] : r->held[j];
    }
    if (in && columns > n && p->m->nuserdata >= 2) { /* the measured supply over the step */
      p->d->userdata[0] = in[n];
      p->d->userdata[1] = k < r->steps ? in[columns + n] : in[n];
    }
    int status = prepare(p, u);
    if (status == ML_BAD_COMMAND) p->error.time = t;
    if (status != ML_OK) return status;
    int record = k % r->every == 0 || k == r->steps;
    if (record) record_row(p, r, t);
    if (k == r->steps) {
      record_forces(p, r, r->rows++);
      break;
    }
    status = advance(p);
    taken++;
    if (status != ML_OK) return status;
    if (record) record_forces(p, r, r->rows++);
  }
  r->k = r->steps + 1;
  return ML_OK;
}

int ml_plant_run(ml_plant* p, ml_run* r) {
  ml_plant* previous = enter(p);
  int status = run(p, r);
  leave(previous);
  return status;
}

void ml_plant_record(const ml_plant* p, double* q, double* qd, double* act, double* u,
                     signed char* mode, double* fric, double* limit) {
  int n = p->n;
  if (q) memcpy(q, p->rq, n * sizeof(double));
  if (qd) memcpy(qd, p->rqd, n * sizeof(double));
  if (act) memcpy(act, p->ract, p->m->na * sizeof(double));
  if (u) memcpy(u, p->ru, n * sizeof(double));
  if (mode) memcpy(mode, p->rmode, n);
  if (fric) memcpy(fric, p->rfric, n * sizeof(double));
  if (limit) memcpy(limit, p->rlimit, n * sizeof(double));
}

void ml_plant_modes(const ml_plant* p, signed char* mode) {
  for (int j = 0; j < p->n; j++) mode[j] = (signed char)p->modes[j];
}

ml_error ml_plant_error(const ml_plant* p) { return p->error; }
