/* The two-chamber cylinder's equations (chambers.h) as exported functions, for ctypes
   (maniplab.actuators.hydraulic.chambers calls these; nothing there repeats the equations). */
#include <stddef.h>

#include "chambers.h"

#include "stiff.h"

/* rates = (dpA/dt, dpB/dt, dx/dt), Pa/s, Pa/s, 1/s. */
void ml_chambers_rates(const ml_chambers* c, double pa, double pb, double x, double u, double s,
                       double sdot, double* rates) {
  ml_chambers_rates_law(c, pa, pb, x, u, s, sdot, rates);
}

/* The force along the pins, N (the pressures within their bounds). */
double ml_chambers_force(const ml_chambers* c, double pa, double pb) {
  return ml_chambers_force_law(c, pa, pb);
}

/* The force at `count` samples: out[k] = force(pa[k], pb[k]), N. */
void ml_chambers_forces(const ml_chambers* c, int count, const double* pa, const double* pb,
                        double* out) {
  for (int k = 0; k < count; k++) out[k] = ml_chambers_force_law(c, pa[k], pb[k]);
}

/* out = (Q_A, Q_B, V_A, V_B): the valve's flows into the chambers at (x, pA, pB), m^3/s, and
   the chamber volumes at length s, m^3. */
void ml_chambers_flows(const ml_chambers* c, double pa, double pb, double x, double s,
                       double* out) {
  ml_valve_edges(c, x, pa, pb, out, out + 1);
  ml_chamber_volumes(c, s, out + 2, out + 3);
}

/* The valve's flows (Q_A, Q_B) at `count` states x[k] = (pA, pB, spool), row-major (count, 3),
   into out (count, 2), m^3/s. */
void ml_chambers_flows_many(const ml_chambers* c, int count, const double* x, double* out) {
  for (int k = 0; k < count; k++) {
    ml_valve_edges(c, x[3 * k + 2], x[3 * k], x[3 * k + 1], out + 2 * k, out + 2 * k + 1);
  }
}

/* The load-holding valves' openings at `count` samples (pa[k], pb[k]), into out (count, 2):
   0..1 (ml_hold_opening, the pilot at the other chamber's pressure), NaN where a chamber has no
   holding valve. */
void ml_chambers_hold_openings(const ml_chambers* c, int count, const double* pa, const double* pb,
                               double* out) {
  double slope[2];
  for (int k = 0; k < count; k++) {
    out[2 * k] = c->hold_type[0] != ML_HOLD_NONE ? ml_hold_opening(c, 0, pa[k], pb[k], slope) : NAN;
    out[2 * k + 1] = c->hold_type[1] != ML_HOLD_NONE ? ml_hold_opening(c, 1, pb[k], pa[k], slope)
                                                     : NAN;
  }
}

/* The spool's opening the command u asks for (ml_spool_target). */
double ml_chambers_spool_target(const ml_chambers* c, double u) { return ml_spool_target(c, u); }

/* The command that asks for the opening x (ml_spool_command). */
double ml_chambers_spool_command(const ml_chambers* c, double x) { return ml_spool_command(c, x); }

/* J: d(rates)/d(pA, pB, x), row-major 3 x 3 (chambers.h). */
void ml_chambers_jacobian(const ml_chambers* c, double pa, double pb, double x, double u,
                          double s, double* J) {
  ml_chambers_jacobian_law(c, pa, pb, x, u, s, J);
}

/* One exponential step from y0 (chambers.h's ml_chambers_step, without sub-steps), the supply
   pressure going from ps0 to ps1. */
static int one_step(const ml_chambers* c, const double* y0, double u, double s0, double sdot0,
                    double ps0, double s1, double sdot1, double ps1, double h, double* y1) {
  double J[9], f0[3], f1[3], df[3], dy[3];
  double scale[3] = {c->supply, c->supply, 1.0};
  ml_chambers start = *c, end = *c;
  start.supply = ps0;
  end.supply = ps1;
  ml_chambers_jacobian_law(&start, y0[0], y0[1], y0[2], u, s0, J);
  ml_chambers_rates_law(&start, y0[0], y0[1], y0[2], u, s0, sdot0, f0);
  ml_chambers_rates_law(&end, y0[0], y0[1], y0[2], u, s1, sdot1, f1);
  for (int i = 0; i < 3; i++) {
    for (int j = 0; j < 3; j++) J[3 * i + j] *= scale[j] / scale[i];
    df[i] = (f1[i] - f0[i]) / scale[i];
    f0[i] /= scale[i];
  }
  int status = ml_exponential_step(3, h, J, f0, df, dy);
  for (int i = 0; i < 3; i++) y1[i] = y0[i] + scale[i] * dy[i];
  return status;
}

/* The powers at (y, length, its rate, supply) into powers[ML_ACCUMULATED]. */
static void powers_at(const ml_chambers* c, const double* y, double s, double sdot,
                      double supply, double* powers) {
  ml_chambers law = *c;
  law.supply = supply;
  ml_chambers_powers(&law, y[0], y[1], y[2], s, sdot, powers);
}

int ml_chambers_step_energy(const ml_chambers* c, const double* y0, double u, double s0,
                            double sdot0, double s1, double sdot1, double supply1, double h,
                            int substeps, double* y1, double* energy) {
  double y[3] = {y0[0], y0[1], y0[2]}, ps0 = c->supply, half = 0.5 * h / substeps;
  double before[ML_ACCUMULATED], after[ML_ACCUMULATED];
  int status = 0;
  if (energy) powers_at(c, y, s0, sdot0, ps0, before);
  for (int k = 0; k < substeps; k++) { /* the length, its rate and the supply linear */
    double a = (double)k / substeps, b = (double)(k + 1) / substeps;
    double ra = sdot0 + a * (sdot1 - sdot0), rb = sdot0 + b * (sdot1 - sdot0);
    double pa = ps0 + a * (supply1 - ps0), pb = ps0 + b * (supply1 - ps0);
    double sa = s0 + a * (s1 - s0), sb = s0 + b * (s1 - s0);
    status |= one_step(c, y, u, sa, ra, pa, sb, rb, pb, h / substeps, y1);
    if (energy) { /* the trapezoidal rule; a sub-step's end is the next one's start */
      powers_at(c, y1, sb, rb, pb, after);
      for (int i = 0; i < ML_ACCUMULATED; i++) {
        energy[i] += half * (before[i] + after[i]);
        before[i] = after[i];
      }
    }
    for (int i = 0; i < 3; i++) y[i] = y1[i];
  }
  return status;
}

int ml_chambers_step(const ml_chambers* c, const double* y0, double u, double s0, double sdot0,
                     double s1, double sdot1, double supply1, double h, int substeps,
                     double* y1) {
  return ml_chambers_step_energy(c, y0, u, s0, sdot0, s1, sdot1, supply1, h, substeps, y1, NULL);
}
