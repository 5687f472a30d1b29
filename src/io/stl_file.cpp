#include "talus/io/stl_file.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <iterator>
#include <map>
#include <sstream>
#include <string>

namespace talus {

namespace {

// Adds a triangle, welding its corners by exact coordinates.
void add_triangle(TriangleMesh& mesh, std::map<std::array<double, 3>, int>& index,
                  const std::array<std::array<double, 3>, 3>& corners, int facet) {
  std::array<int, 3> t{};
  for (int k = 0; k < 3; ++k) {
    const auto [at, fresh] = index.emplace(corners[k], static_cast<int>(mesh.vertices.size()));
    if (fresh) mesh.vertices.push_back(corners[k]);
    t[k] = at->second;
  }
  if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) return;  // a sliver without area
  mesh.triangles.push_back(t);
  mesh.facet.push_back(facet);
}

TriangleMesh read_binary(const std::string& bytes, std::uint32_t count) {
  TriangleMesh mesh;
  std::map<std::array<double, 3>, int> index;
  for (std::uint32_t f = 0; f < count; ++f) {
    const char* record = bytes.data() + 84 + 50 * static_cast<std::size_t>(f);
    std::array<std::array<double, 3>, 3> corners{};
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) {
        float value;  // little-endian IEEE float32, as the format (and x86) stores it
        std::memcpy(&value, record + 12 + 12 * k + 4 * a, 4);
        if (!std::isfinite(value))
          throw FileLineError{0, "facet " + std::to_string(f + 1) + " has a coordinate that is not a finite number"};
        corners[k][a] = value;
      }
    add_triangle(mesh, index, corners, static_cast<int>(f + 1));
  }
  return mesh;
}

TriangleMesh read_ascii(const std::string& text) {
  TriangleMesh mesh;
  std::map<std::array<double, 3>, int> index;
  std::istringstream in(text);
  std::string line;
  std::array<std::array<double, 3>, 3> corners{};
  int corner_count = 0, facets = 0, loop_line = 0;
  bool in_loop = false;
  for (int number = 1; std::getline(in, line); ++number) {
    const std::vector<std::string> f = split_fields(line, false);
    if (f.empty()) continue;
    const std::string& word = f[0];
    if (word == "outer") {
      if (in_loop) throw FileLineError{number, "'outer loop' inside a loop (no 'endloop' since line " + std::to_string(loop_line) + ")"};
      in_loop = true;
      loop_line = number;
      corner_count = 0;
    } else if (word == "vertex") {
      if (!in_loop) throw FileLineError{number, "'vertex' outside an 'outer loop'"};
      if (f.size() != 4) throw FileLineError{number, "'vertex' needs 3 coordinates, found " + std::to_string(f.size() - 1)};
      if (corner_count == 3) throw FileLineError{number, "a facet with more than 3 vertices (STL facets are triangles)"};
      for (int a = 0; a < 3; ++a) corners[corner_count][a] = file_number(f[a + 1], number, "coordinate");
      ++corner_count;
    } else if (word == "endloop") {
      if (!in_loop) throw FileLineError{number, "'endloop' without 'outer loop'"};
      if (corner_count != 3)
        throw FileLineError{number, "the facet has " + std::to_string(corner_count) + " vertices (STL facets are triangles)"};
      in_loop = false;
      add_triangle(mesh, index, corners, ++facets);
    } else if (word != "solid" && word != "facet" && word != "endfacet" && word != "endsolid") {
      throw FileLineError{number, "unexpected '" + word + "' (an ASCII STL holds solid, facet normal, outer loop, vertex, "
                                                           "endloop, endfacet, endsolid)"};
    }
  }
  if (in_loop) throw FileLineError{loop_line, "the loop that starts here has no 'endloop'"};
  return mesh;
}

}  // namespace

TriangleMesh read_stl(std::istream& in) {
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw FileLineError{0, "cannot read the file"};
  if (bytes.size() >= 84) {
    std::uint32_t count;
    std::memcpy(&count, bytes.data() + 80, 4);
    if (bytes.size() == 84 + 50 * static_cast<std::size_t>(count)) {
      if (count == 0) throw FileLineError{0, "is a binary STL without triangles"};
      return read_binary(bytes, count);
    }
  }
  const std::size_t first = bytes.find_first_not_of(" \t\r\n");
  if (first == std::string::npos || bytes.compare(first, 5, "solid") != 0)
    throw FileLineError{0, "is neither a binary STL (84 + 50 n bytes for n triangles) nor an ASCII STL (starting with "
                           "'solid')"};
  TriangleMesh mesh = read_ascii(bytes);
  if (mesh.triangles.empty()) throw FileLineError{0, "is an ASCII STL without facets"};
  return mesh;
}

}  // namespace talus
