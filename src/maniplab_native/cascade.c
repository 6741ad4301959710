/* The cascade controller's sample (cascade.h). */
#include "cascade.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "linalg.h"
#include "plant.h"
#include "valve.h"

#define ML_PI 3.14159265358979323846

/* The state of a PID (maniplab.control.pid.PID): its integrator and filtered error rate. */
typedef struct {
  double* integral;
  double* rate;
  int started;  /* a sample since the reset: the rate filter starts at the first measured rate */
} pid_state;

struct ml_cascade {
  ml_cascade_config cfg;  /* its arrays point into `pool` */
  double* pool;           /* every array of the cascade, one allocation */
  int python_drives;      /* joints with ML_DRIVE_PYTHON */
  int any_integral_outer, any_integral_joint;
  /* loop states */
  pid_state outer, joint;
  double *p_prev, *p_rate, *p_integral;  /* the pressure loop's (n) */
  int p_started;
  int saturated;          /* the last command reached a limit: freeze the outer integrator */
  ml_cascade_log* log;
  /* scratch */
  ml_dls dls;
  double H[16], E[9], bias_acc[6];
  double *J, *Jp, *Jm, *qshift, *Mb, *rhs, *sol, *inv_supply, *dP, *pB, *u, *err, *rate, *ff,
      *spare_row;
};

int ml_cascade_sizes(int* out4) {
  out4[0] = (int)sizeof(ml_pid_gains);
  out4[1] = (int)sizeof(ml_cascade_config);
  out4[2] = (int)sizeof(ml_cascade_log);
  out4[3] = (int)sizeof(ml_cascade_run);
  return 4;
}

/* --- construction ----------------------------------------------------------------------------- */

/* Hands out consecutive pieces of the pool; without a pool (NULL) it only counts them. */
typedef struct {
  double* pool;
  int used;  /* doubles handed out */
} carver;

static double* carve(carver* k, int count) {
  double* out = k->pool ? k->pool + k->used : NULL;
  k->used += count;
  return out;
}

/* A copy of `count` doubles in the pool (NULL for NULL, or while counting). */
static const double* keep(carver* k, const double* from, int count) {
  if (from == NULL) return NULL;
  double* to = carve(k, count);
  if (to) memcpy(to, from, (size_t)count * sizeof(double));
  return to;
}

/* A copy of `count` ints, in as many doubles as they take (NULL for NULL). */
static const int* keep_ints(carver* k, const int* from, int count) {
  if (from == NULL) return NULL;
  int* to = (int*)carve(k, (count * (int)sizeof(int) + (int)sizeof(double) - 1) /
                               (int)sizeof(double));
  if (to) memcpy(to, from, (size_t)count * sizeof(int));
  return to;
}

static void keep_pid(carver* k, ml_pid_gains* g, int size) {
  g->kp = keep(k, g->kp, size);
  g->ki = keep(k, g->ki, size);
  g->kd = keep(k, g->kd, size);
  g->lo = g->limited ? keep(k, g->lo, size) : NULL;
  g->hi = g->limited ? keep(k, g->hi, size) : NULL;
  g->tracking = g->limited ? keep(k, g->tracking, size) : NULL;
}

/* The cascade's arrays in `pool` (the config's copied, the states and the scratch); with a NULL
   pool only the doubles it needs, which the return value always is. */
