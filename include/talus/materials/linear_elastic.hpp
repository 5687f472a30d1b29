#pragma once
#include "talus/materials/material.hpp"

namespace talus {

// Hooke's law, sigma = sigma* + C : d_eps, with C from E and nu.
class LinearElastic final : public Material {
 public:
  LinearElastic(double density, double youngs_modulus, double poisson_ratio);
  static std::unique_ptr<Material> from_yaml(YamlSection& p);

  const char* model() const override { return "linear_elastic"; }
  double density() const override { return density_; }
  void update(const Voigt& rotated_stress, const Voigt& strain_increment, const double*, double*,
              MaterialPointUpdate& out) const override;
  const Tangent& elastic_stiffness() const override { return stiffness_; }
  std::string parameters() const override;

  double youngs_modulus() const { return youngs_modulus_; }
  double poisson_ratio() const { return poisson_ratio_; }

 private:
  double density_, youngs_modulus_, poisson_ratio_;
  Tangent stiffness_;
};

}  // namespace talus
