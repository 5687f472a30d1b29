#pragma once
// The nonlinear system of one implicit step (Moreau-Jean, theta-method):
//
//   F_i(v) = m_i (v_i - v_i^n) - h m_i g + h sum_p V_p sigma_p^theta(v) grad N_i(x_p) = 0
//
// for every active grid point i, where v_theta = theta v + (1 - theta) v^n,
// L_p = sum_i v_theta,i (x) grad N_i(x_p), and the particle stress
//   sigma_p^{n+1} = S(sigma*_p, h sym L_p),  sigma*_p = sigma_p^n + h (W sigma^n - sigma^n W),
//   W = skew L_p (Jaumann rotation), sigma^theta = (1 - theta) sigma^n + theta sigma^{n+1}
// comes from the material's stress update (docs/formulation.md). Constrained
// velocity components (fixed/slip faces) carry the equation m_i v_i = 0.
//
// The Jacobian is m_i I + h theta^2 sum_p V_p grad N_i . A_p . grad N_j, with
// A_p = d sigma^{n+1} / d L_p assembled from the material's consistent tangent
// and the derivative of the Jaumann rotation, so Newton is exact.
//
// Frictional contact (docs/contact.md): at a contact candidate i the impulse
// the obstacle must give is the momentum imbalance R_i(v) (the row above), so
// the row is replaced by the natural map of the Coulomb cone complementarity
//   Phi_i(v) = R_i(v) - P_K(R_i(v) - rho_i u_hat_i(v)) = 0,
// with r_i = R_i(v) condensed: contact adds no unknowns, and its Jacobian rows
// are (I - D_i) dR_i/dv + rho_i D_i du_hat_i/dv_i (D_i the projection's
// generalized derivative). One semismooth Newton solves momentum,
// plasticity and contact together.
//
// Bodies in contact with each other (docs/contact.md#bodies-in-contact) have
// separate velocity fields: the unknowns are then the active nodes (a grid
// point in one field, GridFields), a particle's stencil reaches its field's
// nodes only, and at a point where fields a and b touch (BodyContactPoint)
// a's row becomes Phi(R_a(v), v_a - v_b) = 0 and b's the point's total
// balance R_a(v) + R_b(v) = 0. Its Jacobian rows: P dR_a/dv + Q (e_a - e_b)
// and dR_a/dv + dR_b/dv.
//
// Rigid bodies (rigid_body.hpp, docs/contact.md#rigid-bodies): a rigid body's
// field rows are its rigid constraint m_i (v_i - T(x_i) q) = 0, its motion q
// (two extra blocks, ActiveSet) carries the body's Newton-Euler rows, and at
// a rigid body's obstacle contact point the unknown of the point is the
// contact impulse r_k itself (a rigid body's impulses are not its nodes'
// momentum imbalances), with the row Phi(r_k, T(x_s) q - v_obstacle +
// eps r_k / rho) = 0: eps (rigid_compliance) makes the impulses of a body
// resting on several points unique (a failed step is solved again with a
// Jacobian that regularizes them more, rigid_jacobian_compliance). Where a
// deformable field a touches a rigid body (always the hub), the impulse R_a
// goes into the body's rows.
#include <petscmat.h>

#include <algorithm>
#include <vector>

#include "talus/contact/coulomb_cone.hpp"
#include "talus/contact/contact_set.hpp"
#include "talus/materials/material.hpp"
#include "talus/particles/rigid_body.hpp"
#include "talus/solver/active_set.hpp"
#include "talus/solver/primal_dual_tangent.hpp"
#include "talus/solver/strain_increment.hpp"
#include "talus/solver/tensor_stencil.hpp"
#include "talus/solver/energy_balance.hpp"
#include "talus/solver/ghost_penalty.hpp"

namespace talus {

// The buffers of a step's MomentumSystem worth keeping for the next step's
// (MomentumSystem::use_workspace; Simulation owns one).
struct MomentumWorkspace {
  std::vector<double> jacobian_rows;
};

template <int dim>
class MomentumSystem {
 public:
  static constexpr int nL = dim * dim;
  // The in-plane stress components: xx, yy, xy in 2D; the Voigt six in 3D.
  static constexpr int nS = dim == 2 ? 3 : 6;
  // (stress_row<dim>(i, j), k*dim + l): d sigma_ij / d L_kl. The stress is
  // symmetric, so its rows ij and ji are one: nS rows, not nL.
  using StressTangent = Eigen::Matrix<double, nS, nL>;

