#pragma once
// The background grid: a PETSc DMDA whose points are the grid's shape
// functions (vertices for linear hats, Greville points for quadratic
// B-splines), distributed over the ranks of `comm`.
//
// The same DMDA is the DMSwarm cell DM. Its uniform coordinates place point i
// at lower + (i - offset) h, offset = 1/2 for quadratic B-splines, so that the
// DMDA cell k is centred on grid vertex k; ownership of particles follows
// owner_rank(), which mirrors PETSc's DMDA point location.
//
// The points of each axis are split over the process columns of that axis
// either evenly (PETSc's choice) or by explicit counts, which is how the
// ranks are balanced on the particles (talus/grid/partition.hpp).
#include <petscdmda.h>

#include <array>
#include <vector>

#include "talus/core/types.hpp"
#include "talus/shape/shape_functions.hpp"

namespace talus {

enum class Face { x_min, x_max, y_min, y_max, z_min, z_max };

// Grid points per process column along each axis (their sum is points()[a]).
template <int dim>
using Ownership = std::array<std::vector<int>, dim>;

template <int dim>
class Grid {
 public:
  // Without `ownership` (or with an empty one) PETSc splits the points evenly.
  Grid(MPI_Comm comm, const Vector<dim>& lower, const Vector<dim>& upper, double cell_size, ShapeKind kind,
       ParticleQuadrature quadrature = ParticleQuadrature::point, const Ownership<dim>* ownership = nullptr);
  ~Grid();
  Grid(const Grid&) = delete;
  Grid& operator=(const Grid&) = delete;

  MPI_Comm comm() const { return comm_; }
  DM dm() const { return da_; }                  // one scalar per grid point
  DM mass_momentum_dm() const { return da_mp_; }  // (m, m v) per grid point
  ShapeKind shape() const { return kind_; }
  ParticleQuadrature quadrature() const { return quadrature_; }
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
  // The grid point along each axis that decides which process column owns a
  // particle at x: k + 1 for the DMDA cell k (between points k and k + 1).
  std::array<int, dim> owner_points(const Vector<dim>& x) const;
  // Points per process column along each axis, as passed to the DMDA.
  Ownership<dim> ownership() const;
  // Rank owning a particle whose owner_points() are `c`, for process columns
  // ending (exclusively) at `ends` along each axis.
  static PetscMPIInt rank_of(const std::array<int, dim>& c, const std::array<std::vector<int>, dim>& ends);
  // Largest index distance, per axis, between two points of one particle's
  // stencil: two points farther apart never couple in the Jacobian.
  int reach() const { return (kind_ == ShapeKind::linear ? 1 : 2) + (quadrature_ == ParticleQuadrature::domain); }
  // The DMDA's ghost width, and the smallest number of points a process
  // column may own: the reach, so that a rank knows every point its owned
  // points couple with.
  int stencil_width() const { return reach(); }

  // Values per ghosted node (`fields` blocks of ghosted points, `components`
  // values per point: 1 or dim), each rank's contributions summed over all
  // ranks, complete on owned and ghost points alike.
  std::vector<double> sum_over_ranks(const std::vector<double>& mine, int fields, int components) const;

  // Shape-function stencil of a particle, with ghosted local indices filled
  // in; half_width: the particle's domain (domain quadrature only).
  void stencil(const Vector<dim>& x, Stencil<dim>& st, const Vector<dim>* half_width = nullptr) const;

 private:
  MPI_Comm comm_;
  DM da_ = nullptr, da_mp_ = nullptr;
  ShapeKind kind_;
  ParticleQuadrature quadrature_;
  double h_;
  Vector<dim> lower_, upper_;
  std::array<int, dim> cells_{}, points_{};
  std::array<int, dim> own_start_{}, own_size_{}, ghost_start_{}, ghost_size_{};
  std::array<std::vector<int>, dim> range_end_;  // exclusive end of each process column's points
};

}  // namespace talus
