/// @file physical_environment.hpp
/// The physical disturbance environment of the simulated plant (docs/model.md, "Physical environment";
/// `disturbance.model = "physical"`): what the truth feels beyond the controller's model, evaluated at
/// every derivative evaluation of the truth propagation, with no additive draw:
///
/// - solar radiation pressure on a faceted spacecraft (flat plates fixed in B, lit when n . s > 0):
///
///       F_i = -P A_i cos(theta_i) [(1 - rho_s,i) s + 2 (rho_s,i cos(theta_i) + rho_d,i / 3) n_i]    (N, in B)
///       T   = sum_i c_i x F_i                                                                    (N m, in B)
///       P   = solar_pressure (1 AU / R)^2,   cos(theta_i) = n_i . s
///
///   with s = C_BL (-x_L) the unit vector towards the Sun (the Sun lies along -x_L seen from the
///   asteroid; its parallax over the spacecraft's distance from the asteroid, below 1e-8 rad, is
///   neglected), R the asteroid's heliocentric distance (ModelParams::orbit_radius, the R of beta_SRP),
///   c_i the plate's centre of pressure relative to the centre of mass. No plate shadows another. The
///   asteroid's shadow is a cylinder of radius shadow_radius about +x_L behind the body (a Sun at
///   infinity: the umbra of a sphere of that radius); inside it there is no SRP;
/// - the gravity-gradient torque of a point mass (as Basilisk's GravityGradientEffector):
///
///       T_gg = 3 mu / |r|^5 (r_B x J r_B),     r_B = C_BL r_L                                   (N m, in B)
///
///   with mu = G M of the truth body and J the truth's inertia;
/// - the truth's mass and inertia: m_true = (1 + mass_error) mass; J_true = J with its diagonal scaled
///   by inertia_scale and inertia_products added off the diagonal;
/// - actuator errors: the controller's acceleration command u_p (m/s^2, in L) is a force m u_p
///   (mass: the controller's value), which thrusters fixed in B deliver with the error matrix E_F
///   (scale and misalignment), so that the truth's acceleration is C_LB E_F C_BL u_p m / m_true; the
///   torque T is delivered as E_T T. The attitude of the period's start maps the command, which is held
///   constant in L over the period, as the actuators' delivered input is (docs/model.md M37).
///
/// The forces enter the truth's derivative (ProximityModel::truth_derivative) as the disturbance
/// [F_L / m_true (m/s^2, in L); J_true^-1 (T_srp + T_gg) (rad/s^2, in B)]; the truth model's inertia
/// must be J_true and its cannonball SRP off (propagate() checks both).
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "tubempc/core/fields.hpp"
#include "tubempc/dynamics/propagator.hpp"
#include "tubempc/dynamics/proximity_model.hpp"
#include "tubempc/math/so3.hpp"

namespace tubempc::dynamics {

/// The astronomical unit (m), IAU 2012 Resolution B2 (exact).
inline constexpr double kAstronomicalUnit = 1.495978707e11;

/// One flat plate of the spacecraft's surface, fixed in B (one side: a thin panel lit from both sides
/// is two plates with opposite normals).
struct FlatPlate {
  double area{1.0};                                    ///< area A (m^2), > 0
  Eigen::Vector3d normal_B{Eigen::Vector3d::UnitX()};  ///< outward normal n in B (normalised on use)
  Eigen::Vector3d center_B{
      Eigen::Vector3d::Zero()};  ///< centre of pressure c relative to the centre of mass, in B (m)
  double specular{0.0};          ///< specular reflection coefficient rho_s, in [0, 1]
  double diffuse{0.0};           ///< diffuse reflection coefficient rho_d, in [0, 1 - rho_s]

  /// Checks the ranges given above.
  /// @throws std::invalid_argument naming the first bad field.
  void validate() const;

  /// Calls visit(core::FieldInfo, member pointer) once per field (the Python attributes).
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit);
};