  MomentumSystem(const Grid<dim>& grid, const Particles<dim>& particles, const std::vector<Stencil<dim>>& stencils,
                 const GridFields<dim>& fields, const ActiveSet<dim>& active,
                 const std::vector<const Material*>& materials, const Vector<dim>& gravity, double h, double theta,
                 std::vector<ContactPoint<dim>> contacts = {},
                 std::vector<BodyContactPoint<dim>> body_contacts = {},
                 std::vector<RigidBody<dim>> rigid = {});
  // A rigid body's contact compliance eps (dimensionless; the velocity
  // into the obstacle it allows is eps r_N / m_i, about eps g h).
  static constexpr double rigid_compliance = 1e-8;
  // The compliance the Jacobian takes when a step with rigid bodies failed
  // (NewtonSolver's last retry, docs/contact.md#rigid-bodies): a
  // Levenberg-Marquardt-like regularization of the impulses' columns, so that
  // a Newton step into many new contact points does not make impulses of
  // 1 / eps (the residual, and so the answer, keeps eps). By default the
  // Jacobian takes eps itself and is exact.
  static constexpr double rigid_jacobian_compliance = 1e-4;
  void set_rigid_jacobian_compliance(double eps) { rigid_jacobian_compliance_ = eps; }
  ~MomentumSystem();
  // Take the large buffers from `workspace` (and give them back at the end):
  // kept from step to step, they are not page-faulted anew (the Jacobian's
  // rows are 200 MB at 128,000 3D particles; a fresh vector of that size
  // cost 0.2 s per step).
  void use_workspace(MomentumWorkspace& workspace);
  MomentumSystem(const MomentumSystem&) = delete;
  MomentumSystem& operator=(const MomentumSystem&) = delete;

  void residual(Vec v, Vec F);
  void jacobian(Vec v, Mat J);
  // The Jacobian's action without its matrix (docs/solver.md#the-jacobian-as-an-operator):
  // prepare_operator(v) evaluates the particle tangents and contact factors
  // at v, then apply_jacobian(x, y) sets y = J(v) x from them, equal to
  // jacobian(v, J) followed by MatMult(J, x, y) to round-off.
  void prepare_operator(Vec v);
  // Particles whose Jacobian product takes the tensor-product path
  // (tensor_stencil.hpp), once the stencils are packed (the first Jacobian).
  std::size_t tensor_stencil_particles() const {
    return static_cast<std::size_t>(std::count_if(tensor_base_.begin(), tensor_base_.end(), [](int b) { return b >= 0; }));
  }
  int stencil_nodes() const;  // grid points per particle: 9 or 27 (quadratic B-splines), 4 or 8 (linear hats)
  void apply_jacobian(Vec x, Vec y);
  // The Jacobian's dim x dim diagonal blocks at v (those of jacobian(v, D))
  // into D, a matrix of create_block_diagonal_matrix(): the point-block
  // Jacobi preconditioner of the operator, without the block rows.
  void jacobian_block_diagonal(Vec v, Mat D);
  Mat create_block_diagonal_matrix() const;
  // Preallocated for this step's couplings, block size dim, of `type` (MATAIJ
  // or MATBAIJ) unless -talus_mat_type says otherwise.
  Mat create_matrix(MatType type = MATAIJ) const;
  // v^n + h a on free components, 0 on constrained ones: a the acceleration
  // of the grid point in the last accepted step (GridFields::last_acceleration)
  // if `last`, g where it is unknown or without `last`.
  Vec initial_guess(bool last = true) const;
  double momentum_scale() const;  // sum_i m_i (|v_i^n| + h |g|), all ranks
  // The step has a reference acceleration for its time-error estimate
  // (NewtonSolver::Scale): the last step's grid acceleration, or where that
  // is unknown the acceleration of the stresses at t^n
  // (GridFields::start_acceleration); not in a geostatic stage, whose steps
  // start from rest in a pseudo-time. The predictor v^n + h a of the
  // estimate, and its weights: the point's mass on each velocity unknown
  // with a reference, zero elsewhere (constrained components, rigid bodies'
  // points, their motions and contact impulses).
  bool has_time_error_reference() const {
    return !fields_.pseudo_time && (fields_.last_acceleration.size() == velocity_old_.size() ||
                                    fields_.start_acceleration.size() == velocity_old_.size());
  }
  Vec time_error_predictor() const;
  Vec time_error_weights() const;
  const ActiveSet<dim>& active() const { return active_; }
  const Grid<dim>& grid() const { return grid_; }
  int field_count() const { return fields_.field_count; }
  // The explicit step needs the stresses only: no tangents A_p (jacobian()
  // is then unavailable).
  void skip_tangents() { with_tangents_ = false; }
  // The primal-dual tangent (primal_dual_tangent.hpp), on or off; a new
  // Newton solve starts it from the consistent tangent.
  void set_primal_dual(bool on) { primal_dual_ = on; }
  // Particles whose last evaluation returned to the yield surface (this rank).
  std::size_t plastic_particles() const { return plastic_particles_; }
  void reset_carried_stresses() { carried_.reset(); }
  // The last evaluation was at Newton's accepted iterate (the Jacobian's).
  void commit_carried_stresses() {
    if (primal_dual_) carried_.commit();
  }
  // The strain increment of the step (strain_increment.hpp,
  // docs/formulation.md#the-strain-increment): linear (h sym L) by default.
  void set_strain_increment(StrainIncrement kind) { strain_increment_ = kind; }
  // The ghost penalty (ghost_penalty.hpp, docs/solver.md#ghost-penalty) on
  // the step's displacement h v_theta: the momentum rows gain h K h v_theta,
  // the Jacobian h^2 theta K (inside the particles' pattern).
  void set_ghost_penalty(const GhostPenalty<dim>* ghost) {
    ghost_ = ghost;
    jacobian_layout_built_ = false;  // its cells add slots
  }
  const GhostPenalty<dim>* ghost_penalty() const { return ghost_; }

