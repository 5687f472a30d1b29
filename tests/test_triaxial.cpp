// Single-point drained triaxial compression of Drucker-Prager (material
// driver: axial strain prescribed, lateral stresses held at the confining
// pressure by Newton on the lateral strain with the consistent tangent).
// The peak deviatoric stress q = sigma_r - sigma_a is compared with
//  - the Mohr-Coulomb triaxial-compression strength 2 (c cos phi + s_c sin phi) / (1 - sin phi)
//    for the outer-cone match (the cone passes through the compressive meridians);
//  - the Drucker-Prager closed form (xi c + eta s_c) / (1/sqrt3 - eta/3) for any match;
// and the dilatancy ratio d eps_v^p / d eps_q^p with its closed form sqrt(3) eta_bar(psi).
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>

#include "talus/materials/drucker_prager.hpp"
#include "talus/materials/mohr_coulomb.hpp"

using namespace talus;

namespace {

struct TriaxialResult {
  double peak_q, dilatancy_ratio;
};

TriaxialResult triaxial(const DruckerPrager& m, double confining) {
  Voigt sigma = -confining * (Voigt() << 1, 1, 1, 0, 0, 0).finished();
  double alpha = 0;
  const double d_axial = -2e-5;  // compression
  double peak = 0, ratio = 0;
  for (int step = 0; step < 2000; ++step) {
    // Find the lateral strain increment x with sigma_22 = sigma_33 = -confining.
    double x = -0.3 * d_axial;
    MaterialPointUpdate u;
    double alpha_new = alpha;
    for (int it = 0; it < 30; ++it) {
      const Voigt de = (Voigt() << d_axial, x, x, 0, 0, 0).finished();
      m.update(sigma, de, &alpha, &alpha_new, u);
      const double r = u.stress[1] + confining;
      if (std::abs(r) < 1e-10 * confining) break;
      x -= r / (u.tangent(1, 1) + u.tangent(1, 2));
    }
    REQUIRE(std::abs(u.stress[1] + confining) < 1e-8 * confining);
    sigma = u.stress;
    alpha = alpha_new;
    peak = std::max(peak, sigma[1] - sigma[0]);
    const Voigt& ep = u.plastic_strain_increment;
    if (ep.norm() > 0) {
      const double vol = ep.head<3>().sum();
      const Voigt dev = ep - vol / 3 * (Voigt() << 1, 1, 1, 0, 0, 0).finished();
      const double eq = std::sqrt(2.0 / 3.0 * (dev.head<3>().squaredNorm() + 0.5 * dev.tail<3>().squaredNorm()));
      ratio = vol / eq;  // dilation positive (tension-positive volumetric strain)
    }
  }
  return {peak, ratio};
}

DruckerPrager sand(double phi, double psi, double c, MohrCoulombMatch match) {
  return DruckerPrager(drucker_prager_parameters(2000, 5e7, 0.25, phi, psi, c, 0.0, match));
}

}  // namespace

TEST_CASE("triaxial compression: peak strength and dilatancy against closed forms", "[plasticity][triaxial]") {
  const double phi = 32, c = 1e4;
  for (double psi : {0.0, 8.0, 32.0})
    for (double confining : {5e4, 1e5, 2e5}) {
      const double s = std::sin(phi * M_PI / 180), co = std::cos(phi * M_PI / 180);
      // Outer match: Drucker-Prager and Mohr-Coulomb coincide in triaxial compression.
      const DruckerPrager outer = sand(phi, psi, c, MohrCoulombMatch::outer);
      const TriaxialResult r = triaxial(outer, confining);
      const double q_mc = 2 * (c * co + confining * s) / (1 - s);
      // sqrt(3) eta_bar with the outer-match eta_bar = 6 sin(psi) / (sqrt(3) (3 - sin(psi))).
      const double sp = std::sin(psi * M_PI / 180), ratio = 6 * sp / (3 - sp);
      std::printf("triaxial psi %4.1f, s_c %6.0f Pa: q_peak %.6e, Mohr-Coulomb %.6e; dilatancy %.5f, "
                  "closed form %.5f\n", psi, confining, r.peak_q, q_mc, r.dilatancy_ratio, ratio);
      CHECK(r.peak_q == Approx(q_mc).epsilon(0.005));
      CHECK(r.dilatancy_ratio == Approx(ratio).margin(1e-6));
      // Plane-strain match: the Drucker-Prager closed form with
      // eta = 3 tan(phi) / sqrt(9 + 12 tan^2 phi), xi = 3 / sqrt(9 + 12 tan^2 phi).
      const DruckerPrager ps = sand(phi, psi, c, MohrCoulombMatch::plane_strain);
      const double t = std::tan(phi * M_PI / 180), root = std::sqrt(9 + 12 * t * t);
      const double eta = 3 * t / root, xi = 3 / root;
      const double q_dp = (xi * c + eta * confining) / (1 / std::sqrt(3.0) - eta / 3);
      CHECK(triaxial(ps, confining).peak_q == Approx(q_dp).epsilon(0.005));
    }
}

