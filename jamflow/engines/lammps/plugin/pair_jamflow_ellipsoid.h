// SPDX-License-Identifier: GPL-2.0-only -- part of jamflow's LAMMPS plugin, GPL-2.0 like the LAMMPS headers it
// compiles against (the rest of jamflow is MIT); see NOTICE (repository root) and COPYING (the GPL-2.0 text) here.
/* jamflow LAMMPS plugin: pair style jamflow/ellipsoid for atom_style ellipsoid.

     pair_style jamflow/ellipsoid CONTACT spring ALPHA CUTOFF   pair_coeff * * EPSILON
     pair_style jamflow/ellipsoid CONTACT rlj CUTOFF            pair_coeff * * EPSILON

   V(r_ij / sigma_ij) with the jamflow laws of s = r / sigma (pair_jamflow.cpp) and sigma_ij the
   contact distance of two ellipses (2D) or spheroids (3D) by CONTACT = exact | gaussian | cleaver |
   linear | quadratic (contact_distance.h; chapter section 2.3.2). Each atom's full axes are
   its shape (a along the body x-axis, the director; b = c across), its director R(q) x. Forces,
   torques (atom->torque) and the virial; the non-symmetric virial sum r_ij,a f_ij,b and three
   counters are the pair's extra vector (compute pair jamflow/ellipsoid):
     [1] contacts where a truncation's root left (0, 1) and lambda fell back to 1/2, [2] contacts
     where it gave a larger sigma than 1/2 and was capped there, [3] contacts evaluated with a
     truncation, [4] pairs whose sigma came out non-finite (all cumulative);
     [5..13] the virial xx xy xz yx yy yz zx zy zz of the last evaluation.
   CUTOFF is the neighbour-list cutoff, at least the largest long axis (init_style checks).

   Orientations and shapes are read through LAMMPS's own compute property/atom (quatw ... shapez)
   and sent to ghost atoms with this style's forward communication, so the plugin needs no
   declaration of AtomVecEllipsoid's private layout (the wheel ships no atom_vec_ellipsoid.h).

   Distributed under the GNU General Public License, version 2 (GPL-2.0), like LAMMPS: it is
   compiled against LAMMPS's GPL-2.0 headers and loaded into LAMMPS. */

#ifndef JAMFLOW_PAIR_ELLIPSOID_H
#define JAMFLOW_PAIR_ELLIPSOID_H

#include "contact_distance.h"

#include "compute.h"
#include "domain.h"
#include "modify.h"

namespace LAMMPS_NS {

class PairJamflowEllipsoid : public PairJamflowLaw {
 public:
  static constexpr int NPROPS = 6;     // a^2, b^2, quaternion w x y z per atom
  static constexpr int NCOUNTS = 4;    // fallbacks, capped, approximate, invalid
  static constexpr int NEXTRA = NCOUNTS + 9;    // + 9 virial components

  PairJamflowEllipsoid(LAMMPS *lmp) : PairJamflowLaw(lmp)
  {
    single_enable = 0;
    comm_forward = NPROPS;
    no_virial_fdotr_compute = 1;
    nextra = NEXTRA;
    pvector = new double[NEXTRA];
    for (int k = 0; k < NEXTRA; k++) pvector[k] = 0.0;
  }

  ~PairJamflowEllipsoid() override
  {
    delete[] pvector;
    memory->destroy(props);
    // the internal compute stays (a new instance of this style reuses it; Modify may be gone here)
  }

  void settings(int narg, char **arg) override;
  void init_style() override;
  void compute(int eflag, int vflag) override;
  int pack_forward_comm(int n, int *list, double *buf, int, int *) override
  {
    int m = 0;
    for (int k = 0; k < n; k++)
      for (int c = 0; c < NPROPS; c++) buf[m++] = props[list[k]][c];
    return m;
  }
  void unpack_forward_comm(int n, int first, double *buf) override
  {
    int m = 0;
    for (int i = first; i < first + n; i++)
      for (int c = 0; c < NPROPS; c++) props[i][c] = buf[m++];
  }

 private:
  const char *PROPS_ID = "jamflow_ellipsoid_props";
  int method = jamflow_contact::EXACT;
  double **props = nullptr;
  int nmax_props = 0;
  Compute *props_compute = nullptr;
  double counts[NCOUNTS] = {0.0, 0.0, 0.0, 0.0};

