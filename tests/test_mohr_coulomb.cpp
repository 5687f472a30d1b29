// Mohr-Coulomb return mapping (docs/mohr_coulomb.md): admissibility, elastic
// states untouched, the flow along the potential g (not f), zero plastic
// volume change for psi = 0, the apex for psi = 0 beyond the apex, every
// branch hit by a designed trial state, the branches partitioning the trial
// space (checked against an independent implementation of the closed-form
// candidates of de Souza Neto et al. 2008, Boxes 8.4-8.5), the consistent
// tangent against central finite differences in every branch (also with two
// equal principal stresses), and the case-file keys.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>

#include "talus/core/errors.hpp"
#include "talus/io/yaml_section.hpp"
#include "talus/materials/mohr_coulomb.hpp"

using namespace talus;

namespace {

using Vector3 = Eigen::Vector3d;
using Matrix3 = Eigen::Matrix3d;
using Branch = MohrCoulombBranch;

const Voigt unit = (Voigt() << 1, 1, 1, 0, 0, 0).finished();

MohrCoulomb make(double phi_deg, double psi_deg, double cohesion) {
  return MohrCoulomb(mohr_coulomb_parameters(2000, 1e7, 0.3, phi_deg, psi_deg, cohesion));
}

MaterialPointUpdate update(const MohrCoulomb& m, const Voigt& sigma0, const Voigt& de) {
  MaterialPointUpdate out;
  m.update(sigma0, de, nullptr, nullptr, out);
  return out;
}

Voigt random_voigt(std::mt19937& rng, double scale) {
  std::normal_distribution<double> d(0.0, scale);
  Voigt v;
  for (int i = 0; i < 6; ++i) v[i] = d(rng);
  return v;
}

// Principal values, sorted descending, and their eigenvectors (columns).
struct Principal {
  Vector3 values;
  Matrix3 vectors;
};
Principal principal(const Voigt& s) {
  const Eigen::SelfAdjointEigenSolver<Matrix3> eig(voigt_to_tensor(s));
  return {eig.eigenvalues().reverse(), eig.eigenvectors().rowwise().reverse()};
}

// The branch the return of this trial stress takes.
Branch branch_of(const MohrCoulomb& m, const Voigt& trial) {
  return m.principal_return(principal(trial).values).branch;
}

const char* name(Branch b) {
  switch (b) {
    case Branch::elastic: return "elastic";
    case Branch::plane: return "plane";
    case Branch::edge_12: return "edge s1=s2";
    case Branch::edge_23: return "edge s2=s3";
    case Branch::apex: return "apex";
  }
  return "?";
}

// A stress with principal values `lambda` along the axes of a random rotation.
Voigt rotated(const Vector3& lambda, std::mt19937& rng) {
  std::normal_distribution<double> d(0.0, 1.0);
  Eigen::Quaterniond q(d(rng), d(rng), d(rng), d(rng));
  q.normalize();
  const Matrix3 R = q.toRotationMatrix();
  return tensor_to_voigt(R * lambda.asDiagonal() * R.transpose());
}

// Normal (1 + sin) e_i - (1 - sin) e_j of the plane (s_i - s_j) + (s_i + s_j) sin.
Vector3 normal(int i, int j, double sin_angle) {
  Vector3 n = Vector3::Zero();
  n[i] = 1 + sin_angle;
  n[j] = -(1 - sin_angle);
  return n;
}

// Principal plastic strain of an update, in the trial's eigenbasis (the
// returned stress shares it): V^T eps_p V must be diagonal.
Vector3 principal_plastic_strain(const MaterialPointUpdate& u, const Matrix3& V) {
  Voigt ep = u.plastic_strain_increment;
  ep.tail<3>() *= 0.5;  // engineering -> tensor shear
  const Matrix3 e = V.transpose() * voigt_to_tensor(ep) * V;
  CHECK((e - Matrix3(e.diagonal().asDiagonal())).norm() <= 1e-9 * e.norm() + 1e-18);
  return e.diagonal();
}

// Central differences of the return map with respect to the strain increment
// and to the rotated stress: errors of the tangent (relative to ||C||) and of
// the trial sensitivity.
struct TangentError {
  double strain, stress;
};
TangentError tangent_error(const MohrCoulomb& m, const Voigt& sigma0, const Voigt& de) {
  const MaterialPointUpdate u = update(m, sigma0, de);
  const double h = 1e-7 * std::max(de.norm(), 1e-2);
  const double hs = 1e-7 * (sigma0.norm() + 1e3);
  Tangent fd_strain, fd_stress;
  for (int j = 0; j < 6; ++j) {
    Voigt e = Voigt::Zero();
    e[j] = h;
    fd_strain.col(j) = (update(m, sigma0, de + e).stress - update(m, sigma0, de - e).stress) / (2 * h);
    Voigt t = Voigt::Zero();
    t[j] = hs;
    fd_stress.col(j) = (update(m, sigma0 + t, de).stress - update(m, sigma0 - t, de).stress) / (2 * hs);
  }
  INFO("tangent:\n" << u.tangent << "\nfinite differences:\n" << fd_strain);
  INFO("trial sensitivity:\n" << u.trial_sensitivity << "\nfinite differences:\n" << fd_stress);
  const TangentError err{(u.tangent - fd_strain).norm() / m.elastic_stiffness().norm(),
                         (u.trial_sensitivity - fd_stress).norm()};
  // Central differences: O(h^2) truncation + 1e-16 |sigma| / h round-off ~ 1e-8 relative.
  CHECK(err.strain <= 1e-6);
  CHECK(err.stress <= 1e-6);
  return err;
}

// True when the branch does not change within 100 finite-difference steps in
// any direction of strain or stress (so that the differences see one branch).
bool branch_is_stable(const MohrCoulomb& m, const Voigt& sigma0, const Voigt& de) {
  const Tangent& D = m.elastic_stiffness();
  const Branch b = branch_of(m, sigma0 + D * de);
  const double h = 100 * 1e-7 * std::max(de.norm(), 1e-2), hs = 100 * 1e-7 * (sigma0.norm() + 1e3);
  for (int j = 0; j < 6; ++j)
    for (double s : {-1.0, 1.0}) {
      if (branch_of(m, sigma0 + D * (de + s * h * Voigt::Unit(j))) != b) return false;
      if (branch_of(m, sigma0 + s * hs * Voigt::Unit(j) + D * de) != b) return false;
    }
  return true;
}

}  // namespace

