/* An arm's plant as an FMI 2.0 co-simulation FMU: maniplab's plant in C (plant.c: MuJoCo's step
   with the friction/limit automaton; the hydraulic, cylinder and LuGre engine plugins) behind the
   FMI functions, with no Python.

   The arm's MuJoCo model travels in the FMU's resources as MJCF (resources/model.xml) in which the
   parameters are ${name} tokens. When initialisation ends, the tokens take the parameters' values
   (%.17g, as exact as the doubles), MuJoCo compiles the text, and the plant is made as maniplab's
   Plant makes it (hold inertia 1e12 times the largest diagonal entry of M at the reference pose).
   Each fmi2DoStep takes whole plant steps of ML_FMU_DT: the inputs are held over a step (the
   commands of ml.simulate), every step is prepare + advance, as a run of ml.simulate takes it.

   fmu_config.h is written for each arm by maniplab.fmu: the joints, the automaton's settings, the
   initial actuator states, the parameters and the table of variables (value reference -> kind,
   index). */
#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <mujoco/mujoco.h>

#include "fmi2.h"
#include "plant.h"
#include "plugins.h"

/* What a value reference designates (fmu_config.h's kVarKind). */
enum { ML_V_Q, ML_V_QD, ML_V_ACT, ML_V_MODE, ML_V_U, ML_V_PARAM, ML_V_Q0 };

#include "fmu_config.h"

#define HOLD_INERTIA 1e12 /* as maniplab.sim.plant.HOLD_INERTIA */

typedef enum { INSTANTIATED, INITIALIZING, STEPPING, TERMINATED, FAILED } Phase;

typedef struct {
  fmi2CallbackLogger log;
  fmi2ComponentEnvironment env;
  char name[128];
  int logging;
  char* text;                    /* resources/model.xml, with its ${tokens} */
  double param[ML_FMU_NPARAM1];  /* the parameters (kParamName) */
  double q0[ML_FMU_N];           /* the initial positions */
  double u[ML_FMU_N];            /* the inputs */
  double start;                  /* the experiment's start time, s */
  mjModel* m;
  mjData* d;
  ml_plant* plant;
  Phase phase;
} Instance;

/* --- messages ------------------------------------------------------------------------------ */
static void say(const Instance* in, fmi2Status status, const char* format, ...) {
  if (in == NULL || in->log == NULL) return;
  if (status == fmi2OK && !in->logging) return;
  char text[1024];
  va_list args;
  va_start(args, format);
  vsnprintf(text, sizeof(text), format, args);
  va_end(args);
  const char* category = status == fmi2OK ? "logAll" : (status == fmi2Warning ? "logWarning"
                                                                                 : "logError");
  /* the message is the format itself, '%' doubled: importers that cannot call variadic C
     (FMPy, through ctypes) print the format as it is */
  char escaped[2 * sizeof(text)];
  size_t k = 0;
  for (const char* s = text; *s; s++) {
    if (*s == '%') escaped[k++] = '%';
    escaped[k++] = *s;
  }
  escaped[k] = '\0';
  in->log(in->env, in->name, status, category, escaped);
}

static fmi2Status fail(Instance* in, const char* format, const char* detail) {
  say(in, fmi2Error, format, detail);
  return fmi2Error;
}

/* --- the plugins, registered once per loaded copy of this library under names of its own ------- */
static pthread_once_t g_once = PTHREAD_ONCE_INIT;
static char g_prefix[96];
static char g_names[3][128];

static void register_plugins(void) {
  struct timespec now;
  clock_gettime(CLOCK_REALTIME, &now);
  /* unique to this copy and this load: a host may load the FMU twice, or maniplab's own plugins */
  snprintf(g_prefix, sizeof(g_prefix), "mlfmu_%s_%lx_%lx.", ML_FMU_BUILD,
           (unsigned long)(size_t)&g_once, (unsigned long)(now.tv_nsec ^ now.tv_sec));
  snprintf(g_names[0], sizeof(g_names[0]), "%shydraulic", g_prefix);
  snprintf(g_names[1], sizeof(g_names[1]), "%scylinder", g_prefix);
  snprintf(g_names[2], sizeof(g_names[2]), "%slugre", g_prefix);
  ml_register_hydraulic(g_names[0]);
  ml_register_cylinder(g_names[1]);
  ml_register_lugre(g_names[2]);
}

