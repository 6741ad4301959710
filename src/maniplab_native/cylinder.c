/* The pinned two-chamber cylinder (chambers.h) as a MuJoCo actuator plugin.

   The actuator acts on a spatial tendon between the cylinder's pins: its length is the
   cylinder's s, its velocity ds/dt, and MuJoCo applies the force F along it (the moment arm
   ds/dq is the tendon's). Activations (actdim 3): pA, pB (Pa) and the spool's opening x.
   Control: the valve current (A), clipped to the ctrlrange.

   With a config pump_flow (the spec's shared `supply:`), the cylinders that have it share one
   pump: its pressure falls below the setting when their valves together would draw more than
   pump_flow (chambers.h), so that cylinders moving together slow down. With pump_ls_margin too,
   the pump is load-sensing: its pressure is the highest load-sense pressure plus the margin, at
   most the setting (its cut-off), taken quasi-statically (a pump's swash plate answers in tens
   of milliseconds; the pressure follows the sections' states within each step as the flow limit
   does).

   The three states are stiff (a small chamber filling through a wide-open edge decays at up to
   1e6 1/s), so MuJoCo's integrator does not take them: each step they take one exponential
   Rosenbrock-Euler step (stiff.h) of their own, exact for the linear part of their dynamics and
   stable at any step, so that the step is the arm mechanics' (the oil spring included). The
   first act_dot of a step records the step's start (the states, the cylinder's length and rate,
   the supply pressure); at each stage of MuJoCo's integrator within the step, the force
   (`compute`) comes from the states taken by that step from the start to the stage's time, with
   the cylinder moving as the stage has it move; after the step (`advance`) the states are taken
   from the start to the step's end, with the rate from the advanced joint velocities, and
   replace what the integrator made of act_dot (which reports the states' rate of change at each
   stage, for the record). The coupling to the mechanics is second order.

   The relief and anti-cavitation valves are ideal: after each step each pressure is brought
   back within [Pt, p_r], and within a step the force sees it there (`compute`). */
#include <math.h>
#include <string.h>

#include "chambers.h"
#include "plugins.h"

#define PLUGIN "maniplab.cylinder"
#define ML_MAX_PUMPED 64 /* the most reversing sections a pump's step is split at */

typedef struct {
  int actuator;
  int output;           /* the actuator's force output (its length, velocity and force) */
  ml_chambers law;
  double pump_flow;     /* Q_max of the shared supply, m^3/s; 0: a supply of its own */
  double ls_margin;     /* a load-sensing pump's margin, Pa; 0: a constant-pressure pump */
  double pump_tau;      /* the pump pressure's response time, s; 0: quasi-static */
} Cylinder;

static int g_slot = -1;  /* this plugin's registered slot */

/* plugin_state of an instance: the step's start (time, states, length, rate, supply pressure),
   whether it is recorded, the states predicted for the step's end (a shared pump's), on a
   load-sensing pump the other sections' highest load-sense pressure over the step, the supply
   pressure at the step's end (it goes linearly from START_SUPPLY), and a pump with a response
   time its own pressure (PUMP_P, once PUMP_SET), whether the pump's step is still to be taken
   (PUMP_DUE: set at the step's start, cleared by the first cylinder's `advance` for all on the
   pump), whether the step's supply pressure is a measured one (MEASURED); then the energies
   since the last reset
   (chambers.h's ML_E_* terms, J, and the supply pressure's integral; Python zeroes them when a
   run starts) */
enum { START_TIME, HAVE_START, START_Y, START_S = START_Y + 3, START_SDOT, START_SUPPLY, PRED_Y,
       START_OTHERS = PRED_Y + 3, END_SUPPLY, PUMP_P, PUMP_SET, PUMP_DUE, MEASURED, ENERGY,
       NSTATE = ENERGY + ML_ACCUMULATED };

/* Where an instance's energies start in its plugin_state, and how many there are (for the
   recorder, which reads them from the recorded plugin states); the supply pressure's time
   integral follows them. */
int ml_cylinder_energy_slot(int* count) {
  *count = ML_ENERGIES;
  return ENERGY;
}

static const char* kAttributes[] = {
    "area_a", "area_b", "dead_a", "dead_b", "min_length", "stroke", "bulk_modulus", "leakage",
    "gain_a", "gain_b", "laminar", "supply_pressure", "tank_pressure", "relief_pressure",
    "valve_tau", "current_limit", "pump_flow", "out_a", "out_b", "compensator_margin",
    "pump_ls_margin", "deadband", "characteristic", "pump_response", "flow_sharing", "cushion",
    "holding_a", "holding_b", "burst_gain"};

