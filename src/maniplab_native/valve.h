/* The servo-valve's flow law, its inversion (the controller's G2), the relief valve and the
   cylinder's state equations (the paper's eq. 4): the one implementation in maniplab.

   The hydraulic engine plugin (hydraulic.c), the compiled cascade (cascade.c) and, through the
   exported functions of valve.c and ctypes, the Python actuator model and the linearisation
   (maniplab.actuators.hydraulic.valve, .cylinder) all evaluate the valve here.

   Steady valve flow at current i_v (A) and load pressure dP (Pa), no-load flow i_v C:

     Q* = i_v C root,   root = sqrt(max(0, 1 - s dP / Ps))

   with s = sign(i_v) for the orifice law (the default: the pressure drop across the metering
   edge that passes the flow) and s = sign(dP) for the paper's law (the flow falls with |dP|
   whichever way the load acts). A relief valve across the cylinder passes
   Q_r = K_r (|dP| - p_r) sign(dP) above its setting p_r.

   The cylinder (states dP and Q, joint speed v):

     (V/E) d(dP)/dt = Q - A v - Le dP - Q_r(dP)
       tau dQ/dt    = Q*(i_v, dP) - Q

   Everything here is static inline (each user compiles its own copy, no call overhead in the
   plugin's act_dot); valve.c exports the same functions for ctypes. */
#ifndef MANIPLAB_VALVE_H_
#define MANIPLAB_VALVE_H_

#include <math.h>

/* One cylinder with its valve: the parameters of eq. (4) as the formulas use them. */
typedef struct {
  double area;          /* A, m^2 or m^3/rad */
  double stiffness;     /* E/V, Pa/m^3 */
  double leakage;       /* Le, m^3/(s Pa) */
  double valve_gain;    /* C, m^3/(s A) */
  double inv_supply;    /* 1/Ps, 1/Pa */
  double inv_tau;       /* 1/tau, 1/s */
  double relief;        /* p_r, Pa; 0: no relief valve */
  double relief_gain;   /* K_r, m^3/(s Pa) */
  int orifice;          /* 1: orifice law, 0: the paper's */
} ml_cylinder;

/* The share of the no-load flow the valve passes: sqrt(max(0, 1 - s dP/Ps)). */
static inline double ml_valve_root_law(double current, double dP, double inv_supply,
                                       int orifice) {
  double drop = orifice ? (current >= 0.0 ? dP : -dP) : fabs(dP);
  double r = 1.0 - drop * inv_supply;
  return r > 0.0 ? sqrt(r) : 0.0;
}

/* Steady valve flow Q* = i_v C root, m^3/s; exactly 0 where the root vanishes. */
static inline double ml_valve_flow_law(double current, double dP, double gain, double inv_supply,
                                       int orifice) {
  return current * gain * ml_valve_root_law(current, dP, inv_supply, orifice);
}

/* The slopes (dQ* / di_v, dQ* / d(dP)). At i_v = 0 the orifice law's flow has a kink under load (the drop
   jumps from one metering edge to the other): the mean of the two one-sided slopes in i_v.
   Where the root vanishes both are 0. */
static inline void ml_valve_slopes_law(double current, double dP, double gain, double inv_supply,
                                       int orifice, double* d_current, double* d_pressure) {
  if (orifice && current == 0.0) {
    double up = ml_valve_root_law(1.0, dP, inv_supply, 1);
    double down = ml_valve_root_law(-1.0, dP, inv_supply, 1);
    *d_current = gain * 0.5 * (up + down);
    *d_pressure = 0.0;
    return;
  }
  double r = ml_valve_root_law(current, dP, inv_supply, orifice);
  if (r == 0.0) {
    *d_current = 0.0;
    *d_pressure = 0.0;
    return;
  }
  double sign = orifice ? (current >= 0.0 ? 1.0 : -1.0) : copysign(1.0, dP);
  *d_current = gain * r;
  *d_pressure = -current * gain * sign * inv_supply / (2.0 * r);
}

/* G2: the current that passes `flow` at dP, clipped to +-limit, A. The current takes the flow's
   sign and the root is the law's for it; where the root falls below min_root (no current passes
   the flow, or only a huge one) it is floored there to keep the current finite. NaN in, NaN out
   (the clipping compares, it does not use fmin/fmax, which drop a NaN). */
static inline double ml_valve_current_law(double flow, double dP, double gain, double inv_supply,
                                          double limit, double min_root, int orifice) {
  double r = ml_valve_root_law(flow, dP, inv_supply, orifice);
  if (min_root > r) r = min_root;
  double current = flow / (gain * r);
  if (current < -limit) current = -limit;
  if (current > limit) current = limit;
  return current;
}

/* The relief's flow Q_r = K_r (|dP| - p_r) sign(dP) above its setting, else 0, m^3/s. */
static inline double ml_relief_flow_law(double dP, double relief, double relief_gain) {
  double excess = fabs(dP) - relief;
  return excess > 0.0 ? copysign(relief_gain * excess, dP) : 0.0;
}

/* The relief's flow of a cylinder: 0 without a relief valve. */
static inline double ml_cylinder_relief(const ml_cylinder* c, double dP) {
  return c->relief > 0.0 ? ml_relief_flow_law(dP, c->relief, c->relief_gain) : 0.0;
}

/* (d(dP)/dt, dQ/dt) of eq. (4), Pa/s and m^3/s^2, at command u (already clipped) and joint
   speed v. `with_relief` 0 leaves the relief out: the engine plugin takes the stiff relief
   through its regime exactly at each evaluation within a step and at its end instead
   (hydraulic.c). */
static inline void ml_cylinder_rates_law(const ml_cylinder* c, double dP, double Q, double u,
                                         double v, int with_relief, double* rates) {
  double relief = with_relief ? ml_cylinder_relief(c, dP) : 0.0;
  rates[0] = c->stiffness * (Q - c->area * v - c->leakage * dP - relief);
  rates[1] = (ml_valve_flow_law(u, dP, c->valve_gain, c->inv_supply, c->orifice) - Q) *
             c->inv_tau;
}

#endif
