/* The valve-controlled hydraulic cylinder (the paper's eq. 4) as a MuJoCo actuator plugin.

   Activations (actdim 2): dP, the differential pressure (Pa), and Q, the valve flow (m^3/s).
   Control: the valve current i_v (A), clipped to the actuator's ctrlrange. Force: A dP.

     (V/E) d(dP)/dt = Q - A v - Le dP - Q_r(dP)      v = the actuator's velocity
       tau dQ/dt    = Q*(i_v, dP) - Q

   Q* = i_v C sqrt(max(0, 1 - s dP / Ps)), s = sign(i_v) for the orifice law (the default),
   s = sign(dP) for the paper's law; Q_r = K_r (|dP| - p_r) sign(dP) above the relief setting p_r.
   The law and the rates are valve.h's, which every other part of maniplab evaluates too.

   MuJoCo's integrator advances dP and Q with the arm (actuator_act_dot), so mj_step, rollout and
   the viewers all run it. The relief valve is stiff (its pressure decay rate lambda = K_r E/V
   reaches 1e4 to 1e8 1/s), so it is not part of act_dot: MuJoCo's dP runs on without it, and
   every later evaluation inside a step (RK4's stages 2 to 4: their force and rates) and the
   step's end (`advance`) take that pressure through the relief's regime exactly from the step's
   start (`relieved`): the rate without the relief is taken as linear over the time since the start,
   from its value at the start to the value that gives MuJoCo's mean rate, and under it the
   pressure rises or falls freely while the relief is closed and relaxes at lambda towards p_r
   while it is open (an exponential integrator, exact for that rate), the relief opening and
   closing where the pressure reaches p_r. While the relief stays closed this is MuJoCo's dP
   itself, so RK4's fourth order is untouched. That needs the step's starting pressure and rate:
   they are recorded at every evaluation that is not one of RK4's later stages (half a step or a
   whole step after the recorded start), so at each step's start. The valve flow Q is MuJoCo's
   too, except over a step whose pressure crosses a kink of the valve law (below), where it is
   taken from the exact lag of the valve's flow over the step. */
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
} Cylinder;

/* plugin_state of an instance: the step's start time, pressure and rate without the relief
   (Pa/s), whether they are set, and the valve flow Q at the start */
enum { START_TIME, START_PRESSURE, START_RATE, HAVE_START, START_FLOW, NSTATE };

static const char* kAttributes[] = {
    "area", "bulk_modulus", "volume", "leakage", "valve_gain", "supply_pressure", "valve_tau",
    "valve_law", "relief_pressure", "relief_gain"};

/* phi1(x) = (1 - e^-x)/x and phi2(x) = (x - 1 + e^-x)/x^2, x >= 0 (their series near 0). */
static void phis(double x, double* phi1, double* phi2) {
  if (x < 1e-3) {
    *phi1 = 1.0 - x * (0.5 - x * (1.0 / 6.0 - x / 24.0));
    *phi2 = 0.5 - x * (1.0 / 6.0 - x * (1.0 / 24.0 - x / 120.0));
    return;
  }
  double grow = -expm1(-x); /* 1 - e^-x */
  *phi1 = grow / x;
  *phi2 = (x - grow) / (x * x);
}

/* The open relief's excess e = p - s p_r after a time u from e, under the rate r + k t:
   de/dt = r + k t - lambda e, solved exactly. */
static double open_excess(double e, double r, double k, double lambda, double u) {
  double x = lambda * u, phi1, phi2;
  phis(x, &phi1, &phi2);
  return e * exp(-x) + u * (r * phi1 + k * u * phi2);
}

/* The real roots of a u^2 + b u + c = 0 into roots (the form that loses no digits to
   cancellation; one root where a = 0): their count. */
