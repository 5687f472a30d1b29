#include "talus/solver/momentum_system.hpp"
#include "talus/solver/strain_increment.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>

namespace talus {

namespace {

// W s - s W in Voigt order for a symmetric s and the skew W with W_01 = a,
// W_02 = b, W_12 = c: the Jaumann rate's spin term. It is M + M^T with
// M = W s, written out (about 20 multiply-adds instead of two 3 x 3
// products and their conversions).
Voigt spin_term(const Voigt& s, double a, double b, double c) {
  const double s00 = s[0], s11 = s[1], s22 = s[2], s12 = s[3], s02 = s[4], s01 = s[5];
  Voigt q;
  q << 2.0 * (a * s01 + b * s02), 2.0 * (c * s12 - a * s01), -2.0 * (b * s02 + c * s12),
      c * s22 - a * s02 - b * s01 - c * s11, a * s12 + b * s22 - b * s00 - c * s01,
      a * s11 + b * s12 - a * s00 + c * s02;
  return q;
}

}  // namespace

template <int dim>
MomentumSystem<dim>::MomentumSystem(const Grid<dim>& grid, const Particles<dim>& particles,
                                    const std::vector<Stencil<dim>>& stencils, const GridFields<dim>& fields,
                                    const ActiveSet<dim>& active, const std::vector<const Material*>& materials,
                                    const Vector<dim>& gravity, double h, double theta,
                                    std::vector<ContactPoint<dim>> contacts,
                                    std::vector<BodyContactPoint<dim>> body_contacts,
                                    std::vector<RigidBody<dim>> rigid)
    : grid_(grid),
      stencils_(stencils),
      fields_(fields),
      active_(active),
      materials_(materials),
      gravity_(gravity),
      h_(h),
      theta_(theta),
      contacts_(std::move(contacts)),
      body_contacts_(std::move(body_contacts)),
      rigid_(std::move(rigid)) {
  points_ = grid.ghosted_count();
  nodes_ = static_cast<int>(fields.mass.size());
  rigid_of_field_.assign(fields.field_count, -1);
  for (std::size_t k = 0; k < rigid_.size(); ++k) {
    rigid_of_field_[rigid_[k].field] = static_cast<int>(k);
    motion_.push_back(rigid_[k].start);
  }
  rigid_impulse_.assign(rigid_.size(), RigidBody<dim>::Motion::Zero());
  if (!rigid_.empty()) {
    rigid_contact_.assign(nodes_, -1);
    for (std::size_t c = 0; c < contacts_.size(); ++c)
      if (contacts_[c].rigid >= 0) rigid_contact_[contacts_[c].point] = static_cast<int>(c);
  }
  {
    Vec layout = active.create_vector();
    TALUS_PETSC(VecGetOwnershipRange(layout, &rigid_first_, nullptr));
    TALUS_PETSC(VecDestroy(&layout));
    rigid_first_ /= dim;
  }
  contact_impulse_.assign(contacts_.size(), Vector<dim>::Zero());
  contact_map_.resize(contacts_.size());
  body_impulse_.assign(body_contacts_.size(), Vector<dim>::Zero());
  body_map_.resize(body_contacts_.size());
  // The contact evaluation has collective parts (VecEqual, assembly): every
  // rank takes it when any rank has a contact point.
  int local_contacts = contacts_.empty() && body_contacts_.empty() ? 0 : 1;
  MPI_Allreduce(&local_contacts, &any_contacts_, 1, MPI_INT, MPI_MAX, grid.comm());
  const PetscInt np = particles.local_count();
  DM sw = particles.swarm();
  FieldView<PetscReal> s(sw, field::stress), v0(sw, field::initial_volume);
  FieldView<PetscInt> mat(sw, field::material_id);
  FieldView<PetscReal> state(sw, field::material_state), separation(sw, field::separation_strain);
  state_old_.assign(state.data(), state.data() + static_cast<std::size_t>(max_state_size) * np);
  state_end_ = state_old_;
  stress_old_.resize(np);
  reference_volume_.resize(np);
  separation_old_.assign(separation.data(), separation.data() + np);
  separation_end_ = separation_old_;
  closed_voids_.assign(np, 0.0);
  rotated_stress_ = stress_old_;
  material_.resize(np);
  for (PetscInt p = 0; p < np; ++p) {
    stress_old_[p] = Eigen::Map<const Voigt>(s.data() + 6 * p);
    // The step works on the configuration at t^n (gradients at x^n).
    // The stored stress is the Kirchhoff stress tau = J sigma, so the
    // internal force V sigma grad N = V0 tau grad N needs only the initial
    // volume (docs/formulation.md). Volume opened by plastic dilatancy or at
    // the apex then never scales the stiffness of a particle.
    reference_volume_[p] = v0[p];
    material_[p] = mat[p];
  }
  stress_end_ = stress_old_;
  plastic_increment_.assign(np, Voigt::Zero());
  tangent_.resize(np);
  stiff_.assign(np, 0);

  // v^n on the unknowns only: inactive points and constrained components carry none.
  velocity_old_.assign(static_cast<std::size_t>(nodes_) * dim, 0.0);
  for (int i = 0; i < nodes_; ++i)
    if (active.compact_index(i) >= 0)
      for (int c = 0; c < dim; ++c)
        if (!active.constrained(i, c)) velocity_old_[dim * i + c] = fields.velocity[dim * i + c];
}

template <int dim>
MomentumSystem<dim>::~MomentumSystem() {
  VecDestroy(&evaluated_at_);
  VecDestroy(&contact_at_);
  if (workspace_) jacobian_rows_.swap(workspace_->jacobian_rows);
}

template <int dim>
void MomentumSystem<dim>::use_workspace(MomentumWorkspace& workspace) {
  workspace_ = &workspace;
  jacobian_rows_.swap(workspace.jacobian_rows);
}

template <int dim>
bool MomentumSystem<dim>::evaluated_at(Vec v) const {
  if (!evaluated_at_) return false;
  PetscBool same = PETSC_FALSE;
  TALUS_PETSC(VecEqual(v, evaluated_at_, &same));
  return same;
}

template <int dim>
void MomentumSystem<dim>::pack_stencils() {
  if (!packed_offset_.empty()) return;
  // A Stencil reserves room for 4 functions per axis (domain quadrature) and
  // its arrays lie a few kB apart, so on a large grid every particle read
  // from the stencils cost a TLB miss and a dozen cache misses that no
  // prefetcher foresaw: the Jacobian's product took 430 ns per particle at
  // 128,000 particles in 3D, 200 ns from these packed arrays.
  std::size_t nodes = 0;
  for (const Stencil<dim>& st : stencils_) nodes += static_cast<std::size_t>(st.count);
  packed_offset_.reserve(stencils_.size() + 1);
  packed_offset_.assign(1, 0);
  packed_local_.reserve(nodes);
  packed_lin_.reserve(nodes);
  packed_gradient_.reserve(nodes * dim);
  // lin = sum_ax node[ax] width^ax, width = 2 reach + 1: lin(b) - lin(a) is
  // b's position in a's block row, relative to its centre (jacobian()).
  const int width = 2 * grid_.reach() + 1;
  for (const Stencil<dim>& st : stencils_) {
    for (int b = 0; b < st.count; ++b) {
      int lin = 0;
      for (int ax = 0, w = 1; ax < dim; ++ax, w *= width) lin += st.node[b][ax] * w;
      packed_lin_.push_back(lin);
      packed_local_.push_back(st.local[b]);
      for (int k = 0; k < dim; ++k) packed_gradient_.push_back(st.gradient[b][k]);
    }
    packed_offset_.push_back(static_cast<int>(packed_local_.size()));
  }
  // The tensor-product stencils, in 3D (tensor_stencil.hpp): nodes x
  // fastest at unit steps of the ghosted arrays (evaluate_stencil's order),
  // checked, not assumed.
  tensor_base_.clear();
  if constexpr (dim == 3) pack_tensor_stencils();
}

template <int dim>
void MomentumSystem<dim>::pack_tensor_stencils() {
  constexpr int n1 = 3, n_tensor = dim == 2 ? 9 : 27;
  tensor_stride_[0] = 1;
  for (int ax = 1; ax < dim; ++ax) tensor_stride_[ax] = tensor_stride_[ax - 1] * grid_.ghost_size()[ax - 1];
  tensor_base_.assign(stencils_.size(), -1);
  tensor_basis_.resize(stencils_.size() * 2 * dim * n1);
  for (std::size_t p = 0; p < stencils_.size(); ++p) {
    const Stencil<dim>& st = stencils_[p];
    bool tensor = st.count == n_tensor;
    for (int ax = 0; ax < dim && tensor; ++ax) tensor = st.basis[ax].count == n1;
    for (int n = 0; n < st.count && tensor; ++n) {
      int offset = 0;
      for (int ax = 0, rest = n; ax < dim; ++ax, rest /= n1) {
        offset += (rest % n1) * tensor_stride_[ax];
        tensor = tensor && st.node[n][ax] == st.basis[ax].first + rest % n1;
      }
      tensor = tensor && st.local[n] == st.local[0] + offset;
    }
    if (!tensor) continue;
    tensor_base_[p] = st.local[0];
    double* basis = tensor_basis_.data() + p * 2 * dim * n1;
    for (int ax = 0; ax < dim; ++ax)
      for (int a = 0; a < n1; ++a) {
        basis[2 * ax * n1 + a] = st.basis[ax].value[a];
        basis[(2 * ax + 1) * n1 + a] = st.basis[ax].slope[a];
      }
  }
}

template <int dim>
void MomentumSystem<dim>::evaluate_particles(Vec v) {
  const auto t0 = std::chrono::steady_clock::now();
  if (with_tangents_) pack_stencils();
  active_.to_grid_active(v, velocity_);  // zero elsewhere: only active entries are set below
  for (const int e : active_.constrained_entries()) velocity_[e] = 0.0;
  if (!rigid_.empty()) {
    // A rigid body's grid velocities are its rigid motion (its contact
    // points' unknowns are impulses, not velocities).
    gather_motion(v);
    for (int i = 0; i < nodes_; ++i)
      if (rigid_node(i) && active_.compact_index(i) >= 0) {
        const RigidBody<dim>& rb = rigid_body_of(i);
        Eigen::Map<Vector<dim>>(velocity_.data() + static_cast<std::size_t>(dim) * i) =
            rb.velocity_map(grid_.point_position(grid_.global_index(i % points_))) *
            motion_[rigid_of_field_[i / points_]];
      }
  }
  force_.assign(velocity_.size(), 0.0);

  const std::size_t np = stencils_.size();
  // Tensor-product stencils (tensor_stencil.hpp, packed with the stencils):
  // every L_p from v_theta on the grid first, and the internal forces from
  // V_p sigma_theta after the loop; the other particles node by node in it.
  const bool tensor = !tensor_base_.empty();
  if (tensor) {
    velocity_theta_.resize(velocity_.size() + dim);  // one node of padding
    for (std::size_t e = 0; e < velocity_.size(); ++e)
      velocity_theta_[e] = theta_ * velocity_[e] + (1.0 - theta_) * velocity_old_[e];
    std::fill(velocity_theta_.end() - dim, velocity_theta_.end(), 0.0);
    particle_gradient_.resize(np * nL);
    if constexpr (dim == 3) gather_tensor_gradients(tensor_stencils(), velocity_theta_.data(), particle_gradient_.data());
    particle_force_stress_.resize(np * nS);
  }
  MaterialPointUpdate update;
  const bool primal_dual = primal_dual_ && with_tangents_;
  plastic_particles_ = 0;
  if (primal_dual) carried_.begin_evaluation(np);
  for (std::size_t p = 0; p < np; ++p) {
    if (rigid_particle(p)) {
      // A rigid body's particles do not strain: no stress, no internal force.
      stress_end_[p] = rotated_stress_[p] = stress_old_[p];
      plastic_increment_[p].setZero();
      closed_voids_[p] = 0.0;
      tangent_[p].setZero();
      stiff_[p] = 0;
      if (tensor) std::fill_n(particle_force_stress_.begin() + p * nS, nS, 0.0);
      continue;
    }
    const bool tensor_p = tensor && tensor_base_[p] >= 0;
    const auto [count, local, gradient] = nodes_of(p);
    Matrix<dim> L = Matrix<dim>::Zero();
    if (tensor_p) L = Eigen::Map<const Eigen::Matrix<double, dim, dim, Eigen::RowMajor>>(particle_gradient_.data() + p * nL);
    for (int k = 0; k < count && !tensor_p; ++k) {
      const std::size_t o = static_cast<std::size_t>(dim) * local[k];
      const Vector<dim> vt = theta_ * Eigen::Map<const Vector<dim>>(velocity_.data() + o) +
                             (1.0 - theta_) * Eigen::Map<const Vector<dim>>(velocity_old_.data() + o);
      L += vt * Eigen::Map<const Vector<dim>>(gradient + dim * k).transpose();
    }
    Eigen::Matrix3d L3 = Eigen::Matrix3d::Zero();
    L3.template topLeftCorner<dim, dim>() = L;
    // sigma* = s + h (W s - s W), W = (L - L^T)/2.
    const Voigt& sn = stress_old_[p];
    const Voigt rotated = sn + h_ * spin_term(sn, 0.5 * (L3(0, 1) - L3(1, 0)), 0.5 * (L3(0, 2) - L3(2, 0)),
                                               0.5 * (L3(1, 2) - L3(2, 1)));
    // h sym L, or the Hencky strain of the step's stretch with its derivative
    // (docs/formulation.md#the-strain-increment; the linear one's derivative
    // is h on the matching component, taken below as it is).
    const bool logarithmic = strain_increment_ == StrainIncrement::logarithmic;
    const StrainIncrementResult increment =
        strain_increment(L3, h_, strain_increment_, logarithmic && with_tangents_ ? dim : 0);
    Voigt strain = increment.strain;
    // Compression first closes the voids of a separated particle, stress
    // free: the volumetric strain d = max(tr d_eps, -s^n) (when negative) is
    // taken off the increment the solid sees (docs/plasticity.md).
    const double volumetric = strain[0] + strain[1] + strain[2];
    const bool closing = separation_old_[p] > 0.0 && volumetric < 0.0;
    const bool closes_fully = closing && volumetric <= -separation_old_[p];
    const double closed = !closing ? 0.0 : closes_fully ? -separation_old_[p] : volumetric;
    strain.head<3>().array() -= closed / 3.0;
    const Material& material = *materials_[material_[p]];
    const double* state_old = state_old_.data() + max_state_size * p;
    material.update(rotated, strain, state_old, state_end_.data() + max_state_size * p, update);
    const bool plastic = !update.plastic_strain_increment.isZero(0.0);
    plastic_particles_ += plastic;
    if (primal_dual) {
      // The primal-dual tangent at the stress carried from the last iterate
      // (primal_dual_tangent.hpp); an elastic particle needs none.
      if (!plastic) {
        carried_.record_elastic(p);
      } else {
        const Voigt trial = rotated + material.elastic_stiffness() * strain;
        Voigt carried;
        if (carried_.carried(p, trial, carried) && carried_far_from(carried, update.stress))
          add_primal_dual_term(material, trial, carried, state_old, update);
        carried_.record(p, update.stress, trial, update.trial_sensitivity);
      }
    }
    separation_end_[p] = separation_old_[p] + closed + update.separation_strain_increment;
    closed_voids_[p] = closed;
    rotated_stress_[p] = rotated;
    if (closing && !closes_fully) {
      // d(strain seen)/d(strain) = I - (1/3) 1 1^T on the volumetric part.
      const Voigt volumetric_column = update.tangent.leftCols<3>().rowwise().sum() / 3.0;
      for (int j = 0; j < 3; ++j) update.tangent.col(j) -= volumetric_column;
    }
    stress_end_[p] = update.stress;
    plastic_increment_[p] = update.plastic_strain_increment;

    // A = d sigma^{n+1}_ij / d L_kl = h D[ij, kl] + S[ij, :] d sigma*/d L_kl, with
    // d sigma*_ij / d L_kl = h/2 (d_ik s_lj - d_il s_kj - s_ik d_lj + s_il d_kj).
    // The rotation sees only the spin, the skew part of L: d sigma*/d L_kk = 0
    // and d sigma*/d L_lk = -d sigma*/d L_kl, so one product with S per pair
    // k < l (one in 2D, three in 3D) instead of one per component.
    StressTangent& A = tangent_[p];
    for (int k = 0; k < dim && with_tangents_; ++k)
      for (int l = k; l < dim; ++l) {
        // D d(de)/dL_kl: h D[:, (kl)] for the linear increment; the
        // logarithmic one's d(de)/dL_kl and d(de)/dL_lk differ at second order.
        const Voigt strain_column = logarithmic ? Voigt(update.tangent * increment.derivative.col(3 * k + l))
                                                : Voigt(h_ * update.tangent.col(voigt_index(k, l)));
        if (k == l) {
          for (int i = 0; i < dim; ++i)
            for (int j = i; j < dim; ++j) A(stress_row<dim>(i, j), k * dim + k) = strain_column[voigt_index(i, j)];
          continue;
        }
        const Voigt strain_column_lk =
            logarithmic ? Voigt(update.tangent * increment.derivative.col(3 * l + k)) : strain_column;
        // d sigma*/d L_kl = h (dW s - s dW), dW = dW/dL_kl: the skew unit of
        // the pair k < l with W_kl = 1/2.
        const int pair = k == 0 ? l - 1 : 2;  // (0,1) -> a, (0,2) -> b, (1,2) -> c
        const Voigt spin_column = update.trial_sensitivity * (h_ * spin_term(sn, pair == 0 ? 0.5 : 0.0,
                                                                             pair == 1 ? 0.5 : 0.0,
                                                                             pair == 2 ? 0.5 : 0.0));
        for (int i = 0; i < dim; ++i)
          for (int j = i; j < dim; ++j) {
            const int v = voigt_index(i, j);
            A(stress_row<dim>(i, j), k * dim + l) = strain_column[v] + spin_column[v];
            A(stress_row<dim>(i, j), l * dim + k) = strain_column_lk[v] - spin_column[v];
          }
      }

    if (with_tangents_) stiff_[p] = !A.isZero(0.0);
    const Voigt st_theta = (1.0 - theta_) * stress_old_[p] + theta_ * update.stress;
    const Eigen::Matrix3d sigma = voigt_to_tensor(st_theta);
    const Matrix<dim> s_dim = sigma.template topLeftCorner<dim, dim>();
    if (tensor_p) {
      for (int i = 0; i < dim; ++i)
        for (int j = i; j < dim; ++j) particle_force_stress_[p * nS + stress_row<dim>(i, j)] = reference_volume_[p] * s_dim(i, j);
      continue;
    }
    for (int k = 0; k < count; ++k) {
      Eigen::Map<Vector<dim>> f(force_.data() + static_cast<std::size_t>(dim) * local[k]);
      f += reference_volume_[p] * (s_dim * Eigen::Map<const Vector<dim>>(gradient + dim * k));
    }
  }
  if (tensor) {
    const std::size_t size = force_.size();
    force_.resize(size + dim, 0.0);  // the rows' padding
    if constexpr (dim == 3) scatter_tensor_stresses(tensor_stencils(), particle_force_stress_.data(), force_.data());
    force_.resize(size);
  }
  if (!evaluated_at_) TALUS_PETSC(VecDuplicate(v, &evaluated_at_));
  TALUS_PETSC(VecCopy(v, evaluated_at_));
  material_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

template <int dim>
void MomentumSystem<dim>::step_displacement(std::vector<double>& u) const {
  u.resize(velocity_.size());
  for (std::size_t k = 0; k < u.size(); ++k) u[k] = h_ * (theta_ * velocity_[k] + (1.0 - theta_) * velocity_old_[k]);
}

template <int dim>
void MomentumSystem<dim>::residual(Vec v, Vec F) {
  evaluate_particles(v);
  if (ghost_) {
    // f += K h v_theta (ghost_penalty.hpp), before the common factor h below.
    step_displacement(ghost_work_);
    ghost_->add_product(ghost_work_, force_, 1.0);
  }
  // Only the active entries go to F (add_to_compact).
  for (const PetscInt e : active_.active_entries()) force_[e] *= h_;
  for (const int e : active_.constrained_entries()) force_[e] = 0.0;
  TALUS_PETSC(VecZeroEntries(F));
  active_.add_to_compact(force_, F);

  PetscScalar* f;
  const PetscScalar* x;
  TALUS_PETSC(VecGetArray(F, &f));
  TALUS_PETSC(VecGetArrayRead(v, &x));
  const auto& owned = active_.owned_points();
  for (std::size_t k = 0; k < owned.size(); ++k) {
    const int i = owned[k];
    const double m = fields_.mass[i];
    for (int c = 0; c < dim; ++c) {
      const std::size_t r = dim * k + c;
      if (active_.constrained(i, c))
        f[r] = m * x[r];
      else
        f[r] += m * (x[r] - velocity_old_[dim * i + c]) - h_ * m * gravity_[c];
    }
  }
  TALUS_PETSC(VecRestoreArrayRead(v, &x));
  TALUS_PETSC(VecRestoreArray(F, &f));
  for (auto& r : rigid_impulse_) r.setZero();
  if (any_contacts_) contact_rows(v, F);
  if (!rigid_.empty()) rigid_rows(v, F);
}

template <int dim>
Vec MomentumSystem<dim>::initial_guess(bool last) const {
  Vec v = active_.create_vector();
  PetscScalar* x;
  TALUS_PETSC(VecGetArray(v, &x));
  const auto& owned = active_.owned_points();
  // The last step's acceleration continued (a first-order extrapolation of
  // v in time) starts Newton closer to the solution than free fall does:
  // fewer iterations where the material keeps decelerating on a floor or
  // flowing steadily (docs/solver.md, "The predictor").
  const std::vector<double>& last_a = fields_.last_acceleration;
  const bool kept = last && last_a.size() == velocity_old_.size();
  for (std::size_t k = 0; k < owned.size(); ++k) {
    const int i = owned[k];
    const double* a = kept ? last_a.data() + dim * i : nullptr;
    bool known = a != nullptr;
    for (int c = 0; c < dim && known; ++c) known = std::isfinite(a[c]);
    for (int c = 0; c < dim; ++c)
      x[dim * k + c] =
          active_.constrained(i, c) ? 0.0 : velocity_old_[dim * i + c] + h_ * (known ? a[c] : gravity_[c]);
  }
  if (!rigid_.empty()) {
    // Rigid bodies: q^n + h (g, 0), their nodes' rigid velocities, no
    // impulse at their contact points.
    std::vector<typename RigidBody<dim>::Motion> q(rigid_.size());
    for (std::size_t b = 0; b < rigid_.size(); ++b) {
      q[b] = rigid_[b].start;
      q[b].template head<dim>() += h_ * gravity_;
    }
    for (std::size_t k = 0; k < owned.size(); ++k) {
      const int i = owned[k];
      if (!rigid_node(i)) continue;
      const Vector<dim> vi = rigid_contact_[i] >= 0 ? Vector<dim>::Zero()
                                        : Vector<dim>(rigid_body_of(i).velocity_map(grid_.point_position(
                                                          grid_.global_index(i % points_))) *
                                                      q[rigid_of_field_[i / points_]]);
      for (int c = 0; c < dim; ++c) x[dim * k + c] = vi[c];
    }
    for (std::size_t b = 0; b < rigid_.size(); ++b) {
      const PetscInt offset = (rigid_[b].block - rigid_first_) * dim;
      if (offset >= 0 && offset < active_.local_blocks() * dim)
        for (int j = 0; j < RigidBody<dim>::unknowns; ++j) x[offset + j] = q[b][j];
    }
  }
  TALUS_PETSC(VecRestoreArray(v, &x));
  return v;
}

template <int dim>
const double* MomentumSystem<dim>::reference_acceleration(int i) const {
  // The last step's acceleration where known, else the stresses' at t^n.
  for (const std::vector<double>* a : {&fields_.last_acceleration, &fields_.start_acceleration}) {
    if (a->size() != velocity_old_.size()) continue;
    bool known = true;
    for (int c = 0; c < dim; ++c) known = known && std::isfinite((*a)[dim * i + c]);
    if (known) return a->data() + dim * i;
  }
  return nullptr;
}

template <int dim>
Vec MomentumSystem<dim>::time_error_predictor() const {
  Vec v = active_.create_vector();
  TALUS_PETSC(VecZeroEntries(v));  // rigid bodies' rows, which weigh zero
  PetscScalar* x;
  TALUS_PETSC(VecGetArray(v, &x));
  const auto& owned = active_.owned_points();
  for (std::size_t k = 0; k < owned.size(); ++k) {
    const double* a = reference_acceleration(owned[k]);
    for (int c = 0; c < dim; ++c)
      x[dim * k + c] = velocity_old_[dim * owned[k] + c] + h_ * (a ? a[c] : gravity_[c]);
  }
  TALUS_PETSC(VecRestoreArray(v, &x));
  return v;
}

template <int dim>
Vec MomentumSystem<dim>::time_error_weights() const {
  Vec w = active_.create_vector();
  TALUS_PETSC(VecZeroEntries(w));
  if (!has_time_error_reference()) return w;
  PetscScalar* x;
  TALUS_PETSC(VecGetArray(w, &x));
  const auto& owned = active_.owned_points();
  for (std::size_t k = 0; k < owned.size(); ++k) {
    const int i = owned[k];
    if (rigid_node(i) || !reference_acceleration(i)) continue;
    for (int c = 0; c < dim; ++c)
      if (!active_.constrained(i, c)) x[dim * k + c] = fields_.mass[i];
  }
  TALUS_PETSC(VecRestoreArray(w, &x));
  return w;
}

template <int dim>
double MomentumSystem<dim>::momentum_scale() const {
  double local = 0.0;
  const double hg = h_ * gravity_.norm();
  for (int i : active_.owned_points())
    local += fields_.mass[i] * (Eigen::Map<const Vector<dim>>(velocity_old_.data() + dim * i).norm() + hg);
  double total = 0.0;
  MPI_Allreduce(&local, &total, 1, MPI_DOUBLE, MPI_SUM, grid_.comm());
  return total;
}

template <int dim>
void MomentumSystem<dim>::finish(Vec v) {
  if (!evaluated_at(v)) evaluate_particles(v);
  // The impulses at the converged velocities (SNES's last residual is
  // normally there already).
  PetscBool same = PETSC_FALSE;
  if (contact_at_) TALUS_PETSC(VecEqual(v, contact_at_, &same));
  if (any_contacts_ && !same) {
    Vec F;
    TALUS_PETSC(VecDuplicate(v, &F));
    residual(v, F);
    TALUS_PETSC(VecDestroy(&F));
  }
}

template class MomentumSystem<2>;
template class MomentumSystem<3>;

}  // namespace talus