TEST_CASE("mohr_coulomb: elastic trial states are returned unchanged", "[plasticity]") {
  const MohrCoulomb m = make(30, 10, 1e4);
  const Voigt sigma0 = (Voigt() << -5e4, -6e4, -5e4, 1e3, 0, 2e3).finished();
  const Voigt de = (Voigt() << -1e-5, 0, 0, 0, 0, 1e-5).finished();
  const MaterialPointUpdate u = update(m, sigma0, de);
  CHECK(m.yield_function(sigma0 + m.elastic_stiffness() * de) < 0);
  CHECK((u.stress - (sigma0 + m.elastic_stiffness() * de)).norm() == 0.0);
  CHECK(u.plastic_strain_increment.norm() == 0.0);
  CHECK((u.tangent - m.elastic_stiffness()).norm() == 0.0);
  CHECK((u.trial_sensitivity - Tangent::Identity()).norm() == 0.0);
  CHECK(u.separation_strain_increment == 0.0);
}

TEST_CASE("mohr_coulomb: returned stress is admissible and on the surface", "[plasticity]") {
  std::mt19937 rng(3);
  std::map<Branch, int> counts;
  double worst = 0;
  for (double phi : {20.0, 35.0})
    for (double psi : {0.0, 0.5 * phi, phi})
      for (double c : {0.0, 2e4}) {
        const MohrCoulomb m = make(phi, psi, c);
        for (int trial = 0; trial < 250; ++trial) {
          const Voigt sigma0 = (trial % 4 == 0 ? 1e4 : -4e4) * unit + random_voigt(rng, 2e4);
          const Voigt de = random_voigt(rng, 3e-3);
          const MaterialPointUpdate u = update(m, sigma0, de);
          const Branch b = branch_of(m, sigma0 + m.elastic_stiffness() * de);
          ++counts[b];
          REQUIRE(u.stress.allFinite());
          const double f = m.yield_function(u.stress);
          const double scale = u.stress.norm() + c;
          worst = std::max(worst, (b == Branch::elastic ? f : std::abs(f)) / scale);
          CHECK(f <= 1e-10 * scale);
          if (b != Branch::elastic) CHECK(std::abs(f) <= 1e-10 * scale);  // on the yield surface
          if (b != Branch::apex) CHECK(u.separation_strain_increment == 0.0);
          CHECK(u.separation_strain_increment >= 0.0);
        }
      }
  std::printf("Mohr-Coulomb admissibility: max |f| / scale after return %.2e; elastic %d, plane %d, edge s1=s2 %d, "
              "edge s2=s3 %d, apex %d\n",
              worst, counts[Branch::elastic], counts[Branch::plane], counts[Branch::edge_12], counts[Branch::edge_23],
              counts[Branch::apex]);
  for (Branch b : {Branch::elastic, Branch::plane, Branch::edge_12, Branch::edge_23, Branch::apex}) {
    INFO(name(b));
    CHECK(counts[b] > 20);  // every branch was hit
  }
}