static int layout(ml_cascade* c, const ml_cascade_config* config, double* pool) {
  int n = config->n, m = config->rows;
  carver k = {pool, 0};
  ml_cascade_config* g = &c->cfg;
  *g = *config;
  g->params = keep(&k, g->params, g->nparams);
  keep_pid(&k, &g->outer, m);
  keep_pid(&k, &g->joint, n);
  g->weights = keep(&k, g->weights, n);
  g->viscous = keep(&k, g->viscous, n);
  g->coulomb = keep(&k, g->coulomb, n);
  g->stribeck = keep(&k, g->stribeck, n);
  g->drive = keep_ints(&k, g->drive, n);
  g->orifice = keep_ints(&k, g->orifice, n);
  g->limit = keep(&k, g->limit, n);
  g->area = keep(&k, g->area, n);
  g->valve_gain = keep(&k, g->valve_gain, n);
  g->supply = keep(&k, g->supply, n);
  g->capacitance = keep(&k, g->capacitance, n);
  g->leakage = keep(&k, g->leakage, n);
  g->pressure_kp = keep(&k, g->pressure_kp, n);
  g->pressure_ki = keep(&k, g->pressure_ki, n);
  /* ml_chambers is all doubles (no padding): kept as doubles */
  g->chambers = (const ml_chambers*)keep(&k, (const double*)g->chambers,
                                         n * (int)(sizeof(ml_chambers) / sizeof(double)));
  g->geometry = keep(&k, g->geometry, 3 * n);
  g->prismatic = keep_ints(&k, g->prismatic, n);
  g->weight = keep(&k, g->weight, 3);
  c->outer.integral = carve(&k, m);
  c->outer.rate = carve(&k, m);
  c->joint.integral = carve(&k, n);
  c->joint.rate = carve(&k, n);
  c->p_prev = carve(&k, n);
  c->p_rate = carve(&k, n);
  c->p_integral = carve(&k, n);
  c->J = carve(&k, 6 * n);
  c->Jp = carve(&k, 6 * n);
  c->Jm = carve(&k, 6 * n);
  c->qshift = carve(&k, n);
  c->Mb = carve(&k, n * n + n);
  c->rhs = carve(&k, 3 * m);
  c->sol = carve(&k, 3 * n);
  c->inv_supply = carve(&k, n);
  c->dP = carve(&k, n);
  c->pB = carve(&k, n);
  c->u = carve(&k, n > 6 ? n : 6);  /* the outer loop's too (rows <= 6) */
  c->err = carve(&k, n);
  c->rate = carve(&k, n);
  c->ff = carve(&k, n);
  c->spare_row = carve(&k, 36 + 4 * n);  /* a sample's row when the log has no room */
  double* scratch = carve(&k, ml_dls_scratch(m, n));
  if (scratch) ml_dls_init(&c->dls, m, n, scratch);
  return k.used;
}

static int any_positive(const double* x, int size) {
  for (int i = 0; i < size; i++) {
    if (x[i] > 0.0) return 1;
  }
  return 0;
}

ml_cascade* ml_cascade_new(const ml_cascade_config* config) {
  int n = config->n, m = config->rows;
  if (n < 1 || (m != 3 && m != 6) || config->nparams < 1) return NULL;
  ml_cascade* c = (ml_cascade*)calloc(1, sizeof(ml_cascade));
  if (c == NULL) return NULL;
  c->pool = (double*)calloc((size_t)layout(c, config, NULL), sizeof(double));
  if (c->pool == NULL) {
    free(c);
    return NULL;
  }
  layout(c, config, c->pool);
  const ml_cascade_config* g = &c->cfg;
  for (int j = 0; j < n; j++) {
    if (g->drive[j] == ML_DRIVE_CHAMBERS && (!g->chambers || !g->geometry || !g->prismatic)) {
      ml_cascade_free(c);
      return NULL;
    }
    c->python_drives += g->drive[j] == ML_DRIVE_PYTHON;
    c->inv_supply[j] = g->drive[j] == ML_DRIVE_VALVE ? 1.0 / g->supply[j] : 0.0;
  }
  c->any_integral_outer = any_positive(g->outer.ki, m);
  c->any_integral_joint = any_positive(g->joint.ki, n);
  ml_cascade_reset(c);
  return c;
}

void ml_cascade_free(ml_cascade* c) {
  if (c == NULL) return;
  free(c->pool);
  free(c);
}