// The same drained triaxial compression for Mohr-Coulomb (tension positive;
// the axial stress sigma3 is the most compressive, sigma1 = sigma2 = sigma_lat).
// With both planes f_13 and f_23 active (the edge sigma1 = sigma2),
//   q = sigma_lat - sigma_axial = 2 (c cos(phi) - sigma_lat sin(phi)) / (1 - sin(phi)),
// and the flow d_eps_p = dgamma (N_13 + N_23) = dgamma (1 + sin psi, 1 + sin psi, -2 (1 - sin psi))
// (lateral, lateral, axial) gives the dilatancy ratio
//   -d_eps_v^p / d_eps_axial^p = 2 sin(psi) / (1 - sin(psi))
// (and d_eps_v^p / d_eps_q^p = 6 sin(psi) / (3 - sin(psi)), the outer Drucker-Prager one).

namespace {

struct MohrCoulombTriaxial {
  double peak_q, axial_ratio, shear_ratio;
  MohrCoulombBranch branch;  // of the last step
};

MohrCoulombTriaxial mohr_coulomb_triaxial(const MohrCoulomb& m, double confining) {
  Voigt sigma = -confining * (Voigt() << 1, 1, 1, 0, 0, 0).finished();
  const double d_axial = -2e-5;  // compression of axis 1 (Voigt 0)
  MohrCoulombTriaxial r{0, 0, 0, MohrCoulombBranch::elastic};
  for (int step = 0; step < 2000; ++step) {
    // Lateral strain increment x with sigma_22 = sigma_33 = -confining (Newton, consistent tangent).
    double x = -0.3 * d_axial;
    MaterialPointUpdate u;
    Voigt de;
    for (int it = 0; it < 30; ++it) {
      de = (Voigt() << d_axial, x, x, 0, 0, 0).finished();
      m.update(sigma, de, nullptr, nullptr, u);
      const double res = u.stress[1] + confining;
      if (std::abs(res) < 1e-10 * confining) break;
      x -= res / (u.tangent(1, 1) + u.tangent(1, 2));
    }
    REQUIRE(std::abs(u.stress[1] + confining) < 1e-8 * confining);
    REQUIRE(std::abs(u.stress[2] + confining) < 1e-8 * confining);
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(voigt_to_tensor(sigma + m.elastic_stiffness() * de));
    r.branch = m.principal_return(eig.eigenvalues().reverse()).branch;
    sigma = u.stress;
    r.peak_q = std::max(r.peak_q, sigma[1] - sigma[0]);
    const Voigt& ep = u.plastic_strain_increment;
    if (ep.norm() > 0) {
      const double vol = ep.head<3>().sum();
      r.axial_ratio = -vol / ep[0];
      const Voigt dev = ep - vol / 3 * (Voigt() << 1, 1, 1, 0, 0, 0).finished();
      const double eq = std::sqrt(2.0 / 3.0 * (dev.head<3>().squaredNorm() + 0.5 * dev.tail<3>().squaredNorm()));
      r.shear_ratio = vol / eq;
    }
  }
  return r;
}

}  // namespace

TEST_CASE("triaxial compression: mohr_coulomb peak strength and dilatancy against closed forms",
          "[plasticity][triaxial]") {
  const double phi = 32, c = 1e4;
  double worst_q = 0, worst_ratio = 0;
  for (double psi : {0.0, 8.0, 32.0})
    for (double confining : {5e4, 1e5, 2e5}) {
      const MohrCoulomb m(mohr_coulomb_parameters(2000, 5e7, 0.25, phi, psi, c));
      const MohrCoulombTriaxial r = mohr_coulomb_triaxial(m, confining);
      const double s = std::sin(phi * M_PI / 180), co = std::cos(phi * M_PI / 180);
      const double sigma_lat = -confining;
      const double q_mc = 2 * (c * co - sigma_lat * s) / (1 - s);
      const double sp = std::sin(psi * M_PI / 180);
      const double axial_ratio = 2 * sp / (1 - sp), shear_ratio = 6 * sp / (3 - sp);
      std::printf("Mohr-Coulomb triaxial psi %4.1f, s_c %6.0f Pa: q_peak %.9e, closed form %.9e (rel. error %.1e); "
                  "-deps_v/deps_a %.9f, closed form %.9f; deps_v/deps_q %.9f, closed form %.9f\n",
                  psi, confining, r.peak_q, q_mc, r.peak_q / q_mc - 1, r.axial_ratio, axial_ratio, r.shear_ratio,
                  shear_ratio);
      CHECK(r.branch == MohrCoulombBranch::edge_12);  // sigma_lat = sigma1 = sigma2: the compression edge
      CHECK(r.peak_q == Approx(q_mc).epsilon(0.005));
      CHECK(r.peak_q == Approx(q_mc).epsilon(1e-9));  // perfect plasticity: the plateau is exact
      CHECK(r.axial_ratio == Approx(axial_ratio).margin(1e-9));
      CHECK(r.shear_ratio == Approx(shear_ratio).margin(1e-9));
      worst_q = std::max(worst_q, std::abs(r.peak_q / q_mc - 1));
      worst_ratio = std::max(worst_ratio, std::abs(r.axial_ratio - axial_ratio));
    }
  std::printf("Mohr-Coulomb triaxial: max relative error of q_peak %.2e, of the dilatancy ratio %.2e\n", worst_q,
              worst_ratio);
}