TEST_CASE("mohr_coulomb: plane-strain states (closed-form principal axes) return as the general solver does",
          "[plasticity]") {
  // Every 2D particle has sigma_xz = sigma_yz = 0, and the return then takes
  // its principal axes in closed form (half-angle formulas, no trigonometry).
  // Expected: the principal return of the values from Eigen's solver, mapped
  // back with its eigenvectors. Orientations sweep the whole half turn,
  // including the ends where cos 2 theta = -1 (b = 0, sigma_xx < sigma_yy),
  // b -> 0 on that side, and an isotropic in-plane state (r = 0).
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> angle(-M_PI / 2, M_PI / 2);
  std::normal_distribution<double> d(0.0, 3e4);
  double worst = 0.0;
  int plastic = 0;
  for (double psi : {0.0, 15.0, 30.0}) {
    const MohrCoulomb m = make(30.0, psi, 5e3);
    for (int trial = 0; trial < 400; ++trial) {
      // In-plane principal values s1, s2 along angle t, and sigma_zz.
      const double s1 = -4e4 + d(rng), s2 = -4e4 + d(rng), szz = -4e4 + d(rng);
      double t = angle(rng);
      if (trial % 8 == 0) t = M_PI / 2;                 // b = 0, rotated by 90 degrees
      if (trial % 8 == 1) t = M_PI / 2 - 1e-9;          // b -> 0 on that side
      if (trial % 8 == 2) t = 0.0;                      // b = 0
      const double c = std::cos(t), s = std::sin(t);
      Voigt trial_stress;
      trial_stress << s1 * c * c + s2 * s * s, s1 * s * s + s2 * c * c, szz, 0.0, 0.0, (s1 - s2) * c * s;
      if (trial % 8 == 3) trial_stress << s1, s1, szz, 0.0, 0.0, 0.0;  // r = 0
      const MaterialPointUpdate u = update(m, trial_stress, Voigt::Zero());
      const Principal p = principal(trial_stress);
      const MohrCoulombPrincipalReturn ret = m.principal_return(p.values);
      const Voigt expected = tensor_to_voigt(p.vectors * ret.stress.asDiagonal() * p.vectors.transpose());
      plastic += ret.branch != Branch::elastic;
      const double error = (u.stress - expected).norm() / trial_stress.norm();
      worst = std::max(worst, error);
      INFO("trial " << trial << " psi " << psi << " branch " << name(ret.branch));
      CHECK(error <= 1e-12);
      CHECK(u.stress[3] == 0.0);
      CHECK(u.stress[4] == 0.0);
    }
  }
  std::printf("Mohr-Coulomb plane strain: closed-form axes against Eigen's, worst relative stress difference %.2e "
              "(%d plastic of 1200)\n",
              worst, plastic);
  CHECK(plastic > 300);         // both elastic and plastic states are compared
  CHECK(plastic < 1200 - 300);
}

TEST_CASE("mohr_coulomb: psi = 0, hydrostatic tension far beyond the apex returns to the apex",
          "[plasticity]") {
  // The classical apex return (de Souza Neto Box 8.5) needs sin(psi) > 0
  // (HYPLAS stops with an error): no plastic volume change can bring p back.
  for (double c : {1e4, 0.0}) {
    const MohrCoulomb m = make(30, 0, c);
    const Voigt de = 1e-2 * unit;  // 1 % stretch on each axis: p_trial = K 3e-2 = 2.5e5 Pa >> apex
    const MaterialPointUpdate u = update(m, Voigt::Zero(), de);
    REQUIRE(u.stress.allFinite());
    const double apex = c / std::tan(30 * M_PI / 180);
    CHECK(m.apex_stress() == Approx(apex).epsilon(1e-15));
    CHECK((u.stress - m.apex_stress() * unit).norm() == 0.0);  // exactly the apex
    CHECK(m.yield_function(u.stress) <= 1e-12 * (apex + 1));
    CHECK(u.trial_sensitivity.norm() == 0.0);
    CHECK(u.tangent.norm() == 0.0);
    // All the stretch beyond the apex pressure is plastic, and with psi = 0 all
    // of it is separation (the flow rule allows no dilatancy).
    const double tr = u.plastic_strain_increment.head<3>().sum();
    CHECK(tr == Approx(3e-2 - apex / m.bulk_modulus()).epsilon(1e-12));
    CHECK(u.separation_strain_increment > 0.0);
    CHECK(u.separation_strain_increment == Approx(tr).epsilon(1e-14));
  }
  // With psi > 0 the flow rule itself dilates: a hydrostatic stretch is all
  // separation only up to sin(psi) sum |e_i| (here e is isotropic, sum |e_i| = tr e).
  const MohrCoulomb m = make(30, 20, 1e4);
  const MaterialPointUpdate u = update(m, Voigt::Zero(), 1e-2 * unit);
  const double tr = u.plastic_strain_increment.head<3>().sum();
  CHECK(u.separation_strain_increment == Approx((1 - std::sin(20 * M_PI / 180)) * tr).epsilon(1e-12));
}

