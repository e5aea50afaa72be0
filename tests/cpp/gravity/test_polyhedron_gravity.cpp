#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "gravity_test_meshes.hpp"
#include "tubempc/gravity/polyhedron_gravity.hpp"
#include "tubempc/math/so3.hpp"

using gravity_test::box;
using gravity_test::kPi;
using gravity_test::Mesh;
using tubempc::gravity::GravitySample;
using tubempc::gravity::kGravitationalConstant;
using tubempc::gravity::PolyhedronGravity;
using tubempc::gravity::Shape;

namespace {

constexpr double kRho = 1260.0;

PolyhedronGravity model(const Mesh& m, double rho = kRho) { return PolyhedronGravity(Shape(m.v, m.f), rho); }

// Closed form of the homogeneous rectangular prism [x0,x1] x [y0,y1] x [z0,z1] (Nagy 1966; Nagy,
// Papp and Benedek 2000): with X = x' - p etc., U = G rho sum_corners s F(X, Y, Z),
// F = XY ln(Z+R) + YZ ln(X+R) + ZX ln(Y+R) - X^2/2 atan(YZ/(XR)) - Y^2/2 atan(ZX/(YR)) - Z^2/2 atan(XY/(ZR)),
// and a_x = dU/dp_x = -G rho sum_corners s (Y ln(Z+R) + Z ln(Y+R) - X atan(YZ/(XR))), cyclically;
// s = +1 for an even number of lower bounds, -1 otherwise. Valid away from the corner planes.
struct Prism {
  double x0, x1, y0, y1, z0, z1;
  void eval(const Eigen::Vector3d& p, double& U_out, Eigen::Vector3d& a_out) const {
    Eigen::Matrix3d unused;
    eval(p, U_out, a_out, unused);
  }
  void eval(const Eigen::Vector3d& p, double& U_out, Eigen::Vector3d& a_out, Eigen::Matrix3d& H_out) const {
    using LD = long double;  // the closed form cancels too: evaluate it in extended precision
    LD U = 0, ax = 0, ay = 0, az = 0, hxx = 0, hyy = 0, hzz = 0, hxy = 0, hxz = 0, hyz = 0;
    for (int i = 0; i < 8; ++i) {
      const LD X = LD((i & 1) ? x1 : x0) - p.x(), Y = LD((i & 2) ? y1 : y0) - p.y(),
               Z = LD((i & 4) ? z1 : z0) - p.z();
      const int lower = !(i & 1) + !(i & 2) + !(i & 4);
      const LD s = (lower % 2 == 0) ? 1 : -1;
      const LD R = std::sqrt(X * X + Y * Y + Z * Z);
      // ln(W + R) without cancellation for W < 0: W + R = (R^2 - W^2)/(R - W).
      auto ln_plus_r = [R](LD W, LD P, LD Q) { return std::log(W >= 0 ? W + R : (P * P + Q * Q) / (R - W)); };
      const LD lx = ln_plus_r(X, Y, Z), ly = ln_plus_r(Y, Z, X), lz = ln_plus_r(Z, X, Y);
      U += s * (X * Y * lz + Y * Z * lx + Z * X * ly - X * X / 2 * std::atan(Y * Z / (X * R)) -
                Y * Y / 2 * std::atan(Z * X / (Y * R)) - Z * Z / 2 * std::atan(X * Y / (Z * R)));
      ax -= s * (Y * lz + Z * ly - X * std::atan(Y * Z / (X * R)));
      ay -= s * (Z * lx + X * lz - Y * std::atan(Z * X / (Y * R)));
      az -= s * (X * ly + Y * lx - Z * std::atan(X * Y / (Z * R)));
      // Hess U: d a_x / d p_x = -G rho sum s atan(YZ/(XR)), d a_x / d p_y = G rho sum s ln(Z+R), ...
      hxx -= s * std::atan(Y * Z / (X * R));
      hyy -= s * std::atan(Z * X / (Y * R));
      hzz -= s * std::atan(X * Y / (Z * R));
      hxy += s * lz;
      hxz += s * ly;
      hyz += s * lx;
    }
    const LD g_rho = LD(kGravitationalConstant) * kRho;
    U_out = static_cast<double>(g_rho * U);
    a_out << static_cast<double>(g_rho * ax), static_cast<double>(g_rho * ay),
        static_cast<double>(g_rho * az);
    H_out << static_cast<double>(hxx), static_cast<double>(hxy), static_cast<double>(hxz),  //
        static_cast<double>(hxy), static_cast<double>(hyy), static_cast<double>(hyz),       //
        static_cast<double>(hxz), static_cast<double>(hyz), static_cast<double>(hzz);
    H_out *= static_cast<double>(g_rho);
  }
};

}  // namespace

