/// @file proximity_model.hpp
/// 6-DOF relative dynamics of a spacecraft near an asteroid in the orbital (Hill) frame L
/// (docs/model.md, "Frames", "State and input", "Translational dynamics", "Gravity", "Attitude"),
/// with analytic Jacobians and the exact zero-order-hold discretisation used by the MPC
/// ("Linearisation and discretisation").
///
/// State x = [r_L (m), v_L (m/s), phi (rad), omega_BL_B (rad/s)] (12): r, v position and velocity
/// relative to the asteroid's centre of mass in L; phi = log(q_B/L) the rotation vector of the
/// attitude, with the conventions of tubempc/math/so3.hpp (R(q_B/L) = C_LB = Exp(phi)); omega_BL_B
/// the angular velocity of B relative to L, in B.
/// Input u = [u_p (m/s^2, in L), T (N m, in B)] (6).
///
/// Frames (closed form, constant rates). L rotates about z_L at the orbital rate
/// n = sqrt(mu_sun / R^3) relative to inertial space. The asteroid spins about z_A = z_L at the
/// signed rate omega_A, read as an inertial rate (the paper's q_A/L = q_A/I (x) q_L/I^* composes two
/// inertial rotations), so relative to L the asteroid turns at (omega_A - n) about z:
///     theta(t) = theta_0 + (omega_A - n) t,   x_A = [cos theta, sin theta, 0] in L,
///     C_AL(t) = Rz(theta)^T (r_A = C_AL r_L),  q_A/L(t) = exp_map(-theta z) (R(q_A/L) = C_AL).
///
/// Dynamics f(t, x, u):
///     r' = v
///     v' = -2 n z x v + n^2 diag(3, 0, -1) r + (beta_SRP / R^2) x_L + C_AL^T a_A(C_AL r) + u_p
///          [+ extra acceleration hook]
///     phi' = w (Kinematics::FirstOrder) or Jr(phi)^-1 w (Kinematics::Exact)
///     w' = J^-1 (T - (w + w_LI) x J (w + w_LI)) + w x w_LI,  w_LI = C_BL n z_L = Exp(phi)^T n z
#pragma once

#include <Eigen/Dense>
#include <array>
#include <memory>

#include "tubempc/core/fields.hpp"
#include "tubempc/gravity/expansion_hold.hpp"
#include "tubempc/gravity/gravity_model.hpp"
#include "tubempc/math/so3.hpp"

namespace tubempc::dynamics {

inline constexpr int kNx = 12;      ///< state dimension of x = [r, v, phi, w]
inline constexpr int kNu = 6;       ///< input dimension of u = [u_p, T]
inline constexpr int kNtruth = 13;  ///< truth-state dimension of [r, v, q_B/L, w]

/// Model state x = [r_L (m), v_L (m/s), phi (rad), omega_BL_B (rad/s)].
using StateVector = Eigen::Matrix<double, kNx, 1>;
/// Input u = [u_p (m/s^2, in L), T (N m, in B)].
using InputVector = Eigen::Matrix<double, kNu, 1>;
/// Truth state [r_L (m), v_L (m/s), q_B/L ([x,y,z,w], unit), omega_BL_B (rad/s)].
using TruthState = Eigen::Matrix<double, kNtruth, 1>;
/// 12 x 12 matrix over the model state (e.g. A = df/dx, in the state's mixed units).
using StateMatrix = Eigen::Matrix<double, kNx, kNx>;
/// 12 x 6 matrix from the input to the model state (e.g. B = df/du).
using InputMatrix = Eigen::Matrix<double, kNx, kNu>;

/// Attitude kinematics of the rotation vector (docs/model.md, "Attitude").
enum class Kinematics {
  FirstOrder,  ///< phi' = omega_BL_B (the paper's first-order law)
  Exact,       ///< phi' = Jr(phi)^-1 omega_BL_B
};
/// Name of a kinematics variant.
/// @param k the variant.
/// @return "first_order" or "exact".
const char* to_string(Kinematics k);

/// Model constants; in-class defaults are the paper's scenario (Table 1, docs/model.md "Scenario").
struct ModelParams {
  double mu_sun{1.32712440018e20};  ///< Sun's gravitational parameter (m^3/s^2), >= 0 (0: L inertial)
  double orbit_radius{1.685e11};    ///< heliocentric distance R (m), > 0
  double beta_srp{1.7744e15};       ///< SRP constant (m^3/s^2): acceleration beta/R^2 along +x_L
  bool srp_enabled{true};           ///< include the SRP acceleration
  /// Spacecraft inertia about its centre of mass in B (kg m^2), symmetric positive definite.
  Eigen::Matrix3d inertia_B{Eigen::Vector3d(2750.0, 2750.0, 2030.0).asDiagonal()};
  /// Asteroid spin rate omega_A (rad/s) about z_A = z_L, inertial, signed (+: counter-clockwise
  /// about +z_L). Default 2 pi / 4.296 h (Bennu).
  double spin_rate{2.0 * 3.14159265358979323846 / (4.296 * 3600.0)};
  double spin_angle0{0.0};                        ///< theta_0 (rad): angle from x_L to x_A about z at t = 0
  Kinematics kinematics{Kinematics::FirstOrder};  ///< rotation-vector kinematics of the model x
  double glide_slope_angle{70.0 * 3.14159265358979323846 / 180.0};  ///< phi_gs (rad), in (0, pi/2)
  double los_angle{80.0 * 3.14159265358979323846 / 180.0};          ///< theta_LOS (rad), in (0, pi/2)
  Eigen::Vector3d boresight_B{0.0, 0.0, 1.0};  ///< camera boresight b_B in B (normalised on use)
  /// Apex of the glide-slope cone in the asteroid frame A (m). The cone is fixed in A and turns with
  /// the body; the default (the centre, axis z_A = z_L, the spin axis) is the paper's cone, fixed in L.
  Eigen::Vector3d glide_slope_apex_A{Eigen::Vector3d::Zero()};
  /// Axis of the glide-slope cone in A (normalised on use; e.g. the outward surface normal at a site).
  Eigen::Vector3d glide_slope_axis_A{Eigen::Vector3d::UnitZ()};