TEST_CASE("mohr_coulomb: each branch is hit by a designed trial state", "[plasticity]") {
  // phi = 30, psi = 10, c = 1e4: 2 c cos(phi) = 17.3 kPa, apex at c cot(phi) = 17.3 kPa.
  const MohrCoulomb m = make(30, 10, 1e4);
  std::mt19937 rng(7);
  struct Designed {
    Vector3 trial;
    Branch branch;
  };
  const std::vector<Designed> cases = {
      {{-10e3, -50e3, -90e3}, Branch::plane},      // sigma2 halfway: shear meridian
      {{-20e3, -20e3, -150e3}, Branch::edge_12},   // triaxial compression, sigma1 = sigma2
      {{-18e3, -22e3, -150e3}, Branch::edge_12},   // near it, distinct eigenvalues
      {{0.0, -100e3, -100e3}, Branch::edge_23},    // triaxial extension, sigma2 = sigma3
      {{2e3, -98e3, -102e3}, Branch::edge_23},     // near it, distinct eigenvalues
      {{60e3, 40e3, 30e3}, Branch::apex},          // tension beyond the apex
  };
  const double s_psi = std::sin(10 * M_PI / 180);
  for (const Designed& d : cases) {
    INFO(name(d.branch) << ", trial " << d.trial.transpose());
    const MohrCoulombPrincipalReturn r = m.principal_return(d.trial);
    REQUIRE(r.branch == d.branch);
    // The same through the Voigt interface with a rotated trial stress.
    const Voigt trial = rotated(d.trial, rng);
    const MaterialPointUpdate u = update(m, trial, Voigt::Zero());
    const Principal p = principal(u.stress);
    const double scale = d.trial.cwiseAbs().sum();
    CHECK((p.values - r.stress).norm() <= 1e-10 * scale);
    CHECK(std::abs(m.yield_function(u.stress)) <= 1e-10 * scale);
    const Vector3 e = r.plastic_strain;
    switch (d.branch) {
      case Branch::plane:
        CHECK(r.multiplier[0] > 0);
        CHECK(r.multiplier[1] == 0);
        CHECK(p.values[0] - p.values[1] > 1e-3 * scale);  // strictly inside the sextant
        CHECK(p.values[1] - p.values[2] > 1e-3 * scale);
        CHECK((e - r.multiplier[0] * normal(0, 2, s_psi)).norm() <= 1e-12 * e.norm());
        break;
      case Branch::edge_12:
        CHECK(r.multiplier[0] > 0);
        CHECK(r.multiplier[1] > 0);
        CHECK(r.stress[0] == r.stress[1]);
        CHECK(p.values[0] - p.values[1] <= 1e-10 * scale);
        CHECK(p.values[1] - p.values[2] > 1e-3 * scale);
        CHECK((e - r.multiplier[0] * normal(0, 2, s_psi) - r.multiplier[1] * normal(1, 2, s_psi)).norm() <=
              1e-12 * e.norm());
        break;
      case Branch::edge_23:
        CHECK(r.multiplier[0] > 0);
        CHECK(r.multiplier[1] > 0);
        CHECK(r.stress[1] == r.stress[2]);
        CHECK(p.values[1] - p.values[2] <= 1e-10 * scale);
        CHECK(p.values[0] - p.values[1] > 1e-3 * scale);
        CHECK((e - r.multiplier[0] * normal(0, 2, s_psi) - r.multiplier[1] * normal(0, 1, s_psi)).norm() <=
              1e-12 * e.norm());
        break;
      case Branch::apex:
        CHECK((u.stress - m.apex_stress() * unit).norm() == 0.0);
        CHECK(e.sum() >= s_psi * e.cwiseAbs().sum());  // in the apex cone C
        break;
      case Branch::elastic:
        break;
    }
    // Triaxial symmetry: equal trial stresses give equal multipliers.
    if (d.trial[0] == d.trial[1] || d.trial[1] == d.trial[2])
      CHECK(r.multiplier[0] == Approx(r.multiplier[1]).epsilon(1e-12));
  }
}

