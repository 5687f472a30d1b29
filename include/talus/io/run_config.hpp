#pragma once
// The sections of a case file that configure the run rather than the model
// (docs/case_file.md): `transfer`, `equilibrium`, `solver`, `parallel`. Each reads and
// checks its section into c; c's grid, time and materials are read.
#include "talus/io/config.hpp"
#include "talus/io/yaml_section.hpp"

namespace talus {

void parse_transfer(YamlSection& t, CaseConfig& c);
void parse_equilibrium(YamlSection& e, CaseConfig& c);
// c.solver.ghost_penalty holds its default for the grid's shape functions.
void parse_solver(YamlSection& s, CaseConfig& c);
void parse_parallel(YamlSection& q, CaseConfig& c);

}  // namespace talus