/// Settings of the physical environment; each field is the `[physical]` field of the same name
/// (`tubempc.config`; the plates are its `plate_*` arrays, one entry per plate).
struct PhysicalSettings {
  double mass{2110.0};     ///< the spacecraft's mass as the controller knows it (kg), > 0
  double mass_error{0.0};  ///< the truth's mass is (1 + mass_error) mass; in (-0.5, 0.5)
  /// The truth's principal moments are these multiples of the controller's J's diagonal, each in (0.5, 2).
  Eigen::Vector3d inertia_scale{Eigen::Vector3d::Ones()};
  /// Products of inertia [J_xy, J_xz, J_yz] added to the truth's off-diagonal (kg m^2).
  Eigen::Vector3d inertia_products{Eigen::Vector3d::Zero()};
  bool srp{true};                  ///< the flat-plate SRP force and torque
  double solar_pressure{4.56e-6};  ///< solar radiation pressure at 1 AU (N/m^2), >= 0
  double shadow_radius{0.0};       ///< radius of the asteroid's cylindrical shadow (m), >= 0 (0: none)
  bool gravity_gradient{true};     ///< the gravity-gradient torque
  std::vector<FlatPlate> plates;   ///< the spacecraft's surface (each validated)

  /// Checks the ranges given above and every plate.
  /// @throws std::invalid_argument naming the first bad field (`plates[i].area`, ...).
  void validate() const;

  /// The truth's mass.
  /// @return (1 + mass_error) mass (kg).
  double true_mass() const { return (1.0 + mass_error) * mass; }

  /// The truth's inertia from the controller's (see the file comment).
  /// @param inertia_model_B the controller's inertia in B (kg m^2), symmetric positive definite.
  /// @return J_true (kg m^2): symmetric, positive definite, its principal moments obeying the triangle
  ///         inequality.
  /// @throws std::invalid_argument (naming inertia_products or inertia_scale) when J_true is not an
  ///         inertia tensor.
  Eigen::Matrix3d true_inertia(const Eigen::Matrix3d& inertia_model_B) const;

  /// Calls visit(core::FieldInfo, member pointer) once per scalar or vector field (not `plates`), in
  /// the order of the `[physical]` section (the Python attributes).
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit);
};

/// Force and torque of one flat plate (the standard flat-plate model; see the file comment).
/// @param plate    the plate (its normal normalised here).
/// @param sun_B    unit vector from the spacecraft towards the Sun, in B.
/// @param pressure solar radiation pressure at the spacecraft P (N/m^2).
/// @param force_B  receives F (N, in B); zero when the plate is not lit (n . s <= 0).
/// @param torque_B receives c x F (N m, in B).
void flat_plate_wrench(const FlatPlate& plate, const Eigen::Vector3d& sun_B, double pressure,
                       Eigen::Vector3d& force_B, Eigen::Vector3d& torque_B);

/// Gravity-gradient torque of a point mass on a rigid body.
/// @param gm        gravitational parameter mu of the attracting body (m^3/s^2).
/// @param r_B       position of the body's centre of mass relative to the attracting point, in B (m), non-zero.
/// @param inertia_B the body's inertia about its centre of mass, in B (kg m^2).
/// @return 3 mu / |r|^5 (r_B x J r_B) (N m, in B).
Eigen::Vector3d gravity_gradient_torque(double gm, const Eigen::Vector3d& r_B,
                                        const Eigen::Matrix3d& inertia_B);

/// The physical environment of one run (see the file comment). Immutable after construction; the
/// evaluations neither allocate nor lock.
class PhysicalEnvironment {
 public:
  /// @param settings        the `[physical]` settings, validated here.
  /// @param inertia_model_B the controller's inertia J in B (kg m^2).
  /// @param gm              G M of the truth body (m^3/s^2), finite and > 0 (the gravity gradient's mu).
  /// @param orbit_radius    the asteroid's heliocentric distance R (m), finite and > 0.
  /// @param thrust_error_B  E_F, the delivered force per commanded force in B (scale and misalignment).
  /// @param torque_error_B  E_T, the delivered torque per commanded torque in B.
  /// @throws std::invalid_argument for invalid settings, a bad gm, R or non-finite error matrices.
  PhysicalEnvironment(const PhysicalSettings& settings, const Eigen::Matrix3d& inertia_model_B, double gm,
                      double orbit_radius,
                      const Eigen::Matrix3d& thrust_error_B = Eigen::Matrix3d::Identity(),
                      const Eigen::Matrix3d& torque_error_B = Eigen::Matrix3d::Identity());

