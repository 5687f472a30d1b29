// Drucker-Prager return mapping: admissibility, flow direction (the plastic
// potential, not the yield function), zero dilatancy, the apex for psi = 0
// beyond the apex, elastic states untouched, and the consistent tangent
// against central finite differences in every branch.
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "talus/materials/drucker_prager.hpp"

using namespace talus;

namespace {

const Voigt unit = (Voigt() << 1, 1, 1, 0, 0, 0).finished();

DruckerPrager make(double phi_deg, double psi_deg, double cohesion, double hardening = 0.0) {
  return DruckerPrager(drucker_prager_parameters(2000, 1e7, 0.3, phi_deg, psi_deg, cohesion, hardening));
}

MaterialPointUpdate update(const DruckerPrager& m, const Voigt& sigma0, const Voigt& de, double* alpha = nullptr) {
  MaterialPointUpdate out;
  double a0 = 0.0, a1 = 0.0;
  m.update(sigma0, de, &a0, &a1, out);
  if (alpha) *alpha = a1;
  return out;
}

Voigt random_voigt(std::mt19937& rng, double scale) {
  std::normal_distribution<double> d(0.0, scale);
  Voigt v;
  for (int i = 0; i < 6; ++i) v[i] = d(rng);
  return v;
}

// Which branch a converged return used.
enum class Branch { elastic, cone, apex };
Branch branch_of(const MaterialPointUpdate& u) {
  if (u.plastic_strain_increment.norm() == 0.0) return Branch::elastic;
  const Voigt s = u.stress - mean_stress(u.stress) * unit;
  return s.norm() < 1e-9 * std::abs(mean_stress(u.stress)) + 1e-12 ? Branch::apex : Branch::cone;
}

// Central differences of the return map with respect to the strain increment
// and to the rotated stress, against the returned tangent and sensitivity.
void check_tangent(const DruckerPrager& m, const Voigt& sigma0, const Voigt& de) {
  const MaterialPointUpdate u = update(m, sigma0, de);
  const double h = 1e-7 * de.norm();
  Tangent fd_strain, fd_stress;
  for (int j = 0; j < 6; ++j) {
    Voigt e = Voigt::Zero();
    e[j] = h;
    fd_strain.col(j) = (update(m, sigma0, de + e).stress - update(m, sigma0, de - e).stress) / (2 * h);
    const double hs = 1e-7 * (sigma0.norm() + 1e3);
    Voigt t = Voigt::Zero();
    t[j] = hs;
    fd_stress.col(j) = (update(m, sigma0 + t, de).stress - update(m, sigma0 - t, de).stress) / (2 * hs);
  }
  const double scale_strain = m.elastic_stiffness().norm();
  INFO("tangent:\n" << u.tangent << "\nfinite differences:\n" << fd_strain);
  // Central differences: O(h^2) truncation + 1e-16 |sigma| / h round-off ~ 1e-8 relative.
  CHECK((u.tangent - fd_strain).norm() <= 1e-6 * scale_strain);
  CHECK((u.trial_sensitivity - fd_stress).norm() <= 1e-6);
}

}  // namespace

TEST_CASE("Drucker-Prager: elastic trial states are returned unchanged", "[plasticity]") {
  const DruckerPrager m = make(30, 10, 1e4);
  const Voigt sigma0 = (Voigt() << -5e4, -6e4, -5e4, 1e3, 0, 2e3).finished();
  const Voigt de = (Voigt() << -1e-5, 0, 0, 0, 0, 1e-5).finished();
  const MaterialPointUpdate u = update(m, sigma0, de);
  CHECK((u.stress - (sigma0 + m.elastic_stiffness() * de)).norm() == 0.0);
  CHECK(u.plastic_strain_increment.norm() == 0.0);
  CHECK((u.tangent - m.elastic_stiffness()).norm() == 0.0);
}

TEST_CASE("Drucker-Prager: returned stress is admissible and on the surface", "[plasticity]") {
  std::mt19937 rng(3);
  int counts[3] = {0, 0, 0};
  for (double psi : {0.0, 15.0, 35.0})
    for (double H : {0.0, 2e5, -2e5})
      for (int trial = 0; trial < 300; ++trial) {
        const DruckerPrager m = make(35, psi, 2e4, H);
        const Voigt sigma0 = -3e4 * unit + random_voigt(rng, 1e4);
        const Voigt de = random_voigt(rng, 2e-3);
        double alpha = 0;
        const MaterialPointUpdate u = update(m, sigma0, de, &alpha);
        const Branch b = branch_of(u);
        ++counts[static_cast<int>(b)];
        const double f = m.yield_function(u.stress, alpha);
        const double scale = u.stress.norm() + 2e4;
        CHECK(f <= 1e-10 * scale);
        if (b != Branch::elastic) CHECK(std::abs(f) <= 1e-10 * scale);  // on the yield surface
        CHECK(alpha >= 0.0);
      }
  INFO("elastic " << counts[0] << ", cone " << counts[1] << ", apex " << counts[2]);
  CHECK(counts[1] > 100);  // every branch was hit
  CHECK(counts[2] > 10);
  CHECK(counts[0] > 10);
}