void ml_cascade_reset(ml_cascade* c) {
  int n = c->cfg.n, m = c->cfg.rows;
  memset(c->outer.integral, 0, (size_t)m * sizeof(double));
  memset(c->outer.rate, 0, (size_t)m * sizeof(double));
  memset(c->joint.integral, 0, (size_t)n * sizeof(double));
  memset(c->joint.rate, 0, (size_t)n * sizeof(double));
  memset(c->p_prev, 0, (size_t)n * sizeof(double));
  memset(c->p_rate, 0, (size_t)n * sizeof(double));
  memset(c->p_integral, 0, (size_t)n * sizeof(double));
  c->outer.started = c->joint.started = c->p_started = 0;
  c->saturated = 0;
  if (c->log) c->log->count = 0;
}

void ml_cascade_set_log(ml_cascade* c, ml_cascade_log* log) { c->log = log; }

/* --- the blocks ------------------------------------------------------------------------------- */

/* x clipped to [lo, hi]; a NaN stays NaN (as numpy's minimum/maximum, unlike fmin/fmax). */
static double clip(double x, double lo, double hi) {
  if (x < lo) x = lo;
  if (x > hi) x = hi;
  return x;
}

/* One PID sample with the measured error rate (PID.update(error, rate, freeze=freeze,
   feedforward=ff)): d = rate at the first sample, then filtered; u = clip(Kp e + I + Kd d + ff)
   (ff NULL: none); the integrator takes
   h (Ki e + (u - v)/Tt) unless frozen (components with Ki = 0 have none). */
static void pid_update(const ml_pid_gains* g, pid_state* s, int size, int any_integral, double dt,
                       const double* e, const double* rate, const double* ff, int freeze,
                       double* u) {
  for (int i = 0; i < size; i++) {
    s->rate[i] = s->started ? g->filter_a * s->rate[i] + g->filter_b * rate[i] : rate[i];
  }
  s->started = 1;
  for (int i = 0; i < size; i++) {
    double v = g->kp[i] * e[i] + s->integral[i] + g->kd[i] * s->rate[i] + (ff ? ff[i] : 0.0);
    double out = v, step;
    if (g->limited) {
      out = clip(v, g->lo[i], g->hi[i]);
      step = g->ki[i] * e[i] + (out - v) / g->tracking[i];
    } else {
      step = g->ki[i] * e[i];
    }
    u[i] = out;
    if (any_integral && !freeze) {
      s->integral[i] = s->integral[i] + dt * (g->ki[i] > 0.0 ? step : 0.0);
    }
  }
}

/* The rotation vector of a rotation matrix (kinematics.rotation_log), branch for branch. */
static void rotation_log(const double* R, double* w) {
  double trace = 0.5 * (R[0] + R[4] + R[8] - 1.0);
  double cs = trace < 1.0 ? trace : 1.0;  /* Python's max(-1, min(1, x)) */
  cs = cs > -1.0 ? cs : -1.0;
  double vee[3] = {0.5 * (R[7] - R[5]), 0.5 * (R[2] - R[6]), 0.5 * (R[3] - R[1])};
  double theta = acos(cs);
  if (theta < 1e-6) { /* sin(theta) ~ theta: vee = sin(theta) axis ~ theta axis */
    memcpy(w, vee, sizeof(vee));
    return;
  }
  if (theta < ML_PI - 1e-4) {
    double f = theta / sin(theta);
    for (int i = 0; i < 3; i++) w[i] = f * vee[i];
    return;
  }
  /* near pi the axis a comes from the symmetric part: (R + R^T)/2 = cos I + (1 - cos) a a^T */
  double B[9];
  for (int i = 0; i < 3; i++) {
    for (int j = 0; j < 3; j++) {
      B[3 * i + j] = (0.5 * (R[3 * i + j] + R[3 * j + i]) - (i == j ? cs : 0.0)) / (1.0 - cs);
    }
  }
  int k = 0;
  for (int i = 1; i < 3; i++) {
    if (B[4 * i] > B[4 * k]) k = i;
  }
  double scale = sqrt(B[4 * k] > 1e-300 ? B[4 * k] : 1e-300);
  double axis[3], dot = 0.0, norm = 0.0;
  for (int i = 0; i < 3; i++) {
    axis[i] = B[3 * i + k] / scale;
    dot += axis[i] * vee[i];
  }
  if (dot < 0.0) { /* vee = sin(theta) a fixes the sign */
    for (int i = 0; i < 3; i++) axis[i] = -axis[i];
  }
  for (int i = 0; i < 3; i++) norm += axis[i] * axis[i];
  norm = sqrt(norm);
  for (int i = 0; i < 3; i++) w[i] = theta * axis[i] / norm;
}