TEST_CASE("mohr_coulomb: plastic flow follows the potential g, not f", "[plasticity]") {
  std::mt19937 rng(5);
  for (double psi : {0.0, 10.0, 30.0}) {
    const MohrCoulomb m = make(30, psi, 1e4);
    const double s_psi = std::sin(psi * M_PI / 180), s_phi = 0.5;
    std::map<Branch, int> tested;
    for (int trial = 0; trial < 400; ++trial) {
      const Voigt sigma0 = -6e4 * unit + random_voigt(rng, 2e4);
      const Voigt de = random_voigt(rng, 3e-3);
      const Voigt trial_stress = sigma0 + m.elastic_stiffness() * de;
      const MaterialPointUpdate u = update(m, sigma0, de);
      const Principal pt = principal(trial_stress);
      const Branch b = m.principal_return(pt.values).branch;
      if (b == Branch::elastic || b == Branch::apex) continue;
      ++tested[b];
      const Vector3 e = principal_plastic_strain(u, pt.vectors);
      const double vol = u.plastic_strain_increment.head<3>().sum();
      // psi = 0: no plastic volume change on the planes and the edges.
      if (psi == 0.0) CHECK(std::abs(vol) <= 1e-12 * u.plastic_strain_increment.norm());
      if (b != Branch::plane) continue;
      // dg/dsigma in the trial's eigenbasis, as a Voigt strain (shears doubled).
      const auto voigt_strain = [&](const Vector3& n) {
        Voigt v = tensor_to_voigt(pt.vectors * n.asDiagonal() * pt.vectors.transpose());
        v.tail<3>() *= 2.0;
        return v;
      };
      const Voigt dg = voigt_strain(normal(0, 2, s_psi)), df = voigt_strain(normal(0, 2, s_phi));
      const Voigt& ep = u.plastic_strain_increment;
      const double lambda = ep.dot(dg) / dg.dot(dg);
      CHECK((ep - lambda * dg).norm() <= 1e-8 * ep.norm());
      CHECK(lambda > 0.0);
      CHECK(e.sum() == Approx(2 * s_psi * lambda).margin(1e-12 * e.norm()));  // tr dg = 2 sin(psi)
      if (psi < 30.0) {  // not along df/dsigma
        const double mu = ep.dot(df) / df.dot(df);
        CHECK((ep - mu * df).norm() > 1e-3 * ep.norm());
      }
    }
    CHECK(tested[Branch::plane] > 20);
    CHECK(tested[Branch::edge_12] + tested[Branch::edge_23] > 20);
  }
}

