#pragma once
// A ghost penalty on the cut cells of quadratic B-splines (docs/solver.md#ghost-penalty):
//
//   j(u, w) = sum_C gamma M_C h^2 sum_a int_C (d^2 u / dx_a^2) . (d^2 w / dx_a^2) dV
//
// over the cut cells C: cells that hold particles of a velocity field next
// to a cell (faces and corners) that holds none, i.e. the cells a body's
// surface passes through. h is the cell size, M_C the particles' P-wave
// modulus lambda + 2 mu (volume-weighted) and gamma a dimensionless weight.
// The grid functions that the particles barely touch at a body's edge (the
// "light points" of docs/solver.md#large-steps) have almost no stiffness
// from the particle quadrature; j ties them to their neighbours. It is zero
// for every linear field (rigid motions, uniform strain rates), so it does
// not resist them. It is a derivative-type ghost penalty (Burman 2010,
// "Ghost penalty", penalizing derivatives on the cut cells rather than
// their jumps across faces, as in Coombs, Augarde et al. 2022 for the
// material point method): the jump form for C1 quadratic splines needs the
// third difference of 4 coefficients, which couples grid points one further
// apart than a particle's stencil and so changes the matrix's pattern; this
// form stays inside it.
//
// j(u, w) = w^T K u per velocity component, K_C(I, J) = s_C sum_a D_a(I_a) D_a(J_a) h prod_{b != a} M_b(I_b, J_b)
// with D_a the three functions' second derivatives on the cell's span along
// a (constant there), M_b the 1D mass matrices of its span along b and
// s_C = gamma M_C h^2. MomentumSystem applies it to the step's displacement
// h v_theta (docs/solver.md#ghost-penalty).
#include <array>
#include <functional>
#include <vector>

#include "talus/grid/grid.hpp"
#include "talus/materials/material.hpp"
#include "talus/particles/particles.hpp"
#include "talus/solver/active_set.hpp"
#include "talus/transfer/transfer.hpp"

namespace talus {

template <int dim>
class GhostPenalty {
 public:
  static constexpr int cell_nodes = dim == 2 ? 9 : 27;

  // The cut cells of this rank's particles (each cell on the one rank that
  // owns its particles). Quadratic B-splines only. An empty neighbour cell
  // that reaches into an obstacle (`inside_obstacle` true at a corner) is a
  // wall, not a free surface; a cell with a node that contact holds
  // (`held`, per ghosted node, set by the rank that owns the point) is left
  // out: the contact condition supports its points, and a penalty across
  // the contact layer, where the velocity is not smooth, fights it (the 3D
  // landslide on terrain needed twice the Newton iterations with it).
  GhostPenalty(const Grid<dim>& grid, const Particles<dim>& particles, const std::vector<Stencil<dim>>& stencils,
               const GridFields<dim>& fields, const ActiveSet<dim>& active,
               const std::vector<const Material*>& materials, double gamma,
               const std::function<bool(const Vector<dim>&)>& inside_obstacle = {},
               const std::vector<char>* held = nullptr);

  // y += scale K x on ghosted node arrays (dim values per node).
  void add_product(const std::vector<double>& x, std::vector<double>& y, double scale) const;

  // One cut cell: its ghosted nodes (the stencil order of a particle in it:
  // first axis fastest) and K_C, row-major cell_nodes x cell_nodes.
  struct Cell {
    std::array<int, cell_nodes> node{};
    std::array<double, cell_nodes * cell_nodes> coupling{};
  };
  const std::vector<Cell>& cells() const { return cells_; }
  long global_cells() const { return global_cells_; }

 private:
  std::vector<Cell> cells_;
  long global_cells_ = 0;
};

}  // namespace talus
