/* The pinned two-chamber cylinder with its four-edge valve: the one implementation in maniplab.

   The engine plugin maniplab.cylinder (cylinder.c) and, through the exported functions of
   chambers.c and ctypes, the Python actuator model (maniplab.actuators.hydraulic.pinned)
   evaluate these equations.

   States: the cap-side pressure pA and the rod-side pressure pB (Pa), and the spool's opening
   x (-1..1). Inputs: the valve command u (A, or the datasheet's unit from neutral, clipped), the
   cylinder's length s (pin to pin, m) and its rate ds/dt (m/s). The spool's steady opening x*(u)
   is u / u_max, or 0 within a deadband and linear beyond it, or a characteristic's points
   interpolated (ml_spool_target).

     dx/dt  = (x*(u) - x) / tau                                   (the spool's lag)
     dpA/dt = E / V_A (Q_A - A_A ds/dt - Q_L)                     (cap side)
     dpB/dt = E / V_B (Q_B + A_B ds/dt + Q_L)                     (rod side)

   with the chamber volumes V_A = V_A0 + A_A y and V_B = V_B0 + A_B (stroke - y), y = s - s_min
   the piston's travel (held within the stroke), the leakage across the piston Q_L = Le (pA - pB),
   and the valve's four metering edges, each an orifice Q = K x g(dp):

     x > 0:  P -> A  K_A x g_in(Ps - pA)     B -> T  K_BT x g(pB - Pt)
     x < 0:  P -> B  K_B |x| g_in(Ps - pB)   A -> T  K_AT |x| g(pA - Pt)

   Q_A = K_A x+ g_in(Ps - pA) - K_AT x- g(pA - Pt),  Q_B = K_B x- g_in(Ps - pB) - K_BT x+ g(pB - Pt),
   the meter-out gains K_AT, K_BT their own (a datasheet's meter-out coefficients). A meter-in
   edge with a local pressure compensator (margin dp_c) sees at most dp_c: g_in(dp) = g(min(dp,
   dp_c)) (a smooth minimum over the band p_l), so its flow follows the opening, not the load,
   while the supply exceeds the chamber's pressure by dp_c (the compensator's spool throttles
   the rest), and the orifice law below.
   g(dp) = dp / (dp^2 + p_l^2)^(1/4) is the orifice's square root sign(dp) sqrt(|dp|), made
   laminar (linear) below the transition pressure p_l so that its slope stays finite. The P
   edges have the load-check valve of a mobile valve section: no flow back into the supply line
   (their g is 0 where the chamber's pressure is above Ps).

   Each chamber has an ideal relief valve to tank at p_r (optional) and an ideal anti-cavitation
   check valve from tank: its pressure is held within [Pt, p_r]. The plugin takes them as bounds
   after each step; within a step the force sees the pressures within them.

   The cylinder's force along its pins, positive pushing them apart: F = pA A_A - pB A_B (N).

   A shared supply (a pump with a flow limit Q_max at its pressure setting) feeds several
   cylinders: when their valves together would draw more than Q_max at the setting, the supply
   pressure falls to the ps at which they draw Q_max (sum of ml_supply_draw = Q_max), and every
   cylinder sees that ps (cylinder.c). */
#ifndef MANIPLAB_CHAMBERS_H_
#define MANIPLAB_CHAMBERS_H_

#include <math.h>

#define ML_VALVE_POINTS 16 /* the most points of a valve's opening characteristic */