TEST_CASE("mohr_coulomb: the branches partition the trial space (KKT, independent candidates)", "[plasticity]") {
  // For each trial state the closed-form candidates of de Souza Neto et al.
  // (2008) Boxes 8.4-8.5 (one-vector return, right and left two-vector
  // returns, written here independently of the library) and the apex with the
  // cone C are evaluated; each has a KKT margin (multipliers >= 0, stresses in
  // the sextant, plastic strain in C at the apex). Exactly one must be valid
  // (up to round-off at the boundaries), and it must be the one the material
  // returned; the returned state must satisfy the KKT conditions.
  std::mt19937 rng(11);
  struct Setting {
    double phi, psi, c;
  };
  const Setting settings[] = {{30, 0, 0}, {30, 0, 2e4}, {30, 10, 2e4}, {30, 30, 2e4}, {40, 20, 0}, {20, 20, 1e4}};
  std::map<Branch, int> counts;
  int overlaps = 0, gaps = 0, total = 0;
  for (const Setting& st : settings) {
    const MohrCoulomb m = make(st.phi, st.psi, st.c);
    const double G = m.shear_modulus(), K = m.bulk_modulus();
    const double sf = std::sin(st.phi * M_PI / 180), cf = std::cos(st.phi * M_PI / 180);
    const double sp = std::sin(st.psi * M_PI / 180);
    const double a = 4 * G * (1 + sf * sp / 3) + 4 * K * sf * sp;
    const double b_right = 2 * G * (1 + sf + sp - sf * sp / 3) + 4 * K * sf * sp;
    const double b_left = 2 * G * (1 - sf - sp - sf * sp / 3) + 4 * K * sf * sp;
    const double aux1 = 2 * G * (1 + sp / 3) + 2 * K * sp, aux2 = (4 * G / 3 - 2 * K) * sp,
                 aux3 = 2 * G * (1 - sp / 3) - 2 * K * sp;
    const double apex = st.c * cf / sf;
    for (int trial = 0; trial < 350; ++trial) {
      const Voigt trial_stress = (trial % 3 == 0 ? 2e4 : -5e4) * unit + random_voigt(rng, 4e4);
      const Principal pt = principal(trial_stress);
      const Vector3 l = pt.values;
      const double fa = l[0] - l[2] + (l[0] + l[2]) * sf - 2 * st.c * cf;
      const double scale = l.cwiseAbs().sum() + st.c;
      const MaterialPointUpdate u = update(m, trial_stress, Voigt::Zero());
      const MohrCoulombPrincipalReturn r = m.principal_return(l);
      ++counts[r.branch];
      ++total;
      CHECK(m.yield_function(u.stress) <= 1e-10 * scale);
      if (fa <= 1e-12 * scale) {
        CHECK(r.branch == Branch::elastic);
        continue;
      }
      // Candidates: stress and KKT margin (>= 0 valid), in units of stress.
      std::map<Branch, std::pair<Vector3, double>> cand;
      {
        const double g = fa / a;
        const Vector3 s(l[0] - aux1 * g, l[1] + aux2 * g, l[2] + aux3 * g);
        cand[Branch::plane] = {s, std::min(s[0] - s[1], s[1] - s[2])};
      }
      {
        const double fb = l[0] - l[1] + (l[0] + l[1]) * sf - 2 * st.c * cf;
        const double det = a * a - b_right * b_right;
        const double ga = (a * fa - b_right * fb) / det, gb = (a * fb - b_right * fa) / det;
        const Vector3 s(l[0] - aux1 * (ga + gb), l[1] + aux2 * ga + aux3 * gb, l[2] + aux3 * ga + aux2 * gb);
        cand[Branch::edge_23] = {s, std::min({2 * G * ga, 2 * G * gb, s[0] - s[1]})};
      }
      {
        const double fb = l[1] - l[2] + (l[1] + l[2]) * sf - 2 * st.c * cf;
        const double det = a * a - b_left * b_left;
        const double ga = (a * fa - b_left * fb) / det, gb = (a * fb - b_left * fa) / det;
        const Vector3 s(l[0] - aux1 * ga + aux2 * gb, l[1] + aux2 * ga - aux1 * gb, l[2] + aux3 * (ga + gb));
        cand[Branch::edge_12] = {s, std::min({2 * G * ga, 2 * G * gb, s[1] - s[2]})};
      }
      {
        const double p = l.mean();
        const Vector3 e = (l - p * Vector3::Ones()) / (2 * G) + (p - apex) / (3 * K) * Vector3::Ones();
        cand[Branch::apex] = {Vector3::Constant(apex), 2 * G * (e.sum() - sp * e.cwiseAbs().sum())};
      }
      const double tol = 1e-9 * scale;
      int strict = 0, loose = 0;
      for (const auto& [branch, c] : cand) {
        strict += c.second > tol;
        loose += c.second >= -tol;
      }
      overlaps += strict > 1;
      gaps += loose == 0;
      INFO("phi " << st.phi << " psi " << st.psi << " c " << st.c << " trial " << l.transpose() << " branch "
                  << name(r.branch));
      CHECK(strict <= 1);  // no two branches valid
      CHECK(loose >= 1);   // no trial state without a valid branch
      REQUIRE(cand.count(r.branch) == 1);
      CHECK(cand[r.branch].second >= -tol);
      CHECK((cand[r.branch].first - r.stress).norm() <= 1e-9 * scale);
      // KKT of the returned state: multipliers >= 0, complementarity f = 0,
      // plastic strain in the cone spanned by the active dg (or in C at the apex).
      CHECK(std::abs(m.yield_function(u.stress)) <= 1e-10 * scale);
      const Vector3 e = principal_plastic_strain(u, pt.vectors);
      CHECK((e - r.plastic_strain).norm() <= 1e-9 * (e.norm() + 1e-12));
      CHECK(r.multiplier[0] >= 0);
      CHECK(r.multiplier[1] >= 0);
      Vector3 flow = r.multiplier[0] * normal(0, 2, sp);
      if (r.branch == Branch::edge_12) flow += r.multiplier[1] * normal(1, 2, sp);
      if (r.branch == Branch::edge_23) flow += r.multiplier[1] * normal(0, 1, sp);
      if (r.branch == Branch::apex)
        CHECK(e.sum() >= sp * e.cwiseAbs().sum() - 1e-12 * e.norm());
      else
        CHECK((e - flow).norm() <= 1e-9 * e.norm());
    }
  }
  std::printf("Mohr-Coulomb partition: %d trial states; elastic %d, plane %d, edge s1=s2 %d, edge s2=s3 %d, "
              "apex %d; overlaps %d, gaps %d\n",
              total, counts[Branch::elastic], counts[Branch::plane], counts[Branch::edge_12], counts[Branch::edge_23],
              counts[Branch::apex], overlaps, gaps);
  for (Branch b : {Branch::elastic, Branch::plane, Branch::edge_12, Branch::edge_23, Branch::apex}) {
    INFO(name(b));
    CHECK(counts[b] > 20);
  }
}

