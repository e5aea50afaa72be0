#include "tubempc/dynamics/physical_environment.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace tubempc::dynamics {
namespace {

std::string num(double v) {
  std::ostringstream os;
  os.precision(17);
  os << v;
  return os.str();
}

void require(bool ok, const std::string& field, const std::string& rule, double value) {
  if (!ok) throw std::invalid_argument(field + ": must be " + rule + ", got " + num(value));
}

}  // namespace

void FlatPlate::validate() const {
  require(std::isfinite(area) && area > 0.0, "FlatPlate.area", "finite and > 0 (m^2)", area);
  const double n = normal_B.norm();
  require(std::isfinite(n) && n > 1e-12, "FlatPlate.normal_B", "finite and non-zero (norm)", n);
  if (!center_B.allFinite()) throw std::invalid_argument("FlatPlate.center_B: must be finite");
  require(std::isfinite(specular) && specular >= 0.0 && specular <= 1.0, "FlatPlate.specular", "in [0, 1]",
          specular);
  require(std::isfinite(diffuse) && diffuse >= 0.0 && specular + diffuse <= 1.0, "FlatPlate.diffuse",
          "in [0, 1 - specular]", diffuse);
}

void PhysicalSettings::validate() const {
  require(std::isfinite(mass) && mass > 0.0, "PhysicalSettings.mass", "finite and > 0 (kg)", mass);
  require(std::isfinite(mass_error) && mass_error > -0.5 && mass_error < 0.5, "PhysicalSettings.mass_error",
          "in (-0.5, 0.5)", mass_error);
  for (int i = 0; i < 3; ++i) {
    require(std::isfinite(inertia_scale(i)) && inertia_scale(i) > 0.5 && inertia_scale(i) < 2.0,
            "PhysicalSettings.inertia_scale[" + std::to_string(i) + "]", "in (0.5, 2)", inertia_scale(i));
  }
  if (!inertia_products.allFinite())
    throw std::invalid_argument("PhysicalSettings.inertia_products: must be finite");
  require(std::isfinite(solar_pressure) && solar_pressure >= 0.0, "PhysicalSettings.solar_pressure",
          "finite and >= 0 (N/m^2)", solar_pressure);
  require(std::isfinite(shadow_radius) && shadow_radius >= 0.0, "PhysicalSettings.shadow_radius",
          "finite and >= 0 (m)", shadow_radius);
  for (std::size_t i = 0; i < plates.size(); ++i) {
    try {
      plates[i].validate();
    } catch (const std::invalid_argument& e) {
      std::string what = e.what();
      what.replace(0, std::string("FlatPlate").size(), "PhysicalSettings.plates[" + std::to_string(i) + "]");
      throw std::invalid_argument(what);
    }
  }
}

Eigen::Matrix3d PhysicalSettings::true_inertia(const Eigen::Matrix3d& inertia_model_B) const {
  Eigen::Matrix3d J = inertia_model_B;
  for (int i = 0; i < 3; ++i) J(i, i) *= inertia_scale(i);
  J(0, 1) += inertia_products(0);
  J(1, 0) += inertia_products(0);
  J(0, 2) += inertia_products(1);
  J(2, 0) += inertia_products(1);
  J(1, 2) += inertia_products(2);
  J(2, 1) += inertia_products(2);
  if (!J.allFinite())
    throw std::invalid_argument("PhysicalSettings.inertia_products: the truth's inertia is not finite");
  const Eigen::Vector3d l = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(J).eigenvalues();  // ascending
  require(l(0) > 0.0, "PhysicalSettings.inertia_products",
          "such that the truth's inertia is positive definite (smallest principal moment, kg m^2)", l(0));
  require(
      l(2) <= l(0) + l(1), "PhysicalSettings.inertia_scale",
      "such that the truth's principal moments obey the triangle inequality (largest minus the sum of the "
      "others, kg m^2)",
      l(2) - l(0) - l(1));
  return J;
}

void flat_plate_wrench(const FlatPlate& plate, const Eigen::Vector3d& sun_B, double pressure,
                       Eigen::Vector3d& force_B, Eigen::Vector3d& torque_B) {
  const Eigen::Vector3d n = plate.normal_B.normalized();
  const double c = n.dot(sun_B);
  if (!(c > 0.0)) {
    force_B.setZero();
    torque_B.setZero();
    return;
  }
  force_B = -pressure * plate.area * c *
            ((1.0 - plate.specular) * sun_B + 2.0 * (plate.specular * c + plate.diffuse / 3.0) * n);
  torque_B = plate.center_B.cross(force_B);
}

Eigen::Vector3d gravity_gradient_torque(double gm, const Eigen::Vector3d& r_B,
                                        const Eigen::Matrix3d& inertia_B) {
  const double r2 = r_B.squaredNorm();
  const double r = std::sqrt(r2);
  return (3.0 * gm / (r2 * r2 * r)) * r_B.cross(inertia_B * r_B);
}

