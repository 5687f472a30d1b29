#pragma once
// Terrain files of obstacles (docs/case_file.md#terrain-files), read when the
// case is loaded so that a bad file stops the run before the first step.
#include <array>
#include <istream>
#include <string>
#include <vector>

#include "talus/contact/obstacle.hpp"
#include "talus/io/text_fields.hpp"

namespace talus {

// A problem in a terrain file: its line (0: the file as a whole) and what is wrong.
using TerrainError = FileLineError;

// 2D terrain: one vertex "x height" per line (whitespace or comma separated,
// '#' comments and blank lines allowed), x strictly increasing.
std::vector<std::array<double, 2>> read_polyline(std::istream& in);

// 3D terrain: an ESRI ASCII grid. Header lines "key value" (keys in any
// case): ncols, nrows, xllcorner | xllcenter, yllcorner | yllcenter,
// cellsize, optional NODATA_value; then nrows lines of ncols heights, the
// first one the northmost (largest y) row. Fills the height-map fields of o.
void read_height_map(std::istream& in, ObstacleConfig& o);

}  // namespace talus
