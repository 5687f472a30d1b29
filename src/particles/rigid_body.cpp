#include "talus/particles/rigid_body.hpp"

#include <cmath>

#include <Eigen/Geometry>

namespace talus {

template <int dim>
typename RigidBody<dim>::Map RigidBody<dim>::velocity_map(const Vector<dim>& x) const {
  Map T = Map::Zero();
  T.template leftCols<dim>().setIdentity();
  const Vector<dim> r = x - centre;
  if constexpr (dim == 2) {
    // omega e_z x r = omega (-r_y, r_x)
    T(0, 2) = -r[1] / gyration;
    T(1, 2) = r[0] / gyration;
  } else {
    // omega x r = -[r]x omega
    T(0, 4) = r[2] / gyration, T(0, 5) = -r[1] / gyration;
    T(1, 3) = -r[2] / gyration, T(1, 5) = r[0] / gyration;
    T(2, 3) = r[1] / gyration, T(2, 4) = -r[0] / gyration;
  }
  return T;
}

template <int dim>
typename RigidBody<dim>::Inertia RigidBody<dim>::generalized_mass() const {
  Inertia G = Inertia::Zero();
  G.template topLeftCorner<dim, dim>() = mass * Matrix<dim>::Identity();
  const double g2 = gyration * gyration;
  if constexpr (dim == 2) {
    G(2, 2) = inertia(2, 2) / g2;
    G(3, 3) = mass;
  } else {
    G.template bottomRightCorner<3, 3>() = inertia / g2;
  }
  return G;
}

template <int dim>
Eigen::Vector3d RigidBody<dim>::angular_velocity(const Motion& q) const {
  Eigen::Vector3d omega = Eigen::Vector3d::Zero();
  if constexpr (dim == 2)
    omega[2] = q[2] / gyration;
  else
    omega = q.template tail<3>() / gyration;
  return omega;
}

template <int dim>
std::vector<RigidBody<dim>> rigid_bodies(const Particles<dim>& particles, const std::vector<char>& rigid,
                                         const std::vector<int>& body_field, MPI_Comm comm) {
  std::vector<RigidBody<dim>> bodies;
  const int nb = static_cast<int>(rigid.size());
  std::vector<int> index(nb, -1);
  for (int b = 0; b < nb; ++b)
    if (rigid[b]) {
      index[b] = static_cast<int>(bodies.size());
      bodies.emplace_back();
      bodies.back().body = b;
      bodies.back().field = body_field.empty() ? 0 : body_field[b];
    }
  if (bodies.empty()) return bodies;
  const std::size_t n = bodies.size();
  DM sw = particles.swarm();
  FieldView<PetscReal> x(sw, field::position), v(sw, field::velocity), m(sw, field::mass),
      c(sw, field::affine_velocity), v0(sw, field::initial_volume);
  FieldView<PetscInt> body(sw, field::body_id);
  const PetscInt np = particles.local_count();
  // Pass 1: mass, first moment, momentum.
  std::vector<double> first(n * (1 + 2 * dim), 0.0), first_all(first.size());
  for (PetscInt p = 0; p < np; ++p) {
    const int k = index[body[p]];
    if (k < 0) continue;
    double* s = first.data() + k * (1 + 2 * dim);
    s[0] += m[p];
    for (int a = 0; a < dim; ++a) s[1 + a] += m[p] * x[dim * p + a], s[1 + dim + a] += m[p] * v[dim * p + a];
  }
  MPI_Allreduce(first.data(), first_all.data(), static_cast<int>(first.size()), MPI_DOUBLE, MPI_SUM, comm);
  std::vector<Vector<dim>> velocity(n);
  for (std::size_t k = 0; k < n; ++k) {
    const double* s = first_all.data() + k * (1 + 2 * dim);
    bodies[k].mass = s[0];
    for (int a = 0; a < dim; ++a)
      bodies[k].centre[a] = s[1 + a] / s[0], velocity[k][a] = s[1 + dim + a] / s[0];
  }
  // Pass 2: angular momentum and inertia about the centre (3D components),
  // each particle a cube of side l = V0^(1/dim) spinning with its affine
  // velocity's skew part.
  std::vector<double> second(n * 12, 0.0), second_all(second.size());
  for (PetscInt p = 0; p < np; ++p) {
    const int k = index[body[p]];
    if (k < 0) continue;
    Eigen::Vector3d r = Eigen::Vector3d::Zero(), u = Eigen::Vector3d::Zero();
    Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
    for (int a = 0; a < dim; ++a) {
      r[a] = x[dim * p + a] - bodies[k].centre[a];
      u[a] = v[dim * p + a] - velocity[k][a];
      for (int b = 0; b < dim; ++b) C(a, b) = c[dim * dim * p + dim * a + b];
    }
    const Eigen::Vector3d spin(0.5 * (C(2, 1) - C(1, 2)), 0.5 * (C(0, 2) - C(2, 0)), 0.5 * (C(1, 0) - C(0, 1)));
    const double own = m[p] * std::pow(v0[p], 2.0 / dim) / 6.0;
    Eigen::Matrix3d own_inertia = own * Eigen::Matrix3d::Identity();
    if constexpr (dim == 2) own_inertia(0, 0) = own_inertia(1, 1) = 0.0;
    double* s = second.data() + k * 12;
    Eigen::Map<Eigen::Vector3d>(s) += m[p] * r.cross(u) + own_inertia * spin;
    Eigen::Map<Eigen::Matrix3d>(s + 3) +=
        m[p] * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose()) + own_inertia;
  }
  MPI_Allreduce(second.data(), second_all.data(), static_cast<int>(second.size()), MPI_DOUBLE, MPI_SUM, comm);
  for (std::size_t k = 0; k < n; ++k) {
    RigidBody<dim>& rb = bodies[k];
    const Eigen::Map<const Eigen::Vector3d> L(second_all.data() + k * 12);
    rb.inertia = Eigen::Map<const Eigen::Matrix3d>(second_all.data() + k * 12 + 3);
    Eigen::Vector3d omega = Eigen::Vector3d::Zero();
    if constexpr (dim == 2) {
      rb.gyration = std::sqrt(rb.inertia(2, 2) / rb.mass);
      omega[2] = L[2] / rb.inertia(2, 2);
    } else {
      rb.gyration = std::sqrt(rb.inertia.trace() / (3.0 * rb.mass));
      omega = rb.inertia.ldlt().solve(L);
    }
    rb.start.template head<dim>() = velocity[k];
    if constexpr (dim == 2)
      rb.start[2] = rb.gyration * omega[2];
    else
      rb.start.template tail<3>() = rb.gyration * omega;
  }
  return bodies;
}

