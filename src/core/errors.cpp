#include "talus/core/errors.hpp"

namespace talus {

PetscFailure::PetscFailure(PetscErrorCode code, const char* call, const char* file, int line)
    : std::runtime_error(std::string("PETSc error ") + std::to_string(code) + " in " + call +
                         " (" + file + ":" + std::to_string(line) + ")"),
      code_(code) {}

}  // namespace talus