/* Jdot qd (Kinematics.bias_acceleration): the central difference of J along qd with a joint
   step of fd_step, (J(q + s qd) - J(q - s qd)) / (2 s) qd, s = fd_step / max|qd|; 0 at rest. */
static void bias_acceleration(ml_cascade* c, const double* q, const double* qd, double* out) {
  const ml_cascade_config* g = &c->cfg;
  int n = g->n;
  double speed = 0.0;
  for (int j = 0; j < n; j++) {
    double a = fabs(qd[j]);
    if (a > speed || a != a) speed = a;  /* numpy's max propagates a NaN */
  }
  if (speed == 0.0) {
    for (int i = 0; i < 6; i++) out[i] = 0.0;
    return;
  }
  double s = g->fd_step / speed;
  for (int j = 0; j < n; j++) c->qshift[j] = q[j] + s * qd[j];
  g->jacobian(g->params, c->qshift, NULL, NULL, c->Jp);
  for (int j = 0; j < n; j++) c->qshift[j] = q[j] - s * qd[j];
  g->jacobian(g->params, c->qshift, NULL, NULL, c->Jm);
  for (int i = 0; i < 6; i++) {
    double sum = 0.0;
    for (int j = 0; j < n; j++) sum += (c->Jp[i * n + j] - c->Jm[i * n + j]) / (2.0 * s) * qd[j];
    out[i] = sum;
  }
}

/* --- the two modes ---------------------------------------------------------------------------- */

/* The valve's drive at joint j (PressureDrive.command): dP_d = tau / A, the pressure loop's flow
   command phi, then G2. The loop's rate filter starts at its second sample. */
/* The pressure loop at joint j (PressureLoop.flow): the command for the desired pressure p_d at
   the measured p, with the loop's "area" (A, or a pinned cylinder's k_s), speed and reference
   speed, "capacitance" and leakage. The rate filter starts at the loop's second sample. */
static double pressure_loop(ml_cascade* c, int j, double p_d, double p, double area,
                            double speed, double speed_ref, double capacitance,
                            double leakage) {
  const ml_cascade_config* g = &c->cfg;
  if (c->p_started) {
    c->p_rate[j] += g->rate_alpha * ((p_d - c->p_prev[j]) / g->dt - c->p_rate[j]);
  }
  c->p_prev[j] = p_d;
  double error = p_d - p;
  double flow = area * speed + leakage * p + g->pressure_kp[j] * error + c->p_integral[j];
  c->p_integral[j] = c->p_integral[j] + g->dt * g->pressure_ki[j] * error;
  if (g->compressibility) flow += capacitance * c->p_rate[j];
  if (g->speed_gain != 0.0) flow += g->speed_gain * area * (speed_ref - speed);
  return flow;
}

/* s(q) and r(q) = ds/dq of a pinned cylinder from its pins' closed form (PinGeometry). */
static void pin_length(const double* geo, int prismatic, double q, double* s, double* r) {
  if (prismatic) {
    double x = q + geo[1];
    *s = sqrt(geo[0] + x * x);
    *r = x / *s;
    return;
  }
  double x = q - geo[2], s2 = geo[0] - 2.0 * geo[1] * cos(x);
  *s = sqrt(s2 > 0.0 ? s2 : 0.0);
  *r = geo[1] * sin(x) / *s;
}

/* A pinned cylinder's drive at joint j (ChamberDrive.command): F_d = tau / r(q), the desired load
   pressure p_Ld = F_d / A_A against p_L = pA - alpha pB, the load-pressure loop with k_s in place
   of the area, and the four-edge valve inverted for the rate it asks (each root floored at
   min_root sqrt(Ps - Pt)). */
