#pragma once
// Rigid obstacles that the material can touch: half-planes, boxes and
// terrains (a polyline in 2D, a height map in 3D), each with its own Coulomb
// friction, restitution and prescribed (constant) velocity
// (docs/contact.md). The contact solve needs only the signed gap of a grid
// point and the outward normal of the closest surface point.
#include <array>
#include <string>
#include <vector>

#include "talus/core/types.hpp"

namespace talus {

enum class ObstacleShape { half_plane, box, terrain };

// One obstacle as the case file gives it (validated by the loader; terrain
// files are read at load time so that a bad file stops the run before the
// first step).
struct ObstacleConfig {
  std::string name;
  ObstacleShape shape = ObstacleShape::half_plane;
  // half_plane: a point on the boundary and the unit normal pointing out of
  // the solid (into the free side).
  std::vector<double> point, normal;
  // box: the solid is lower <= x <= upper.
  std::vector<double> lower, upper;
  // terrain, 2D: polyline vertices (x, z) with x strictly increasing; the
  // solid lies below. Points beyond the ends see the end segments extended.
  std::vector<std::array<double, 2>> polyline;
  // terrain, 3D: height map z(x, y) sampled on a regular grid, x fastest:
  // heights[j * nx + i] = z(origin_x + i * spacing, origin_y + j * spacing);
  // bilinear cells split into two triangles; the solid lies below.
  std::array<double, 2> map_origin{0.0, 0.0};
  double map_spacing = 0.0;
  int map_nx = 0, map_ny = 0;
  std::vector<double> heights;
  std::string file;  // the terrain file as given in the case (messages, output)
  std::vector<double> velocity;  // prescribed translation velocity [m/s], default 0
  double friction = 0.0;         // Coulomb mu >= 0
  double restitution = 0.0;      // Newton's e in [0, 1]
};

template <int dim>
struct ObstacleGap {
  double gap = 0.0;     // signed distance to the surface: > 0 outside the solid, < 0 inside
  Vector<dim> normal;   // unit outward normal at the closest surface point
};

template <int dim>
class Obstacle {
 public:
  explicit Obstacle(ObstacleConfig config);

  // Gap and normal at x when the obstacle has moved by velocity * t.
  ObstacleGap<dim> gap(const Vector<dim>& x, double t) const;

  const std::string& name() const { return config_.name; }
  const ObstacleConfig& config() const { return config_; }
  const Vector<dim>& velocity() const { return velocity_; }
  double friction() const { return config_.friction; }
  double restitution() const { return config_.restitution; }

 private:
  ObstacleConfig config_;
  Vector<dim> velocity_;
};

}  // namespace talus