  // After convergence: grid velocity v^{n+1} (ghosted, constraints applied),
  // start-of-step v^n (same layout) and particle stresses sigma^{n+1}.
  void finish(Vec v);
  const std::vector<double>& end_velocity() const { return velocity_; }
  const std::vector<double>& start_velocity() const { return velocity_old_; }
  const std::vector<Voigt>& end_stress() const { return stress_end_; }
  const std::vector<double>& end_state() const { return state_end_; }  // max_state_size per particle
  const std::vector<Voigt>& plastic_strain_increment() const { return plastic_increment_; }
  const std::vector<double>& end_separation() const { return separation_end_; }
  // Contact candidates and, after finish(), their impulses r_i (N s) and
  // regions (sticking = inside, sliding = boundary, separating = polar).
  const std::vector<ContactPoint<dim>>& contacts() const { return contacts_; }
  const std::vector<Vector<dim>>& contact_impulses() const { return contact_impulse_; }
  // After finish(): this rank's share of the step's energy terms
  // (energy_balance.hpp, docs/energy.md). stress_weight: the weight of
  // sigma^{n+1} in the internal force (theta; 0 for the explicit step);
  // velocity_weight: that of v^{n+1} in the strain and the motion (theta; 1
  // explicit). compliance: C^-1 of each material. `contacts` and their
  // impulses r_i: the system's own or the explicit step's.
  // body_contacts / body_impulses: the explicit step's (nullptr: the system's own).
  StepEnergy step_energy(double stress_weight, double velocity_weight, const std::vector<Tangent>& compliance,
                         const std::vector<ContactPoint<dim>>& contacts, const std::vector<Vector<dim>>& impulses,
                         const std::vector<BodyContactPoint<dim>>* body_contacts = nullptr,
                         const std::vector<Vector<dim>>* body_impulses = nullptr) const;
  const std::vector<NaturalMap<dim>>& contact_maps() const { return contact_map_; }
  // Points where two bodies touch and, after finish(), the impulse r each
  // gives its body a (N s; -r on body b) and its region of the cone.
  const std::vector<BodyContactPoint<dim>>& body_contacts() const { return body_contacts_; }
  const std::vector<Vector<dim>>& body_contact_impulses() const { return body_impulse_; }
  const std::vector<NaturalMap<dim>>& body_contact_maps() const { return body_map_; }
  // The step's rigid bodies and, after finish(), their motions q^{n+1}.
  const std::vector<RigidBody<dim>>& rigid_bodies() const { return rigid_; }
  const std::vector<typename RigidBody<dim>::Motion>& rigid_motion() const { return motion_; }
  // Per velocity field: the index of its rigid body, -1 for a deformable field.
  const std::vector<int>& rigid_of_field() const { return rigid_of_field_; }
  double contact_seconds() const { return contact_seconds_; }  // time spent in the contact rows
  // Time in the particles' stress updates and internal forces (every
  // residual), in assembling Jacobian matrices and in operator products
  // (apply_jacobian, part of the linear solves), s.
  double material_seconds() const { return material_seconds_; }
  double assembly_seconds() const { return assembly_seconds_; }
  double operator_seconds() const { return operator_seconds_; }

