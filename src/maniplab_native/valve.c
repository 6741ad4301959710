/* The valve law and the cylinder's equations (valve.h) as exported functions, for ctypes
   (maniplab.actuators.hydraulic.valve and .cylinder call these; nothing there repeats the law).
   Arrays are plain C arrays of `count` entries; supply pressures are Ps (Pa), inverted here as
   the scalar functions' callers do. */
#include "valve.h"

double ml_valve_root(double current, double dP, double inv_supply, int orifice) {
  return ml_valve_root_law(current, dP, inv_supply, orifice);
}

double ml_valve_flow(double current, double dP, double gain, double inv_supply, int orifice) {
  return ml_valve_flow_law(current, dP, gain, inv_supply, orifice);
}

/* slopes[0] = dQ* / di_v, slopes[1] = dQ* / d(dP). */
void ml_valve_slopes(double current, double dP, double gain, double inv_supply, int orifice,
                     double* slopes) {
  ml_valve_slopes_law(current, dP, gain, inv_supply, orifice, slopes, slopes + 1);
}

double ml_relief_flow(double dP, double relief, double relief_gain) {
  return ml_relief_flow_law(dP, relief, relief_gain);
}

/* Q* at `count` points: out[k] = flow(current[k], dP[k], gain[k], 1/supply[k], orifice[k]). */
void ml_valve_flows(int count, const double* current, const double* dP, const double* gain,
                    const double* supply, const int* orifice, double* out) {
  for (int k = 0; k < count; k++) {
    out[k] = ml_valve_flow_law(current[k], dP[k], gain[k], 1.0 / supply[k], orifice[k]);
  }
}

/* G2 at `count` points (see ml_valve_current_law). */
void ml_valve_currents(int count, const double* flow, const double* dP, const double* gain,
                       const double* supply, const double* limit, double min_root,
                       const int* orifice, double* out) {
  for (int k = 0; k < count; k++) {
    out[k] = ml_valve_current_law(flow[k], dP[k], gain[k], 1.0 / supply[k], limit[k], min_root,
                                  orifice[k]);
  }
}

/* rates = (d(dP)/dt, dQ/dt) with the relief's flow (the actuator model's derivatives). */
void ml_cylinder_rates(const ml_cylinder* c, double dP, double Q, double u, double v,
                       double* rates) {
  ml_cylinder_rates_law(c, dP, Q, u, v, 1, rates);
}

/* The exact partial derivatives of the rates at (dP, u); they depend on neither Q nor v:
   out = (d rate0/d dP, d rate0/d Q, d rate1/d dP, d rate1/d Q, d rate1/d u, d rate0/d v).
   Above the relief's setting its slope K_r adds to the leakage's. */
void ml_cylinder_partials(const ml_cylinder* c, double dP, double u, double* out) {
  double du, dp;
  ml_valve_slopes_law(u, dP, c->valve_gain, c->inv_supply, c->orifice, &du, &dp);
  int relieving = c->relief > 0.0 && fabs(dP) > c->relief;
  double leak = c->leakage + (relieving ? c->relief_gain : 0.0);
  out[0] = -c->stiffness * leak;
  out[1] = c->stiffness;
  out[2] = dp * c->inv_tau;
  out[3] = -c->inv_tau;
  out[4] = du * c->inv_tau;
  out[5] = -c->stiffness * c->area;
}

/* The steady state that holds `force` (N or N m) at joint speed v: out = (dP, Q, i_v) with
   dP = f/A, Q = A v + Le dP + Q_r (the piston's flow, the leakage and what the relief lets by)
   and i_v the law inverted exactly (+-inf where no current passes Q at that load). */
void ml_cylinder_steady(const ml_cylinder* c, double force, double v, double* out) {
  double dP = force / c->area;
  double Q = c->area * v + c->leakage * dP + ml_cylinder_relief(c, dP);
  double r = ml_valve_root_law(Q, dP, c->inv_supply, c->orifice);
  out[0] = dP;
  out[1] = Q;
  out[2] = r > 0.0 ? Q / (c->valve_gain * r) : copysign(INFINITY, Q);
}