  /// Checks the ranges given above (finite values, inertia symmetric positive definite, ...).
  /// @throws std::invalid_argument naming the first bad field.
  void validate() const;
  /// Orbital rate of the frame L.
  /// @return n = sqrt(mu_sun / R^3) (rad/s).
  double mean_motion() const;

  /// The fields, once: calls visit(info, pointer to the member) with a core::FieldInfo for each member,
  /// in the order scenario files write them (records model.name and truth.name). Drives the scenario
  /// file's reading and writing (io/scenario.cpp) and the Python binding (docs/decisions.md "One field
  /// table").
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit);
};

/// An extra acceleration in L for the truth model (e.g. an unmodelled force), with its Jacobian so
/// that f and its linearisation stay consistent. Implementations must be thread-safe and not
/// allocate.
class ExtraAcceleration {
 public:
  virtual ~ExtraAcceleration() = default;
  /// The extra acceleration.
  /// @param t   time (s).
  /// @param r_L position in L (m).
  /// @param v_L velocity in L (m/s).
  /// @return the acceleration in L (m/s^2).
  virtual Eigen::Vector3d acceleration(double t, const Eigen::Vector3d& r_L,
                                       const Eigen::Vector3d& v_L) const = 0;
  /// Partial derivatives of acceleration().
  /// @param t     time (s).
  /// @param r_L   position in L (m).
  /// @param v_L   velocity in L (m/s).
  /// @param da_dr receives d a / d r_L (1/s^2).
  /// @param da_dv receives d a / d v_L (1/s).
  virtual void jacobian(double t, const Eigen::Vector3d& r_L, const Eigen::Vector3d& v_L,
                        Eigen::Matrix3d& da_dr, Eigen::Matrix3d& da_dv) const = 0;
};

/// Outcome of a discretisation.
enum class DiscretizationStatus {
  Ok,               ///< finite result
  NonFiniteInput,   ///< t, dt, x or u not finite
  NonFiniteResult,  ///< non-finite f, Jacobian or exponential, or Jr^-1 singular (Exact, |phi| ~ 2 pi)
};
/// Name of a discretisation status.
/// @param s the status.
/// @return its name ("ok", ...).
const char* to_string(DiscretizationStatus s);

/// The 6-DOF proximity model. Immutable after construction; all methods are const, thread-safe
/// (if the gravity model is) and allocation-free.
class ProximityModel {
 public:
  /// @param gravity field in the asteroid frame A, non-null.
  /// @param params  model constants, validated here.
  /// @param extra   optional extra acceleration (truth model), may be null.
  /// @throws std::invalid_argument for a null gravity or invalid params (ModelParams::validate).
  ProximityModel(std::shared_ptr<const gravity::GravityModel> gravity, const ModelParams& params = {},
                 std::shared_ptr<const ExtraAcceleration> extra = nullptr);

