// The step's strain increment (docs/formulation.md#the-strain-increment):
// a uniaxial finite stretch of one material point through many uneven steps
// gives the Hencky stress E ln(lambda) to round-off with the logarithmic
// increment (and not with the linear one), and the increment's derivative
// equals central differences, also where the step stretches coincide.
#include <catch2/catch.hpp>
#include <cmath>

#include "talus/materials/linear_elastic.hpp"
#include "talus/solver/strain_increment.hpp"

using namespace talus;

namespace {

// Stretches x from 1 to 3, back to 0.4 and to 1.7, in 300 steps of uneven
// length and rate; returns the Kirchhoff stress tau_xx of a Hooke material
// (nu = 0, so tau_xx = E * (summed strain)) and the final stretch.
std::pair<double, double> stretch_history(StrainIncrement kind, double E) {
  const LinearElastic hooke(1000.0, E, 0.0);
  Voigt stress = Voigt::Zero();
  double lambda = 1.0;
  const double targets[3] = {3.0, 0.4, 1.7};
  int step = 0;
  for (double target : targets) {
    const double start = lambda;
    for (int k = 1; k <= 100; ++k, ++step) {
      // The next stretch on an uneven path; h varies too.
      const double s = static_cast<double>(k) / 100.0;
      const double next = start + (target - start) * (s + 0.05 * std::sin(7.0 * s) * s * (1.0 - s));
      const double h = 0.01 * (1.0 + 0.5 * std::sin(1.3 * step));
      Eigen::Matrix3d L = Eigen::Matrix3d::Zero();
      L(0, 0) = (next / lambda - 1.0) / h;  // x^{n+1} = (1 + h L) x^n
      const StrainIncrementResult de = strain_increment(L, h, kind);
      MaterialPointUpdate out;
      hooke.update(stress, de.strain, nullptr, nullptr, out);
      stress = out.stress;
      lambda = next;
    }
  }
  return {stress[0], lambda};
}

}  // namespace

TEST_CASE("a uniaxial finite stretch through 300 uneven steps gives E ln(lambda) to round-off",
          "[strain_increment][verification]") {
  const double E = 1.0e7;
  const auto [tau, lambda] = stretch_history(StrainIncrement::logarithmic, E);
  REQUIRE(lambda == Approx(1.7).epsilon(1e-14));
  // 300 sums of logarithms of order 0.01: round-off about 300 * 1e-16.
  CHECK(std::abs(tau - E * std::log(lambda)) <= 1e-12 * E);
  // The linear increment sums r - 1 instead of ln r: off by O(h) of the
  // stretches, here more than 1e-3 of E (the test can tell the two apart).
  const auto [tau_linear, lambda_linear] = stretch_history(StrainIncrement::linear, E);
  INFO("linear: tau / E = " << tau_linear / E << ", ln(lambda) = " << std::log(lambda_linear));
  CHECK(std::abs(tau_linear - E * std::log(lambda_linear)) > 1e-3 * E);
}

TEST_CASE("a coaxial stretch along three axes: the Hencky strain of each axis", "[strain_increment]") {
  Eigen::Vector3d lambda = Eigen::Vector3d::Ones();
  Voigt sum = Voigt::Zero();
  for (int step = 0; step < 50; ++step) {
    const Eigen::Vector3d rate(2.0 * std::cos(0.2 * step), -1.5, 0.7 * std::sin(0.3 * step));
    const double h = 0.02;
    const StrainIncrementResult de = strain_increment(Eigen::Matrix3d(rate.asDiagonal()), h, StrainIncrement::logarithmic);
    sum += de.strain;
    lambda = lambda.cwiseProduct((Eigen::Vector3d::Ones() + h * rate));
  }
  for (int a = 0; a < 3; ++a) CHECK(sum[a] == Approx(std::log(lambda[a])).margin(1e-13));
  CHECK(sum.tail<3>().norm() <= 1e-14);
}

TEST_CASE("the logarithmic increment's derivative equals central differences", "[strain_increment]") {
  // A general L (stretch and spin), and one whose step stretches coincide
  // (the divided differences' limit), and small h (close to h sym L).
  Eigen::Matrix3d general;
  general << 3.0, -1.2, 0.4, 2.1, -2.5, 0.9, -0.3, 1.7, 1.1;
  Eigen::Matrix3d coincident = Eigen::Matrix3d::Zero();
  coincident(0, 0) = coincident(1, 1) = 1.5;
  coincident(2, 2) = -0.5;
  coincident(0, 1) = 1e-9;
  // Plane strain (row and column 3 zero) takes the closed-form 2 x 2 path:
  // a general one and one with coincident step stretches.
  Eigen::Matrix3d plane = Eigen::Matrix3d::Zero(), plane_coincident = Eigen::Matrix3d::Zero();
  plane.topLeftCorner<2, 2>() << 2.2, -0.7, 1.3, -1.1;
  plane_coincident(0, 0) = plane_coincident(1, 1) = 1.5;
  plane_coincident(0, 1) = 1e-9;
  for (const auto& [L, h] : {std::pair{general, 0.1}, std::pair{coincident, 0.1}, std::pair{general, 1e-4},
                             std::pair{plane, 0.1}, std::pair{plane_coincident, 0.1}}) {
    const StrainIncrementResult de = strain_increment(L, h, StrainIncrement::logarithmic);
    const double eps = 1e-6;
    for (int c = 0; c < 9; ++c) {
      Eigen::Matrix3d dL = Eigen::Matrix3d::Zero();
      dL(c / 3, c % 3) = eps;
      const Voigt fd = (strain_increment(L + dL, h, StrainIncrement::logarithmic).strain -
                        strain_increment(L - dL, h, StrainIncrement::logarithmic).strain) /
                       (2.0 * eps);
      INFO("h " << h << " component " << c << ": derivative " << de.derivative.col(c).transpose() << ", FD "
                << fd.transpose());
      // Central differences of a smooth function: truncation O(eps^2 h)
      // = 1e-12 h, and round-off: the logarithms of eigenvalues near 1
      // carry absolute errors of 1e-16, divided by eps, 1e-10 whatever h.
      // The derivative itself is of order h.
      CHECK((de.derivative.col(c) - fd).norm() <= 1e-8 * h + 1e-9);
    }
  }
}

TEST_CASE("an inverted step has no logarithmic strain: NaN, so Newton backs off", "[strain_increment]") {
  // 1 + h L_yy = -0.5: the step turns the particle inside out along y. Its
  // C = dF^T dF is that of a compression to 0.5, which the guard must not
  // take for one (docs/formulation.md#the-strain-increment).
  Eigen::Matrix3d L = Eigen::Matrix3d::Zero();
  L(1, 1) = -15.0;
  const StrainIncrementResult inverted = strain_increment(L, 0.1, StrainIncrement::logarithmic);
  CHECK(inverted.strain.array().isNaN().all());
  // The same compression without inversion, 1 + h L_yy = 0.5: ln 0.5.
  L(1, 1) = -5.0;
  const StrainIncrementResult compressed = strain_increment(L, 0.1, StrainIncrement::logarithmic);
  CHECK(compressed.strain[1] == Approx(std::log(0.5)).epsilon(1e-14));
  // The linear increment is defined for any L.
  L(1, 1) = -15.0;
  CHECK(strain_increment(L, 0.1, StrainIncrement::linear).strain[1] == Approx(-1.5).epsilon(1e-15));
}