TEST_CASE("mohr_coulomb: consistent tangent equals finite differences in every branch", "[plasticity]") {
  std::mt19937 rng(13);
  std::map<Branch, TangentError> worst;
  std::map<Branch, int> checked;
  const auto record = [&](Branch b, const TangentError& e) {
    ++checked[b];
    worst[b].strain = std::max(worst[b].strain, e.strain);
    worst[b].stress = std::max(worst[b].stress, e.stress);
  };
  struct Setting {
    double phi, psi, c;
  };
  for (const Setting& st : {Setting{30, 0, 1e4}, Setting{30, 12, 1e4}, Setting{30, 30, 1e4}, Setting{50, 25, 0}}) {
    const MohrCoulomb m = make(st.phi, st.psi, st.c);
    for (int trial = 0; trial < 150; ++trial) {
      const Voigt sigma0 = (trial % 4 == 0 ? 2e4 : -4e4) * unit + random_voigt(rng, 1.5e4);
      const Voigt de = random_voigt(rng, 2e-3) + (trial % 4 == 0 ? 2e-3 : 0.0) * unit;
      if (!branch_is_stable(m, sigma0, de)) continue;  // within the difference step of a branch boundary
      record(branch_of(m, sigma0 + m.elastic_stiffness() * de), tangent_error(m, sigma0, de));
    }
  }
  std::printf("Mohr-Coulomb tangent vs central differences, max error (||D - FD|| / ||C||, ||S - FD||):\n");
  for (Branch b : {Branch::elastic, Branch::plane, Branch::edge_12, Branch::edge_23, Branch::apex}) {
    std::printf("  %-11s %3d states: %.2e  %.2e\n", name(b), checked[b], worst[b].strain, worst[b].stress);
    INFO(name(b));
    CHECK(checked[b] >= 5);
  }
}

TEST_CASE("mohr_coulomb: consistent tangent with two equal principal stresses", "[plasticity]") {
  // Triaxial states: sigma1 = sigma2 returns to the edge sigma1 = sigma2, and
  // sigma2 = sigma3 to the edge sigma2 = sigma3, where the eigenvectors of the
  // pair are arbitrary; the tangent must not depend on them.
  std::mt19937 rng(17);
  TangentError worst{0, 0};
  int n = 0;
  for (double psi : {0.0, 12.0, 30.0}) {
    const MohrCoulomb m = make(30, psi, 1e4);
    struct Triaxial {
      Vector3 trial;
      Branch branch;
    };
    const Triaxial states[] = {
        {{-20e3, -20e3, -150e3}, Branch::edge_12},
        {{0.0, -100e3, -100e3}, Branch::edge_23},
        {{-5e3, -5e3, -60e3}, Branch::edge_12},
    };
    for (const Triaxial& t : states) {
      INFO("psi " << psi << " trial " << t.trial.transpose());
      REQUIRE(m.principal_return(t.trial).branch == t.branch);
      // Along the axes (exactly equal eigenvalues) and rotated (equal to round-off).
      const Voigt axes = (Voigt() << t.trial[0], t.trial[1], t.trial[2], 0, 0, 0).finished();
      for (const Voigt& sigma0 : {axes, rotated(t.trial, rng)}) {
        REQUIRE(branch_is_stable(m, sigma0, Voigt::Zero()));
        const TangentError e = tangent_error(m, sigma0, Voigt::Zero());
        worst.strain = std::max(worst.strain, e.strain);
        worst.stress = std::max(worst.stress, e.stress);
        ++n;
      }
      // A strain-driven triaxial step: sigma0 isotropic, d_eps = (axial, lateral, lateral).
      // Compression of axis 3 gives sigma1 = sigma2 (edge_12), extension sigma2 = sigma3 (edge_23).
      const bool compression = t.branch == Branch::edge_12;
      const double d = compression ? -2e-2 : 2e-2;
      const Voigt sigma0 = (compression ? -4e4 : -1.5e5) * unit;
      const Voigt de = (Voigt() << -0.3 * d, -0.3 * d, d, 0, 0, 0).finished();
      REQUIRE(branch_of(m, sigma0 + m.elastic_stiffness() * de) == t.branch);
      REQUIRE(branch_is_stable(m, sigma0, de));
      const TangentError e = tangent_error(m, sigma0, de);
      worst.strain = std::max(worst.strain, e.strain);
      worst.stress = std::max(worst.stress, e.stress);
      ++n;
    }
  }
  std::printf("Mohr-Coulomb tangent with two equal principal stresses: %d states, max error %.2e (D), %.2e (S)\n",
              n, worst.strain, worst.stress);
  CHECK(n == 27);
}

