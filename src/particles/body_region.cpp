#include "talus/particles/body_region.hpp"

#include <algorithm>
#include <cmath>

namespace talus {

template <int dim>
BodyLattice<dim>::BodyLattice(const BodyConfig& body, const std::vector<double>& grid_lower, double cell_size)
    : lower(grid_lower), spacing(cell_size / body.particles_per_cell) {
  size = 1;
  for (int a = 0; a < dim; ++a) {
    const double lo = (body.box_lower[a] - lower[a]) / spacing - 0.5;
    const double hi = (body.box_upper[a] - lower[a]) / spacing - 0.5;
    first[a] = static_cast<long>(std::ceil(lo - 1e-9));
    const long last = static_cast<long>(std::floor(hi + 1e-9));
    count[a] = std::max(0L, last - first[a] + 1);
    size *= count[a];
  }
}

template <int dim>
std::array<long, dim> BodyLattice<dim>::index(std::int64_t id) const {
  std::array<long, dim> s{};
  for (int a = 0; a < dim; ++a) {
    s[a] = first[a] + static_cast<long>(id % count[a]);
    id /= count[a];
  }
  return s;
}

template <int dim>
Vector<dim> BodyLattice<dim>::point(std::int64_t id) const {
  const std::array<long, dim> s = index(id);
  Vector<dim> x;
  for (int a = 0; a < dim; ++a) x[a] = lower[a] + (s[a] + 0.5) * spacing;
  return x;
}

namespace {
bool inside_polygon(const std::vector<std::array<double, 2>>& polygon, double x, double y) {
  bool inside = false;
  for (std::size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++) {
    const auto& a = polygon[i];
    const auto& b = polygon[j];
    if ((a[1] > y) != (b[1] > y) && x < a[0] + (y - a[1]) * (b[0] - a[0]) / (b[1] - a[1])) inside = !inside;
  }
  return inside;
}

Vector<3> vertex(const std::vector<std::array<double, 3>>& vertices, int i) {
  return Vector<3>(vertices[i][0], vertices[i][1], vertices[i][2]);
}
}  // namespace

double winding_number(const std::vector<std::array<double, 3>>& vertices,
                      const std::vector<std::array<int, 3>>& triangles, const Vector<3>& x) {
  // tan(Omega / 2) = a . (b x c) / (|a||b||c| + (a.b)|c| + (a.c)|b| + (b.c)|a|),
  // a, b, c the corners relative to x; atan2 keeps the full (-2 pi, 2 pi) range.
  double omega = 0.0;
  for (const auto& t : triangles) {
    const Vector<3> a = vertex(vertices, t[0]) - x, b = vertex(vertices, t[1]) - x, c = vertex(vertices, t[2]) - x;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    const double numerator = a.dot(b.cross(c));
    const double denominator = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    omega += 2.0 * std::atan2(numerator, denominator);
  }
  return omega / (4.0 * M_PI);
}

double enclosed_volume(const std::vector<std::array<double, 3>>& vertices,
                       const std::vector<std::array<int, 3>>& triangles) {
  double six_v = 0.0;
  for (const auto& t : triangles)
    six_v += vertex(vertices, t[0]).dot(vertex(vertices, t[1]).cross(vertex(vertices, t[2])));
  return six_v / 6.0;
}

std::vector<std::pair<double, int>> ray_crossings(const std::vector<std::array<double, 3>>& vertices,
                                                  const std::vector<std::array<int, 3>>& triangles, double x, double y) {
  // Top-left rule for a counter-clockwise triangle in (x, y): a point on the
  // edge a -> b counts if the edge runs downwards, or horizontally to the
  // left. Of the two directions of a shared edge exactly one qualifies.
  const auto counts = [](double e, double dx, double dy) { return e > 0 || (e == 0 && (dy < 0 || (dy == 0 && dx < 0))); };
  std::vector<std::pair<double, int>> out;
  for (const auto& t : triangles) {
    const auto& A = vertices[t[0]];
    std::array<double, 3> B = vertices[t[1]], C = vertices[t[2]];
    double area2 = (B[0] - A[0]) * (C[1] - A[1]) - (B[1] - A[1]) * (C[0] - A[0]);
    if (area2 == 0) continue;  // seen edge-on
    const int facing = area2 > 0 ? 1 : -1;  // counter-clockwise from above: its normal points up
    if (facing < 0) std::swap(B, C), area2 = -area2;
    const std::array<const std::array<double, 3>*, 3> v = {&A, &B, &C};
    double w[3];
    bool inside = true;
    for (int k = 0; k < 3 && inside; ++k) {
      const auto& p = *v[k];
      const auto& q = *v[(k + 1) % 3];
      const double dx = q[0] - p[0], dy = q[1] - p[1];
      // w[k]: twice the area of (p, q, point), the barycentric weight of the vertex opposite the edge.
      w[k] = dx * (y - p[1]) - dy * (x - p[0]);
      inside = counts(w[k], dx, dy);
    }
    if (!inside) continue;
    // w[0] belongs to C (opposite A -> B), w[1] to A, w[2] to B.
    const double z = (w[1] * A[2] + w[2] * B[2] + w[0] * C[2]) / area2;
    out.emplace_back(z, facing);
  }
  std::sort(out.begin(), out.end());
  return out;
}

template <int dim>
std::vector<bool> seeded_lattice_points(const BodyConfig& body, const BodyLattice<dim>& lattice) {
  std::vector<bool> seeded(static_cast<std::size_t>(lattice.size), body.shape == BodyShape::box);
  if (body.shape == BodyShape::polygon) {
    for (std::int64_t id = 0; id < lattice.size; ++id) {
      const Vector<dim> x = lattice.point(id);
      seeded[id] = inside_polygon(body.polygon, x[0], x[dim - 1]);
    }
  } else if (body.shape == BodyShape::polyhedron) {
    if constexpr (dim == 3) {
      // One ray per lattice column (x, y); ids run x fastest, z slowest.
      const std::int64_t columns = static_cast<std::int64_t>(lattice.count[0]) * lattice.count[1];
      for (std::int64_t column = 0; column < columns; ++column) {
        const Vector<3> bottom = lattice.point(column);
        const auto crossings =
            ray_crossings(body.polyhedron_vertices, body.polyhedron_triangles, bottom[0], bottom[1]);
        if (crossings.empty()) continue;
        int above = 0;  // winding number: the signs of the crossings above the point
        for (const auto& c : crossings) above += c.second;
        std::size_t next = 0;
        for (long k = 0; k < lattice.count[2]; ++k) {
          const double z = bottom[2] + k * lattice.spacing;
          while (next < crossings.size() && crossings[next].first <= z) above -= crossings[next++].second;
          seeded[column + k * columns] = above != 0;
        }
      }
    }
  }
  return seeded;
}

template struct BodyLattice<2>;
template struct BodyLattice<3>;
template std::vector<bool> seeded_lattice_points<2>(const BodyConfig&, const BodyLattice<2>&);
template std::vector<bool> seeded_lattice_points<3>(const BodyConfig&, const BodyLattice<3>&);

}  // namespace talus