  /// @return the model constants.
  const ModelParams& params() const { return params_; }
  /// @return the gravity field (frame A).
  const std::shared_ptr<const gravity::GravityModel>& gravity() const { return gravity_; }
  /// @return the extra acceleration, or null.
  const std::shared_ptr<const ExtraAcceleration>& extra_acceleration() const { return extra_; }
  /// @return the orbital rate n (rad/s).
  double mean_motion() const { return n_; }
  /// @return the body's rotation rate relative to L about z_L = z_A, omega_A - n (rad/s).
  double rotation_rate_AL() const { return params_.spin_rate - n_; }
  /// @return the SRP acceleration in L (m/s^2): beta_SRP / R^2 along +x_L, or zero when SRP is off.
  Eigen::Vector3d srp_acceleration_L() const { return {srp_accel_, 0.0, 0.0}; }

  /// Angle of x_A from x_L about z.
  /// @param t time (s).
  /// @return theta(t) = theta_0 + (omega_A - n) t (rad).
  double spin_angle(double t) const;
  /// Rotation from L to A.
  /// @param t time (s).
  /// @return C_AL(t), with r_A = C_AL r_L.
  Eigen::Matrix3d C_AL(double t) const;
  /// The glide-slope cone at time t in L: its apex C_AL^T apex_A (m) and unit axis C_AL^T axis_A.
  /// @param t      time (s).
  /// @param apex_L receives the apex in L (m).
  /// @param axis_L receives the unit axis in L.
  void glide_slope_cone_L(double t, Eigen::Vector3d& apex_L, Eigen::Vector3d& axis_L) const;
  /// Attitude of A relative to L.
  /// @param t time (s).
  /// @return q_A/L(t) with R(q_A/L) = C_AL (so3.hpp conventions).
  math::Quaternion q_AL(double t) const;

  /// Gravity acceleration and gradient in L.
  /// @param t   time (s).
  /// @param r_L position in L (m).
  /// @param a_L receives the acceleration in L (m/s^2).
  /// @param G_L receives the gradient G_L = C_AL^T G_A C_AL (1/s^2).
  void gravity_L(double t, const Eigen::Vector3d& r_L, Eigen::Vector3d& a_L, Eigen::Matrix3d& G_L) const;

  /// Continuous dynamics.
  /// @param t time (s).
  /// @param x model state [r_L (m), v_L (m/s), phi (rad), omega_BL_B (rad/s)].
  /// @param u input [u_p (m/s^2, in L), T (N m, in B)].
  /// @return x' = f(t, x, u) (units of x per second).
  /// @throws std::domain_error for non-finite arguments.
  StateVector f(double t, const StateVector& x, const InputVector& u) const;

  /// f and its Jacobians at (t, x, u) with one gravity evaluation.
  /// @param t     time (s).
  /// @param x     model state (see f).
  /// @param u     input (see f).
  /// @param f_out receives f(t, x, u).
  /// @param A     receives df/dx (12 x 12).
  /// @param B     receives df/du (12 x 6).
  /// @throws std::domain_error for non-finite arguments.
  void linearize(double t, const StateVector& x, const InputVector& u, StateVector& f_out, StateMatrix& A,
                 InputMatrix& B) const;

  /// Exact zero-order-hold discretisation over [t, t + dt] about (x_ref, u_ref):
  /// x(t + dt) ~= Ad x(t) + Bd u + cd, with A, B, c = f - A x_ref - B u_ref taken at the node's start
  /// time t and held over the step (the frame rotation of A within the step, |omega_A - n| dt
  /// ~ 8e-4 rad for dt = 2 s, is left to the model residual). One 19x19 exponential; no allocation.
  /// Non-finite input or result, and |phi| >= 2 pi - 1e-6 with Kinematics::Exact (Jr^-1 singular),
  /// give a status, not an exception; the gravity model's own errors (e.g. r = 0) propagate.
  /// @param t     start time of the step (s).
  /// @param dt    step length (s).
  /// @param x_ref linearisation state (see f).
  /// @param u_ref linearisation input (see f).
  /// @param Ad    receives e^{A dt}.
  /// @param Bd    receives int_0^dt e^{A s} ds B.
  /// @param cd    receives int_0^dt e^{A s} ds c (state units).
  /// @return DiscretizationStatus::Ok, or why the outputs are not usable.
  DiscretizationStatus discretize(double t, double dt, const StateVector& x_ref, const InputVector& u_ref,
                                  StateMatrix& Ad, InputMatrix& Bd, StateVector& cd) const;

