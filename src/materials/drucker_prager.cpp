#include "talus/materials/drucker_prager.hpp"

#include <algorithm>
#include <cmath>

#include "talus/io/yaml_section.hpp"
#include "talus/materials/parameters.hpp"

namespace talus {

namespace {

const Voigt unit_voigt = (Voigt() << 1, 1, 1, 0, 0, 0).finished();

// The same tensor as a strain-like Voigt vector (shears doubled), so that
// a.dot(strain_like(b)) = a : b for stress-like a and b.
Voigt strain_like(const Voigt& s) {
  Voigt e = s;
  e.tail<3>() *= 2.0;
  return e;
}

double norm(const Voigt& s) { return std::sqrt(s.dot(strain_like(s))); }

}  // namespace

DruckerPragerParameters drucker_prager_parameters(double density, double youngs_modulus, double poisson_ratio,
                                                  double friction_angle_deg, double dilatancy_angle_deg,
                                                  double cohesion, double hardening_modulus, MohrCoulombMatch match) {
  DruckerPragerParameters p;
  p.density = density;
  p.youngs_modulus = youngs_modulus;
  p.poisson_ratio = poisson_ratio;
  p.friction_angle = friction_angle_deg * M_PI / 180.0;
  p.dilatancy_angle = dilatancy_angle_deg * M_PI / 180.0;
  p.cohesion = cohesion;
  p.hardening_modulus = hardening_modulus;
  p.match = match;
  return p;
}

void drucker_prager_coefficients(MohrCoulombMatch match, double angle, double& eta, double& xi) {
  const double s = std::sin(angle), c = std::cos(angle), t = std::tan(angle);
  switch (match) {
    case MohrCoulombMatch::outer:  // through the compressive meridians of Mohr-Coulomb
      eta = 6.0 * s / (std::sqrt(3.0) * (3.0 - s));
      xi = 6.0 * c / (std::sqrt(3.0) * (3.0 - s));
      break;
    case MohrCoulombMatch::inner:  // through the extension meridians
      eta = 6.0 * s / (std::sqrt(3.0) * (3.0 + s));
      xi = 6.0 * c / (std::sqrt(3.0) * (3.0 + s));
      break;
    case MohrCoulombMatch::plane_strain:  // same collapse load in plane strain
      eta = 3.0 * t / std::sqrt(9.0 + 12.0 * t * t);
      xi = 3.0 / std::sqrt(9.0 + 12.0 * t * t);
      break;
  }
}

DruckerPrager::DruckerPrager(const DruckerPragerParameters& p)
    : par_(p), stiffness_(isotropic_stiffness(p.youngs_modulus, p.poisson_ratio)) {
  drucker_prager_coefficients(p.match, p.friction_angle, eta_, xi_);
  double unused;
  drucker_prager_coefficients(p.match, p.dilatancy_angle, eta_bar_, unused);
  shear_ = p.youngs_modulus / (2.0 * (1.0 + p.poisson_ratio));
  bulk_ = p.youngs_modulus / (3.0 * (1.0 - 2.0 * p.poisson_ratio));
  compliance_ = stiffness_.inverse();
}

std::unique_ptr<Material> DruckerPrager::from_yaml(YamlSection& y) {
  const ElasticParameters e = read_elastic_parameters(y);
  const FrictionParameters f = read_friction_parameters(y);
  const double rho = e.density, E = e.youngs_modulus, nu = e.poisson_ratio;
  const double phi = f.friction_angle, psi = f.dilatancy_angle, c = f.cohesion;
  const double H = y.real("hardening_modulus", 0.0);
  const std::string match = y.choice("mohr_coulomb_match", {"outer", "inner", "plane_strain"}, "plane_strain");
  DruckerPragerParameters par = drucker_prager_parameters(rho, E, nu, phi, psi, c, H,
                                                          match == "outer"   ? MohrCoulombMatch::outer
                                                          : match == "inner" ? MohrCoulombMatch::inner
                                                                             : MohrCoulombMatch::plane_strain);
  if (y.has("tension_cutoff")) {
    par.tension_cutoff = y.real("tension_cutoff");
    if (!(par.tension_cutoff >= 0.0))
      y.fail_value("tension_cutoff", "must be >= 0");
  }
  return std::make_unique<DruckerPrager>(par);
}

double DruckerPrager::yield_function(const Voigt& stress, double alpha) const {
  const double p = mean_stress(stress);
  const Voigt s = stress - p * unit_voigt;
  const double c = std::max(0.0, par_.cohesion + par_.hardening_modulus * alpha);
  return norm(s) / std::sqrt(2.0) + eta_ * p - xi_ * c;
}

void DruckerPrager::update(const Voigt& rotated_stress, const Voigt& strain_increment, const double* state_old,
                           double* state_new, MaterialPointUpdate& out) const {
  const double alpha_n = state_old ? state_old[0] : 0.0;
  // Softening stops at zero cohesion: from there on the cone no longer shrinks.
  const double c_n = std::max(0.0, par_.cohesion + par_.hardening_modulus * alpha_n);
  const double H = c_n > 0.0 ? par_.hardening_modulus : std::max(0.0, par_.hardening_modulus);
  double alpha = alpha_n;
  return_map(rotated_stress, strain_increment, alpha_n, c_n, H, &alpha, out);
  if (H < 0.0 && c_n + H * (alpha - alpha_n) < 0.0) {
    // The step softened past zero cohesion: redo it on the c = 0 cone.
    return_map(rotated_stress, strain_increment, alpha_n, 0.0, 0.0, &alpha, out);
  }
  if (state_new) state_new[0] = alpha;
}

void DruckerPrager::return_map(const Voigt& rotated_stress, const Voigt& strain_increment, double alpha_n,
                               double c_n, double H, double* alpha_new, MaterialPointUpdate& out) const {
  const double G = shear_, K = bulk_;
  const Voigt trial = rotated_stress + stiffness_ * strain_increment;
  const double p_tr = mean_stress(trial);
  const Voigt s_tr = trial - p_tr * unit_voigt;
  const double sqrt_j2 = norm(s_tr) / std::sqrt(2.0);
  const double f_tr = sqrt_j2 + eta_ * p_tr - xi_ * c_n;
  // Tension cut-off f_t = p - p_t (p_t = infinity: none, and then every
  // branch below runs exactly the operations of the law without cut-off).
  const bool cutoff = std::isfinite(par_.tension_cutoff);
  const double p_t = par_.tension_cutoff;
  // Relative tolerance on the yield test: round-off of the trial stress.
  const double scale = std::abs(p_tr) + sqrt_j2 + xi_ * std::abs(c_n);
  if (f_tr <= 1e-12 * scale && (!cutoff || p_tr - p_t <= 1e-12 * scale)) {
    out.stress = trial;
    out.tangent = stiffness_;
    out.trial_sensitivity.setIdentity();
    out.plastic_strain_increment.setZero();
    out.separation_strain_increment = 0.0;
    *alpha_new = alpha_n;
    return;
  }
  const Tangent P_dev = Tangent::Identity() - unit_voigt * unit_voigt.transpose() / 3.0;
  const Voigt n = sqrt_j2 > 0 ? Voigt(s_tr / (std::sqrt(2.0) * sqrt_j2)) : Voigt(Voigt::Zero());  // unit deviator

  // Return to the smooth part of the cone: f(dgamma) is linear in dgamma.
  const double A = G + K * eta_ * eta_bar_ + xi_ * xi_ * H;
  const double dgamma = f_tr / A;
  const double p_cone = p_tr - K * eta_bar_ * dgamma;
  // The cone evaluated at the cut-off with the trial deviator: m <= 0 means the
  // trial deviator fits inside the cone on the plane p = p_t.
  const double m = sqrt_j2 + eta_ * p_t - xi_ * c_n;
  Tangent S;  // d sigma / d trial
  bool on_cone = false;
  if (sqrt_j2 - G * dgamma >= 0.0 && (!cutoff || p_cone <= p_t)) {
    on_cone = true;
    const double ratio = G * dgamma / sqrt_j2;
    out.stress = (1.0 - ratio) * s_tr + p_cone * unit_voigt;
    // d dgamma / d trial = (n/sqrt2 + eta/3 I) : / A  (strain-like row)
    const Voigt ddg = strain_like(n / std::sqrt(2.0) + eta_ / 3.0 * unit_voigt) / A;
    const Tangent ds = (1.0 - ratio) * P_dev - std::sqrt(2.0) * G * n * ddg.transpose() +
                       ratio * n * strain_like(n).transpose();
    const Voigt dp = unit_voigt / 3.0 - K * eta_bar_ * ddg;
    S = ds + unit_voigt * dp.transpose();
    *alpha_new = alpha_n + xi_ * dgamma;
  } else if (cutoff && p_tr > p_t && m <= 0.0) {
    // Cut-off plane: p = p_t, deviator unchanged; the plastic strain is purely
    // volumetric, tr d_eps_p = (p_tr - p_t) / K, and the cone does not harden.
    out.stress = s_tr + p_t * unit_voigt;
    S = P_dev;
    *alpha_new = alpha_n;
  } else if (cutoff && m > 0.0 && sqrt_j2 - G * m / (G + xi_ * xi_ * H) >= 0.0) {
    // Corner of cone and cut-off: p = p_t and f = 0 give the shear multiplier
    //   dgamma = (sqrt(J2_tr) + eta p_t - xi c_n) / (G + xi^2 H);
    // the cut-off's multiplier (p_tr - p_t)/K - eta_bar dgamma takes the rest
    // of the volume change.
    const double B = G + xi_ * xi_ * H;
    const double dg = m / B;
    const double ratio = G * dg / sqrt_j2;
    out.stress = (1.0 - ratio) * s_tr + p_t * unit_voigt;
    const Voigt ddg = strain_like(n / std::sqrt(2.0)) / B;
    S = (1.0 - ratio) * P_dev - std::sqrt(2.0) * G * n * ddg.transpose() + ratio * n * strain_like(n).transpose();
    *alpha_new = alpha_n + xi_ * dg;
  } else {
    // Apex: sigma = p I with p = xi c / eta; the modified plastic strain
    // eps_hat lies in the normal cone of the apex, tr(eps_hat) = eta dgamma,
    //   eta dgamma = (p_tr - p) / K + (eta - eta_bar) sqrt(J2_tr) / G.
    const double denom = eta_ + xi_ * xi_ * H / (eta_ * K);
    const double dg = ((p_tr - xi_ * c_n / eta_) / K + (eta_ - eta_bar_) * sqrt_j2 / G) / denom;
    const double p = xi_ * (c_n + H * xi_ * dg) / eta_;
    if (!cutoff || p <= p_t) {
      out.stress = p * unit_voigt;
      const Voigt ddg = strain_like(unit_voigt / (3.0 * K) + (eta_ - eta_bar_) / G * n / std::sqrt(2.0)) / denom;
      S = unit_voigt * (xi_ * xi_ * H / eta_ * ddg).transpose();
      *alpha_new = alpha_n + xi_ * dg;
    } else {
      // Tip: hardening would lift the apex above the cut-off; the stress stays
      // at p_t I and the cone hardens just enough to put its apex there,
      // xi c(alpha) / eta = p_t. Only reached with H != 0 (H = 0 here is
      // round-off at an apex exactly on the cut-off, where alpha is inert).
      out.stress = p_t * unit_voigt;
      S.setZero();
      const double dg_tip = H != 0.0 ? (eta_ * p_t / xi_ - c_n) / (xi_ * H) : 0.0;
      *alpha_new = alpha_n + xi_ * std::max(0.0, dg_tip);
    }
  }
  out.trial_sensitivity = S;
  out.tangent = S * stiffness_;
  out.plastic_strain_increment = compliance_ * (trial - out.stress);
  out.separation_strain_increment = 0.0;
  if (!on_cone) {
    // Off the smooth cone (apex, tip, cut-off plane, corner) the volume opened
    // beyond the flow rule's dilatancy, tr d_eps_p - sqrt(2) eta_bar
    // |dev d_eps_p|, is separation (a void); on the cut-off plane that is the
    // whole plastic volume change, at the corner the cut-off's multiplier.
    const Voigt& e = out.plastic_strain_increment;
    const double tr = e.head<3>().sum();
    Voigt dev = e;
    dev.head<3>().array() -= tr / 3.0;
    const double dev_norm = std::sqrt(dev.head<3>().squaredNorm() + 0.5 * dev.tail<3>().squaredNorm());
    out.separation_strain_increment = std::max(0.0, tr - std::sqrt(2.0) * eta_bar_ * dev_norm);
  }
}

std::string DruckerPrager::parameters() const {
  const double deg = 180.0 / 3.14159265358979323846;
  const char* matches[3] = {"outer", "inner", "plane_strain"};
  return parameter_text(model(), {{"density", par_.density},
                                  {"youngs_modulus", par_.youngs_modulus},
                                  {"poisson_ratio", par_.poisson_ratio},
                                  {"friction_angle", par_.friction_angle * deg},
                                  {"dilatancy_angle", par_.dilatancy_angle * deg},
                                  {"cohesion", par_.cohesion},
                                  {"hardening_modulus", par_.hardening_modulus},
                                  {"tension_cutoff", par_.tension_cutoff}}) +
         ", mohr_coulomb_match: " + matches[static_cast<int>(par_.match)];
}

}  // namespace talus
