#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "gravity_test_meshes.hpp"
#include "tubempc/gravity/composite_gravity.hpp"

using gravity_test::box;
using gravity_test::kPi;
using gravity_test::Mesh;
using tubempc::gravity::CompositeGravity;
using tubempc::gravity::GravityPart;
using tubempc::gravity::GravitySample;
using tubempc::gravity::kGravitationalConstant;
using tubempc::gravity::PolyhedronGravity;
using tubempc::gravity::Shape;

namespace {

// A lumpy 250 m body (1260 kg/m^3) with a denser core (a 0.5 scaled copy, +150 kg/m^3) and a lighter
// lobe (a 40 m box offset along x, -200 kg/m^3).
struct Body {
  Mesh body = gravity_test::lumpy_body(16, 24, 250.0);
  Mesh core = scaled(body, 0.5);
  Mesh lobe = box(-20.0, 20.0, -20.0, 20.0, -20.0, 20.0);
  Eigen::Vector3d lobe_offset{120.0, 30.0, -10.0};
  double rho = 1260.0, d_core = 150.0, d_lobe = -200.0;

  static Mesh scaled(const Mesh& m, double s) {
    Mesh out = m;
    out.v *= s;
    return out;
  }
  CompositeGravity composite() const {
    return CompositeGravity({CompositeGravity::part(Shape(body.v, body.f), rho, Eigen::Vector3d::Zero()),
                             CompositeGravity::part(Shape(core.v, core.f), d_core, Eigen::Vector3d::Zero()),
                             CompositeGravity::part(Shape(lobe.v, lobe.f), d_lobe, lobe_offset)});
  }
};

}  // namespace

TEST(CompositeGravity, EqualsTheSumOfItsPartsEvaluatedApart) {
  const Body b;
  const CompositeGravity g = b.composite();
  // Each part on its own, at the magnitude of its density, with its sign.
  const PolyhedronGravity body(Shape(b.body.v, b.body.f), b.rho);
  const PolyhedronGravity core(Shape(b.core.v, b.core.f), b.d_core);
  const PolyhedronGravity lobe(Shape(b.lobe.v, b.lobe.f), -b.d_lobe);
  for (const Eigen::Vector3d p : {Eigen::Vector3d(600.0, -20.0, 5.0), Eigen::Vector3d(10.0, -20.0, 5.0),
                                  Eigen::Vector3d(125.0, 25.0, -5.0), Eigen::Vector3d(-100.0, 350.0, 300.0),
                                  Eigen::Vector3d(3e4, -2e4, 1e4)}) {
    GravitySample s, sb, sc, sl;
    g.evaluate(p, s);
    body.evaluate(p, sb);
    core.evaluate(p, sc);
    lobe.evaluate(p - b.lobe_offset, sl);
    const double U = sb.potential + sc.potential - sl.potential;
    const Eigen::Vector3d a = sb.acceleration + sc.acceleration - sl.acceleration;
    const Eigen::Matrix3d G = sb.gradient + sc.gradient - sl.gradient;
    EXPECT_NEAR(s.potential, U, 1e-13 * std::abs(sb.potential));
    EXPECT_LE((s.acceleration - a).norm(), 1e-13 * sb.acceleration.norm());
    EXPECT_LE((s.gradient - G).norm(), 1e-12 * sb.gradient.norm());
    EXPECT_EQ(g.acceleration(p), s.acceleration);  // acceleration alone: the same sums
  }
}

TEST(CompositeGravity, LaplacianInsideEachRegionIsMinusFourPiGTimesItsDensity) {
  const Body b;
  const CompositeGravity g = b.composite();
  const double four_pi_g = 4.0 * kPi * kGravitationalConstant;
  const Eigen::Vector3d in_core(10.0, -20.0, 5.0), in_body(-150.0, 20.0, 30.0), in_lobe(125.0, 25.0, -5.0),
      outside(600.0, -20.0, 5.0);
  EXPECT_NEAR(g.laplacian(in_core), -four_pi_g * (b.rho + b.d_core), 1e-11 * four_pi_g * b.rho);
  EXPECT_NEAR(g.laplacian(in_body), -four_pi_g * b.rho, 1e-11 * four_pi_g * b.rho);
  EXPECT_NEAR(g.laplacian(in_lobe), -four_pi_g * (b.rho + b.d_lobe), 1e-11 * four_pi_g * b.rho);
  EXPECT_NEAR(g.laplacian(outside), 0.0, 1e-11 * four_pi_g * b.rho);
  GravitySample s;
  g.evaluate(in_core, s);
  EXPECT_NEAR(s.gradient.trace(), -four_pi_g * (b.rho + b.d_core), 1e-9 * four_pi_g * b.rho);
}

