// The primal-dual tangent (src/solver/primal_dual_tangent.cpp,
// docs/solver.md#the-primal-dual-tangent): the return linearized at a carried
// stress T instead of at itself,
//   S_pd = dP/d sigma_tr + (P - T_ret)_dev (x) s_tr / |s_tr|^2,
// checked in closed form on Drucker-Prager (psi = 0, no hardening), whose
// return of a trial on the smooth cone does not move when the trial's deviator
// is scaled (dP/d sigma_tr s_tr = 0), and the carried stresses' bookkeeping.
#include <catch2/catch.hpp>
#include <cmath>

#include "talus/materials/drucker_prager.hpp"
#include "talus/materials/mohr_coulomb.hpp"
#include "talus/solver/primal_dual_tangent.hpp"

using namespace talus;

namespace {

Voigt deviator(Voigt s) {
  s.head<3>().array() -= s.head<3>().mean();
  return s;
}

const Voigt pressure = (Voigt() << 1, 1, 1, 0, 0, 0).finished();

// A trial stress far outside the cone (the strain increment is ~100 c/E):
// the smooth branch of the return, as in a crawling Newton step.
struct Plastic {
  DruckerPrager law{drucker_prager_parameters(2000, 1e6, 0.3, 30, 0, 100, 0, MohrCoulombMatch::plane_strain)};
  Voigt rotated = (Voigt() << -2000, -3000, -2500, 0, 0, 400).finished();
  Voigt strain = (Voigt() << 0.01, -0.01, 0, 0, 0, 0.02).finished();  // isochoric
  Voigt trial = rotated + law.elastic_stiffness() * strain;
  MaterialPointUpdate update;
  Plastic() { law.update(rotated, strain, nullptr, nullptr, update); }
};

}  // namespace

TEST_CASE("primal-dual tangent: none at the return, the carried stress's pull under radial loading",
          "[solver][primal_dual]") {
  Plastic c;
  const Voigt s_tr = deviator(c.trial);
  const Voigt P = c.update.stress;
  // The premise: plastic on the smooth cone (not the apex), and the
  // consistent tangent does not move the return when the deviator scales.
  REQUIRE(deviator(P).norm() > 1.0);
  REQUIRE((P - c.trial).norm() > 100.0);
  const Tangent& S = c.update.trial_sensitivity;
  CHECK((S * s_tr).norm() <= 1e-10 * S.norm() * s_tr.norm());

  SECTION("carried stress = the return: the consistent tangent") {
    MaterialPointUpdate u = c.update;
    add_primal_dual_term(c.law, c.trial, P, nullptr, u);
    CHECK((u.trial_sensitivity - S).norm() <= 1e-12 * S.norm());
    CHECK((u.tangent - c.update.tangent).norm() <= 1e-12 * c.update.tangent.norm());
  }
  SECTION("an admissible carried stress: S_pd s_tr = (P - T)_dev, nothing across s_tr") {
    // Well inside the cone (mean stress -2500 Pa, a small deviator): its own return.
    const Voigt T = (Voigt() << -2400, -2600, -2500, 0, 0, 50).finished();
    MaterialPointUpdate u = c.update;
    add_primal_dual_term(c.law, c.trial, T, nullptr, u);
    const Voigt expected = deviator(P - T);
    CHECK((u.trial_sensitivity * s_tr - expected).norm() <= 1e-10 * expected.norm());
    // Directions orthogonal to s_tr (a pressure, a deviator with s_tr : d = 0)
    // keep the consistent tangent.
    Voigt across = (Voigt() << 0, 0, 0, 0, 0, 1).finished();
    Voigt s_tr_strain_like = s_tr;
    s_tr_strain_like.tail<3>() *= 2.0;
    across -= s_tr * (s_tr_strain_like.dot(across) / s_tr_strain_like.dot(s_tr));
    across = deviator(across);
    for (const Voigt& d : {pressure, across}) {
      REQUIRE(std::abs(s_tr_strain_like.dot(d)) <= 1e-12 * s_tr.norm() * d.norm() * 4);
      CHECK((u.trial_sensitivity * d - S * d).norm() <= 1e-12 * S.norm() * d.norm());
    }
    // d sigma / d strain = d sigma / d sigma_tr D.
    CHECK((u.tangent - c.update.tangent - (u.trial_sensitivity - S) * c.law.elastic_stiffness()).norm() <=
          1e-12 * c.update.tangent.norm());
  }
  SECTION("a carried stress outside the cone is first returned") {
    const Voigt T = (Voigt() << -1000, -4000, -2500, 0, 0, 900).finished();
    MaterialPointUpdate returned;
    c.law.update(T, Voigt::Zero(), nullptr, nullptr, returned);
    REQUIRE((returned.stress - T).norm() > 100.0);
    MaterialPointUpdate u = c.update;
    add_primal_dual_term(c.law, c.trial, T, nullptr, u);
    const Voigt expected = deviator(P - returned.stress);
    CHECK((u.trial_sensitivity * s_tr - expected).norm() <= 1e-10 * expected.norm());
  }
}

