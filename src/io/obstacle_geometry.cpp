// Obstacles as ParaView geometry: each obstacle's surface clipped to the grid
// box (docs/output.md), drawn by draw_obstacles for ObstacleSeries.
#include <vtkCellType.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "talus/io/vtk_output.hpp"

namespace talus {

namespace {

// Liang-Barsky: the part t0 <= t <= t1 of a + t d (t0, t1 may be infinite)
// inside lo <= x <= hi; false if there is none.
template <int dim>
bool clip_line(const Vector<dim>& a, const Vector<dim>& d, const Vector<dim>& lo, const Vector<dim>& hi, double& t0,
               double& t1) {
  for (int k = 0; k < dim; ++k) {
    if (d[k] == 0.0) {
      if (a[k] < lo[k] || a[k] > hi[k]) return false;
      continue;
    }
    double ta = (lo[k] - a[k]) / d[k], tb = (hi[k] - a[k]) / d[k];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

// Sutherland-Hodgman: a convex polygon clipped to the box.
std::vector<Vector<3>> clip_polygon(std::vector<Vector<3>> poly, const Vector<3>& lo, const Vector<3>& hi) {
  for (int k = 0; k < 3 && !poly.empty(); ++k)
    for (int side = 0; side < 2 && !poly.empty(); ++side) {
      // inside: s(x) >= 0
      const auto s = [&](const Vector<3>& x) { return side == 0 ? x[k] - lo[k] : hi[k] - x[k]; };
      std::vector<Vector<3>> out;
      for (std::size_t i = 0; i < poly.size(); ++i) {
        const Vector<3>& p = poly[i];
        const Vector<3>& q = poly[(i + 1) % poly.size()];
        const double sp = s(p), sq = s(q);
        if (sp >= 0.0) out.push_back(p);
        if ((sp >= 0.0) != (sq >= 0.0)) {
          Vector<3> x = p + (sp / (sp - sq)) * (q - p);
          x[k] = side == 0 ? lo[k] : hi[k];  // exactly on the face
          out.push_back(x);
        }
      }
      poly = std::move(out);
    }
  return poly;
}

// The polygon where the plane (x - p) . n = 0 cuts the box: the points where
// it crosses the 12 edges (a box vertex on the plane counts once), ordered
// counter-clockwise about n.
std::vector<Vector<3>> plane_section(const Vector<3>& p, const Vector<3>& n, const Vector<3>& lo, const Vector<3>& hi) {
  const double size = (hi - lo).norm();
  const double tol = 1e-12 * size;
  std::vector<Vector<3>> pts;
  const auto add = [&](const Vector<3>& x) {
    for (const auto& y : pts)
      if ((x - y).norm() <= tol) return;
    pts.push_back(x);
  };
  const auto corner = [&](int c) -> Vector<3> {
    return Vector<3>(c & 1 ? hi[0] : lo[0], c & 2 ? hi[1] : lo[1], c & 4 ? hi[2] : lo[2]);
  };
  for (int c = 0; c < 8; ++c)
    for (int k = 0; k < 3; ++k) {
      if (c & (1 << k)) continue;  // each edge once: from its lower corner along axis k
      const Vector<3> a = corner(c), b = corner(c | (1 << k));
      double fa = (a - p).dot(n), fb = (b - p).dot(n);
      if (std::abs(fa) <= tol) fa = 0.0;
      if (std::abs(fb) <= tol) fb = 0.0;
      if (fa == 0.0) add(a);
      if (fb == 0.0) add(b);
      if ((fa < 0.0 && fb > 0.0) || (fa > 0.0 && fb < 0.0)) add(a + fa / (fa - fb) * (b - a));
    }
  if (pts.size() < 3) return {};
  Vector<3> centre = Vector<3>::Zero();
  for (const auto& x : pts) centre += x;
  centre /= static_cast<double>(pts.size());
  // An in-plane basis (e1, e2) with e1 x e2 = n.
  const Vector<3> helper = std::abs(n[0]) < 0.9 ? Vector<3>(1, 0, 0) : Vector<3>(0, 1, 0);
  const Vector<3> e1 = n.cross(helper).normalized(), e2 = n.cross(e1);
  std::sort(pts.begin(), pts.end(), [&](const Vector<3>& x, const Vector<3>& y) {
    const auto angle = [&](const Vector<3>& z) { return std::atan2((z - centre).dot(e2), (z - centre).dot(e1)); };
    return angle(x) < angle(y);
  });
  return pts;
}

}  // namespace

template <int dim>
ObstacleDrawing draw_obstacles(const std::vector<Obstacle<dim>>& obstacles, const Vector<dim>& lo,
                               const Vector<dim>& hi, double time) {
  ObstacleDrawing d;
  const double size = (hi - lo).norm();
  const auto add_point = [&](const Point3& p) {
    d.points.push_back(p);
    return static_cast<long>(d.points.size() - 1);
  };
  const auto add_cell = [&](int type, const std::vector<Point3>& pts, int obstacle) {
    ObstacleDrawing::Cell c;
    c.vtk_type = type;
    c.obstacle = obstacle;
    for (const auto& p : pts) c.points.push_back(add_point(p));
    d.cells.push_back(std::move(c));
  };
  for (std::size_t o = 0; o < obstacles.size(); ++o) {
    const ObstacleConfig& c = obstacles[o].config();
    const Vector<dim> shift = time * obstacles[o].velocity();
    const int id = static_cast<int>(o);
    switch (c.shape) {
      case ObstacleShape::half_plane: {
        Vector<dim> p, n;
        for (int a = 0; a < dim; ++a) p[a] = c.point[a], n[a] = c.normal[a];
        n.normalize();
        p += shift;
        if constexpr (dim == 2) {
          const Vector<2> t(-n[1], n[0]);
          double t0 = -std::numeric_limits<double>::infinity(), t1 = std::numeric_limits<double>::infinity();
          if (clip_line<2>(p, t, lo, hi, t0, t1) && t1 - t0 > 1e-12 * size)
            add_cell(VTK_LINE, {to_point<2>(p + t0 * t), to_point<2>(p + t1 * t)}, id);
        } else {
          const auto poly = plane_section(p, n, lo, hi);
          if (poly.size() >= 3) {
            std::vector<Point3> pts;
            for (const auto& x : poly) pts.push_back(to_point<3>(x));
            add_cell(VTK_POLYGON, pts, id);
          }
        }
        break;
      }
      case ObstacleShape::box: {
        Vector<dim> bl, bh;
        bool empty = false;
        for (int a = 0; a < dim; ++a) {
          bl[a] = std::max(c.lower[a] + shift[a], lo[a]);
          bh[a] = std::min(c.upper[a] + shift[a], hi[a]);
          empty |= !(bh[a] > bl[a]);
        }
        if (empty) break;
        if constexpr (dim == 2) {
          add_cell(VTK_POLYGON, {Point3{bl[0], bl[1], 0}, Point3{bh[0], bl[1], 0}, Point3{bh[0], bh[1], 0},
                                 Point3{bl[0], bh[1], 0}},
                   id);
        } else {
          // Face k, side s: vertices (0,0), (1,0), (1,1), (0,1) in the axes
          // (k+1, k+2), whose cross product is +e_k; reversed on the lower side.
          for (int k = 0; k < 3; ++k)
            for (int side = 0; side < 2; ++side) {
              const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
              std::vector<Point3> pts;
              const int uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
              for (int v = 0; v < 4; ++v) {
                Point3 x;
                x[k] = side ? bh[k] : bl[k];
                x[k1] = uv[v][0] ? bh[k1] : bl[k1];
                x[k2] = uv[v][1] ? bh[k2] : bl[k2];
                pts.push_back(x);
              }
              if (side == 0) std::reverse(pts.begin(), pts.end());
              add_cell(VTK_QUAD, pts, id);
            }
        }
        break;
      }
      case ObstacleShape::terrain: {
        if constexpr (dim == 2) {
          // Segment s runs from vertex s to s + 1; the first and the last
          // are extended beyond the ends (as the gap sees them).
          const auto& v = c.polyline;
          const std::size_t segments = v.size() - 1;
          std::vector<Point3> line;
          bool open = false;  // the last segment reached its end unclipped
          for (std::size_t s = 0; s < segments; ++s) {
            const Vector<2> a = Vector<2>(v[s][0], v[s][1]) + shift, b = Vector<2>(v[s + 1][0], v[s + 1][1]) + shift;
            double t0 = s == 0 ? -std::numeric_limits<double>::infinity() : 0.0;
            double t1 = s + 1 == segments ? std::numeric_limits<double>::infinity() : 1.0;
            const bool inside = clip_line<2>(a, b - a, lo, hi, t0, t1);
            if (!inside || t1 <= t0) {
              if (line.size() >= 2) add_cell(VTK_POLY_LINE, line, id);
              line.clear();
              open = false;
              continue;
            }
            const Point3 pa = t0 == 0.0 ? to_point<2>(a) : to_point<2>(a + t0 * (b - a));
            const Point3 pb = t1 == 1.0 ? to_point<2>(b) : to_point<2>(a + t1 * (b - a));
            if (!(open && t0 == 0.0)) {
              if (line.size() >= 2) add_cell(VTK_POLY_LINE, line, id);
              line.assign(1, pa);
            }
            line.push_back(pb);
            open = t1 == 1.0;
          }
          if (line.size() >= 2) add_cell(VTK_POLY_LINE, line, id);
        } else {
          const double s = c.map_spacing;
          const auto node = [&](int i, int j) -> Vector<3> {
            return Vector<3>(c.map_origin[0] + i * s, c.map_origin[1] + j * s,
                             c.heights[static_cast<std::size_t>(j) * c.map_nx + i]) +
                   shift;
          };
          const auto inside = [&](const Vector<3>& x) {
            for (int a = 0; a < 3; ++a)
              if (x[a] < lo[a] || x[a] > hi[a]) return false;
            return true;
          };
          // Map nodes are shared by the triangles that keep them whole.
          std::vector<long> node_point(static_cast<std::size_t>(c.map_nx) * c.map_ny, -1);
          const auto node_id = [&](int i, int j) {
            long& k = node_point[static_cast<std::size_t>(j) * c.map_nx + i];
            if (k < 0) k = add_point(to_point<3>(node(i, j)));
            return k;
          };
          for (int j = 0; j + 1 < c.map_ny; ++j)
            for (int i = 0; i + 1 < c.map_nx; ++i) {
              const int tri[2][3][2] = {{{0, 0}, {1, 0}, {1, 1}}, {{0, 0}, {1, 1}, {0, 1}}};
              for (const auto& t : tri) {
                std::vector<Vector<3>> poly;
                bool whole = true;
                for (const auto& ij : t) {
                  poly.push_back(node(i + ij[0], j + ij[1]));
                  whole &= inside(poly.back());
                }
                if (whole) {
                  ObstacleDrawing::Cell cell;
                  cell.vtk_type = VTK_TRIANGLE;
                  cell.obstacle = id;
                  for (const auto& ij : t) cell.points.push_back(node_id(i + ij[0], j + ij[1]));
                  d.cells.push_back(std::move(cell));
                  continue;
                }
                poly = clip_polygon(std::move(poly), lo, hi);
                if (poly.size() < 3) continue;
                std::vector<Point3> pts;
                for (const auto& x : poly) pts.push_back(to_point<3>(x));
                add_cell(VTK_POLYGON, pts, id);
              }
            }
        }
        break;
      }
    }
  }
  return d;
}

template ObstacleDrawing draw_obstacles<2>(const std::vector<Obstacle<2>>&, const Vector<2>&, const Vector<2>&,
                                           double);
template ObstacleDrawing draw_obstacles<3>(const std::vector<Obstacle<3>>&, const Vector<3>&, const Vector<3>&,
                                           double);

}  // namespace talus