template <int dim>
void move_rigid_particles(Particles<dim>& particles, const std::vector<RigidBody<dim>>& bodies,
                          const std::vector<typename RigidBody<dim>::Motion>& motion, double h) {
  if (bodies.empty()) return;
  using RowMat = Eigen::Matrix<double, dim, dim, Eigen::RowMajor>;
  std::vector<int> index;
  for (std::size_t k = 0; k < bodies.size(); ++k) {
    if (static_cast<int>(index.size()) <= bodies[k].body) index.resize(bodies[k].body + 1, -1);
    index[bodies[k].body] = static_cast<int>(k);
  }
  // The rotation over the step and the new centre of each body.
  std::vector<Matrix<dim>> rotation(bodies.size());
  std::vector<Vector<dim>> centre(bodies.size()), V(bodies.size());
  std::vector<Matrix<dim>> spin(bodies.size());
  for (std::size_t k = 0; k < bodies.size(); ++k) {
    const Eigen::Vector3d omega = bodies[k].angular_velocity(motion[k]);
    const double angle = h * omega.norm();
    const Eigen::Matrix3d R =
        angle > 0.0 ? Eigen::AngleAxisd(angle, omega.normalized()).toRotationMatrix() : Eigen::Matrix3d::Identity();
    Eigen::Matrix3d W;
    W << 0.0, -omega[2], omega[1], omega[2], 0.0, -omega[0], -omega[1], omega[0], 0.0;
    rotation[k] = R.template topLeftCorner<dim, dim>();
    spin[k] = W.template topLeftCorner<dim, dim>();
    V[k] = motion[k].template head<dim>();
    centre[k] = bodies[k].centre + h * V[k];
  }
  DM sw = particles.swarm();
  FieldView<PetscReal> x(sw, field::position), v(sw, field::velocity), c(sw, field::affine_velocity),
      u(sw, field::displacement), F(sw, field::deformation_gradient);
  FieldView<PetscInt> body(sw, field::body_id);
  const PetscInt np = particles.local_count();
  for (PetscInt p = 0; p < np; ++p) {
    const int k = body[p] < static_cast<int>(index.size()) ? index[body[p]] : -1;
    if (k < 0) continue;
    Eigen::Map<Vector<dim>> xp(x.data() + dim * p), vp(v.data() + dim * p), up(u.data() + dim * p);
    Eigen::Map<RowMat> cp(c.data() + dim * dim * p), Fp(F.data() + dim * dim * p);
    const Vector<dim> old_position = xp;  // x^n: grid_to_particles leaves rigid particles alone
    const Vector<dim> moved = centre[k] + rotation[k] * (old_position - bodies[k].centre);
    up += moved - old_position;
    xp = moved;
    vp = V[k] + spin[k] * (moved - centre[k]);
    cp = spin[k];
    Fp = rotation[k] * Fp;
  }
}

template struct RigidBody<2>;
template struct RigidBody<3>;
template std::vector<RigidBody<2>> rigid_bodies(const Particles<2>&, const std::vector<char>&, const std::vector<int>&,
                                                MPI_Comm);
template std::vector<RigidBody<3>> rigid_bodies(const Particles<3>&, const std::vector<char>&, const std::vector<int>&,
                                                MPI_Comm);
template void move_rigid_particles(Particles<2>&, const std::vector<RigidBody<2>>&,
                                   const std::vector<RigidBody<2>::Motion>&, double);
template void move_rigid_particles(Particles<3>&, const std::vector<RigidBody<3>>&,
                                   const std::vector<RigidBody<3>::Motion>&, double);

}  // namespace talus
