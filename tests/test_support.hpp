#pragma once
// Helpers shared by the tests: cases from inline YAML, particle field access,
// and gathering particle data across ranks by particle id.
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "talus/io/config.hpp"
#include "talus/particles/particles.hpp"
#include "talus/solver/active_set.hpp"
#include "talus/solver/momentum_system.hpp"
#include "talus/transfer/transfer.hpp"

namespace talus::testing {

inline CaseConfig case_from_yaml(const std::string& yaml) { return parse_case(yaml, "<test case>"); }

// A PETSc option set for the lifetime of this object, then removed.
class ScopedOption {
 public:
  ScopedOption(std::string name, const char* value) : name_(std::move(name)) {
    TALUS_PETSC(PetscOptionsSetValue(nullptr, name_.c_str(), value));
  }
  ~ScopedOption() { PetscOptionsClearValue(nullptr, name_.c_str()); }
  ScopedOption(const ScopedOption&) = delete;
  ScopedOption& operator=(const ScopedOption&) = delete;

 private:
  std::string name_;
};

// Serial and parallel runs both on LU factors, so that they differ by
// round-off only: the serial default, GMRES on an incomplete LU, stops at the
// balance tolerance, so its answer differs from the parallel one (MUMPS's
// LU) by up to that tolerance times the conditioning (docs/solver.md).
inline ScopedOption lu_on_every_rank() { return ScopedOption("-talus_pc_type", "lu"); }

// All particles' values of a real field, ordered by particle id, on every rank.
template <int dim>
std::vector<double> gather_by_id(Particles<dim>& particles, const char* name, int block) {
  const PetscInt n = particles.local_count();
  std::vector<double> local;
  std::vector<long long> ids;
  {
    FieldView<PetscReal> f(particles.swarm(), name);
    FieldView<std::int64_t> id(particles.swarm(), field::particle_id);
    for (PetscInt p = 0; p < n; ++p) {
      ids.push_back(id[p]);
      for (int b = 0; b < block; ++b) local.push_back(f[block * p + b]);
    }
  }
  MPI_Comm comm = PetscObjectComm(reinterpret_cast<PetscObject>(particles.swarm()));
  int size;
  MPI_Comm_size(comm, &size);
  int count = static_cast<int>(n);
  std::vector<int> counts(size), displs(size, 0);
  MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, comm);
  for (int r = 1; r < size; ++r) displs[r] = displs[r - 1] + counts[r - 1];
  const int total = displs[size - 1] + counts[size - 1];
  std::vector<long long> all_ids(total);
  MPI_Allgatherv(ids.data(), count, MPI_LONG_LONG, all_ids.data(), counts.data(), displs.data(), MPI_LONG_LONG, comm);
  for (int r = 0; r < size; ++r) counts[r] *= block, displs[r] *= block;
  std::vector<double> all(static_cast<std::size_t>(total) * block);
  MPI_Allgatherv(local.data(), count * block, MPI_DOUBLE, all.data(), counts.data(), displs.data(), MPI_DOUBLE, comm);
  // Ids are unique but need not be contiguous (polygon bodies skip lattice points).
  std::vector<int> order(total);
  for (int k = 0; k < total; ++k) order[k] = k;
  std::sort(order.begin(), order.end(), [&](int a, int b) { return all_ids[a] < all_ids[b]; });
  std::vector<double> ordered(all.size());
  for (int k = 0; k < total; ++k)
    for (int b = 0; b < block; ++b) ordered[static_cast<std::size_t>(k) * block + b] = all[order[k] * block + b];
  return ordered;
}

// The grid side of a step, as Simulation::advance builds it: the particles'
// stencils, P2G (APIC) and the active points.
template <int dim>
struct GridStep {
  std::vector<Stencil<dim>> stencils;
  GridFields<dim> fields;
  ActiveSet<dim> active;
  GridStep(const Grid<dim>& grid, Particles<dim>& particles, const CaseConfig& config) {
    compute_stencils(grid, particles, stencils);
    particles_to_grid(grid, particles, stencils, TransferScheme::apic, fields);
    active.build(grid, fields, 1e-12, config.faces);
  }
};