static double chamber_drive(ml_cascade* c, int j, double tau, double q, double qd, double qd_ref,
                            double pa, double pb, double* p_d_out) {
  const ml_cascade_config* g = &c->cfg;
  const ml_chambers* law = &g->chambers[j];
  double s, r, va, vb, qa, qb;
  pin_length(g->geometry + 3 * j, g->prismatic[j], q, &s, &r);
  ml_chamber_volumes(law, s, &va, &vb);
  double ratio = law->area_b / law->area_a, e = law->bulk_modulus;
  double stiff = e * (law->area_a / va + ratio * law->area_b / vb);
  double leak = e * (1.0 / va + ratio / vb) * law->leakage * (pa - pb);
  double p_d = tau / (r * law->area_a);
  double need = pressure_loop(c, j, p_d, pa - ratio * pb, stiff, r * qd, r * qd_ref, 1.0, 0.0)
                + leak;
  double sign = need >= 0.0 ? 1.0 : -1.0;
  ml_valve_edges(law, sign, pa, pb, &qa, &qb);
  double floor = g->min_root * sqrt(law->supply - law->tank);
  double fa = sign * qa, fb = -sign * qb;
  double least_a = (sign > 0.0 ? law->gain_a : law->out_a) * floor; /* P->A or A->T */
  double least_b = (sign > 0.0 ? law->out_b : law->gain_b) * floor;  /* B->T or P->B */
  qa = sign * (fa > least_a ? fa : least_a);
  qb = -sign * (fb > least_b ? fb : least_b);
  double gain = e * (qa / va - ratio * qb / vb) * sign;
  *p_d_out = p_d;
  return clip(ml_spool_command(law, need / gain), -g->limit[j], g->limit[j]);
}

static double valve_drive(ml_cascade* c, int j, double tau, double qd, double qd_ref, double dP,
                          double* dP_d_out, double* phi_out) {
  const ml_cascade_config* g = &c->cfg;
  double dP_d = tau / g->area[j];
  double phi = pressure_loop(c, j, dP_d, dP, g->area[j], qd, qd_ref, g->capacitance[j],
                             g->leakage[j]);
  *dP_d_out = dP_d;
  *phi_out = phi;
  return ml_valve_current_law(phi, dP, g->valve_gain[j], c->inv_supply[j], g->limit[j],
                              g->min_root, g->orifice[j]);
}

typedef struct {
  double *a_x, *qdd, *tau, *dP_d, *phi;
} row_view;

/* The null space's part of the pull towards the planned joint path, added to qdd:
   (I - J+ J) z with z = w^2 (q_p - q) + D qd_p, w = D/2 (the damping term -D (I - J+ J) qd is
   the caller's), J+ J z by the same least squares. */
static void posture_pull(ml_cascade* c, const double* q, const double* posture, double* qdd) {
  const ml_cascade_config* g = &c->cfg;
  int n = g->n, m = g->rows;
  double w = 0.5 * g->null_damping, stiffness = w * w;
  for (int j = 0; j < n; j++) {
    c->err[j] = stiffness * (posture[j] - q[j]) + g->null_damping * posture[n + j];
  }
  for (int i = 0; i < m; i++) {
    double sum = 0.0;
    for (int j = 0; j < n; j++) sum += c->J[i * n + j] * c->err[j];
    c->rhs[i] = sum;
  }
  ml_dls_solve(&c->dls, c->rhs, 1, c->rate);
  for (int j = 0; j < n; j++) qdd[j] += c->err[j] - c->rate[j];
}

