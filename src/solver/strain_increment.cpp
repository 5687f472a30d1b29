#include "talus/solver/strain_increment.hpp"

#include <cmath>
#include <limits>

namespace talus {

namespace {

// A symmetric tensor in Voigt form with engineering shear.
Voigt strain_voigt(const Eigen::Matrix3d& e) {
  Voigt v;
  v << e(0, 0), e(1, 1), e(2, 2), 2.0 * e(1, 2), 2.0 * e(0, 2), 2.0 * e(0, 1);
  return v;
}

StrainIncrementResult linear_increment(const Eigen::Matrix3d& L, double h, int derivative_dim) {
  StrainIncrementResult r;
  r.strain = strain_voigt(0.5 * h * (L + L.transpose()));
  if (derivative_dim == 0) return r;  // the step's hot path: no derivative asked for
  r.derivative.setZero();
  for (int k = 0; k < derivative_dim; ++k)
    for (int l = 0; l < derivative_dim; ++l) r.derivative(voigt_index(k, l), 3 * k + l) = h;
  return r;
}

}  // namespace

StrainIncrementResult strain_increment(const Eigen::Matrix3d& L, double h, StrainIncrement kind, int derivative_dim) {
  if (kind == StrainIncrement::linear) return linear_increment(L, h, derivative_dim);
  const Eigen::Matrix3d dF = Eigen::Matrix3d::Identity() + h * L;
  if (!(dF.determinant() > 0.0)) {
    // An inverted step (or a NaN velocity): no strain measure applies.
    StrainIncrementResult r;
    r.strain.setConstant(std::numeric_limits<double>::quiet_NaN());
    r.derivative.setZero();
    return r;
  }
  const Eigen::Matrix3d C = dF.transpose() * dF;
  Eigen::Vector3d c;  // > 0: dF is not singular
  Eigen::Matrix3d N;
  if (L(2, 0) == 0.0 && L(2, 1) == 0.0 && L(0, 2) == 0.0 && L(1, 2) == 0.0 && L(2, 2) == 0.0) {
    // Plane strain: C = diag(C_2x2, 1), whose 2 x 2 block has the closed
    // form c = m +- r, m = (C00 + C11)/2, r = |((C00 - C11)/2, C01)|, at the
    // angle atan2(2 C01, C00 - C11)/2 (accurate to round-off; half the
    // cost of the iterative 3 x 3 solver on the 2D column).
    const double m = 0.5 * (C(0, 0) + C(1, 1)), half_gap = 0.5 * (C(0, 0) - C(1, 1));
    const double r = std::hypot(half_gap, C(0, 1)), angle = 0.5 * std::atan2(C(0, 1), half_gap);
    c << m + r, m - r, 1.0;
    const double cs = std::cos(angle), sn = std::sin(angle);
    N << cs, -sn, 0.0, sn, cs, 0.0, 0.0, 0.0, 1.0;
  } else {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(C);
    c = eigen.eigenvalues();
    N = eigen.eigenvectors();
  }
  auto g = [](double x) { return 0.5 * std::log(x); };
  auto dg = [](double x) { return 0.5 / x; };
  Eigen::Vector3d gc;
  for (int a = 0; a < 3; ++a) gc[a] = g(c[a]);
  StrainIncrementResult r;
  r.strain = strain_voigt(N * gc.asDiagonal() * N.transpose());
  // d g(C) = sum_ab f_ab (n_a . dC n_b) n_a (x) n_b with f_aa = g'(c_a) and
  // f_ab = (g(c_a) - g(c_b)) / (c_a - c_b) (for close eigenvalues the mean
  // of g', where the divided difference loses its digits; exact to
  // O(gap^2)); dC = h (E_lk dF + dF^T E_kl) for dL = E_kl.
  Eigen::Matrix3d f;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      const double gap = c[a] - c[b];
      f(a, b) = std::abs(gap) > 1e-6 * (c[a] + c[b]) ? (gc[a] - gc[b]) / gap : 0.5 * (dg(c[a]) + dg(c[b]));
    }
  r.derivative.setZero();
  // dL = E_kl gives dC = h (e_l r_k^T + r_k e_l^T), r_k = dF^T e_k, so in the
  // eigenbasis n_a . dC n_b = h (a_a b_b + b_a a_b) with a = N^T e_l (row l
  // of N) and b = N^T r_k: a symmetric rank-2 matrix, no 3 x 3 products.
  for (int k = 0; k < derivative_dim; ++k) {
    const Eigen::Vector3d b = N.transpose() * dF.row(k).transpose();
    for (int l = 0; l < derivative_dim; ++l) {
      const Eigen::Vector3d a = N.row(l).transpose();
      const Eigen::Matrix3d projected = h * (a * b.transpose() + b * a.transpose());
      r.derivative.col(3 * k + l) = strain_voigt(N * f.cwiseProduct(projected) * N.transpose());
    }
  }
  return r;
}

}  // namespace talus
