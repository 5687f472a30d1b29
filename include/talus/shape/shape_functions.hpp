#pragma once
// Grid shape functions: linear hats and quadratic B-splines, tensor products
// of 1D bases on a uniform grid of `cells` cells per axis.
//
// Quadratic B-splines use the open (clamped) knot vector
//   t = [0, 0, 0, 1, 2, ..., n-1, n, n, n]   (units of the cell size)
// so there are n + 2 basis functions per axis, C1 across cell faces, with
// partition of unity and exact reproduction of linear fields everywhere,
// boundary cells included. Basis i "lives" at its Greville abscissa
//   x*_0 = 0, x*_i = i - 1/2 (1 <= i <= n), x*_{n+1} = n,
// and only basis 0 (resp. n+1) is non-zero on the face x = 0 (resp. n), where it
// equals 1: fixing that coefficient imposes the Dirichlet value exactly on the
// face, without over-constraining the neighbouring cells (which zeroing the
// two outer functions of an unclamped spline would do; see docs/grid.md).
// Linear hats have n + 1 functions at the cell vertices.
//
// Particle quadrature. Classic MPM evaluates the functions at the particle's
// position ("point"). With "domain" quadrature a particle stands for a box
// of half-widths r_a around it, and every weight and gradient is the box's
// average (GIMP, Bardenhagen & Kober 2004, for linear hats; the same average
// of the quadratic B-splines, e.g. Gan et al. 2018):
//   S_i(x_p) = (1/|Omega_p|) int_{Omega_p} N_i dV,
//   grad S_i(x_p) = (1/|Omega_p|) int_{Omega_p} grad N_i dV,
// so the internal force sum_p V_p sigma_p grad S_i is the exact integral of a
// stress that is constant on each domain, wherever the particle sits
// relative to the knots (docs/grid.md#particle-quadrature). Per axis the
// average spans at most two knot spans (r <= h/2), so a quadratic B-spline
// stencil has up to 4 functions per axis, a linear one up to 3.
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "talus/core/types.hpp"