  std::string name() const override { return "jamflow/ellipsoid"; }
  void gather_props();
  template <int LAW> void eval(int eflag, int vflag);
};

/* pair_style jamflow/ellipsoid CONTACT spring ALPHA CUTOFF | CONTACT rlj CUTOFF */

inline void PairJamflowEllipsoid::settings(int narg, char **arg)
{
  static const char *methods[] = {"exact", "gaussian", "cleaver", "linear", "quadratic"};
  const std::string usage = "Illegal pair_style jamflow/ellipsoid command: expected CONTACT spring ALPHA CUTOFF "
                            "or CONTACT rlj CUTOFF, CONTACT = exact|gaussian|cleaver|linear|quadratic";
  if (narg < 3) error->all(FLERR, usage);
  method = -1;
  for (int k = 0; k < 5; k++)
    if (std::string(arg[0]) == methods[k]) method = k;
  if (method < 0) error->all(FLERR, usage);
  const std::string kind = arg[1];
  if ((kind != "spring" && kind != "rlj") || !parse_law(kind == "rlj", narg - 2, arg + 2)) error->all(FLERR, usage);
}

/* Needs atom_style ellipsoid with every atom an ellipsoid; checks the cutoff. */

inline void PairJamflowEllipsoid::init_style()
{
  if (!atom->ellipsoid_flag || !atom->torque_flag)
    error->all(FLERR, "Pair style jamflow/ellipsoid requires atom_style ellipsoid");
  for (int i = 1; i <= atom->ntypes; i++)
    for (int j = i; j <= atom->ntypes; j++)
      if (!setflag[i][j]) error->all(FLERR, "Pair style jamflow/ellipsoid: pair_coeff missing; use pair_coeff * * EPSILON");
  props_compute = modify->get_compute_by_id(PROPS_ID);
  if (!props_compute)
    props_compute = modify->add_compute(std::string(PROPS_ID) +
                                        " all property/atom quatw quati quatj quatk shapex shapey shapez");
  neighbor->add_request(this);

  double amax_local = 0.0;
  int round_local = 0;
  for (int i = 0; i < atom->nlocal; i++) {
    if (atom->ellipsoid[i] < 0) round_local = 1;
  }
  int round = 0;
  MPI_Allreduce(&round_local, &round, 1, MPI_INT, MPI_MAX, world);
  if (round)
    error->all(FLERR, "Pair style jamflow/ellipsoid: every atom must be an ellipsoid (Ellipsoids section or set shape)");
  gather_props();
  int bad_local = 0;    // spheroids only (shape a b b), unit quaternions
  for (int i = 0; i < atom->nlocal; i++) {
    const double *q = props_compute->array_atom[i];
    const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!(q[4] > 0.0 && q[5] > 0.0) || std::fabs(q[6] - q[5]) > 1e-12 * q[5] || std::fabs(norm - 1.0) > 1e-8)
      bad_local = 1;
    amax_local = std::fmax(amax_local, std::fmax(std::sqrt(props[i][0]), std::sqrt(props[i][1])));
  }
  int bad = 0;
  MPI_Allreduce(&bad_local, &bad, 1, MPI_INT, MPI_MAX, world);
  if (bad)
    error->all(FLERR, "Pair style jamflow/ellipsoid handles spheroids: every atom needs shape a b b (the second "
                      "and third diameters equal) and a unit quaternion");
  double amax = 0.0;
  MPI_Allreduce(&amax_local, &amax, 1, MPI_DOUBLE, MPI_MAX, world);
  if (amax > cut_global * (1.0 + 1e-12))    // (a from sqrt(a^2): allow round-off)
    error->all(FLERR, "Pair style jamflow/ellipsoid: CUTOFF " + std::to_string(cut_global) +
                          " is below the largest long axis " + std::to_string(amax) + "; pass it as CUTOFF");
}

/* local atoms' a^2, b^2 and quaternion from compute property/atom, ghosts by forward comm */

inline void PairJamflowEllipsoid::gather_props()
{
  if (atom->nmax > nmax_props) {
    memory->destroy(props);
    nmax_props = atom->nmax;
    memory->create(props, nmax_props, NPROPS, "pair:jamflow_ellipsoid_props");
  }
  props_compute->compute_peratom();
  double **q = props_compute->array_atom;
  for (int i = 0; i < atom->nlocal; i++) {
    props[i][0] = q[i][4] * q[i][4];    // shapex = a (full length along the director)
    props[i][1] = q[i][5] * q[i][5];    // shapey = b
    for (int c = 0; c < 4; c++) props[i][2 + c] = q[i][c];
  }
  comm->forward_comm(this);
}

inline void PairJamflowEllipsoid::compute(int eflag, int vflag)
{
  ev_init(eflag, vflag);
  switch (law) {
    case SPRING2: eval<SPRING2>(eflag, vflag); break;
    case HERTZ: eval<HERTZ>(eflag, vflag); break;
    case SPRING_POW: eval<SPRING_POW>(eflag, vflag); break;
    default: eval<RLJ>(eflag, vflag); break;
  }
}

namespace {
inline void director(const double *p, double *u)
{
  const double w = p[2], x = p[3], y = p[4], z = p[5];
  u[0] = 1 - 2 * (y * y + z * z);
  u[1] = 2 * (x * y + w * z);
  u[2] = 2 * (x * z - w * y);
}
}    // namespace