 private:
  void evaluate_particles(Vec v);
  bool evaluated_at(Vec v) const;
  void contact_rows(Vec v, Vec F);      // replaces the contact candidates' rows of F by the natural map
  // The left factors P_i of the contact rows' Jacobian (dPhi_i/dv =
  // P_i dR_i/dv + Q_i on v_i) at v, row-major dim x dim per ghosted point
  // (identity off contact points); keeps P_i, Q_i of the owned contacts.
  // With bodies in contact also, per ghosted node, the node whose row takes
  // this node's momentum row as well (b for a contact's a, else -1).
  std::vector<double> contact_row_factors(Vec v, std::vector<int>& partner);
  bool shared_point(int node) const;  // more than one field is active at the node's point
  // The active nodes of `field` within the stencils' reach of the ghosted
  // point `point` (grid index ijk), as compact indices (-1: inactive or
  // outside the ghost region), in the block-row order of jacobian(); with
  // `points`, also their ghosted points (-1 outside).
  void neighbour_columns(const std::array<int, dim>& ijk, int field, std::vector<PetscInt>& cols,
                         std::vector<int>* points = nullptr) const;
  void contact_factors(Vec v);  // P_i, Q_i of the contacts at v (the first half of contact_row_factors)
  // Rigid bodies: read q from v (on every rank), the rows of the rigid
  // nodes and bodies (after contact_rows), and their Jacobian entries.
  void gather_motion(Vec v);
  void rigid_rows(Vec v, Vec F);
  void rigid_jacobian(Mat J, const std::vector<double>& left);
  bool rigid_node(int node) const { return !rigid_.empty() && rigid_of_field_[node / points_] >= 0; }
  // Node i's reference acceleration for the time-error estimate (dim
  // values), or none (has_time_error_reference).
  const double* reference_acceleration(int i) const;
  bool rigid_particle(std::size_t p) const;
  const RigidBody<dim>& rigid_body_of(int node) const { return rigid_[rigid_of_field_[node / points_]]; }
  PetscInt rigid_first_ = 0;  // this rank's first unknown block (global)

  const Grid<dim>& grid_;
  const std::vector<Stencil<dim>>& stencils_;
  const GridFields<dim>& fields_;
  const ActiveSet<dim>& active_;
  std::vector<const Material*> materials_;
  Vector<dim> gravity_;
  double h_, theta_;
  bool with_tangents_ = true;
  bool primal_dual_ = false;
  std::size_t plastic_particles_ = 0;
  CarriedStresses<dim> carried_;
  StrainIncrement strain_increment_ = StrainIncrement::linear;

  // Committed particle state at the start of the step (frozen during Newton).
  std::vector<Voigt> stress_old_;
  std::vector<double> reference_volume_;  // V0: the stress is Kirchhoff's, tau = J sigma
  std::vector<double> separation_old_;
  std::vector<int> material_;
  std::vector<double> state_old_;  // internal variables, max_state_size per particle

