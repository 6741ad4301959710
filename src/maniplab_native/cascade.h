/* The cascade controller's sample in C: maniplab.control.cascade.CascadeController's control law
   (the paper's Fig. 8 cascade, or the PID-only baseline), with no Python and no allocation per
   sample. CascadeController builds one ml_cascade from its blocks' settings and calls it for
   every sample, from Python (ml_cascade_sample, then ml_cascade_commit) or from the plant's C run
   loop (ml_cascade_control, an ml_controller_fn of plant.h, over a pre-sampled reference).

   A sample, at time t for the joint state (q, qd) and the cylinders' pressures dP:

   1. G3: the end-effector's pose (p, R) and Jacobian J from the arm's compiled model;
   2. the task error e = [p_d - p; log(R_d R^T)] and its rate de = twist_d - J qd on the task
      rows (3: position, 6: pose);
   3. cascade: a_x = accel_d + PID(e, de) (integrator frozen while the last command saturated);
      qdd = J+ (a_x - Jdot qd) by damped least squares (linalg.h), Jdot qd the central difference
      of J along qd, minus null_damping times the joint speed's null-space part on a redundant
      arm (with a planned joint path, the null space's part of w^2 (q_p - q) + D (qd_p - qd),
      w = D/2: the arm follows the path the planner checked instead of drifting onto a limit);
      G1: tau = M qdd + C qd + G + Fv qd (+ Fc tanh(qd_ref / vs)) (- J_p^T w, the weight w of
      a tool hanging at the end effector), qd_ref = J+ twist_d;
      then each joint's drive: a valve's pressure loop and G2 (valve.h), a pinned cylinder's
      load-pressure loop and four-edge valve inversion (chambers.h), or a force source's
      clip(tau);
      pid: a joint PID on (J+ e, J+ de) gives joint speeds; a valve gets i_v = v A / C, a force
      source a velocity loop's force M_jj k_v (v - qd).
   Joints whose drive is written in Python (ML_DRIVE_PYTHON) get NaN; the sample leaves their
   inputs (tau, qd_ref, or the speed and M_jj) in `aux` for Python to finish, and
   ml_cascade_commit takes the whole command. Every step computes exactly what the Python blocks
   (PID, DampedLeastSquares, Kinematics, InverseDynamics, PressureLoop) compute, in their order of
   operations, so the two agree to round-off. */
#ifndef MANIPLAB_CASCADE_H_
#define MANIPLAB_CASCADE_H_

#include <mujoco/mujoco.h>

#include "chambers.h"

/* A kernel of the arm's compiled analytic model (maniplab.model.tape): out from the model's
   parameter vector p and the state (q, qd, qdd; unused ones may be NULL). */
typedef void (*ml_kernel_fn)(const double* p, const double* q, const double* qd,
                             const double* qdd, double* out);

enum { ML_MODE_CASCADE = 0, ML_MODE_PID = 1 };

/* How a joint's command is made from the desired force. */
enum {
  ML_DRIVE_VALVE = 0,  /* a hydraulic cylinder: pressure loop and G2 (PressureDrive) */
  ML_DRIVE_FORCE = 1,  /* a force/torque source: the force, clipped (its steady state) */
  ML_DRIVE_PYTHON = 2, /* a drive written in Python: finished by the caller */
  ML_DRIVE_CHAMBERS = 3 /* a pinned two-chamber cylinder: its load-pressure loop and the inversion
                           of its four-edge valve (ChamberDrive) */
};

/* The reference at one sample, ML_REF_SIZE doubles: p_d, R_d (row-major), twist_d, accel_d. */
enum { ML_REF_P = 0, ML_REF_R = 3, ML_REF_TWIST = 12, ML_REF_ACCEL = 18, ML_REF_SIZE = 24 };

/* Rows of the sample's `aux` (ML_AUX_SIZE x n) for the drives written in Python. */
enum { ML_AUX_TAU = 0, ML_AUX_QD_REF = 1, ML_AUX_SPEED = 2, ML_AUX_INERTIA = 3, ML_AUX_SIZE = 4 };

/* ml_cascade_sample's outcome; ml_cascade_run's status (0: none). */
enum {
  ML_CASCADE_OK = 0,
  ML_CASCADE_LOG_FULL = 1,     /* no room for the sample's row (the command was still made) */
  ML_CASCADE_NO_SAMPLE = 2,    /* the run loop called at a time not in the schedule */
  ML_CASCADE_NOT_FINITE = 3,   /* a command came out NaN or infinite */
  ML_CASCADE_PYTHON_DRIVE = 4  /* a joint's drive is Python's: no native run */
};

/* A vector PID with a measured error rate (maniplab.control.pid.PID.update with `rate`). */
typedef struct {
  const double *kp, *ki, *kd;  /* gains (size) */
  const double *lo, *hi;       /* output limits (size), or NULL when `limited` is 0 */
  const double* tracking;      /* anti-windup tracking time Tt, s (size), or NULL likewise */
  int limited;                 /* any finite limit */
  double filter_a, filter_b;   /* derivative filter: Tf/(Tf + h) and h/(Tf + h) */
} ml_pid_gains;

/* Everything ml_cascade_new copies: sizes, the model's kernels and every gain. Arrays have n
   entries unless noted; a valve's entries are unused at other joints. */