static int required(const mjModel* m, int instance, const char* key, double* value, int positive) {
  return ml_config_required(m, instance, PLUGIN, key, value, positive);
}

static int read_characteristic(const mjModel* m, int instance, ml_chambers* c);

/* An optional positive config number into *value (left as it is when absent); -1 on a bad one. */
static int optional_positive(const mjModel* m, int instance, const char* key, double* value) {
  double read = *value;
  int status = ml_config_number(m, instance, key, &read);
  if (status < 0) return -1;
  if (status == 0) {
    if (!(read > 0.0)) {
      mju_warning(PLUGIN ": %s %g must be positive", key, read);
      return -1;
    }
    *value = read;
  }
  return 0;
}

/* A chamber's load-holding valve "type setting ratio gain band leakage" (chambers.h's hold_*:
   type 1 counterbalance, 2 pilot-operated check), into slot k; none when absent. */
static int read_holding(const mjModel* m, int instance, const char* key, int k, ml_chambers* c) {
  double v[6];
  int count = ml_config_numbers(m, instance, key, v, 6);
  if (count < 0) return -1;
  if (count == 0) return 0;
  if (count != 6 || (v[0] != ML_HOLD_COUNTERBALANCE && v[0] != ML_HOLD_PILOT_CHECK) ||
      !(v[1] >= 0.0) || !(v[2] > 0.0) || !(v[3] > 0.0) || !(v[4] > 0.0) || !(v[5] >= 0.0)) {
    mju_warning(PLUGIN ": %s needs 'type setting ratio gain band leakage': type 1 or 2, the "
                "ratio, gain and band positive, setting and leakage not negative", key);
    return -1;
  }
  c->hold_type[k] = v[0];
  c->hold_setting[k] = v[1];
  c->hold_ratio[k] = v[2];
  c->hold_gain[k] = v[3];
  c->hold_band[k] = v[4];
  c->hold_leakage[k] = v[5];
  return 0;
}

/* A burst line's open end when the spec gives no hose bore: half an inch, discharge
   coefficient 0.7, oil of 870 kg/m^3 (K = C_d pi d^2 / 4 sqrt(2 / rho)), m^3/(s sqrt(Pa)). */
#define ML_BURST_GAIN (0.7 * 0.25 * 3.141592653589793 * 0.0127 * 0.0127 * 0.04794633014853841)