TEST(PolyhedronGravity, PrismPotentialAccelerationAndHessianMatchClosedForm) {
  const Prism pr{-100.0, 140.0, -60.0, 90.0, -75.0, 55.0};
  const PolyhedronGravity g = model(box(pr.x0, pr.x1, pr.y0, pr.y1, pr.z0, pr.z1));
  const Eigen::Vector3d pts[] = {{300.0, 41.0, -17.0}, {-20.0, 150.0, 230.0}, {1234.0, -987.0, 2345.0},
                                 {13.0, -7.0, 5.0},    {120.0, 80.0, -70.0},  {141.0, 3.0, 2.0}};
  for (const auto& p : pts) {
    double U = 0.0;
    Eigen::Vector3d a;
    Eigen::Matrix3d H;
    pr.eval(p, U, a, H);
    GravitySample s;
    g.evaluate(p, s);
    EXPECT_NEAR(s.potential, U, 1e-12 * U) << p.transpose();
    EXPECT_LT((s.acceleration - a).norm(), 1e-11 * a.norm()) << p.transpose();
    EXPECT_LT((s.gradient - H).norm(), 1e-10 * H.norm()) << p.transpose();
  }
}

TEST(PolyhedronGravity, FarFieldMatchesPointMassPlusQuadrupole) {
  // MacCullagh: U = GM/r + G/(2 r^3) (tr I - 3 u^T I u); for a centred box the next term is O(r^-5).
  const Mesh m = box(-150.0, 150.0, -100.0, 100.0, -60.0, 60.0);
  const PolyhedronGravity g = model(m);
  const Eigen::Matrix3d I = g.shape().inertia(kRho);
  for (double dist : {3000.0, 10000.0, 100000.0}) {
    const Eigen::Vector3d u = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
    const Eigen::Vector3d p = dist * u;
    GravitySample s;
    g.evaluate(p, s);
    const double U0 = g.gm() / dist;
    const double U2 = kGravitationalConstant / (2.0 * dist * dist * dist) * (I.trace() - 3.0 * u.dot(I * u));
    const double rel = std::pow(180.0 / dist, 4);             // size of the first neglected term
    const double cancel = 1e-15 * std::pow(dist / 180.0, 2);  // the formula's own cancellation
    EXPECT_NEAR(s.potential, U0 + U2, (2.0 * rel + cancel) * U0) << dist;
    EXPECT_GT(std::fabs(s.potential - U0), 10.0 * std::fabs(s.potential - U0 - U2)) << dist;
    EXPECT_LT((s.acceleration + U0 / dist * u).norm(), 10.0 * std::fabs(U2) / dist + cancel * U0 / dist);
  }
}