  // Results of the last evaluation.
  std::vector<double> velocity_, velocity_old_, force_;
  // For the tensor-product stencils (evaluate_particles): v_theta on the
  // grid (padded by a node), each particle's L (dim^2, row-major) and
  // V_p sigma_theta (nS).
  std::vector<double> velocity_theta_, particle_gradient_, particle_force_stress_;
  std::vector<Voigt> stress_end_, plastic_increment_;
  std::vector<double> state_end_, separation_end_;
  std::vector<double> closed_voids_;  // volumetric strain of the voids closed this step (<= 0)
  std::vector<Voigt> rotated_stress_;  // sigma* (the Jaumann-rotated start stress) of the last evaluation
  // The stencils' local indices and gradients packed particle after
  // particle (pack_stencils, once per step): particle p's nodes are
  // packed_offset_[p] .. packed_offset_[p + 1] - 1.
  std::vector<int> packed_offset_, packed_local_, packed_lin_;
  std::vector<double> packed_gradient_;
  // 3D stencils that are full tensor products of three quadratic B-splines
  // per axis (point quadrature), for the residual and the Jacobian's product
  // (tensor_stencil.hpp), packed with the others: the first node's local
  // index (-1 for any other stencil; none at all in 2D), each axis's 3 values
  // and 3 slopes (6 dim per particle), and the local index's step along each axis.
  std::vector<int> tensor_base_;
  std::vector<double> tensor_basis_;
  std::array<int, dim> tensor_stride_{};
  TensorStencils<dim> tensor_stencils() const {
    TensorStencils<dim> s;
    for (int ax = 0; ax < dim; ++ax) s.stride[ax] = tensor_stride_[ax];
    s.particles = tensor_base_.size();
    s.base = tensor_base_.data();
    s.basis = tensor_basis_.data();
    return s;
  }
  void pack_stencils();
  void pack_tensor_stencils();  // 3D
  // Particle p's nodes: their count, local indices and gradients (dim per
  // node), from the packed copy once it exists (implicit steps), else from
  // the stencil itself (the explicit step reads each stencil once: a copy
  // would cost it a pass).
  struct NodeSpan {
    int count;
    const int* local;
    const double* gradient;
  };
  NodeSpan nodes_of(std::size_t p) const {
    static_assert(sizeof(Vector<dim>) == dim * sizeof(double), "gradients stored contiguously");
    if (packed_offset_.empty()) {
      const Stencil<dim>& st = stencils_[p];
      return {st.count, st.local.data(), st.gradient[0].data()};
    }
    const int first = packed_offset_[p];
    return {packed_offset_[p + 1] - first, packed_local_.data() + first,
            packed_gradient_.data() + static_cast<std::size_t>(dim) * first};
  }
  std::vector<StressTangent> tangent_;
  std::vector<char> stiff_;  // A_p != 0 (a particle at the apex adds nothing to the Jacobian)
  // Jacobian assembly buffers (kept between Jacobians): the slot of each
  // ghosted point, the points of the slots, their block rows.
  std::vector<int> jacobian_slot_, jacobian_slot_point_;
  std::vector<double> jacobian_rows_;
  MomentumWorkspace* workspace_ = nullptr;  // use_workspace()
  // Built at the step's first Jacobian (jacobian()): each slot's neighbour
  // columns, and the entries of its block row zeroed by constraints (slot sa's
  // in jacobian_zeroed_[start[sa], start[sa + 1])).
  bool jacobian_layout_built_ = false;
  std::vector<PetscInt> jacobian_columns_;
  std::vector<int> jacobian_zeroed_start_, jacobian_zeroed_;
  std::vector<double> operator_x_, operator_y_;  // apply_jacobian's ghosted vectors
  std::vector<int> product_nodes_;  // the nodes a product writes (product_nodes())
  const std::vector<int>& product_nodes();
  Vec evaluated_at_ = nullptr;  // the v of the last evaluation

  int points_ = 0, nodes_ = 0;  // ghosted grid points; nodes (points x velocity fields)
  std::vector<ContactPoint<dim>> contacts_;
  std::vector<BodyContactPoint<dim>> body_contacts_;
  std::vector<Vector<dim>> body_impulse_;
  std::vector<NaturalMap<dim>> body_map_;
  std::vector<Matrix<dim>> body_left_, body_right_;  // P, Q of the body contacts' a rows
  std::vector<Vector<dim>> contact_impulse_;
  std::vector<NaturalMap<dim>> contact_map_;
  std::vector<Matrix<dim>> contact_left_, contact_right_;  // P_i, Q_i (contact_row_factors)
  Vec contact_at_ = nullptr;  // the v of the last contact evaluation
  double contact_seconds_ = 0.0;
  double material_seconds_ = 0.0, assembly_seconds_ = 0.0, operator_seconds_ = 0.0;
  int any_contacts_ = 0;  // on any rank
  const GhostPenalty<dim>* ghost_ = nullptr;
  std::vector<RigidBody<dim>> rigid_;
  std::vector<int> rigid_contact_;  // per node: the index of its rigid body's obstacle contact, -1 for none
  double rigid_jacobian_compliance_ = rigid_compliance;
  std::vector<int> rigid_of_field_;
  std::vector<typename RigidBody<dim>::Motion> motion_;  // q at the last evaluation
  // This rank's share of each body's rows from the contacts (impulses on the
  // body), filled by contact_rows.
  std::vector<typename RigidBody<dim>::Motion> rigid_impulse_;
  std::vector<double> ghost_work_;  // h v_theta, ghosted (residual)
  void step_displacement(std::vector<double>& u) const;  // u = h v_theta at the last evaluation, ghosted
};

}  // namespace talus
