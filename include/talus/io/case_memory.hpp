#pragma once
// How much memory a case needs, estimated from the case file before
// anything is allocated (docs/case_file.md#grid-required), and the check
// against grid.memory_limit_gb.
#include "talus/io/config.hpp"
#include "talus/io/yaml_section.hpp"

namespace talus {

// Basis functions (grid points) of the case's grid.
double grid_points(const CaseConfig& c);
// This machine's physical memory (the default of grid.memory_limit_gb).
double physical_memory_gb();
// Fails on the grid section's cell_size (an input error naming the estimate)
// when the case needs more than grid.memory_limit_gb.
void check_case_memory(YamlSection& root, const CaseConfig& c);

}  // namespace talus
