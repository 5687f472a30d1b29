// Drucker-Prager return mapping: admissibility, flow direction (the plastic
// potential, not the yield function), zero dilatancy, the apex for psi = 0
// beyond the apex, elastic states untouched, and the consistent tangent
// against central finite differences in every branch. Then the tension
// cut-off: admissibility and the flow rule (KKT) of every return, the plane,
// corner and tip branches on designed states, the partition of the trial
// space, tangents, identity with the law without cut-off, and the case file.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <yaml-cpp/yaml.h>

#include "talus/io/yaml_section.hpp"
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
// Returns the larger of the two relative errors.
double check_tangent(const DruckerPrager& m, const Voigt& sigma0, const Voigt& de) {
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
  const double error_strain = (u.tangent - fd_strain).norm() / scale_strain;
  const double error_stress = (u.trial_sensitivity - fd_stress).norm();
  CHECK(error_strain <= 1e-6);
  CHECK(error_stress <= 1e-6);
  return std::max(error_strain, error_stress);
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

// ---------------------------------------------------------------------------
// Tension cut-off p <= p_t (docs/plasticity.md, "Tension cut-off").

namespace {

DruckerPrager make_cutoff(double phi_deg, double psi_deg, double cohesion, double hardening, double p_t) {
  DruckerPragerParameters par = drucker_prager_parameters(2000, 1e7, 0.3, phi_deg, psi_deg, cohesion, hardening);
  par.tension_cutoff = p_t;
  return DruckerPrager(par);
}

double apex_of(const DruckerPrager& m, double cohesion) { return m.xi() * cohesion / m.eta(); }

double sqrt_j2_of(const Voigt& sigma) {
  const Voigt s = sigma - mean_stress(sigma) * unit;
  return std::sqrt(0.5 * (s.head<3>().squaredNorm() + 2 * s.tail<3>().squaredNorm()));
}

// The branch a return took, read from its result: the stress (on the cut-off
// or below it, on the hydrostatic axis or not) and whether alpha grew.
enum class Cut { elastic, cone, plane, corner, apex, tip };
const char* const cut_names[] = {"elastic", "cone", "plane", "corner", "apex", "tip"};

Cut cut_branch(const DruckerPrager& m, const MaterialPointUpdate& u, double alpha_old, double alpha_new) {
  if (u.plastic_strain_increment.norm() == 0.0) return Cut::elastic;
  const double p = mean_stress(u.stress), q = sqrt_j2_of(u.stress), p_t = m.tension_cutoff();
  const bool at_cutoff = std::abs(p - p_t) <= 1e-10 * (std::abs(p) + q + std::abs(p_t)) + 1e-9;
  const bool on_axis = q <= 1e-9 * std::abs(p) + 1e-9;
  if (!at_cutoff) return on_axis ? Cut::apex : Cut::cone;
  if (alpha_new == alpha_old) return Cut::plane;
  return on_axis ? Cut::tip : Cut::corner;
}

struct Step {
  MaterialPointUpdate u;
  double alpha_old, alpha_new;
  Cut branch;
};

Step step(const DruckerPrager& m, const Voigt& sigma0, const Voigt& de, double alpha_old = 0.0) {
  Step r;
  r.alpha_old = alpha_old;
  m.update(sigma0, de, &r.alpha_old, &r.alpha_new, r.u);
  r.branch = cut_branch(m, r.u, r.alpha_old, r.alpha_new);
  return r;
}

// A trial-like stress around the cut-off: a deviator of log-uniform size
// (1e2 ... 5e4 Pa) on a mean stress p_t - 5e4 ... p_t + 2e5 Pa, so that the
// small regions (the plane, the tip) are sampled too.
Voigt sample_near_cutoff(std::mt19937& rng, double p_t) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Voigt s = random_voigt(rng, std::pow(10.0, 2.0 + 2.7 * u(rng)));
  s -= mean_stress(s) * unit;
  return (p_t - 5e4 + 2.5e5 * u(rng)) * unit + s;
}

// Tensor norm of the deviator of an engineering-shear strain.
double dev_norm(const Voigt& e) {
  Voigt d = e;
  d.head<3>().array() -= e.head<3>().sum() / 3.0;
  return std::sqrt(d.head<3>().squaredNorm() + 0.5 * d.tail<3>().squaredNorm());
}

// The region of the trial space each branch owns, from the closed forms of
// docs/plasticity.md in the trial invariants (independent of the return
// code): d = p_tr - p_t, m = f at (p_t, sqrt(J2_tr)), e = apex - p_t,
// V = (eta - eta_bar) sqrt(J2_tr) + G d / K, Q* = -G eta e / (xi^2 H).
// `slack` gets the smallest relative distance to any of the boundaries.
std::vector<Cut> regions(const DruckerPrager& m, const Voigt& trial, double cohesion, double H, double& slack) {
  const double G = m.shear_modulus(), K = m.bulk_modulus(), eta = m.eta(), eb = m.eta_bar(), xi = m.xi();
  const double p_t = m.tension_cutoff();
  const double B = G + xi * xi * H, A = B + K * eta * eb;
  const double q = sqrt_j2_of(trial), d = mean_stress(trial) - p_t, e = apex_of(m, cohesion) - p_t;
  const double mm = q - eta * e, f = mm + eta * d, V = (eta - eb) * q + G * d / K;
  const double sc = std::abs(mean_stress(trial)) + q + std::abs(p_t) + xi * cohesion;
  const double c_cone_q = q * A - G * f, c_cut = d * B - K * eb * mm, c_corner_q = xi * xi * H * q + G * eta * e,
               c_apex_p = G * eta * eta * e + xi * xi * H * V;
  const double Qs = H != 0.0 ? -G * eta * e / (xi * xi * H) : -1.0;
  slack = std::min({std::abs(f), std::abs(d), std::abs(mm), std::abs(c_cone_q) / A, std::abs(c_cut) / B,
                    std::abs(c_corner_q) / G, std::abs(c_apex_p) / (G * eta * eta),
                    H != 0.0 ? std::abs(q - Qs) : sc, H != 0.0 ? std::abs(V - eta * Qs) : sc}) /
          sc;
  std::vector<Cut> r;
  if (f <= 0 && d <= 0) r.push_back(Cut::elastic);
  if (f > 0 && c_cone_q >= 0 && c_cut <= 0) r.push_back(Cut::cone);
  if (d > 0 && mm <= 0) r.push_back(Cut::plane);
  if (mm > 0 && c_cut >= 0 && c_corner_q >= 0) r.push_back(Cut::corner);
  if (c_cone_q <= 0 && c_apex_p <= 0) r.push_back(Cut::apex);
  if (H != 0.0 && Qs >= 0 && q <= Qs && V >= eta * Qs) r.push_back(Cut::tip);
  return r;
}

}  // namespace

