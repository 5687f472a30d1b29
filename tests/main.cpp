// Catch2 runner shared by every test binary: PETSc is initialised around the
// session (with argc = 1, so that PETSc never sees Catch's arguments).
#define CATCH_CONFIG_RUNNER
#include <petscsys.h>

#include <catch2/catch.hpp>

int main(int argc, char** argv) {
  int petsc_argc = 1;
  if (PetscInitialize(&petsc_argc, &argv, nullptr, nullptr)) return 1;
  const int result = Catch::Session().run(argc, argv);
  PetscFinalize();
  return result;
}