// ||J_BAIJ - J_AIJ||_F / ||J_AIJ||_F at v: the Jacobian assembled into a
// block matrix (what the direct solvers get, src/solver/newton.cpp) against
// the same Jacobian assembled into `aij`, which the caller has filled.
template <int dim>
double block_matrix_difference(MomentumSystem<dim>& system, Vec v, Mat aij) {
  Mat baij = system.create_matrix(MATBAIJ);
  system.jacobian(v, baij);
  Mat converted;
  MatConvert(baij, MATAIJ, MAT_INITIAL_MATRIX, &converted);
  double norm = 0.0, difference = 0.0;
  MatNorm(aij, NORM_FROBENIUS, &norm);
  MatAXPY(converted, -1.0, aij, DIFFERENT_NONZERO_PATTERN);
  MatNorm(converted, NORM_FROBENIUS, &difference);
  MatDestroy(&converted);
  MatDestroy(&baij);
  return difference / norm;
}

// ||J(v) w - Jw||_2 / ||Jw||_2 with J(v) w from the particle operator
// (MomentumSystem::apply_jacobian, no matrix) and Jw = MatMult of the
// assembled Jacobian at v, which the caller has computed.
template <int dim>
double operator_difference(MomentumSystem<dim>& system, Vec v, Vec w, Vec Jw) {
  Vec y, d;
  VecDuplicate(w, &y);
  VecDuplicate(w, &d);
  system.prepare_operator(v);
  system.apply_jacobian(w, y);
  double norm = 0.0, difference = 0.0;
  VecNorm(Jw, NORM_2, &norm);
  VecWAXPY(d, -1.0, Jw, y);
  VecNorm(d, NORM_2, &difference);
  VecDestroy(&y);
  VecDestroy(&d);
  return difference / norm;
}

// max |D_rr - J_rr| / max |J_rr| over the owned dim x dim diagonal blocks,
// with D from MomentumSystem::jacobian_block_diagonal (point-block Jacobi's
// matrix, no block rows) and J the assembled Jacobian at v.
template <int dim>
double block_diagonal_difference(MomentumSystem<dim>& system, Vec v, Mat J) {
  Mat D = system.create_block_diagonal_matrix();
  system.jacobian_block_diagonal(v, D);
  PetscInt first = 0, last = 0;
  MatGetOwnershipRange(J, &first, &last);
  double scale = 0.0, difference = 0.0;
  for (PetscInt r = first; r < last; r += dim) {
    PetscInt index[dim];
    for (int a = 0; a < dim; ++a) index[a] = r + a;
    double j[dim * dim], d[dim * dim];
    MatGetValues(J, dim, index, dim, index, j);
    MatGetValues(D, dim, index, dim, index, d);
    for (int k = 0; k < dim * dim; ++k) {
      scale = std::max(scale, std::abs(j[k]));
      difference = std::max(difference, std::abs(j[k] - d[k]));
    }
  }
  MatDestroy(&D);
  MPI_Allreduce(MPI_IN_PLACE, &scale, 1, MPI_DOUBLE, MPI_MAX, PETSC_COMM_WORLD);
  MPI_Allreduce(MPI_IN_PLACE, &difference, 1, MPI_DOUBLE, MPI_MAX, PETSC_COMM_WORLD);
  return difference / scale;
}

// max_k |a_k - b_k| / max_k |a_k| (the plain difference when a is zero).
inline double max_relative_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double scale = 0, diff = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    scale = std::max(scale, std::abs(a[i]));
    diff = std::max(diff, std::abs(a[i] - b[i]));
  }
  return scale > 0 ? diff / scale : diff;
}

inline int comm_size(MPI_Comm comm) {
  int s;
  MPI_Comm_size(comm, &s);
  return s;
}

}  // namespace talus::testing
