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