static int read_law(const mjModel* m, int instance, ml_chambers* c) {
  double tau, limit;
  c->burst_gain[0] = c->burst_gain[1] = ML_BURST_GAIN;
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
  /* optional (a file written before they existed): meter-out gains as the meter-in's, and no
     compensator */
  c->out_a = c->gain_a;
  c->out_b = c->gain_b;
  c->margin = 0.0;
  if (optional_positive(m, instance, "out_a", &c->out_a) ||
      optional_positive(m, instance, "out_b", &c->out_b) ||
      optional_positive(m, instance, "compensator_margin", &c->margin) ||
      optional_positive(m, instance, "deadband", &c->deadband)) {
    return -1;
  }
  if (!(c->deadband < limit)) {
    mju_warning(PLUGIN ": deadband %g must be below current_limit %g", c->deadband, limit);
    return -1;
  }
  if (read_characteristic(m, instance, c)) return -1;
  double sharing = 0.0;
  if (ml_config_number(m, instance, "flow_sharing", &sharing) < 0) return -1;
  if (sharing != 0.0 && sharing != 1.0) {
    mju_warning(PLUGIN ": flow_sharing %g must be 0 or 1", sharing);
    return -1;
  }
  if (sharing == 1.0 && c->margin > 0.0) {
    mju_warning(PLUGIN ": flow_sharing and compensator_margin exclude each other");
    return -1;
  }
  c->post = sharing;
  double cushion[2];
  int count = ml_config_numbers(m, instance, "cushion", cushion, 2);
  if (count < 0) return -1;
  if (count) {
    if (count != 2 || !(cushion[0] > 0.0) || !(cushion[1] > 0.0) || !(cushion[0] < c->stroke)) {
      mju_warning(PLUGIN ": cushion needs 'length gain', both positive, the length below the "
                  "stroke %g m", c->stroke);
      return -1;
    }
    c->cushion_length = cushion[0];
    c->cushion_gain = cushion[1];
  }
  if (read_holding(m, instance, "holding_a", 0, c) || read_holding(m, instance, "holding_b", 1, c)) {
    return -1;
  }
  int ends = ml_config_numbers(m, instance, "burst_gain", c->burst_gain, 2);
  if (ends < 0 || (ends && (ends != 2 || !(c->burst_gain[0] > 0.0) || !(c->burst_gain[1] > 0.0)))) {
    mju_warning(PLUGIN ": burst_gain needs two positive gains (the A and B lines' open ends)");
    return -1;
  }
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

/* The opening characteristic "u1 x1 u2 x2 ...": 2 to ML_VALVE_POINTS points, commands ascending,
   openings non-decreasing within -1..1. */
static int read_characteristic(const mjModel* m, int instance, ml_chambers* c) {
  double pairs[2 * ML_VALVE_POINTS];
  int count = ml_config_numbers(m, instance, "characteristic", pairs, 2 * ML_VALVE_POINTS);
  if (count < 0) return -1;
  if (count == 0) return 0;
  if (count % 2 || count < 4) {
    mju_warning(PLUGIN ": characteristic needs 2 to %d (command, opening) pairs", ML_VALVE_POINTS);
    return -1;
  }
  for (int k = 0; k < count / 2; k++) {
    c->point_u[k] = pairs[2 * k];
    c->point_x[k] = pairs[2 * k + 1];
    if (fabs(c->point_x[k]) > 1.0 ||
        (k > 0 && !(c->point_u[k] > c->point_u[k - 1] && c->point_x[k] >= c->point_x[k - 1]))) {
      mju_warning(PLUGIN ": characteristic point %d: commands must rise, openings within -1..1 "
                  "must not fall", k);
      return -1;
    }
  }
  c->points = count / 2;
  return 0;
}

static int init(const mjModel* m, mjData* d, int instance) {
  Cylinder c;
  memset(&c, 0, sizeof(c));
  c.actuator = ml_instance_actuator(m, instance, PLUGIN);
  if (c.actuator < 0) return -1;
  c.output = m->actuator_outadr[c.actuator];
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
  int shared = ml_config_number(m, instance, "pump_flow", &c.pump_flow);
  if (shared < 0) return -1;
  if (shared == 0 && !(c.pump_flow > 0.0)) {
    mju_warning(PLUGIN ": pump_flow %g must be positive", c.pump_flow);
    return -1;
  }
  if (optional_positive(m, instance, "pump_ls_margin", &c.ls_margin) ||
      optional_positive(m, instance, "pump_response", &c.pump_tau)) {
    return -1;
  }
  return ml_keep(d, instance, &c, sizeof(c));
}

static int nstate(const mjModel* m, int instance) { return NSTATE; }

static void reset(const mjModel* m, mjtNum* plugin_state, void* plugin_data, int instance) {
  for (int k = 0; k < NSTATE; k++) plugin_state[k] = 0.0;
}

/* The cylinder's rate ds/dt from the joint velocities d->qvel and the actuator's moments. */
static double length_rate(const mjModel* m, const mjData* d, const Cylinder* c) {
  int start = d->moment_rowadr[c->output], count = d->moment_rownnz[c->output];
  double rate = 0.0;
  for (int k = start; k < start + count; k++) {
    rate += d->actuator_moment[k] * d->qvel[d->moment_colind[k]];
  }
  return rate;
}

/* Which states a cylinder's valve draws with: d->act's (CURRENT) or those predicted for the
   step's end (PREDICTED, plugin_state's). */
enum { CURRENT, PREDICTED };

static const double* drawing_states(const mjModel* m, const mjData* d, int i, const Cylinder* c,
                                    int which) {
  if (which == PREDICTED) return d->plugin_state + m->plugin_stateadr[i] + PRED_Y;
  return d->act + m->actuator_actadr[c->actuator];
}

/* Which of the cylinder's lines have burst by the time t: a run's scenario writes the time a
   chamber's line bursts into d->userdata[2 + 2 actuator + k] (0: it does not), the model
   holding nuserdata >= 2 + 2 nu. */
static void burst_lines(const mjModel* m, const mjData* d, const Cylinder* c, double t,
                        ml_chambers* law) {
  int slot = 2 + 2 * c->actuator;
  for (int k = 0; k < 2; k++) {
    double when = slot + k < m->nuserdata ? d->userdata[slot + k] : 0.0;
    law->burst[k] = when > 0.0 && t >= when ? 1.0 : 0.0;
  }
}

static double sensed_max(const mjModel* m, const mjData* d, int skip, double tank, int predicted);

/* The shared supply's total draw at pressure ps: every cylinder of this plugin on the pump, at
   its current (or predicted) states. */
static double pump_draw(const mjModel* m, const mjData* d, double ps, int predicted) {
  double total = 0.0;
  for (int i = 0; i < m->nplugin; i++) {
    const Cylinder* c = (const Cylinder*)d->plugin_data[i];
    if (m->plugin[i] != g_slot || c == NULL || c->pump_flow <= 0.0) continue;
    const double* x = drawing_states(m, d, i, c, predicted);
    ml_chambers law = c->law;
    burst_lines(m, d, c, d->time, &law);
    if (law.post > 0.0) law.ls_others = sensed_max(m, d, i, law.tank, predicted);
    total += ml_supply_draw(&law, x[2], x[0], x[1], ps);
  }
  return total;
}

/* The chamber a section's load-sense line reads with its spool's opening on the side `way`:
   0 (A), 1 (B), or -1 (closed: the tank's). */
static int sensed_chamber(double way) { return way > 0.0 ? 0 : (way < 0.0 ? 1 : -1); }

/* A load-sensing pump's target at the highest load-sense pressure `highest`: that plus its
   margin, at most its setting (the cut-off), Pa. */
static double ls_target(const Cylinder* c, double highest) {
  double high = highest + c->ls_margin;
  return high < c->law.supply ? high : c->law.supply;
}

/* The highest load-sense pressure of the cylinders on the shared pump but `skip` (-1: none): the
   chamber an open (or opening) section's meter-in edge feeds, the tank's for a closed one. */
static double sensed_max(const mjModel* m, const mjData* d, int skip, double tank, int predicted) {
  double highest = tank;
  for (int i = 0; i < m->nplugin; i++) {
    const Cylinder* c = (const Cylinder*)d->plugin_data[i];
    if (i == skip || m->plugin[i] != g_slot || c == NULL || c->pump_flow <= 0.0) continue;
    const double* x = drawing_states(m, d, i, c, predicted);
    /* a spool at 0 that its command opens senses the side it opens to at once (it is open an
       instant later: the load-sense pressure jumps there, not a step later) */
    double way = x[2] != 0.0 ? x[2] : ml_spool_target(&c->law, ml_control(m, d, c->actuator));
    int k = sensed_chamber(way);
    double sensed = k < 0 ? tank : x[k];
    highest = sensed > highest ? sensed : highest;
  }
  return highest;
}

/* What the pump offers at these states: its setting, or a load-sensing pump's highest
   load-sense pressure plus its margin, at most its setting (the cut-off). */
static double pump_target(const mjModel* m, const mjData* d, const Cylinder* c, int predicted) {
  if (c->ls_margin <= 0.0) return c->law.supply;
  return ls_target(c, sensed_max(m, d, -1, c->law.tank, predicted));
}

/* The time within a step of h (s) at which a section's spool, lagging from x0 towards its
   command's opening, passes 0 (it reverses), or h when it does not within the step. */
static double spool_crossing(const Cylinder* c, double x0, double u, double h) {
  double target = ml_spool_target(&c->law, u);
  if (x0 == 0.0 || target == 0.0 || (x0 > 0.0) == (target > 0.0)) return h;
  double t = log(1.0 - x0 / target) / c->law.inv_tau;
  return t < h ? t : h;
}

/* A load-sensing pump's target at the share w (0..1) of the step, the sections' pressures going
   linearly from the step's start to their predicted end and each spool on the side it is at the
   time `side` within the step (s; its exact lag): the highest sensed plus the margin, at most
   the setting. */
static double target_within(const mjModel* m, const mjData* d, const Cylinder* any, double w,
                            double side) {
  double highest = any->law.tank;
  for (int i = 0; i < m->nplugin; i++) {
    const Cylinder* c = (const Cylinder*)d->plugin_data[i];
    if (m->plugin[i] != g_slot || c == NULL || c->pump_flow <= 0.0) continue;
    const double* y0 = d->plugin_state + m->plugin_stateadr[i] + START_Y;
    const double* y1 = d->plugin_state + m->plugin_stateadr[i] + PRED_Y;
    double goal = ml_spool_target(&c->law, ml_control(m, d, c->actuator));
    double way = goal + (y0[2] - goal) * exp(-side * c->law.inv_tau);
    if (y0[2] == 0.0) way = goal;  /* opening from 0: the side it opens to at once */
    int k = sensed_chamber(way);
    double sensed = k < 0 ? any->law.tank : y0[k] + w * (y1[k] - y0[k]);
    highest = sensed > highest ? sensed : highest;
  }
  return ls_target(any, highest);
}

/* A pump with a response time relaxed over the step from `pump` (Pa) exactly towards its target,
   taken linear between the instants where a section's spool reverses (its load-sense pressure
   jumps from one side's chamber to the other's there): the step split at those instants, each
   piece relaxed towards the mean of its ends' targets. Without a load-sensing margin the target
   is the setting. */
static double relax_pump(const mjModel* m, const mjData* d, const Cylinder* any, double pump) {
  double h = m->opt.timestep, tau = any->pump_tau;
  if (any->ls_margin <= 0.0) return any->law.supply + (pump - any->law.supply) * exp(-h / tau);
  double cuts[ML_MAX_PUMPED + 2];
  int count = 0;
  cuts[count++] = 0.0;
  for (int i = 0; i < m->nplugin && count < ML_MAX_PUMPED + 1; i++) {
    const Cylinder* c = (const Cylinder*)d->plugin_data[i];
    if (m->plugin[i] != g_slot || c == NULL || c->pump_flow <= 0.0) continue;
    double x0 = d->plugin_state[m->plugin_stateadr[i] + START_Y + 2];
    double t = spool_crossing(c, x0, ml_control(m, d, c->actuator), h);
    if (t > 0.0 && t < h) cuts[count++] = t;
  }
  cuts[count++] = h;
  for (int a = 1; a < count; a++) { /* sort the few cuts (insertion) */
    for (int b = a; b > 0 && cuts[b] < cuts[b - 1]; b--) {
      double swap = cuts[b];
      cuts[b] = cuts[b - 1];
      cuts[b - 1] = swap;
    }
  }
  for (int k = 0; k + 1 < count; k++) {
    double t0 = cuts[k], t1 = cuts[k + 1], side = 0.5 * (t0 + t1);
    if (t1 <= t0) continue;
    double target = 0.5 * (target_within(m, d, any, t0 / h, side) +
                           target_within(m, d, any, t1 / h, side));
    pump = target + (pump - target) * exp(-(t1 - t0) / tau);
  }
  return pump;
}

/* The supply pressure when the pump offers `offered`: that, or lower where the valves would draw
   more than Q_max there (the pump at full displacement: the draw rises with ps, bisection down
   to the tank pressure). */
static double flow_limited(const mjModel* m, const mjData* d, const Cylinder* c, double offered,
                           int predicted) {
  double high = offered, low = c->law.tank;
  if (pump_draw(m, d, high, predicted) <= c->pump_flow) return offered;
  for (int k = 0; k < 100 && high - low > 1e-12 * c->law.supply; k++) {
    double mid = 0.5 * (low + high);
    if (pump_draw(m, d, mid, predicted) > c->pump_flow) high = mid; else low = mid;
  }
  return 0.5 * (low + high);
}

/* The shared supply's pressure cap for the step when the pump offers `offered` (its own
   pressure with a response time, else its target). A quasi-static load-sensing pump whose flow
   suffices gives its setting: each section's law then follows the load-sense pressure itself
   (chambers.h, ml_supply_seen). */
static double pump_pressure(const mjModel* m, const mjData* d, const Cylinder* c, double offered,
                            int predicted) {
  double limited = flow_limited(m, d, c, offered, predicted);
  if (c->pump_tau > 0.0) return limited;
  return limited == offered ? c->law.supply : limited;
}

/* The law over the recorded step: the supply pressure (cap) and, on a load-sensing pump, its
   margin and the other sections' load-sense pressure. */
static ml_chambers step_law(const mjModel* m, const mjData* d, const Cylinder* c,
                            const mjtNum* state) {
  ml_chambers law = c->law;
  burst_lines(m, d, c, state[START_TIME], &law);
  law.supply = state[START_SUPPLY];
  if (c->pump_flow > 0.0 && c->ls_margin > 0.0 && c->pump_tau <= 0.0 && !state[MEASURED]) {
    law.ls_margin = c->ls_margin;
    law.ls_others = state[START_OTHERS];
  }
  if (c->pump_flow > 0.0 && law.post > 0.0) law.ls_others = state[START_OTHERS];
  return law;
}

/* A measured supply pressure for the step, Pa (d->userdata[0] at its start, [1] at its end;
   the run loop writes them from a run's input), into start and end; 0 when none is given. */
static int measured_supply(const mjModel* m, const mjData* d, double* start, double* end) {
  if (m->nuserdata < 2 || !(d->userdata[0] > 0.0)) return 0;
  *start = d->userdata[0];
  *end = d->userdata[1] > 0.0 ? d->userdata[1] : d->userdata[0];
  return 1;
}

static void act_dot(const mjModel* m, mjData* d, int instance) {
  const Cylinder* c = (const Cylinder*)d->plugin_data[instance];
  int adr = m->actuator_actadr[c->actuator];
  mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  ml_chambers law = c->law;
  double s = d->actuator_length[c->output], sdot = d->actuator_velocity[c->output];
  const double* y = d->act + adr;
  if (!state[HAVE_START] || d->time == state[START_TIME]) { /* a step starts here */
    if (c->pump_flow > 0.0) {
      /* a pump with a response time starts at its own pressure (at first, at its target) and
         is expected at the step's end to have moved towards the target (pump_over_step says
         where it ends) */
      double target = pump_target(m, d, c, CURRENT);
      double pump = c->pump_tau > 0.0 && state[PUMP_SET] ? state[PUMP_P] : target;
      law.supply = pump_pressure(m, d, c, pump, CURRENT);
      state[PUMP_P] = pump;
      state[END_SUPPLY] = law.supply;
      if (c->pump_tau > 0.0) {
        double decay = exp(-m->opt.timestep / c->pump_tau);
        state[END_SUPPLY] = pump_pressure(m, d, c, target + (pump - target) * decay, CURRENT);
      }
    } else {
      state[END_SUPPLY] = law.supply;
    }
    state[START_TIME] = d->time;
    state[HAVE_START] = 1.0;
    for (int i = 0; i < 3; i++) state[START_Y + i] = y[i];
    state[START_S] = s;
    state[START_SDOT] = sdot;
    state[START_SUPPLY] = law.supply;
    state[PUMP_DUE] = c->pump_flow > 0.0;
    double start, end;
    state[MEASURED] = measured_supply(m, d, &start, &end);
    if (state[MEASURED]) { /* the rig's pump, as measured, instead of the model's */
      state[START_SUPPLY] = start;
      state[END_SUPPLY] = end;
      state[PUMP_P] = start;
      state[PUMP_DUE] = 0.0;
    }
    if (c->pump_flow > 0.0 && (c->ls_margin > 0.0 || c->law.post > 0.0)) {
      state[START_OTHERS] = sensed_max(m, d, instance, c->law.tank, CURRENT);
    }
  }
  law = step_law(m, d, c, state);
  ml_chambers_rates_law(&law, y[0], y[1], y[2], ml_control(m, d, c->actuator), s, sdot,
                        d->act_dot + adr);
}

/* A shared pump's pressure over the step, second order: every cylinder on it predicted to the
   step's end, and the supply at the predicted states. Quasi-static, each cylinder's supply over
   the step is the mean of the two. With a response time, the pump's own pressure relaxes over
   the step towards its target (the mean of the target at the start's states and at the
   predicted ones), exactly, and each cylinder's supply goes linearly from the start's to the
   end's (flow limited at each). The first cylinder's `advance` does this for all, before any of
   them has moved. */
static void pump_over_step(const mjModel* m, mjData* d) {
  double h = m->opt.timestep, start = 0.0, pump = 0.0, end;
  const Cylinder* any = NULL;
  for (int i = 0; i < m->nplugin; i++) {
    const Cylinder* c = (const Cylinder*)d->plugin_data[i];
    if (m->plugin[i] != g_slot || c == NULL || c->pump_flow <= 0.0) continue;
    mjtNum* state = d->plugin_state + m->plugin_stateadr[i];
    ml_chambers law = step_law(m, d, c, state);
    start = state[START_SUPPLY];
    pump = state[PUMP_P];
    double s0 = state[START_S], sdot0 = state[START_SDOT], sdot1 = length_rate(m, d, c);
    ml_chambers_step(&law, state + START_Y, ml_control(m, d, c->actuator), s0, sdot0,
                     s0 + 0.5 * h * (sdot0 + sdot1), sdot1, state[END_SUPPLY], h, 1,
                     state + PRED_Y);
    any = c;
  }
  if (any == NULL) return;
  if (any->pump_tau > 0.0) {
    pump = relax_pump(m, d, any, pump);
    end = pump_pressure(m, d, any, pump, PREDICTED);
  } else {
    start = end = 0.5 * (start + pump_pressure(m, d, any, pump_target(m, d, any, PREDICTED),
                                               PREDICTED));
  }
  for (int i = 0; i < m->nplugin; i++) {
    const Cylinder* c = (const Cylinder*)d->plugin_data[i];
    if (m->plugin[i] != g_slot || c == NULL || c->pump_flow <= 0.0) continue;
    mjtNum* state = d->plugin_state + m->plugin_stateadr[i];
    state[START_SUPPLY] = start;
    state[END_SUPPLY] = end;
    state[PUMP_P] = pump;
    state[PUMP_SET] = 1.0;
    state[PUMP_DUE] = 0.0;
    if (c->ls_margin > 0.0 || c->law.post > 0.0) { /* the others' load sense: the mean of start
                                                       and end */
      double sensed = sensed_max(m, d, i, c->law.tank, PREDICTED);
      state[START_OTHERS] = 0.5 * (state[START_OTHERS] + sensed);
    }
  }
}

static void advance(const mjModel* m, mjData* d, int instance) {
  const Cylinder* c = (const Cylinder*)d->plugin_data[instance];
  mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  double* x = d->act + m->actuator_actadr[c->actuator];
  double h = m->opt.timestep;
  double since = d->time - state[START_TIME];  /* MuJoCo has advanced the time by h */
  if (state[HAVE_START] && fabs(since - h) <= 1e-9 * (h + fabs(d->time))) {
    if (c->pump_flow > 0.0 && state[PUMP_DUE]) pump_over_step(m, d);
    ml_chambers law = step_law(m, d, c, state);
    double s0 = state[START_S], sdot0 = state[START_SDOT], sdot1 = length_rate(m, d, c);
    double s1 = s0 + 0.5 * h * (sdot0 + sdot1), va, vb;
    ml_chambers_step_energy(&law, state + START_Y, ml_control(m, d, c->actuator), s0, sdot0, s1,
                            sdot1, state[END_SUPPLY], h, ML_CHAMBER_SUBSTEPS, x, state + ENERGY);
    ml_chamber_volumes(&c->law, s1, &va, &vb);
    x[0] = ml_chambers_bound_energy(&c->law, x[0], va, state + ENERGY);
    x[1] = ml_chambers_bound_energy(&c->law, x[1], vb, state + ENERGY);
  }
  state[HAVE_START] = 0.0;
  x[0] = ml_chamber_bounded(&c->law, x[0]);
  x[1] = ml_chamber_bounded(&c->law, x[1]);
}

static void compute(const mjModel* m, mjData* d, int instance, int capability_bit) {
  const Cylinder* c = (const Cylinder*)d->plugin_data[instance];
  const mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  const double* x = d->act + m->actuator_actadr[c->actuator];
  double y[3] = {x[0], x[1], x[2]};
  double since = d->time - state[START_TIME];
  if (state[HAVE_START] && since > 0.0 && since <= m->opt.timestep * (1.0 + 1e-9)) {
    /* a stage within the step: the pressures from the step's start to this stage's time, with
       the cylinder moving as this stage has it move */
    ml_chambers law = step_law(m, d, c, state);
    double s = d->actuator_length[c->output], sdot = d->actuator_velocity[c->output];
    double share = since / m->opt.timestep;
    double supply = state[START_SUPPLY] + share * (state[END_SUPPLY] - state[START_SUPPLY]);
    ml_chambers_step(&law, state + START_Y, ml_control(m, d, c->actuator), state[START_S],
                     state[START_SDOT], s, sdot, supply, since, 1, y);
  }
  d->actuator_force[c->output] = ml_chambers_force_law(&c->law, y[0], y[1]);
}

void ml_register_cylinder(const char* name) {
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
  g_slot = mjp_registerPlugin(&plugin);
}