TEST_CASE("Drucker-Prager tension cut-off: every return is admissible and satisfies the flow rule",
          "[plasticity][cutoff]") {
  // Admissibility f <= 0, p <= p_t, and the KKT conditions of the two-surface
  // law read from the result: dgamma = d alpha / xi >= 0 (cone), the cut-off
  // multiplier dlambda = tr d_eps_p - eta_bar dgamma >= 0 off the axis,
  // dev d_eps_p = dgamma n / sqrt2, complementarity, and the separation.
  std::mt19937 rng(31);
  int counts[6] = {0, 0, 0, 0, 0, 0};
  double max_f = 0.0, max_excess = -1.0;
  // (c0, p_t / apex, p_t): the cut-off at zero, below and above the apex, and
  // a cohesionless material with its apex on the cut-off (p_t = 0) or below it.
  const double cases[5][3] = {{2e4, 0.0, 0.0}, {2e4, 0.4, 0.0}, {2e4, 1.5, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 5e3}};
  for (double psi : {0.0, 35.0})
    for (double H : {0.0, 3e5, -2e5})
      for (const auto& cs : cases) {
        const double c0 = cs[0];
        const double p_t = cs[1] * apex_of(make(35, psi, c0), c0) + cs[2];
        const DruckerPrager m = make_cutoff(35, psi, c0, H, p_t);
        int local[6] = {0, 0, 0, 0, 0, 0};
        for (int trial = 0; trial < 400; ++trial) {
          const Voigt sigma0 = trial % 2 ? Voigt(-2e4 * unit + random_voigt(rng, 1.5e4)) : sample_near_cutoff(rng, p_t);
          const Voigt de = trial % 2 ? Voigt(random_voigt(rng, 2e-3) + (trial % 3 == 0 ? 4e-3 : 0.0) * unit)
                                     : Voigt(random_voigt(rng, 1e-5));
          const double alpha0 = (trial % 4) * 2e-3;
          const Step r = step(m, sigma0, de, alpha0);
          ++counts[static_cast<int>(r.branch)];
          ++local[static_cast<int>(r.branch)];
          const MaterialPointUpdate& u = r.u;
          const double p = mean_stress(u.stress), q = sqrt_j2_of(u.stress);
          const double scale = (sigma0 + m.elastic_stiffness() * de).norm() + c0;  // of the trial state
          const double f = m.yield_function(u.stress, r.alpha_new);
          const bool cone_active = r.branch != Cut::elastic && r.branch != Cut::plane;
          max_f = std::max(max_f, (cone_active ? std::abs(f) : f) / scale);
          max_excess = std::max(max_excess, (p - p_t) / scale);
          CHECK(f <= 1e-10 * scale);
          CHECK(p - p_t <= 1e-12 * scale);
          if (r.branch == Cut::elastic) continue;
          const Voigt& ep = u.plastic_strain_increment;
          const double tol = 1e-9 * ep.norm();
          const double dgamma = (r.alpha_new - r.alpha_old) / m.xi();
          const double tr = ep.head<3>().sum();
          CHECK(dgamma >= 0.0);
          if (dgamma > tol) CHECK(std::abs(f) <= 1e-10 * scale);  // the cone is active
          if (q > 1e-6 * scale) {
            Voigt n = (u.stress - p * unit) / (std::sqrt(2.0) * q);
            n.tail<3>() *= 2.0;  // strain-like
            Voigt ep_dev = ep;
            ep_dev.head<3>().array() -= tr / 3.0;
            CHECK((ep_dev - dgamma * n / std::sqrt(2.0)).norm() <= tol);
            const double dlambda = tr - m.eta_bar() * dgamma;
            CHECK(dlambda >= -tol);
            if (dlambda > tol) CHECK(std::abs(p - p_t) <= 1e-12 * scale);  // the cut-off is active
            CHECK(u.separation_strain_increment ==
                  Approx(r.branch == Cut::cone ? 0.0 : dlambda).margin(tol));
          } else {
            // On the axis (apex, tip, or the plane with a hydrostatic trial):
            // the modified strain lies in the normal cone of the apex plus
            // a cut-off part: sqrt2 |dev| <= dgamma (the plane: dgamma = 0).
            CHECK(std::sqrt(2.0) * dev_norm(ep) <= dgamma + tol);
            const double dlambda = tr + (m.eta() - m.eta_bar()) * std::sqrt(2.0) * dev_norm(ep) - m.eta() * dgamma;
            CHECK(dlambda >= -tol);
            if (dlambda > tol) CHECK(std::abs(p - p_t) <= 1e-12 * scale);
          }
        }
        INFO("psi " << psi << " H " << H << " p_t " << p_t);
        CHECK(local[static_cast<int>(Cut::cone)] > 20);
      }
  std::string tally;
  for (int b = 0; b < 6; ++b) tally += std::string(cut_names[b]) + " " + std::to_string(counts[b]) + ", ";
  INFO(tally);
  std::ostringstream worst;
  worst << "max f / scale (|f| where the cone is active) " << max_f << ", max (p - p_t) / scale " << max_excess;
  INFO(worst.str());
  CHECK(max_f <= 1e-10);
  CHECK(max_excess <= 1e-12);
  for (int b = 0; b < 6; ++b) CHECK(counts[b] > 20);  // every branch, the tip included
}