typedef struct {
  double area_a, area_b;      /* A_A, A_B: cap and rod side areas, m^2 */
  double dead_a, dead_b;      /* V_A0, V_B0: dead volumes, hoses included, m^3 */
  double min_length, stroke;  /* s_min (pin to pin, retracted) and the stroke, m */
  double bulk_modulus;        /* E, Pa */
  double leakage;             /* Le, across the piston, m^3/(s Pa) */
  double gain_a, gain_b;      /* K_A, K_B: edge flow at full opening per sqrt(Pa) */
  double laminar;             /* p_l, the orifices' transition pressure, Pa */
  double supply, tank;        /* Ps, Pt, Pa */
  double relief;              /* p_r, Pa; 0: no relief valve */
  double inv_tau;             /* 1/tau, 1/s */
  double inv_current;         /* 1/i_max, 1/A */
  double out_a, out_b;        /* K_AT, K_BT: the meter-out edges' gains, per sqrt(Pa) */
  double margin;              /* the local compensator's margin across a meter-in edge, Pa;
                                 0: no compensator */
  double ls_margin;           /* on a load-sensing pump: its margin, Pa; 0: supply at Ps */
  double ls_others;           /* the highest load-sense pressure of the other sections on that
                                 pump (the tank's when they are closed), Pa */
  double deadband;            /* the command band around neutral where the spool stays shut */
  double points;              /* the opening characteristic's points (0: linear beyond the
                                 deadband) */
  double point_u[ML_VALVE_POINTS]; /* its commands, ascending */
  double point_x[ML_VALVE_POINTS]; /* the spool's openings there, non-decreasing, -1..1 */
  double post;                /* 1: the compensator sits after the metering edge and is set by
                                 the highest load on the pump (flow sharing, LUDV): every
                                 section's edge sees the pump's pressure less that load; 0: a
                                 local compensator before the edge (or none) */
  double cushion_length;      /* m: the end cushions' length at both ends (0: none) */
  double cushion_gain;        /* K of a cushion's throttle at the very end, m^3/(s sqrt(Pa)) */
  /* each chamber's load-holding valve ([0] A, [1] B; ml_hold_opening): */
  double hold_type[2];        /* ML_HOLD_NONE, ML_HOLD_COUNTERBALANCE or ML_HOLD_PILOT_CHECK */
  double hold_setting[2];     /* a counterbalance valve's crack pressure, a pilot-operated
                                 check's spring in pilot pressure (gauge, above the tank's), Pa */
  double hold_ratio[2];       /* its pilot ratio */
  double hold_gain[2];        /* K fully open, m^3/(s sqrt(Pa)) */
  double hold_band[2];        /* the pressure from cracked to fully open, Pa */
  double hold_leakage[2];     /* its seat's leakage, closed, m^3/(s Pa) */
  double burst[2];            /* 1: the chamber's line is open to the atmosphere (a burst hose,
                                 at the tank's pressure) */
  double burst_gain[2];       /* K of each burst line's open end, m^3/(s sqrt(Pa)) */
} ml_chambers;

enum { ML_HOLD_NONE, ML_HOLD_COUNTERBALANCE, ML_HOLD_PILOT_CHECK };

/* The spool's opening the command u asks for (its steady position), -1..1: the characteristic's
   points interpolated (held beyond its ends), or 0 within the deadband and linear beyond it to
   full opening at the command's limit. */
static inline double ml_spool_target(const ml_chambers* c, double u) {
  int n = (int)c->points;
  if (n >= 2) {
    if (u <= c->point_u[0]) return c->point_x[0];
    for (int k = 1; k < n; k++) {
      if (u <= c->point_u[k]) {
        double w = (u - c->point_u[k - 1]) / (c->point_u[k] - c->point_u[k - 1]);
        return c->point_x[k - 1] + w * (c->point_x[k] - c->point_x[k - 1]);
      }
    }
    return c->point_x[n - 1];
  }
  double a = fabs(u), span = 1.0 / c->inv_current - c->deadband;
  if (a <= c->deadband) return 0.0;
  double x = (a - c->deadband) / span;
  return copysign(x < 1.0 ? x : 1.0, u);
}

/* The command nearest neutral that asks for the opening x (clipped to -1..1): the inverse of
   ml_spool_target, so a controller's command passes the deadband or the characteristic. */
static inline double ml_spool_command(const ml_chambers* c, double x) {
  x = x < -1.0 ? -1.0 : (x > 1.0 ? 1.0 : x);
  if (x == 0.0) return 0.0;
  int n = (int)c->points;
  if (n >= 2) {
    if (x > 0.0) {
      for (int k = 1; k < n; k++) {
        if (c->point_x[k] >= x && c->point_x[k] > c->point_x[k - 1]) {
          double w = (x - c->point_x[k - 1]) / (c->point_x[k] - c->point_x[k - 1]);
          w = w < 0.0 ? 0.0 : w;
          return c->point_u[k - 1] + w * (c->point_u[k] - c->point_u[k - 1]);
        }
      }
      return c->point_u[n - 1];
    }
    for (int k = n - 1; k > 0; k--) {
      if (c->point_x[k - 1] <= x && c->point_x[k] > c->point_x[k - 1]) {
        double w = (c->point_x[k] - x) / (c->point_x[k] - c->point_x[k - 1]);
        w = w < 0.0 ? 0.0 : w;
        return c->point_u[k] - w * (c->point_u[k] - c->point_u[k - 1]);
      }
    }
    return c->point_u[0];
  }
  return copysign(c->deadband + fabs(x) * (1.0 / c->inv_current - c->deadband), x);
}

/* The orifice's signed square root g(dp), sqrt(Pa). */
static inline double ml_orifice_root(double dp, double laminar) {
  return dp / sqrt(sqrt(dp * dp + laminar * laminar));
}

