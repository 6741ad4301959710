/* maniplab's plant in C: the friction/limit automaton around MuJoCo's step, the run loop and its
   recording, with no Python per step (the caller may release the GIL for a whole run).

   A plant steps one mjModel/mjData pair. Each step of length dt (m->opt.timestep times the
   substeps) is MuJoCo's mj_step split in two, as in the paper's template plant:

     prepare (at t): commands clipped into ctrl; the slipping joints' friction into qfrc_applied;
       the held joints (stuck, or on a limit) made immovable by a large armature; mj_forward;
       the automaton decides the step's modes on that evaluation (break-away, release from a
       stop, joints that stop within the step), evaluating again after any change;
     advance: MuJoCo's integrator from that evaluation; then the step's events (held joints put
       back, stick and limit events) and the instability checks.

   The physics of the actuators is MuJoCo's (its motor, maniplab's engine plugins); actuators
   written in Python are reached through MuJoCo's act_dyn/act_bias callbacks: this library
   installs one dispatcher for the process (ml_mjcb_install), which answers the plant the calling
   thread steps and leaves every other model as MuJoCo would. */
#ifndef MANIPLAB_PLANT_H_
#define MANIPLAB_PLANT_H_

#include <stdint.h>

#include <mujoco/mujoco.h>

/* Friction/limit modes of a joint (maniplab.friction.FrictionMode). */
enum { ML_SLIP = 0, ML_STICK = 1, ML_AT_LOWER = 2, ML_AT_UPPER = 3 };

/* Outcome of a call that steps. */
enum {
  ML_OK = 0,              /* done */
  ML_PAUSED = 1,          /* ml_plant_run stopped after max_steps: call it again to go on */
  ML_UNSTABLE_MOTION = 2, /* a NaN/inf/huge value in qpos, qvel or qacc (err_joint, err_index: the
                             MuJoCo warning mjWARN_BADQPOS/QVEL/QACC, or -1 for a velocity) */
  ML_STATE_BOUND = 3,     /* an actuator state beyond its bound (err_joint, err_index: act adr) */
  ML_BAD_COMMAND = 4,     /* a non-finite command (err_joint) */
  ML_CONTROLLER_ERROR = 5,/* the controller returned non-zero */
  ML_CALLBACK_ERROR = 6,  /* a Python actuator callback or check failed */
  ML_BAD_RUN = 7          /* ml_plant_run: a count or time of the ml_run out of range (steps or k
                             negative, every < 1, dt not positive and finite...) */
};

/* A controller the run loop calls at its samples: writes the commands u (n) for the state in
   (m, d) at time t (d->time == t). Returns 0, or non-zero to stop the run. */
typedef int (*ml_controller_fn)(void* context, double t, const mjModel* m, const mjData* d,
                                double* u);

/* A Python actuator's MuJoCo callback (kind 0: act_dyn, 1: act_bias) for actuator `id`: writes
   the return value to *out (act_dyn of a multi-state actuator writes d->act_dot itself).
   Returns 0, or non-zero when the Python code raised. */
typedef int (*ml_actuator_fn)(int kind, int id, double* out);

/* A per-step check in Python of actuator states the plant cannot bound itself: the joint whose
   state is wrong, or -1. */
typedef int (*ml_check_fn)(void);

/* What the plant needs besides the model: all arrays have n entries (n = nv = the first n
   actuators, one per joint), copied by ml_plant_new. */
typedef struct {
  int n;
  int substeps;            /* MuJoCo steps per plant step */
  double hold_inertia;     /* armature added to a held joint, kg or kg m^2 */
  const double* lower;     /* joint limits, -inf/+inf for none */
  const double* upper;
  const double* command_limit; /* |u| <= limit, inf for none */
  const int* slip;         /* 1: the joint has hybrid (Coulomb + Stribeck) friction */
  const double* coulomb;   /* Fc, N or N m */
  const double* stiction;  /* Fs (above Coulomb) */
  const double* stribeck;  /* vs, m/s or rad/s */
  const double* stick_velocity; /* > 0: the joint can stick (hybrid with Fc + Fs > 0); else 0 */
  int nbounds;             /* actuator states with a bound |act[adr]| <= value (NaN fails) */
  const int* bound_adr;
  const double* bound_value;
  const int* bound_joint;
  /* A pinned cylinder's rod friction, in newtons on the rod (NULL: no joint has any). It acts
     on joint j through the moment arm r of actuator j (MuJoCo's actuator moment ds/dq, taken
     exactly at each step's start pose): Coulomb Fc|r| and stiction Fs|r| added to the joint's
     own (slip must be 1 when Fc + Fs > 0), Stribeck and stick velocities vs/|r| and sv/|r|;
     the viscous part Fv r^2 is MuJoCo's (the tendon's damping), here for the record only. */
  const int* rod;          /* 1: joint j has rod friction */
  const double* rod_coulomb;   /* Fc, N */
  const double* rod_stiction;  /* Fs (above Coulomb), N */
  const double* rod_stribeck;  /* vs, m/s */
  const double* rod_viscous;   /* Fv, N s/m */
  const double* rod_stick_velocity; /* m/s */
} ml_plant_config;

typedef struct ml_plant ml_plant;

