// SPDX-License-Identifier: GPL-2.0-only -- part of jamflow's LAMMPS plugin, GPL-2.0 like the LAMMPS headers it
// compiles against (the rest of jamflow is MIT); see NOTICE (repository root) and COPYING (the GPL-2.0 text) here.
/* jamflow LAMMPS plugin: what its styles share (pair_jamflow.cpp, pair_jamflow_ellipsoid.h,
   fix_jamflow_damping.cpp): checked numeric arguments, the largest diameter over all MPI ranks,
   the arrays of a neighbour list, the overlap test of two spheres (sigma_ij = radius_i + radius_j,
   chapter Fig. 2.1) and the plugin record LAMMPS registers.

   Licence: GPL-2.0, like LAMMPS, whose headers it includes (see pair_jamflow.cpp). */

#ifndef JAMFLOW_PLUGIN_COMMON_H
#define JAMFLOW_PLUGIN_COMMON_H

#include "lammpsplugin.h"

#include "atom.h"
#include "error.h"
#include "lammps.h"
#include "neigh_list.h"
#include "utils.h"

#include <cmath>
#include <string>

#ifndef JAMFLOW_LAMMPS_VERSION
#define JAMFLOW_LAMMPS_VERSION "unknown"
#endif

namespace LAMMPS_NS {
namespace jamflow_common {

/* A style argument that must be a finite number > lower (>= lower if at_least); error->all(message) otherwise */
inline double checked_number(LAMMPS *lmp, const char *arg, double lower, bool at_least, const std::string &message)
{
  const double value = utils::numeric(FLERR, arg, false, lmp);
  if (!std::isfinite(value) || !(at_least ? value >= lower : value > lower)) lmp->error->all(FLERR, message);
  return value;
}

/* 2 max radius_i over the atoms of every rank: the contact distance a neighbour cutoff must cover */
inline double largest_diameter(const Atom *atom, MPI_Comm world)
{
  double local = 0.0, global = 0.0;
  for (int i = 0; i < atom->nlocal; i++) local = std::fmax(local, atom->radius[i]);
  MPI_Allreduce(&local, &global, 1, MPI_DOUBLE, MPI_MAX, world);
  return 2.0 * global;
}

/* The arrays of a neighbour list: for ii < inum, atom i = ilist[ii] has numneigh[i] neighbours firstneigh[i][jj]
   (mask them with NEIGHMASK) */
struct Neighbours {
  int inum;
  const int *ilist;
  const int *numneigh;
  int **firstneigh;
  explicit Neighbours(const NeighList *list) :
      inum(list->inum), ilist(list->ilist), numneigh(list->numneigh), firstneigh(list->firstneigh)
  {
  }
};

/* Two spheres at xi, xj: del = x_i - x_j, rsq = |del|^2, sigma = radius_i + radius_j; in contact for r < sigma */
struct SpherePair {
  double delx, dely, delz, rsq, sigma;
  SpherePair(const double *xi, double radi, const double *xj, double radj) :
      delx(xi[0] - xj[0]), dely(xi[1] - xj[1]), delz(xi[2] - xj[2]),
      rsq(delx * delx + dely * dely + delz * delz), sigma(radi + radj)
  {
  }
  bool overlapping() const { return rsq < sigma * sigma; }
};

/* The record of one style of this plugin; the caller sets its creator and passes it to reg */
inline lammpsplugin_t plugin_record(const char *style, const char *name, const char *info, void *handle)
{
  lammpsplugin_t plugin;
  plugin.version = JAMFLOW_LAMMPS_VERSION;
  plugin.style = style;
  plugin.name = name;
  plugin.info = info;
  plugin.author = "jamflow";
  plugin.handle = handle;
  return plugin;
}

}    // namespace jamflow_common
}    // namespace LAMMPS_NS

#endif
