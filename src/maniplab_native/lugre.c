/* LuGre friction (Canudas de Wit et al. 1995) on one joint as a MuJoCo actuator plugin.

   Activation (actdim 1): the bristle deflection z (m or rad). With v the joint's velocity:

     g(v)   = Fc + Fs exp(-(v/vs)^2)
     dz/dt  = v - sigma0 |v| z / g(v)
     force  = -(sigma0 z + sigma1 dz/dt)         (sigma2 v is the joint's damping)

   The bristles relax at the rate sigma0 |v| / g(v), which reaches 1e4 1/s on the 1995 paper's
   stick-slip case: integrated by MuJoCo's RK4 with the arm, z would need steps of ~0.1 ms. So z
   is not part of act_dot (its rate is 0 within a step): after each step (`advance`) it takes the
   exact solution of dz/dt for the step's mean velocity vbar = (q1 - q0)/h,

     z1 = z0 exp(-a h) + vbar h (1 - exp(-a h)) / (a h),   a = sigma0 |vbar| / g(vbar),

   stable at any step. Each evaluation inside the step (each RK4 stage's force) takes the same
   solution to its own time t0 + t, for the mean velocity (q - q0)/t since the step's start: z is
   not held at z0 (a zero-order hold, first order) but follows the joint, so where the bristles
   are slow (a h << 1: presliding, sticking) z - z0 is exactly q - q0, which RK4 integrates to
   fourth order, and where they are fast z is at its quasi-steady deflection for the current
   motion. The step's starting time and position are recorded at every evaluation that is not one
   of RK4's later stages (half a step or a whole step after the recorded start), so at each step's
   start.

   The actuator takes no control (give it ctrllimited="false" and leave ctrl at 0). */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "plugins.h"

#define PLUGIN "maniplab.lugre"

typedef struct {
  int actuator;
  int qpos;             /* the joint's position address */
  double sigma0, sigma1, coulomb, stiction, inv_stribeck;
} Bristles;

/* plugin_state of an instance: the step's start time and position, and whether they are set */
enum { START_TIME, START_POSITION, HAVE_START, NSTATE };

static const char* kAttributes[] = {"sigma0", "sigma1", "coulomb", "static", "stribeck_velocity"};

static double level(const Bristles* b, double v) {
  double r = v * b->inv_stribeck;
  return b->coulomb + b->stiction * exp(-r * r);
}

static double rate(const Bristles* b, double z, double v) {
  return v - b->sigma0 * fabs(v) * z / level(b, v);
}

/* z after a step h at the constant velocity v, exactly. */
static double relax(const Bristles* b, double z, double v, double h) {
  double x = b->sigma0 * fabs(v) / level(b, v) * h;
  double phi1 = x > 1e-12 ? -expm1(-x) / x : 1.0 - 0.5 * x; /* (1 - e^-x) / x */
  return z * exp(-x) + v * h * phi1;
}

static int required(const mjModel* m, int instance, const char* key, double* value, int positive) {
  return ml_config_required(m, instance, PLUGIN, key, value, positive);
}

static int init(const mjModel* m, mjData* d, int instance) {
  Bristles b;
  double stribeck;
  memset(&b, 0, sizeof(b));
  b.actuator = ml_instance_actuator(m, instance, PLUGIN);
  if (b.actuator < 0) return -1;
  if (m->actuator_trntype[b.actuator] != mjTRN_JOINT) {
    mju_warning(PLUGIN ": actuator %d must act on a joint", b.actuator);
    return -1;
  }
  b.qpos = m->jnt_qposadr[m->actuator_trnid[2 * b.actuator]];
  if (m->actuator_actnum[b.actuator] != 1) {
    mju_warning(PLUGIN ": actuator %d needs actdim=\"1\" (z)", b.actuator);
    return -1;
  }
  if (required(m, instance, "sigma0", &b.sigma0, 1) || required(m, instance, "sigma1", &b.sigma1, 0)
      || required(m, instance, "coulomb", &b.coulomb, 0)
      || required(m, instance, "static", &b.stiction, 0)
      || required(m, instance, "stribeck_velocity", &stribeck, 1)) {
    return -1;
  }
  if (!(b.coulomb + b.stiction > 0.0)) {
    mju_warning(PLUGIN ": coulomb + static must be positive");
    return -1;
  }
  b.inv_stribeck = 1.0 / stribeck;
  return ml_keep(d, instance, &b, sizeof(b));
}