TEST_CASE("Drucker-Prager tension cut-off: hydrostatic tension far beyond returns to p_t as a void",
          "[plasticity][cutoff]") {
  for (double psi : {0.0, 30.0}) {
    const double c0 = 1e4;
    const double p_t = 0.5 * apex_of(make(30, psi, c0), c0);
    const DruckerPrager m = make_cutoff(30, psi, c0, 0.0, p_t);
    const Voigt de = 1e-2 * unit;  // p_trial = 3e-2 K = 2.5e5 Pa >> p_t
    const Step r = step(m, Voigt::Zero(), de);
    CHECK(r.branch == Cut::plane);
    CHECK(mean_stress(r.u.stress) == Approx(p_t).epsilon(1e-14));
    CHECK((r.u.stress - mean_stress(r.u.stress) * unit).norm() <= 1e-12 * p_t);
    CHECK(r.alpha_new == 0.0);
    const double opening = 3e-2 - p_t / m.bulk_modulus();  // all the stretch beyond p_t
    CHECK(r.u.plastic_strain_increment.head<3>().sum() == Approx(opening).epsilon(1e-12));
    CHECK(dev_norm(r.u.plastic_strain_increment) <= 1e-15);
    CHECK(r.u.separation_strain_increment == Approx(opening).epsilon(1e-12));
  }
}