template <int LAW> void PairJamflowEllipsoid::eval(int /*eflag*/, int /*vflag*/)
{
  using namespace jamflow_contact;
  gather_props();
  double **x = atom->x;
  double **f = atom->f;
  double **torque = atom->torque;
  const int *type = atom->type;
  const int nlocal = atom->nlocal;
  const int newton_pair = force->newton_pair;
  const int dim = domain->dimension;
  double virial9[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};

  const jamflow_common::Neighbours nb(list);

  for (int ii = 0; ii < nb.inum; ii++) {
    const int i = nb.ilist[ii];
    const int *jlist = nb.firstneigh[i];
    const int jnum = nb.numneigh[i];
    double ui[3], uj[3];
    director(props[i], ui);
    const double reach_i = 0.5 * std::sqrt(std::fmax(props[i][0], props[i][1]));
    for (int jj = 0; jj < jnum; jj++) {
      const int j = jlist[jj] & NEIGHMASK;
      double dr[3] = {x[i][0] - x[j][0], x[i][1] - x[j][1], dim == 3 ? x[i][2] - x[j][2] : 0.0};
      const double r2 = dr[0] * dr[0] + dr[1] * dr[1] + dr[2] * dr[2];
      const double reach_j = 0.5 * std::sqrt(std::fmax(props[j][0], props[j][1]));
      if (r2 >= bound_sq(method, reach_i, reach_j)) continue;
      const double r = std::sqrt(r2);
      const double rh[3] = {dr[0] / r, dr[1] / r, dr[2] / r};
      director(props[j], uj);
      if (dim == 2) ui[2] = uj[2] = 0.0;
      Geometry p;
      p.ai2 = props[i][0];
      p.bi2 = props[i][1];
      p.aj2 = props[j][0];
      p.bj2 = props[j][1];
      p.x = rh[0] * ui[0] + rh[1] * ui[1] + rh[2] * ui[2];
      p.z = rh[0] * uj[0] + rh[1] * uj[1] + rh[2] * uj[2];
      p.m = ui[0] * uj[0] + ui[1] * uj[1] + ui[2] * uj[2];
      p.g = 0.0;
      if (dim == 3) {
        const double t = rh[0] * (ui[1] * uj[2] - ui[2] * uj[1]) + rh[1] * (ui[2] * uj[0] - ui[0] * uj[2]) +
            rh[2] * (ui[0] * uj[1] - ui[1] * uj[0]);
        p.g = t * t;
      }
      const double tol = 1e-12;  // contact_distance.SAME_SIZE_RTOL
      const bool identical = std::fabs(p.ai2 - p.aj2) <= 2 * tol * p.ai2 && std::fabs(p.bi2 - p.bj2) <= 2 * tol * p.bi2;
      if (r2 * pw_h(0.5, p) >= 1.0) continue;    // r >= sigma(1/2) >= every method's sigma
      double sigma, s_x, s_z, s_m;
      bool fell_back, capped;
      contact(method, dim, identical, p, sigma, s_x, s_z, s_m, fell_back, capped);
      if (!(sigma > 0.0 && sigma < INFINITY)) {
        counts[3] += 1.0;
        continue;
      }
      if (r >= sigma) continue;
      if (method == LINEAR || method == QUADRATIC) {
        counts[2] += 1.0;
        if (fell_back) counts[0] += 1.0;
        if (capped) counts[1] += 1.0;
      }
      const int itype = type[i], jtype = type[j];
      double dvds;
      const double v = law_of_s<LAW>(r / sigma, epsilon[itype][jtype], eps_over_alpha[itype][jtype], alpha, dvds);
      double radial = 0.0;
      for (int a = 0; a < 3; a++) radial += (s_x * ui[a] + s_z * uj[a]) * rh[a];
      double fi[3];
      for (int a = 0; a < 3; a++) {
        const double g_r = s_x * ui[a] + s_z * uj[a] - radial * rh[a];
        fi[a] = -dvds * (rh[a] / sigma - g_r / (sigma * sigma));
      }
      const double lever = dvds * r / (sigma * sigma);
      double gi[3], gj[3];
      for (int a = 0; a < 3; a++) {
        gi[a] = s_x * rh[a] + s_m * uj[a];
        gj[a] = s_z * rh[a] + s_m * ui[a];
      }
      const bool j_local = newton_pair || j < nlocal;
      for (int a = 0; a < 3; a++) f[i][a] += fi[a];
      torque[i][0] += lever * (ui[1] * gi[2] - ui[2] * gi[1]);
      torque[i][1] += lever * (ui[2] * gi[0] - ui[0] * gi[2]);
      torque[i][2] += lever * (ui[0] * gi[1] - ui[1] * gi[0]);
      if (j_local) {
        for (int a = 0; a < 3; a++) f[j][a] -= fi[a];
        torque[j][0] += lever * (uj[1] * gj[2] - uj[2] * gj[1]);
        torque[j][1] += lever * (uj[2] * gj[0] - uj[0] * gj[2]);
        torque[j][2] += lever * (uj[0] * gj[1] - uj[1] * gj[0]);
      }
      const double share = j_local ? 1.0 : 0.5;
      for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) virial9[3 * a + b] += share * dr[a] * fi[b];
      if (evflag) ev_tally_xyz(i, j, nlocal, newton_pair, v, 0.0, fi[0], fi[1], fi[2], dr[0], dr[1], dr[2]);
    }
  }
  for (int k = 0; k < NCOUNTS; k++) pvector[k] = counts[k];
  for (int k = 0; k < 9; k++) pvector[NCOUNTS + k] = virial9[k];
}

}    // namespace LAMMPS_NS

#endif