static int nstate(const mjModel* m, int instance) { return NSTATE; }

static void reset(const mjModel* m, mjtNum* plugin_state, void* plugin_data, int instance) {
  plugin_state[START_TIME] = 0.0;
  plugin_state[START_POSITION] = 0.0;
  plugin_state[HAVE_START] = 0.0;
}

/* The time since the recorded start of the step when this evaluation is one of RK4's later
   stages of that step (half a step or a whole step after it), else 0: then the evaluation starts
   a step (the first after a reset or a step, the same time again, or a state set elsewhere) and
   its time and position are recorded. */
static double into_step(const Bristles* b, const mjModel* m, mjData* d, mjtNum* state) {
  if (state[HAVE_START]) {
    double t = d->time - state[START_TIME], h = m->opt.timestep;
    double tol = 1e-9 * (h + fabs(d->time));
    if (fabs(t - 0.5 * h) <= tol || fabs(t - h) <= tol) return t;
  }
  state[START_TIME] = d->time;
  state[START_POSITION] = d->qpos[b->qpos];
  state[HAVE_START] = 1.0;
  return 0.0;
}

static void act_dot(const mjModel* m, mjData* d, int instance) {
  const Bristles* b = (const Bristles*)d->plugin_data[instance];
  d->act_dot[m->actuator_actadr[b->actuator]] = 0.0;
  into_step(b, m, d, d->plugin_state + m->plugin_stateadr[instance]);
}

static void advance(const mjModel* m, mjData* d, int instance) {
  const Bristles* b = (const Bristles*)d->plugin_data[instance];
  mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  double h = m->opt.timestep;
  int adr = m->actuator_actadr[b->actuator];
  /* MuJoCo has advanced the time by h; without a recorded start (the state was set at another
     time) the joint's current velocity stands for the step's mean */
  double since = d->time - state[START_TIME];
  int known = state[HAVE_START] && fabs(since - h) <= 1e-9 * (h + fabs(d->time));
  double v = known ? (d->qpos[b->qpos] - state[START_POSITION]) / h : d->qvel[m->jnt_dofadr[
      m->actuator_trnid[2 * b->actuator]]];
  d->act[adr] = relax(b, d->act[adr], v, h);
  state[HAVE_START] = 0.0;
}

/* The bristle force at this evaluation: at a later stage of the step, z taken from the step's
   start to now for the mean velocity since; at the start, z itself. */
static void compute(const mjModel* m, mjData* d, int instance, int capability_bit) {
  const Bristles* b = (const Bristles*)d->plugin_data[instance];
  int adr = m->actuator_actadr[b->actuator];
  double z = d->act[adr];
  mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  double t = into_step(b, m, d, state);
  if (t > 0.0) z = relax(b, z, (d->qpos[b->qpos] - state[START_POSITION]) / t, t);
  double zdot = rate(b, z, d->actuator_velocity[b->actuator]);
  d->actuator_force[b->actuator] = -(b->sigma0 * z + b->sigma1 * zdot);
}

void ml_register_lugre(const char* name) {
  mjpPlugin plugin;
  mjp_defaultPlugin(&plugin);
  plugin.name = name;
  plugin.capabilityflags |= mjPLUGIN_ACTUATOR;
  plugin.nattribute = sizeof(kAttributes) / sizeof(kAttributes[0]);
  plugin.attributes = kAttributes;
  plugin.nstate = nstate;
  plugin.init = init;
  plugin.destroy = ml_destroy;
  plugin.reset = reset;
  plugin.compute = compute;
  plugin.actuator_act_dot = act_dot;
  plugin.advance = advance;
  mjp_registerPlugin(&plugin);
}
