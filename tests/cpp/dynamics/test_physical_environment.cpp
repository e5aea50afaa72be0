// The physical environment of the truth (docs/model.md "Physical environment"): flat-plate SRP against
// its closed forms and the project's beta_SRP, the gravity-gradient torque against a point cloud and the
// potential, the truth's mass, inertia and actuator errors, and the invariants of a propagation in it.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "test_fields.hpp"
#include "tubempc/dynamics/physical_environment.hpp"

namespace tubempc::dynamics {
namespace {

constexpr double kP = 4.56e-6;  // N/m^2 at 1 AU

FlatPlate plate(const Eigen::Vector3d& n, double area, double specular = 0.0, double diffuse = 0.0,
                const Eigen::Vector3d& c = Eigen::Vector3d::Zero()) {
  FlatPlate p;
  p.area = area;
  p.normal_B = n;
  p.center_B = c;
  p.specular = specular;
  p.diffuse = diffuse;
  return p;
}

Eigen::Vector3d force(const FlatPlate& p, const Eigen::Vector3d& s, double P = kP) {
  Eigen::Vector3d F, T;
  flat_plate_wrench(p, s, P, F, T);
  return F;
}

TEST(FlatPlate, FacingTheSunAbsorbingSpecularAndDiffuse) {
  const Eigen::Vector3d s = Eigen::Vector3d(1.0, 2.0, -2.0) / 3.0;  // towards the Sun, in B
  const double A = 6.0;
  // Absorbing: P A along -s (away from the Sun).
  EXPECT_LE((force(plate(s, A), s) - (-kP * A * s)).norm(), 1e-20);
  // Specular: 2 P A along -n.
  EXPECT_LE((force(plate(s, A, 1.0), s) - (-2.0 * kP * A * s)).norm(), 1e-20);
  // Diffuse (Lambertian): P A (1 + 2/3) along -n.
  EXPECT_LE((force(plate(s, A, 0.0, 1.0), s) - (-5.0 / 3.0 * kP * A * s)).norm(), 1e-20);
  // The normal is normalised on use.
  EXPECT_LE((force(plate(7.0 * s, A), s) - (-kP * A * s)).norm(), 1e-20);
}

TEST(FlatPlate, AtAnAngleAndFacingAway) {
  const double theta = 60.0 * 3.14159265358979323846 / 180.0, A = 4.0, rs = 0.3, rd = 0.2;
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d s(std::sin(theta), 0.0, std::cos(theta));
  const double c = std::cos(theta);
  // In the plate's axes: the normal component and the component along s's tangential part.
  const Eigen::Vector3d F = force(plate(n, A, rs, rd), s);
  EXPECT_NEAR(F.z(), -kP * A * c * ((1.0 - rs) * c + 2.0 * (rs * c + rd / 3.0)), 1e-20);
  EXPECT_NEAR(F.x(), -kP * A * c * (1.0 - rs) * std::sin(theta), 1e-20);
  EXPECT_EQ(F.y(), 0.0);
  // Absorbing at 60 deg: half the face-on force, along -s; specular: P A 2 cos^2 along -n.
  EXPECT_LE((force(plate(n, A), s) - (-0.5 * kP * A * s)).norm(), 1e-20);
  EXPECT_LE((force(plate(n, A, 1.0), s) - (-2.0 * c * c * kP * A * n)).norm(), 1e-20);
  // Facing away from the Sun, or edge-on: no force.
  EXPECT_EQ(force(plate(-n, A, rs, rd), s), Eigen::Vector3d::Zero());
  EXPECT_EQ(force(plate(Eigen::Vector3d::UnitY(), A, rs, rd), s), Eigen::Vector3d::Zero());
}

TEST(FlatPlate, TorqueIsTheCentreOfPressureCrossTheForce) {
  const Eigen::Vector3d c(0.4, -2.5, 1.2), s = Eigen::Vector3d(1.0, 1.0, 1.0).normalized();
  const FlatPlate p = plate(Eigen::Vector3d(0.0, 1.0, 1.0), 3.0, 0.4, 0.3, c);
  Eigen::Vector3d F, T;
  flat_plate_wrench(p, s, kP, F, T);
  EXPECT_GT(F.norm(), 0.0);
  EXPECT_LE((T - c.cross(F)).norm(), 1e-22);
}

PhysicalSettings settings_with(std::vector<FlatPlate> plates) {
  PhysicalSettings s;
  s.mass = 2000.0;
  s.mass_error = 0.02;
  s.plates = std::move(plates);
  return s;
}

const Eigen::Matrix3d kJ = Eigen::Vector3d(2750.0, 2750.0, 2030.0).asDiagonal();

TEST(PhysicalEnvironment, AnAbsorbingPlateFacingTheSunIsTheCannonballOfTheSameBeta) {
  // beta_SRP = P(1 AU) (1 AU)^2 A / m: the project's SRP constant for an absorbing area A (docs/model.md).
  const double R = 1.685e11, A = 10.0;
  PhysicalSettings s = settings_with({plate(-Eigen::Vector3d::UnitX(), A)});  // faces -x_B
  const PhysicalEnvironment env(s, kJ, 5.0, R);
  EXPECT_NEAR(env.pressure(), kP * std::pow(kAstronomicalUnit / R, 2), 1e-22);
  TruthState st = TruthState::Zero();
  st.head<3>() << -300.0, 50.0, 20.0;  // sunlit side
  st(9) = 1.0;                         // B = L: the plate faces the Sun (-x_L)
  ModelParams p;
  p.beta_srp = kP * kAstronomicalUnit * kAstronomicalUnit * A / s.true_mass();
  p.orbit_radius = R;
  const ProximityModel cannonball(testing::bennu_point_mass(), p);
  EXPECT_LE((env.srp_acceleration_L(st) - cannonball.srp_acceleration_L()).norm(),
            1e-14 * cannonball.srp_acceleration_L().norm());
  EXPECT_GT(env.srp_acceleration_L(st).x(), 0.0);  // away from the Sun
  // The same through the derivative's disturbance, and no torque (centre of pressure at the centre of mass).
  const Disturbance6 d = env(0.0, st);
  EXPECT_LE((d.head<3>() - cannonball.srp_acceleration_L()).norm(), 1e-14 * d.head<3>().norm());
}

TEST(PhysicalEnvironment, TorqueOfOffsetPlatesAndTheShadow) {
  const Eigen::Vector3d c1(0.1, 4.0, 0.0), c2(0.1, -3.5, 0.0);
  PhysicalSettings s = settings_with({plate(-Eigen::Vector3d::UnitX(), 4.25, 0.1, 0.2, c1),
                                      plate(-Eigen::Vector3d::UnitX(), 4.25, 0.1, 0.2, c2),
                                      plate(Eigen::Vector3d::UnitX(), 4.25, 0.1, 0.2, c1)});  // unlit
  s.shadow_radius = 250.0;
  s.gravity_gradient = false;
  const PhysicalEnvironment env(s, kJ, 5.0, 1.685e11);
  const Eigen::Matrix3d C_BL =
      math::rotation_matrix(math::exp_map(Eigen::Vector3d(0.1, -0.2, 0.05))).transpose();
  const Eigen::Vector3d r_L(-400.0, 30.0, 100.0);
  Eigen::Vector3d F, T, F1, T1, F2, T2;
  env.srp_wrench(r_L, C_BL, F, T);
  const Eigen::Vector3d sun_B = C_BL * -Eigen::Vector3d::UnitX();
  flat_plate_wrench(s.plates[0], sun_B, env.pressure(), F1, T1);
  flat_plate_wrench(s.plates[1], sun_B, env.pressure(), F2, T2);
  EXPECT_LE((F - (F1 + F2)).norm(), 1e-14 * F.norm());
  EXPECT_LE((T - (c1.cross(F1) + c2.cross(F2))).norm(), 1e-14 * T.norm());
  EXPECT_GT(T.norm(), 1e-3 * F.norm());  // the arrays' offsets differ: a net torque
  // The angular acceleration is J_true^-1 T.
  TruthState st = TruthState::Zero();
  st.head<3>() = r_L;
  st.segment<4>(6) = math::quat_from_rotation_matrix(C_BL.transpose());
  EXPECT_LE((env(0.0, st).tail<3>() - env.inertia_B().inverse() * T).norm(), 1e-12 * T.norm() / 2030.0);
  // Behind the body (x_L > 0) within the shadow's radius: nothing; beside it: lit.
  env.srp_wrench(Eigen::Vector3d(300.0, 100.0, -200.0), C_BL, F, T);
  EXPECT_EQ(F, Eigen::Vector3d::Zero());
  EXPECT_TRUE(env.in_shadow(Eigen::Vector3d(300.0, 100.0, -200.0)));
  EXPECT_FALSE(env.in_shadow(Eigen::Vector3d(300.0, 200.0, -200.0)));
  EXPECT_FALSE(env.in_shadow(Eigen::Vector3d(-300.0, 0.0, 0.0)));
}

TEST(GravityGradient, ZeroAlongAPrincipalAxis) {
  const Eigen::Matrix3d J = Eigen::Vector3d(2750.0, 2600.0, 2030.0).asDiagonal();
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(gravity_gradient_torque(5.0, 300.0 * Eigen::Vector3d::Unit(i), J), Eigen::Vector3d::Zero());
  }
  // Along a principal axis of a rotated inertia: zero to rounding.
  const Eigen::Matrix3d R = math::rotation_matrix(math::exp_map(Eigen::Vector3d(0.3, -0.7, 1.1)));
  const Eigen::Matrix3d Jr = R * J * R.transpose();
  const Eigen::Vector3d T = gravity_gradient_torque(5.0, 300.0 * R.col(1), Jr);
  EXPECT_LE(T.norm(),
            1e-12 * gravity_gradient_torque(5.0, 300.0 * (R.col(0) + R.col(1)).normalized(), Jr).norm());
}

TEST(GravityGradient, EqualsTheTorqueOnAPointCloudOfTheSameInertia) {
  // Pairs of point masses at +-p_j (centre of mass at the origin; the odd terms of the expansion cancel, so
  // the point-mass formula is exact to O((|p| / |r|)^2)).
  const std::vector<Eigen::Vector3d> p{{1.2, 0.3, -0.4}, {-0.2, 0.9, 0.5}, {0.4, -0.6, 1.5}, {0.8, 0.8, 0.1}};
  const std::vector<double> m{300.0, 200.0, 250.0, 120.0};
  Eigen::Matrix3d J = Eigen::Matrix3d::Zero();
  for (std::size_t j = 0; j < p.size(); ++j) {
    J += 2.0 * m[j] * (p[j].squaredNorm() * Eigen::Matrix3d::Identity() - p[j] * p[j].transpose());
  }
  const double mu = 5.2;
  for (const Eigen::Vector3d r : {Eigen::Vector3d(3e3, -1e3, 2e3), Eigen::Vector3d(-500.0, 4e3, -800.0)}) {
    Eigen::Vector3d T = Eigen::Vector3d::Zero();
    for (std::size_t j = 0; j < p.size(); ++j) {
      for (const double sgn : {1.0, -1.0}) {
        const Eigen::Vector3d q = sgn * p[j], d = r + q;
        T += q.cross(-mu * m[j] * d / std::pow(d.norm(), 3));
      }
    }
    const Eigen::Vector3d T_gg = gravity_gradient_torque(mu, r, J);
    EXPECT_GT(T_gg.norm(), 0.0);
    EXPECT_LE((T_gg - T).norm(), 1e-6 * T.norm());
  }
}

TEST(GravityGradient, IsMinusTheDerivativeOfThePotentialEnergyUnderRotation) {
  // V = 3 mu / (2 |r|^5) r_B^T J r_B (MacCullagh, up to terms that do not depend on the attitude); turning
  // the body by d about e (in B) turns r_B by -d about e, and T . e = -dV/dd.
  Eigen::Matrix3d J;
  J << 2750.0, 30.0, -12.0, 30.0, 2600.0, 25.0, -12.0, 25.0, 2030.0;
  const double mu = 5.2;
  const Eigen::Vector3d r_B(150.0, -220.0, 90.0);
  auto V = [&](const Eigen::Vector3d& rb) { return 1.5 * mu / std::pow(rb.norm(), 5) * rb.dot(J * rb); };
  const Eigen::Vector3d T = gravity_gradient_torque(mu, r_B, J);
  const double h = 1e-5;
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d e = Eigen::Vector3d::Unit(i);
    const Eigen::Matrix3d Rp = math::rotation_matrix(math::exp_map(h * e)).transpose();  // Exp(-h e)
    const Eigen::Matrix3d Rm = math::rotation_matrix(math::exp_map(-h * e)).transpose();
    const double dV = (V(Rp * r_B) - V(Rm * r_B)) / (2.0 * h);
    EXPECT_NEAR(T(i), -dV, 1e-7 * T.norm());
  }
}

