/// @file linearized_model.hpp
/// What the tube MPC needs from a plant model: node-by-node exact zero-order-hold discretisation of
/// the affine model about a linearisation point, and linearised state constraints. The 6-DOF
/// proximity model implements it (dynamics::LinearizedProximityModel), as do mpc::LtiModel and the
/// tests' simple plants; the tube MPC (mpc::TubeMPC) and the controller use it. It lives in math so
/// that dynamics, below mpc, can implement it.
#pragma once

#include <Eigen/Dense>

namespace tubempc::math {

/// Affine discrete-time model x+ = A x + B u + c and state constraints G x <= h, both about a
/// linearisation point. Implementations must not allocate in `discretize` or `constraints`.
class LinearizedModel {
 public:
  virtual ~LinearizedModel() = default;

  /// @return the state dimension n_x.
  virtual int nx() const = 0;
  /// @return the input dimension n_u.
  virtual int nu() const = 0;
  /// @return the number of linearised state-constraint rows per node.
  virtual int n_constraints() const = 0;

  /// Discretises the dynamics over [t, t + dt] about (x_lin, u_lin) with a zero-order hold:
  /// x(t + dt) ~= A x(t) + B u + c.
  /// @param t     start time of the step (s).
  /// @param dt    step length (s).
  /// @param x_lin linearisation state (n_x, state units).
  /// @param u_lin linearisation input (n_u, input units).
  /// @param A     receives A (n_x x n_x).
  /// @param B     receives B (n_x x n_u).
  /// @param c     receives c (n_x, state units).
  virtual void discretize(double t, double dt, const Eigen::Ref<const Eigen::VectorXd>& x_lin,
                          const Eigen::Ref<const Eigen::VectorXd>& u_lin, Eigen::Ref<Eigen::MatrixXd> A,
                          Eigen::Ref<Eigen::MatrixXd> B, Eigen::Ref<Eigen::VectorXd> c) const = 0;

  /// Re-discretises a node about (x_lin, u_lin) when A, B, c hold its discretisation over the same
  /// [t, t + dt] about (x_prev, u_prev), as in the sequential convex iterations of the tube MPC.
  /// An implementation may keep the parts of A, B, c that do not depend on what changed (and must
  /// document any tolerance it applies); the default calls `discretize`. A caller that re-discretises
  /// kept data again passes the point they were computed about as x_prev (the tube MPC does), so that a
  /// tolerance is measured from there and not from the last call's point.
  /// @param t      start time of the step (s).
  /// @param dt     step length (s).
  /// @param x_prev linearisation state of the data in A, B, c (n_x).
  /// @param u_prev linearisation input of the data in A, B, c (n_u).
  /// @param x_lin  new linearisation state (n_x).
  /// @param u_lin  new linearisation input (n_u).
  /// @param A      holds A about (x_prev, u_prev); receives A about (x_lin, u_lin) (n_x x n_x).
  /// @param B      likewise B (n_x x n_u).
  /// @param c      likewise c (n_x).
  /// @return whether a part of the data about (x_prev, u_prev) was kept (false: all of A, B, c were
  ///         computed about (x_lin, u_lin)).
  virtual bool rediscretize(double t, double dt, const Eigen::Ref<const Eigen::VectorXd>& x_prev,
                            const Eigen::Ref<const Eigen::VectorXd>& u_prev,
                            const Eigen::Ref<const Eigen::VectorXd>& x_lin,
                            const Eigen::Ref<const Eigen::VectorXd>& u_lin, Eigen::Ref<Eigen::MatrixXd> A,
                            Eigen::Ref<Eigen::MatrixXd> B, Eigen::Ref<Eigen::VectorXd> c) const {
    (void)x_prev;
    (void)u_prev;
    discretize(t, dt, x_lin, u_lin, A, B, c);
    return false;
  }

  /// Linearised state constraints at (t, x_lin): G x <= h.
  /// @param t     time (s).
  /// @param x_lin linearisation state (n_x).
  /// @param G     receives G (n_constraints x n_x).
  /// @param h     receives h (n_constraints, constraint units).
  virtual void constraints(double t, const Eigen::Ref<const Eigen::VectorXd>& x_lin,
                           Eigen::Ref<Eigen::MatrixXd> G, Eigen::Ref<Eigen::VectorXd> h) const = 0;
};

}  // namespace tubempc::math