/* --- the model ------------------------------------------------------------------------------- */
/* The template with its tokens replaced: ${plugin} by the plugins' prefix, ${name} by the
   parameter's value. NULL (and a message) on an unknown token or no memory. */
static char* fill(Instance* in) {
  const char* t = in->text;
  size_t tokens = 0;
  for (const char* s = strstr(t, "${"); s; s = strstr(s + 2, "${")) tokens++;
  size_t cap = strlen(t) + 128 * tokens + 1, used = 0;
  char* out = (char*)malloc(cap);
  if (out == NULL) return NULL;
  while (*t) {
    const char* s = strstr(t, "${");
    const char* e = s ? strchr(s, '}') : NULL;
    if (s == NULL || e == NULL) {
      strcpy(out + used, t);
      return out;
    }
    memcpy(out + used, t, (size_t)(s - t));
    used += (size_t)(s - t);
    char key[96];
    size_t len = (size_t)(e - s - 2);
    if (len >= sizeof(key)) len = sizeof(key) - 1;
    memcpy(key, s + 2, len);
    key[len] = '\0';
    int found = strcmp(key, "plugin") == 0;
    if (found) {
      used += (size_t)snprintf(out + used, cap - used, "%s", g_prefix);
    }
    for (int i = 0; i < ML_FMU_NPARAM && !found; i++) {
      if (strcmp(key, kParamName[i]) == 0) {
        used += (size_t)snprintf(out + used, cap - used, "%.17g", in->param[i]);
        found = 1;
      }
    }
    if (!found) {
      free(out);
      fail(in, "maniplab FMU: resources/model.xml has an unknown token ${%s}", key);
      return NULL;
    }
    t = e + 1;
  }
  out[used] = '\0';
  return out;
}

/* The largest diagonal entry of M at the model's reference pose, at least 1 (kg or kg m^2). */
static double largest_inertia(const mjModel* m) {
  mjData* d = mj_makeData(m);
  double* dense = (double*)calloc((size_t)(m->nv * m->nv) + 1, sizeof(double));
  double largest = 1.0;
  if (d && dense) {
    mj_kinematics(m, d);
    mj_comPos(m, d);
    mj_crb(m, d);
    mj_fullM(m, d, dense);
    for (int i = 0; i < m->nv; i++) largest = fmax(largest, dense[i * m->nv + i]);
  }
  free(dense);
  if (d) mj_deleteData(d);
  return largest;
}

static void drop_model(Instance* in) {
  if (in->plant) ml_plant_free(in->plant);
  if (in->d) mj_deleteData(in->d);
  if (in->m) mj_deleteModel(in->m);
  in->plant = NULL;
  in->d = NULL;
  in->m = NULL;
}

/* The plant at the start: time `start`, q = q0 on the limits, q' = 0, the actuators' initial
   states, the modes from that state (as Plant.reset and Plant.set_state). */
static void reset_state(Instance* in) {
  mj_resetData(in->m, in->d);
  in->d->time = in->start;
  for (int i = 0; i < in->m->na && i < ML_FMU_NA; i++) in->d->act[i] = kAct0[i];
  for (int j = 0; j < ML_FMU_N; j++) {
    in->d->qpos[j] = fmin(fmax(in->q0[j], kLower[j]), kUpper[j]);
  }
  ml_plant_resync(in->plant);
}

/* Compile the model with the parameters' values and make the plant. */
static fmi2Status build(Instance* in) {
  if (in->plant) return fmi2OK;
  char* xml = fill(in);
  if (xml == NULL) return fmi2Error;
  mjVFS vfs;
  mj_defaultVFS(&vfs);
  mj_addBufferVFS(&vfs, "model.xml", xml, (int)strlen(xml));
  char error[1024] = "";
  in->m = mj_loadXML("model.xml", &vfs, error, sizeof(error));
  mj_deleteVFS(&vfs);
  free(xml);
  if (in->m == NULL) return fail(in, "maniplab FMU: MuJoCo cannot compile the arm: %s", error);
  if (in->m->nv != ML_FMU_N || in->m->na != ML_FMU_NA) {
    drop_model(in);
    return fail(in, "maniplab FMU: %s", "the compiled model's sizes differ from the FMU's");
  }
  in->d = mj_makeData(in->m);
  if (in->d == NULL) {
    drop_model(in);
    return fail(in, "maniplab FMU: %s", "MuJoCo cannot make the model's data (see its log)");
  }
  ml_plant_config c = {ML_FMU_N, ML_FMU_SUBSTEPS, HOLD_INERTIA * largest_inertia(in->m),
                       kLower, kUpper, kCommandLimit, kSlip, kCoulomb, kStiction, kStribeck,
                       kStickVelocity, ML_FMU_NBOUND, kBoundAdr, kBoundValue, kBoundJoint,
                       kRod, kRodCoulomb, kRodStiction, kRodStribeck, kRodViscous,
                       kRodStickVelocity};
  in->plant = ml_plant_new(in->m, in->d, &c);
  if (in->plant == NULL) {
    drop_model(in);
    return fail(in, "maniplab FMU: %s", "out of memory");
  }
  reset_state(in);
  return fmi2OK;
}