TEST(PolyhedronGravity, FarFieldExpansionTakesOverContinuouslyAndStaysExact) {
  const Mesh m = gravity_test::lumpy_body(16, 24, 250.0);
  const PolyhedronGravity g = model(m);
  const Eigen::Vector3d c = g.shape().center_of_mass();
  const double r_max = (m.v.rowwise() - c.transpose()).rowwise().norm().maxCoeff();
  const Eigen::Vector3d u = Eigen::Vector3d(-0.2, 0.6, 0.7).normalized();
  const double r_switch = tubempc::gravity::kFarFieldFactor * r_max;
  GravitySample in, out;
  g.evaluate(c + (1.0 - 1e-14) * r_switch * u, in);   // polyhedron formula
  g.evaluate(c + (1.0 + 1e-14) * r_switch * u, out);  // expansion
  // The jump: cancellation of the polyhedron sums and truncation of the expansion, both ~1e-10.
  EXPECT_NEAR(out.potential, in.potential, 1e-9 * in.potential);
  EXPECT_LT((out.acceleration - in.acceleration).norm(), 2e-9 * in.acceleration.norm());
  EXPECT_LT((out.gradient - in.gradient).norm(), 1e-8 * in.gradient.norm());
  EXPECT_EQ(g.laplacian(c + 1.1 * r_switch * u), 0.0);
  // Expansion derivatives against central differences.
  const Eigen::Vector3d p = c + 2.0 * r_switch * u;
  GravitySample s, sp, sm;
  g.evaluate(p, s);
  const double h = 1.0;
  for (int i = 0; i < 3; ++i) {
    g.evaluate(p + h * Eigen::Vector3d::Unit(i), sp);
    g.evaluate(p - h * Eigen::Vector3d::Unit(i), sm);
    EXPECT_NEAR((sp.potential - sm.potential) / (2 * h), s.acceleration(i), 1e-8 * s.acceleration.norm());
    EXPECT_LT(((sp.acceleration - sm.acceleration) / (2 * h) - s.gradient.col(i)).norm(),
              1e-7 * s.gradient.norm());
  }
  EXPECT_LT((s.gradient - s.gradient.transpose()).norm(), 1e-15 * s.gradient.norm());
  EXPECT_NEAR(s.gradient.trace(), 0.0, 1e-12 * s.gradient.norm());
  // Far beyond, the point-mass limit holds to rounding (the polyhedron sums would have lost all
  // digits to cancellation here).
  for (double dist : {1e12, 1e20, 1e100}) {
    g.evaluate(c + dist * u, s);
    EXPECT_NEAR(s.potential, g.gm() / dist, 1e-12 * g.gm() / dist) << dist;
    EXPECT_LT((s.acceleration + g.gm() / (dist * dist) * u).norm(), 1e-12 * g.gm() / (dist * dist)) << dist;
  }
  EXPECT_THROW(g.evaluate(Eigen::Vector3d(1e151, 0.0, 0.0), s), std::domain_error);
}

TEST(PolyhedronGravity, LaplacianIsMinusFourPiGRhoInsideAndZeroOutside) {
  const Mesh m = gravity_test::lumpy_body(16, 24, 250.0);
  const PolyhedronGravity g = model(m);
  const double four_pi_g_rho = 4.0 * kPi * kGravitationalConstant * kRho;
  for (const Eigen::Vector3d p : {Eigen::Vector3d(10.0, -20.0, 5.0), Eigen::Vector3d(100.0, 50.0, -80.0)}) {
    EXPECT_NEAR(g.laplacian(p), -four_pi_g_rho, 1e-12 * four_pi_g_rho);
    GravitySample s;
    g.evaluate(p, s);
    EXPECT_NEAR(s.gradient.trace(), -four_pi_g_rho, 1e-10 * four_pi_g_rho);
  }
  for (const Eigen::Vector3d p : {Eigen::Vector3d(600.0, -20.0, 5.0), Eigen::Vector3d(-100.0, 350.0, 300.0),
                                  Eigen::Vector3d(1e5, 2e5, -3e5)}) {
    EXPECT_NEAR(g.laplacian(p), 0.0, 1e-13 * four_pi_g_rho);
    GravitySample s;
    g.evaluate(p, s);
    EXPECT_NEAR(s.gradient.trace(), 0.0, 1e-10 * four_pi_g_rho);
  }
}

