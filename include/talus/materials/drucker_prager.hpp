#pragma once
// Nonassociated Drucker-Prager plasticity with linear cohesion hardening,
// closed-form return mapping and consistent tangent (docs/plasticity.md).
//
//   yield      f = sqrt(J2) + eta p - xi c(alpha),  c = c0 + H alpha
//   potential  g = sqrt(J2) + eta_bar p             (p = tr(sigma)/3, tension positive)
//
// The return to the apex is written with De Saxce's modified plastic strain
//   eps_hat = d_eps_p + (eta - eta_bar) (sqrt(2)/3) |dev d_eps_p| I,
// normal to the yield cone (the bipotential / implicit standard material form
// of the nonassociated law, the same device as the modified velocity of
// Coulomb friction). Cone and apex regions then partition the trial space for
// every eta_bar in [0, eta], so psi = 0 never fails: a trial state beyond the
// apex returns to the apex, opening volumetrically like a contact separating.
//
// Optional tension cut-off f_t = p - p_t <= 0 (docs/plasticity.md, "Tension
// cut-off"): the return then also has the cut-off plane (p = p_t, deviator
// unchanged), the corner of plane and cone (two multipliers), and, with
// hardening, the tip (sigma = p_t I, the apex pinned at the cut-off). The
// regions partition the plastic trial states (with softening the local
// problem can have several solutions; the least-softening one is taken).
// The cut-off itself does not harden.
#include <limits>

#include "talus/materials/material.hpp"

namespace talus {

enum class MohrCoulombMatch { outer, inner, plane_strain };

struct DruckerPragerParameters {
  double density = 0, youngs_modulus = 0, poisson_ratio = 0;
  double friction_angle = 0;   // phi, radians
  double dilatancy_angle = 0;  // psi, radians, 0 <= psi <= phi
  double cohesion = 0;         // c0, Pa
  double hardening_modulus = 0;  // H = dc/dalpha, Pa (negative: softening)
  // p_t, Pa: the largest admissible mean stress; infinity: no cut-off.
  double tension_cutoff = std::numeric_limits<double>::infinity();
  MohrCoulombMatch match = MohrCoulombMatch::plane_strain;
};

// Parameters with the angles in degrees, as in the case file.
DruckerPragerParameters drucker_prager_parameters(double density, double youngs_modulus, double poisson_ratio,
                                                  double friction_angle_deg, double dilatancy_angle_deg,
                                                  double cohesion, double hardening_modulus = 0.0,
                                                  MohrCoulombMatch match = MohrCoulombMatch::plane_strain);

// eta, xi (or eta_bar with the dilatancy angle) of the Drucker-Prager cone
// matching Mohr-Coulomb (de Souza Neto, Peric & Owen 2008, Sec. 6.4.6).
void drucker_prager_coefficients(MohrCoulombMatch match, double angle, double& eta, double& xi);

class DruckerPrager final : public Material {
 public:
  explicit DruckerPrager(const DruckerPragerParameters& parameters);
  static std::unique_ptr<Material> from_yaml(YamlSection& p);

  const char* model() const override { return "drucker_prager"; }
  double density() const override { return par_.density; }
  int state_size() const override { return 1; }  // alpha, the hardening variable
  void update(const Voigt& rotated_stress, const Voigt& strain_increment, const double* state_old,
              double* state_new, MaterialPointUpdate& out) const override;
  const Tangent& elastic_stiffness() const override { return stiffness_; }
  std::string parameters() const override;

  double yield_function(const Voigt& stress, double alpha) const;
  double eta() const { return eta_; }
  double eta_bar() const { return eta_bar_; }
  double xi() const { return xi_; }
  double shear_modulus() const { return shear_; }
  double bulk_modulus() const { return bulk_; }
  double tension_cutoff() const { return par_.tension_cutoff; }  // infinity when absent

 private:
  // The closed-form return with cohesion c_n and slope H = dc/dalpha.
  void return_map(const Voigt& rotated_stress, const Voigt& strain_increment, double alpha_n, double c_n, double H,
                  double* alpha_new, MaterialPointUpdate& out) const;

  DruckerPragerParameters par_;
  double eta_, xi_, eta_bar_, shear_, bulk_;
  Tangent stiffness_, compliance_;
};

}  // namespace talus
