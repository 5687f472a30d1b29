#include "talus/materials/mohr_coulomb.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "talus/io/yaml_section.hpp"
#include "talus/materials/parameters.hpp"

namespace talus {

namespace {

// Principal stresses of a symmetric 3 x 3 stress. In plane strain
// (sigma_xz = sigma_yz = 0, every 2D particle) z is a principal direction and
// the x-y block is solved in closed form,
//   lambda = m +- r,  r = sqrt(((a - d)/2)^2 + b^2),
//   theta = atan2(2 b, a - d) / 2  (cos 2 theta = (a - d)/(2 r), sin 2 theta = b / r),
// exact to round-off and several times cheaper than Eigen's iterative
// solver, which remains for general 3D states. (Stresses are far from the
// range where r could overflow, so no hypot.) The values come first and the
// directions only on request: an elastic or apex particle needs none.
struct PrincipalStresses {
  Eigen::Vector3d values;   // ascending
  Eigen::Matrix3d vectors;  // unit eigenvectors (columns), set by directions()
  bool plane = false;
  std::array<int, 3> order{};  // plane strain: which of (m + r, m - r, zz) is values[i]
  double a = 0, b = 0, d = 0, r = 0;

  explicit PrincipalStresses(const Eigen::Matrix3d& A) {
    plane = A(0, 2) == 0.0 && A(1, 2) == 0.0;
    if (!plane) {
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(A);
      values = eigen.eigenvalues();
      vectors = eigen.eigenvectors();
      return;
    }
    a = A(0, 0), b = A(0, 1), d = A(1, 1);
    const double m = 0.5 * (a + d);
    r = std::sqrt(0.25 * (a - d) * (a - d) + b * b);
    const double candidate[3] = {m + r, m - r, A(2, 2)};
    // Stable insertion sort of three (ties keep this order).
    order = {0, 1, 2};
    for (int i = 1; i < 3; ++i)
      for (int j = i; j > 0 && candidate[order[j]] < candidate[order[j - 1]]; --j) std::swap(order[j], order[j - 1]);
    for (int i = 0; i < 3; ++i) values[i] = candidate[order[i]];
  }

