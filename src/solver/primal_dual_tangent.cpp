#include "talus/solver/primal_dual_tangent.hpp"

namespace talus {

template <int dim>
void CarriedStresses<dim>::begin_evaluation(std::size_t particles) {
  if (candidate_.size() != particles * size) {
    committed_.assign(particles * size, 0.0);
    candidate_.assign(particles * size, 0.0);
  }
  fresh_ = true;
}

template <int dim>
bool CarriedStresses<dim>::carried(std::size_t p, const Voigt& trial, Voigt& out) const {
  const double* c = committed_.data() + p * size;
  if (c[0] != generation_) return false;
  if (c[1] == 1.0) {
    out = trial;
    return true;
  }
  // sigma_k + S_k (trial - trial_k)
  const double* stress = c + 2;
  const double* trial_k = c + 2 + n;
  const double* S = c + 2 + 2 * n;
  double change[n];
  for (int j = 0; j < n; ++j) change[j] = trial[component(j)] - trial_k[j];
  out.setZero();
  for (int i = 0; i < n; ++i) {
    double value = stress[i];
    for (int j = 0; j < n; ++j) value += S[n * i + j] * change[j];
    out[component(i)] = value;
  }
  return true;
}

template <int dim>
void CarriedStresses<dim>::record_elastic(std::size_t p) {
  double* c = candidate_.data() + p * size;
  c[0] = generation_;
  c[1] = 1.0;
}

template <int dim>
void CarriedStresses<dim>::record(std::size_t p, const Voigt& stress, const Voigt& trial, const Tangent& sensitivity) {
  double* c = candidate_.data() + p * size;
  c[0] = generation_;
  c[1] = 2.0;
  for (int i = 0; i < n; ++i) {
    c[2 + i] = stress[component(i)];
    c[2 + n + i] = trial[component(i)];
    for (int j = 0; j < n; ++j) c[2 + 2 * n + n * i + j] = sensitivity(component(i), component(j));
  }
}

template <int dim>
void CarriedStresses<dim>::commit() {
  if (!fresh_) return;
  committed_.swap(candidate_);
  fresh_ = false;
}

template class CarriedStresses<2>;
template class CarriedStresses<3>;

namespace {
double squared_deviator_norm(const Voigt& s) {
  const double mean = s.head<3>().mean();
  return (s.head<3>().array() - mean).square().sum() + 2.0 * s.tail<3>().squaredNorm();
}
}  // namespace

bool carried_far_from(const Voigt& carried, const Voigt& stress) {
  // 10 %: on the reference column 0, 1e-3, 1e-2 and 0.1 gave 1,407, 1,410,
  // 1,423 and 1,420 Newton iterations; on the 3D landslide 1e-2 gave 937
  // and 0.1 886 (the consistent tangent 877). Most plastic particles then
  // skip the second return (docs/solver.md#the-primal-dual-tangent).
  constexpr double fraction = 0.1;
  return squared_deviator_norm(carried - stress) > fraction * fraction * squared_deviator_norm(stress);
}

void add_primal_dual_term(const Material& material, const Voigt& trial, const Voigt& carried,
                          const double* state_old, MaterialPointUpdate& update) {
  Voigt deviator = trial;
  deviator.head<3>().array() -= deviator.head<3>().mean();
  Voigt deviator_strain_like = deviator;  // a . strain_like(b) = a : b
  deviator_strain_like.tail<3>() *= 2.0;
  const double squared_norm = deviator.dot(deviator_strain_like);
  if (!(squared_norm > 0.0)) return;
  // T returned to the yield surface: the law's own return of T as a trial.
  MaterialPointUpdate feasible;
  feasible.stress_only = true;
  material.update(carried, Voigt::Zero(), state_old, nullptr, feasible);
  Voigt difference = update.stress - feasible.stress;
  difference.head<3>().array() -= difference.head<3>().mean();
  const Eigen::Matrix<double, 1, 6> row = deviator_strain_like.transpose() / squared_norm;
  update.trial_sensitivity += difference * row;
  update.tangent += difference * (row * material.elastic_stiffness());
}

}  // namespace talus
