#pragma once
// The background grid: a PETSc DMDA whose points are the grid's shape
// functions (vertices for linear hats, Greville points for quadratic
// B-splines), distributed over the ranks of `comm`.
//
// The same DMDA is the DMSwarm cell DM. Its uniform coordinates place point i
// at lower + (i - offset) h, offset = 1/2 for quadratic B-splines, so that the
// DMDA cell k is centred on grid vertex k; ownership of particles follows
// owner_rank(), which mirrors PETSc's DMDA point location.
#include <petscdmda.h>

#include <array>

#include "talus/core/types.hpp"
#include "talus/shape/shape_functions.hpp"

namespace talus {

enum class Face { x_min, x_max, y_min, y_max, z_min, z_max };

template <int dim>
class Grid {
 public:
  Grid(MPI_Comm comm, const Vector<dim>& lower, const Vector<dim>& upper, double cell_size, ShapeKind kind);
  ~Grid();
  Grid(const Grid&) = delete;
  Grid& operator=(const Grid&) = delete;

  MPI_Comm comm() const { return comm_; }
  DM dm() const { return da_; }                  // one scalar per grid point
  DM mass_momentum_dm() const { return da_mp_; }  // (m, m v) per grid point
  ShapeKind shape() const { return kind_; }
  double cell_size() const { return h_; }
  const Vector<dim>& lower() const { return lower_; }
  const Vector<dim>& upper() const { return upper_; }
  const std::array<int, dim>& cells() const { return cells_; }
  const std::array<int, dim>& points() const { return points_; }  // basis functions per axis

  // Owned and ghosted index boxes of this rank (global indices).
  const std::array<int, dim>& owned_start() const { return own_start_; }
  const std::array<int, dim>& owned_size() const { return own_size_; }
  const std::array<int, dim>& ghost_start() const { return ghost_start_; }
  const std::array<int, dim>& ghost_size() const { return ghost_size_; }
  int ghosted_count() const;
  int local_index(const std::array<int, dim>& ijk) const;  // into ghosted arrays
  std::array<int, dim> global_index(int local) const;
  bool is_owned(const std::array<int, dim>& ijk) const;

  Vector<dim> point_position(const std::array<int, dim>& ijk) const;  // Greville point
  PetscMPIInt owner_rank(const Vector<dim>& x) const;

  // Shape-function stencil of a particle, with ghosted local indices filled in.
  void stencil(const Vector<dim>& x, Stencil<dim>& st) const;

 private:
  MPI_Comm comm_;
  DM da_ = nullptr, da_mp_ = nullptr;
  ShapeKind kind_;
  double h_;
  Vector<dim> lower_, upper_;
  std::array<int, dim> cells_{}, points_{};
  std::array<int, dim> own_start_{}, own_size_{}, ghost_start_{}, ghost_size_{};
  std::array<int, dim> procs_{};
  std::array<std::vector<int>, dim> range_end_;  // exclusive end of each process column's points
};

}  // namespace talus