/* --- checks --------------------------------------------------------------------------------- */
static int bad_references(Instance* in, const fmi2ValueReference vr[], size_t nvr,
                          int integer) {
  for (size_t i = 0; i < nvr; i++) {
    if (vr[i] >= ML_FMU_NVAR || (kVarKind[vr[i]] == ML_V_MODE) != integer) {
      say(in, fmi2Error, "maniplab FMU: no %s variable has value reference %u",
          integer ? "Integer" : "Real", vr[i]);
      return 1;
    }
  }
  return 0;
}

/* One line on a parameter outside its range, or NULL. */
static int bad_parameter(Instance* in, int i, double value) {
  int ok = isfinite(value) && (kParamPositive[i] ? value > 0.0 : value >= 0.0);
  if (!ok) {
    say(in, fmi2Error, "maniplab FMU: parameter %s = %g: it must be %s", kParamName[i], value,
        kParamPositive[i] ? "positive" : "zero or positive");
  }
  return !ok;
}

/* --- FMI: instances -------------------------------------------------------------------------- */
ML_FMI2_EXPORT const char* fmi2GetTypesPlatform(void) { return "default"; }
ML_FMI2_EXPORT const char* fmi2GetVersion(void) { return "2.0"; }

/* The file named by a file: URI ("file:///a/b", "file:/a/b", "file://localhost/a/b"), with %XX
   escapes decoded; NULL when it is not one. */
static char* uri_path(const char* uri) {
  if (uri == NULL || strncmp(uri, "file:", 5) != 0) return NULL;
  const char* p = uri + 5;
  if (strncmp(p, "///", 3) == 0) {
    p += 2;
  } else if (strncmp(p, "//localhost/", 12) == 0) {
    p += 11;
  }
  char* out = (char*)malloc(strlen(p) + 1);
  if (out == NULL) return NULL;
  size_t k = 0;
  for (; *p; p++) {
    unsigned int hex;
    if (p[0] == '%' && p[1] && p[2] && sscanf(p + 1, "%2x", &hex) == 1) {
      out[k++] = (char)hex;
      p += 2;
    } else {
      out[k++] = *p;
    }
  }
  out[k] = '\0';
  return out;
}

static char* read_resource(const char* location, const char* file) {
  char* folder = uri_path(location);
  if (folder == NULL) return NULL;
  size_t len = strlen(folder) + strlen(file) + 2;
  char* path = (char*)malloc(len);
  char* text = NULL;
  if (path) {
    snprintf(path, len, "%s/%s", folder, file);
    FILE* f = fopen(path, "rb");
    if (f) {
      fseek(f, 0, SEEK_END);
      long size = ftell(f);
      fseek(f, 0, SEEK_SET);
      text = size >= 0 ? (char*)malloc((size_t)size + 1) : NULL;
      if (text && fread(text, 1, (size_t)size, f) == (size_t)size) {
        text[size] = '\0';
      } else {
        free(text);
        text = NULL;
      }
      fclose(f);
    }
  }
  free(path);
  free(folder);
  return text;
}

