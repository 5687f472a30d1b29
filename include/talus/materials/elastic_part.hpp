#pragma once
// The elastic part of a law: sigma = sigma* + C : d_eps with the law's own
// elastic stiffness C, its internal variables carried through unchanged.
// The equilibrium stage's `law: elastic` (docs/equilibrium.md) loads the
// bodies with it, as the usual gravity-loading step of geotechnical codes.
#include "talus/materials/material.hpp"

namespace talus {

class ElasticPart final : public Material {
 public:
  explicit ElasticPart(const Material& law) : law_(law) {}

  const char* model() const override { return "elastic part"; }
  double density() const override { return law_.density(); }
  int state_size() const override { return law_.state_size(); }
  void update(const Voigt& rotated_stress, const Voigt& strain_increment, const double* state_old,
              double* state_new, MaterialPointUpdate& out) const override {
    const Tangent& c = law_.elastic_stiffness();
    out.stress = rotated_stress + c * strain_increment;
    out.tangent = c;
    out.trial_sensitivity = Tangent::Identity();
    out.plastic_strain_increment = Voigt::Zero();
    out.separation_strain_increment = 0.0;
    for (int k = 0; k < law_.state_size(); ++k) state_new[k] = state_old[k];
  }
  const Tangent& elastic_stiffness() const override { return law_.elastic_stiffness(); }
  std::string parameters() const override { return "elastic part of " + law_.parameters(); }

 private:
  const Material& law_;
};

}  // namespace talus
