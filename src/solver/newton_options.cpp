// The solver options checked before a run writes anything
// (NewtonSolver::options_read_by_no_configuration, docs/command_line.md#petsc-options):
// a throwaway solver configured in a copy of the options database.
#include <cerrno>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>
#include <utility>
#include <vector>

#include "talus/solver/newton.hpp"
#include "newton_option_readers.hpp"
#include "talus/solver/petsc_options.hpp"

namespace talus {

namespace {

// The first PETSc error message of a failed call (PETSc's own handler would
// print a trace; this one keeps the message for an input error).
PetscErrorCode keep_message(MPI_Comm, int, const char*, const char*, PetscErrorCode code, PetscErrorType type,
                            const char* message, void* context) {
  auto* kept = static_cast<std::string*>(context);
  if (type == PETSC_ERROR_INITIAL && kept->empty() && message) *kept = message;
  return code;
}

// The -talus_ options of the global database not read so far, as name/value pairs.
std::vector<std::pair<std::string, std::string>> unread_talus_options() {
  std::vector<std::pair<std::string, std::string>> left;
  for (auto& option : unused_petsc_options())
    if (option.first.rfind("talus_", 0) == 0) left.push_back(std::move(option));
  return left;
}

// Read by PETSc only when the solver is set up on a matrix, when it solves
// or when it is needed: the sub-solvers of block Jacobi, ASM and multigrid,
// field splits, the viewers and reasons printed after a solve, the Jacobian
// test, the LU fallback after a failed linear solve (NewtonSolver::solve),
// the factorization packages' own options (read when they factor).
bool read_at_setup(const std::string& name) {
  for (const char* part : {"sub_", "mg_levels_", "mg_coarse_", "fieldsplit_", "talus_fallback_", "view",
                           "converged_reason", "test_", "mat_mumps_", "mat_superlu_", "mat_umfpack_", "mat_klu_"})
    if (name.find(part) != std::string::npos) return true;
  return false;
}

// A small nonlinear system of the Jacobian's kind (blocks of dim x dim,
// block tridiagonal, nonsymmetric): F(x) = A x + x^3 / 10 - 1. Solving it
// once with the configured solver makes PETSc check what it checks only
// when it sets up or solves (a factorization's fill and ordering, a Krylov
// method's side and norm, a line search or solver type that needs what
// talus does not give it), so that such an option is refused before the run
// instead of stopping it at its first step.
struct Rehearsal {
  int dim = 2;
  PetscInt first = 0;         // this rank's first block (global)
  // Coupled among themselves only, not across ranks; enough unknowns for
  // every Krylov method's start-up.
  PetscInt local_blocks = 64;
};

PetscErrorCode rehearsal_fill(const Rehearsal& r, Mat P, const PetscScalar* x) {
  PetscCall(MatZeroEntries(P));
  for (PetscInt b = r.first; b < r.first + r.local_blocks; ++b)
    for (int c = 0; c < r.dim; ++c) {
      const PetscInt row = b * r.dim + c;
      const PetscScalar xi = x ? x[(b - r.first) * r.dim + c] : 0.0;
      PetscCall(MatSetValue(P, row, row, 4.0 + 0.3 * xi * xi, INSERT_VALUES));
      if (c + 1 < r.dim) PetscCall(MatSetValue(P, row, row + 1, 0.5, INSERT_VALUES));
      if (b > r.first) PetscCall(MatSetValue(P, row, row - r.dim, -1.0, INSERT_VALUES));
      if (b + 1 < r.first + r.local_blocks) PetscCall(MatSetValue(P, row, row + r.dim, -1.0, INSERT_VALUES));
    }
  PetscCall(MatAssemblyBegin(P, MAT_FINAL_ASSEMBLY));
  return MatAssemblyEnd(P, MAT_FINAL_ASSEMBLY);
}

PetscErrorCode rehearsal_residual(SNES, Vec x, Vec f, void* context) {
  const auto& r = *static_cast<const Rehearsal*>(context);
  const PetscScalar* xa;
  PetscScalar* fa;
  PetscCall(VecGetArrayRead(x, &xa));
  PetscCall(VecGetArray(f, &fa));
  // Rows of A x from this rank's entries alone (its blocks couple only
  // among themselves).
  for (PetscInt k = 0; k < r.local_blocks * r.dim; ++k) {
    const int c = static_cast<int>(k % r.dim);
    PetscScalar v = 4.0 * xa[k] + (c + 1 < r.dim ? 0.5 * xa[k + 1] : 0.0);
    if (k >= r.dim) v -= xa[k - r.dim];
    if (k + r.dim < r.local_blocks * r.dim) v -= xa[k + r.dim];
    fa[k] = v + 0.1 * xa[k] * xa[k] * xa[k] - 1.0;
  }
  PetscCall(VecRestoreArrayRead(x, &xa));
  return VecRestoreArray(f, &fa);
}

PetscErrorCode rehearsal_jacobian(SNES, Vec x, Mat J, Mat P, void* context) {
  const auto& r = *static_cast<const Rehearsal*>(context);
  const PetscScalar* xa;
  PetscCall(VecGetArrayRead(x, &xa));
  PetscCall(rehearsal_fill(r, P, xa));
  PetscCall(VecRestoreArrayRead(x, &xa));
  if (J != P) {
    PetscCall(MatAssemblyBegin(J, MAT_FINAL_ASSEMBLY));
    PetscCall(MatAssemblyEnd(J, MAT_FINAL_ASSEMBLY));
  }
  return 0;
}

// One solve of the rehearsal system with `snes` as configured, its matrix of
// `type` with the options' -talus_mat_type. Each rank holds its own blocks,
// uncoupled from the other ranks' (a block-diagonal matrix across ranks), so
// that the residual needs no communication.
PetscErrorCode print_nothing(FILE*, const char[], va_list) { return 0; }

void rehearse_solve(MPI_Comm comm, SNES snes, MatType type, int dim) {
  Rehearsal r;
  r.dim = dim;
  const PetscInt n = r.local_blocks * dim;
  Mat P = nullptr;
  Vec x = nullptr, f = nullptr;
  // The user's monitors, converged reasons and views print nothing for the
  // rehearsal: everything PETSc prints goes through PetscVFPrintf (its
  // errors do not, and are kept by the error handler).
  const auto printer = PetscVFPrintf;
  PetscVFPrintf = print_nothing;
  const auto cleanup = [&] {
    PetscVFPrintf = printer;
    MatDestroy(&P);
    VecDestroy(&x);
    VecDestroy(&f);
  };
  try {
    TALUS_PETSC(MatCreate(comm, &P));
    TALUS_PETSC(MatSetSizes(P, n, n, PETSC_DETERMINE, PETSC_DETERMINE));
    TALUS_PETSC(MatSetBlockSize(P, dim));
    TALUS_PETSC(MatSetType(P, type));
    TALUS_PETSC(MatSetOptionsPrefix(P, "talus_"));
    TALUS_PETSC(MatSetFromOptions(P));
    std::vector<PetscInt> d_nnz(static_cast<std::size_t>(r.local_blocks), 3), o_nnz(d_nnz.size(), 0);
    TALUS_PETSC(MatXAIJSetPreallocation(P, dim, d_nnz.data(), o_nnz.data(), nullptr, nullptr));
    PetscInt row_start = 0;
    TALUS_PETSC(MatGetOwnershipRange(P, &row_start, nullptr));
    r.first = row_start / dim;
    TALUS_PETSC(MatCreateVecs(P, &x, &f));
    TALUS_PETSC(VecSet(x, 0.0));
    TALUS_PETSC(SNESSetFunction(snes, f, rehearsal_residual, &r));
    TALUS_PETSC(SNESSetJacobian(snes, P, P, rehearsal_jacobian, &r));
    // PETSc's own test: the rehearsal is about the options, not the balance.
    TALUS_PETSC(SNESSetConvergenceTest(snes, SNESConvergedDefault, nullptr, nullptr));
    TALUS_PETSC(SNESSolve(snes, nullptr, x));
  } catch (...) {
    cleanup();
    throw;
  }
  cleanup();
}

}  // namespace

template <int dim>
std::vector<std::string> NewtonSolver<dim>::options_read_by_no_configuration(
    MPI_Comm comm, PetscInt direct_limit, double max_unknowns, const std::map<std::string, std::string>* where) {
  const auto given = unread_talus_options();
  if (given.empty()) return {};
  // Configure a throwaway solver, below and above the direct limit, in a
  // database that holds `options` only; returns the options it left unread,
  // or throws with PETSc's message if PETSc refused a value.
  auto rehearse = [&](const std::vector<std::pair<std::string, std::string>>& options, std::string* refused) {
    PetscOptions copy = nullptr;
    TALUS_PETSC(PetscOptionsCreate(&copy));
    for (const auto& [name, value] : options)
      TALUS_PETSC(PetscOptionsSetValue(copy, ("-" + name).c_str(), value.empty() ? nullptr : value.c_str()));
    TALUS_PETSC(PetscOptionsPush(copy));
    TALUS_PETSC(PetscPushErrorHandler(keep_message, refused));
    std::vector<std::pair<std::string, std::string>> left;
    bool failed = false;
    std::exception_ptr other;
    try {
      NewtonSolver<dim> rehearsal(comm, direct_limit, 1.0);
      for (const PetscInt unknowns : {PetscInt(dim), direct_limit + 1}) {
        TALUS_PETSC(SNESCreate(comm, &rehearsal.snes_));
        rehearsal.configure(unknowns);
        if (unknowns <= direct_limit || max_unknowns > static_cast<double>(direct_limit))
          rehearse_solve(comm, rehearsal.snes_, rehearsal.matrix_type(), dim);
        TALUS_PETSC(SNESDestroy(&rehearsal.snes_));
      }
      Mat matrix = nullptr;
      TALUS_PETSC(MatCreate(comm, &matrix));
      TALUS_PETSC(MatSetSizes(matrix, PETSC_DECIDE, PETSC_DECIDE, dim, dim));
      TALUS_PETSC(MatSetOptionsPrefix(matrix, "talus_"));
      TALUS_PETSC(MatSetFromOptions(matrix));
      TALUS_PETSC(MatDestroy(&matrix));
      left = unread_talus_options();
    } catch (const PetscFailure&) {
      failed = true;
    } catch (...) {
      other = std::current_exception();  // an InputError of talus's own options: after clean-up
    }
    PetscPopErrorHandler();
    PetscOptionsPop();
    PetscOptionsDestroy(&copy);
    if (other) std::rethrow_exception(other);
    if (failed && refused->empty()) *refused = "refused";
    return left;
  };
  std::string refused;
  const auto left = rehearse(given, &refused);
  if (!refused.empty()) {
    // Which option: each one alone.
    for (const auto& option : given) {
      std::string why;
      rehearse({option}, &why);
      if (why.empty()) continue;
      std::string named = "PETSc option -" + option.first + (option.second.empty() ? "" : " " + option.second);
      if (where) {  // set in the case file (the command line would win, under the same name)
        const auto set = where->find(option.first.substr(6));
        if (set != where->end()) named = set->second + " = " + option.second + ": " + named;
      }
      throw InputError(named + ": PETSc does not accept it (" + why + ")");
    }
    throw InputError("PETSc options: PETSc does not accept them together (" + refused + ")");
  }
  std::vector<std::string> unread;
  for (const auto& [name, value] : left)
    if (!read_at_setup(name)) unread.push_back(name);
  return unread;
}

template std::vector<std::string> NewtonSolver<2>::options_read_by_no_configuration(
    MPI_Comm, PetscInt, double, const std::map<std::string, std::string>*);
template std::vector<std::string> NewtonSolver<3>::options_read_by_no_configuration(
    MPI_Comm, PetscInt, double, const std::map<std::string, std::string>*);

// A talus-specific count option -talus_<name> (an integer in [0, 1e6]),
// read once, before the run writes anything. Parsed here: PETSc's own parser
// would fail as an internal error instead of a clear input error.
namespace {

// The text of -talus_<name>, or false when the option is not given.
bool option_text(const char* name, char (&text)[64]) {
  PetscBool given = PETSC_FALSE;
  TALUS_PETSC(PetscOptionsGetString(nullptr, "talus_", (std::string("-") + name).c_str(), text, sizeof text, &given));
  return given;
}

}  // namespace

void set_right_gmres(KSP ksp, PetscReal rtol, PetscInt max_it) {
  TALUS_PETSC(KSPSetType(ksp, KSPGMRES));
  TALUS_PETSC(KSPSetPCSide(ksp, PC_RIGHT));
  TALUS_PETSC(KSPSetTolerances(ksp, rtol, PETSC_DEFAULT, PETSC_DEFAULT, max_it));
}

void set_inexact_newton(SNES snes) {
  TALUS_PETSC(SNESKSPSetUseEW(snes, PETSC_TRUE));
  TALUS_PETSC(SNESKSPSetParametersEW(snes, 2, 1e-8, 1e-2, PETSC_DEFAULT, PETSC_DEFAULT, PETSC_DEFAULT, PETSC_DEFAULT));
}

bool adaptive_first_tolerance(SNES snes) {
  PetscBool ew = PETSC_FALSE, given = PETSC_FALSE;
  TALUS_PETSC(SNESKSPGetUseEW(snes, &ew));
  TALUS_PETSC(PetscOptionsHasName(nullptr, "talus_", "-snes_ksp_ew_rtol0", &given));
  return ew && !given;
}

void choose_first_tolerance(SNES snes, std::size_t plastic_particles_here) {
  PetscInt iteration = 0;
  TALUS_PETSC(SNESGetIterationNumber(snes, &iteration));
  if (iteration != 0) return;
  long here = static_cast<long>(plastic_particles_here), plastic = 0;
  MPI_Allreduce(&here, &plastic, 1, MPI_LONG, MPI_SUM, PetscObjectComm(reinterpret_cast<PetscObject>(snes)));
  TALUS_PETSC(SNESKSPSetParametersEW(snes, PETSC_DEFAULT, plastic > 0 ? 1e-4 : 1e-8, PETSC_DEFAULT, PETSC_DEFAULT,
                                     PETSC_DEFAULT, PETSC_DEFAULT, PETSC_DEFAULT));
}

void default_block_option(const char* name, const std::string& value) {
  PetscBool given = PETSC_FALSE, other_pc = PETSC_FALSE;
  TALUS_PETSC(PetscOptionsHasName(nullptr, "talus_", ("-" + std::string(name)).c_str(), &given));
  TALUS_PETSC(PetscOptionsHasName(nullptr, "talus_", "-pc_type", &other_pc));
  if (!given && !other_pc) TALUS_PETSC(PetscOptionsSetValue(nullptr, ("-talus_" + std::string(name)).c_str(), value.c_str()));
}

void guard_superlu_ilu(PC pc) {
  PetscBool ilu = PETSC_FALSE;
  TALUS_PETSC(PetscObjectTypeCompare(reinterpret_cast<PetscObject>(pc), PCILU, &ilu));
  MatSolverType package = nullptr;
  if (ilu) TALUS_PETSC(PCFactorGetMatSolverType(pc, &package));
  if (!package || std::strcmp(package, MATSOLVERSUPERLU) != 0) return;
  char text[64] = "";
  if (!option_text("mat_superlu_rowperm", text))
    TALUS_PETSC(PetscOptionsSetValue(nullptr, "-talus_mat_superlu_rowperm", "NOROWPERM"));
  else if (std::strcmp(text, "NOROWPERM") != 0)
    throw InputError("PETSc option -talus_mat_superlu_rowperm: '" + std::string(text) +
                     "' needs MC64, which this SuperLU does not have; its incomplete LU takes NOROWPERM only");
}

PetscInt count_option(const char* name, PetscInt fallback) {
  char text[64] = "";
  if (!option_text(name, text)) return fallback;
  char* end = nullptr;
  errno = 0;
  const long value = std::strtol(text, &end, 10);
  if (end == text || *end != '\0' || errno == ERANGE || value < 0 || value > 1000000)
    throw InputError("PETSc option -talus_" + std::string(name) + ": expected an integer in [0, 1000000], got '" +
                     std::string(text) + "'");
  return static_cast<PetscInt>(value);
}

// A talus-specific real option -talus_<name> in [lower, upper], read once,
// before the run writes anything.
double real_option(const char* name, double fallback, double lower, double upper) {
  char text[64] = "";
  if (!option_text(name, text)) return fallback;
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(text, &end);
  if (end == text || *end != '\0' || errno == ERANGE || !(value >= lower && value <= upper))
    throw InputError("PETSc option -talus_" + std::string(name) + ": expected a number in [" + std::to_string(lower) +
                     ", " + std::to_string(upper) + "], got '" + std::string(text) + "'");
  return value;
}

// A talus-specific choice option -talus_<name> (one of `choices`, the first
// the default), read once, before the run writes anything.
std::string choice_option(const char* name, const std::vector<std::string>& choices) {
  char text[64] = "";
  if (!option_text(name, text)) return choices.front();
  for (const std::string& c : choices)
    if (c == text) return c;
  std::string list;
  for (const std::string& c : choices) list += (list.empty() ? "" : ", ") + c;
  throw InputError("PETSc option -talus_" + std::string(name) + ": expected one of " + list + ", got '" +
                   std::string(text) + "'");
}

void set_newton(SNES snes, PetscInt max_it, SNESLineSearchType line_search_type) {
  TALUS_PETSC(SNESSetType(snes, SNESNEWTONLS));
  TALUS_PETSC(SNESSetTolerances(snes, 0.0, 0.0, 0.0, max_it, PETSC_DEFAULT));
  SNESLineSearch line_search;
  TALUS_PETSC(SNESGetLineSearch(snes, &line_search));
  TALUS_PETSC(SNESLineSearchSetType(line_search, line_search_type));
  // Backtracking by quadratic fits, not PETSc's cubic default: in a crawl
  // the merit rises steeply past one plastic particle's kink and then
  // flattens, and the cubic through that plateau picks lambda ~ 0.02 where
  // the quadratic picks ~ 0.05-0.1 (docs/solver.md#the-backtracking-order).
  if (std::string(line_search_type) == SNESLINESEARCHBT)
    TALUS_PETSC(SNESLineSearchSetOrder(line_search, SNES_LINESEARCH_ORDER_QUADRATIC));
}

}  // namespace talus
