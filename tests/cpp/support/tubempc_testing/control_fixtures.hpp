// Shared set-ups of the control tests: the paper-sized 12-state, 6-input plant as two decoupled double
// integrators, and LQR-based subsystem designs (an independent source of stabilising gains). The designs are
// compiled once in control_fixtures.cpp (library tubempc_test_support): their eigenvalue solver and Riccati
// solution cost each test file including this header about 17 s of compile time when defined inline here.
#pragma once

#include <Eigen/Dense>
#include <initializer_list>
#include <memory>

#include "tubempc/control/controller.hpp"
#include "tubempc/control/tube_update.hpp"
#include "tubempc/mpc/lti_model.hpp"
#include "tubempc/mpc/tube_mpc.hpp"

namespace control_test {

using tubempc::control::SubGain;
using tubempc::control::SubInputMatrix;
using tubempc::control::SubMatrix;
using tubempc::control::SubsystemDesign;

// Continuous double integrator of one subsystem: position/angle and rate, input gain b per axis.
inline void double_integrator(double dt, double b, SubMatrix& A, SubInputMatrix& B) {
  A.setIdentity();
  A.topRightCorner<3, 3>() = dt * Eigen::Matrix3d::Identity();
  B.setZero();
  B.topRows<3>() = 0.5 * dt * dt * b * Eigen::Matrix3d::Identity();
  B.bottomRows<3>() = dt * b * Eigen::Matrix3d::Identity();
}

// The LQR gain (u = K x) of (A, B) with weights I and r I.
SubGain lqr_gain(const SubMatrix& A, const SubInputMatrix& B, double r);

// The spectral radius of M (largest eigenvalue modulus).
double spectral_radius(const SubMatrix& M);

// A design of (A, B) for P_W: the LQR gain, alpha halfway between rho(A + B K)^2 and 1, and the
// certified Lyapunov tube (u_max generous).
SubsystemDesign lqr_design(const SubMatrix& A, const SubInputMatrix& B, const SubMatrix& P_W, double r);

// The 12/6 plant: translation (unit input gain) and rotation (1/2750 per N m), four planar constraints.
inline std::shared_ptr<tubempc::mpc::LtiModel> plant_12_6(double dt) {
  Eigen::MatrixXd A_c = Eigen::MatrixXd::Zero(12, 12), B_c = Eigen::MatrixXd::Zero(12, 6);
  A_c.block(0, 3, 3, 3).setIdentity();
  A_c.block(6, 9, 3, 3).setIdentity();
  B_c.block(3, 0, 3, 3).setIdentity();
  B_c.block(9, 3, 3, 3) = Eigen::Vector3d(1.0 / 2750, 1.0 / 2750, 1.0 / 2750).asDiagonal();
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(4, 12);
  G(0, 0) = 1.0;
  G(1, 1) = -1.0;
  G(2, 3) = 1.0;
  G(3, 6) = 1.0;
  Eigen::VectorXd h(4);
  h << 100.0, 100.0, 5.0, 3.0;
  return std::make_shared<tubempc::mpc::LtiModel>(A_c, B_c, Eigen::VectorXd::Zero(12), dt, G, h);
}

// The 12/6 plant's MPC settings: horizon N, period dt, input bounds 0.55 m/s^2 and 3 N m, a generous time limit.
inline tubempc::mpc::Settings plant_12_6_mpc(double dt, int horizon) {
  tubempc::mpc::Settings mpc;
  mpc.horizon = horizon;
  mpc.dt = dt;
  mpc.u_max = (Eigen::VectorXd(6) << 0.55, 0.55, 0.55, 3.0, 3.0, 3.0).finished();
  mpc.time_limit = 10.0;
  return mpc;
}

// Designs of both subsystems of the 12/6 plant: the initial one for 9 S0 (its LQR weight r_initial_p or
// r_initial_r) and a library for c 9 S0, c in scales (weight 1).
tubempc::control::ControllerDesigns plant_12_6_designs(double dt, const SubMatrix& S0_p,
                                                       const SubMatrix& S0_r,
                                                       std::initializer_list<double> scales,
                                                       double r_initial_r = 1.0);

}  // namespace control_test
