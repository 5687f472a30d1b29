#pragma once
// Readers of talus's own solver options (-talus_<name>), read once before
// the run writes anything (defined in newton_options.cpp).
#include <petscsys.h>

#include <string>
#include <vector>

namespace talus {

// An integer in [0, 1e6]; `fallback` when not given.
PetscInt count_option(const char* name, PetscInt fallback);
// One of `choices`, the first when not given.
std::string choice_option(const char* name, const std::vector<std::string>& choices);

}  // namespace talus