  /// The attitude half of `discretize` (rows and columns 6-11 of Ad, rows 6-11 and columns 3-5 of
  /// Bd, entries 6-11 of cd). Attitude and translation are decoupled in this model and the attitude
  /// dynamics do not depend on t, so this equals the corresponding blocks of `discretize` at any t
  /// (to rounding). Allocation-free; statuses as `discretize`.
  /// @param dt         step length (s).
  /// @param phi        linearisation rotation vector of q_B/L (rad).
  /// @param omega_BL_B linearisation angular velocity of B relative to L, in B (rad/s).
  /// @param T_B        linearisation torque, in B (N m).
  /// @param Ad_r       receives the attitude block of Ad (6 x 6).
  /// @param Bd_r       receives the torque block of Bd (6 x 3).
  /// @param cd_r       receives the attitude part of cd (rad, rad/s).
  /// @return DiscretizationStatus::Ok, or why the outputs are not usable.
  DiscretizationStatus discretize_rotation(double dt, const Eigen::Vector3d& phi,
                                           const Eigen::Vector3d& omega_BL_B, const Eigen::Vector3d& T_B,
                                           Eigen::Matrix<double, 6, 6>& Ad_r,
                                           Eigen::Matrix<double, 6, 3>& Bd_r,
                                           Eigen::Matrix<double, 6, 1>& cd_r) const;

  /// Derivative of the 13-dimensional truth state [r, v, q_B/L, w] with the quaternion kinematics
  /// q' = 1/2 q (x) [w; 0] and C_BL = R(q)^T; disturbance = [acceleration in L (m/s^2); angular
  /// acceleration in B (rad/s^2)] added to v' and w'. No finiteness check (the propagator checks).
  /// @param t           time (s).
  /// @param s           truth state [r_L (m), v_L (m/s), q_B/L, omega_BL_B (rad/s)].
  /// @param u           input (see f).
  /// @param disturbance [acceleration in L (m/s^2); angular acceleration in B (rad/s^2)].
  /// @param gravity      the gravity field's held expansion to use in its place (valid, held about a
  ///                     point of this model's field: propagate() holds it); nullptr: the field.
  /// @return the derivative of s (units of s per second).
  TruthState truth_derivative(double t, const TruthState& s, const InputVector& u,
                              const Eigen::Matrix<double, 6, 1>& disturbance,
                              const gravity::ExpansionHold* gravity = nullptr) const;

  /// Rotation-vector kinematics for the configured variant.
  /// @param phi        rotation vector of q_B/L (rad).
  /// @param omega_BL_B angular velocity of B relative to L, in B (rad/s).
  /// @return phi' (rad/s): omega_BL_B (Paper) or Jr(phi)^-1 omega_BL_B (Exact).
  Eigen::Vector3d phi_dot(const Eigen::Vector3d& phi, const Eigen::Vector3d& omega_BL_B) const;

 private:
  // [phi', omega'] and its Jacobians with respect to [phi, omega] and T.
  void rotational_jacobians(const Eigen::Vector3d& phi, const Eigen::Vector3d& w, const Eigen::Vector3d& T,
                            Eigen::Matrix<double, 6, 1>& f_r, Eigen::Matrix<double, 6, 6>& A_r,
                            Eigen::Matrix<double, 6, 3>& B_r) const;
  // With a held expansion (no Jacobians then), its acceleration in place of the field's.
  void translational(double t, const Eigen::Vector3d& r, const Eigen::Vector3d& v, const Eigen::Vector3d& u_p,
                     Eigen::Vector3d& a_L, Eigen::Matrix3d* da_dr, Eigen::Matrix3d* da_dv,
                     const gravity::ExpansionHold* held = nullptr) const;
  Eigen::Vector3d rotational(const Eigen::Matrix3d& C_BL, const Eigen::Vector3d& w,
                             const Eigen::Vector3d& T) const;

  std::shared_ptr<const gravity::GravityModel> gravity_;
  ModelParams params_;
  std::shared_ptr<const ExtraAcceleration> extra_;
  double n_{0.0};
  double srp_accel_{0.0};
  Eigen::Matrix3d J_inv_{Eigen::Matrix3d::Identity()};
};

/// Inverse right Jacobian and its directional derivative, accurate near phi = 0 (series).
/// @param phi            rotation vector (rad), |phi| < 2 pi.
/// @param w              angular velocity (rad/s).
/// @param Jr_inv         receives Jr(phi)^-1.
/// @param d_Jrinv_w_dphi receives d(Jr(phi)^-1 w)/dphi (3 x 3, 1/s).
/// @throws std::domain_error for non-finite input or |phi| >= 2 pi.
void right_jacobian_inverse_and_derivative(const Eigen::Vector3d& phi, const Eigen::Vector3d& w,
                                           Eigen::Matrix3d& Jr_inv, Eigen::Matrix3d& d_Jrinv_w_dphi);