  /// @return the settings, as validated.
  const PhysicalSettings& settings() const { return settings_; }
  /// @return the truth's mass m_true (kg).
  double true_mass() const { return mass_true_; }
  /// @return the truth's inertia J_true in B (kg m^2): the truth model's ModelParams::inertia_B.
  const Eigen::Matrix3d& inertia_B() const { return inertia_; }
  /// @return G M of the truth body (m^3/s^2).
  double gm() const { return gm_; }
  /// @return the solar radiation pressure at the asteroid P = solar_pressure (1 AU / R)^2 (N/m^2).
  double pressure() const { return pressure_; }
  /// @return E_F, the thrust error matrix in B.
  const Eigen::Matrix3d& thrust_error_B() const { return thrust_error_; }
  /// @return E_T, the torque error matrix in B.
  const Eigen::Matrix3d& torque_error_B() const { return torque_error_; }

  /// Whether a position lies in the asteroid's cylindrical shadow.
  /// @param r_L position in L (m).
  /// @return true when x_L > 0 and y_L^2 + z_L^2 < shadow_radius^2.
  bool in_shadow(const Eigen::Vector3d& r_L) const;

  /// The input the truth receives for a command (see the file comment).
  /// @param u    the controller's command [u_p (m/s^2, in L); T (N m, in B)].
  /// @param q_BL the truth's attitude at the period's start ([x, y, z, w], normalised here).
  /// @return [C_LB E_F C_BL u_p m / m_true (m/s^2, in L); E_T T (N m, in B)].
  InputVector deliver(const InputVector& u, const math::Quaternion& q_BL) const;

  /// The flat-plate SRP force and torque at a state (zero in the shadow or with srp off).
  /// @param r_L  position in L (m).
  /// @param C_BL rotation from L to B.
  /// @param force_B  receives the total force (N, in B).
  /// @param torque_B receives the total torque about the centre of mass (N m, in B).
  void srp_wrench(const Eigen::Vector3d& r_L, const Eigen::Matrix3d& C_BL, Eigen::Vector3d& force_B,
                  Eigen::Vector3d& torque_B) const;

  /// The SRP acceleration of the truth at a state (what an accelerometer measures besides the thrust).
  /// @param s truth state [r_L (m), v_L (m/s), q_B/L, omega_BL_B (rad/s)].
  /// @return F_L / m_true (m/s^2, in L).
  Eigen::Vector3d srp_acceleration_L(const TruthState& s) const;

  /// The environment's part of the truth's derivative.
  /// @param t time (s) (the environment does not depend on it).
  /// @param s truth state [r_L (m), v_L (m/s), q_B/L (normalised here), omega_BL_B (rad/s)].
  /// @return [F_L / m_true (m/s^2, in L); J_true^-1 (T_srp + T_gg) (rad/s^2, in B)].
  Disturbance6 operator()(double t, const TruthState& s) const;

  /// The environment as the propagator's disturbance (its function refers to this object, which must
  /// outlive it; no allocation).
  /// @return a Disturbance whose function is operator().
  Disturbance disturbance() const;

 private:
  PhysicalSettings settings_;
  double mass_true_{0.0};
  Eigen::Matrix3d inertia_{Eigen::Matrix3d::Identity()};
  Eigen::Matrix3d inertia_inv_{Eigen::Matrix3d::Identity()};
  double gm_{0.0};
  double pressure_{0.0};
  Eigen::Matrix3d thrust_error_{Eigen::Matrix3d::Identity()};
  Eigen::Matrix3d torque_error_{Eigen::Matrix3d::Identity()};
};

