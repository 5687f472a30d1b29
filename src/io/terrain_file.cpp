#include "talus/io/terrain_file.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>

namespace talus {

std::vector<std::array<double, 2>> read_polyline(std::istream& in) {
  std::vector<std::array<double, 2>> vertices;
  std::string line, previous_x;
  for (int number = 1; std::getline(in, line); ++number) {
    const std::vector<std::string> f = split_fields(strip_comment(line), true);
    if (f.empty()) continue;
    if (f.size() != 2)
      throw TerrainError{number, "expected one vertex 'x height' (2 numbers), found " + std::to_string(f.size()) +
                                     " fields"};
    const double x = file_number(f[0], number, "x");
    const double z = file_number(f[1], number, "height");
    if (!vertices.empty() && !(x > vertices.back()[0]))
      throw TerrainError{number, "x must increase (" + f[0] + " after " + previous_x + ")"};
    vertices.push_back({x, z});
    previous_x = f[0];
  }
  if (in.bad()) throw TerrainError{0, "cannot read the file"};
  if (vertices.size() < 2)
    throw TerrainError{0, "needs at least 2 vertices 'x height' (found " + std::to_string(vertices.size()) + ")"};
  return vertices;
}

namespace {
std::string lower_case(std::string s) {
  for (char& ch : s) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return s;
}
}  // namespace

void read_height_map(std::istream& in, ObstacleConfig& o) {
  static const std::vector<std::string> known = {"ncols",     "nrows",     "xllcorner", "xllcenter",
                                                 "yllcorner", "yllcenter", "cellsize",  "nodata_value"};
  std::map<std::string, std::pair<double, std::string>> header;  // key -> value, as written
  std::string line;
  std::vector<std::string> f;
  int number = 0;
  bool data = false;
  while (std::getline(in, line)) {
    ++number;
    f = split_fields(line, false);
    if (f.empty()) continue;
    const std::string key = lower_case(f[0]);
    const bool word = std::isalpha(static_cast<unsigned char>(f[0][0])) && key != "nan" && key != "inf" &&
                      key != "infinity";
    if (!word) {
      data = true;
      break;
    }
    if (std::find(known.begin(), known.end(), key) == known.end())
      throw TerrainError{number, "unknown ESRI ASCII grid header key '" + f[0] +
                                     "' (known: ncols, nrows, xllcorner or xllcenter, yllcorner or yllcenter, "
                                     "cellsize, NODATA_value)"};
    if (f.size() != 2) throw TerrainError{number, "header line '" + f[0] + "' must hold one value"};
    if (header.count(key)) throw TerrainError{number, "header key '" + f[0] + "' is given twice"};
    header[key] = {file_number(f[1], number, f[0]), f[1]};
  }
  if (in.bad()) throw TerrainError{0, "cannot read the file"};
  for (const char* axis : {"x", "y"}) {
    const std::string corner = std::string(axis) + "llcorner", center = std::string(axis) + "llcenter";
    if (header.count(corner) && header.count(center))
      throw TerrainError{0, "the header gives both " + corner + " and " + center};
    if (!header.count(corner) && !header.count(center))
      throw TerrainError{0, "the header has no " + corner + " (or " + center + ")"};
  }
  for (const char* key : {"ncols", "nrows", "cellsize"})
    if (!header.count(key))
      throw TerrainError{0, std::string("the header has no ") + key + " (an ESRI ASCII grid starts with ncols, "
                                                                      "nrows, xllcorner, yllcorner, cellsize)"};
  int count[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    const char* key = k == 0 ? "ncols" : "nrows";
    const double v = header[key].first;
    if (!(v == std::floor(v) && v >= 2 && v <= 1e8))
      throw TerrainError{0, std::string(key) + " = " + header[key].second + " must be a whole number from 2 to 1e8"};
    count[k] = static_cast<int>(v);
  }
  const int nx = count[0], ny = count[1];
  const double spacing = header["cellsize"].first;
  if (!(spacing > 0)) throw TerrainError{0, "cellsize = " + header["cellsize"].second + " must be > 0"};
  const bool has_nodata = header.count("nodata_value") > 0;
  const double nodata = has_nodata ? header["nodata_value"].first : 0.0;

  std::vector<double> rows;  // north row first, as in the file
  int row = 0;
  for (bool first = true; data; first = false) {
    if (!first) {  // the first data line is already split
      if (!std::getline(in, line)) break;
      ++number;
      f = split_fields(line, false);
      if (f.empty()) continue;
    }
    if (row == ny) throw TerrainError{number, "more than nrows = " + std::to_string(ny) + " rows of heights"};
    if (static_cast<int>(f.size()) != nx)
      throw TerrainError{number, "row " + std::to_string(row + 1) + " has " + std::to_string(f.size()) +
                                     " heights, ncols = " + std::to_string(nx)};
    for (int i = 0; i < nx; ++i) {
      const std::string where = "height in row " + std::to_string(row + 1) + ", column " + std::to_string(i + 1);
      const double z = file_number(f[i], number, where);
      if (has_nodata && z == nodata)
        throw TerrainError{number, "the " + where + " is the NODATA_value " + f[i] +
                                       ": the height map must have a height everywhere"};
      rows.push_back(z);
    }
    ++row;
  }
  if (in.bad()) throw TerrainError{0, "cannot read the file"};
  if (row != ny)
    throw TerrainError{0, std::to_string(row) + " rows of heights, but nrows = " + std::to_string(ny)};

  o.map_nx = nx;
  o.map_ny = ny;
  o.map_spacing = spacing;
  o.map_origin[0] = header.count("xllcenter") ? header["xllcenter"].first : header["xllcorner"].first + 0.5 * spacing;
  o.map_origin[1] = header.count("yllcenter") ? header["yllcenter"].first : header["yllcorner"].first + 0.5 * spacing;
  o.heights.assign(static_cast<std::size_t>(nx) * ny, 0.0);
  for (int r = 0; r < ny; ++r)  // file row r is y index j = ny - 1 - r (j = 0 the southmost)
    for (int i = 0; i < nx; ++i)
      o.heights[static_cast<std::size_t>(ny - 1 - r) * nx + i] = rows[static_cast<std::size_t>(r) * nx + i];
}

}  // namespace talus