/* A supply edge's root: the load-check valve in the P port lets no oil back into the supply
   line, so g(dp) for dp > 0 and 0 otherwise. */
static inline double ml_supply_root(double dp, double laminar) {
  return dp > 0.0 ? ml_orifice_root(dp, laminar) : 0.0;
}

/* The slope of the orifice's root, dg/d(dp) = (dp^2 / 2 + p_l^2) / (dp^2 + p_l^2)^(5/4), 1/sqrt(Pa). */
static inline double ml_orifice_slope(double dp, double laminar) {
  double r2 = dp * dp + laminar * laminar;
  return (0.5 * dp * dp + laminar * laminar) / (r2 * sqrt(sqrt(r2)));
}

/* The drop a meter-in edge sees at the drop dp = (supply) - (chamber): dp, or with a local
   pressure compensator of margin m the smooth minimum (dp + m - sqrt((dp - m)^2 + w^2)) / 2,
   w = p_l: the compensator throttles everything above its margin, with a regulation band of
   the orifices' laminar transition (a real compensator is a proportional spool; the band keeps
   the law's slope continuous, so the step is not held at the transition), Pa. */
static inline double ml_compensated_drop(const ml_chambers* c, double dp) {
  if (c->margin <= 0.0) return dp;
  double over = dp - c->margin;
  return 0.5 * (dp + c->margin - sqrt(over * over + c->laminar * c->laminar));
}

/* d(ml_compensated_drop)/d(dp). */
static inline double ml_compensated_slope(const ml_chambers* c, double dp) {
  if (c->margin <= 0.0) return 1.0;
  double over = dp - c->margin;
  return 0.5 * (1.0 - over / sqrt(over * over + c->laminar * c->laminar));
}

/* The drop across a meter-in edge fed at ps into a chamber at p, Pa: ps - p, or on a
   post-compensated section ps less the highest load on the pump (its own or the others'), the
   compensator after the edge taking the rest. */
static inline double ml_metering_drop(const ml_chambers* c, double ps, double p) {
  if (c->post > 0.0 && c->ls_others > p) return ps - c->ls_others;
  return ps - p;
}

/* d(ml_metering_drop)/d(p): -1, or 0 on a post-compensated section whose load is not the
   highest. */
static inline double ml_metering_slope(const ml_chambers* c, double p) {
  return c->post > 0.0 && c->ls_others > p ? 0.0 : -1.0;
}

/* A meter-in edge's root at the drop dp: the load-check valve lets no oil back (0 where the
   drop it sees is <= 0); with a compensator the edge sees ml_compensated_drop, so the flow
   follows the opening and not the load while the supply exceeds the chamber's pressure by the
   margin, and the orifice law below it. */
static inline double ml_meter_in_root(const ml_chambers* c, double dp) {
  return ml_supply_root(ml_compensated_drop(c, dp), c->laminar);
}

/* d(ml_meter_in_root)/d(dp), 1/sqrt(Pa). */
static inline double ml_meter_in_slope(const ml_chambers* c, double dp) {
  double seen = ml_compensated_drop(c, dp);
  return seen > 0.0 ? ml_orifice_slope(seen, c->laminar) * ml_compensated_slope(c, dp) : 0.0;
}

/* A chamber pressure within the valves' bounds [Pt, p_r] (p_r only with a relief valve). */
static inline double ml_chamber_bounded(const ml_chambers* c, double p) {
  if (p < c->tank) return c->tank;
  if (c->relief > 0.0 && p > c->relief) return c->relief;
  return p;
}

/* The supply pressure this section's meter-in edge sees: Ps, or on a load-sensing pump the
   highest load-sense pressure (the others', or this section's own: the chamber its open
   meter-in edge feeds) plus the pump's margin, at most Ps (then the pump's cut-off, or the
   pressure its flow limit leaves). */
static inline double ml_supply_seen(const ml_chambers* c, double pa, double pb, double x) {
  if (c->ls_margin <= 0.0) return c->supply;
  double own = x > 0.0 ? pa : (x < 0.0 ? pb : c->tank);
  double target = (own > c->ls_others ? own : c->ls_others) + c->ls_margin;
  return target < c->supply ? target : c->supply;
}

/* d(ml_supply_seen)/d(the pressure of the chamber x's meter-in edge feeds): 1 where this
   section's own load sets a load-sensing pump's pressure, else 0. */
static inline double ml_supply_follows(const ml_chambers* c, double pa, double pb, double x) {
  if (c->ls_margin <= 0.0 || x == 0.0) return 0.0;
  double own = x > 0.0 ? pa : pb;
  return own > c->ls_others && own + c->ls_margin < c->supply ? 1.0 : 0.0;
}