namespace talus {

enum class ShapeKind { linear, quadratic_bspline };
enum class ParticleQuadrature { point, domain };

// Values and derivatives (per unit length) of the basis functions that are
// non-zero on one axis at one point: functions first, first+1, ...
struct Basis1D {
  static constexpr int max_count = 4;  // 3 at a point; 4 averaged over a domain
  int first = 0;
  int count = 0;
  double value[max_count] = {0, 0, 0, 0};
  double slope[max_count] = {0, 0, 0, 0};
};

inline int basis_count(ShapeKind kind, int cells) {
  return kind == ShapeKind::linear ? cells + 1 : cells + 2;
}

// Greville abscissa (position in cell units) of basis i.
inline double basis_position(ShapeKind kind, int i, int cells) {
  if (kind == ShapeKind::linear) return i;
  if (i == 0) return 0.0;
  if (i == cells + 1) return cells;
  return i - 0.5;
}

// Knot t_k of the clamped quadratic knot vector with `cells` spans.
inline double clamped_knot(int k, int cells) {
  const int t = k - 2;
  return t < 0 ? 0.0 : (t > cells ? double(cells) : double(t));
}

// Integral of basis i over the grid, in cells: a B-spline of degree p on
// knots t_i .. t_{i+p+1} integrates to (t_{i+p+1} - t_i) / (p + 1) (de Boor,
// A Practical Guide to Splines, IX(20)); 1 inside, 1/3 and 2/3 for the two
// quadratic functions at a face, 1/2 for a hat at a face.
inline double basis_integral(ShapeKind kind, int i, int cells) {
  if (kind == ShapeKind::linear) return (i == 0 || i == cells) ? 0.5 : 1.0;
  return (clamped_knot(i + 3, cells) - clamped_knot(i, cells)) / 3.0;
}

// u: position in cell units (0 <= u <= cells); h: cell size.
inline Basis1D evaluate_basis_1d(ShapeKind kind, double u, int cells, double h) {
  Basis1D b;
  int c = static_cast<int>(std::floor(u));
  if (c < 0) c = 0;
  if (c > cells - 1) c = cells - 1;
  const double inv_h = 1.0 / h;
  if (kind == ShapeKind::linear) {
    const double s = u - c;
    b.first = c;
    b.count = 2;
    b.value[0] = 1.0 - s;
    b.value[1] = s;
    b.slope[0] = -inv_h;
    b.slope[1] = inv_h;
    return b;
  }
  b.first = c;
  b.count = 3;
  if (c >= 2 && c <= cells - 3) {
    // Interior span: the uniform quadratic B-spline (all knots distinct).
    const double s = u - c;
    b.value[0] = 0.5 * (1.0 - s) * (1.0 - s);
    b.value[1] = 0.5 + s - s * s;
    b.value[2] = 0.5 * s * s;
    b.slope[0] = (s - 1.0) * inv_h;
    b.slope[1] = (1.0 - 2.0 * s) * inv_h;
    b.slope[2] = s * inv_h;
    return b;
  }
  // Spans near a face: Cox-de Boor for degree 2 on the clamped knot vector
  // (Piegl & Tiller, The NURBS Book, A2.2/A2.3). Span index s = c + 2.
  const int s = c + 2;
  auto t = [cells](int k) { return clamped_knot(k, cells); };
  // Degree 1 on the span: B_{s-1,1}, B_{s,1}.
  const double n1_0 = (t(s + 1) - u) / (t(s + 1) - t(s));
  const double n1_1 = (u - t(s)) / (t(s + 1) - t(s));
  // Degree 2: B_{s-2,2}, B_{s-1,2}, B_{s,2}.
  const double a = t(s + 1) - t(s - 1);  // >= 1 on every span
  const double d = t(s + 2) - t(s);      // >= 1 on every span
  b.value[0] = (t(s + 1) - u) / a * n1_0;
  b.value[1] = (u - t(s - 1)) / a * n1_0 + (t(s + 2) - u) / d * n1_1;
  b.value[2] = (u - t(s)) / d * n1_1;
  b.slope[0] = -2.0 / a * n1_0 * inv_h;
  b.slope[1] = (2.0 / a * n1_0 - 2.0 / d * n1_1) * inv_h;
  b.slope[2] = 2.0 / d * n1_1 * inv_h;
  return b;
}

// The average over [u - r, u + r] (cell units, clipped to the grid [0, cells])
// of the basis functions and of their derivatives. The values are exact
// integrals: the functions are polynomials of degree <= 2 on each knot span,
// which two Gauss points integrate exactly; the derivative's average is the
// difference of the end values over the length. r is capped at 1/2 (a domain
// at most one cell long): beyond, the stencil would need a fifth function.
inline Basis1D evaluate_domain_basis_1d(ShapeKind kind, double u, double r, int cells, double h) {
  r = std::min(r, 0.5);
  const double a = std::max(u - r, 0.0), b = std::min(u + r, static_cast<double>(cells));
  if (!(b - a > 1e-12)) return evaluate_basis_1d(kind, std::clamp(u, 0.0, static_cast<double>(cells)), cells, h);
  const int span_a = std::min(static_cast<int>(std::floor(a)), cells - 1);
  const int span_b = std::clamp(static_cast<int>(std::ceil(b)) - 1, span_a, cells - 1);
  Basis1D out;
  out.first = span_a;
  out.count = span_b - span_a + (kind == ShapeKind::linear ? 2 : 3);
  const double inv_length = 1.0 / (b - a), gauss = 0.5 / std::sqrt(3.0);
  for (int s = span_a; s <= span_b; ++s) {
    const double lo = std::max(a, double(s)), hi = std::min(b, double(s + 1));
    if (!(hi > lo)) continue;
    const double mid = 0.5 * (lo + hi), len = hi - lo;
    for (const double g : {mid - gauss * len, mid + gauss * len}) {
      const Basis1D at = evaluate_basis_1d(kind, g, cells, h);
      for (int i = 0; i < at.count; ++i) out.value[at.first - out.first + i] += 0.5 * len * inv_length * at.value[i];
    }
  }
  const Basis1D end_a = evaluate_basis_1d(kind, a, cells, h), end_b = evaluate_basis_1d(kind, b, cells, h);
  const double per_length = inv_length / h;
  for (int i = 0; i < end_b.count; ++i) out.slope[end_b.first - out.first + i] += per_length * end_b.value[i];
  for (int i = 0; i < end_a.count; ++i) out.slope[end_a.first - out.first + i] -= per_length * end_a.value[i];
  return out;
}

// Per grid function of one axis: what a lattice of n particles per cell
// (at (j + 1/2)/n cells, filling the axis) gives for its integral, over the
// integral. The midpoint rule integrates every function with uniform knots
// exactly (its errors on the three spans cancel) and so the hats too, but not
// the two clamped B-splines at each face: 1 - 1/(4 n^2) at the face (15/16 for
// n = 2) and 1 + 1/(8 n^2) beside it (33/32), whatever the grid's length.
inline std::vector<double> lattice_rule_ratio(ShapeKind kind, int cells, int n) {
  std::vector<double> ratio(static_cast<std::size_t>(basis_count(kind, cells)), 0.0);
  for (long j = 0; j < static_cast<long>(n) * cells; ++j) {
    const Basis1D b = evaluate_basis_1d(kind, (j + 0.5) / n, cells, 1.0);
    for (int i = 0; i < b.count; ++i) ratio[b.first + i] += b.value[i] / n;
  }
  for (std::size_t i = 0; i < ratio.size(); ++i) ratio[i] /= basis_integral(kind, static_cast<int>(i), cells);
  return ratio;
}

// The tensor-product stencil of one particle: the grid functions that are
// non-zero at its position, their values and gradients.
template <int dim>
struct Stencil {
  static constexpr int max_nodes = dim == 2 ? 16 : 64;  // 4 per axis (domain quadrature)
  int count = 0;
  std::array<std::array<int, dim>, max_nodes> node;  // global grid index (i, j[, k])
  std::array<int, max_nodes> local;                  // index in the rank's ghosted node arrays
  std::array<double, max_nodes> weight;
  std::array<Vector<dim>, max_nodes> gradient;
  // The 1D bases whose tensor product the nodes are (x fastest): the
  // Jacobian's product contracts them axis by axis (momentum_operator.cpp).
  std::array<Basis1D, dim> basis;
};

// x_rel: position relative to the grid's lower corner (physical units);
// half_width: the particle's domain (physical units), or none for point
// quadrature.
template <int dim>
inline void evaluate_stencil(ShapeKind kind, const Vector<dim>& x_rel, const std::array<int, dim>& cells,
                             double h, Stencil<dim>& st, const Vector<dim>* half_width = nullptr) {
  std::array<Basis1D, dim> b;
  for (int a = 0; a < dim; ++a)
    b[a] = half_width ? evaluate_domain_basis_1d(kind, x_rel[a] / h, (*half_width)[a] / h, cells[a], h)
                      : evaluate_basis_1d(kind, x_rel[a] / h, cells[a], h);
  int n = 0;
  if constexpr (dim == 2) {
    for (int j = 0; j < b[1].count; ++j)
      for (int i = 0; i < b[0].count; ++i, ++n) {
        st.node[n] = {b[0].first + i, b[1].first + j};
        st.weight[n] = b[0].value[i] * b[1].value[j];
        st.gradient[n] = Vector<2>(b[0].slope[i] * b[1].value[j], b[0].value[i] * b[1].slope[j]);
      }
  } else {
    for (int k = 0; k < b[2].count; ++k)
      for (int j = 0; j < b[1].count; ++j)
        for (int i = 0; i < b[0].count; ++i, ++n) {
          st.node[n] = {b[0].first + i, b[1].first + j, b[2].first + k};
          const double wi = b[0].value[i], wj = b[1].value[j], wk = b[2].value[k];
          st.weight[n] = wi * wj * wk;
          st.gradient[n] = Vector<3>(b[0].slope[i] * wj * wk, wi * b[1].slope[j] * wk, wi * wj * b[2].slope[k]);
        }
  }
  st.count = n;
  st.basis = b;
}

}  // namespace talus
