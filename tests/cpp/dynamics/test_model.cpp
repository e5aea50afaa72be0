// ProximityModel: frames, f, analytic Jacobians against finite differences, kinematics, validation.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "test_fields.hpp"
#include "tubempc/dynamics/proximity_model.hpp"
#include "tubempc/math/so3.hpp"

namespace tubempc::dynamics {
namespace {

using testing::cluster;
using testing::fast_frames;

// A velocity- and position-dependent extra acceleration (drag-like plus a linear field).
class TestExtra final : public ExtraAcceleration {
 public:
  Eigen::Vector3d acceleration(double t, const Eigen::Vector3d& r, const Eigen::Vector3d& v) const override {
    return -1e-3 * v.norm() * v + 1e-7 * std::cos(1e-3 * t) * Eigen::Vector3d(r.y(), r.z(), r.x());
  }
  void jacobian(double t, const Eigen::Vector3d& r, const Eigen::Vector3d& v, Eigen::Matrix3d& da_dr,
                Eigen::Matrix3d& da_dv) const override {
    (void)r;
    da_dr << 0, 1, 0, 0, 0, 1, 1, 0, 0;
    da_dr *= 1e-7 * std::cos(1e-3 * t);
    const double vn = v.norm();
    da_dv = -1e-3 * (vn * Eigen::Matrix3d::Identity() + v * v.transpose() / vn);
  }
};

StateVector random_state(std::mt19937& rng, double phi_max) {
  std::normal_distribution<double> N(0.0, 1.0);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  Eigen::Vector3d dir(N(rng), N(rng), N(rng));
  dir.normalize();
  Eigen::Vector3d axis(N(rng), N(rng), N(rng));
  axis.normalize();
  StateVector x;
  x.segment<3>(0) = (250.0 + 1000.0 * U(rng)) * dir;
  x.segment<3>(3) = Eigen::Vector3d(N(rng), N(rng), N(rng)) * 0.05;
  x.segment<3>(6) = phi_max * U(rng) * axis;
  x.segment<3>(9) = Eigen::Vector3d(N(rng), N(rng), N(rng)) * 0.02;
  return x;
}

// Fourth-order central difference of f in direction e_j with step h.
template <typename F, typename V>
auto central4(const F& fn, const V& x, int j, double h) {
  V xp1 = x, xm1 = x, xp2 = x, xm2 = x;
  xp1(j) += h;
  xm1(j) -= h;
  xp2(j) += 2 * h;
  xm2(j) -= 2 * h;
  return ((8.0 * (fn(xp1) - fn(xm1)) - (fn(xp2) - fn(xm2))) / (12.0 * h)).eval();
}

// Per 3x3 block, |FD - analytic| <= rel * max|analytic block| (and exact zeros stay zero).
template <typename M>
void expect_blocks_close(const M& fd, const M& an, double rel, const std::string& what) {
  for (int bi = 0; bi < fd.rows() / 3; ++bi) {
    for (int bj = 0; bj < fd.cols() / 3; ++bj) {
      const Eigen::Matrix3d a = an.template block<3, 3>(3 * bi, 3 * bj);
      const Eigen::Matrix3d d = fd.template block<3, 3>(3 * bi, 3 * bj);
      const double scale = a.cwiseAbs().maxCoeff();
      const double err = (a - d).cwiseAbs().maxCoeff();
      EXPECT_LE(err, rel * scale + 1e-300)
          << what << " block (" << bi << "," << bj << ") scale " << scale << "\nanalytic\n"
          << a << "\nfd\n"
          << d;
    }
  }
}

void check_jacobians(const ProximityModel& model, int trials, unsigned seed, double phi_max, double rel) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> N(0.0, 1.0);
  const double steps[4] = {0.5, 1e-4, 1e-4, 1e-5};  // r (m), v (m/s), phi (rad), w (rad/s)
  for (int k = 0; k < trials; ++k) {
    const StateVector x = random_state(rng, phi_max);
    InputVector u;
    for (int i = 0; i < 6; ++i) u(i) = (i < 3 ? 1e-3 : 0.5) * N(rng);
    const double t = 1e4 * std::abs(N(rng));
    StateVector f0;
    StateMatrix A;
    InputMatrix B;
    model.linearize(t, x, u, f0, A, B);
    const StateVector f_direct = model.f(t, x, u);
    EXPECT_LE((f_direct - f0).cwiseAbs().maxCoeff(), 1e-15 * f0.cwiseAbs().maxCoeff());
    StateMatrix A_fd;
    InputMatrix B_fd;
    auto fx = [&](const StateVector& xx) { return model.f(t, xx, u); };
    auto fu = [&](const InputVector& uu) { return model.f(t, x, uu); };
    for (int j = 0; j < kNx; ++j) A_fd.col(j) = central4(fx, x, j, steps[j / 3]);
    for (int j = 0; j < kNu; ++j) B_fd.col(j) = central4(fu, u, j, j < 3 ? 1e-4 : 1e-2);
    expect_blocks_close(A_fd, A, rel, std::string("A, ") + to_string(model.params().kinematics));
    expect_blocks_close(B_fd, B, rel, "B");
  }
}

TEST(ProximityModel, JacobiansMatchFiniteDifferencesBothKinematics) {
  for (Kinematics k : {Kinematics::FirstOrder, Kinematics::Exact}) {
    const ProximityModel model(cluster(), fast_frames(k), std::make_shared<TestExtra>());
    check_jacobians(model, 25, 7u, 3.0, 1e-6);
  }
}

TEST(ProximityModel, JacobiansMatchFiniteDifferencesNearIdentityAttitude) {
  const ProximityModel model(cluster(), fast_frames(Kinematics::Exact));
  check_jacobians(model, 10, 8u, 0.3, 1e-6);  // |phi| < 0.5: the series branch of c(|phi|)
}

TEST(ProximityModel, JacobiansMatchFiniteDifferencesPaperScenario) {
  // Realistic rates: the w_LI terms (~n |w|) are small, so compare each block row-group-wise.
  ModelParams p;
  p.kinematics = Kinematics::Exact;
  const ProximityModel model(cluster(), p);
  std::mt19937 rng(9u);
  for (int k = 0; k < 10; ++k) {
    const StateVector x = random_state(rng, 3.0);
    const InputVector u = InputVector::Constant(1e-3);
    StateVector f0;
    StateMatrix A;
    InputMatrix B;
    model.linearize(100.0 * k, x, u, f0, A, B);
    auto fx = [&](const StateVector& xx) { return model.f(100.0 * k, xx, u); };
    const double steps[4] = {0.5, 1e-4, 1e-4, 1e-5};
    for (int j = 0; j < kNx; ++j) {
      const StateVector d = central4(fx, x, j, steps[j / 3]);
      for (int i = 0; i < kNx; ++i) {
        const double scale = A.block<3, 12>(3 * (i / 3), 0).cwiseAbs().maxCoeff();
        EXPECT_NEAR(d(i), A(i, j), 1e-6 * scale) << "A(" << i << "," << j << ")";
      }
    }
  }
}

TEST(ProximityModel, RightJacobianInverseDerivativeMatchesFiniteDifferences) {
  const Eigen::Vector3d w(0.3, -0.7, 0.2);
  for (double ang : {1e-7, 1e-3, 0.3, 0.4999, 0.5001, 1.5, 3.0, 3.3, 5.0}) {
    const Eigen::Vector3d phi = ang * Eigen::Vector3d(1.0, 2.0, -0.5).normalized();
    Eigen::Matrix3d Jinv;
    Eigen::Matrix3d D;
    right_jacobian_inverse_and_derivative(phi, w, Jinv, D);
    EXPECT_LE((Jinv - math::right_jacobian(phi).inverse()).cwiseAbs().maxCoeff(), 1e-12) << ang;
    auto h = [&](const Eigen::Vector3d& p) {
      Eigen::Matrix3d Ji;
      Eigen::Matrix3d Di;
      right_jacobian_inverse_and_derivative(p, w, Ji, Di);
      return (Ji * w).eval();
    };
    Eigen::Matrix3d D_fd;
    for (int j = 0; j < 3; ++j) D_fd.col(j) = central4(h, phi, j, 1e-4);
    EXPECT_LE((D - D_fd).cwiseAbs().maxCoeff(), 1e-9 * std::max(1.0, D.cwiseAbs().maxCoeff())) << ang;
  }
  Eigen::Matrix3d Ji;
  Eigen::Matrix3d Di;
  EXPECT_THROW(right_jacobian_inverse_and_derivative(Eigen::Vector3d(0, 0, 6.3), w, Ji, Di),
               std::domain_error);
}

TEST(ProximityModel, ExactKinematicsMatchQuaternionKinematics) {
  // d/dt Exp(phi(t)) with phi' = Jr^-1 w equals the quaternion law q' = 1/2 q (x) [w; 0].
  ModelParams p;
  p.kinematics = Kinematics::Exact;
  const ProximityModel model(testing::bennu_point_mass(), p);
  const Eigen::Vector3d w(0.02, -0.01, 0.03);
  for (double ang : {0.2, 1.0, 2.5, 3.1}) {
    const Eigen::Vector3d phi = ang * Eigen::Vector3d(0.3, -1.0, 0.4).normalized();
    const Eigen::Vector3d dphi = model.phi_dot(phi, w);
    const double h = 1e-5;
    const Eigen::Matrix3d dR = (math::rotation_matrix(math::exp_map(phi + h * dphi)) -
                                math::rotation_matrix(math::exp_map(phi - h * dphi))) /
                               (2 * h);
    const Eigen::Matrix3d R = math::rotation_matrix(math::exp_map(phi));
    EXPECT_LE((dR - R * math::skew(w)).cwiseAbs().maxCoeff(), 1e-9) << ang;
  }
}

TEST(ProximityModel, FramesAreClosedFormConstantRateRotations) {
  ModelParams p;
  p.spin_angle0 = 0.7;
  const ProximityModel model(testing::bennu_point_mass(), p);
  const double n = model.mean_motion();
  EXPECT_NEAR(n, std::sqrt(1.32712440018e20 / std::pow(1.685e11, 3)), 1e-22);
  EXPECT_NEAR(n, 1.666e-7, 1e-9);
  for (double t : {0.0, 123.4, 5e4}) {
    // q_A/L = q_A/I (x) q_L/I^*, with the A and L frames turning about z at omega_A and n (inertial).
    const math::Quaternion q_AI = math::exp_map(Eigen::Vector3d(0, 0, -(p.spin_angle0 + p.spin_rate * t)));
    const math::Quaternion q_LI = math::exp_map(Eigen::Vector3d(0, 0, -n * t));
    const Eigen::Matrix3d C = math::rotation_matrix(math::quat_mul(q_AI, math::quat_conj(q_LI)));
    EXPECT_LE((C - model.C_AL(t)).cwiseAbs().maxCoeff(), 1e-14);
    EXPECT_LE((math::rotation_matrix(model.q_AL(t)) - model.C_AL(t)).cwiseAbs().maxCoeff(), 1e-15);
    // x_A expressed in L is at angle theta(t) from x_L.
    const Eigen::Vector3d xA_L = model.C_AL(t).transpose() * Eigen::Vector3d::UnitX();
    const double th = p.spin_angle0 + (p.spin_rate - n) * t;
    EXPECT_NEAR(xA_L.x(), std::cos(th), 1e-14);
    EXPECT_NEAR(xA_L.y(), std::sin(th), 1e-14);
  }
}

TEST(ProximityModel, TranslationalDynamicsMatchHandComputation) {
  ModelParams p;
  const auto g = std::make_shared<gravity::PointMassGravity>(5.0);
  const ProximityModel model(g, p);
  StateVector x = StateVector::Zero();
  x.head<3>() << 300.0, -200.0, 400.0;
  x.segment<3>(3) << 0.01, 0.02, -0.03;
  InputVector u;
  u << 1e-4, -2e-4, 3e-4, 0, 0, 0;
  const StateVector fx = model.f(42.0, x, u);
  const double n = model.mean_motion();
  const Eigen::Vector3d r = x.head<3>();
  const Eigen::Vector3d v = x.segment<3>(3);
  const Eigen::Vector3d expect = -2.0 * n * Eigen::Vector3d::UnitZ().cross(v) +
                                 n * n * Eigen::Vector3d(3 * r.x(), 0.0, -r.z()) +
                                 Eigen::Vector3d(1.7744e15 / (1.685e11 * 1.685e11), 0, 0) -
                                 5.0 / std::pow(r.norm(), 3) * r + u.head<3>();
  EXPECT_LE((fx.segment<3>(3) - expect).cwiseAbs().maxCoeff(), 1e-18);
  EXPECT_NEAR(1.7744e15 / (1.685e11 * 1.685e11), 6.2496e-8, 1e-12);  // docs/model.md: ~6.25e-8 m/s^2
  p.srp_enabled = false;
  const ProximityModel no_srp(g, p);
  EXPECT_NEAR(model.f(42.0, x, u)(3) - no_srp.f(42.0, x, u)(3), 1.7744e15 / (1.685e11 * 1.685e11), 1e-20);
}

TEST(ProximityModel, RejectsBadParametersAndNonFiniteInput) {
  auto bad = [](auto mutate, const char* field) {
    ModelParams p;
    mutate(p);
    try {
      const ProximityModel m(testing::bennu_point_mass(), p);
      ADD_FAILURE() << "no throw for " << field;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  bad([](ModelParams& p) { p.mu_sun = -1.0; }, "mu_sun");
  bad([](ModelParams& p) { p.orbit_radius = 0.0; }, "orbit_radius");
  bad([](ModelParams& p) { p.beta_srp = std::nan(""); }, "beta_srp");
  bad([](ModelParams& p) { p.spin_rate = INFINITY; }, "spin_rate");
  bad([](ModelParams& p) { p.inertia_B(0, 1) = 5.0; }, "inertia_B");
  bad([](ModelParams& p) { p.inertia_B(2, 2) = -1.0; }, "inertia_B");
  bad([](ModelParams& p) { p.glide_slope_angle = 2.0; }, "glide_slope_angle");
  bad([](ModelParams& p) { p.los_angle = 0.0; }, "los_angle");
  bad([](ModelParams& p) { p.boresight_B.setZero(); }, "boresight_B");
  EXPECT_THROW(ProximityModel(nullptr, ModelParams{}), std::invalid_argument);

  const ProximityModel model(testing::bennu_point_mass());
  StateVector x = StateVector::Constant(1.0);
  x(4) = std::nan("");
  const InputVector u = InputVector::Zero();
  try {
    model.f(0.0, x, u);
    ADD_FAILURE() << "no throw";
  } catch (const std::domain_error& e) {
    EXPECT_NE(std::string(e.what()).find("x[4]"), std::string::npos) << e.what();
  }
  StateMatrix Ad;
  InputMatrix Bd;
  StateVector cd;
  EXPECT_EQ(model.discretize(0.0, 2.0, x, u, Ad, Bd, cd), DiscretizationStatus::NonFiniteInput);
  EXPECT_EQ(model.discretize(0.0, NAN, StateVector::Constant(100.0), u, Ad, Bd, cd),
            DiscretizationStatus::NonFiniteInput);
  EXPECT_EQ(model.discretize(0.0, 2.0, StateVector::Constant(100.0), u, Ad, Bd, cd),
            DiscretizationStatus::Ok);
}

TEST(ProximityModel, TruthStateConversionUnwrapsAcrossPi) {
  const Eigen::Vector3d axis = Eigen::Vector3d(1.0, -2.0, 0.5).normalized();
  StateVector x = StateVector::Zero();
  x.head<3>() << 1, 2, 3;
  x.segment<3>(6) = 1.2 * axis;
  x.tail<3>() << 0.1, 0.2, 0.3;
  const StateVector back = truth_to_state(state_to_truth(x));
  EXPECT_LE((back - x).cwiseAbs().maxCoeff(), 1e-14);
  // A rotation of pi + 0.1 about axis: principal value -(pi - 0.1) axis; unwrapped near pi axis.
  x.segment<3>(6) = (M_PI + 0.1) * axis;
  const TruthState s = state_to_truth(x);
  EXPECT_LE((truth_to_state(s).segment<3>(6) + (M_PI - 0.1) * axis).norm(), 1e-12);
  EXPECT_LE((truth_to_state(s, M_PI * axis).segment<3>(6) - (M_PI + 0.1) * axis).norm(), 1e-12);
  EXPECT_THROW(truth_to_state(TruthState::Constant(NAN)), std::domain_error);
}

}  // namespace
}  // namespace tubempc::dynamics