TEST_CASE("primal-dual tangent: the term is skipped only where the carried stress is near the return",
          "[solver][primal_dual]") {
  const Voigt P = (Voigt() << -1000, -3000, -2000, 0, 0, 500).finished();
  // A change of 5 % of the deviator's norm (energy norm) is near; 20 % is not.
  Voigt d = deviator(P);
  const double norm = std::sqrt(d.head<3>().squaredNorm() + 2.0 * d.tail<3>().squaredNorm());
  const Voigt unit = (Voigt() << 1, -1, 0, 0, 0, 0).finished() / std::sqrt(2.0);
  CHECK_FALSE(carried_far_from(P + 0.05 * norm * unit, P));
  CHECK(carried_far_from(P + 0.2 * norm * unit, P));
  // A pressure alone is no change of the deviator.
  CHECK_FALSE(carried_far_from(P + 1e4 * pressure, P));
}

namespace {

template <int dim>
void check_carried_stresses() {
  // The stress components a particle has (plane strain: xz = yz = 0).
  const auto plane = [](Voigt s) {
    if (dim == 2) s[3] = s[4] = 0.0;
    return s;
  };
  const Voigt stress = plane((Voigt() << -1, -2, -3, 0.4, 0.5, 0.6).finished());
  const Voigt trial = plane((Voigt() << -5, -6, -7, 0.8, 0.9, 1.0).finished());
  Tangent S;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) S(i, j) = 0.1 * (i + 1) - 0.03 * (j + 2) * (i == j ? -3 : 1);
  if (dim == 2)  // plane strain keeps xz, yz apart from the rest
    for (int i : {3, 4})
      for (int j : {0, 1, 2, 5}) S(i, j) = S(j, i) = 0.0;
  const Voigt next_trial = plane((Voigt() << -4, -6.5, -6, 0.1, -0.2, 2.0).finished());
  const Voigt expected = stress + S * (next_trial - trial);

  CarriedStresses<dim> carried;
  Voigt out;
  carried.begin_evaluation(3);
  carried.record(0, stress, trial, S);
  carried.record_elastic(1);
  // Nothing is carried before the first commit (the solve's first iterate).
  CHECK_FALSE(carried.carried(0, next_trial, out));
  carried.commit();
  REQUIRE(carried.carried(0, next_trial, out));
  CHECK((out - expected).norm() <= 1e-14 * expected.norm());
  REQUIRE(carried.carried(1, next_trial, out));
  CHECK(out == next_trial);  // elastic: the law is linear there
  CHECK_FALSE(carried.carried(2, next_trial, out));  // never recorded (a rigid particle)

  // An evaluation at a trial point that was not accepted changes nothing;
  // a second commit of the same evaluation is none.
  carried.begin_evaluation(3);
  carried.record(0, Voigt::Zero(), Voigt::Zero(), Tangent::Identity());
  carried.record_elastic(1);
  carried.commit();
  carried.commit();
  REQUIRE(carried.carried(0, next_trial, out));
  CHECK(out == next_trial);  // the accepted one: sigma = trial = 0, S = I

  carried.reset();
  CHECK_FALSE(carried.carried(0, next_trial, out));
  CHECK_FALSE(carried.carried(1, next_trial, out));
}

}  // namespace

TEST_CASE("carried stresses continue the last accepted iterate linearly (plane strain)", "[solver][primal_dual]") {
  check_carried_stresses<2>();
}

TEST_CASE("carried stresses continue the last accepted iterate linearly (3D)", "[solver][primal_dual]") {
  check_carried_stresses<3>();
}
