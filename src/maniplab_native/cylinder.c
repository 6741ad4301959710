/* The pinned two-chamber cylinder (chambers.h) as a MuJoCo actuator plugin.

   The actuator acts on a spatial tendon between the cylinder's pins: its length is the
   cylinder's s, its velocity ds/dt, and MuJoCo applies the force F along it (the moment arm
   ds/dq is the tendon's). Activations (actdim 3): pA, pB (Pa) and the spool's opening x.
   Control: the valve current (A), clipped to the ctrlrange.

   MuJoCo's integrator advances the three states with the arm (actuator_act_dot). The relief and
   anti-cavitation valves are ideal: after each step (`advance`) each pressure is brought back
   within [Pt, p_r], and within a step the force sees it there (`compute`). */
#include <math.h>
#include <string.h>

#include "chambers.h"
#include "plugins.h"

#define PLUGIN "maniplab.cylinder"

typedef struct {
  int actuator;
  ml_chambers law;
} Cylinder;

static const char* kAttributes[] = {
    "area_a", "area_b", "dead_a", "dead_b", "min_length", "stroke", "bulk_modulus", "leakage",
    "gain_a", "gain_b", "laminar", "supply_pressure", "tank_pressure", "relief_pressure",
    "valve_tau", "current_limit"};

static int required(const mjModel* m, int instance, const char* key, double* value, int positive) {
  return ml_config_required(m, instance, PLUGIN, key, value, positive);
}

static int read_law(const mjModel* m, int instance, ml_chambers* c) {
  double tau, limit;
  if (required(m, instance, "area_a", &c->area_a, 1) ||
      required(m, instance, "area_b", &c->area_b, 1) ||
      required(m, instance, "dead_a", &c->dead_a, 1) ||
      required(m, instance, "dead_b", &c->dead_b, 1) ||
      required(m, instance, "min_length", &c->min_length, 1) ||
      required(m, instance, "stroke", &c->stroke, 1) ||
      required(m, instance, "bulk_modulus", &c->bulk_modulus, 1) ||
      required(m, instance, "leakage", &c->leakage, 0) ||
      required(m, instance, "gain_a", &c->gain_a, 1) ||
      required(m, instance, "gain_b", &c->gain_b, 1) ||
      required(m, instance, "laminar", &c->laminar, 1) ||
      required(m, instance, "supply_pressure", &c->supply, 1) ||
      required(m, instance, "tank_pressure", &c->tank, 0) ||
      required(m, instance, "valve_tau", &tau, 1) ||
      required(m, instance, "current_limit", &limit, 1)) {
    return -1;
  }
  c->inv_tau = 1.0 / tau;
  c->inv_current = 1.0 / limit;
  c->relief = 0.0;
  int has_relief = ml_config_number(m, instance, "relief_pressure", &c->relief);
  if (has_relief < 0) return -1;
  if (has_relief == 0 && !(c->relief > c->tank)) {
    mju_warning(PLUGIN ": relief_pressure %g must be above tank_pressure %g", c->relief, c->tank);
    return -1;
  }
  if (!(c->supply > c->tank)) {
    mju_warning(PLUGIN ": supply_pressure %g must be above tank_pressure %g", c->supply, c->tank);
    return -1;
  }
  return 0;
}

static int init(const mjModel* m, mjData* d, int instance) {
  Cylinder c;
  memset(&c, 0, sizeof(c));
  c.actuator = ml_instance_actuator(m, instance, PLUGIN);
  if (c.actuator < 0) return -1;
  if (m->actuator_actnum[c.actuator] != 3) {
    mju_warning(PLUGIN ": actuator %d needs actdim=\"3\" (pA, pB, spool)", c.actuator);
    return -1;
  }
  if (m->actuator_trntype[c.actuator] != mjTRN_TENDON) {
    mju_warning(PLUGIN ": actuator %d must act on a tendon between the cylinder's pins",
                c.actuator);
    return -1;
  }
  if (read_law(m, instance, &c.law)) return -1;
  return ml_keep(d, instance, &c, sizeof(c));
}

static int nstate(const mjModel* m, int instance) { return 0; }

static void act_dot(const mjModel* m, mjData* d, int instance) {
  const Cylinder* c = (const Cylinder*)d->plugin_data[instance];
  int adr = m->actuator_actadr[c->actuator];
  const double* x = d->act + adr;
  ml_chambers_rates_law(&c->law, x[0], x[1], x[2], ml_control(m, d, c->actuator),
                        d->actuator_length[c->actuator], d->actuator_velocity[c->actuator],
                        d->act_dot + adr);
}

static void advance(const mjModel* m, mjData* d, int instance) {
  const Cylinder* c = (const Cylinder*)d->plugin_data[instance];
  double* x = d->act + m->actuator_actadr[c->actuator];
  x[0] = ml_chamber_bounded(&c->law, x[0]);
  x[1] = ml_chamber_bounded(&c->law, x[1]);
}

static void compute(const mjModel* m, mjData* d, int instance, int capability_bit) {
  const Cylinder* c = (const Cylinder*)d->plugin_data[instance];
  const double* x = d->act + m->actuator_actadr[c->actuator];
  d->actuator_force[c->actuator] = ml_chambers_force_law(&c->law, x[0], x[1]);
}

void ml_register_cylinder(void) {
  mjpPlugin plugin;
  mjp_defaultPlugin(&plugin);
  plugin.name = PLUGIN;
  plugin.capabilityflags |= mjPLUGIN_ACTUATOR;
  plugin.nattribute = sizeof(kAttributes) / sizeof(kAttributes[0]);
  plugin.attributes = kAttributes;
  plugin.nstate = nstate;
  plugin.init = init;
  plugin.destroy = ml_destroy;
  plugin.compute = compute;
  plugin.actuator_act_dot = act_dot;
  plugin.advance = advance;
  mjp_registerPlugin(&plugin);
}
