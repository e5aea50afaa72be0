// The compiled part of the control tests' fixtures (tubempc_testing/control_fixtures.hpp).
#include "tubempc_testing/control_fixtures.hpp"

#include <stdexcept>

namespace control_test {

SubGain lqr_gain(const SubMatrix& A, const SubInputMatrix& B, double r) {
  const Eigen::MatrixXd X =
      tubempc::mpc::solve_dare(A, B, Eigen::MatrixXd::Identity(6, 6), r * Eigen::MatrixXd::Identity(3, 3));
  const Eigen::Matrix3d S = r * Eigen::Matrix3d::Identity() + B.transpose() * X * B;
  return -S.ldlt().solve(B.transpose() * X * A);
}

double spectral_radius(const SubMatrix& M) {
  return Eigen::EigenSolver<SubMatrix>(M).eigenvalues().cwiseAbs().maxCoeff();
}

SubsystemDesign lqr_design(const SubMatrix& A, const SubInputMatrix& B, const SubMatrix& P_W, double r) {
  SubsystemDesign d;
  d.K = lqr_gain(A, B, r);
  const SubMatrix Acl = A + B * d.K;
  const double rho = spectral_radius(Acl);
  d.alpha = 0.5 * (rho * rho + 1.0);
  d.P_W = P_W;
  tubempc::control::SubsystemTube t;
  if (tubempc::control::lyapunov_tube(A, B, d.K, d.alpha, P_W, 1e9, t) !=
      tubempc::control::Certification::Certified)
    throw std::runtime_error("lqr_design: not certified");
  d.Pe = t.Pe;
  return d;
}

tubempc::control::ControllerDesigns plant_12_6_designs(double dt, const SubMatrix& S0_p,
                                                       const SubMatrix& S0_r,
                                                       std::initializer_list<double> scales,
                                                       double r_initial_r) {
  tubempc::control::ControllerDesigns designs;
  SubMatrix A;
  SubInputMatrix B;
  for (int s = 0; s < 2; ++s) {
    double_integrator(dt, s == 0 ? 1.0 : 1.0 / 2750, A, B);
    const SubMatrix P0 = 9.0 * (s == 0 ? S0_p : S0_r);
    (s == 0 ? designs.initial_p : designs.initial_r) = lqr_design(A, B, P0, s == 0 ? 1.0 : r_initial_r);
    for (double c : scales)
      (s == 0 ? designs.library_p : designs.library_r).push_back(lqr_design(A, B, c * P0, 1.0));
  }
  return designs;
}

}  // namespace control_test