  void directions() {
    if (!plane) return;
    // cos and sin of theta from those of 2 theta by the half-angle formulas,
    // each taken where it does not cancel; theta in (-pi/2, pi/2], c >= 0.
    double c = 1.0, s = 0.0;
    if (r > 0.0) {
      const double cos2 = 0.5 * (a - d) / r, sin2 = b / r;
      if (cos2 >= 0.0) {
        c = std::sqrt(0.5 * (1.0 + cos2));
        s = 0.5 * sin2 / c;
      } else {
        s = std::copysign(std::sqrt(0.5 * (1.0 - cos2)), b == 0.0 ? 1.0 : b);
        c = 0.5 * sin2 / s;
      }
    }
    const Eigen::Vector3d candidate[3] = {{c, s, 0.0}, {-s, c, 0.0}, {0.0, 0.0, 1.0}};
    for (int i = 0; i < 3; ++i) vectors.col(i) = candidate[order[i]];
  }
};

using Vector3 = Eigen::Vector3d;
using Matrix3 = Eigen::Matrix3d;

const Voigt unit_voigt = (Voigt() << 1, 1, 1, 0, 0, 0).finished();

// Normal of the plane (sigma_i - sigma_j) + (sigma_i + sigma_j) sin(angle) in
// principal stresses: (1 + sin) e_i - (1 - sin) e_j.
Vector3 plane_normal(int i, int j, double sin_angle) {
  Vector3 n = Vector3::Zero();
  n[i] = 1.0 + sin_angle;
  n[j] = -(1.0 - sin_angle);
  return n;
}

}  // namespace

MohrCoulombParameters mohr_coulomb_parameters(double density, double youngs_modulus, double poisson_ratio,
                                              double friction_angle_deg, double dilatancy_angle_deg,
                                              double cohesion) {
  MohrCoulombParameters p;
  p.density = density;
  p.youngs_modulus = youngs_modulus;
  p.poisson_ratio = poisson_ratio;
  p.friction_angle = friction_angle_deg * M_PI / 180.0;
  p.dilatancy_angle = dilatancy_angle_deg * M_PI / 180.0;
  p.cohesion = cohesion;
  return p;
}

MohrCoulomb::MohrCoulomb(const MohrCoulombParameters& p)
    : par_(p), stiffness_(isotropic_stiffness(p.youngs_modulus, p.poisson_ratio)) {
  sin_phi_ = std::sin(p.friction_angle);
  cos_phi_ = std::cos(p.friction_angle);
  sin_psi_ = std::sin(p.dilatancy_angle);
  shear_ = p.youngs_modulus / (2.0 * (1.0 + p.poisson_ratio));
  bulk_ = p.youngs_modulus / (3.0 * (1.0 - 2.0 * p.poisson_ratio));
  apex_ = p.cohesion * cos_phi_ / sin_phi_;
  principal_stiffness_ = (bulk_ - 2.0 * shear_ / 3.0) * Matrix3::Ones() + 2.0 * shear_ * Matrix3::Identity();
  compliance_ = stiffness_.inverse();
}

std::unique_ptr<Material> MohrCoulomb::from_yaml(YamlSection& y) {
  const ElasticParameters e = read_elastic_parameters(y);
  const FrictionParameters f = read_friction_parameters(y);
  return std::make_unique<MohrCoulomb>(mohr_coulomb_parameters(e.density, e.youngs_modulus, e.poisson_ratio,
                                                               f.friction_angle, f.dilatancy_angle, f.cohesion));
}

double MohrCoulomb::yield_function(const Voigt& stress) const {
  const Vector3 s = PrincipalStresses(voigt_to_tensor(stress)).values;  // ascending
  return (s[2] - s[0]) + (s[2] + s[0]) * sin_phi_ - 2.0 * par_.cohesion * cos_phi_;
}

MohrCoulombPrincipalReturn MohrCoulomb::principal_return(const Vector3& trial) const {
  const Matrix3& De = principal_stiffness_;
  const double two_c_cos = 2.0 * par_.cohesion * cos_phi_;
  MohrCoulombPrincipalReturn r;
  // Relative tolerance on the yield test: round-off of the trial stress.
  const double scale = trial.cwiseAbs().sum() + two_c_cos;
  const Vector3 nf = plane_normal(0, 2, sin_phi_), ng = plane_normal(0, 2, sin_psi_);
  const double f_tr = nf.dot(trial) - two_c_cos;
  if (f_tr <= 1e-12 * scale) {
    r.stress = trial;
    r.jacobian.setIdentity();
    r.plastic_strain.setZero();
    return r;
  }

  // Apex: the plastic strain that returns the trial state to sigma_a lies in
  // the apex cone C = { e : tr e >= sin(psi) sum |e_i| } (checked first).
  const double p_tr = trial.mean();
  const Vector3 e_apex =
      (trial - p_tr * Vector3::Ones()) / (2.0 * shear_) + (p_tr - apex_) / (3.0 * bulk_) * Vector3::Ones();
  const auto apex = [&]() {
    r.branch = MohrCoulombBranch::apex;
    r.stress = Vector3::Constant(apex_);
    r.jacobian.setZero();
    r.plastic_strain = e_apex;
    r.multiplier[0] = r.multiplier[1] = 0.0;
    return r;
  };
  if (e_apex.sum() >= sin_psi_ * e_apex.cwiseAbs().sum()) return apex();

  // Main plane f_13: f is linear in the multiplier (Box 8.4).
  {
    const Vector3 Dng = De * ng;
    const double a = nf.dot(Dng);  // 4G (1 + sin(phi) sin(psi) / 3) + 4K sin(phi) sin(psi)
    const double dgamma = f_tr / a;
    const Vector3 s = trial - dgamma * Dng;
    if (s[0] >= s[1] && s[1] >= s[2]) {
      r.branch = MohrCoulombBranch::plane;
      r.stress = s;
      r.jacobian = Matrix3::Identity() - Dng * nf.transpose() / a;
      r.plastic_strain = dgamma * ng;
      r.multiplier[0] = dgamma;
      return r;
    }
  }

  // Edges (Box 8.5), two planes active: f_13 and f_12 (sigma2 = sigma3, dSN's
  // right corner) or f_13 and f_23 (sigma1 = sigma2, left corner). dSN's
  // criterion picks the side the main-plane return overshot; the other edge
  // is only tried against round-off at the boundary between the two.
  // The 2x2 system [a b; b a] (dgamma_a, dgamma_b) = (f_a, f_b) is solved in
  // sums and differences: with d the direction that separates the edge's
  // pair, (1, -1, 0) or (0, 1, -1), n_a - n_b = kappa d for both f and g, and
  //   dgamma_a - dgamma_b = (d . trial) / (2 G kappa_g),
  //   sigma = trial - d (d . trial) / 2 - De n_g (n_f . trial - 4 c cos(phi)) / (n_f . De n_g),
  // n_f, n_g the sums of the two planes' normals. (a - b = 2G(1 - sin phi)(1 - sin psi)
  // on the right edge: the explicit inverse would lose digits as phi, psi -> 90.)
  const double side = (1.0 - sin_psi_) * trial[0] - 2.0 * trial[1] + (1.0 + sin_psi_) * trial[2];
  const bool right_first = side > 0.0;
  for (int attempt = 0; attempt < 2; ++attempt) {
    const bool right = (attempt == 0) == right_first;
    const Vector3 nfs = nf + (right ? plane_normal(0, 1, sin_phi_) : plane_normal(1, 2, sin_phi_));
    const Vector3 ngs = ng + (right ? plane_normal(0, 1, sin_psi_) : plane_normal(1, 2, sin_psi_));
    const Vector3 d = right ? Vector3(0, 1, -1) : Vector3(1, -1, 0);
    const double kappa_g = right ? 1.0 - sin_psi_ : 1.0 + sin_psi_;
    const Vector3 Dngs = De * ngs;
    const double a_plus_b = 0.5 * nfs.dot(Dngs);
    const double gamma_sum = (nfs.dot(trial) - 2.0 * two_c_cos) / a_plus_b;
    const double gamma_diff = d.dot(trial) / (2.0 * shear_ * kappa_g);
    const double dgamma[2] = {0.5 * (gamma_sum + gamma_diff), 0.5 * (gamma_sum - gamma_diff)};
    Vector3 s = trial - 0.5 * d.dot(trial) * d - 0.5 * gamma_sum * Dngs;
    // The two stresses of the edge are equal; make them so to the last bit.
    const int k = right ? 1 : 0;
    s[k] = s[k + 1] = 0.5 * (s[k] + s[k + 1]);
    const double tol_gamma = 1e-10 * (std::abs(dgamma[0]) + std::abs(dgamma[1]));
    const double tol_stress = 1e-10 * scale;
    const bool sorted = right ? s[0] + tol_stress >= s[1] : s[1] + tol_stress >= s[2];
    if (dgamma[0] >= -tol_gamma && dgamma[1] >= -tol_gamma && sorted) {
      r.branch = right ? MohrCoulombBranch::edge_23 : MohrCoulombBranch::edge_12;
      r.stress = s;
      r.jacobian = Matrix3::Identity() - 0.5 * d * d.transpose() - Dngs * nfs.transpose() / nfs.dot(Dngs);
      r.plastic_strain = dgamma[0] * ng + dgamma[1] * (ngs - ng);
      r.multiplier[0] = dgamma[0];
      r.multiplier[1] = dgamma[1];
      return r;
    }
  }
  // Not reached outside round-off: the plane, edge and apex regions partition
  // the plastic trial states (docs/mohr_coulomb.md). The apex is admissible.
  return apex();
}

void MohrCoulomb::update(const Voigt& rotated_stress, const Voigt& strain_increment, const double*, double*,
                         MaterialPointUpdate& out) const {
  const Voigt trial = rotated_stress + stiffness_ * strain_increment;
  out.separation_strain_increment = 0.0;
  // Inside the cone for sure, without the principal stresses: with p the mean
  // stress and J2 the deviator's invariant, sigma_1 - sigma_3 <= 2 sqrt(J2)
  // (pure shear) and sigma_1 + sigma_3 = 2 p - s_2 with |s_2| <= sqrt(J2 / 3)
  // (s_2 the middle deviatoric stress), so the yield function of
  // principal_return is at most 2 sqrt(J2) + sin(phi) (2 p + sqrt(J2 / 3))
  // - 2 c cos(phi). Where that is <= 0 the step is elastic on every branch
  // test below; most particles of a resting or creeping mass are.
  const double p = mean_stress(trial), root_j2 = deviatoric_stress(trial) / std::sqrt(3.0);
  if (2.0 * root_j2 + sin_phi_ * (2.0 * p + root_j2 / std::sqrt(3.0)) <= 2.0 * par_.cohesion * cos_phi_) {
    out.stress = trial;
    out.tangent = stiffness_;
    out.trial_sensitivity.setIdentity();
    out.plastic_strain_increment.setZero();
    return;
  }
  PrincipalStresses principal(voigt_to_tensor(trial));
  // Sorted descending: sigma1 >= sigma2 >= sigma3.
  const Vector3 lambda = principal.values.reverse();
  const MohrCoulombPrincipalReturn ret = principal_return(lambda);

  if (ret.branch == MohrCoulombBranch::elastic) {
    out.stress = trial;
    out.tangent = stiffness_;
    out.trial_sensitivity.setIdentity();
    out.plastic_strain_increment.setZero();
    return;
  }
  if (ret.branch == MohrCoulombBranch::apex) {
    out.stress = apex_ * unit_voigt;
    out.trial_sensitivity.setZero();
    out.tangent.setZero();
    out.plastic_strain_increment = compliance_ * (trial - out.stress);
    // The volumetric opening beyond the dilatancy the flow rule allows.
    const Vector3& e = ret.plastic_strain;
    out.separation_strain_increment = std::max(0.0, e.sum() - sin_psi_ * e.cwiseAbs().sum());
    return;
  }
  principal.directions();
  const Matrix3 V = principal.vectors.rowwise().reverse();

  // sigma = sum_i sigma_i E_i with the trial's eigenprojections E_i = v_i v_i^T;
  // S = sum_ij (d sigma_i / d lambda_j) E_i (x) E_j
  //   + sum_{i<k} (sigma_i - sigma_k) / (lambda_i - lambda_k) M_ik (x) M_ik,
  // M_ik = (v_i v_k^T + v_k v_i^T) / sqrt(2), the unit shear of the pair.
  // In matrix form S = E J Es^T + M R Ms^T: E, M the 6 x 3 matrices of the
  // E_i and M_ik, Es, Ms the same strain-like, R the diagonal of the ratios.
  Eigen::Matrix<double, 6, 3> E, M;
  for (int i = 0; i < 3; ++i) E.col(i) = tensor_to_voigt(V.col(i) * V.col(i).transpose());
  const int pair[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  for (int p = 0; p < 3; ++p) {
    const int i = pair[p][0], k = pair[p][1];
    M.col(p) = tensor_to_voigt(V.col(i) * V.col(k).transpose() + V.col(k) * V.col(i).transpose()) / std::sqrt(2.0);
  }
  out.stress = E * ret.stress;
  if (out.stress_only) return;
  Eigen::Matrix<double, 6, 3> Es = E, Ms = M;
  Es.bottomRows<3>() *= 2.0;
  Ms.bottomRows<3>() *= 2.0;
  Vector3 ratio;
  const double scale = lambda.cwiseAbs().sum() + par_.cohesion;
  for (int p = 0; p < 3; ++p) {
    const int i = pair[p][0], k = pair[p][1];
    if ((ret.branch == MohrCoulombBranch::edge_12 && p == 0) || (ret.branch == MohrCoulombBranch::edge_23 && p == 2)) {
      ratio[p] = 0.0;  // sigma_i = sigma_k on the whole edge, so the ratio and its limit vanish
    } else if (lambda[i] - lambda[k] > 1e-12 * scale) {
      ratio[p] = (ret.stress[i] - ret.stress[k]) / (lambda[i] - lambda[k]);
    } else {
      // Coincident eigenvalues: the limit of the ratio for the smooth,
      // symmetric principal map of the branch.
      ratio[p] = ret.jacobian(i, i) - ret.jacobian(i, k);
    }
  }
  const Tangent S = E * ret.jacobian * Es.transpose() + M * ratio.asDiagonal() * Ms.transpose();
  out.trial_sensitivity = S;
  // S D with the isotropic D = lambda 1 1^T + diag(2G, 2G, 2G, G, G, G)
  // (engineering shear), without the full 6 x 6 product.
  const double lame = bulk_ - 2.0 * shear_ / 3.0;
  const Voigt volumetric = lame * S.leftCols<3>().rowwise().sum();
  out.tangent.leftCols<3>() = volumetric.replicate<1, 3>() + 2.0 * shear_ * S.leftCols<3>();
  out.tangent.rightCols<3>() = shear_ * S.rightCols<3>();
  out.plastic_strain_increment = compliance_ * (trial - out.stress);
}

std::string MohrCoulomb::parameters() const {
  const double deg = 180.0 / 3.14159265358979323846;
  return parameter_text(model(), {{"density", par_.density},
                                  {"youngs_modulus", par_.youngs_modulus},
                                  {"poisson_ratio", par_.poisson_ratio},
                                  {"friction_angle", par_.friction_angle * deg},
                                  {"dilatancy_angle", par_.dilatancy_angle * deg},
                                  {"cohesion", par_.cohesion}});
}

}  // namespace talus