/* A run of `steps` steps from the plant's current state: samples k = 0..steps at t0 + k dt, the
   last one prepared but not advanced. Sample k's command is held + inputs[k - inputs_k0] (the
   controller's held command plus the open-loop inputs); the controller is called before sample k
   when k < steps and t >= next_call - 1e-9 dt, then next_call += period (period 0: every step).
   Rows are recorded at samples with k % every == 0 and at k == steps: the state at the step's
   start (q, qd after the step's stick resets, act), the clipped command, the modes, and the
   friction and limit forces of the step (the last row: the last step's), and the position of
   body ee_body (from the step's forward pass). A row is written whole within one call, at index
   `rows` of the buffers; while the run is paused the caller may take the rows written, set
   `rows` back to 0 and move the inputs' window (inputs, inputs_k0), so that a run of any length
   is recorded through buffers of max_steps / every + 2 rows and inputs of max_steps + 1 rows. */
typedef struct {
  int64_t steps;           /* 64 bits: a run may be longer than 2^31 steps */
  double t0, dt;
  int64_t k;               /* in/out: the next sample; 0 to start */
  int max_steps;           /* pause (ML_PAUSED) after this many steps; 0: never */
  const double* inputs;    /* rows k - inputs_k0 (n each) for the samples k of this call, or NULL */
  int64_t inputs_k0;       /* the sample of inputs' first row; 0 for a table of all steps + 1 */
  double* held;            /* (n): the controller's last commands (in/out) */
  ml_controller_fn controller; /* or NULL */
  void* controller_context;
  double period;
  double next_call;        /* in/out: t0 to start */
  int64_t every;
  int rows;                /* in/out: the buffers' next row (rows written); 0 to start */
  double* t;               /* (rows,) */
  double* q;               /* (rows, n) */
  double* qd;              /* (rows, n) */
  double* act;             /* (rows, na) */
  double* ctrl;            /* (rows, n) */
  signed char* mode;       /* (rows, n) */
  double* fric;            /* (rows, n): the slipping joints' applied friction, stiction's holding
                              force (the step's average), the friction actuators' (LuGre's bristles,
                              the actuators after the first n) at the step's start; not the joints'
                              viscous friction (the rod friction's viscous part at the step's start
                              is included: it changes with the pose) */
  double* limit;           /* (rows, n) */
  int ee_body;             /* a body whose position is recorded (the end-effector), or -1 */
  double* ee_pos;          /* (rows, 3): its position at the step's start (d->xpos) */
  double* plugin_state;    /* (rows, npluginstate): the plugins' states at the step's start (the
                              cylinders' energy accumulators among them), or NULL */
  int columns;             /* the inputs' columns: n (0 reads as n), or n + 1 with a measured
                              supply pressure (Pa) last, written to d->userdata[0] for the step's
                              start and [1] for its end (the pinned cylinders take it instead of
                              their pump's; the model needs nuserdata >= 2) */
} ml_run;

/* Outcome details after a call returned an error. */
typedef struct {
  int status;
  int joint;               /* -1 when unknown */
  int index;               /* see the status codes */
  double time;
} ml_error;

ml_plant* ml_plant_new(mjModel* m, mjData* d, const ml_plant_config* config);
void ml_plant_free(ml_plant* p);

/* The Python actuators' callbacks (NULL: none) and per-step check (NULL: none). */
void ml_plant_set_python(ml_plant* p, ml_actuator_fn actuator, ml_check_fn check);

/* Install the process's mjcb_act_dyn/mjcb_act_bias dispatcher unless it is installed, chaining to
   the callbacks installed now; it is never removed. It answers a call with the Python actuators
   of the plant (with them) that the calling thread steps; for any other model it calls the
   chained callback, or returns 0 without one, as MuJoCo does without callbacks. A plant call
   installs it again if someone replaced it (mujoco.set_mjcb_act_dyn), chaining to the new one. */
void ml_mjcb_install(void);
/* on != 0: for the calling thread, the dispatcher answers every model but its plant's with 0 (no
   chained callback: MuJoCo calls them while compiling a model). Returns the previous setting. */
int ml_mjcb_suspend(int on);

/* After a reset or any change of the state: modes from the state (on a limit: AT_*, velocity
   zeroed; at rest with stick/slip friction: STICK; else SLIP), break-away directions cleared. */
void ml_plant_resync(ml_plant* p);

/* First half of a step at the current time: commands u (n), clipped. Returns ML_OK. */
int ml_plant_prepare(ml_plant* p, const double* u);
/* Second half (after ml_plant_prepare): integrate dt in `substeps` MuJoCo steps. */
int ml_plant_advance(ml_plant* p);
/* A run (see ml_run); returns ML_OK, ML_PAUSED or an error. */
int ml_plant_run(ml_plant* p, ml_run* run);

/* The last step's record: the prepared step's start (q, qd, act), clipped commands and modes,
   and the friction and limit forces of the last advanced step. Any pointer may be NULL. */
void ml_plant_record(const ml_plant* p, double* q, double* qd, double* act, double* u,
                     signed char* mode, double* fric, double* limit);
/* The joints' current modes. */
void ml_plant_modes(const ml_plant* p, signed char* mode);
/* The last error's details. */
ml_error ml_plant_error(const ml_plant* p);

#endif
