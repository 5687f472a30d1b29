// The case's solver options (docs/command_line.md#petsc-options): the case
// file's solver.petsc_options put into PETSc's database under the command
// line, their checks before a run writes anything, and the options the
// solver never read.
#include <cmath>
#include <map>
#include <set>
#include <string>

#include "talus/simulation.hpp"
#include "talus/solver/petsc_options.hpp"

namespace talus {

void apply_case_petsc_options(const CaseConfig& config) {
  // Which options the command line gave, from the list of options not used
  // yet: asking PETSc for one (PetscOptionsHasName) would mark it used, and
  // a used option escapes the checks of check_solver_options.
  std::set<std::string> given;
  for (const auto& option : unused_petsc_options()) given.insert(option.first);
  for (const auto& [key, value] : config.solver.petsc_options)
    if (!given.count("talus_" + key))  // the command line wins
      TALUS_PETSC(PetscOptionsSetValue(nullptr, ("-talus_" + key).c_str(), value.empty() ? nullptr : value.c_str()));
}

std::string unused_solver_options() {
  std::string list;
  for (const auto& [name, value] : unused_petsc_options()) {
    // Read only when they are needed: the LU retry after a failed linear
    // solve, the inner solver of a nonlinear preconditioner.
    if (name.rfind("talus_", 0) != 0 || name.rfind("talus_fallback_", 0) == 0) continue;
    list += (list.empty() ? "-" : ", -") + name;
  }
  return list;
}

template <int dim>
void check_solver_options(const CaseConfig& config, MPI_Comm comm) {
  // Values first (a type PETSc does not know, or one that would crash the
  // rehearsal below), then the rehearsal of the configurations.
  check_petsc_options(comm);
  // A bound on the unknowns: every grid function of every velocity field
  // (quadratic B-splines add one function per axis; domain quadrature none).
  double max_unknowns = static_cast<double>(dim) * config.contact.field_count;
  for (int a = 0; a < dim; ++a)
    max_unknowns *= std::ceil((config.grid.upper[a] - config.grid.lower[a]) / config.grid.cell_size) + 3.0;
  // Where the case file sets an option that is in force (the command line
  // wins under the same name: then the case file is not named).
  const auto unused = unused_petsc_options();
  const std::map<std::string, std::string> in_force(unused.begin(), unused.end());
  std::map<std::string, std::string> case_file_options;
  for (const auto& [key, value] : config.solver.petsc_options) {
    const auto given = in_force.find("talus_" + key);
    const auto where = config.solver.petsc_option_where.find(key);
    if (given != in_force.end() && given->second == value && where != config.solver.petsc_option_where.end())
      case_file_options[key] = where->second;
  }
  const std::vector<std::string> unread =
      NewtonSolver<dim>::options_read_by_no_configuration(comm, config.solver.direct_solver_limit, max_unknowns,
                                                          &case_file_options);
  if (unread.empty()) return;
  std::string list;
  for (const std::string& name : unread) {
    list += (list.empty() ? "-" : ", -") + name;
    // Named where the case file gives it (the command line would win, under the same name).
    const auto where = config.solver.petsc_option_where.find(name.substr(6));
    if (where != config.solver.petsc_option_where.end()) list += " (" + where->second + ")";
  }
  throw InputError((unread.size() == 1 ? "PETSc option " : "PETSc options ") + list +
                   ": read by no solver configuration of talus (misspelled? docs/solver.md lists the options; "
                   "-talus_ is the prefix of every solver option)");
}

template void check_solver_options<2>(const CaseConfig&, MPI_Comm);
template void check_solver_options<3>(const CaseConfig&, MPI_Comm);

}  // namespace talus
