#pragma once
// Nonassociated Mohr-Coulomb perfect plasticity, return mapping in principal
// stresses and consistent tangent (docs/mohr_coulomb.md; de Souza Neto, Peric
// & Owen 2008, Sec. 8.2, Boxes 8.4-8.5). Tension positive, sigma1 >= sigma2 >= sigma3:
//
//   yield planes  f_ij = (sigma_i - sigma_j) + (sigma_i + sigma_j) sin(phi) - 2 c cos(phi)
//   potential     g_ij = (sigma_i - sigma_j) + (sigma_i + sigma_j) sin(psi)
//   main plane    f = f_13;  edges sigma1 = sigma2 (f_13, f_23) and sigma2 = sigma3 (f_13, f_12)
//   apex          sigma_a = c cot(phi) I
//
// The apex is taken when the plastic strain that returns the trial stress to
// it, e = C^-1 (sigma_tr - sigma_a), lies in the apex cone of the flow rule
//   C = { e : tr e >= sin(psi) sum_i |e_i| }
// (De Saxce's bipotential view, as in the Drucker-Prager law): for psi > 0 the
// cone spanned by the six potential normals, for psi = 0 the half-space
// tr e >= 0, so a trial state beyond the apex always returns to the apex.
#include "talus/materials/material.hpp"

namespace talus {

struct MohrCoulombParameters {
  double density = 0, youngs_modulus = 0, poisson_ratio = 0;
  double friction_angle = 0;   // phi, radians, in (0, pi/2)
  double dilatancy_angle = 0;  // psi, radians, 0 <= psi <= phi
  double cohesion = 0;         // c, Pa
};

// Parameters with the angles in degrees, as in the case file.
MohrCoulombParameters mohr_coulomb_parameters(double density, double youngs_modulus, double poisson_ratio,
                                              double friction_angle_deg, double dilatancy_angle_deg,
                                              double cohesion);

// Which part of the yield surface the return ended on. The edges are named by
// the principal stresses they make equal: edge_12 is dSN's "left corner"
// (planes f_13 and f_23, triaxial compression), edge_23 the "right corner"
// (planes f_13 and f_12, triaxial extension).
enum class MohrCoulombBranch { elastic, plane, edge_12, edge_23, apex };

// The return of one trial state in sorted principal stresses.
struct MohrCoulombPrincipalReturn {
  MohrCoulombBranch branch = MohrCoulombBranch::elastic;
  Eigen::Vector3d stress;          // sigma1 >= sigma2 >= sigma3
  Eigen::Matrix3d jacobian;        // d stress_i / d trial_j
  Eigen::Vector3d plastic_strain;  // principal plastic strain increment C^-1 (trial - stress)
  // Plastic multipliers: [0] of the main plane f_13, [1] of the edge's second
  // plane (f_23 or f_12); both 0 when elastic and at the apex.
  double multiplier[2] = {0.0, 0.0};
};

class MohrCoulomb final : public Material {
 public:
  explicit MohrCoulomb(const MohrCoulombParameters& parameters);
  static std::unique_ptr<Material> from_yaml(YamlSection& p);

  const char* model() const override { return "mohr_coulomb"; }
  double density() const override { return par_.density; }
  void update(const Voigt& rotated_stress, const Voigt& strain_increment, const double* state_old,
              double* state_new, MaterialPointUpdate& out) const override;
  const Tangent& elastic_stiffness() const override { return stiffness_; }
  std::string parameters() const override;

  // The return mapping in principal stresses; `trial` sorted descending.
  MohrCoulombPrincipalReturn principal_return(const Eigen::Vector3d& trial) const;

  // max over the six planes of f_ij(stress), from the principal stresses.
  double yield_function(const Voigt& stress) const;
  double apex_stress() const { return apex_; }  // c cot(phi), the mean stress of the apex
  double sin_phi() const { return sin_phi_; }
  double sin_psi() const { return sin_psi_; }
  double shear_modulus() const { return shear_; }
  double bulk_modulus() const { return bulk_; }

 private:
  MohrCoulombParameters par_;
  double sin_phi_, cos_phi_, sin_psi_, shear_, bulk_, apex_;
  Eigen::Matrix3d principal_stiffness_;  // elastic stiffness on principal strains
  Tangent stiffness_, compliance_;
};

}  // namespace talus