/* The piston's travel from fully retracted at length s, within the stroke, m. */
static inline double ml_travel(const ml_chambers* c, double s) {
  double y = s - c->min_length;
  return y < 0.0 ? 0.0 : (y > c->stroke ? c->stroke : y);
}

/* The chamber volumes (V_A, V_B) at length s, m^3. */
static inline void ml_chamber_volumes(const ml_chambers* c, double s, double* va, double* vb) {
  double y = s - c->min_length;
  y = y < 0.0 ? 0.0 : (y > c->stroke ? c->stroke : y);
  *va = c->dead_a + c->area_a * y;
  *vb = c->dead_b + c->area_b * (c->stroke - y);
}

/* 1/K of an end cushion's throttle at `distance` (m) from the end the piston moves towards,
   (1 - d/l) / K_c: 0 outside the cushion (or without one), 1/K_c at the very end. */
static inline double ml_cushion_throttle(const ml_chambers* c, double distance) {
  double l = c->cushion_length;
  if (!(l > 0.0) || distance >= l) return 0.0;
  return (1.0 - (distance > 0.0 ? distance : 0.0) / l) / c->cushion_gain;
}

/* The gain of a draining chamber's way out at `distance` (m) from the end the piston moves
   towards: the meter-out edge's `edge` alone, or within an end cushion in series with the
   cushion's throttle, whose gain K_c / (1 - d/l) falls from wide open as the spear enters to K_c
   at the very end (1/K^2 = 1/edge^2 + (1 - d/l)^2 / K_c^2: continuous with its slope there). */
static inline double ml_cushioned(const ml_chambers* c, double edge, double distance) {
  double t = ml_cushion_throttle(c, distance);
  return t > 0.0 && edge > 0.0 ? edge / sqrt(1.0 + edge * edge * t * t) : edge;
}

/* d(ml_cushioned)/d(edge): 1 / (1 + edge^2 t^2)^(3/2) (1 outside the cushion). */
static inline double ml_cushioned_slope(const ml_chambers* c, double edge, double distance) {
  double t = ml_cushion_throttle(c, distance), r = 1.0 + edge * edge * t * t;
  return 1.0 / (r * sqrt(r));
}

/* The ramp min(max(e, 0), 1) with its corners rounded over ML_RAMP_ROUND on each side (a
   parabola that meets the lines with their slopes), and its slope into *slope: continuous with
   its slope, so that the exponential step stays second order across them. */
#define ML_RAMP_ROUND 0.05
static inline double ml_smooth_ramp(double e, double* slope) {
  double d = ML_RAMP_ROUND;
  if (!(e > -d)) {
    *slope = 0.0;
    return 0.0;
  }
  if (e >= 1.0 + d) {
    *slope = 0.0;
    return 1.0;
  }
  if (e < d) {
    *slope = (e + d) / (2.0 * d);
    return (e + d) * (e + d) / (4.0 * d);
  }
  if (e > 1.0 - d) {
    *slope = (1.0 + d - e) / (2.0 * d);
    return 1.0 - (1.0 + d - e) * (1.0 + d - e) / (4.0 * d);
  }
  *slope = 1.0;
  return e;
}

/* The opening (0..1) of chamber k's load-holding valve at the chamber's pressure p and the pilot
   pressure `pilot` (the other line's), and its slopes d/dp and d/dpilot (1/Pa) into slope[2]:
   the excess over the setting divided by the band, within 0..1. Gauge pressures (above the
   tank's, Pt):

     counterbalance:        (p - Pt) + R (pilot - Pt) - p_c    (the load and the pilot open it)
     pilot-operated check:  R (pilot - Pt - p_s) - (p - Pt)    (the load holds it shut)

   so a counterbalance valve cracks where p + R pilot reaches its setting and a pilot-operated
   check where its pilot reaches (p - Pt)/R + p_s (its outlet drained). */
static inline double ml_hold_opening(const ml_chambers* c, int k, double p, double pilot,
                                     double* slope) {
  double t = c->tank, r = c->hold_ratio[k], w = c->hold_band[k], excess, sign;
  if (c->hold_type[k] == ML_HOLD_COUNTERBALANCE) {
    excess = (p - t) + r * (pilot - t) - c->hold_setting[k];
    sign = 1.0;
  } else {
    excess = r * (pilot - t - c->hold_setting[k]) - (p - t);
    sign = -1.0;
  }
  double dz, z = ml_smooth_ramp(excess / w, &dz);
  slope[0] = sign * dz / w;
  slope[1] = r * dz / w;
  return z;
}

