/* The two-chamber cylinder's equations (chambers.h) as exported functions, for ctypes
   (maniplab.actuators.hydraulic.chambers calls these; nothing there repeats the equations). */
#include "chambers.h"

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