TEST_CASE("Drucker-Prager tension cut-off: designed states hit the plane, corner, apex and tip branches",
          "[plasticity][cutoff]") {
  const double c0 = 1e4;
  SECTION("plane: a small trial deviator is kept exactly") {
    const DruckerPrager m = make_cutoff(30, 10, c0, 0.0, 5e3);
    const Voigt sigma0 = (Voigt() << 1e3, -2e3, 0, 1.5e3, -500, 800).finished();
    const Voigt de = 1e-3 * unit;
    const Voigt trial = sigma0 + m.elastic_stiffness() * de;
    const Step r = step(m, sigma0, de);
    REQUIRE(r.branch == Cut::plane);
    // Shear components untouched bit for bit; the normal ones all move by p_t - p_tr.
    CHECK(r.u.stress.tail<3>() == trial.tail<3>());
    const double shift = 5e3 - mean_stress(trial);
    for (int i = 0; i < 3; ++i) CHECK(r.u.stress[i] - trial[i] == Approx(shift).epsilon(1e-13));
    CHECK(r.u.plastic_strain_increment.head<3>().sum() == Approx(-shift / m.bulk_modulus()).epsilon(1e-12));
    CHECK(r.u.separation_strain_increment == Approx(-shift / m.bulk_modulus()).epsilon(1e-12));
    CHECK(m.yield_function(r.u.stress, 0.0) < 0.0);  // strictly inside the cone
  }
  SECTION("corner: p = p_t on the cone, with the closed-form multipliers") {
    for (double H : {0.0, 3e5, -2e5}) {
      const double apex = apex_of(make(30, 10, c0), c0), p_t = 0.3 * apex;
      const DruckerPrager m = make_cutoff(30, 10, c0, H, p_t);
      const Voigt trial = (p_t + 5e4) * unit + (Voigt() << 3e4, -1e4, -2e4, 1e4, 0, 2e4).finished();
      const Step r = step(m, trial, Voigt::Zero());
      REQUIRE(r.branch == Cut::corner);
      const double G = m.shear_modulus(), K = m.bulk_modulus(), xi = m.xi();
      const double q_tr = sqrt_j2_of(trial), mm = q_tr + m.eta() * p_t - xi * c0;
      const double dgamma = mm / (G + xi * xi * H);
      CHECK(mean_stress(r.u.stress) == Approx(p_t).epsilon(1e-12));
      CHECK(r.alpha_new == Approx(xi * dgamma).epsilon(1e-12));
      CHECK(sqrt_j2_of(r.u.stress) == Approx(q_tr - G * dgamma).epsilon(1e-12));
      CHECK(m.yield_function(r.u.stress, r.alpha_new) == Approx(0.0).margin(1e-10 * q_tr));
      // The cut-off's multiplier is the separation.
      const double dlambda = (mean_stress(trial) - p_t) / K - m.eta_bar() * dgamma;
      CHECK(dlambda > 0.0);
      CHECK(r.u.separation_strain_increment == Approx(dlambda).epsilon(1e-10));
      // Symmetric although psi != phi: eta_bar does not enter the corner.
      CHECK((r.u.tangent - r.u.tangent.transpose()).norm() <= 1e-9 * r.u.tangent.norm());
    }
  }
  SECTION("apex below the cut-off: the law without cut-off, bit for bit") {
    const double apex = apex_of(make(30, 0, c0), c0);
    const DruckerPrager with = make_cutoff(30, 0, c0, 0.0, 2 * apex), without = make(30, 0, c0);
    const Step r = step(with, Voigt::Zero(), 1e-2 * unit), s = step(without, Voigt::Zero(), 1e-2 * unit);
    CHECK(r.branch == Cut::apex);
    CHECK(r.u.stress == s.u.stress);
    CHECK(r.u.separation_strain_increment == s.u.separation_strain_increment);
  }
  SECTION("tip: hardening lifts the apex to the cut-off and stops there") {
    // H = 3e5, p_t = 1.5 apex: from a hydrostatic trial the apex return alone
    // would harden past p_t once d = p_tr - p_t exceeds K eta^2 (p_t - apex) /
    // (xi^2 H) (about 8e4 Pa here); below that the apex branch holds.
    const double H = 3e5;
    const double apex = apex_of(make(30, 0, c0), c0), p_t = 1.5 * apex;
    const DruckerPrager m = make_cutoff(30, 0, c0, H, p_t);
    const double threshold = m.bulk_modulus() * m.eta() * m.eta() * (p_t - apex) / (m.xi() * m.xi() * H);
    const Step tip = step(m, Voigt::Zero(), (p_t + 2 * threshold) / (3 * m.bulk_modulus()) * unit);
    CHECK(tip.branch == Cut::tip);
    CHECK((tip.u.stress - p_t * unit).norm() <= 1e-12 * p_t);
    CHECK(apex_of(m, c0 + H * tip.alpha_new) == Approx(p_t).epsilon(1e-12));  // the apex sits on the cut-off
    CHECK(tip.u.tangent.norm() == 0.0);
    const Step below = step(m, Voigt::Zero(), (p_t + 0.5 * threshold) / (3 * m.bulk_modulus()) * unit);
    CHECK(below.branch == Cut::apex);
    CHECK(mean_stress(below.u.stress) < p_t);
    CHECK(apex_of(m, c0 + H * below.alpha_new) == Approx(mean_stress(below.u.stress)).epsilon(1e-12));
  }
}