TEST(PolyhedronGravity, DerivativesMatchFiniteDifferencesAndHessianIsSymmetric) {
  const Mesh m = gravity_test::lumpy_body(16, 24, 250.0);
  const PolyhedronGravity g = model(m);
  const Eigen::Vector3d pts[] = {{400.0, -150.0, 120.0}, {30.0, 20.0, -10.0}, {-180.0, 260.0, 190.0}};
  for (const auto& p : pts) {
    GravitySample s, sp, sm;
    g.evaluate(p, s);
    const double h = 1e-2;
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d d = h * Eigen::Vector3d::Unit(i);
      g.evaluate(p + d, sp);
      g.evaluate(p - d, sm);
      EXPECT_NEAR((sp.potential - sm.potential) / (2 * h), s.acceleration(i), 1e-8 * s.acceleration.norm());
      EXPECT_LT(((sp.acceleration - sm.acceleration) / (2 * h) - s.gradient.col(i)).norm(),
                1e-7 * s.gradient.norm());
    }
    EXPECT_LT((s.gradient - s.gradient.transpose()).norm(), 1e-14 * s.gradient.norm());
  }
}

TEST(PolyhedronGravity, InvariantUnderRotatingAndTranslatingMeshAndPointTogether) {
  const Mesh m = gravity_test::lumpy_body(12, 18, 250.0);
  const PolyhedronGravity g = model(m);
  const Eigen::Matrix3d R =
      tubempc::math::rotation_matrix(tubempc::math::exp_map(Eigen::Vector3d(0.4, -1.1, 0.7)));
  const Eigen::Vector3d t(1234.5, -678.9, 4321.0);
  Mesh moved = m;
  for (Eigen::Index i = 0; i < m.v.rows(); ++i) moved.v.row(i) = (R * m.v.row(i).transpose() + t).transpose();
  const PolyhedronGravity gm = model(moved);
  for (const Eigen::Vector3d p :
       {Eigen::Vector3d(400.0, -150.0, 120.0), Eigen::Vector3d(20.0, 10.0, -30.0)}) {
    GravitySample s, q;
    g.evaluate(p, s);
    gm.evaluate(R * p + t, q);
    EXPECT_NEAR(q.potential, s.potential, 1e-12 * s.potential);
    EXPECT_LT((q.acceleration - R * s.acceleration).norm(), 1e-11 * s.acceleration.norm());
    EXPECT_LT((q.gradient - R * s.gradient * R.transpose()).norm(), 1e-10 * s.gradient.norm());
  }
}

TEST(PolyhedronGravity, SurfacePointsGiveFiniteDocumentedValues) {
  const Prism pr{-100.0, 140.0, -60.0, 90.0, -75.0, 55.0};
  const PolyhedronGravity g = model(box(pr.x0, pr.x1, pr.y0, pr.y1, pr.z0, pr.z1));
  const double g_rho = kGravitationalConstant * kRho;
  struct Case {
    Eigen::Vector3d p;
    double solid_angle;  // of the body seen from p
  };
  const Case cases[] = {{{140.0, 13.0, -21.0}, 2.0 * kPi},  // face x = x1
                        {{140.0, 90.0, 17.0}, kPi},         // edge x = x1, y = y1
                        {{140.0, 90.0, 55.0}, 0.5 * kPi}};  // vertex
  for (const auto& c : cases) {
    GravitySample s;
    g.evaluate(c.p, s);
    EXPECT_TRUE(std::isfinite(s.potential) && s.acceleration.allFinite() && s.gradient.allFinite());
    EXPECT_NEAR(g.laplacian(c.p), -g_rho * c.solid_angle, 1e-12 * g_rho);
    // U and a are continuous: their limits are the means of the closed form at p +- d (the closed
    // form itself is singular on the surface); the error of the mean is O(|d|^2 Hess) for U and
    // O(G rho |d|) for a at an edge or vertex.
    const Eigen::Vector3d d(1e-9, 1.3e-9, 0.7e-9);
    double Up = 0.0, Um = 0.0;
    Eigen::Vector3d ap, am;
    pr.eval(c.p + d, Up, ap);
    pr.eval(c.p - d, Um, am);
    EXPECT_NEAR(s.potential, 0.5 * (Up + Um), 1e-12 * Up);
    EXPECT_LT((s.acceleration - 0.5 * (ap + am)).norm(), 1e-9 * ap.norm());
  }
  // On a face interior the Hessian is the mean of the inside and outside limits.
  GravitySample on, in, out;
  const Eigen::Vector3d p(140.0, 13.0, -21.0);
  g.evaluate(p, on);
  g.evaluate(p - Eigen::Vector3d(1e-7, 0, 0), in);
  g.evaluate(p + Eigen::Vector3d(1e-7, 0, 0), out);
  EXPECT_NEAR((in.gradient - out.gradient)(0, 0), -4.0 * kPi * g_rho, 1e-6 * g_rho);
  EXPECT_LT((on.gradient - 0.5 * (in.gradient + out.gradient)).norm(), 1e-5 * g_rho);
}

