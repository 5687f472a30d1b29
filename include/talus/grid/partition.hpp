#pragma once
// Balanced ranks (docs/parallel.md): the grid's DMDA ownership ranges chosen
// from where the particles are, so that no rank idles on empty grid.
//
// A DMDA splits each axis into process columns, so a partition is a process
// grid p_0 x p_1 (x p_2) = ranks and, along each axis, the points of each
// column. For every factorization of the rank count, each axis is cut where
// the particles' cumulative count along it reaches j/p_a of the total (the
// particles' marginal distribution along the axis), with every column at
// least the stencil width wide; the exact particle count of every rank is
// then evaluated for that candidate and the one with the smallest largest
// count wins (ties: the shorter total interface between columns, then the
// first in lexicographic order). The particles are the weight: the work of
// P2G, G2P and every stress update of every Newton iteration is per
// particle, and the active grid points (the rows of the Newton system) are
// where the particles are.
#include <mpi.h>

#include "talus/grid/grid.hpp"

namespace talus {

// Particles per rank, over all ranks.
struct RankLoad {
  long min = 0, max = 0, total = 0;
  int ranks = 1;
  double mean() const { return static_cast<double>(total) / ranks; }
  // max / mean: 1 for a perfect balance, `ranks` with every particle on one rank.
  double imbalance() const { return total > 0 ? max / mean() : 1.0; }
};

RankLoad rank_load(MPI_Comm comm, long local_particles);

template <int dim>
struct BalancedPartition {
  Ownership<dim> ownership;  // points per process column along each axis
  RankLoad load;             // particles per rank under this ownership
};

// The partition of `grid`'s points that balances the particles at
// `positions` (dim coordinates per particle of this rank); collective.
// Returns an empty ownership if the grid is too small to split among the
// ranks (fewer points than ranks times the stencil width along every axis).
template <int dim>
BalancedPartition<dim> balanced_partition(const Grid<dim>& grid, const double* positions, long local_particles);

}  // namespace talus