static void cascade_mode(ml_cascade* c, const double* ref, const double* q, const double* qd,
                         const double* dP, const double* pB, const double* posture,
                         const double* e, const double* de, const double* Jqd, double* cmd,
                         double* aux, row_view row) {
  const ml_cascade_config* g = &c->cfg;
  int n = g->n, m = g->rows;
  double* rhs = c->rhs;
  double* sol = c->sol;
  /* outer loop: a_x = accel_d + PID(e, de) */
  pid_update(&g->outer, &c->outer, m, c->any_integral_outer, g->dt, e, de, NULL, c->saturated, c->u);
  for (int i = 0; i < 6; i++) row.a_x[i] = i < m ? ref[ML_REF_ACCEL + i] + c->u[i] : NAN;
  /* qdd = J+ (a_x - Jdot qd), qd_ref = J+ twist_d, and J+ (J qd) for the null space */
  bias_acceleration(c, q, qd, c->bias_acc);
  for (int i = 0; i < m; i++) {
    rhs[3 * i] = row.a_x[i] - c->bias_acc[i];
    rhs[3 * i + 1] = ref[ML_REF_TWIST + i];
    rhs[3 * i + 2] = Jqd[i];
  }
  ml_dls_solve(&c->dls, rhs, 3, sol);
  double* qdd = row.qdd;
  for (int j = 0; j < n; j++) {
    qdd[j] = sol[3 * j];
    if (g->null_damping > 0.0) qdd[j] = qdd[j] - g->null_damping * (qd[j] - sol[3 * j + 2]);
  }
  if (posture && g->null_damping > 0.0) posture_pull(c, q, posture, qdd);
  /* G1 */
  g->mass_bias(g->params, q, qd, NULL, c->Mb);
  const double* M = c->Mb;
  const double* bias = c->Mb + n * n;
  for (int i = 0; i < n; i++) {
    double sum = 0.0;
    for (int j = 0; j < n; j++) sum += M[i * n + j] * qdd[j];
    row.tau[i] = sum + bias[i] + g->viscous[i] * qd[i];
    if (g->coulomb) row.tau[i] += g->coulomb[i] * tanh(sol[3 * i + 1] / g->stribeck[i]);
    if (g->weight) {  /* a hanging tool's weight at the end effector (J's position rows) */
      for (int r = 0; r < 3; r++) row.tau[i] -= c->J[r * n + i] * g->weight[r];
    }
  }
  /* the drives */
  for (int j = 0; j < n; j++) {
    double qd_ref = sol[3 * j + 1];
    row.dP_d[j] = row.phi[j] = NAN;
    switch (g->drive[j]) {
      case ML_DRIVE_VALVE:
        cmd[j] = valve_drive(c, j, row.tau[j], qd[j], qd_ref, dP[j], row.dP_d + j, row.phi + j);
        break;
      case ML_DRIVE_FORCE:
        cmd[j] = clip(row.tau[j], -g->limit[j], g->limit[j]);
        break;
      case ML_DRIVE_CHAMBERS:
        cmd[j] = chamber_drive(c, j, row.tau[j], q[j], qd[j], qd_ref, dP[j], pB ? pB[j] : 0.0,
                               row.dP_d + j);
        break;
      default:
        cmd[j] = NAN;
    }
    if (aux) {
      aux[ML_AUX_TAU * n + j] = row.tau[j];
      aux[ML_AUX_QD_REF * n + j] = qd_ref;
    }
  }
  c->p_started = 1;
}

