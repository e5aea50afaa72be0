// Actuator sets of the tests: a 12-thruster cluster that produces every force and torque, and a pyramid of
// four wheels.
#pragma once

#include <cmath>
#include <vector>

#include "tubempc/actuators/reaction_wheels.hpp"
#include "tubempc/actuators/thrusters.hpp"

namespace actuator_test {

using namespace tubempc::actuators;

// For each axis k and sign s: two thrusters pushing along s e_k from the opposite face (-s e_k), offset by
// +-0.5 m along e_(k+1); the pair's torques are -+0.5 s e_(k+2) per newton.
inline std::vector<ThrusterSpec> cube_specs(double f_max = 4.5, double t_min = 0.02) {
  std::vector<ThrusterSpec> specs;
  for (int k = 0; k < 3; ++k)
    for (double s : {1.0, -1.0})
      for (double o : {0.5, -0.5}) {
        ThrusterSpec t;
        t.direction_B = s * Eigen::Vector3d::Unit(k);
        t.position_B = -s * Eigen::Vector3d::Unit(k) + o * Eigen::Vector3d::Unit((k + 1) % 3);
        t.max_thrust = f_max;
        t.min_on_time = t_min;
        t.isp = 226.1;
        specs.push_back(t);
      }
  return specs;
}

inline ThrusterCluster cube_cluster(double f_max = 4.5, double t_min = 0.02) {
  return ThrusterCluster(cube_specs(f_max, t_min));
}

inline ReactionWheels pyramid_wheels(double u_max = 0.2, double h_max = 50.0,
                                     MomentumDumpSettings dump = {}) {
  const double b = std::atan(std::sqrt(2.0));  // 54.7 deg from z
  std::vector<ReactionWheelSpec> w;
  for (int i = 0; i < 4; ++i) {
    const double a = M_PI / 2 * i;
    ReactionWheelSpec s;
    s.axis_B = Eigen::Vector3d(std::sin(b) * std::cos(a), std::sin(b) * std::sin(a), std::cos(b));
    s.max_torque = u_max;
    s.max_momentum = h_max;
    w.push_back(s);
  }
  return ReactionWheels(w, dump);
}

}  // namespace actuator_test
