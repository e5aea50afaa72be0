/// @file linearized_model.hpp
/// What the tube MPC needs from a plant model: node-by-node exact zero-order-hold discretisation of
/// the affine model about a linearisation point, and linearised state constraints. The 6-DOF
/// proximity model implements it (dynamics area); tests implement it for simple plants.
#pragma once

#include <Eigen/Dense>

namespace tubempc::mpc {

/// Affine discrete-time model x+ = A x + B u + c and state constraints G x <= h, both about a
/// linearisation point. Implementations must not allocate in `discretize` or `constraints`.
class LinearizedModel {
 public:
  virtual ~LinearizedModel() = default;

  /// State dimension n_x.
  virtual int nx() const = 0;
  /// Input dimension n_u.
  virtual int nu() const = 0;
  /// Number of linearised state-constraint rows per node.
  virtual int n_constraints() const = 0;

  /// Discretises the dynamics over [t, t + dt] (s) about (x_lin, u_lin) with a zero-order hold:
  /// x(t + dt) ~= A x(t) + B u + c. Writes A (n_x x n_x), B (n_x x n_u) and c (n_x).
  virtual void discretize(double t, double dt, const Eigen::Ref<const Eigen::VectorXd>& x_lin,
                          const Eigen::Ref<const Eigen::VectorXd>& u_lin, Eigen::Ref<Eigen::MatrixXd> A,
                          Eigen::Ref<Eigen::MatrixXd> B, Eigen::Ref<Eigen::VectorXd> c) const = 0;

  /// Linearised state constraints at (t, x_lin): G x <= h, G (n_constraints x n_x), h (n_constraints).
  virtual void constraints(double t, const Eigen::Ref<const Eigen::VectorXd>& x_lin,
                           Eigen::Ref<Eigen::MatrixXd> G, Eigen::Ref<Eigen::VectorXd> h) const = 0;
};

}  // namespace tubempc::mpc