static void pid_mode(ml_cascade* c, const double* ref, const double* q, const double* qd,
                     const double* e, const double* de, const double* posture, double* cmd,
                     double* aux, row_view row) {
  const ml_cascade_config* g = &c->cfg;
  int n = g->n, m = g->rows;
  const double* ff = c->ff;
  int moving = 0;
  if (posture) { /* a PID per joint on the planned joint path, its speed fed forward; the
                    integrators wait for the path to stop (no wind-up from a joint's lag) */
    for (int j = 0; j < n; j++) {
      c->err[j] = posture[j] - q[j];
      c->rate[j] = posture[n + j] - qd[j];
      moving |= posture[n + j] != 0.0;
    }
    ff = posture + n;
  } else { /* the task's error, its rate and its reference speed by the same least squares */
    for (int i = 0; i < m; i++) {
      c->rhs[3 * i] = e[i];
      c->rhs[3 * i + 1] = de[i];
      c->rhs[3 * i + 2] = ref[ML_REF_TWIST + i];
      moving |= ref[ML_REF_TWIST + i] != 0.0;
    }
    ml_dls_solve(&c->dls, c->rhs, 3, c->sol);
    for (int j = 0; j < n; j++) {
      c->err[j] = c->sol[3 * j];
      c->rate[j] = c->sol[3 * j + 1];
      c->ff[j] = c->sol[3 * j + 2];
    }
  }
  pid_update(&g->joint, &c->joint, n, c->any_integral_joint, g->dt, c->err, c->rate, ff, moving,
             c->u);
  /* a force source (or Python's drive) needs the joint's inertia for its velocity loop */
  int inertia = c->python_drives > 0;
  for (int j = 0; j < n; j++) inertia |= g->drive[j] == ML_DRIVE_FORCE;
  if (inertia) g->mass(g->params, q, NULL, NULL, c->Mb);
  for (int j = 0; j < n; j++) {
    double speed = c->u[j];
    switch (g->drive[j]) {
      case ML_DRIVE_VALVE: /* i_v = v A / C, the no-load inversion */
      case ML_DRIVE_CHAMBERS:  /* its no-load inversion's A and C (ChamberDrive.compiled) */
        cmd[j] = clip(speed * g->area[j] / g->valve_gain[j], -g->limit[j], g->limit[j]);
        break;
      case ML_DRIVE_FORCE: {
        double force = c->Mb[j * n + j] * g->velocity_gain * (speed - qd[j]);
        cmd[j] = clip(force, -g->limit[j], g->limit[j]);
        break;
      }
      default:
        cmd[j] = NAN;
    }
    if (aux) {
      aux[ML_AUX_SPEED * n + j] = speed;
      aux[ML_AUX_INERTIA * n + j] = inertia ? c->Mb[j * n + j] : NAN;
    }
    row.qdd[j] = row.tau[j] = row.dP_d[j] = row.phi[j] = NAN;
  }
  for (int i = 0; i < 6; i++) row.a_x[i] = NAN;
}

/* --- the sample ------------------------------------------------------------------------------- */

int ml_cascade_sample(ml_cascade* c, double t, const double* ref, const double* q,
                      const double* qd, const double* dP, const double* pB,
                      const double* posture, double* cmd, double* aux) {
  const ml_cascade_config* g = &c->cfg;
  int n = g->n, m = g->rows;
  ml_cascade_log* log = c->log;
  int status = ML_CASCADE_OK;
  /* the row: in the log, or in scratch when there is no room (the command is made anyway) */
  double *x_d, *x, *e;
  row_view row;
  if (log && log->count < log->capacity) {
    int k = log->count;
    log->t[k] = t;
    x_d = log->x_d + 12 * k;
    x = log->x + 12 * k;
    e = log->e + 6 * k;
    row.a_x = log->a_x + 6 * k;
    row.qdd = log->qdd + n * k;
    row.tau = log->tau + n * k;
    row.dP_d = log->dP_d + n * k;
    row.phi = log->phi + n * k;
  } else {
    double* s = c->spare_row;
    status = log ? ML_CASCADE_LOG_FULL : ML_CASCADE_OK;
    x_d = s;
    x = s + 12;
    e = s + 24;
    row.a_x = s + 30;
    row.qdd = s + 36;
    row.tau = row.qdd + n;
    row.dP_d = row.tau + n;
    row.phi = row.dP_d + n;
  }
  /* G3 */
  g->fk(g->params, q, NULL, NULL, c->H);
  g->jacobian(g->params, q, NULL, NULL, c->J);
  const double* H = c->H;
  double p[3] = {H[3], H[7], H[11]};
  double R[9] = {H[0], H[1], H[2], H[4], H[5], H[6], H[8], H[9], H[10]};
  memcpy(x_d, ref + ML_REF_P, 12 * sizeof(double));
  memcpy(x, p, sizeof(p));
  memcpy(x + 3, R, sizeof(R));
  /* the task error [p_d - p; log(R_d R^T)] and its rate twist_d - J qd on the task rows */
  const double* Rd = ref + ML_REF_R;
  for (int i = 0; i < 6; i++) e[i] = i < 3 ? ref[ML_REF_P + i] - p[i] : NAN;
  if (m == 6) {
    for (int i = 0; i < 3; i++) {
      for (int j = 0; j < 3; j++) {
        c->E[3 * i + j] = Rd[3 * i] * R[3 * j] + Rd[3 * i + 1] * R[3 * j + 1] +
                          Rd[3 * i + 2] * R[3 * j + 2];
      }
    }
    rotation_log(c->E, e + 3);
  }
  double Jqd[6], de[6];
  for (int i = 0; i < m; i++) {
    double sum = 0.0;
    for (int j = 0; j < n; j++) sum += c->J[i * n + j] * qd[j];
    Jqd[i] = sum;
    de[i] = ref[ML_REF_TWIST + i] - sum;
  }
  ml_dls_factor(&c->dls, c->J, g->weights, g->dls_damping, g->dls_threshold);
  if (g->mode == ML_MODE_PID) {
    pid_mode(c, ref, q, qd, e, de, posture, cmd, aux, row);
  } else {
    cascade_mode(c, ref, q, qd, dP, pB, posture, e, de, Jqd, cmd, aux, row);
  }
  return status;
}