TEST_CASE("mohr_coulomb: the tangent is non-symmetric exactly when psi != phi", "[plasticity]") {
  // A rotated trial state on the main plane. With engineering shear strains
  // the Voigt matrices of the elastic and of the associated tangent are
  // symmetric; the nonassociated one is not.
  std::mt19937 rng(19);
  const Voigt trial = rotated(Vector3(-10e3, -50e3, -90e3), rng);
  const MaterialPointUpdate assoc = update(make(30, 30, 1e4), trial, Voigt::Zero());
  const MaterialPointUpdate nonassoc = update(make(30, 0, 1e4), trial, Voigt::Zero());
  REQUIRE(branch_of(make(30, 30, 1e4), trial) == Branch::plane);
  REQUIRE(branch_of(make(30, 0, 1e4), trial) == Branch::plane);
  CHECK((assoc.tangent - assoc.tangent.transpose()).norm() <= 1e-9 * assoc.tangent.norm());
  CHECK((nonassoc.tangent - nonassoc.tangent.transpose()).norm() > 1e-3 * nonassoc.tangent.norm());
}

TEST_CASE("mohr_coulomb: case-file keys, defaults and validation", "[plasticity][config]") {
  const auto section = [](const std::string& yaml) {
    return YamlSection(YAML::Load(yaml), "materials[0]", "case.yaml");
  };
  {
    YamlSection s = section("{density: 2000, youngs_modulus: 1.0e7, poisson_ratio: 0.3, friction_angle: 30}");
    const std::unique_ptr<Material> law = make_material("mohr_coulomb", s);
    CHECK(std::string(law->model()) == "mohr_coulomb");
    CHECK(law->density() == 2000.0);
    const auto* mc = dynamic_cast<const MohrCoulomb*>(law.get());
    REQUIRE(mc);
    CHECK(mc->sin_psi() == 0.0);       // dilatancy_angle defaults to 0
    CHECK(mc->apex_stress() == 0.0);   // cohesion defaults to 0
    CHECK(mc->sin_phi() == Approx(0.5).epsilon(1e-15));
    CHECK_NOTHROW(s.finish());
  }
  const auto models = material_models();
  CHECK(std::find(models.begin(), models.end(), "mohr_coulomb") != models.end());
  struct Bad {
    std::string yaml, expected;
  };
  const std::string base = "density: 2000\nyoungs_modulus: 1.0e7\npoisson_ratio: 0.3\n";
  const std::vector<Bad> cases = {
      {base + "friction_angle: 95\n", "case.yaml:4: materials[0].friction_angle = 95"},
      {base + "friction_angle: 0\n", "materials[0].friction_angle = 0"},
      {base + "friction_angle: 30\ndilatancy_angle: 40\n", "case.yaml:5: materials[0].dilatancy_angle = 40"},
      {base + "friction_angle: 30\ndilatancy_angle: -1\n", "materials[0].dilatancy_angle = -1"},
      {base + "friction_angle: 30\ncohesion: -5\n", "materials[0].cohesion = -5"},
      {"density: 2000\nyoungs_modulus: 1.0e7\npoisson_ratio: 0.5\nfriction_angle: 30\n",
       "materials[0].poisson_ratio = 0.5"},
      {"density: -1\nyoungs_modulus: 1.0e7\npoisson_ratio: 0.3\nfriction_angle: 30\n", "materials[0].density"},
      {"density: 2000\nyoungs_modulus: 1.0e7\npoisson_ratio: 0.3\n", "materials[0].friction_angle"},
  };
  for (const Bad& b : cases) {
    std::string message;
    try {
      YamlSection s = section(b.yaml);
      make_material("mohr_coulomb", s);
    } catch (const InputError& e) {
      message = e.what();
    }
    INFO("yaml:\n" << b.yaml << "message: " << message);
    CHECK(message.find(b.expected) != std::string::npos);
  }
}