ML_FMI2_EXPORT fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type type,
                                             fmi2String guid, fmi2String resourceLocation,
                                             const fmi2CallbackFunctions* functions,
                                             fmi2Boolean visible, fmi2Boolean loggingOn) {
  (void)visible;
  Instance* in = (Instance*)calloc(1, sizeof(Instance));
  if (in == NULL) return NULL;
  in->log = functions ? functions->logger : NULL;
  in->env = functions ? functions->componentEnvironment : NULL;
  snprintf(in->name, sizeof(in->name), "%s", instanceName ? instanceName : "arm");
  in->logging = loggingOn;
  const char* problem = NULL;
  if (type != fmi2CoSimulation) {
    problem = "this FMU is for co-simulation only (no model exchange)";
  } else if (guid == NULL || strcmp(guid, ML_FMU_GUID) != 0) {
    problem = "the GUID differs from modelDescription.xml's (files of two FMUs mixed?)";
  } else if ((in->text = read_resource(resourceLocation, "model.xml")) == NULL) {
    problem = "cannot read resources/model.xml from the resource location";
  }
  if (problem) {
    say(in, fmi2Error, "maniplab FMU: %s", problem);
    free(in->text);
    free(in);
    return NULL;
  }
  pthread_once(&g_once, register_plugins);
  memcpy(in->param, kParamDefault, sizeof(in->param));
  memcpy(in->q0, kQ0Default, sizeof(in->q0));
  in->phase = INSTANTIATED;
  return in;
}

ML_FMI2_EXPORT void fmi2FreeInstance(fmi2Component c) {
  Instance* in = (Instance*)c;
  if (in == NULL) return;
  drop_model(in);
  free(in->text);
  free(in);
}

ML_FMI2_EXPORT fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn,
                                              size_t nCategories, const fmi2String categories[]) {
  (void)nCategories;
  (void)categories;
  ((Instance*)c)->logging = loggingOn;
  return fmi2OK;
}

ML_FMI2_EXPORT fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                                              fmi2Real tolerance, fmi2Real startTime,
                                              fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
  (void)toleranceDefined;
  (void)tolerance;
  (void)stopTimeDefined;
  (void)stopTime;
  ((Instance*)c)->start = startTime;
  return fmi2OK;
}

ML_FMI2_EXPORT fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
  ((Instance*)c)->phase = INITIALIZING;
  return fmi2OK;
}

ML_FMI2_EXPORT fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
  Instance* in = (Instance*)c;
  fmi2Status status = build(in);
  in->phase = status == fmi2OK ? STEPPING : FAILED;
  return status;
}

ML_FMI2_EXPORT fmi2Status fmi2Terminate(fmi2Component c) {
  ((Instance*)c)->phase = TERMINATED;
  return fmi2OK;
}

ML_FMI2_EXPORT fmi2Status fmi2Reset(fmi2Component c) {
  Instance* in = (Instance*)c;
  drop_model(in);
  memcpy(in->param, kParamDefault, sizeof(in->param));
  memcpy(in->q0, kQ0Default, sizeof(in->q0));
  memset(in->u, 0, sizeof(in->u));
  in->start = 0.0;
  in->phase = INSTANTIATED;
  return fmi2OK;
}

/* --- FMI: values ----------------------------------------------------------------------------- */
ML_FMI2_EXPORT fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      fmi2Real value[]) {
  Instance* in = (Instance*)c;
  if (bad_references(in, vr, nvr, 0)) return fmi2Error;
  for (size_t i = 0; i < nvr; i++) {
    int kind = kVarKind[vr[i]], k = kVarIndex[vr[i]];
    if (kind == ML_V_U) {
      value[i] = in->u[k];
    } else if (kind == ML_V_PARAM) {
      value[i] = in->param[k];
    } else if (kind == ML_V_Q0) {
      value[i] = in->q0[k];
    } else {
      if (build(in) != fmi2OK) return fmi2Error; /* outputs during initialisation */
      const mjData* d = in->d;
      value[i] = kind == ML_V_Q ? d->qpos[k] : (kind == ML_V_QD ? d->qvel[k] : d->act[k]);
    }
  }
  return fmi2OK;
}

ML_FMI2_EXPORT fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[],
                                         size_t nvr, fmi2Integer value[]) {
  Instance* in = (Instance*)c;
  if (bad_references(in, vr, nvr, 1)) return fmi2Error;
  if (nvr == 0) return fmi2OK;
  if (build(in) != fmi2OK) return fmi2Error;
  signed char modes[ML_FMU_N];
  ml_plant_modes(in->plant, modes);
  for (size_t i = 0; i < nvr; i++) value[i] = modes[kVarIndex[vr[i]]];
  return fmi2OK;
}

