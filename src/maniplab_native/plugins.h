/* maniplab's MuJoCo engine plugins: shared helpers (see hydraulic.c, lugre.c). */
#ifndef MANIPLAB_PLUGINS_H_
#define MANIPLAB_PLUGINS_H_

#include <stddef.h>

#include <mujoco/mujoco.h>

/* A number from the instance's config: 0 and *value set when present and a finite number;
   1 when absent or empty (value untouched); -1 (with a MuJoCo warning) when it is not a number. */
int ml_config_number(const mjModel* m, int instance, const char* key, double* value);
/* Up to `most` numbers of a space-separated config list into values: their count (0 when
   absent), or -1 (with a warning) when it is not such a list. */
int ml_config_numbers(const mjModel* m, int instance, const char* key, double* values, int most);

/* A required number of the config: 0 and *value set when present and positive (or, with
   positive = 0, non-negative); -1 with a MuJoCo warning naming `plugin` and `key` otherwise. */
int ml_config_required(const mjModel* m, int instance, const char* plugin, const char* key,
                       double* value, int positive);

/* Keep a copy of an instance's `size` bytes of parameters in d->plugin_data: 0, or -1. */
int ml_keep(mjData* d, int instance, const void* params, size_t size);

/* Free what ml_keep kept (the plugins' `destroy`). */
void ml_destroy(mjData* d, int instance);

/* The one actuator driven by plugin instance `instance`, or -1 (with a MuJoCo warning). */
int ml_instance_actuator(const mjModel* m, int instance, const char* plugin);

/* The actuator's control, clipped to its ctrlrange when it has one. */
double ml_control(const mjModel* m, const mjData* d, int actuator);

/* Register a plugin with MuJoCo under `name` (the library: "maniplab.hydraulic"...; an FMU: names
   of its own, so that several FMUs and maniplab itself can share one libmujoco). The name must
   outlive the registration. */
void ml_register_hydraulic(const char* name);
void ml_register_cylinder(const char* name);
/* The first of a cylinder instance's energies in its plugin_state, then the supply pressure's
   time integral; *count: how many energies (cylinder.c). */
int ml_cylinder_energy_slot(int* count);
void ml_register_lugre(const char* name);

#endif
