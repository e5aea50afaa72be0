/// @file lti_model.hpp
/// A linear time-invariant LinearizedModel (exact zero-order hold of x' = A_c x + B_c u + c_c) with
/// fixed linear state constraints: the plant of the MPC's tests and stand-in benchmarks.
#pragma once

#include <Eigen/Dense>

#include "tubempc/math/linearized_model.hpp"

namespace tubempc::mpc {

/// Linear time-invariant plant x+ = A x + B u + c with constant constraints G x <= h: a test and
/// benchmark plant (and a stand-in for the 6-DOF model). The discretisation is computed once.
class LtiModel final : public math::LinearizedModel {
 public:
  /// Continuous-time (A_c, B_c, c_c), discretised with a zero-order hold over dt (s).
  LtiModel(const Eigen::MatrixXd& A_c, const Eigen::MatrixXd& B_c, const Eigen::VectorXd& c_c, double dt,
           const Eigen::MatrixXd& G, const Eigen::VectorXd& h);
  int nx() const override { return static_cast<int>(A_.rows()); }
  int nu() const override { return static_cast<int>(B_.cols()); }
  int n_constraints() const override { return static_cast<int>(G_.rows()); }
  /// Writes the precomputed (A, B, c); throws std::invalid_argument if dt differs from the construction's.
  void discretize(double t, double dt, const Eigen::Ref<const Eigen::VectorXd>& x_lin,
                  const Eigen::Ref<const Eigen::VectorXd>& u_lin, Eigen::Ref<Eigen::MatrixXd> A,
                  Eigen::Ref<Eigen::MatrixXd> B, Eigen::Ref<Eigen::VectorXd> c) const override;
  void constraints(double t, const Eigen::Ref<const Eigen::VectorXd>& x_lin, Eigen::Ref<Eigen::MatrixXd> G,
                   Eigen::Ref<Eigen::VectorXd> h) const override;

 private:
  Eigen::MatrixXd A_, B_;
  Eigen::VectorXd c_;
  double dt_;
  Eigen::MatrixXd G_;
  Eigen::VectorXd h_;
};

}  // namespace tubempc::mpc
