/* Helpers shared by maniplab's plugins, and the library's registration with MuJoCo. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "plugins.h"

int ml_config_number(const mjModel* m, int instance, const char* key, double* value) {
  const char* text = mj_getPluginConfig(m, instance, key);
  if (text == NULL || text[0] == '\0') return 1;
  char* end = NULL;
  double x = strtod(text, &end);
  while (end && (*end == ' ' || *end == '\t' || *end == '\n')) end++;
  if (end == text || (end && *end != '\0') || !isfinite(x)) {
    mju_warning("maniplab plugin: config '%s' = '%s' is not a finite number", key, text);
    return -1;
  }
  *value = x;
  return 0;
}

int ml_config_numbers(const mjModel* m, int instance, const char* key, double* values, int most) {
  const char* text = mj_getPluginConfig(m, instance, key);
  if (text == NULL || text[0] == '\0') return 0;
  int count = 0;
  const char* at = text;
  while (1) {
    while (*at == ' ' || *at == '\t' || *at == '\n') at++;
    if (*at == '\0') return count;
    char* end = NULL;
    double x = strtod(at, &end);
    if (end == at || !isfinite(x) || count >= most) {
      mju_warning("maniplab plugin: config '%s' = '%s' is not a list of at most %d finite numbers",
                  key, text, most);
      return -1;
    }
    values[count++] = x;
    at = end;
  }
}

int ml_config_required(const mjModel* m, int instance, const char* plugin, const char* key,
                       double* value, int positive) {
  int status = ml_config_number(m, instance, key, value);
  if (status == 1) {
    mju_warning("%s: config '%s' is missing", plugin, key);
    return -1;
  }
  if (status == 0 && (positive ? !(*value > 0.0) : !(*value >= 0.0))) {
    mju_warning("%s: config '%s' must be %s, got %g", plugin, key,
                positive ? "positive" : "non-negative", *value);
    return -1;
  }
  return status;
}

int ml_keep(mjData* d, int instance, const void* params, size_t size) {
  void* kept = malloc(size);
  if (kept == NULL) return -1;
  memcpy(kept, params, size);
  d->plugin_data[instance] = (uintptr_t)kept;
  return 0;
}

void ml_destroy(mjData* d, int instance) {
  free((void*)d->plugin_data[instance]);
  d->plugin_data[instance] = 0;
}

int ml_instance_actuator(const mjModel* m, int instance, const char* plugin) {
  int found = -1;
  for (int i = 0; i < m->nu; i++) {
    if (m->actuator_plugin[i] == instance) {
      if (found != -1) {
        mju_warning("%s: one plugin instance drives several actuators (%d and %d)", plugin,
                    found, i);
        return -1;
      }
      found = i;
    }
  }
  if (found == -1) mju_warning("%s: no actuator uses plugin instance %d", plugin, instance);
  return found;
}

double ml_control(const mjModel* m, const mjData* d, int actuator) {
  double u = d->ctrl[actuator];
  if (m->actuator_ctrllimited[actuator]) {
    const double* range = m->actuator_ctrlrange + 2 * actuator;
    u = u < range[0] ? range[0] : (u > range[1] ? range[1] : u);
  }
  return u;
}

#ifndef ML_NO_LIB_INIT /* an FMU registers its plugins itself, under names of its own */
mjPLUGIN_LIB_INIT(maniplab) {
  ml_register_hydraulic("maniplab.hydraulic");
  ml_register_cylinder("maniplab.cylinder");
  ml_register_lugre("maniplab.lugre");
}
#endif