ML_FMI2_EXPORT fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      const fmi2Real value[]) {
  Instance* in = (Instance*)c;
  if (bad_references(in, vr, nvr, 0)) return fmi2Error;
  for (size_t i = 0; i < nvr; i++) {
    int kind = kVarKind[vr[i]], k = kVarIndex[vr[i]];
    if (kind == ML_V_U) {
      in->u[k] = value[i];
      continue;
    }
    if (kind != ML_V_PARAM && kind != ML_V_Q0) {
      say(in, fmi2Error, "maniplab FMU: value reference %u is an output: it cannot be set", vr[i]);
      return fmi2Error;
    }
    if (in->phase != INSTANTIATED && in->phase != INITIALIZING) {
      say(in, fmi2Error, "maniplab FMU: parameters are fixed once initialisation has ended");
      return fmi2Error;
    }
    if (kind == ML_V_PARAM && bad_parameter(in, k, value[i])) return fmi2Error;
    if (kind == ML_V_Q0 && !isfinite(value[i])) {
      say(in, fmi2Error, "maniplab FMU: q0.%s = %g is not a finite number", kJoint[k], value[i]);
      return fmi2Error;
    }
    if (kind == ML_V_PARAM) in->param[k] = value[i];
    if (kind == ML_V_Q0) in->q0[k] = value[i];
    drop_model(in); /* rebuilt with the new value when needed */
  }
  return fmi2OK;
}

ML_FMI2_EXPORT fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[],
                                         size_t nvr, const fmi2Integer value[]) {
  (void)value;
  if (nvr == 0) return fmi2OK;
  say((Instance*)c, fmi2Error, "maniplab FMU: value reference %u (a mode) cannot be set", vr[0]);
  return fmi2Error;
}

static fmi2Status no_such(fmi2Component c, size_t nvr, const char* type) {
  if (nvr == 0) return fmi2OK;
  say((Instance*)c, fmi2Error, "maniplab FMU: it has no %s variables", type);
  return fmi2Error;
}

ML_FMI2_EXPORT fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[],
                                         size_t nvr, fmi2Boolean value[]) {
  (void)vr;
  (void)value;
  return no_such(c, nvr, "Boolean");
}

ML_FMI2_EXPORT fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t nvr, fmi2String value[]) {
  (void)vr;
  (void)value;
  return no_such(c, nvr, "String");
}

ML_FMI2_EXPORT fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[],
                                         size_t nvr, const fmi2Boolean value[]) {
  (void)vr;
  (void)value;
  return no_such(c, nvr, "Boolean");
}

ML_FMI2_EXPORT fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2String value[]) {
  (void)vr;
  (void)value;
  return no_such(c, nvr, "String");
}

/* --- FMI: stepping --------------------------------------------------------------------------- */
static const char* cause(int status) {
  switch (status) {
    case ML_UNSTABLE_MOTION: return "unstable motion (a NaN, infinite or huge value)";
    case ML_STATE_BOUND: return "an actuator state beyond its bound (a pressure far beyond supply?)";
    case ML_BAD_COMMAND: return "a non-finite input";
    default: return "the plant failed";
  }
}

static fmi2Status step_failed(Instance* in, int status) {
  ml_error e = ml_plant_error(in->plant);
  const char* joint = e.joint >= 0 && e.joint < ML_FMU_N ? kJoint[e.joint] : "(arm)";
  say(in, fmi2Error, "maniplab FMU: joint %s: %s at t = %.6g s (try a shorter --step)", joint,
      cause(status), e.time);
  in->phase = FAILED;
  return fmi2Error;
}

ML_FMI2_EXPORT fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                                     fmi2Real communicationStepSize,
                                     fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
  (void)currentCommunicationPoint;
  (void)noSetFMUStatePriorToCurrentPoint;
  Instance* in = (Instance*)c;
  if (in->phase != STEPPING) {
    say(in, fmi2Error, "maniplab FMU: fmi2DoStep outside step mode (initialisation not ended, "
        "or the run failed)");
    return fmi2Error;
  }
  double h = communicationStepSize, ratio = h / ML_FMU_DT;
  /* lround of a NaN or of a value beyond a long is undefined: range first */
  long steps = isfinite(ratio) && ratio >= 0.5 && ratio < 4e18 ? lround(ratio) : 0;
  if (!(steps >= 1 && fabs(ratio - (double)steps) <= 1e-6 * ratio)) {
    say(in, fmi2Error, "maniplab FMU: the communication step %.9g s is not a whole number of "
        "the FMU's steps of %.9g s (build it with --step to match)", h, (double)ML_FMU_DT);
    return fmi2Error;
  }
  for (int j = 0; j < ML_FMU_N; j++) {
    if (!isfinite(in->u[j])) {
      say(in, fmi2Error, "maniplab FMU: joint %s: input u.%s = %g is not a finite number",
          kJoint[j], kJoint[j], in->u[j]);
      return fmi2Error;
    }
  }
  for (long k = 0; k < steps; k++) {
    int status = ml_plant_prepare(in->plant, in->u);
    if (status == ML_OK) status = ml_plant_advance(in->plant);
    if (status != ML_OK) return step_failed(in, status);
  }
  return fmi2OK;
}