TEST_CASE("Drucker-Prager: plastic flow follows the potential g, not f", "[plasticity]") {
  std::mt19937 rng(5);
  for (double psi : {0.0, 10.0, 30.0}) {
    const DruckerPrager m = make(30, psi, 1e4);
    int tested = 0;
    for (int trial = 0; trial < 200; ++trial) {
      const Voigt sigma0 = -5e4 * unit + random_voigt(rng, 2e4);
      const Voigt de = random_voigt(rng, 3e-3);
      const MaterialPointUpdate u = update(m, sigma0, de);
      if (branch_of(u) != Branch::cone) continue;
      ++tested;
      const double p = mean_stress(u.stress);
      const Voigt s = u.stress - p * unit;
      const double sqrt_j2 = std::sqrt(0.5 * (s.head<3>().squaredNorm() + 2 * s.tail<3>().squaredNorm()));
      // dg/dsigma as a strain-like vector: s / (2 sqrt(J2)) + eta_bar / 3 I (shears doubled).
      Voigt dg = s / (2 * sqrt_j2) + m.eta_bar() / 3 * unit;
      dg.tail<3>() *= 2.0;
      const Voigt ep = u.plastic_strain_increment;
      const double lambda = ep.dot(dg) / dg.dot(dg);
      CHECK((ep - lambda * dg).norm() <= 1e-8 * ep.norm());
      CHECK(lambda > 0.0);
      // Volumetric part: eta_bar * dgamma; zero for psi = 0.
      if (psi == 0.0) CHECK(std::abs(ep.head<3>().sum()) <= 1e-12 * ep.norm());
      // With psi != phi the flow is NOT along df/dsigma.
      if (psi < 30.0) {
        Voigt df = s / (2 * sqrt_j2) + m.eta() / 3 * unit;
        df.tail<3>() *= 2.0;
        const double mu = ep.dot(df) / df.dot(df);
        CHECK((ep - mu * df).norm() > 1e-3 * ep.norm());
      }
    }
    CHECK(tested > 20);
  }
}

TEST_CASE("Drucker-Prager with psi = 0: hydrostatic tension far beyond the apex returns to the apex", "[plasticity]") {
  // The classical apex return (de Souza Neto Box 8.9) has no solution here.
  const DruckerPrager m = make(30, 0, 1e4);
  const Voigt de = 1e-2 * unit;  // 1 % volumetric stretch: p_trial = K * 3e-2 = 2.5e5 Pa >> apex
  const MaterialPointUpdate u = update(m, Voigt::Zero(), de);
  REQUIRE(u.stress.allFinite());
  const double apex = m.xi() * 1e4 / m.eta();
  CHECK(mean_stress(u.stress) == Approx(apex).epsilon(1e-12));
  CHECK((u.stress - mean_stress(u.stress) * unit).norm() == Approx(0.0).margin(1e-9));
  CHECK(m.yield_function(u.stress, 0.0) <= 1e-9 * apex);
  // All the stretch beyond the apex pressure is plastic (volumetric opening).
  CHECK(u.plastic_strain_increment.head<3>().sum() ==
        Approx(3e-2 - apex / m.bulk_modulus()).epsilon(1e-12));
  // ... and all of it is separation: a void, not dilatancy of the solid.
  CHECK(u.separation_strain_increment == Approx(3e-2 - apex / m.bulk_modulus()).epsilon(1e-12));
}