/* The flow leaving chamber k (pressure p, the other chamber's p_other) to the tank through its
   line, m^3/s, with `edge` the gain of the valve's meter-out edge that drains it (end cushion
   included; 0 while the spool does not drain it), and its derivatives by p, p_other and edge
   into d[3] (NULL: not wanted). The ways out, each an orifice K g(p - Pt):

     no holding valve:      K = edge
     holding valve:         K = edge K_h z / sqrt(edge^2 + (K_h z)^2)  (the two in series, the
                            line between them without volume); its check lets the meter-in
                            edge's oil in freely (ml_valve_edges_at)
     burst line, valve:     K = K_h z  (the line at the tank's pressure)
     burst line, no valve:  K = K_burst, the line's open end

   with the pilot at the other line's pressure (the tank's when that line has burst), plus the
   holding valve's seat leakage L_h (p - Pt) while its line is open to the tank. */
static inline double ml_way_out(const ml_chambers* c, int k, double p, double p_other, double edge,
                                double* d) {
  double l = c->laminar, root = ml_orifice_root(p - c->tank, l);
  int burst = c->burst[k] != 0.0;
  double gain, d_p = 0.0, d_other = 0.0, d_edge = burst ? 0.0 : 1.0, leak = 0.0;
  if (c->hold_type[k] == ML_HOLD_NONE) {
    gain = burst ? c->burst_gain[k] : edge;
  } else {
    double slope[2], pilot_burst = c->burst[1 - k] != 0.0;
    double z = ml_hold_opening(c, k, p, pilot_burst ? c->tank : p_other, slope);
    double v = c->hold_gain[k] * z, dv = 0.0;
    if (burst) {
      gain = v;
      dv = 1.0;
    } else {
      double r = edge * edge + v * v, r3 = r * sqrt(r);
      gain = r > 0.0 ? edge * v / sqrt(r) : 0.0;
      d_edge = r > 0.0 ? v * v * v / r3 : 0.0;
      dv = r > 0.0 ? edge * edge * edge / r3 : 0.0;
    }
    d_p = dv * c->hold_gain[k] * slope[0];
    d_other = pilot_burst ? 0.0 : dv * c->hold_gain[k] * slope[1];
    leak = burst || edge > 0.0 ? c->hold_leakage[k] : 0.0;
  }
  if (d) {
    d[0] = gain * ml_orifice_slope(p - c->tank, l) + d_p * root + leak;
    d[1] = d_other * root;
    d[2] = d_edge * root;
  }
  return gain * root + leak * (p - c->tank);
}

/* The valve's flows into the chambers (Q_A, Q_B) at opening x and piston travel y (m from fully
   retracted), m^3/s: the meter-in edge's (none into a burst line's chamber) less the way out
   (ml_way_out) through the meter-out edge with the end cushions (the cap side drains through
   the retracted end's, the rod side through the extended end's). */
static inline void ml_valve_edges_at(const ml_chambers* c, double x, double pa, double pb,
                                     double y, double* qa, double* qb) {
  double open = x > 0.0 ? x : 0.0, reverse = x < 0.0 ? -x : 0.0;
  double ps = ml_supply_seen(c, pa, pb, x);
  double in_a = c->burst[0] != 0.0 ? 0.0 : open;
  double in_b = c->burst[1] != 0.0 ? 0.0 : reverse;
  *qa = c->gain_a * in_a * ml_meter_in_root(c, ml_metering_drop(c, ps, pa)) -
        ml_way_out(c, 0, pa, pb, ml_cushioned(c, c->out_a * reverse, y), NULL);
  *qb = c->gain_b * in_b * ml_meter_in_root(c, ml_metering_drop(c, ps, pb)) -
        ml_way_out(c, 1, pb, pa, ml_cushioned(c, c->out_b * open, c->stroke - y), NULL);
}

/* The valve's flows into the chambers (Q_A, Q_B) at opening x, m^3/s, away from the cushions
   (mid-stroke: a cushion is at most half the stroke long). */
static inline void ml_valve_edges(const ml_chambers* c, double x, double pa, double pb,
                                  double* qa, double* qb) {
  ml_valve_edges_at(c, x, pa, pb, 0.5 * c->stroke, qa, qb);
}

/* The pressure of the line a meter-in edge feeds: the chamber's, or the tank's where the line
   has burst (chamber k, pressure p). */
static inline double ml_line_pressure(const ml_chambers* c, int k, double p) {
  return c->burst[k] != 0.0 ? c->tank : p;
}

/* The flow the valve draws from the supply line at pressure ps: through P->A (x > 0) or P->B
   (x < 0), m^3/s (into a burst line too). */
