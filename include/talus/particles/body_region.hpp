#pragma once
// The region a body fills with material points (docs/case_file.md#bodies):
// a box, a simple polygon (2D; in 3D an (x, z) section extruded over y) or a
// closed polyhedron (3D), and the sub-cell lattice that seeds it. One place
// for "is x in the body" and "which lattice points are there", shared by the
// seeding and by the case-file checks that must predict it.
#include <array>
#include <utility>
#include <cstdint>
#include <vector>

#include "talus/core/types.hpp"
#include "talus/io/config.hpp"

namespace talus {

// The seeding lattice of a body: points grid_lower + (s + 1/2) * spacing,
// s integer, spacing = cell_size / particles_per_cell, inside the body's
// bounding box [box_lower, box_upper] (edges included to 1e-9 of a spacing).
// Point `id` has s[a] = first[a] + (id / prod_{b<a} count[b]) % count[a].
template <int dim>
struct BodyLattice {
  BodyLattice(const BodyConfig& body, const std::vector<double>& grid_lower, double cell_size);
  Vector<dim> point(std::int64_t id) const;
  std::array<long, dim> index(std::int64_t id) const;  // s of point id
  std::array<long, dim> first{}, count{};
  std::vector<double> lower;
  double spacing = 0;
  std::int64_t size = 0;
};

// Which points of the body's lattice are seeded (by lattice id): every point
// of a box; for a polygon, those whose (x, last axis) section point lies
// inside it (crossing number with half-open edges, so a point on an edge
// shared by two bodies belongs to one of them); for a polyhedron, those inside
// it, by ray casting along z per lattice column (ray_crossings). Bodies read
// from a particle file have no lattice: all false.
template <int dim>
std::vector<bool> seeded_lattice_points(const BodyConfig& body, const BodyLattice<dim>& lattice);

// Where the vertical line through (x, y) crosses a closed triangle surface:
// (z, +1) where it leaves through a triangle facing up, (z, -1) where it
// enters through one facing down (for counter-clockwise-from-outside
// triangles; the signs flip for the other orientation), sorted by z. The sum
// of the signs above a point is its winding number. A line through an edge
// or a vertex counts it once: the projected triangles are tested with the
// top-left rule of rasterization, which gives a point on an edge shared by
// two triangles (projected with the same orientation) to exactly one of
// them. Triangles seen edge-on are skipped.
std::vector<std::pair<double, int>> ray_crossings(const std::vector<std::array<double, 3>>& vertices,
                                                  const std::vector<std::array<int, 3>>& triangles, double x, double y);

// Winding number of a closed, consistently oriented triangle surface around
// x: the sum of the triangles' solid angles (Van Oosterom & Strackee 1983,
// IEEE Trans. Biomed. Eng. 30(2)) over 4 pi. +-1 inside, 0 outside, for
// either orientation of the surface.
double winding_number(const std::vector<std::array<double, 3>>& vertices,
                      const std::vector<std::array<int, 3>>& triangles, const Vector<3>& x);

// Signed volume enclosed by the triangles (divergence theorem); positive when
// they are ordered counter-clockwise seen from outside.
double enclosed_volume(const std::vector<std::array<double, 3>>& vertices,
                       const std::vector<std::array<int, 3>>& triangles);

}  // namespace talus
