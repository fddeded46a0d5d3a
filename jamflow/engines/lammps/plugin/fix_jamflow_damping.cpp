// SPDX-License-Identifier: GPL-2.0-only -- part of jamflow's LAMMPS plugin, GPL-2.0 like the LAMMPS headers it
// compiles against (the rest of jamflow is MIT); see NOTICE (repository root) and COPYING (the GPL-2.0 text) here.
/* jamflow LAMMPS plugin: the pairwise normal damping of damped MD (chapter eq. 2.3).

     fix ID group jamflow/damping B

   Schreck & O'Hern, "Computational methods to study jammed systems", eq. 2.3:
       m a_i = sum_j [ -dV(r_ij)/dr_ij - B (v_ij . rhat_ij) ] rhat_ij.
   The pair style supplies -dV/dr; this fix adds the dissipative part. For every pair i, j
   (both in the group) in contact, r_ij < sigma_ij = radius_i + radius_j, particle i gets
       F_i = -B [(v_i - v_j) . rhat_ij] rhat_ij,     rhat_ij = (x_i - x_j) / r_ij,
   and particle j gets -F_i. Nothing acts on pairs at or beyond contact, on tangential
   relative motion or on free (rattler) motion; total momentum is conserved. The fix adds
   no energy and no virial (a dissipative force; the pressure jamflow reads is taken at
   rest). Units: LAMMPS "lj"; B in sqrt(m eps) / diameter (force per velocity, as in
   fix viscous). The relative normal coordinate of one isolated contact of two masses m
   is damped at rate 2 B / m.

   Acts in post_force of run (velocity Verlet, fix nve), also at setup, not in minimize.
   Needs atom_style sphere, comm_modify vel yes (velocities of ghost atoms) and a pair
   style whose neighbour cutoff covers the largest diameter. It uses a full neighbour
   list: each owned atom sums over all its neighbours (each pair is evaluated from both
   sides with exactly negated separations and velocities), so newton on/off, MPI ranks,
   2D/3D and triclinic cells need no reverse communication.

   Licence: this file is compiled against LAMMPS's headers and loaded into LAMMPS, so it
   is a derivative of LAMMPS and is distributed under the GNU General Public License,
   version 2 (GPL-2.0), like LAMMPS. */

#include "plugin_common.h"

#include "comm.h"
#include "fix.h"
#include "force.h"
#include "neighbor.h"
#include "pair.h"
#include "update.h"

namespace LAMMPS_NS {
using namespace jamflow_common;

class FixJamflowDamping : public Fix {
 public:
  FixJamflowDamping(LAMMPS *lmp, int narg, char **arg) : Fix(lmp, narg, arg)
  {
    if (narg != 4) error->all(FLERR, "Illegal fix jamflow/damping command: expected fix ID group jamflow/damping B");
    damping = checked_number(lmp, arg[3], 0.0, true, "fix jamflow/damping: B must be a finite number >= 0");
  }

  int setmask() override { return FixConst::POST_FORCE; }

  void init() override
  {
    if (!atom->radius_flag) error->all(FLERR, "fix jamflow/damping requires atom_style sphere (per-atom radius)");
    if (!comm->ghost_velocity)
      error->all(FLERR, "fix jamflow/damping needs the velocities of ghost atoms: use comm_modify vel yes");
    if (!utils::strmatch(update->integrate_style, "^verlet"))
      error->all(FLERR, "fix jamflow/damping supports run_style verlet only");
    if (force->pair == nullptr)
      error->all(FLERR, "fix jamflow/damping needs a pair style (its neighbour cutoff must cover the largest diameter)");
    const double dmax = largest_diameter(atom, world);
    if (force->pair->cutforce < dmax)
      error->all(FLERR, "fix jamflow/damping: the pair cutoff " + std::to_string(force->pair->cutforce) +
                            " is below the largest diameter " + std::to_string(dmax) + ", so contacts would be missed");
    neighbor->add_request(this, NeighConst::REQ_FULL);
  }

  void init_list(int /*id*/, NeighList *ptr) override { list = ptr; }

  void setup(int vflag) override { post_force(vflag); }

  void post_force(int /*vflag*/) override
  {
    double **x = atom->x;
    double **v = atom->v;
    double **f = atom->f;
    const double *radius = atom->radius;
    const int *mask = atom->mask;
    const Neighbours nb(list);

    for (int ii = 0; ii < nb.inum; ii++) {
      const int i = nb.ilist[ii];
      if (!(mask[i] & groupbit)) continue;
      const int *jlist = nb.firstneigh[i];
      double fx = 0.0, fy = 0.0, fz = 0.0;
      for (int jj = 0; jj < nb.numneigh[i]; jj++) {
        const int j = jlist[jj] & NEIGHMASK;
        if (!(mask[j] & groupbit)) continue;
        const SpherePair p(x[i], radius[i], x[j], radius[j]);
        if (!p.overlapping() || p.rsq == 0.0) continue;
        // -B (v_ij . del) del / r^2 = -B (v_ij . rhat) rhat
        const double vdotdel = (v[i][0] - v[j][0]) * p.delx + (v[i][1] - v[j][1]) * p.dely +
            (v[i][2] - v[j][2]) * p.delz;
        const double scale = -damping * vdotdel / p.rsq;
        fx += scale * p.delx;
        fy += scale * p.dely;
        fz += scale * p.delz;
      }
      f[i][0] += fx;
      f[i][1] += fy;
      f[i][2] += fz;
    }
  }

 private:
  double damping = 0.0;
  NeighList *list = nullptr;
};

static Fix *create_damping(LAMMPS *lmp, int narg, char **arg) { return new FixJamflowDamping(lmp, narg, arg); }

}    // namespace LAMMPS_NS

using namespace LAMMPS_NS;

/* Called by lammpsplugin_init (pair_jamflow.cpp): registers fix jamflow/damping. */

void jamflow_register_fixes(void *lmp, void *handle, lammpsplugin_regfunc reg)
{
  lammpsplugin_t plugin = jamflow_common::plugin_record(
      "fix", "jamflow/damping", "jamflow pairwise normal damping -B (v_ij . rhat) rhat of contacting pairs (chapter eq. 2.3)",
      handle);
  plugin.creator.v2 = (lammpsplugin_factory2 *) &create_damping;
  (*reg)(&plugin, lmp);
}
