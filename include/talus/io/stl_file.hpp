#pragma once
// STL files of polyhedron bodies (docs/case_file.md#polyhedra): a closed
// triangle surface from CAD or a mesher, binary or ASCII.
#include <array>
#include <istream>
#include <vector>

#include "talus/io/text_fields.hpp"

namespace talus {

// The triangles of an STL file with their corners welded: corners with
// exactly the same coordinates become one vertex, which gives the surface
// its topology (STL stores each triangle's corners separately). Triangles are
// in file order, corners in file order (counter-clockwise seen from outside
// by the STL convention); the stored normals are ignored. Triangles with two
// equal corners (slivers some exporters write) are dropped.
struct TriangleMesh {
  std::vector<std::array<double, 3>> vertices;
  std::vector<std::array<int, 3>> triangles;
  std::vector<int> facet;  // each kept triangle's facet number in the file, from 1
};

// Binary when the file is 84 + 50 n bytes with n the count at byte 80;
// otherwise ASCII ("solid ... facet normal ... outer loop, vertex x y z x 3,
// endloop, endfacet ... endsolid"). Throws FileLineError (line 0 for binary
// files and the file as a whole).
TriangleMesh read_stl(std::istream& in);

}  // namespace talus
