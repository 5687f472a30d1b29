#pragma once
#include <cmath>
// The constitutive interface: one material point, one time step.
//
// In: the objectively rotated stress at the start of the step sigma* (tension
// positive, Voigt), the strain increment d_eps (engineering shear), and the
// internal variables at the start of the step. Out: the stress at the end of
// the step, the consistent tangent d sigma / d d_eps, the sensitivity
// d sigma / d sigma* (identity for elasticity), and the new internal
// variables. Stress and tangent come from the same call, so they always agree.
// A material has at most max_state_size internal variables per particle.
#include <memory>
#include <string>

#include "talus/core/types.hpp"

namespace talus {

class YamlSection;

struct MaterialPointUpdate {
  Voigt stress;
  Tangent tangent;                  // d stress / d strain_increment
  Tangent trial_sensitivity;        // d stress / d rotated_stress
  Voigt plastic_strain_increment;   // engineering shear; zero for elastic steps
  // Volumetric strain opened at the apex beyond the flow rule's dilatancy:
  // the material separates there (a void, like a contact gap). The step
  // removes it from the particle's quadrature volume and closes it, stress
  // free, before any later compression loads the solid (docs/plasticity.md).
  double separation_strain_increment = 0.0;
  // In: only the stress is wanted (a law may then leave the tangents and the
  // strains unset).
  bool stress_only = false;
};

inline constexpr int max_state_size = 2;

class Material {
 public:
  virtual ~Material() = default;
  virtual const char* model() const = 0;
  virtual double density() const = 0;
  virtual int state_size() const { return 0; }
  virtual void update(const Voigt& rotated_stress, const Voigt& strain_increment, const double* state_old,
                      double* state_new, MaterialPointUpdate& out) const = 0;
  // Elastic stiffness (for wave speeds, time-step estimates and initial stress).
  virtual const Tangent& elastic_stiffness() const = 0;
  // Every parameter of the law as parsed, defaults included, as
  // "key: value, ..." (angles in degrees): what a checkpoint's case
  // fingerprint compares, so that writing a default out is no change.
  virtual std::string parameters() const = 0;
};

// The speed of a P-wave in the law's elastic stiffness, sqrt(C_11 / rho)
// (explicit step limit, docs/explicit.md#the-step; how static an implicit
// step is, docs/solver.md#geometric-multigrid).
inline double p_wave_speed(const Material& m) { return std::sqrt(m.elastic_stiffness()(0, 0) / m.density()); }

// The built-in materials, by the key used in the case file's `model:`.
std::unique_ptr<Material> make_material(const std::string& model, YamlSection& parameters);
std::vector<std::string> material_models();

// Isotropic elastic stiffness in Voigt form (engineering shear).
Tangent isotropic_stiffness(double youngs_modulus, double poisson_ratio);

}  // namespace talus