void ml_cascade_commit(ml_cascade* c, const double* cmd) {
  const ml_cascade_config* g = &c->cfg;
  int n = g->n;
  if (g->mode == ML_MODE_CASCADE) {
    int saturated = 0;
    for (int j = 0; j < n; j++) saturated |= fabs(cmd[j]) >= g->limit[j];
    c->saturated = saturated;
  }
  ml_cascade_log* log = c->log;
  if (log && log->count < log->capacity) {
    memcpy(log->cmd + n * log->count, cmd, (size_t)n * sizeof(double));
    log->count++;
  }
}

/* --- the run loop's controller ---------------------------------------------------------------- */

int ml_cascade_control(void* context, double t, const mjModel* m, const mjData* d, double* u) {
  ml_cascade_run* run = (ml_cascade_run*)context;
  ml_cascade* c = run->cascade;
  int n = c->cfg.n;
  if (c->python_drives) return run->status = ML_CASCADE_PYTHON_DRIVE;
  /* the sample at t: the schedule's next time within round-off */
  double tol = 1e-9 * c->cfg.dt;
  int k = run->next;
  while (k < run->count && run->times[k] < t - tol) k++;
  if (k >= run->count || run->times[k] > t + tol) return run->status = ML_CASCADE_NO_SAMPLE;
  run->next = k + 1;
  for (int j = 0; j < n; j++) {  /* a lumped cylinder's dP, a pinned one's pA and pB */
    int drive = c->cfg.drive[j], adr = m->actuator_actadr[j];
    int pressures = drive == ML_DRIVE_VALVE || drive == ML_DRIVE_CHAMBERS;
    c->dP[j] = pressures ? d->act[adr] : 0.0;
    c->pB[j] = drive == ML_DRIVE_CHAMBERS ? d->act[adr + 1] : 0.0;
  }
  const double* posture = run->postures ? run->postures + 2 * n * k : NULL;
  int status = ml_cascade_sample(c, t, run->refs + ML_REF_SIZE * k, d->qpos, d->qvel, c->dP,
                                 c->pB, posture, u, NULL);
  if (status) return run->status = status;
  ml_cascade_commit(c, u);
  for (int j = 0; j < n; j++) {
    if (!isfinite(u[j])) return run->status = ML_CASCADE_NOT_FINITE;
  }
  return 0;
}

/* ml_cascade_control is plant.h's controller type (a compile-time check, and its address). */
ml_controller_fn ml_cascade_controller(void) { return ml_cascade_control; }
