// The sections of a case file that configure the run rather than the
// model: the particle-grid transfers, the equilibrium stage, the solver and
// the ranks' balance
// (docs/case_file.md).
#include "talus/io/run_config.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <petscsys.h>

#include "talus/solver/petsc_options.hpp"

namespace talus {

void parse_transfer(YamlSection& t, CaseConfig& c) {
  c.transfer.scheme = t.choice("scheme", {"apic", "flip"}, "apic") == "apic" ? TransferScheme::apic
                                                                                : TransferScheme::flip;
  c.transfer.flip_blend = t.real("flip_blend", 0.99);
  if (!(c.transfer.flip_blend >= 0 && c.transfer.flip_blend <= 1)) t.fail_value("flip_blend", "must be in [0, 1]");
  c.transfer.packing_correction = t.real("packing_correction", TransferConfig{}.packing_correction);
  if (!(c.transfer.packing_correction >= 0 && c.transfer.packing_correction <= 1))
    t.fail_value("packing_correction", "must be in [0, 1]");
  t.finish();
}

void parse_equilibrium(YamlSection& e, CaseConfig& c) {
  // The equilibrium stage (docs/equilibrium.md).
  EquilibriumConfig& q = c.equilibrium;
  q.enabled = true;
  q.stick = e.choice("contact", {"case", "stick"}, "case") == "stick";
  q.max_steps = e.integer("max_steps", q.max_steps);
  if (q.max_steps < 1 || q.max_steps > 1000) e.fail_value("max_steps", "must be in [1, 1000]");
  q.tolerance = e.real("tolerance", q.tolerance);
  if (!(q.tolerance >= 1e-12 && q.tolerance <= 1e-1)) e.fail_value("tolerance", "must be in [1e-12, 0.1]");
  // The inertia left in a stage step relative to the stiffness is about
  // (T / 2 pi step)^2 for a body's slowest mode of period T <~ 4 L / c_p:
  // 10 crossings of the grid leave ~1e-3 in the first step, and each
  // further step removes the same factor of what is left.
  double slowest = std::numeric_limits<double>::infinity();
  for (const MaterialConfig& m : c.materials)
    slowest = std::min(slowest, p_wave_speed(*m.law));
  double extent = 0.0;
  for (int a = 0; a < c.dim; ++a) extent = std::max(extent, c.grid.upper[a] - c.grid.lower[a]);
  q.step = e.has("step") ? e.positive("step", e.real("step")) : 10.0 * extent / slowest;
  if (!std::isfinite(q.step)) e.fail_value("step", "must be finite (give equilibrium.step in seconds)");
  e.finish();
}

void parse_solver(YamlSection& s, CaseConfig& c) {
  // The default is set before (parse_root: it follows the quadrature).
  c.solver.active_mass_ratio = s.real("active_mass_ratio", c.solver.active_mass_ratio);
  if (!(c.solver.active_mass_ratio >= 0 && c.solver.active_mass_ratio < 1))
    s.fail_value("active_mass_ratio", "must be in [0, 1)");
  c.solver.direct_solver_limit = s.integer("direct_solver_limit", SolverConfig::default_direct_solver_limit);
  if (c.solver.direct_solver_limit < 0)
    s.fail_value("direct_solver_limit", "must be >= 0");
  c.solver.balance_tolerance = s.real("balance_tolerance", 1e-8);
  if (!(c.solver.balance_tolerance >= 1e-15 && c.solver.balance_tolerance <= 1e-2))
    s.fail_value("balance_tolerance", "must be in [1e-15, 1e-2]");
  c.solver.ghost_penalty = s.real("ghost_penalty", c.solver.ghost_penalty);
  if (!(c.solver.ghost_penalty >= 0 && c.solver.ghost_penalty <= 10))
    s.fail_value("ghost_penalty", "must be in [0, 10]");
  if (c.solver.ghost_penalty > 0 && c.grid.shape == ShapeKind::linear)
    s.fail_value("ghost_penalty", "needs quadratic B-splines (grid.shape_function: quadratic_bspline); "
                                  "it is not defined for linear hats (0 turns it off)");
  const auto petsc_options = s.free_map("petsc_options");
  for (auto& [k, v] : petsc_options) {
    std::string key = k;
    if (!key.empty() && key[0] == '-') key.erase(0, 1);
    PetscBool petsc_ready = PETSC_FALSE;
    PetscInitialized(&petsc_ready);
    if (petsc_ready) {
      const std::string why = petsc_option_problem("talus_" + key, v, PETSC_COMM_SELF);
      if (!why.empty()) s.fail_value("petsc_options", key + ": " + v, why);
    }
    c.solver.petsc_options.emplace_back(key, v);
    // For a name that no solver configuration reads, found once PETSc is up.
    c.solver.petsc_option_where[key] = s.section("petsc_options").where(k);
  }
  s.finish();
}

void parse_parallel(YamlSection& q, CaseConfig& c) {
  c.parallel.balance = q.boolean("balance", true);
  c.parallel.imbalance_limit = q.real("imbalance_limit", 1.2);
  if (!(c.parallel.imbalance_limit >= 1.0 && c.parallel.imbalance_limit <= 1e6))
    q.fail_value("imbalance_limit", "must be in [1, 1e6] (largest over mean particles per rank)");
  q.finish();
}

}  // namespace talus
