// The rows of rigid bodies in the step's system (momentum_system.hpp,
// docs/contact.md#rigid-bodies): the rigid constraint of their grid points,
// the bodies' Newton-Euler equations, and their Jacobian entries.
#include <mpi.h>

#include "talus/solver/momentum_system.hpp"

namespace talus {

namespace {

int last_rank(MPI_Comm comm) {
  int size = 1;
  MPI_Comm_size(comm, &size);
  return size - 1;
}

}  // namespace

template <int dim>
bool MomentumSystem<dim>::rigid_particle(std::size_t p) const {
  if (rigid_.empty() || stencils_[p].count == 0) return false;
  return rigid_of_field_[stencils_[p].local[0] / points_] >= 0;
}

template <int dim>
void MomentumSystem<dim>::gather_motion(Vec v) {
  // q lives in the last rank's extra blocks (ActiveSet); every rank needs it.
  constexpr int U = RigidBody<dim>::unknowns;
  std::vector<double> q(rigid_.size() * U, 0.0);
  const MPI_Comm comm = grid_.comm();
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  const int owner = last_rank(comm);
  if (rank == owner) {
    const PetscScalar* x;
    TALUS_PETSC(VecGetArrayRead(v, &x));
    for (std::size_t b = 0; b < rigid_.size(); ++b)
      for (int j = 0; j < U; ++j) q[b * U + j] = x[(rigid_[b].block - rigid_first_) * dim + j];
    TALUS_PETSC(VecRestoreArrayRead(v, &x));
  }
  MPI_Bcast(q.data(), static_cast<int>(q.size()), MPI_DOUBLE, owner, comm);
  for (std::size_t b = 0; b < rigid_.size(); ++b) motion_[b] = Eigen::Map<const typename RigidBody<dim>::Motion>(q.data() + b * U);
}

template <int dim>
void MomentumSystem<dim>::rigid_rows(Vec v, Vec F) {
  constexpr int U = RigidBody<dim>::unknowns;
  PetscScalar* f;
  const PetscScalar* x;
  TALUS_PETSC(VecGetArray(F, &f));
  TALUS_PETSC(VecGetArrayRead(v, &x));
  // The rigid constraint m_i (v_i - T(x_i) q) = 0 of the body's points.
  const auto& owned = active_.owned_points();
  for (std::size_t k = 0; k < owned.size(); ++k) {
    const int i = owned[k];
    if (!rigid_node(i) || rigid_contact_[i] >= 0) continue;
    const Eigen::Map<const Vector<dim>> vi(velocity_.data() + static_cast<std::size_t>(dim) * i);  // T(x_i) q
    for (int c = 0; c < dim; ++c) f[dim * k + c] = fields_.mass[i] * (x[dim * k + c] - vi[c]);
  }
  // The bodies' rows: G (q - q^n) - h (M g, 0) + the impulses from the
  // contacts of every rank.
  std::vector<double> local(rigid_.size() * U), total(local.size());
  for (std::size_t b = 0; b < rigid_.size(); ++b)
    Eigen::Map<typename RigidBody<dim>::Motion>(local.data() + b * U) = rigid_impulse_[b];
  MPI_Allreduce(local.data(), total.data(), static_cast<int>(local.size()), MPI_DOUBLE, MPI_SUM, grid_.comm());
  int rank = 0;
  MPI_Comm_rank(grid_.comm(), &rank);
  if (rank == last_rank(grid_.comm()))
    for (std::size_t b = 0; b < rigid_.size(); ++b) {
      const RigidBody<dim>& rb = rigid_[b];
      typename RigidBody<dim>::Motion row = rb.generalized_mass() * (motion_[b] - rb.start);
      row.template head<dim>() -= h_ * rb.mass * gravity_;
      row += Eigen::Map<const typename RigidBody<dim>::Motion>(total.data() + b * U);
      for (int j = 0; j < U; ++j) f[(rb.block - rigid_first_) * dim + j] = row[j];
    }
  TALUS_PETSC(VecRestoreArrayRead(v, &x));
  TALUS_PETSC(VecRestoreArray(F, &f));
}

template <int dim>
void MomentumSystem<dim>::rigid_jacobian(Mat J, const std::vector<double>& left) {
  constexpr int U = RigidBody<dim>::unknowns;
  using Block = Eigen::Matrix<double, dim, U, Eigen::RowMajor>;
  using BlockT = Eigen::Matrix<double, U, dim, Eigen::RowMajor>;
  const auto& owned = active_.owned_points();
  for (std::size_t k = 0; k < owned.size(); ++k) {
    const int i = owned[k];
    if (!rigid_node(i)) continue;
    const RigidBody<dim>& rb = rigid_body_of(i);
    const PetscInt r = rigid_first_ + static_cast<PetscInt>(k), q[2] = {rb.block, rb.block + 1};
    const int c = left.empty() ? -1 : rigid_contact_[i];  // (left is empty only without contacts)
    if (c < 0) {
      // m_i (v_i - T(x_i) q): -m_i T on q (m_i I on v_i with the masses).
      const Block block = -fields_.mass[i] * rb.velocity_map(grid_.point_position(grid_.global_index(i % points_)));
      TALUS_PETSC(MatSetValuesBlocked(J, 1, &r, 2, q, block.data(), ADD_VALUES));
      continue;
    }
    // Phi(r, T(x_s) q - v_o + eps r / rho): Q T(x_s) on q; on the body's
    // rows -T(x_s)^T on r (the diagonal block is set with the masses).
    const typename RigidBody<dim>::Map T = rb.velocity_map(contacts_[c].surface);
    const Block block = contact_right_[c] * T;
    TALUS_PETSC(MatSetValuesBlocked(J, 1, &r, 2, q, block.data(), ADD_VALUES));
    const BlockT impulse = -T.transpose();
    TALUS_PETSC(MatSetValuesBlocked(J, 2, q, 1, &r, impulse.data(), ADD_VALUES));
  }
  int rank = 0;
  MPI_Comm_rank(grid_.comm(), &rank);
  if (rank == last_rank(grid_.comm()))
    for (const RigidBody<dim>& rb : rigid_) {
      const PetscInt q[2] = {rb.block, rb.block + 1};
      const Eigen::Matrix<double, U, U, Eigen::RowMajor> G = rb.generalized_mass();
      TALUS_PETSC(MatSetValuesBlocked(J, 2, q, 2, q, G.data(), ADD_VALUES));
    }
}

template bool MomentumSystem<2>::rigid_particle(std::size_t) const;
template bool MomentumSystem<3>::rigid_particle(std::size_t) const;
template void MomentumSystem<2>::gather_motion(Vec);
template void MomentumSystem<3>::gather_motion(Vec);
template void MomentumSystem<2>::rigid_rows(Vec, Vec);
template void MomentumSystem<3>::rigid_rows(Vec, Vec);
template void MomentumSystem<2>::rigid_jacobian(Mat, const std::vector<double>&);
template void MomentumSystem<3>::rigid_jacobian(Mat, const std::vector<double>&);

}  // namespace talus