TEST(PolyhedronGravity, BatchOnManyThreadsEqualsSingleThreadExactly) {
  const Mesh m = gravity_test::lumpy_body(12, 18, 250.0);
  const PolyhedronGravity g = model(m);
  const int n = 37;
  tubempc::gravity::Points r = tubempc::gravity::Points::Random(n, 3) * 600.0;
  Eigen::VectorXd u1(n), u3(n), l1(n), l3(n);
  tubempc::gravity::Points a1(n, 3), a3(n, 3);
  tubempc::gravity::Gradients h1(n, 9), h3(n, 9);
  g.evaluate_batch(r, u1, a1, h1, 1);
  g.evaluate_batch(r, u3, a3, h3, 3);
  EXPECT_TRUE((u1.array() == u3.array()).all());
  EXPECT_TRUE((a1.array() == a3.array()).all());
  EXPECT_TRUE((h1.array() == h3.array()).all());
  g.laplacian_batch(r, l1, 1);
  g.laplacian_batch(r, l3, 0);
  EXPECT_TRUE((l1.array() == l3.array()).all());
  for (int i = 0; i < n; ++i) {
    GravitySample s;
    g.evaluate(r.row(i).transpose(), s);
    EXPECT_EQ(s.potential, u1(i));
    EXPECT_EQ(s.gradient(1, 2), h1(i, 5));
  }
  Eigen::VectorXd wrong(n - 1);
  EXPECT_THROW(g.evaluate_batch(r, wrong, a1, h1, 1), std::invalid_argument);
  EXPECT_THROW(model(m, -1.0), std::invalid_argument);
}

TEST(PolyhedronGravity, AccelerationAloneEqualsEvaluateToTheBit) {
  // The truth propagation's acceleration-only path sums the same terms in the same order.
  const Mesh m = gravity_test::lumpy_body(12, 18, 250.0);
  const PolyhedronGravity g = model(m);
  tubempc::gravity::Points r = tubempc::gravity::Points::Random(40, 3) * 600.0;
  r.row(0) << 0.0, 0.0, 0.0;                                      // inside
  r.row(1) << 1e3 * tubempc::gravity::kFarFieldFactor, 0.0, 0.0;  // far field
  for (Eigen::Index i = 0; i < r.rows(); ++i) {
    GravitySample s;
    g.evaluate(r.row(i).transpose(), s);
    const Eigen::Vector3d a = g.acceleration(r.row(i).transpose());
    EXPECT_TRUE((a.array() == s.acceleration.array()).all()) << "point " << i;
  }
  EXPECT_THROW(g.acceleration(Eigen::Vector3d(std::nan(""), 0.0, 0.0)), std::domain_error);
}

TEST(PolyhedronGravity, BennuRadarModelMassAndSurfaceGravity) {
  const auto bennu = gravity_test::bennu_radar();
  if (!bennu) GTEST_SKIP() << "../shared/data/101955bennu.tab not present";
  const PolyhedronGravity g = model(*bennu);
  EXPECT_NEAR(g.shape().volume(), 6.2266e7, 1e-4 * 6.2266e7);  // docs/model.md, "Gravity"
  EXPECT_NEAR(g.mass(), 7.845e10, 1e-3 * 7.845e10);
  EXPECT_NEAR(g.shape().mean_radius(), 245.9, 0.1);
  GravitySample s;
  g.evaluate(Eigen::Vector3d(0.0, 0.0, 246.5), s);  // the paper's landing site
  EXPECT_LT(s.acceleration.z(), 0.0);
  EXPECT_GT(s.potential, g.gm() / 246.5 * 0.9);
}
