#include "talus/materials/linear_elastic.hpp"

#include "talus/io/yaml_section.hpp"
#include "talus/materials/parameters.hpp"

namespace talus {

Tangent isotropic_stiffness(double E, double nu) {
  const double lambda = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
  const double mu = E / (2.0 * (1.0 + nu));
  Tangent C = Tangent::Zero();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) C(i, j) = lambda;
    C(i, i) = lambda + 2.0 * mu;
    C(i + 3, i + 3) = mu;  // engineering shear: tau = mu * gamma
  }
  return C;
}

LinearElastic::LinearElastic(double density, double youngs_modulus, double poisson_ratio)
    : density_(density),
      youngs_modulus_(youngs_modulus),
      poisson_ratio_(poisson_ratio),
      stiffness_(isotropic_stiffness(youngs_modulus, poisson_ratio)) {}

std::unique_ptr<Material> LinearElastic::from_yaml(YamlSection& p) {
  const ElasticParameters e = read_elastic_parameters(p);
  return std::make_unique<LinearElastic>(e.density, e.youngs_modulus, e.poisson_ratio);
}

void LinearElastic::update(const Voigt& rotated_stress, const Voigt& strain_increment, const double*, double*,
                           MaterialPointUpdate& out) const {
  out.stress = rotated_stress + stiffness_ * strain_increment;
  out.tangent = stiffness_;
  out.trial_sensitivity.setIdentity();
  out.plastic_strain_increment.setZero();
}

std::string LinearElastic::parameters() const {
  return parameter_text(model(), {{"density", density_}, {"youngs_modulus", youngs_modulus_}, {"poisson_ratio", poisson_ratio_}});
}

}  // namespace talus