typedef struct {
  int n;                        /* joints */
  int rows;                     /* task rows: 3 (position) or 6 (pose) */
  int mode;                     /* ML_MODE_* */
  int nparams;
  const double* params;         /* the analytic model's parameter vector (nparams) */
  ml_kernel_fn fk, jacobian, mass, mass_bias;
  double dt;                    /* sample time h, s */
  double fd_step;               /* the Jdot qd difference's joint step, rad or m */
  ml_pid_gains outer;           /* the Cartesian PID (rows) */
  double dls_damping, dls_threshold;
  const double* weights;        /* least-squares joint weights, or NULL */
  double null_damping;          /* 1/s; 0: none (also when the arm is not redundant) */
  const double* viscous;        /* Fv */
  const double* coulomb;        /* Fc of the feed-forward, or NULL: none */
  const double* stribeck;       /* vs */
  ml_pid_gains joint;           /* the baseline's joint PID (n) */
  double velocity_gain;         /* the baseline's velocity loop k_v, 1/s */
  const int* drive;             /* ML_DRIVE_* */
  const double* limit;          /* command limits, inf: none */
  const double* area;           /* A */
  const double* valve_gain;     /* C */
  const double* supply;         /* Ps */
  const int* orifice;           /* 1: orifice law */
  const double* capacitance;    /* V/E */
  const double* leakage;        /* Le */
  const double* pressure_kp;    /* Kp_P = omega_P V/E */
  const double* pressure_ki;    /* Ki_P */
  double min_root;              /* G2's floor of the root */
  double rate_alpha;            /* the dP_d rate filter: h / (T + h) */
  double speed_gain;            /* k_v of the pressure loop's speed term */
  int compressibility;          /* include (V/E) d(dP_d)/dt */
  const ml_chambers* chambers;  /* a pinned cylinder's law (n; used at ML_DRIVE_CHAMBERS), or
                                   NULL when no joint has one */
  const double* geometry;       /* its pins' closed form (n x 3): K, rho, phi (rotational,
                                   s^2 = K - 2 rho cos(q - phi)) or w^2, b, 0 (prismatic,
                                   s^2 = w^2 + (q + b)^2); or NULL likewise */
  const int* prismatic;         /* 1: the joint slides (n), or NULL likewise */
  const double* weight;         /* the weight of a tool hanging at the end-effector point, N,
                                   base axes (3): G1 holds it, -J_p^T weight, without its inertia
                                   (a hanging tool swings free above its pendulum's frequency);
                                   or NULL: none */
} ml_cascade_config;

/* The controller's log, one row per sample, in the caller's buffers (rows: capacity). */
typedef struct {
  int capacity;
  int count;                    /* rows written */
  double* t;                    /* (capacity) s */
  double* x_d;                  /* (capacity, 12): p_d, then R_d row-major */
  double* x;                    /* (capacity, 12): p, R */
  double* e;                    /* (capacity, 6): NaN off the task rows */
  double* a_x;                  /* (capacity, 6): NaN off the task rows, or in pid mode */
  double *qdd, *tau, *dP_d, *phi, *cmd;  /* (capacity, n) */
} ml_cascade_log;

typedef struct ml_cascade ml_cascade;

/* A native run's schedule: the context of ml_cascade_control. */
typedef struct {
  ml_cascade* cascade;
  int count;                    /* samples */
  int next;                     /* the next sample expected (0 to start) */
  const double* times;          /* (count) ascending, s */
  const double* refs;           /* (count, ML_REF_SIZE) */
  int status;                   /* ML_CASCADE_* of the failed call, 0 */
  const double* postures;       /* (count, 2 n): the planned joint path q, qd at each sample, or
                                   NULL */
} ml_cascade_run;

/* sizeof of the structures, for the Python side's check of its mirrors. */
int ml_cascade_sizes(int* out4);

/* A cascade (copies the config's arrays), NULL when out of memory or the config is invalid. */
ml_cascade* ml_cascade_new(const ml_cascade_config* config);
void ml_cascade_free(ml_cascade* c);

/* Clear the loops' states (integrators, filters) and the saturation flag; the log's count to 0. */
void ml_cascade_reset(ml_cascade* c);

/* Write rows into `log` (NULL: none); the caller keeps it and its buffers alive. */
void ml_cascade_set_log(ml_cascade* c, ml_cascade_log* log);

/* One sample up to the commands: cmd (n; NaN at Python drives), the row's signals but the
   command; aux (ML_AUX_SIZE x n, or NULL). The pressures (n): dP of a lumped cylinder, and at a
   pinned one its cap side in dP and its rod side in pB (pB may be NULL when no joint has one).
   A pinned cylinder's desired load pressure goes to the row's dP_d. `posture` (2n: q, qd of the
   planned joint path at t, or NULL) pulls a redundant arm towards that path in the task's null
   space; in the PID-only mode each joint's PID tracks it (its speed fed forward) instead of the
   task error's least-squares image. Returns ML_CASCADE_OK or ML_CASCADE_LOG_FULL. */
int ml_cascade_sample(ml_cascade* c, double t, const double* ref, const double* q,
                      const double* qd, const double* dP, const double* pB,
                      const double* posture, double* cmd, double* aux);

/* Finish the sample with the whole command (n): the saturation flag the outer integrator reads
   next sample, and the row's command; the row counts from now on. */
void ml_cascade_commit(ml_cascade* c, const double* cmd);

/* The sampled controller for the plant's run loop (plant.h's ml_controller_fn): context is an
   ml_cascade_run; q and qd are d->qpos, d->qvel (n), a valve joint j's dP is
   d->act[m->actuator_actadr[j]]. Returns 0, or an ML_CASCADE_* status (also in run->status). */
int ml_cascade_control(void* context, double t, const mjModel* m, const mjData* d, double* u);

#endif
