// Gravity fields and helpers shared by the dynamics tests.
#pragma once

#include <Eigen/Dense>
#include <array>
#include <memory>

#include "tubempc/dynamics/proximity_model.hpp"
#include "tubempc/gravity/gravity_model.hpp"

namespace tubempc::dynamics::testing {

// Three point masses off the origin of A: a non-spherical field whose gradient is not rotation
// invariant, so the A-frame rotation and the gravity gradient both enter the Jacobians.
class ClusterGravity final : public gravity::GravityModel {
 public:
  void evaluate(const Eigen::Vector3d& r_A, gravity::GravitySample& out) const override {
    out = gravity::GravitySample{};
    for (std::size_t i = 0; i < gm_.size(); ++i) {
      const Eigen::Vector3d d = r_A - pos_[i];
      const double r2 = d.squaredNorm();
      const double r = std::sqrt(r2);
      const double k = gm_[i] / (r2 * r);
      out.potential += gm_[i] / r;
      out.acceleration -= k * d;
      out.gradient += k * (3.0 * d * d.transpose() / r2 - Eigen::Matrix3d::Identity());
    }
  }
  double gm() const override { return gm_[0] + gm_[1] + gm_[2]; }

 private:
  std::array<double, 3> gm_{2.0, 1.5, 1.7};
  std::array<Eigen::Vector3d, 3> pos_{Eigen::Vector3d(80.0, 0.0, 10.0), Eigen::Vector3d(-60.0, 40.0, -20.0),
                                      Eigen::Vector3d(0.0, -50.0, 30.0)};
};

inline std::shared_ptr<const gravity::GravityModel> cluster() { return std::make_shared<ClusterGravity>(); }
inline std::shared_ptr<const gravity::GravityModel> bennu_point_mass() {
  return std::make_shared<gravity::PointMassGravity>(5.236);
}

// Parameters with fast frame rates (n ~ 0.03 rad/s, spin 0.05 rad/s) so the Coriolis, tidal and
// w_LI terms are large enough for finite differences to check them.
inline ModelParams fast_frames(Kinematics k) {
  ModelParams p;
  p.orbit_radius = 5e7;
  p.beta_srp = 1e12;
  p.spin_rate = 0.05;
  p.spin_angle0 = 0.3;
  p.kinematics = k;
  p.inertia_B << 2750.0, 30.0, -12.0, 30.0, 2600.0, 25.0, -12.0, 25.0, 2030.0;
  return p;
}

}  // namespace tubempc::dynamics::testing
