// SPDX-License-Identifier: GPL-2.0-only -- part of jamflow's LAMMPS plugin, GPL-2.0 like the LAMMPS headers it
// compiles against (the rest of jamflow is MIT); see NOTICE (repository root) and COPYING (the GPL-2.0 text) here.
/* jamflow LAMMPS plugin: the contact distance sigma_ij of two ellipses (2D) or spheroids (3D)
   and its partial derivatives (chapter section 2.3.2; Perram & Wertheim, J. Comput. Phys.
   58, 409 (1985)).

   A C++ transcription of jamflow/shapes/contact_distance.py (the algebra, function by function)
   and of the per-pair solvers of jamflow/engine/compiled/ellipsoids.py; tests/test_ellipsoids.py
   checks the pair style built on it against both to 1e-12. Conventions as there: a, b full axis
   lengths along / across the director, ai2 = a_i^2 etc.; x = r_hat.u_i, z = r_hat.u_j,
   m = u_i.u_j, g = (r_hat . u_i x u_j)^2 (0 in 2D); lambda in (0, 1), y = lambda - 1/2.

   Part of jamflow; distributed with it under GPL-2.0 as part of the plugin (see pair_jamflow.cpp). */

#ifndef JAMFLOW_CONTACT_DISTANCE_H
#define JAMFLOW_CONTACT_DISTANCE_H

#include <cmath>