TEST(CompositeGravity, MassCentreOfMassAndInertiaOfBoxesInClosedForm) {
  // A 4 m cube of 1000 kg/m^3, a 2 m cube core of +500 kg/m^3 and a unit cube [0, 1]^3 placed 0.5 m along x
  // (so its centre is at (1, 0.5, 0.5)) of -200 kg/m^3.
  const Mesh base = box(-2, 2, -2, 2, -2, 2), core = box(-1, 1, -1, 1, -1, 1), lobe = box(0, 1, 0, 1, 0, 1);
  const CompositeGravity g(
      {CompositeGravity::part(Shape(base.v, base.f), 1000.0, Eigen::Vector3d::Zero()),
       CompositeGravity::part(Shape(core.v, core.f), 500.0, Eigen::Vector3d::Zero()),
       CompositeGravity::part(Shape(lobe.v, lobe.f), -200.0, Eigen::Vector3d(0.5, 0, 0))});
  const double M = 64000.0 + 4000.0 - 200.0;
  EXPECT_NEAR(g.mass(), M, 1e-9 * M);
  EXPECT_NEAR(g.gm(), kGravitationalConstant * M, 1e-9 * kGravitationalConstant * M);
  const Eigen::Vector3d c_lobe(1.0, 0.5, 0.5), com = -200.0 * c_lobe / M;
  EXPECT_LE((g.center_of_mass() - com).norm(), 1e-12);
  // Inertia of a cube of side a and mass m about its centre: m a^2 / 6 I; moved to the centre of mass.
  auto moved = [&](double m, double a, const Eigen::Vector3d& c) {
    const Eigen::Vector3d d = c - com;
    return Eigen::Matrix3d(m * a * a / 6.0 * Eigen::Matrix3d::Identity() +
                           m * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose()));
  };
  const Eigen::Matrix3d I = moved(64000.0, 4.0, Eigen::Vector3d::Zero()) +
                            moved(4000.0, 2.0, Eigen::Vector3d::Zero()) + moved(-200.0, 1.0, c_lobe);
  EXPECT_LE((g.inertia() - I).norm(), 1e-9 * I.norm());
  // Far away the field is the point mass at the centre of mass.
  const Eigen::Vector3d far(3e3, -1e3, 2e3);
  const Eigen::Vector3d a_pm = -g.gm() * (far - com) / std::pow((far - com).norm(), 3);
  EXPECT_LE((g.acceleration(far) - a_pm).norm(), 1e-6 * a_pm.norm());
}

TEST(CompositeGravity, TranslatedMovesTheFieldAndTheCentreOfMass) {
  const Body b;
  const CompositeGravity g = b.composite();
  const Eigen::Vector3d d(-1.5, 0.7, 0.2);
  const CompositeGravity moved = g.translated(d);
  EXPECT_LE((moved.center_of_mass() - (g.center_of_mass() + d)).norm(), 1e-12);
  EXPECT_EQ(moved.mass(), g.mass());
  EXPECT_LE((moved.inertia() - g.inertia()).norm(), 1e-12 * g.inertia().norm());
  for (const Eigen::Vector3d p : {Eigen::Vector3d(600.0, -20.0, 5.0), Eigen::Vector3d(10.0, -20.0, 5.0)}) {
    EXPECT_LE((moved.acceleration(p + d) - g.acceleration(p)).norm(), 1e-12 * g.acceleration(p).norm());
  }
  EXPECT_EQ(moved.parts()[0].polyhedron, g.parts()[0].polyhedron);  // shared, not rebuilt
}

TEST(CompositeGravity, RejectsBadParts) {
  const Mesh m = box(-1, 1, -1, 1, -1, 1);
  EXPECT_THROW(CompositeGravity::part(Shape(m.v, m.f), 0.0, Eigen::Vector3d::Zero()), std::invalid_argument);
  EXPECT_THROW(CompositeGravity::part(Shape(m.v, m.f), 1.0, Eigen::Vector3d(NAN, 0, 0)),
               std::invalid_argument);
  EXPECT_THROW(CompositeGravity(std::vector<GravityPart>{}), std::invalid_argument);
  EXPECT_THROW(CompositeGravity({GravityPart{}}), std::invalid_argument);  // null polyhedron
  // A deficit larger than the body: no positive mass.
  EXPECT_THROW(CompositeGravity({CompositeGravity::part(Shape(m.v, m.f), 100.0, Eigen::Vector3d::Zero()),
                                 CompositeGravity::part(Shape(m.v, m.f), -200.0, Eigen::Vector3d::Zero())}),
               std::invalid_argument);
  const CompositeGravity g({CompositeGravity::part(Shape(m.v, m.f), 100.0, Eigen::Vector3d::Zero())});
  GravitySample s;
  EXPECT_THROW(g.evaluate(Eigen::Vector3d(NAN, 0, 0), s), std::domain_error);
}