PhysicalEnvironment::PhysicalEnvironment(const PhysicalSettings& settings,
                                         const Eigen::Matrix3d& inertia_model_B, double gm,
                                         double orbit_radius, const Eigen::Matrix3d& thrust_error_B,
                                         const Eigen::Matrix3d& torque_error_B)
    : settings_(settings), gm_(gm), thrust_error_(thrust_error_B), torque_error_(torque_error_B) {
  settings_.validate();
  require(std::isfinite(gm) && gm > 0.0, "PhysicalEnvironment: gm", "finite and > 0 (m^3/s^2)", gm);
  require(std::isfinite(orbit_radius) && orbit_radius > 0.0, "PhysicalEnvironment: orbit_radius",
          "finite and > 0 (m)", orbit_radius);
  if (!thrust_error_.allFinite() || !torque_error_.allFinite()) {
    throw std::invalid_argument("PhysicalEnvironment: the thrust and torque error matrices must be finite");
  }
  for (FlatPlate& p : settings_.plates) p.normal_B.normalize();
  mass_true_ = settings_.true_mass();
  inertia_ = settings_.true_inertia(inertia_model_B);
  inertia_inv_ = inertia_.inverse();
  const double au_r = kAstronomicalUnit / orbit_radius;
  pressure_ = settings_.solar_pressure * au_r * au_r;
}

bool PhysicalEnvironment::in_shadow(const Eigen::Vector3d& r_L) const {
  const double rs = settings_.shadow_radius;
  return r_L.x() > 0.0 && r_L.y() * r_L.y() + r_L.z() * r_L.z() < rs * rs;
}

InputVector PhysicalEnvironment::deliver(const InputVector& u, const math::Quaternion& q_BL) const {
  const Eigen::Matrix3d C_LB = math::rotation_matrix(q_BL);
  InputVector out;
  out.head<3>() = (settings_.mass / mass_true_) * (C_LB * (thrust_error_ * (C_LB.transpose() * u.head<3>())));
  out.tail<3>() = torque_error_ * u.tail<3>();
  return out;
}

void PhysicalEnvironment::srp_wrench(const Eigen::Vector3d& r_L, const Eigen::Matrix3d& C_BL,
                                     Eigen::Vector3d& force_B, Eigen::Vector3d& torque_B) const {
  force_B.setZero();
  torque_B.setZero();
  if (!settings_.srp || pressure_ == 0.0 || in_shadow(r_L)) return;
  const Eigen::Vector3d sun_B = -C_BL.col(0);  // C_BL (-x_L)
  Eigen::Vector3d f, t;
  for (const FlatPlate& p : settings_.plates) {
    flat_plate_wrench(p, sun_B, pressure_, f, t);
    force_B += f;
    torque_B += t;
  }
}

Eigen::Vector3d PhysicalEnvironment::srp_acceleration_L(const TruthState& s) const {
  const Eigen::Matrix3d C_LB = math::rotation_matrix(s.segment<4>(6));
  Eigen::Vector3d F_B, T_B;
  srp_wrench(s.head<3>(), C_LB.transpose(), F_B, T_B);
  return C_LB * F_B / mass_true_;
}

Disturbance6 PhysicalEnvironment::operator()(double /*t*/, const TruthState& s) const {
  // R(q) of a non-unit q (mid-stage) is normalised inside rotation_matrix.
  const Eigen::Matrix3d C_LB = math::rotation_matrix(s.segment<4>(6));
  const Eigen::Matrix3d C_BL = C_LB.transpose();
  const Eigen::Vector3d r_L = s.head<3>();
  Eigen::Vector3d F_B, T_B;
  srp_wrench(r_L, C_BL, F_B, T_B);
  if (settings_.gravity_gradient) T_B += gravity_gradient_torque(gm_, C_BL * r_L, inertia_);
  Disturbance6 out;
  out.head<3>() = C_LB * F_B / mass_true_;
  out.tail<3>() = inertia_inv_ * T_B;
  return out;
}

Disturbance PhysicalEnvironment::disturbance() const {
  Disturbance d;
  d.function = [this](double t, const TruthState& s) { return (*this)(t, s); };
  return d;
}

PropagationResult propagate(const ProximityModel& truth, const PhysicalEnvironment& environment, double t0,
                            const TruthState& state, const InputVector& u_delivered, double dt,
                            const PropagatorSettings& settings, gravity::ExpansionHold* gravity_hold) {
  const Eigen::Matrix3d& J = truth.params().inertia_B;
  const double mismatch = (J - environment.inertia_B()).cwiseAbs().maxCoeff();
  if (!(mismatch <= 1e-12 * environment.inertia_B().cwiseAbs().maxCoeff())) {
    throw std::invalid_argument(
        "propagate: the truth model's inertia_B must be the physical environment's inertia_B (largest "
        "difference " +
        num(mismatch) + " kg m^2)");
  }
  if (truth.params().srp_enabled) {
    throw std::invalid_argument(
        "propagate: the truth model's cannonball SRP must be off (ModelParams.srp_enabled = false) in a "
        "physical "
        "environment, whose flat plates give the SRP");
  }
  return propagate(truth, t0, state, u_delivered, dt, environment.disturbance(), settings, gravity_hold);
}

}  // namespace tubempc::dynamics
