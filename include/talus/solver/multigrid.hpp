#pragma once
// Geometric multigrid on the active set (docs/solver.md#geometric-multigrid):
// the interpolations between the step's unknowns and those of grids with
// twice, four times, ... the cell size, for PETSc's PCMG with Galerkin
// coarse operators (-talus_pc_type mg).
//
// A coarse grid's shape functions lie in the fine grid's space (its knots
// are every other fine knot), so the interpolation is exact: the fine
// coefficients of a coarse spline. For clamped quadratic B-splines the
// coefficient of fine function i is the blossom of the coarse function at
// the knots (t_{i+1}, t_{i+2}) (de Boor 1978, ch. IX), which for a quadratic
// piece q on [a, b] is
//   c_i = 2 q((a + b)/2) - (q(a) + q(b))/2;
// for linear hats it is the coarse function's value at fine vertex i.
// Constrained fine components (fixed and slip faces) get no coarse
// correction; a coarse unknown exists where some unconstrained fine unknown
// of the active set needs it, and is owned by the rank owning the fine
// grid point nearest to it, so the coarse levels are split over the ranks
// as the fine one is.
#include <petscksp.h>

#include <array>
#include <vector>

#include "talus/grid/grid.hpp"
#include "talus/solver/active_set.hpp"

namespace talus {

// The fine coefficients of each coarse function of one axis: for fine
// function i, the pairs (coarse function, weight). `fine_cells` cells of
// size h refine `coarse_cells` = ceil(fine_cells / 2) cells of size 2h that
// start at the same face.
struct AxisRefinement {
  std::vector<std::vector<std::pair<int, double>>> parents;
};
AxisRefinement refine_axis(ShapeKind kind, int fine_cells);

template <int dim>
class GeometricMultigrid {
 public:
  GeometricMultigrid() = default;
  ~GeometricMultigrid();
  GeometricMultigrid(const GeometricMultigrid&) = delete;
  GeometricMultigrid& operator=(const GeometricMultigrid&) = delete;

  // Coarsens until a level has at most `coarse_unknowns` unknowns, or
  // `max_levels` levels (the fine one included) exist, or a coarsening
  // would keep more than 3/4 of the unknowns (a thin body).
  // `held_rows` (offsets in this rank's part of the unknown vector) get no
  // coarse correction either: contact rows, whose natural map is another
  // equation than the momentum balance the coarse levels average.
  void build(const Grid<dim>& grid, const ActiveSet<dim>& active, int field_count, PetscInt coarse_unknowns,
             int max_levels, const std::vector<PetscInt>& held_rows = {});
  int levels() const { return static_cast<int>(interpolation_.size()) + 1; }
  // Interpolation from level l + 1 to level l (0: the fine level).
  Mat interpolation(int l) const { return interpolation_[l]; }
  PetscInt unknowns(int l) const { return unknowns_[l]; }
  // Where this rank's unknowns of level l are: the Greville point of their
  // shape function (in cells of the fine grid, dim per unknown) and their
  // component (-1 for a rigid body's unknown and for constrained fine ones).
  const std::vector<double>& positions(int l) const { return positions_[l]; }
  const std::vector<int>& components(int l) const { return components_[l]; }
  // Levels, interpolations and Galerkin coarse operators on a PCMG.
  void configure(PC pc) const;

 private:
  void destroy();
  std::vector<Mat> interpolation_;
  std::vector<PetscInt> unknowns_;
  std::vector<std::vector<double>> positions_;
  std::vector<std::vector<int>> components_;
};

}  // namespace talus
