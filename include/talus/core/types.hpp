#pragma once
// Small dense types shared by every module. Stress and strain are stored in
// Voigt order (11, 22, 33, 23, 13, 12) in 3D even for 2D plane strain, so that
// materials never depend on the dimension; strains use engineering shear
// (gamma_ij = 2 eps_ij), stresses do not. Tension is positive.
#include <Eigen/Dense>

namespace talus {

template <int dim>
using Vector = Eigen::Matrix<double, dim, 1>;
template <int dim>
using Matrix = Eigen::Matrix<double, dim, dim>;

using Voigt = Eigen::Matrix<double, 6, 1>;
using Tangent = Eigen::Matrix<double, 6, 6>;

// Voigt position of tensor component (i, j), i, j in 0..2.
constexpr int voigt_index(int i, int j) {
  return i == j ? i : 6 - i - j;  // (1,2)->3, (0,2)->4, (0,1)->5
}

// Row of sigma_ij (= sigma_ji) among a dim-dimensional stress's components:
// xx, yy, xy in 2D (the in-plane ones); the Voigt six in 3D.
template <int dim>
constexpr int stress_row(int i, int j) {
  return dim == 2 ? (i == j ? i : 2) : voigt_index(i, j);
}

inline Eigen::Matrix3d voigt_to_tensor(const Voigt& s) {
  Eigen::Matrix3d t;
  t << s[0], s[5], s[4], s[5], s[1], s[3], s[4], s[3], s[2];
  return t;
}

inline Voigt tensor_to_voigt(const Eigen::Matrix3d& t) {
  Voigt s;
  s << t(0, 0), t(1, 1), t(2, 2), 0.5 * (t(1, 2) + t(2, 1)), 0.5 * (t(0, 2) + t(2, 0)),
      0.5 * (t(0, 1) + t(1, 0));
  return s;
}

// Mean stress p = tr(sigma)/3 (tension positive) and von Mises q = sqrt(3 J2).
inline double mean_stress(const Voigt& s) { return (s[0] + s[1] + s[2]) / 3.0; }
inline double deviatoric_stress(const Voigt& s) {
  const double p = mean_stress(s);
  const double j2 = 0.5 * ((s[0] - p) * (s[0] - p) + (s[1] - p) * (s[1] - p) + (s[2] - p) * (s[2] - p)) +
                    s[3] * s[3] + s[4] * s[4] + s[5] * s[5];
  return std::sqrt(3.0 * j2);
}

}  // namespace talus