static int quadratic_roots(double a, double b, double c, double* roots) {
  if (a == 0.0) {
    if (b == 0.0) return 0;
    roots[0] = -c / b;
    return 1;
  }
  double disc = b * b - 4.0 * a * c;
  if (disc < 0.0) return 0;
  double q = -0.5 * (b + copysign(sqrt(disc), b));
  if (q == 0.0) {
    roots[0] = 0.0;
    return 1;
  }
  roots[0] = q / a;
  roots[1] = c / q;
  return 2;
}

/* The first time u in (0, t] at which the closed valve's pressure p + r u + k u^2/2 reaches the
   relief setting on either side (moving outwards), or -1. */
static double opening(double p, double r, double k, double pr, double t) {
  double first = -1.0;
  for (int side = -1; side <= 1; side += 2) {
    double roots[2];
    int n = quadratic_roots(0.5 * k, r, p - side * pr, roots);
    for (int i = 0; i < n; i++) {
      double u = roots[i];
      if (u > 0.0 && u <= t && side * (r + k * u) > 0.0 && (first < 0.0 || u < first)) first = u;
    }
  }
  return first;
}

/* The time u in (0, t) at which the open relief, s e > 0 now and s e(t) < 0, closes: the root of
   its exact excess (safeguarded Newton). */
static double closing(double e, double s, double r, double k, double lambda, double t) {
  double lo = 0.0, hi = t, u = 0.5 * t;
  for (int i = 0; i < 60; i++) {
    double f = s * open_excess(e, r, k, lambda, u);
    if (f > 0.0) {
      lo = u;
    } else if (f < 0.0) {
      hi = u;
    } else {
      return u;
    }
    double slope = s * (r + k * u) - lambda * f; /* d(s e)/du */
    double next = slope < 0.0 ? u - f / slope : lo;
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (fabs(next - u) <= 1e-14 * t) return next;
    u = next;
  }
  return u;
}

/* The pressure a time t after a step's start at p0, with the relief, the rate without it taken
   as linear over the time, from r0 at the start to r1 (closed, dp/dt = r; open, open_excess),
   the valve opening and closing at p_r exactly. While the relief stays closed that is p_closed,
   the pressure MuJoCo's integration reached without it. */
static double relieved(const ml_cylinder* c, double p0, double r0, double r1, double p_closed,
                       double t) {
  if (!isfinite(p0 + r0 + r1 + p_closed)) return p0 + r0 + r1 + p_closed; /* NaN stays NaN */
  double pr = c->relief, lambda = c->stiffness * c->relief_gain;
  double k = (r1 - r0) / t;
  double p = p0, r = r0, left = t;
  for (int phase = 0; phase < 8 && left > 0.0; phase++) {
    double s = p >= 0.0 ? 1.0 : -1.0;
    if (fabs(p) < pr || (fabs(p) == pr && s * r <= 0.0)) { /* closed */
      double u = opening(p, r, k, pr, left);
      if (u < 0.0) return phase == 0 ? p_closed : p + left * (r + 0.5 * k * left);
      s = r + k * u > 0.0 ? 1.0 : -1.0;
      p = s * pr;
      r += k * u;
      left -= u;
    } else { /* open */
      double e = p - s * pr;
      double end = open_excess(e, r, k, lambda, left);
      if (s * end >= 0.0) return s * pr + end;
      double u = closing(e, s, r, k, lambda, left);
      p = s * pr;
      r += k * u;
      left -= u;
    }
  }
  return p;
}

/* relieved from the step's start (p0, rate r0) to the pressure p1 that MuJoCo's integration
   reached without the relief a time t later: the rate taken as linear with the mean (p1 - p0)/t,
   so ending at 2 (p1 - p0)/t - r0. */
static double relieved_since(const ml_cylinder* c, double p0, double r0, double p1, double t) {
  return relieved(c, p0, r0, 2.0 * (p1 - p0) / t - r0, p1, t);
}