/// Propagates the truth over one interval in its physical environment: propagate() with the
/// environment's disturbance.
/// @param truth       the truth model: its inertia must be environment.inertia_B() and its cannonball
///                    SRP off (ModelParams::srp_enabled false).
/// @param environment the environment.
/// @param t0          start time (s).
/// @param state       truth state at t0: [r_L (m), v_L (m/s), q_B/L (unit), omega_BL_B (rad/s)].
/// @param u_delivered the input the truth receives, held over the interval (environment.deliver()).
/// @param dt          interval length (s), >= 0.
/// @param settings    integration method and its parameters.
/// @param gravity_hold as propagate()'s.
/// @return as propagate().
/// @throws std::invalid_argument when the truth's inertia is not the environment's or its SRP is on, and
///         as propagate().
PropagationResult propagate(const ProximityModel& truth, const PhysicalEnvironment& environment, double t0,
                            const TruthState& state, const InputVector& u_delivered, double dt,
                            const PropagatorSettings& settings = {},
                            gravity::ExpansionHold* gravity_hold = nullptr);

}  // namespace tubempc::dynamics

namespace tubempc::dynamics {

// The table of FlatPlate::for_each_field.
template <typename V>
void FlatPlate::for_each_field(V&& visit) {
  using core::Dim;
  using core::FieldInfo;
  using P = FlatPlate;
  constexpr bool req = false, finite = false;
  constexpr Dim one = Dim::One, three = Dim::Three;
  visit(FieldInfo{"area", "m^2", req, finite, one, one, "A (m^2), > 0"}, &P::area);
  visit(FieldInfo{"normal_B", "", req, finite, three, one, "outward normal in B (normalised on use)"},
        &P::normal_B);
  visit(FieldInfo{"center_B", "m", req, finite, three, one,
                  "centre of pressure from the centre of mass, in B (m)"},
        &P::center_B);
  visit(FieldInfo{"specular", "", req, finite, one, one, "rho_s, in [0, 1]"}, &P::specular);
  visit(FieldInfo{"diffuse", "", req, finite, one, one, "rho_d, in [0, 1 - rho_s]"}, &P::diffuse);
}

// The table of PhysicalSettings::for_each_field.
template <typename V>
void PhysicalSettings::for_each_field(V&& visit) {
  using core::Dim;
  using core::FieldInfo;
  using S = PhysicalSettings;
  constexpr bool req = false, finite = false;
  constexpr Dim one = Dim::One, three = Dim::Three;
  visit(FieldInfo{"mass", "kg", req, finite, one, one, "the controller's spacecraft mass (kg)"}, &S::mass);
  visit(FieldInfo{"mass_error", "", req, finite, one, one, "truth mass = (1 + mass_error) mass"},
        &S::mass_error);
  visit(
      FieldInfo{"inertia_scale", "", req, finite, three, one, "truth moments / the controller's J diagonal"},
      &S::inertia_scale);
  visit(FieldInfo{"inertia_products", "kg m^2", req, finite, three, one,
                  "[J_xy, J_xz, J_yz] added to the truth's inertia (kg m^2)"},
        &S::inertia_products);
  visit(FieldInfo{"srp", "", req, finite, one, one, "the flat-plate SRP force and torque"}, &S::srp);
  visit(
      FieldInfo{"solar_pressure", "N/m^2", req, finite, one, one, "solar radiation pressure at 1 AU (N/m^2)"},
      &S::solar_pressure);
  visit(FieldInfo{"shadow_radius", "m", req, finite, one, one,
                  "the asteroid's cylindrical shadow (m); 0: none"},
        &S::shadow_radius);
  visit(FieldInfo{"gravity_gradient", "", req, finite, one, one, "the gravity-gradient torque"},
        &S::gravity_gradient);
}

}  // namespace tubempc::dynamics
