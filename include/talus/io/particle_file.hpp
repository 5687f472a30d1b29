#pragma once
// Particle files of bodies (docs/case_file.md#particle-files): material points
// placed by another tool (a DEM difference, a mesh, a previous run), read when
// the case is loaded so that a bad file stops the run before the first step.
#include <istream>
#include <vector>

#include "talus/io/text_fields.hpp"

namespace talus {

// The particles of a file, in file order.
struct ParticleTable {
  std::vector<double> positions;   // dim per particle (m)
  std::vector<double> volumes;     // m^3 (m^2 per unit thickness in 2D)
  std::vector<double> velocities;  // dim per particle (m/s), or empty: no velocity columns
  std::vector<int> lines;          // each particle's line in the file
};

// A header line names the columns, then one particle per line; fields are
// separated by whitespace or commas; '#' starts a comment. Columns: x, y (and
// z in 3D) and volume are required; vx, vy (, vz) are optional, all or none;
// any order. Throws FileLineError on an unknown, repeated or missing column,
// a line with the wrong number of fields, a number that is not finite, a
// volume <= 0, or a file without particles.
ParticleTable read_particle_table(std::istream& in, int dim);

}  // namespace talus
