/* The valve-controlled hydraulic cylinder (the paper's eq. 4) as a MuJoCo actuator plugin.

   Activations (actdim 2): dP, the differential pressure (Pa), and Q, the valve flow (m^3/s).
   Control: the valve current i_v (A), clipped to the actuator's ctrlrange. Force: A dP.

     (V/E) d(dP)/dt = Q - A v - Le dP - Q_r(dP)      v = the actuator's velocity
       tau dQ/dt    = Q*(i_v, dP) - Q

   Q* = i_v C sqrt(max(0, 1 - s dP / Ps)), s = sign(i_v) for the orifice law (the default),
   s = sign(dP) for the paper's law; Q_r = K_r (|dP| - p_r) sign(dP) above the relief setting p_r.
   The law and the rates are valve.h's, which every other part of maniplab evaluates too.

   MuJoCo's integrator advances dP and Q with the arm (actuator_act_dot), so mj_step, rollout and
   the viewers all run it. The relief valve is stiff (its pressure decay rate K_r E/V reaches 1e4
   to 1e8 1/s), so it is not part of act_dot: after each step (`advance`) the pressure is taken
   through the relief's regime exactly, as a linear decay towards p_r under the step's mean rate
   of change, which MuJoCo's step gave (operator splitting; exact while the relief stays open).
   That needs the step's starting pressure: act_dot records it when evaluated at the step's start
   (its first evaluation after a reset or a step, or again at that same time). */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "plugins.h"
#include "valve.h"

#define PLUGIN "maniplab.hydraulic"

typedef struct {
  int actuator;
  ml_cylinder law;      /* eq. (4)'s parameters (valve.h) */
  double relief_cap;    /* p_r + C i_max / K_r, Pa: the open relief's pressure at full flow */
} Cylinder;

/* plugin_state of an instance: the step's start time and pressure, and whether they are set */
enum { START_TIME, START_PRESSURE, HAVE_START, NSTATE };

static const char* kAttributes[] = {
    "area", "bulk_modulus", "volume", "leakage", "valve_gain", "supply_pressure", "valve_tau",
    "valve_law", "relief_pressure", "relief_gain"};

/* The open relief from pressure p on side s (+-1) over a time t at the mean rate r (Pa/s):
   dp/dt = r - lambda (p - s p_r), solved exactly. */
static double open_relief(const ml_cylinder* c, double p, double s, double r, double t) {
  double lambda = c->stiffness * c->relief_gain;
  double x = lambda * t;
  double grow = x > 1e-8 ? -expm1(-x) : x * (1.0 - 0.5 * x);  /* 1 - e^-x */
  return s * c->relief + (p - s * c->relief) * (1.0 - grow) + r / lambda * grow;
}

/* The pressure after a step of length h that MuJoCo took from p0 to p1 without the relief, with
   the relief: the step's mean rate r = (p1 - p0)/h held, the valve opening and closing at p_r
   exactly (piecewise: closed, dp/dt = r; open, as open_relief). */
static double relieved(const ml_cylinder* c, double p0, double p1, double h) {
  double r = (p1 - p0) / h;
  double pr = c->relief;
  double lambda = c->stiffness * c->relief_gain;
  if (fabs(p0) <= pr) {                     /* closed: it opens where p reaches +-p_r */
    if (fabs(p1) <= pr) return p1;
    double s = p1 > 0.0 ? 1.0 : -1.0;
    double t1 = (s * pr - p0) / r;
    return open_relief(c, s * pr, s, r, h - t1);
  }
  double s = p0 > 0.0 ? 1.0 : -1.0;       /* open: it closes if the rate pulls p below p_r */
  double excess = p0 - s * pr;
  if (s * r >= 0.0) return open_relief(c, p0, s, r, h);
  double ratio = -r / (lambda * excess - r);  /* e^(-lambda t1) at the closing time t1 */
  double t1 = -log(ratio) / lambda;
  if (t1 >= h) return open_relief(c, p0, s, r, h);
  return s * pr + r * (h - t1);
}

static int required(const mjModel* m, int instance, const char* key, double* value, int positive) {
  return ml_config_required(m, instance, PLUGIN, key, value, positive);
}

