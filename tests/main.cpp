// Catch2 runner shared by every test binary: PETSc is initialised around the
// session (with argc = 1, so that PETSc never sees Catch's arguments).
#define CATCH_CONFIG_RUNNER
#include <petscsys.h>

#include <catch2/catch.hpp>
#include <cstring>

namespace {
// Catch2's test discovery runs every binary at build time with a --list
// option. Listing runs no test, so it must not start MPI: a singleton
// MPI_Init_thread can fail under a parallel build (seen on CI), and the
// binary's tests then go missing from ctest (tests/test_inventory.py).
bool only_lists(int argc, char** argv) {
  for (int i = 1; i < argc; ++i)
    if (std::strncmp(argv[i], "--list", 6) == 0 || std::strcmp(argv[i], "-l") == 0 ||
        std::strcmp(argv[i], "-t") == 0)
      return true;
  return false;
}
}  // namespace

int main(int argc, char** argv) {
  if (only_lists(argc, argv)) return Catch::Session().run(argc, argv);
  int petsc_argc = 1;
  if (PetscInitialize(&petsc_argc, &argv, nullptr, nullptr)) return 1;
  const int result = Catch::Session().run(argc, argv);
  PetscFinalize();
  return result;
}