/* --- the valve flow through the root's kinks -----------------------------------------------
   Where the valve law's root vanishes (the load pressure reaches the supply's on the side the flow
   comes from; for the paper's law also where dP changes sign) the steady flow Q* has a kink, with
   an infinite slope at the root: a fixed-step scheme passes it at a lower order than its own (RK4
   left patu655's slew 1.3e-3 of its range off at 1 ms). A step whose pressure crosses a kink
   takes Q instead from the exact solution of tau dQ/dt = Q* - Q over the step,

     Q(h) = e^(-h/tau) Q0 + (1/tau) int_0^h e^(-(h-u)/tau) Q*(dP(u)) du,

   with dP(u) the quadratic through the start's pressure and rate and the end's pressure,
   integrated piecewise between the kinks by 8-point Gauss-Legendre in theta, u = a + (b - a)
   (1 - cos theta)/2, which makes a square root at either end of a piece smooth. A step that
   crosses none keeps the integrator's Q. */
static const double kPi = 3.14159265358979323846;
static const double kGaussX[4] = {0.1834346424956498, 0.5255324099163290, 0.7966664774136267,
                                  0.9602898564975363};
static const double kGaussW[4] = {0.3626837833783620, 0.3137066458778873, 0.2223810344533745,
                                  0.1012285362903763};

/* The times in (0, h) where p0 + r u + k u^2 = level, appended to times[*count]. */
static void crossings(double p0, double r, double k, double level, double h, double* times,
                      int* count) {
  double roots[2];
  int n = quadratic_roots(k, r, p0 - level, roots);
  for (int i = 0; i < n; i++) {
    if (roots[i] > 0.0 && roots[i] < h) times[(*count)++] = roots[i];
  }
}

/* (1/tau) int_a^b e^(-(h-u)/tau) Q*(p0 + r u + k u^2) du at the current i_v. */
static double lag_integral(const ml_cylinder* c, double current, double p0, double r, double k,
                           double a, double b, double h) {
  double sum = 0.0;
  for (int i = 0; i < 4; i++) {
    for (int side = -1; side <= 1; side += 2) {
      double theta = 0.5 * kPi * (1.0 + side * kGaussX[i]);
      double u = a + 0.5 * (b - a) * (1.0 - cos(theta));
      double du = 0.25 * kPi * (b - a) * sin(theta); /* du/dx, x the Gauss variable */
      double flow = ml_valve_flow_law(current, p0 + u * (r + k * u), c->valve_gain,
                                      c->inv_supply, c->orifice);
      sum += kGaussW[i] * du * exp(-(h - u) * c->inv_tau) * flow;
    }
  }
  return c->inv_tau * sum;
}

/* Q at the step's end: the integrator's `integrated`, or, when the pressure crosses a kink of the
   valve law within the step, the exact lag of the valve flow over it (above). */
static double lagged_flow(const ml_cylinder* c, double current, double q0, double p0, double r0,
                          double p1, double h, double integrated) {
  double k = (p1 - p0 - r0 * h) / (h * h), cuts[8];
  int count = 0;
  double supply = 1.0 / c->inv_supply;
  if (current == 0.0 || !isfinite(p0 + r0 + p1 + q0)) return integrated;
  if (c->orifice) {
    crossings(p0, r0, k, current > 0.0 ? supply : -supply, h, cuts, &count);
  } else {
    crossings(p0, r0, k, supply, h, cuts, &count);
    crossings(p0, r0, k, -supply, h, cuts, &count);
    crossings(p0, r0, k, 0.0, h, cuts, &count);
  }
  if (count == 0) return integrated;
  for (int i = 1; i < count; i++) { /* sort the few cut times */
    for (int j = i; j > 0 && cuts[j] < cuts[j - 1]; j--) {
      double t = cuts[j];
      cuts[j] = cuts[j - 1];
      cuts[j - 1] = t;
    }
  }
  double flow = exp(-h * c->inv_tau) * q0, from = 0.0;
  for (int i = 0; i <= count; i++) {
    double to = i < count ? cuts[i] : h;
    flow += lag_integral(c, current, p0, r0, k, from, to, h);
    from = to;
  }
  return flow;
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
  }
  return ml_keep(d, instance, &c, sizeof(c));
}

static int nstate(const mjModel* m, int instance) { return NSTATE; }