TEST_CASE("Drucker-Prager tension cut-off: the branch taken is the region of the trial state", "[plasticity][cutoff]") {
  // regions() evaluates the closed-form region inequalities. Without
  // softening exactly one holds (a partition, psi = 0 included); with
  // softening and the apex above the cut-off several may (the local problem
  // is not unique) and talus takes the first of cone, plane, corner, apex,
  // tip: the least softening.
  std::mt19937 rng(37);
  const double c0 = 1e4;
  int counts[6] = {0, 0, 0, 0, 0, 0}, tested = 0, overlaps = 0;
  for (double psi : {0.0, 15.0, 30.0})
    for (double H : {0.0, 3e5, -2e5})
      for (double p_t_factor : {0.5, 1.5}) {
        const double p_t = p_t_factor * apex_of(make(30, psi, c0), c0);
        const DruckerPrager m = make_cutoff(30, psi, c0, H, p_t);
        for (int trial = 0; trial < 600; ++trial) {
          const Voigt trial_stress = sample_near_cutoff(rng, p_t);
          double slack;
          const std::vector<Cut> owners = regions(m, trial_stress, c0, H, slack);
          if (slack < 1e-9) continue;
          const Step r = step(m, trial_stress, Voigt::Zero());
          if (H < 0.0 && c0 + H * r.alpha_new < 0.0) continue;  // softened to c = 0: another cone
          ++tested;
          ++counts[static_cast<int>(r.branch)];
          INFO("psi " << psi << " H " << H << " p_t " << p_t << " taken " << cut_names[static_cast<int>(r.branch)]);
          REQUIRE(!owners.empty());  // no gap
          if (H >= 0.0) CHECK(owners.size() == 1);  // no overlap
          overlaps += owners.size() > 1;
          CHECK(r.branch == owners.front());
        }
      }
  std::string tally;
  for (int b = 0; b < 6; ++b) tally += std::string(cut_names[b]) + " " + std::to_string(counts[b]) + ", ";
  INFO(tally);
  INFO("overlaps (softening only) " << overlaps << " of " << tested);
  CHECK(tested > 8000);
  for (int b = 1; b < 6; ++b) CHECK(counts[b] > 50);
}

