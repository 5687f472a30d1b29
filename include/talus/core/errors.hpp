#pragma once
// Error types and the PETSc error-code bridge.
//
// talus code is C++ and reports failure by exception; PETSc reports by error
// code. TALUS_PETSC turns a non-zero code into talus::PetscFailure, and
// petsc_callback() turns an exception escaping a PETSc callback (residual,
// Jacobian) back into an error code so that PETSc can unwind its own stack.
#include <petscsys.h>

#include <stdexcept>
#include <string>

namespace talus {

// A problem with the user's case file or command line: exit code 2, nothing written.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A numerical failure that the run cannot recover from (NaN, no convergence
// after every cut-back, a particle leaving the grid through a free face).
class SimulationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A result file (VTK, CSV, checkpoint) that could not be written: a full
// disk, a file-size limit, a lost permission. Exit code 4; the files written
// before, and the last checkpoint, are left intact.
class OutputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class PetscFailure : public std::runtime_error {
 public:
  PetscFailure(PetscErrorCode code, const char* call, const char* file, int line);
  PetscErrorCode code() const { return code_; }

 private:
  PetscErrorCode code_;
};

// Runs `body` inside a PETSc callback and converts exceptions into an error code.
template <class Body>
PetscErrorCode petsc_callback(Body&& body) noexcept {
  try {
    body();
  } catch (const PetscFailure& e) {
    return e.code();
  } catch (const std::exception& e) {
    (void)PetscError(PETSC_COMM_SELF, __LINE__, "talus callback", __FILE__, PETSC_ERR_LIB,
                     PETSC_ERROR_INITIAL, "%s", e.what());
    return PETSC_ERR_LIB;
  }
  return 0;
}

}  // namespace talus

#define TALUS_PETSC(call)                                                   \
  do {                                                                      \
    const PetscErrorCode talus_ierr_ = (call);                              \
    if (talus_ierr_) throw ::talus::PetscFailure(talus_ierr_, #call, __FILE__, __LINE__); \
  } while (0)