static int init(const mjModel* m, mjData* d, int instance) {
  Cylinder c;
  memset(&c, 0, sizeof(c));
  ml_cylinder* eq = &c.law;
  double E, V, Ps, tau;
  c.actuator = ml_instance_actuator(m, instance, PLUGIN);
  if (c.actuator < 0) return -1;
  if (m->actuator_actnum[c.actuator] != 2) {
    mju_warning(PLUGIN ": actuator %d needs actdim=\"2\" (dP, Q)", c.actuator);
    return -1;
  }
  if (required(m, instance, "area", &eq->area, 1) || required(m, instance, "bulk_modulus", &E, 1)
      || required(m, instance, "volume", &V, 1)
      || required(m, instance, "leakage", &eq->leakage, 0)
      || required(m, instance, "valve_gain", &eq->valve_gain, 1)
      || required(m, instance, "supply_pressure", &Ps, 1)
      || required(m, instance, "valve_tau", &tau, 1)) {
    return -1;
  }
  eq->stiffness = E / V;
  eq->inv_supply = 1.0 / Ps;
  eq->inv_tau = 1.0 / tau;
  const char* law = mj_getPluginConfig(m, instance, "valve_law");
  if (law == NULL || law[0] == '\0' || strcmp(law, "orifice") == 0) {
    eq->orifice = 1;
  } else if (strcmp(law, "paper") == 0) {
    eq->orifice = 0;
  } else {
    mju_warning(PLUGIN ": config 'valve_law' = '%s'; expected 'orifice' or 'paper'", law);
    return -1;
  }
  int has_relief = ml_config_number(m, instance, "relief_pressure", &eq->relief);
  if (has_relief < 0) return -1;
  if (has_relief == 0) {
    if (!(eq->relief > 0.0) || required(m, instance, "relief_gain", &eq->relief_gain, 1)) {
      mju_warning(PLUGIN ": a relief needs a positive relief_pressure and relief_gain");
      return -1;
    }
    double limit = m->actuator_ctrllimited[c.actuator]
                       ? fmax(fabs(m->actuator_ctrlrange[2 * c.actuator]),
                              fabs(m->actuator_ctrlrange[2 * c.actuator + 1]))
                       : 1.0;
    c.relief_cap = eq->relief + eq->valve_gain * limit / eq->relief_gain;
  }
  return ml_keep(d, instance, &c, sizeof(c));
}

static int nstate(const mjModel* m, int instance) { return NSTATE; }

static void reset(const mjModel* m, mjtNum* plugin_state, void* plugin_data, int instance) {
  plugin_state[START_TIME] = 0.0;
  plugin_state[START_PRESSURE] = 0.0;
  plugin_state[HAVE_START] = 0.0;
}

static void act_dot(const mjModel* m, mjData* d, int instance) {
  const Cylinder* c = (const Cylinder*)d->plugin_data[instance];
  int adr = m->actuator_actadr[c->actuator];
  double dP = d->act[adr], Q = d->act[adr + 1];
  double v = d->actuator_velocity[c->actuator];
  double u = ml_control(m, d, c->actuator);
  ml_cylinder_rates_law(&c->law, dP, Q, u, v, 0, d->act_dot + adr);  /* the relief: advance */
  mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  if (c->law.relief > 0.0 && (!state[HAVE_START] || d->time == state[START_TIME])) {
    state[START_TIME] = d->time;
    state[START_PRESSURE] = dP;
    state[HAVE_START] = 1.0;
  }
}

static void advance(const mjModel* m, mjData* d, int instance) {
  const Cylinder* c = (const Cylinder*)d->plugin_data[instance];
  if (c->law.relief <= 0.0) return;
  mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  double h = m->opt.timestep;
  int adr = m->actuator_actadr[c->actuator];
  double p1 = d->act[adr];
  /* without a recorded start (the state was set at another time), hold p1 as the start */
  double since = d->time - state[START_TIME];  /* MuJoCo has advanced the time by h */
  int known = state[HAVE_START] && fabs(since - h) <= 1e-9 * (h + fabs(d->time));
  d->act[adr] = relieved(&c->law, known ? state[START_PRESSURE] : p1, p1, h);
  state[HAVE_START] = 0.0;
}

static void compute(const mjModel* m, mjData* d, int instance, int capability_bit) {
  const Cylinder* c = (const Cylinder*)d->plugin_data[instance];
  double dP = d->act[m->actuator_actadr[c->actuator]];
  /* within a step the pressure runs on without the relief (advance brings it back): the force
     sees at most what the open relief allows, p_r plus the full valve flow's override */
  if (c->law.relief > 0.0 && fabs(dP) > c->relief_cap) dP = copysign(c->relief_cap, dP);
  d->actuator_force[c->actuator] = c->law.area * dP;
}

void ml_register_hydraulic(const char* name) {
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
