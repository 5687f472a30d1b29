#include "talus/solver/petsc_options.hpp"

#include <petscksp.h>
#include <petscsnes.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "talus/core/errors.hpp"

namespace talus {

namespace {

// True if PETSc accepts `type` for a throwaway object of one class (created,
// typed with PETSc's error printing off, destroyed): so that the run does
// not stop with a PETSc error trace at its first step.
template <class Object, class Create, class SetType, class Destroy>
bool petsc_accepts(MPI_Comm comm, const std::string& type, Create create, SetType set_type, Destroy destroy) {
  Object object;
  TALUS_PETSC(create(comm, &object));
  PetscPushErrorHandler(PetscReturnErrorHandler, nullptr);
  const PetscErrorCode code = set_type(object, type.c_str());
  PetscPopErrorHandler();
  destroy(&object);
  return code == 0;
}

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}


}  // namespace

std::string petsc_option_problem(const std::string& name, const std::string& value, MPI_Comm comm) {
  // PETSc 3.18's pipelined CG (pipelcg) does not stop on the rehearsal's
  // nonsymmetric block system (docs/command_line.md#petsc-options): refused
  // before it can hang a run.
  if (ends_with(name, "ksp_type") && value == "pipelcg")
    return "PETSc's pipelined CG loops without end on talus's nonsymmetric systems (use gmres, bcgs, ...)";
  if (ends_with(name, "ksp_type"))
    return petsc_accepts<KSP>(comm, value, KSPCreate, KSPSetType, KSPDestroy)
               ? ""
               : "not a Krylov method of this PETSc (e.g. gmres, bcgs, preonly)";
  if (ends_with(name, "pc_type"))
    return petsc_accepts<PC>(comm, value, PCCreate, PCSetType, PCDestroy)
               ? ""
               : "not a preconditioner of this PETSc (e.g. ilu, bjacobi, lu, gamg)";
  if (ends_with(name, "linesearch_type"))
    return petsc_accepts<SNESLineSearch>(comm, value, SNESLineSearchCreate, SNESLineSearchSetType,
                                         SNESLineSearchDestroy)
               ? ""
               : "not a line search of this PETSc (e.g. bt, basic, l2, cp)";
  if (ends_with(name, "snes_type")) {
    // The solvers that need nothing but talus's residual and Jacobian. The
    // others need a DM's subdomains or levels (fas, nasm, aspin, patch), a
    // user's solve (shell, python, composite) or a coloring of an AIJ
    // matrix (ngs), and stop the run at its first step; aspin crashes even
    // when the type is set on an empty solver, so the list is checked
    // before PETSc sees the value.
    for (const char* supported : {"newtonls", "newtontr", "ngmres", "anderson", "qn", "ncg", "nrichardson", "ms",
                                  "ksponly", "vinewtonrsls", "vinewtonssls"})
      if (value == supported)
        return petsc_accepts<SNES>(comm, value, SNESCreate, SNESSetType, SNESDestroy)
                   ? ""
                   : "not a nonlinear solver of this PETSc (e.g. newtonls, newtontr)";
    return "not a nonlinear solver talus can drive (newtonls, newtontr, ngmres, anderson, qn, ncg, nrichardson, "
           "ms, ksponly, vinewtonrsls, vinewtonssls)";
  }
  if (ends_with(name, "mat_type")) {
    // The Jacobian is assembled by blocks into a preallocated (block) AIJ
    // matrix; other types (dense, SELL, IS, nest, shell, ...) are refused
    // by PETSc at the first step or crash it.
    for (const char* supported : {"aij", "baij", "seqaij", "seqbaij", "mpiaij", "mpibaij"})
      if (value == supported) return "";
    return "not a matrix type talus assembles (aij, baij)";
  }
  if (ends_with(name, "snes_mf_operator"))
    return "talus's Jacobian is exact; for products without the matrix use -talus_jacobian operator";
  if (ends_with(name, "linesearch_order")) {
    // bt fits quadratics (2) or cubics (3); PETSc stops at the first step
    // with any other order (docs/solver.md#the-backtracking-order).
    if (value != "2" && value != "3") return "expected 2 (quadratic) or 3 (cubic)";
    return "";
  }
  if (ends_with(name, "rtol") || ends_with(name, "atol") || ends_with(name, "stol") || ends_with(name, "divtol") ||
      ends_with(name, "_damping") || ends_with(name, "ew_rtol0") || ends_with(name, "ew_rtolmax") ||
      ends_with(name, "ew_gamma") || ends_with(name, "ew_alpha")) {
    // Tolerances: a number, finite and not negative (NaN would never stop).
    char* end = nullptr;
    const double x = std::strtod(value.c_str(), &end);
    if (value.empty() || *end != '\0' || !std::isfinite(x) || x < 0) return "expected a finite number >= 0";
  } else if (ends_with(name, "max_it") || ends_with(name, "max_funcs") || ends_with(name, "_restart") ||
             ends_with(name, "factor_levels") || ends_with(name, "max_linear_solve_fail")) {
    char* end = nullptr;
    errno = 0;
    const long n = std::strtol(value.c_str(), &end, 10);
    if (value.empty() || *end != '\0' || errno == ERANGE || n < 0 || n > 100000000L)
      return "expected an integer in [0, 1e8]";
  } else {
    // Any other number: finite. PETSc takes "nan" and "inf" for a real
    // option and would run with them (a NaN line-search bound, zero pivot
    // or GAMG threshold compares false everywhere).
    char* end = nullptr;
    const double x = std::strtod(value.c_str(), &end);
    if (!value.empty() && *end == '\0' && !std::isfinite(x)) return "expected a finite number";
  }
  return "";
}

std::vector<std::pair<std::string, std::string>> unused_petsc_options() {
  PetscInt count = 0;
  char** names = nullptr;
  char** values = nullptr;
  TALUS_PETSC(PetscOptionsLeftGet(nullptr, &count, &names, &values));
  std::vector<std::pair<std::string, std::string>> left;
  for (PetscInt k = 0; k < count; ++k) left.emplace_back(names[k], values[k] ? values[k] : "");
  TALUS_PETSC(PetscOptionsLeftRestore(nullptr, &count, &names, &values));
  return left;
}

void check_petsc_options(MPI_Comm comm) {
  // Every option given so far is still unused.
  for (const auto& [name, value] : unused_petsc_options()) {
    const std::string why = petsc_option_problem(name, value, comm);
    if (!why.empty()) throw InputError("PETSc option -" + name + " " + value + ": " + why);
  }
}

}  // namespace talus