static inline double ml_supply_draw(const ml_chambers* c, double x, double pa, double pb,
                                    double ps) {
  if (x >= 0.0) {
    return c->gain_a * x * ml_meter_in_root(c, ml_metering_drop(c, ps, ml_line_pressure(c, 0, pa)));
  }
  return -c->gain_b * x * ml_meter_in_root(c, ml_metering_drop(c, ps, ml_line_pressure(c, 1, pb)));
}

/* (dpA/dt, dpB/dt, dx/dt) at current u (clipped), length s and its rate sdot. */
static inline void ml_chambers_rates_law(const ml_chambers* c, double pa, double pb, double x,
                                         double u, double s, double sdot, double* rates) {
  double va, vb, qa, qb;
  ml_chamber_volumes(c, s, &va, &vb);
  ml_valve_edges_at(c, x, pa, pb, ml_travel(c, s), &qa, &qb);
  double leak = c->leakage * (pa - pb);
  rates[0] = c->bulk_modulus / va * (qa - c->area_a * sdot - leak);
  rates[1] = c->bulk_modulus / vb * (qb + c->area_b * sdot + leak);
  rates[2] = (ml_spool_target(c, u) - x) * c->inv_tau;
}


/* The Jacobian of (dpA/dt, dpB/dt, dx/dt) with respect to (pA, pB, x) at (pa, pb, x), length s,
   row-major 3 x 3 (1/s, 1/s and Pa/s per unit opening). At x = 0 the edges that open are those
   of the direction the spool moves to (u / i_max - x). */
static inline void ml_chambers_jacobian_law(const ml_chambers* c, double pa, double pb, double x,
                                            double u, double s, double* J) {
  double va, vb;
  ml_chamber_volumes(c, s, &va, &vb);
  int forward = x > 0.0 || (x == 0.0 && ml_spool_target(c, u) >= 0.0);
  double open = x > 0.0 ? x : 0.0, reverse = x < 0.0 ? -x : 0.0;
  /* on a load-sensing pump that this section's load sets, the supply follows the chamber the
     meter-in edge feeds: the drop, and the edge's flow, do not change with it */
  double ps = ml_supply_seen(c, pa, pb, x), follows = 1.0 - ml_supply_follows(c, pa, pb, x);
  double in_a_p = 0.0, in_a_x = 0.0, in_b_p = 0.0, in_b_x = 0.0;
  if (forward && c->burst[0] == 0.0) { /* P -> A */
    double up = ml_metering_drop(c, ps, pa);
    in_a_p = c->gain_a * open * ml_meter_in_slope(c, up) * ml_metering_slope(c, pa) * follows;
    in_a_x = c->gain_a * ml_meter_in_root(c, up);
  } else if (!forward && c->burst[1] == 0.0) { /* P -> B */
    double up = ml_metering_drop(c, ps, pb);
    in_b_p = c->gain_b * reverse * ml_meter_in_slope(c, up) * ml_metering_slope(c, pb) * follows;
    in_b_x = -c->gain_b * ml_meter_in_root(c, up);
  }
  /* the ways out: A -> T opens with -x, B -> T with +x (each edge's gain within its cushion) */
  double ya = ml_travel(c, s), yb = c->stroke - ya, da[3], db[3];
  double ea = c->out_a * reverse, eb = c->out_b * open;
  double ea_x = forward ? 0.0 : -c->out_a * ml_cushioned_slope(c, ea, ya);
  double eb_x = forward ? c->out_b * ml_cushioned_slope(c, eb, yb) : 0.0;
  ml_way_out(c, 0, pa, pb, ml_cushioned(c, ea, ya), da);
  ml_way_out(c, 1, pb, pa, ml_cushioned(c, eb, yb), db);
  double ka = c->bulk_modulus / va, kb = c->bulk_modulus / vb, leak = c->leakage;
  J[0] = ka * (in_a_p - da[0] - leak);
  J[1] = ka * (leak - da[1]);
  J[2] = ka * (in_a_x - da[2] * ea_x);
  J[3] = kb * (leak - db[1]);
  J[4] = kb * (in_b_p - db[0] - leak);
  J[5] = kb * (in_b_x - db[2] * eb_x);
  J[6] = 0.0;
  J[7] = 0.0;
  J[8] = -c->inv_tau;
}

/* The energy of a run, split by where it goes (J, accumulated by ml_chambers_step_energy and
   ml_chambers_bound_energy): what the supply delivered through this section (at the pressure
   its meter-in edge sees), the losses across the meter-in edge's orifice, its compensator, the
   meter-out edge, the piston's leakage, the relief and anti-cavitation valves, the energy the
   return oil carries into the tank line (Pt Q), the loss in the end cushions' throttles, the work
   on the piston ((pA A_A - pB A_B) ds/dt
   with the pressures within their bounds, as the mechanics sees them; negative where the load
   drives it), the energy put into compressing the oil
   (pA V_A dpA/dt + pB V_B dpB/dt) / E, the loss across the load-holding valves, and the loss
   where a burst line spills its oil. At each instant

     pump = meter_in + compensator + meter_out + leakage + relief + anticavitation + tank + work
            + compression + cushion + holding + burst,

   which is the chambers' continuity multiplied by their pressures: the balance closes by the
   equations, and a missing flow would break it. */
