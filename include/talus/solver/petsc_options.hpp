#pragma once
// Checks of PETSc option values before anything runs (docs/command_line.md#petsc-options).
#include <mpi.h>

#include <string>
#include <utility>
#include <vector>

namespace talus {

// Checks the values of the PETSc options given so far (command line and
// case file) before anything runs: object types (KSP, PC, SNES, line search,
// Mat) that this PETSc does not have, tolerances that are not finite numbers
// >= 0, iteration counts that are not integers. Throws InputError naming the
// option (docs/command_line.md#petsc-options).
void check_petsc_options(MPI_Comm comm);
// Why the PETSc option -name value is not valid ("" if it is); for the case
// file's solver.petsc_options, checked where the case is read.
std::string petsc_option_problem(const std::string& name, const std::string& value, MPI_Comm comm);
// The options of the global database that nothing has read yet, as (name
// without the dash, value) pairs. Unlike asking PETSc for one option, this
// does not mark them used (a used option escapes the checks above).
std::vector<std::pair<std::string, std::string>> unused_petsc_options();

}  // namespace talus
