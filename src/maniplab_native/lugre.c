/* LuGre friction (Canudas de Wit et al. 1995) on one joint as a MuJoCo actuator plugin.

   Activation (actdim 1): the bristle deflection z (m or rad). With v the actuator's velocity:

     g(v)   = Fc + Fs exp(-(v/vs)^2)
     dz/dt  = v - sigma0 |v| z / g(v)
     force  = -(sigma0 z + sigma1 dz/dt)         (sigma2 v is the joint's damping)

   The actuator takes no control (give it ctrllimited="false" and leave ctrl at 0). */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "plugins.h"

#define PLUGIN "maniplab.lugre"

typedef struct {
  int actuator;
  double sigma0, sigma1, coulomb, stiction, inv_stribeck;
} Bristles;

static const char* kAttributes[] = {"sigma0", "sigma1", "coulomb", "static", "stribeck_velocity"};

static double rate(const Bristles* b, double z, double v) {
  double r = v * b->inv_stribeck;
  double level = b->coulomb + b->stiction * exp(-r * r);
  return v - b->sigma0 * fabs(v) * z / level;
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

static int nstate(const mjModel* m, int instance) { return 0; }

static void reset(const mjModel* m, mjtNum* plugin_state, void* plugin_data, int instance) {}

static void act_dot(const mjModel* m, mjData* d, int instance) {
  const Bristles* b = (const Bristles*)d->plugin_data[instance];
  int adr = m->actuator_actadr[b->actuator];
  d->act_dot[adr] = rate(b, d->act[adr], d->actuator_velocity[b->actuator]);
}

static void compute(const mjModel* m, mjData* d, int instance, int capability_bit) {
  const Bristles* b = (const Bristles*)d->plugin_data[instance];
  int adr = m->actuator_actadr[b->actuator];
  double z = d->act[adr];
  double zdot = rate(b, z, d->actuator_velocity[b->actuator]);
  d->actuator_force[b->actuator] = -(b->sigma0 * z + b->sigma1 * zdot);
}

void ml_register_lugre(void) {
  mjpPlugin plugin;
  mjp_defaultPlugin(&plugin);
  plugin.name = PLUGIN;
  plugin.capabilityflags |= mjPLUGIN_ACTUATOR;
  plugin.nattribute = sizeof(kAttributes) / sizeof(kAttributes[0]);
  plugin.attributes = kAttributes;
  plugin.nstate = nstate;
  plugin.init = init;
  plugin.destroy = ml_destroy;
  plugin.reset = reset;
  plugin.compute = compute;
  plugin.actuator_act_dot = act_dot;
  mjp_registerPlugin(&plugin);
}