enum { ML_E_PUMP, ML_E_METER_IN, ML_E_COMPENSATOR, ML_E_METER_OUT, ML_E_LEAKAGE, ML_E_RELIEF,
       ML_E_ANTICAVITATION, ML_E_TANK, ML_E_WORK, ML_E_COMPRESSION, ML_E_CUSHION, ML_E_HOLDING,
       ML_E_BURST, ML_ENERGIES };

/* After the energies, the time integral of the supply pressure this section sees (Pa s): a fixed
   displacement pump delivers Q_max at it, the flow its sections do not take over its relief. */
#define ML_SUPPLY_TIME ML_ENERGIES
#define ML_ACCUMULATED (ML_ENERGIES + 1)

/* The oil leaving chamber k at pressure p (the other's p_other) through the meter-out `edge`
   at `distance` (m) from the end the piston moves towards: its power (p - Pt) Q split into
   powers[] by the drops of the orifices in series (each Q^2 over its gain squared: shares
   1/edge^2, t^2 for the cushion's throttle 1/t and 1/(K_h z)^2 for the holding valve; a burst
   line's spill to ML_E_BURST), and Pt Q to the tank. Returns the oil leaving, Q, m^3/s. */
static inline double ml_way_out_powers(const ml_chambers* c, int k, double p, double p_other,
                                       double edge, double distance, double* powers) {
  double t = ml_cushion_throttle(c, distance);
  double out = ml_way_out(c, k, p, p_other, ml_cushioned(c, edge, distance), NULL);
  double power = (p - c->tank) * out;
  powers[ML_E_TANK] += c->tank * out;
  if (c->hold_type[k] == ML_HOLD_NONE) {
    if (c->burst[k] != 0.0) {
      powers[ML_E_BURST] += power;
      return out;
    }
    double et2 = edge * edge * t * t;
    powers[ML_E_CUSHION] += power * et2 / (1.0 + et2);
    powers[ML_E_METER_OUT] += power / (1.0 + et2);
    return out;
  }
  if (c->burst[k] != 0.0) {
    powers[ML_E_HOLDING] += power;
    return out;
  }
  double slope[2], pilot = c->burst[1 - k] != 0.0 ? c->tank : p_other;
  double v = c->hold_gain[k] * ml_hold_opening(c, k, p, pilot, slope);
  double leak = edge > 0.0 ? c->hold_leakage[k] * (p - c->tank) : 0.0;
  double through = out - leak;  /* the metered oil; the seat's leakage is the valve's loss */
  powers[ML_E_HOLDING] += (p - c->tank) * leak;
  if (!(edge > 0.0 && v > 0.0)) return out;
  double r_edge = 1.0 / (edge * edge), r_cushion = t * t, r_hold = 1.0 / (v * v);
  double share = (p - c->tank) * through / (r_edge + r_cushion + r_hold);
  powers[ML_E_METER_OUT] += share * r_edge;
  powers[ML_E_CUSHION] += share * r_cushion;
  powers[ML_E_HOLDING] += share * r_hold;
  return out;
}

/* The powers (W) of the energy terms at one instant (the relief and anti-cavitation valves act
   at the bounds, ml_chambers_bound_energy), and the supply pressure: powers[ML_ACCUMULATED]. */