TEST_CASE("Drucker-Prager tension cut-off: consistent tangent equals finite differences on the plane and at the corner",
          "[plasticity][cutoff]") {
  std::mt19937 rng(41);
  const double c0 = 1e4;
  double max_error[6] = {0, 0, 0, 0, 0, 0};
  int checked[6] = {0, 0, 0, 0, 0, 0};
  for (double psi : {0.0, 12.0, 30.0})
    for (double H : {0.0, 3e5, -2e5}) {
      const double apex = apex_of(make(30, psi, c0), c0);
      for (double p_t : {0.4 * apex, 1.5 * apex}) {
        const DruckerPrager m = make_cutoff(30, psi, c0, H, p_t);
        for (int trial = 0; trial < 60; ++trial) {
          // A strain increment of finite size (the finite-difference step is
          // relative to it), with the start stress chosen to put the trial
          // state at the sample.
          const Voigt de = random_voigt(rng, 5e-4) + 2e-3 * unit;
          const Voigt sigma0 = sample_near_cutoff(rng, p_t) - m.elastic_stiffness() * de;
          const Step r = step(m, sigma0, de);
          // Skip states within the finite-difference step of a branch boundary.
          bool stable = true;
          for (double s : {-1.0, 1.0}) stable &= step(m, sigma0, de * (1 + s * 1e-5)).branch == r.branch;
          if (!stable || r.branch == Cut::elastic) continue;
          const int b = static_cast<int>(r.branch);
          max_error[b] = std::max(max_error[b], check_tangent(m, sigma0, de));
          ++checked[b];
        }
      }
    }
  std::ostringstream tally;
  for (int b = 1; b < 6; ++b)
    tally << cut_names[b] << ": " << checked[b] << " states, max error " << max_error[b] << "; ";
  INFO(tally.str());
  CHECK(checked[static_cast<int>(Cut::plane)] > 30);
  CHECK(checked[static_cast<int>(Cut::corner)] > 30);
  CHECK(max_error[static_cast<int>(Cut::plane)] <= 1e-6);
  CHECK(max_error[static_cast<int>(Cut::corner)] <= 1e-6);
  CHECK(max_error[static_cast<int>(Cut::cone)] <= 1e-6);
  CHECK(max_error[static_cast<int>(Cut::apex)] <= 1e-6);
  CHECK(max_error[static_cast<int>(Cut::tip)] <= 1e-6);
}

TEST_CASE("Drucker-Prager tension cut-off: far above the apex it changes nothing, bit for bit",
          "[plasticity][cutoff]") {
  // No softening: the apex never rises, so a cut-off at 1e12 Pa is never
  // reached and every output must equal the law without cut-off exactly.
  std::mt19937 rng(43);
  for (double psi : {0.0, 20.0})
    for (double H : {0.0, -2e5}) {
      const DruckerPrager without = make(30, psi, 1e4, H), with = make_cutoff(30, psi, 1e4, H, 1e12);
      CHECK(std::isinf(without.tension_cutoff()));
      for (int trial = 0; trial < 500; ++trial) {
        const Voigt sigma0 = (trial % 3 == 0 ? 2e4 : -3e4) * unit + random_voigt(rng, 2e4);
        const Voigt de = random_voigt(rng, 2e-3) + (trial % 4 == 0 ? 3e-3 : 0.0) * unit;
        const Step a = step(without, sigma0, de, 1e-3), b = step(with, sigma0, de, 1e-3);
        CHECK(a.u.stress == b.u.stress);
        CHECK(a.u.tangent == b.u.tangent);
        CHECK(a.u.trial_sensitivity == b.u.trial_sensitivity);
        CHECK(a.u.plastic_strain_increment == b.u.plastic_strain_increment);
        CHECK(a.u.separation_strain_increment == b.u.separation_strain_increment);
        CHECK(a.alpha_new == b.alpha_new);
      }
    }
}

TEST_CASE("Drucker-Prager tension cut-off: case-file key", "[plasticity][cutoff][config]") {
  const std::string base = "{density: 2000, youngs_modulus: 1.0e7, poisson_ratio: 0.3, friction_angle: 30";
  const auto load = [](const std::string& yaml) {
    YamlSection s(YAML::Load(yaml), "materials[0]", "case.yaml");
    std::unique_ptr<Material> law = make_material("drucker_prager", s);
    s.finish();  // no unknown keys
    return law;
  };
  const std::unique_ptr<Material> none = load(base + "}");
  const std::unique_ptr<Material> some = load(base + ", tension_cutoff: 2.5e3}");
  CHECK(std::isinf(dynamic_cast<const DruckerPrager&>(*none).tension_cutoff()));
  CHECK(dynamic_cast<const DruckerPrager&>(*some).tension_cutoff() == 2.5e3);
  CHECK(dynamic_cast<const DruckerPrager&>(*load(base + ", tension_cutoff: 0}")).tension_cutoff() == 0.0);
  std::string message;
  try {
    load(base + ", tension_cutoff: -1}");
  } catch (const InputError& e) {
    message = e.what();
  }
  INFO(message);
  CHECK(message.find("materials[0].tension_cutoff = -1") != std::string::npos);
  CHECK(message.find("must be >= 0") != std::string::npos);
}