/// Truth state -> model state: phi = log_map(q) (|phi| <= pi), then unwrapped onto the
/// representative nearest to phi_ref (math::nearest_representative). A trajectory
/// crossing |phi| = pi thus stays continuous when phi_ref is the previous model state (|phi| may
/// then exceed pi; the model is valid for |phi| < 2 pi). Pass phi_ref = 0 for the principal value.
/// @param s       truth state [r_L (m), v_L (m/s), q_B/L, omega_BL_B (rad/s)].
/// @param phi_ref rotation vector (rad) the result's phi is taken nearest to.
/// @return the model state [r_L, v_L, phi (rad), omega_BL_B].
/// @throws std::domain_error for non-finite s or phi_ref.
StateVector truth_to_state(const TruthState& s, const Eigen::Vector3d& phi_ref = Eigen::Vector3d::Zero());

/// Model state -> truth state: q_B/L = exp_map(phi).
/// @param x model state [r_L (m), v_L (m/s), phi (rad), omega_BL_B (rad/s)].
/// @return the truth state [r_L, v_L, q_B/L (unit), omega_BL_B].
/// @throws std::domain_error for a non-finite x.
TruthState state_to_truth(const StateVector& x);

}  // namespace tubempc::dynamics

namespace tubempc::core {

/// Names of dynamics::Kinematics.
template <>
struct EnumNames<dynamics::Kinematics> {
  /// The values, their identifiers and file names.
  static constexpr std::array<EnumName<dynamics::Kinematics>, 2> values{
      {{dynamics::Kinematics::FirstOrder, "FirstOrder", "first_order"},
       {dynamics::Kinematics::Exact, "Exact", "exact"}}};
};
/// Names of dynamics::DiscretizationStatus.
template <>
struct EnumNames<dynamics::DiscretizationStatus> {
  /// The values, their identifiers and names.
  static constexpr std::array<EnumName<dynamics::DiscretizationStatus>, 3> values{
      {{dynamics::DiscretizationStatus::Ok, "Ok", "ok"},
       {dynamics::DiscretizationStatus::NonFiniteInput, "NonFiniteInput", "non_finite_input"},
       {dynamics::DiscretizationStatus::NonFiniteResult, "NonFiniteResult", "non_finite_result"}}};
};

}  // namespace tubempc::core

namespace tubempc::dynamics {

// The table of ModelParams::for_each_field.
template <typename V>
void ModelParams::for_each_field(V&& visit) {
  using core::Dim;
  using core::FieldInfo;
  using P = ModelParams;
  constexpr bool req = false, opt = true, finite = false;
  constexpr Dim one = Dim::One, three = Dim::Three;
  visit(FieldInfo{"mu_sun", "m^3/s^2", req, finite, one, one, "m^3/s^2"}, &P::mu_sun);
  visit(FieldInfo{"orbit_radius", "m", req, finite, one, one, "R (m)"}, &P::orbit_radius);
  visit(FieldInfo{"beta_srp", "m^3/s^2", req, finite, one, one,
                  "m^3/s^2; SRP acceleration beta/R^2 along +x_L"},
        &P::beta_srp);
  visit(FieldInfo{"srp_enabled", "", req, finite, one, one, "include the SRP acceleration"}, &P::srp_enabled);
  visit(FieldInfo{"inertia_B", "kg m^2", req, finite, three, three, "J (kg m^2), 3x3"}, &P::inertia_B);
  visit(FieldInfo{"spin_rate", "rad/s", req, finite, one, one, "omega_A (rad/s), inertial, about z_A = z_L"},
        &P::spin_rate);
  visit(FieldInfo{"spin_angle0", "rad", req, finite, one, one, "theta_0 (rad)"}, &P::spin_angle0);
  visit(FieldInfo{"kinematics", "", req, finite, one, one, "rotation-vector kinematics of the model"},
        &P::kinematics);
  visit(FieldInfo{"glide_slope_angle", "rad", req, finite, one, one, "phi_gs (rad)"}, &P::glide_slope_angle);
  visit(FieldInfo{"los_angle", "rad", req, finite, one, one, "theta_LOS (rad)"}, &P::los_angle);
  visit(FieldInfo{"boresight_B", "", req, finite, three, one, "b_B in B"}, &P::boresight_B);
  visit(FieldInfo{"glide_slope_apex_A", "m", opt, finite, three, one,
                  "glide-slope cone apex in A (m); the cone turns with the body"},
        &P::glide_slope_apex_A);
  visit(FieldInfo{"glide_slope_axis_A", "", opt, finite, three, one,
                  "glide-slope cone axis in A (normalised on use)"},
        &P::glide_slope_axis_A);
}

}  // namespace tubempc::dynamics