static inline void ml_chambers_powers(const ml_chambers* c, double pa, double pb, double x,
                                      double s, double sdot, double* powers) {
  double ps = ml_supply_seen(c, pa, pb, x), y = ml_travel(c, s);
  for (int k = 0; k < ML_ENERGIES; k++) powers[k] = 0.0;
  powers[ML_SUPPLY_TIME] = ps;
  /* the meter-in edge: its oil goes into the chamber, or spills from a burst line */
  int fed = x > 0.0 ? 0 : 1;
  double line = ml_line_pressure(c, fed, fed == 0 ? pa : pb);
  double in = x != 0.0 ? ml_supply_draw(c, x, pa, pb, ps) : 0.0;
  double seen = ml_compensated_drop(c, ml_metering_drop(c, ps, line));
  powers[ML_E_PUMP] = ps * in;
  powers[ML_E_METER_IN] = seen * in;
  powers[ML_E_COMPENSATOR] = (ps - line - seen) * in;
  if (c->burst[fed] != 0.0) {
    powers[ML_E_TANK] += c->tank * in;
  }
  /* the ways out, each within its end cushion; the chambers' flows (ml_valve_edges_at's) */
  double into = c->burst[fed] != 0.0 ? 0.0 : in;
  double qa = (fed == 0 ? into : 0.0) -
              ml_way_out_powers(c, 0, pa, pb, c->out_a * (x < 0.0 ? -x : 0.0), y, powers);
  double qb = (fed == 1 ? into : 0.0) -
              ml_way_out_powers(c, 1, pb, pa, c->out_b * (x > 0.0 ? x : 0.0), c->stroke - y,
                                powers);
  double leak = c->leakage * (pa - pb);
  powers[ML_E_LEAKAGE] = (pa - pb) * leak;
  powers[ML_E_COMPRESSION] = pa * (qa - c->area_a * sdot - leak) + pb * (qb + c->area_b * sdot + leak);
  /* the piston works against the pressures within their bounds, as the mechanics sees them;
     where a pressure is beyond a bound within the step, the piston's share above it is the
     valve's (it flows out through the relief valve, in through the anti-cavitation valve) */
  double ba = ml_chamber_bounded(c, pa), bb = ml_chamber_bounded(c, pb);
  double beyond_a = (pa - ba) * c->area_a * sdot, beyond_b = -(pb - bb) * c->area_b * sdot;
  powers[ML_E_WORK] = (ba * c->area_a - bb * c->area_b) * sdot;
  powers[pa > ba ? ML_E_RELIEF : ML_E_ANTICAVITATION] += beyond_a;
  powers[pb > bb ? ML_E_RELIEF : ML_E_ANTICAVITATION] += beyond_b;
}

/* A chamber's pressure p of volume v brought within its bounds (ml_chamber_bounded), the oil
   that left through the relief valve or came in through the anti-cavitation valve accounted in
   energy[ML_ENERGIES] (NULL: not): the oil's compression energy changes by v (b^2 - p^2) / 2E
   (b the bound), the tank line carries Pt dV, and the valve takes the rest. Returns the bound
   pressure. */
static inline double ml_chambers_bound_energy(const ml_chambers* c, double p, double v,
                                              double* energy) {
  double b = ml_chamber_bounded(c, p);
  if (energy && b != p) {
    double stored = v * (b * b - p * p) / (2.0 * c->bulk_modulus);
    double tank = c->tank * v * (p - b) / c->bulk_modulus;  /* > 0: oil left to the tank */
    energy[ML_E_COMPRESSION] += stored;
    energy[ML_E_TANK] += tank;
    energy[b < p ? ML_E_RELIEF : ML_E_ANTICAVITATION] += -stored - tank;
  }
  return b;
}

/* F = pA A_A - pB A_B with the pressures within their bounds, N. */
static inline double ml_chambers_force_law(const ml_chambers* c, double pa, double pb) {
  return ml_chamber_bounded(c, pa) * c->area_a - ml_chamber_bounded(c, pb) * c->area_b;
}

/* One step h of (pA, pB, x) from y0 by the exponential Rosenbrock-Euler method (stiff.h), with
   the current u held and the cylinder's length and rate going linearly from (s0, sdot0) to
   (s1, sdot1) and the supply pressure from c->supply to supply1, in `substeps` equal sub-steps
   (each re-linearised at its start): y1 = y0 + the increment, the pressures not yet bounded.
   Returns 0, or -1 (y1 NaN) on a non-finite input. The pressures are scaled by the supply and
   the spool by 1 for the matrix exponential. */
int ml_chambers_step(const ml_chambers* c, const double* y0, double u, double s0, double sdot0,
                     double s1, double sdot1, double supply1, double h, int substeps,
                     double* y1);

/* ml_chambers_step that also adds the step's energies to energy[ML_ACCUMULATED] (J): each power
   (ml_chambers_powers) by the trapezoidal rule over each sub-step, every term at the same
   instants, so that their balance closes as it does at each instant. */
int ml_chambers_step_energy(const ml_chambers* c, const double* y0, double u, double s0,
                            double sdot0, double s1, double sdot1, double supply1, double h,
                            int substeps, double* y1, double* energy);

/* The sub-steps of a plant step's final update of the chambers (cylinder.c's `advance`): four
   re-linearisations make it about ten times more accurate than one on a crane's valve reversals
   (patu655's tilt: 4e-3 -> 4e-4 of the pressures' range at 1 ms), for three more exponentials;
   the forces within the step (`compute`) need only one. */
#define ML_CHAMBER_SUBSTEPS 4

#endif
