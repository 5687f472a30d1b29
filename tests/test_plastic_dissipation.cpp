// Plastic dissipation d = sigma^{n+1} : d_eps_p of one return mapping, for
// both laws (the seminar's Clausius-Duhem inequality, d >= 0 when the origin
// is admissible). With c = 0 the yield function is positively homogeneous of
// degree one, so for ASSOCIATED flow d = dgamma sigma : df/dsigma =
// dgamma f(sigma) = 0: a cohesionless associated material flows without
// dissipating anything, all the work of shearing goes into dilatancy. This is
// why the associated column in inputs/ spreads as a dilating spray instead of
// coming to rest; with psi < phi, d = dgamma (eta_bar - eta) p > 0 on the
// cone (p < 0) and the flow is frictional.
#include <catch2/catch.hpp>
#include <random>

#include "talus/materials/drucker_prager.hpp"
#include "talus/materials/mohr_coulomb.hpp"

using namespace talus;

namespace {

// The dissipation sigma : d_eps_p (engineering shears in d_eps_p) and the
// scale |sigma| |d_eps_p| it is compared with, over random plastic steps.
struct Dissipation {
  double min_ratio = 1e300, max_ratio = -1e300;
  long plastic = 0;
};

Dissipation sweep(const Material& m, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> d(0.0, 1.0);
  Dissipation out;
  for (int k = 0; k < 3000; ++k) {
    Voigt sigma0, de;
    for (int i = 0; i < 6; ++i) sigma0[i] = 2e4 * d(rng) - 3e4 * (i < 3);  // mostly compressive
    for (int i = 0; i < 6; ++i) de[i] = 2e-3 * d(rng);
    MaterialPointUpdate u;
    double s0[2] = {0, 0}, s1[2] = {0, 0};
    m.update(sigma0, de, s0, s1, u);
    const double scale = u.stress.norm() * u.plastic_strain_increment.norm();
    if (u.plastic_strain_increment.norm() == 0.0 || scale == 0.0) continue;
    ++out.plastic;
    const double ratio = u.stress.dot(u.plastic_strain_increment) / scale;
    out.min_ratio = std::min(out.min_ratio, ratio);
    out.max_ratio = std::max(out.max_ratio, ratio);
  }
  return out;
}

}  // namespace

TEST_CASE("cohesionless associated flow dissipates nothing, nonassociated flow does", "[plasticity]") {
  for (int law = 0; law < 2; ++law) {
    const auto make = [&](double psi, double c) -> std::unique_ptr<Material> {
      if (law == 0) return std::make_unique<DruckerPrager>(drucker_prager_parameters(2000, 1e7, 0.3, 30, psi, c));
      return std::make_unique<MohrCoulomb>(mohr_coulomb_parameters(2000, 1e7, 0.3, 30, psi, c));
    };
    const Dissipation associated = sweep(*make(30, 0), 1), nonassociated = sweep(*make(0, 0), 2),
                      cohesive = sweep(*make(30, 1e4), 3);
    INFO((law == 0 ? "Drucker-Prager" : "Mohr-Coulomb")
         << ": associated c = 0: d / (|sigma| |d_eps_p|) in [" << associated.min_ratio << ", " << associated.max_ratio
         << "] over " << associated.plastic << " plastic steps; psi = 0: [" << nonassociated.min_ratio << ", "
         << nonassociated.max_ratio << "]; associated c > 0: [" << cohesive.min_ratio << ", " << cohesive.max_ratio
         << "]");
    REQUIRE(associated.plastic > 1000);
    REQUIRE(nonassociated.plastic > 1000);
    // Zero to round-off (the stress is on the surface to ~1e-12 relative).
    CHECK(std::abs(associated.min_ratio) < 1e-9);
    CHECK(std::abs(associated.max_ratio) < 1e-9);
    // psi = 0: never negative, and bounded away from zero on the cone.
    CHECK(nonassociated.min_ratio >= -1e-9);
    CHECK(nonassociated.max_ratio > 0.1);
    // Cohesion dissipates under associated flow too: d = dgamma xi c > 0.
    CHECK(cohesive.min_ratio >= -1e-9);
    CHECK(cohesive.max_ratio > 0.01);
  }
}