TEST_CASE("Drucker-Prager: cone and apex regions partition the trial states", "[plasticity]") {
  // With H = 0 the apex is used iff p_tr - xi c / eta >= K eta_bar sqrt(J2_tr) / G.
  std::mt19937 rng(9);
  for (double psi : {0.0, 20.0, 35.0}) {
    const DruckerPrager m = make(35, psi, 1e4);
    for (int trial = 0; trial < 500; ++trial) {
      const Voigt trial_stress = 2e4 * unit + random_voigt(rng, 3e4);
      const MaterialPointUpdate u = update(m, trial_stress, Voigt::Zero());
      const double p_tr = mean_stress(trial_stress);
      const Voigt s = trial_stress - p_tr * unit;
      const double sqrt_j2 = std::sqrt(0.5 * (s.head<3>().squaredNorm() + 2 * s.tail<3>().squaredNorm()));
      const double margin = p_tr - m.xi() * 1e4 / m.eta() - m.bulk_modulus() * m.eta_bar() * sqrt_j2 / m.shear_modulus();
      if (std::abs(margin) < 1e-6 * (std::abs(p_tr) + sqrt_j2) || branch_of(u) == Branch::elastic) continue;
      CHECK((branch_of(u) == Branch::apex) == (margin > 0));
      // Only the apex separates; on the cone the volume change is dilatancy.
      if (branch_of(u) == Branch::cone) CHECK(u.separation_strain_increment == 0.0);
      if (branch_of(u) == Branch::apex) {
        // tr d_eps_p - sqrt(2) eta_bar |dev d_eps_p|: the opening beyond the flow rule's dilatancy.
        const Voigt& e = u.plastic_strain_increment;
        const double tr = e.head<3>().sum();
        Voigt dev = e;
        dev.head<3>().array() -= tr / 3.0;
        const double dev_norm = std::sqrt(dev.head<3>().squaredNorm() + 0.5 * dev.tail<3>().squaredNorm());
        CHECK(u.separation_strain_increment ==
              Approx(tr - std::sqrt(2.0) * m.eta_bar() * dev_norm).epsilon(1e-9).margin(1e-15));
        CHECK(u.separation_strain_increment >= 0.0);
      }
    }
  }
}

TEST_CASE("Drucker-Prager: consistent tangent equals finite differences in every branch", "[plasticity]") {
  std::mt19937 rng(13);
  for (double psi : {0.0, 12.0, 30.0})
    for (double H : {0.0, 3e5}) {
      const DruckerPrager m = make(30, psi, 1e4, H);
      int branches[3] = {0, 0, 0};
      for (int trial = 0; trial < 60; ++trial) {
        const Voigt sigma0 = (trial % 3 == 0 ? 2e4 : -4e4) * unit + random_voigt(rng, 1.5e4);
        const Voigt de = random_voigt(rng, 2e-3) + (trial % 3 == 0 ? 2e-3 : 0.0) * unit;
        const MaterialPointUpdate u = update(m, sigma0, de);
        const Branch b = branch_of(u);
        ++branches[static_cast<int>(b)];
        // Skip states within the finite-difference step of a branch boundary.
        bool stable = true;
        for (double s : {-1.0, 1.0})
          stable &= branch_of(update(m, sigma0, de * (1 + s * 1e-5))) == b;
        if (stable) check_tangent(m, sigma0, de);
      }
      CHECK(branches[1] > 5);
      CHECK(branches[2] > 2);
    }
}

TEST_CASE("Drucker-Prager: the tangent is non-symmetric exactly when psi != phi", "[plasticity]") {
  // A shear-dominated trial state on the smooth part of the cone. With
  // engineering shear strains the Voigt matrices of the elastic and of the
  // associated tangent are symmetric; the nonassociated one is not.
  const Voigt sigma0 = (Voigt() << -2e4, -3e4, -2.5e4, 1e4, -5e3, 2e4).finished();
  const Voigt de = (Voigt() << -1e-3, 2e-3, 0, 1e-3, 0, 2e-3).finished();
  const MaterialPointUpdate assoc = update(make(30, 30, 1e4), sigma0, de);
  const MaterialPointUpdate nonassoc = update(make(30, 0, 1e4), sigma0, de);
  REQUIRE(branch_of(assoc) == Branch::cone);
  REQUIRE(branch_of(nonassoc) == Branch::cone);
  CHECK((assoc.tangent - assoc.tangent.transpose()).norm() <= 1e-9 * assoc.tangent.norm());
  CHECK((nonassoc.tangent - nonassoc.tangent.transpose()).norm() > 1e-3 * nonassoc.tangent.norm());
}

TEST_CASE("Drucker-Prager: softening stops at zero cohesion", "[plasticity]") {
  // H = -1e6 Pa: c reaches 0 after alpha = 0.01; a large shear step must end on
  // the c = 0 cone (f(sigma, alpha) with c clamped at 0), never with c < 0.
  const DruckerPrager m = make(30, 0, 1e4, -1e6);
  const Voigt sigma0 = -2e4 * unit;
  const Voigt de = (Voigt() << 0, 0, 0, 0, 0, 5e-2).finished();
  double alpha = 0;
  const MaterialPointUpdate u = update(m, sigma0, de, &alpha);
  CHECK(alpha > 0.01);
  const double p = mean_stress(u.stress);
  const Voigt s = u.stress - p * unit;
  const double sqrt_j2 = std::sqrt(0.5 * (s.head<3>().squaredNorm() + 2 * s.tail<3>().squaredNorm()));
  CHECK(sqrt_j2 + m.eta() * p == Approx(0.0).margin(1e-8 * std::abs(p)));  // on the c = 0 cone
}