TEST(PhysicalSettings, TrueMassAndInertia) {
  PhysicalSettings s;
  s.mass = 2110.0;
  s.mass_error = 0.02;
  s.inertia_scale << 1.05, 0.95, 1.03;
  s.inertia_products << 15.0, -8.0, 5.0;
  EXPECT_DOUBLE_EQ(s.true_mass(), 1.02 * 2110.0);
  const Eigen::Matrix3d J = s.true_inertia(kJ);
  Eigen::Matrix3d expected;
  expected << 1.05 * 2750.0, 15.0, -8.0, 15.0, 0.95 * 2750.0, 5.0, -8.0, 5.0, 1.03 * 2030.0;
  EXPECT_LE((J - expected).norm(), 1e-12 * J.norm());
  // Not an inertia: not positive definite, or moments against the triangle inequality.
  s.inertia_products << 3000.0, 0.0, 0.0;
  try {
    s.true_inertia(kJ);
    FAIL() << "expected invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("inertia_products"), std::string::npos) << e.what();
  }
  s.inertia_products.setZero();
  s.inertia_scale << 0.6, 0.6, 1.9;  // 0.6 * 2750 * 2 < 1.9 * 2030? no: 3300 > 3857 fails
  EXPECT_THROW(s.true_inertia(kJ), std::invalid_argument);
}

