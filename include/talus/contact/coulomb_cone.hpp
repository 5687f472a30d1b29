#pragma once
// Coulomb friction as a second-order cone complementarity problem
// (De Saxce & Feng 1991; the seminar's "Unilateral contact and Coulomb
// friction" slides; docs/contact.md):
//
//   K_mu = { r : ||r_T|| <= mu r_N },   K_mu* = { y : mu ||y_T|| <= y_N },
//   u_hat = u + (e u_N^n + mu ||u_T||) n          (De Saxce's modified velocity)
//   K_mu  ∋ r  ⊥  u_hat ∈ K_mu*
//   <=>  Phi(r, u) = r - P_K(r - rho u_hat) = 0   for any rho > 0  (natural map)
//
// r is the impulse the obstacle gives the body (r_N >= 0 pushes out along the
// outward normal n), u the velocity relative to the obstacle, u_N^n its
// normal part at the start of the step (Newton's restitution e). Vectors are
// in global Cartesian components; normal and tangential parts are taken
// against n. Everything here is a closed form with its generalized
// (Clarke) derivative, for the semismooth Newton of the step.
#include <cmath>

#include "talus/core/types.hpp"

namespace talus {

enum class ConeRegion { inside, polar, boundary };

template <int dim>
struct ConeProjection {
  Vector<dim> value;
  Matrix<dim> derivative;  // d P_K(x) / d x; an element of the generalized derivative on the kinks
  ConeRegion region = ConeRegion::inside;
};

// Euclidean projection of x onto K_mu with axis n (|n| = 1, mu >= 0):
//   inside  (||x_T|| <= mu x_N):   x
//   polar   (mu ||x_T|| <= -x_N):  0
//   else:   a (n + mu t),  a = (x_N + mu ||x_T||) / (1 + mu^2),  t = x_T / ||x_T||,
// with derivative (n + mu t)(n + mu t)^T / (1 + mu^2) + (a mu / ||x_T||)(I - n n^T - t t^T).
template <int dim>
ConeProjection<dim> project_onto_coulomb_cone(const Vector<dim>& x, const Vector<dim>& n, double mu) {
  ConeProjection<dim> p;
  const double xn = x.dot(n);
  const Vector<dim> xt = x - xn * n;
  const double t = xt.norm();
  if (t <= mu * xn) {
    p.region = ConeRegion::inside;
    p.value = x;
    p.derivative.setIdentity();
  } else if (mu * t <= -xn) {
    p.region = ConeRegion::polar;
    p.value.setZero();
    p.derivative.setZero();
  } else {
    // Here t > 0: t = 0 would need x_N > 0 (not inside) and x_N < 0 (not polar).
    p.region = ConeRegion::boundary;
    const Vector<dim> tangent = xt / t;
    const Vector<dim> generator = n + mu * tangent;
    const double a = (xn + mu * t) / (1.0 + mu * mu);
    p.value = a * generator;
    p.derivative = generator * generator.transpose() / (1.0 + mu * mu) +
                   (a * mu / t) * (Matrix<dim>::Identity() - n * n.transpose() - tangent * tangent.transpose());
  }
  return p;
}

// De Saxce's modified velocity and its derivative in u (at ||u_T|| = 0 the
// element with the tangential term dropped).
template <int dim>
Vector<dim> modified_velocity(const Vector<dim>& u, const Vector<dim>& n, double mu, double restitution,
                              double start_normal_velocity, Matrix<dim>* derivative = nullptr) {
  const Vector<dim> ut = u - u.dot(n) * n;
  const double slip = ut.norm();
  if (derivative) {
    derivative->setIdentity();
    if (slip > 0.0 && mu > 0.0) *derivative += mu * n * (ut / slip).transpose();
  }
  return u + (restitution * start_normal_velocity + mu * slip) * n;
}

template <int dim>
struct NaturalMap {
  Vector<dim> value;        // Phi = r - P_K(r - rho u_hat)
  Matrix<dim> d_impulse;    // dPhi/dr = I - D
  Matrix<dim> d_velocity;   // dPhi/du = rho D du_hat/du
  ConeRegion region = ConeRegion::inside;  // inside: sticking, polar: separating, boundary: sliding
};

template <int dim>
NaturalMap<dim> natural_map(const Vector<dim>& r, const Vector<dim>& u, const Vector<dim>& n, double mu,
                            double restitution, double start_normal_velocity, double rho) {
  Matrix<dim> du_hat;
  const Vector<dim> u_hat = modified_velocity<dim>(u, n, mu, restitution, start_normal_velocity, &du_hat);
  const ConeProjection<dim> p = project_onto_coulomb_cone<dim>(r - rho * u_hat, n, mu);
  NaturalMap<dim> m;
  m.value = r - p.value;
  m.d_impulse = Matrix<dim>::Identity() - p.derivative;
  m.d_velocity = rho * p.derivative * du_hat;
  m.region = p.region;
  return m;
}

}  // namespace talus