namespace jamflow_contact {

enum Method { EXACT = 0, GAUSSIAN = 1, CLEAVER = 2, LINEAR = 3, QUADRATIC = 4 };  // contact_distance.METHODS
const double STEP_TOL = 1e-12;  // contact_distance.STEP_TOL
const int MAX_ITER = 100;

struct Geometry {
  double ai2, bi2, aj2, bj2, x, z, m, g;
};

struct Terms {
  double C, P, Q, Nn, Qd;
};

inline Terms pw_terms(double lam, const Geometry &p)
{
  Terms t;
  t.C = (1 - lam) * p.bi2 + lam * p.bj2;
  t.P = (1 - lam) * (p.ai2 - p.bi2);
  t.Q = lam * (p.aj2 - p.bj2);
  t.Nn = t.C * t.C + t.C * (t.P * (1 - p.x * p.x) + t.Q * (1 - p.z * p.z)) + t.P * t.Q * p.g;
  t.Qd = t.C * t.C + t.C * (t.P + t.Q) + t.P * t.Q * (1 - p.m * p.m);
  return t;
}

inline double pw_h(double lam, const Geometry &p)
{
  const Terms t = pw_terms(lam, p);
  return 4 * lam * (1 - lam) * t.Nn / (t.C * t.Qd);
}

/* sigma(lambda) and its partial derivatives in x, z, m at fixed lambda */
inline void sigma_partials(double lam, const Geometry &p, double &sigma, double &s_x, double &s_z, double &s_m)
{
  const Terms t = pw_terms(lam, p);
  sigma = std::sqrt(t.C * t.Qd / (4 * lam * (1 - lam) * t.Nn));
  const double k_n = -0.5 * sigma / t.Nn, k_q = 0.5 * sigma / t.Qd;
  s_x = k_n * (-2 * t.P * ((t.C + t.Q) * p.x - t.Q * p.m * p.z));
  s_z = k_n * (-2 * t.Q * ((t.C + t.P) * p.z - t.P * p.m * p.x));
  s_m = k_n * (2 * t.P * t.Q * (p.x * p.z - p.m)) + k_q * (-2 * t.P * t.Q * p.m);
}

/* dh/dlambda, d2h/dlambda2 */
inline void h_lambda_derivatives(double lam, const Geometry &p, double &h1, double &h2)
{
  const double dC = p.bj2 - p.bi2, dP = -(p.ai2 - p.bi2), dQ = p.aj2 - p.bj2;
  const Terms t = pw_terms(lam, p);
  const double wx = 1 - p.x * p.x, wz = 1 - p.z * p.z, wm = 1 - p.m * p.m;
  const double Nn1 = 2 * t.C * dC + dC * (t.P * wx + t.Q * wz) + t.C * (dP * wx + dQ * wz) + (dP * t.Q + t.P * dQ) * p.g;
  const double Nn2 = 2 * dC * dC + 2 * dC * (dP * wx + dQ * wz) + 2 * dP * dQ * p.g;
  const double Qd1 = 2 * t.C * dC + dC * (t.P + t.Q) + t.C * (dP + dQ) + (dP * t.Q + t.P * dQ) * wm;
  const double Qd2 = 2 * dC * dC + 2 * dC * (dP + dQ) + 2 * dP * dQ * wm;
  const double w = 4 * lam * (1 - lam), w1 = 4 - 8 * lam, w2 = -8.0;
  const double num = w * t.Nn, num1 = w1 * t.Nn + w * Nn1, num2 = w2 * t.Nn + 2 * w1 * Nn1 + w * Nn2;
  const double den = t.C * t.Qd, den1 = dC * t.Qd + t.C * Qd1, den2 = 2 * dC * Qd1 + t.C * Qd2;
  const double h = num / den;
  h1 = (num1 - h * den1) / den;
  h2 = (num2 - 2 * h1 * den1 - h * den2) / den;
}

/* J, K, L of eqs 2.13-2.15 (2.15 sign-corrected) */
inline void jkl_2d(const Geometry &p, double &J, double &K, double &L)
{
  const double n_i = p.ai2 - (p.ai2 - p.bi2) * p.x * p.x;
  const double n_j = p.aj2 - (p.aj2 - p.bj2) * p.z * p.z;
  J = (n_j - n_i) / n_i;
  K = (p.aj2 * p.bj2) / (p.ai2 * p.bi2) - 1;
  L = (p.ai2 * p.bj2 + p.bi2 * p.aj2 + (p.ai2 - p.bi2) * (p.aj2 - p.bj2) * (1 - p.m * p.m)) / (p.ai2 * p.bi2) - 2;
}

/* J, L, M of eqs 2.23-2.25 (identical spheroids, alpha2 = (a/b)^2) */
inline void jlm_3d(double alpha2, const Geometry &p, double &J, double &L, double &M)
{
  const double e = (alpha2 - 1) / alpha2;
  const double den = 1 - e * p.x * p.x;
  J = e * (p.x * p.x - p.z * p.z) / den;
  L = (alpha2 - 1) * e * (1 - p.m * p.m);
  M = -(alpha2 - 1) * e * p.g / den;
}

/* q0..q5 of the quartic (eqs 2.8-2.12, q5 = 0) or quintic (eqs 2.17-2.22) */
inline void coefficients(int dim, const Geometry &p, double q[6])
{
  if (dim == 2) {
    double J, K, L;
    jkl_2d(p, J, K, L);
    q[0] = J * (L + 4) / 16 - K * (J + 4) / 16;
    q[1] = -(1 + K / 2) * (J + 2);
    q[2] = -J * (L + 6) / 2 - K * (3 * J + 2) / 2;
    q[3] = -2 * J * K;
    q[4] = J * (L - K);
    q[5] = 0.0;
    return;
  }
  double J, L, M;
  jlm_3d(p.ai2 / p.bi2, p, J, L, M);
  q[0] = J * (L + 4) / 16;
  q[1] = -(J + 2) + M * (L + 8) / 8;
  q[2] = -J * (L + 6) / 2;
  q[3] = -M * (L + 4);
  q[4] = J * L;
  q[5] = 2 * M * L;
}

/* eq. 2.26 truncated at linear (quad = 0) or quadratic (quad = 1) order */
inline void truncated_root(double q0, double q1, double q2, double quad, double &y, double &q, bool &inside)
{
  const double disc = q1 * q1 - 4 * q0 * q2;
  q = quad * (disc >= 0 ? 1.0 : 0.0);
  const double root = std::sqrt(disc > 0.0 ? disc : 0.0);
  y = -2 * q0 / (q1 + (1 - q) * q1 + q * std::copysign(root, q1));
  inside = std::fabs(y) < 0.5;
  if (!inside) {
    y = 0.0;
    q = 0.0;
  }
}

/* the truncation's lambda, dropped for 1/2 where it leaves (0, 1) (inside false) or exceeds sigma(1/2) */
inline void truncated_lambda(double quad, const Geometry &p, const double c[6], double &lam, double &q, bool &inside,
                             bool &kept)
{
  double y;
  truncated_root(c[0], c[1], c[2], quad, y, q, inside);
  kept = inside && (pw_h(0.5 + y, p) >= pw_h(0.5, p));
  if (!kept) {
    y = 0.0;
    q = 0.0;
  }
  lam = 0.5 + y;
}

/* dy/d(x, z, m) of the truncated root, by implicit differentiation */
inline void root_partials(int dim, double y, double quad, const Geometry &p, double &y_x, double &y_z, double &y_m)
{
  if (dim == 2) {
    double J, K, L;
    jkl_2d(p, J, K, L);
    const double n_i = p.ai2 - (p.ai2 - p.bi2) * p.x * p.x;
    const double n_j = p.aj2 - (p.aj2 - p.bj2) * p.z * p.z;
    const double J_x = 2 * (p.ai2 - p.bi2) * p.x * n_j / (n_i * n_i), J_z = -2 * (p.aj2 - p.bj2) * p.z / n_i;
    const double L_m = -2 * p.m * (p.ai2 - p.bi2) * (p.aj2 - p.bj2) / (p.ai2 * p.bi2);
    const double p_J = (L + 4) / 16 - K / 16 - (1 + K / 2) * y + quad * (-(L + 6) / 2 - 1.5 * K) * y * y;
    const double p_L = J / 16 + quad * (-J / 2) * y * y;
    const double p_y = -(1 + K / 2) * (J + 2) + quad * 2 * (-J * (L + 6) / 2 - K * (3 * J + 2) / 2) * y;
    y_x = -p_J * J_x / p_y;
    y_z = -p_J * J_z / p_y;
    y_m = -p_L * L_m / p_y;
    return;
  }
  const double alpha2 = p.ai2 / p.bi2;
  double J, L, M;
  jlm_3d(alpha2, p, J, L, M);
  const double e = (alpha2 - 1) / alpha2;
  const double den = 1 - e * p.x * p.x;
  const double J_x = 2 * e * p.x * (1 - e * p.z * p.z) / (den * den), J_z = -2 * e * p.z / den;
  const double L_m = -2 * (alpha2 - 1) * e * p.m;
  const double c = -(alpha2 - 1) * e / den;
  const double M_x = c * (2 * (p.z * p.m - p.x) + p.g * 2 * e * p.x / den);
  const double M_z = c * 2 * (p.x * p.m - p.z), M_m = c * 2 * (p.x * p.z - p.m);
  const double p_J = (L + 4) / 16 - y + quad * (-(L + 6) / 2) * y * y;
  const double p_L = J / 16 + M / 8 * y + quad * (-J / 2) * y * y;
  const double p_M = (L + 8) / 8 * y;
  const double p_y = -(J + 2) + M * (L + 8) / 8 + quad * 2 * (-J * (L + 6) / 2) * y;
  y_x = (-p_J * J_x - p_M * M_x) / p_y;
  y_z = (-p_J * J_z - p_M * M_z) / p_y;
  y_m = (-p_L * L_m - p_M * M_m) / p_y;
}

/* one safeguarded Newton step on a function with f > 0 left of the root, f < 0 right of it */
inline bool safeguarded_step(double &t, double f, double df, double &left, double &right)
{
  if (f > 0) left = t;
  if (f < 0) right = t;
  const double step = df < 0 ? -f / df : NAN;
  const bool small = std::fabs(step) <= STEP_TOL;
  double next = t + step;
  if (!(next > left && next < right) && !small) next = 0.5 * (left + right);
  const bool done = f == 0 || small || right - left <= 4e-16;
  if (f != 0) t = next;
  return done;
}

/* the root of the chapter's polynomial in (-1/2, 1/2), from the quadratic truncation */
inline double polynomial_root(const double c[6])
{
  double t, q;
  bool inside;
  truncated_root(c[0], c[1], c[2], 1.0, t, q, inside);
  double left = -0.5, right = 0.5;
  for (int it = 0; it < MAX_ITER; it++) {
    double f = c[5], df = 0.0;
    for (int k = 4; k >= 0; k--) {
      df = df * t + f;
      f = f * t + c[k];
    }
    if (safeguarded_step(t, f, df, left, right)) break;
  }
  return t;
}

/* lambda_min maximising h over [0, 1] (3D pairs of different sizes) */
inline double maximise(const Geometry &p)
{
  const double d_i = std::sqrt(p.bi2 + (p.ai2 - p.bi2) * p.x * p.x);
  const double d_j = std::sqrt(p.bj2 + (p.aj2 - p.bj2) * p.z * p.z);
  double t = std::fmin(std::fmax(d_i / (d_i + d_j), 0.0), 1.0);
  double left = 0.0, right = 1.0;
  for (int it = 0; it < MAX_ITER; it++) {
    double f, df;
    h_lambda_derivatives(t, p, f, df);
    if (safeguarded_step(t, f, df, left, right)) break;
  }
  return t;
}

/* largest sigma^2 of the method for particles of reach (half longest axis) R_i, R_j */
inline double bound_sq(int method, double reach_i, double reach_j)
{
  if (method == EXACT) return (reach_i + reach_j) * (reach_i + reach_j);
  return 2.0 * (reach_i * reach_i + reach_j * reach_j);
}

/* sigma and dsigma/d(x, z, m) of one pair; fell_back: a truncation's root left (0, 1); capped: it
   gave a larger sigma than lambda = 1/2 */
inline void contact(int method, int dim, bool identical, const Geometry &p, double &sigma, double &s_x,
                    double &s_z, double &s_m, bool &fell_back, bool &capped)
{
  double lam, y_x = 0.0, y_z = 0.0, y_m = 0.0, c[6];
  fell_back = capped = false;
  if (method == EXACT) {
    if (dim == 2 || identical) {
      coefficients(dim, p, c);
      lam = 0.5 + polynomial_root(c);
    } else {
      lam = maximise(p);
    }
  } else if (method == GAUSSIAN || method == CLEAVER) {
    lam = 0.5;
  } else {
    double q;
    bool inside, kept;
    coefficients(dim, p, c);
    truncated_lambda(method == QUADRATIC ? 1.0 : 0.0, p, c, lam, q, inside, kept);
    fell_back = !inside;
    capped = inside && !kept;
    if (kept) root_partials(dim, lam - 0.5, q, p, y_x, y_z, y_m);
  }
  sigma_partials(lam, p, sigma, s_x, s_z, s_m);
  if (y_x != 0.0 || y_z != 0.0 || y_m != 0.0) {
    double h1, h2;
    h_lambda_derivatives(lam, p, h1, h2);
    const double s_lam = -0.5 * sigma * sigma * sigma * h1;
    s_x += s_lam * y_x;
    s_z += s_lam * y_z;
    s_m += s_lam * y_m;
  }
}

}    // namespace jamflow_contact

#endif