TEST(PhysicalSettings, ValidationNamesTheField) {
  auto message = [](const PhysicalSettings& s) {
    try {
      s.validate();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  PhysicalSettings s;
  EXPECT_EQ(message(s), "");
  s.mass = -1.0;
  EXPECT_NE(message(s).find("PhysicalSettings.mass:"), std::string::npos);
  s = PhysicalSettings{};
  s.mass_error = 0.7;
  EXPECT_NE(message(s).find("mass_error"), std::string::npos);
  s = PhysicalSettings{};
  s.solar_pressure = NAN;
  EXPECT_NE(message(s).find("solar_pressure"), std::string::npos);
  s = PhysicalSettings{};
  s.plates = {plate(Eigen::Vector3d::UnitX(), 1.0), plate(Eigen::Vector3d::UnitX(), 1.0, 0.7, 0.5)};
  EXPECT_NE(message(s).find("PhysicalSettings.plates[1].diffuse"), std::string::npos) << message(s);
  s.plates = {plate(Eigen::Vector3d::Zero(), 1.0)};
  EXPECT_NE(message(s).find("plates[0].normal_B"), std::string::npos) << message(s);
  EXPECT_THROW(PhysicalEnvironment(PhysicalSettings{}, kJ, -1.0, 1.685e11), std::invalid_argument);
}

TEST(PhysicalEnvironment, DeliversTheCommandWithTheMassRatioAndTheErrorsInB) {
  PhysicalSettings s = settings_with({});
  const Eigen::Matrix3d E_F = math::rotation_matrix(math::exp_map(Eigen::Vector3d(0.0, 0.0, 0.01))) * 1.03;
  const Eigen::Matrix3d E_T = Eigen::Vector3d(0.98, 1.01, 1.0).asDiagonal();
  const PhysicalEnvironment ideal(s, kJ, 5.0, 1.685e11);
  const PhysicalEnvironment env(s, kJ, 5.0, 1.685e11, E_F, E_T);
  const math::Quaternion q = math::exp_map(Eigen::Vector3d(0.3, 2.9, 0.3));
  InputVector u;
  u << 0.1, -0.2, 0.05, 1.0, -2.0, 0.5;
  const InputVector d0 = ideal.deliver(u, q);
  EXPECT_LE((d0.head<3>() - u.head<3>() / 1.02).norm(), 1e-15);
  EXPECT_EQ(d0.tail<3>(), u.tail<3>());
  const Eigen::Matrix3d C_LB = math::rotation_matrix(q);
  const InputVector d = env.deliver(u, q);
  EXPECT_LE((d.head<3>() - C_LB * E_F * C_LB.transpose() * u.head<3>() / 1.02).norm(), 1e-15);
  EXPECT_LE((d.tail<3>() - E_T * u.tail<3>()).norm(), 1e-15);
}

TEST(PhysicalEnvironment, HoveringInAPointMassFieldConservesEnergyAndTheMomentumAlongTheRadius) {
  // L inertial (mu_sun = 0), a point mass, SRP off, the spacecraft held at rest by a thrust equal to minus
  // the gravity: only the gravity-gradient torque acts on the attitude, a conservative torque whose
  // potential is V = 3 mu / (2 |r|^5) r_B^T J r_B, and perpendicular to r_B. So E = w^T J w / 2 + V and
  // the angular momentum's component along r, (C_LB J w) . r_L, are constant. mu is large enough here for the
  // attitude to librate: the torque exchanges energy of the order of the rotational energy.
  const double mu = 5e3;
  PhysicalSettings s = settings_with({plate(-Eigen::Vector3d::UnitX(), 10.0)});
  s.srp = false;
  s.inertia_scale << 1.04, 0.96, 1.02;
  s.inertia_products << 20.0, -10.0, 6.0;
  const PhysicalEnvironment env(s, kJ, mu, 1.685e11);
  ModelParams p;
  p.mu_sun = 0.0;
  p.srp_enabled = false;
  p.inertia_B = env.inertia_B();
  const ProximityModel truth(std::make_shared<gravity::PointMassGravity>(mu), p);
  TruthState st = TruthState::Zero();
  st.head<3>() << 60.0, -70.0, 40.0;
  st.segment<4>(6) = math::exp_map(Eigen::Vector3d(0.4, 2.5, -0.3));
  st.tail<3>() << 0.02, -0.01, 0.03;
  InputVector u = InputVector::Zero();
  u.head<3>() = mu * st.head<3>() / std::pow(st.head<3>().norm(), 3);  // minus the gravity
  const Eigen::Matrix3d& J = env.inertia_B();
  auto invariants = [&](const TruthState& x) {
    const Eigen::Matrix3d C_LB = math::rotation_matrix(x.segment<4>(6));
    const Eigen::Vector3d w = x.tail<3>(), r_B = C_LB.transpose() * x.head<3>();
    const double V = 1.5 * mu / std::pow(r_B.norm(), 5) * r_B.dot(J * r_B);
    return Eigen::Vector3d(0.5 * w.dot(J * w) + V, (C_LB * J * w).dot(x.head<3>().normalized()), V);
  };
  const Eigen::Vector3d i0 = invariants(st);
  PropagatorSettings set;
  set.substeps = 20;
  double V_min = i0(2), V_max = i0(2);
  for (int k = 0; k < 100; ++k) {
    const PropagationResult res = propagate(truth, env, 2.0 * k, st, u, 2.0, set);
    ASSERT_EQ(res.status, PropagationStatus::Success);
    st = res.state;
    V_min = std::min(V_min, invariants(st)(2));
    V_max = std::max(V_max, invariants(st)(2));
  }
  const Eigen::Vector3d i1 = invariants(st);
  EXPECT_LE((st.head<3>() - Eigen::Vector3d(60.0, -70.0, 40.0)).norm(), 1e-9);  // held in place
  EXPECT_GT(V_max - V_min, 0.1 * std::abs(i0(0)));  // the torque did exchange energy
  EXPECT_NEAR(i1(0), i0(0), 1e-9 * std::abs(i0(0)));
  EXPECT_NEAR(i1(1), i0(1), 1e-9 * J.norm() * 0.04);
}

TEST(PhysicalEnvironment, PropagateRefusesATruthModelThatDoesNotMatch) {
  PhysicalSettings s = settings_with({});
  s.inertia_scale << 1.05, 0.95, 1.0;
  const PhysicalEnvironment env(s, kJ, 5.0, 1.685e11);
  ModelParams p;
  p.inertia_B = env.inertia_B();
  TruthState st = TruthState::Zero();
  st.head<3>() << 300.0, 0.0, 0.0;
  st(9) = 1.0;
  const ProximityModel srp_on(testing::bennu_point_mass(), p);  // the cannonball SRP is on
  EXPECT_THROW(propagate(srp_on, env, 0.0, st, InputVector::Zero(), 1.0), std::invalid_argument);
  p.srp_enabled = false;
  p.inertia_B = kJ;  // the controller's inertia, not the truth's
  const ProximityModel wrong_j(testing::bennu_point_mass(), p);
  EXPECT_THROW(propagate(wrong_j, env, 0.0, st, InputVector::Zero(), 1.0), std::invalid_argument);
  p.inertia_B = env.inertia_B();
  const ProximityModel ok(testing::bennu_point_mass(), p);
  EXPECT_EQ(propagate(ok, env, 0.0, st, InputVector::Zero(), 1.0).status, PropagationStatus::Success);
}

}  // namespace
}  // namespace tubempc::dynamics
