// Minimal program embedding tubempc::core through find_package(tubempc): builds the 6-DOF proximity
// model around a point mass and evaluates its dynamics once.
#include <cstdio>
#include <memory>

#include "tubempc/core/build_info.hpp"
#include "tubempc/dynamics/proximity_model.hpp"
#include "tubempc/gravity/gravity_model.hpp"

int main() {
  auto gravity = std::make_shared<tubempc::gravity::PointMassGravity>(5.2);  // GM (m^3/s^2)
  const tubempc::dynamics::ProximityModel model(gravity);
  tubempc::dynamics::StateVector x = tubempc::dynamics::StateVector::Zero();
  x.head<3>() << 959.2404, 162.4966, 752.7547;  // r_L (m), paper Table 2
  const tubempc::dynamics::StateVector xdot = model.f(0.0, x, tubempc::dynamics::InputVector::Zero());
  std::printf("tubempc %s: n = %.4e rad/s, |a_L| at r0 = %.4e m/s^2\n",
              tubempc::core::build_info().version.c_str(), model.params().mean_motion(),
              xdot.segment<3>(3).norm());
  return 0;
}