static void reset(const mjModel* m, mjtNum* plugin_state, void* plugin_data, int instance) {
  plugin_state[START_TIME] = 0.0;
  plugin_state[START_PRESSURE] = 0.0;
  plugin_state[START_RATE] = 0.0;
  plugin_state[HAVE_START] = 0.0;
}

/* d(dP)/dt without the relief, Pa/s. */
static double inflow(const Cylinder* c, double dP, double Q, double v) {
  return c->law.stiffness * (Q - c->law.area * v - c->law.leakage * dP);
}

/* The time since the recorded start of the step when this evaluation is one of RK4's later
   stages of that step (half a step or a whole step after it), else 0: the evaluation starts a
   step (the first after a reset or a step, the same time again, or a state set elsewhere). */
static double into_step(const mjModel* m, const mjData* d, const mjtNum* state) {
  if (!state[HAVE_START]) return 0.0;
  double t = d->time - state[START_TIME], h = m->opt.timestep;
  double tol = 1e-9 * (h + fabs(d->time));
  return fabs(t - 0.5 * h) <= tol || fabs(t - h) <= tol ? t : 0.0;
}

/* dP as the force and the rates see it at this evaluation. At a step's start, dP, and the start
   (time, pressure, rate without the relief, flow) is recorded; at a later stage with a relief,
   MuJoCo's dP, which runs on without the relief, taken through the relief's regime from the start
   (relieved_since). */
static double pressure(const mjModel* m, mjData* d, int instance, const Cylinder* c) {
  int adr = m->actuator_actadr[c->actuator];
  mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  double dP = d->act[adr], t = into_step(m, d, state);
  if (t == 0.0) {
    state[START_TIME] = d->time;
    state[START_PRESSURE] = dP;
    state[START_RATE] = inflow(c, dP, d->act[adr + 1], d->actuator_velocity[c->actuator]);
    state[START_FLOW] = d->act[adr + 1];
    state[HAVE_START] = 1.0;
    return dP;
  }
  if (c->law.relief <= 0.0) return dP;
  return relieved_since(&c->law, state[START_PRESSURE], state[START_RATE], dP, t);
}

static void act_dot(const mjModel* m, mjData* d, int instance) {
  const Cylinder* c = (const Cylinder*)d->plugin_data[instance];
  int adr = m->actuator_actadr[c->actuator];
  double dP = pressure(m, d, instance, c);
  ml_cylinder_rates_law(&c->law, dP, d->act[adr + 1], ml_control(m, d, c->actuator),
                        d->actuator_velocity[c->actuator], 0, d->act_dot + adr);
}

static void advance(const mjModel* m, mjData* d, int instance) {
  const Cylinder* c = (const Cylinder*)d->plugin_data[instance];
  mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  double h = m->opt.timestep;
  int adr = m->actuator_actadr[c->actuator];
  double p1 = d->act[adr];
  double since = d->time - state[START_TIME]; /* MuJoCo has advanced the time by h */
  int known = state[HAVE_START] && fabs(since - h) <= 1e-9 * (h + fabs(d->time));
  if (c->law.relief > 0.0) {
    /* without a recorded start (the state was set at another time), p1 held over the step */
    d->act[adr] = known ? relieved_since(&c->law, state[START_PRESSURE], state[START_RATE], p1, h)
                        : relieved(&c->law, p1, 0.0, 0.0, p1, h);
  }
  if (known) {
    d->act[adr + 1] = lagged_flow(&c->law, ml_control(m, d, c->actuator), state[START_FLOW],
                                  state[START_PRESSURE], state[START_RATE], d->act[adr], h,
                                  d->act[adr + 1]);
  }
  state[HAVE_START] = 0.0;
}

static void compute(const mjModel* m, mjData* d, int instance, int capability_bit) {
  const Cylinder* c = (const Cylinder*)d->plugin_data[instance];
  d->actuator_force[c->actuator] = c->law.area * pressure(m, d, instance, c);
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
