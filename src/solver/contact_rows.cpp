// The contact rows of the step's system (docs/contact.md): the natural map
// of the Coulomb cone on the rows of obstacle contact points and of bodies
// in contact, and the factors their Jacobian rows are made of.
#include <algorithm>
#include <chrono>
#include <cmath>

#include "talus/solver/momentum_system.hpp"

namespace talus {

template <int dim>
void MomentumSystem<dim>::contact_rows(Vec v, Vec F) {
  const auto t0 = std::chrono::steady_clock::now();
  PetscScalar* f;
  const PetscScalar* x;
  TALUS_PETSC(VecGetArray(F, &f));
  TALUS_PETSC(VecGetArrayRead(v, &x));
  for (std::size_t c = 0; c < contacts_.size(); ++c) {
    const ContactPoint<dim>& cp = contacts_[c];
    if (cp.rigid >= 0) {
      // A rigid body's contact point: the unknown is the impulse r itself;
      // the velocity is the body's at its surface point, plus the compliance
      // eps r / rho that makes the impulses of a body resting on several
      // points unique (momentum_system.hpp).
      const RigidBody<dim>& rb = rigid_[cp.rigid];
      const Vector<dim> r = Eigen::Map<const Vector<dim>>(x + cp.row);
      const typename RigidBody<dim>::Map T = rb.velocity_map(cp.surface);
      // An open gap g > 0 may close within the step: the normal velocity is
      // measured against -g / h (the body reaches the obstacle at t^{n+1}),
      // not against 0, which would stop a rolling body's next contact point
      // before it touches (an inelastic impact per grid cell rolled).
      const Vector<dim> u = T * motion_[cp.rigid] - cp.obstacle_velocity + (rigid_compliance / cp.rho) * r +
                            (std::max(cp.gap, 0.0) / h_) * cp.normal;
      contact_impulse_[c] = r;
      contact_map_[c] = natural_map<dim>(r, u, cp.normal, cp.friction, cp.restitution, cp.start_normal_velocity, cp.rho);
      Eigen::Map<Vector<dim>>(f + cp.row) = contact_map_[c].value;
      rigid_impulse_[cp.rigid] -= T.transpose() * r;
      continue;
    }
    // The impulse the obstacle must supply: the momentum imbalance R_i(v).
    // A slip-face component is held by the face (its row stays m v = 0), so
    // the obstacle's impulse and the velocity have none there.
    Vector<dim> r = Eigen::Map<const Vector<dim>>(f + cp.row);
    Vector<dim> u = Eigen::Map<const Vector<dim>>(x + cp.row);
    for (int a = 0; a < dim; ++a)
      if (!cp.free[a]) r[a] = u[a] = 0.0;
    u -= cp.obstacle_velocity;
    // A point whose material crossed the obstacle in an attempt of the step
    // without it: the open gap closes within the step (u_N >= -g / h), as a
    // rigid body's does above; held at u_N >= 0 it would leave the material
    // hovering at the gap (docs/contact.md#which-grid-points-are-contact-points).
    if (cp.closes_gap) u += (cp.gap / h_) * cp.normal;
    contact_impulse_[c] = r;
    contact_map_[c] = natural_map<dim>(r, u, cp.normal, cp.friction, cp.restitution, cp.start_normal_velocity, cp.rho);
    for (int a = 0; a < dim; ++a)
      if (cp.free[a]) f[cp.row + a] = contact_map_[c].value[a];
  }
  for (std::size_t c = 0; c < body_contacts_.size(); ++c) {
    const BodyContactPoint<dim>& cp = body_contacts_[c];
    // The impulse body b gives body a: a's momentum imbalance R_a(v).
    const Vector<dim> r = Eigen::Map<const Vector<dim>>(f + cp.row_a);
    const Vector<dim> u = Eigen::Map<const Vector<dim>>(x + cp.row_a) - Eigen::Map<const Vector<dim>>(x + cp.row_b);
    body_impulse_[c] = r;
    body_map_[c] = natural_map<dim>(r, u, -cp.normal, cp.friction, 0.0, cp.start_normal_velocity, cp.rho);
    if (rigid_node(cp.node_b)) {
      // A rigid hub: -r acts on the body (its row is its rigid constraint).
      const int k = rigid_of_field_[cp.node_b / points_];
      rigid_impulse_[k] += rigid_[k].velocity_map(grid_.point_position(grid_.global_index(cp.node_b % points_))).transpose() * r;
    } else {
      Eigen::Map<Vector<dim>>(f + cp.row_b) += r;  // R_a + R_b: the point's total balance
    }
    Eigen::Map<Vector<dim>>(f + cp.row_a) = body_map_[c].value;
  }
  TALUS_PETSC(VecRestoreArrayRead(v, &x));
  TALUS_PETSC(VecRestoreArray(F, &f));
  if (!contact_at_) TALUS_PETSC(VecDuplicate(v, &contact_at_));
  TALUS_PETSC(VecCopy(v, contact_at_));
  contact_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

template <int dim>
void MomentumSystem<dim>::contact_factors(Vec v) {
  PetscBool same = PETSC_FALSE;
  if (contact_at_) TALUS_PETSC(VecEqual(v, contact_at_, &same));
  if (!same) {
    Vec F;
    TALUS_PETSC(VecDuplicate(v, &F));
    residual(v, F);
    TALUS_PETSC(VecDestroy(&F));
  }
  contact_left_.resize(contacts_.size());
  contact_right_.resize(contacts_.size());
  for (std::size_t c = 0; c < contacts_.size(); ++c) {
    Matrix<dim>& P = contact_left_[c];
    Matrix<dim>& Q = contact_right_[c];
    P = contact_map_[c].d_impulse;
    Q = contact_map_[c].d_velocity;
    for (int a = 0; a < dim; ++a)
      if (!contacts_[c].free[a]) P.col(a).setZero(), Q.col(a).setZero();
    for (int a = 0; a < dim; ++a)
      if (!contacts_[c].free[a]) P.row(a) = Matrix<dim>::Identity().row(a), Q.row(a).setZero();
  }
  body_left_.resize(body_contacts_.size());
  body_right_.resize(body_contacts_.size());
  for (std::size_t c = 0; c < body_contacts_.size(); ++c) {
    body_left_[c] = body_map_[c].d_impulse;
    body_right_[c] = body_map_[c].d_velocity;
  }
}

template <int dim>
std::vector<double> MomentumSystem<dim>::contact_row_factors(Vec v, std::vector<int>& partner) {
  contact_factors(v);
  const auto t0 = std::chrono::steady_clock::now();
  // The natural map's row block of contact point i is linear in the point's
  // momentum row block dR_i/dv (the assembled row, mass included):
  //   dPhi_i/dv = P_i dR_i/dv + Q_i E_i,   E_i: the columns of v_i,
  //   P_i = I - D_i (= dPhi/dr),  Q_i = rho_i D_i du_hat/du (= dPhi/du),
  // where a component held by a slip face keeps its own row (r_a = v_a = 0
  // are constants: column a of P and Q drops out, row a of P is e_a, of Q 0).
  // Linear in the row, so every rank can apply P_i to its own particles'
  // share of the row before the shares are summed: the contact rows are
  // written in the same assembly pass as the momentum rows (no MatGetRow,
  // no second assembly). Ranks that hold point i as a ghost need P_i from its
  // owner: one scatter per column of P. Q_i goes with the mass, on the owner.
  // A body contact's row a is P times its momentum row, and its row b takes
  // that momentum row as well: ranks that hold a as a ghost learn b (its
  // field + 1 in the first component; 0: none) through the same scatter.
  const int n = nodes_;
  std::vector<double> left(static_cast<std::size_t>(n) * dim * dim, 0.0), column;
  Vec compact = active_.create_vector();
  for (int j = 0; j < dim; ++j) {
    PetscScalar* x;
    TALUS_PETSC(VecGetArray(compact, &x));
    const PetscInt owned = active_.owned_count();
    for (PetscInt k = 0; k < owned; ++k)
      for (int a = 0; a < dim; ++a) x[dim * k + a] = a == j ? 1.0 : 0.0;
    for (std::size_t c = 0; c < contacts_.size(); ++c)
      for (int a = 0; a < dim; ++a) x[contacts_[c].row + a] = contact_left_[c](a, j);
    for (std::size_t c = 0; c < body_contacts_.size(); ++c)
      for (int a = 0; a < dim; ++a) x[body_contacts_[c].row_a + a] = body_left_[c](a, j);
    TALUS_PETSC(VecRestoreArray(compact, &x));
    active_.to_grid(compact, column);
    for (int i = 0; i < n; ++i)
      for (int a = 0; a < dim; ++a) left[(static_cast<std::size_t>(i) * dim + a) * dim + j] = column[dim * i + a];
  }
  partner.assign(n, -1);
  int any_bodies = 0, local_bodies = body_contacts_.empty() ? 0 : 1;
  MPI_Allreduce(&local_bodies, &any_bodies, 1, MPI_INT, MPI_MAX, grid_.comm());
  if (any_bodies) {
    TALUS_PETSC(VecZeroEntries(compact));
    PetscScalar* x;
    TALUS_PETSC(VecGetArray(compact, &x));
    for (const BodyContactPoint<dim>& cp : body_contacts_) x[cp.row_a] = cp.node_b / points_ + 1;
    TALUS_PETSC(VecRestoreArray(compact, &x));
    active_.to_grid(compact, column);
    for (int i = 0; i < n; ++i) {
      const long field = std::lround(column[static_cast<std::size_t>(dim) * i]) - 1;
      if (field >= 0) partner[i] = static_cast<int>(field) * points_ + i % points_;
    }
  }
  TALUS_PETSC(VecDestroy(&compact));
  contact_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return left;
}

template void MomentumSystem<2>::contact_rows(Vec, Vec);
template void MomentumSystem<3>::contact_rows(Vec, Vec);
template void MomentumSystem<2>::contact_factors(Vec);
template void MomentumSystem<3>::contact_factors(Vec);
template std::vector<double> MomentumSystem<2>::contact_row_factors(Vec, std::vector<int>&);
template std::vector<double> MomentumSystem<3>::contact_row_factors(Vec, std::vector<int>&);

}  // namespace talus
