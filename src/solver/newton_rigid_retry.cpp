// The retries of a failed step with rigid bodies (docs/contact.md#rigid-bodies).
#include <cstring>

#include "talus/solver/newton.hpp"

namespace talus {

template <int dim>
NewtonReport NewtonSolver<dim>::retry_rigid(MomentumSystem<dim>& system, Start start, NewtonReport report) {
  // A rigid body's first step into contact overshoots (impulses of 1 / eps)
  // and bt then crawls: solve it again with l2. Only under Newton with bt (a
  // trust region has no line search: its line-search object has no type).
  SNESLineSearch line_search;
  SNESLineSearchType type = nullptr;
  PetscBool line_search_newton = PETSC_FALSE;
  TALUS_PETSC(PetscObjectTypeCompare(reinterpret_cast<PetscObject>(solving_snes()), SNESNEWTONLS, &line_search_newton));
  if (line_search_newton) {
    TALUS_PETSC(SNESGetLineSearch(solving_snes(), &line_search));
    TALUS_PETSC(SNESLineSearchGetType(line_search, &type));
  }
  if (type && std::strcmp(type, SNESLINESEARCHBT) == 0) {
    TALUS_PETSC(SNESLineSearchSetType(line_search, SNESLINESEARCHL2));
    report = retried(report, run_snes(system, start));
    TALUS_PETSC(SNESLineSearchSetType(line_search, SNESLINESEARCHBT));
    report.line_search_retry = true;
  }
  if (!report.converged) {
    // Then with the impulses' columns regularized (a larger compliance in
    // the Jacobian only): the Newton step into many new contact points no
    // longer overshoots by 1 / eps.
    system.set_rigid_jacobian_compliance(MomentumSystem<dim>::rigid_jacobian_compliance);
    report = retried(report, run_snes(system, start));
    report.regularized_retry = true;
  }
  return report;
}

template NewtonReport NewtonSolver<2>::retry_rigid(MomentumSystem<2>&, Start, NewtonReport);
template NewtonReport NewtonSolver<3>::retry_rigid(MomentumSystem<3>&, Start, NewtonReport);

}  // namespace talus
