// The equilibrium stage (docs/equilibrium.md): before the run, gravity is
// applied quasi-statically to the bodies in their initial configuration, so
// that the dynamic run starts from stresses that carry their weight instead
// of from a stress-free state that would first fall and ring.
//
// Each stage step is one implicit step (theta = 1) from rest with a step h_s
// so long that inertia is negligible: M u / h_s^2 + f_int(sigma^n + C eps(u))
// = f_grav, the static balance regularized by M / h_s^2 ~ (T / 2 pi h_s)^2 of
// the stiffness for a mode of period T. The solution's stresses are kept;
// the particles are not moved (u is the response of the initial geometry,
// as in the gravity-loading step of geotechnical codes). The next stage step
// removes the residual inertia of the last; the stage ends when a step moves
// no stress by more than `tolerance` of the largest stress.
#include "talus/simulation.hpp"

#include <iomanip>
#include <memory>

#include "talus/io/yaml_section.hpp"
#include "talus/materials/elastic_part.hpp"

namespace talus {

template <int dim>
void Simulation<dim>::equilibrate(RunSummary& summary, std::ostream* progress) {
  const EquilibriumConfig& q = config_.equilibrium;
  int rank;
  MPI_Comm_rank(comm_, &rank);

  // The stage's laws, put back however the stage ends (`contact: stick` is
  // applied in advance()).
  // The stage is elastic: each law's elastic part. From a stress-free state
  // a cohesionless law has no stiffness where the stress is at its apex (the
  // free surface), and without inertia the static Newton system is singular
  // there (measured: the linear solve diverges, also when the stage
  // continues with the case's laws from the elastic equilibrium,
  // docs/equilibrium.md). The run's first steps return stresses above the
  // yield surface to it.
  std::vector<std::unique_ptr<Material>> elastic_parts;
  std::vector<const Material*> stage_laws = materials_;
  for (auto& law : stage_laws) {
    elastic_parts.push_back(std::make_unique<ElasticPart>(*law));
    law = elastic_parts.back().get();
  }
  struct Restore {
    Simulation& s;
    std::vector<const Material*> laws;
    ~Restore() {
      s.materials_ = laws;
      s.equilibrium_stage_ = false;
      // The run's first step builds its solver for its own laws and contact.
      s.newton_->rebuild_next_step();
    }
  } restore{*this, materials_};
  materials_ = stage_laws;
  equilibrium_stage_ = true;
  newton_->rebuild_next_step();

  const double cell = grid_->cell_size();
  // The unbalance at rest U0 of each stage step's start (the stresses so far
  // against gravity, relative to the weight: Newton's U at its initial
  // guess). A stage whose U0 stops falling while small has balanced
  // everything the particles support: what is left is the weight of grid
  // points without stiffness (a B-spline's far tail at a body's edge), which
  // no further step balances (docs/equilibrium.md#limits).
  constexpr double stalled_unbalance = 1e-3, stalled_ratio = 0.5;
  double last_start = std::numeric_limits<double>::infinity();
  bool stalled = false;
  for (int k = 1; k <= q.max_steps; ++k) {
    const StepReport r = advance(q.step);
    summary.equilibrium_newton_iterations += r.newton.iterations;
    if (!r.converged)
      throw SimulationError("the equilibrium stage did not converge in its step " + std::to_string(k) + " (" +
                            r.newton.reason + "): with `contact: case` a body may have no equilibrium on its "
                            "obstacles (a slope steeper than its friction allows); use `contact: stick`, or drop the "
                            "stage (docs/equilibrium.md)");
    ++summary.equilibrium_steps;
    summary.equilibrium_gravity_work += stage_gravity_work_;
    summary.equilibrium_last_stress_change = stage_stress_change_;
    const double start = r.newton.unbalances.empty() ? 0.0 : r.newton.unbalances.front();
    summary.equilibrium_unbalance = start;
    if (progress && rank == 0)
      *progress << "equilibrium " << std::setw(3) << k << "  newton " << r.newton.iterations << "  unbalance "
                << std::scientific << std::setprecision(1) << r.newton.unbalance << "  start unbalance "
                << start << "  stress change "
                << std::setprecision(2) << stage_stress_change_ << "  largest displacement " << stage_displacement_ / cell
                << " cells  gravity work " << std::setprecision(4)
                << stage_gravity_work_ << std::defaultfloat << std::setprecision(6) << "\n";
    if (stage_stress_change_ <= q.tolerance) break;
    if (start <= stalled_unbalance && start > stalled_ratio * last_start) {
      stalled = true;
      break;
    }
    last_start = start;
  }
  if (stalled && progress && rank == 0)
    *progress << "  the equilibrium stage ends after " << summary.equilibrium_steps
              << " steps: its unbalance at rest, " << std::scientific << std::setprecision(2)
              << summary.equilibrium_unbalance << std::defaultfloat << std::setprecision(6)
              << " of the weight, no longer falls (the weight of grid points that no particle supports; "
                 "docs/equilibrium.md#limits)\n";
  if (!stalled && summary.equilibrium_last_stress_change > q.tolerance && progress && rank == 0)
    *progress << "  warning: the equilibrium stage ended after equilibrium.max_steps = " << q.max_steps
              << " steps with a last stress change of " << summary.equilibrium_last_stress_change
              << " of the largest stress, above equilibrium.tolerance = " << q.tolerance << "\n";
  // The run's energy balance starts from the equilibrium state.
  initial_energy_ = std::numeric_limits<double>::quiet_NaN();
  last_acceleration_.clear();
}

template class Simulation<2>;
template class Simulation<3>;

}  // namespace talus