ML_FMI2_EXPORT fmi2Status fmi2CancelStep(fmi2Component c) {
  (void)c;
  return fmi2Error; /* steps are never asynchronous */
}

ML_FMI2_EXPORT fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s,
                                        fmi2Status* value) {
  (void)s;
  *value = ((Instance*)c)->phase == FAILED ? fmi2Error : fmi2OK;
  return fmi2OK;
}

ML_FMI2_EXPORT fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s,
                                            fmi2Real* value) {
  Instance* in = (Instance*)c;
  if (s != fmi2LastSuccessfulTime || in->d == NULL) return fmi2Discard;
  *value = in->d->time;
  return fmi2OK;
}

ML_FMI2_EXPORT fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s,
                                               fmi2Integer* value) {
  (void)c;
  (void)s;
  (void)value;
  return fmi2Discard;
}

ML_FMI2_EXPORT fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s,
                                               fmi2Boolean* value) {
  Instance* in = (Instance*)c;
  if (s != fmi2Terminated) return fmi2Discard;
  *value = in->phase == TERMINATED;
  return fmi2OK;
}

ML_FMI2_EXPORT fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s,
                                              fmi2String* value) {
  (void)c;
  (void)s;
  (void)value;
  return fmi2Discard;
}

/* --- FMI: what this FMU does not do (modelDescription.xml says so) ----------------------------- */
static fmi2Status unsupported(fmi2Component c, const char* what) {
  say((Instance*)c, fmi2Error, "maniplab FMU: %s is not supported", what);
  return fmi2Error;
}

ML_FMI2_EXPORT fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* s) {
  (void)s;
  return unsupported(c, "fmi2GetFMUstate");
}

ML_FMI2_EXPORT fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) {
  (void)s;
  return unsupported(c, "fmi2SetFMUstate");
}

ML_FMI2_EXPORT fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate* s) {
  (void)s;
  return unsupported(c, "fmi2FreeFMUstate");
}

ML_FMI2_EXPORT fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s,
                                                     size_t* size) {
  (void)s;
  (void)size;
  return unsupported(c, "fmi2SerializedFMUstateSize");
}

ML_FMI2_EXPORT fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s,
                                                fmi2Byte bytes[], size_t size) {
  (void)s;
  (void)bytes;
  (void)size;
  return unsupported(c, "fmi2SerializeFMUstate");
}

ML_FMI2_EXPORT fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[],
                                                  size_t size, fmi2FMUstate* s) {
  (void)bytes;
  (void)size;
  (void)s;
  return unsupported(c, "fmi2DeSerializeFMUstate");
}

ML_FMI2_EXPORT fmi2Status fmi2GetDirectionalDerivative(fmi2Component c,
                                                       const fmi2ValueReference unknown[],
                                                       size_t nunknown,
                                                       const fmi2ValueReference known[],
                                                       size_t nknown, const fmi2Real dknown[],
                                                       fmi2Real dunknown[]) {
  (void)unknown;
  (void)nunknown;
  (void)known;
  (void)nknown;
  (void)dknown;
  (void)dunknown;
  return unsupported(c, "fmi2GetDirectionalDerivative");
}

ML_FMI2_EXPORT fmi2Status fmi2SetRealInputDerivatives(fmi2Component c,
                                                      const fmi2ValueReference vr[], size_t nvr,
                                                      const fmi2Integer order[],
                                                      const fmi2Real value[]) {
  (void)vr;
  (void)nvr;
  (void)order;
  (void)value;
  return unsupported(c, "fmi2SetRealInputDerivatives");
}

ML_FMI2_EXPORT fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c,
                                                       const fmi2ValueReference vr[], size_t nvr,
                                                       const fmi2Integer order[],
                                                       fmi2Real value[]) {
  (void)vr;
  (void)nvr;
  (void)order;
  (void)value;
  return unsupported(c, "fmi2GetRealOutputDerivatives");
}
