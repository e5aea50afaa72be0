/// @file proximity_model.hpp
/// 6-DOF relative dynamics of a spacecraft near an asteroid in the orbital (Hill) frame L
/// (PAPER_NOTES.md, "Frames", "State, input", "Translational dynamics", "Gravity", "Attitude"),
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
///     phi' = w (Kinematics::Paper) or Jr(phi)^-1 w (Kinematics::Exact)
///     w' = J^-1 (T - (w + w_LI) x J (w + w_LI)) + w x w_LI,  w_LI = C_BL n z_L = Exp(phi)^T n z
#pragma once

#include <Eigen/Dense>
#include <memory>

#include "tubempc/gravity/gravity_model.hpp"
#include "tubempc/math/so3.hpp"

namespace tubempc::dynamics {

inline constexpr int kNx = 12;      ///< state dimension of x = [r, v, phi, w]
inline constexpr int kNu = 6;       ///< input dimension of u = [u_p, T]
inline constexpr int kNtruth = 13;  ///< truth-state dimension of [r, v, q_B/L, w]

using StateVector = Eigen::Matrix<double, kNx, 1>;
using InputVector = Eigen::Matrix<double, kNu, 1>;
using TruthState = Eigen::Matrix<double, kNtruth, 1>;  ///< [r_L, v_L, q_B/L ([x,y,z,w]), omega_BL_B]
using StateMatrix = Eigen::Matrix<double, kNx, kNx>;
using InputMatrix = Eigen::Matrix<double, kNx, kNu>;

/// Attitude kinematics of the rotation vector (PAPER_NOTES.md, "Attitude").
enum class Kinematics {
  Paper,  ///< phi' = omega_BL_B (the paper's first-order law)
  Exact,  ///< phi' = Jr(phi)^-1 omega_BL_B
};
const char* to_string(Kinematics k);

/// Model constants; in-class defaults are the paper's scenario (Table 1, PAPER_NOTES.md).
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
  double spin_angle0{0.0};                   ///< theta_0 (rad): angle from x_L to x_A about z at t = 0
  Kinematics kinematics{Kinematics::Paper};  ///< rotation-vector kinematics of the model x
  double glide_slope_angle{70.0 * 3.14159265358979323846 / 180.0};  ///< phi_gs (rad), in (0, pi/2)
  double los_angle{80.0 * 3.14159265358979323846 / 180.0};          ///< theta_LOS (rad), in (0, pi/2)
  Eigen::Vector3d boresight_B{0.0, 0.0, 1.0};  ///< camera boresight b_B in B (normalised on use)

  /// Throws std::invalid_argument naming the first bad field.
  void validate() const;
  /// Orbital rate n = sqrt(mu_sun / R^3) (rad/s).
  double mean_motion() const;
};

/// An extra acceleration in L for the truth model (e.g. an unmodelled force), with its Jacobian so
/// that f and its linearisation stay consistent. Implementations must be thread-safe and not
/// allocate.
class ExtraAcceleration {
 public:
  virtual ~ExtraAcceleration() = default;
  /// Acceleration (m/s^2) in L at time t (s), position r_L (m), velocity v_L (m/s).
  virtual Eigen::Vector3d acceleration(double t, const Eigen::Vector3d& r_L,
                                       const Eigen::Vector3d& v_L) const = 0;
  /// Partial derivatives d a / d r_L (1/s^2) and d a / d v_L (1/s).
  virtual void jacobian(double t, const Eigen::Vector3d& r_L, const Eigen::Vector3d& v_L,
                        Eigen::Matrix3d& da_dr, Eigen::Matrix3d& da_dv) const = 0;
};

/// Outcome of a discretisation.
enum class DiscretizationStatus {
  Ok,
  NonFiniteInput,   ///< t, dt, x or u not finite
  NonFiniteResult,  ///< non-finite f, Jacobian or exponential, or Jr^-1 singular (Exact, |phi| ~ 2 pi)
};
const char* to_string(DiscretizationStatus s);

/// The 6-DOF proximity model. Immutable after construction; all methods are const, thread-safe
/// (if the gravity model is) and allocation-free.
class ProximityModel {
 public:
  /// @param gravity field in the asteroid frame A (non-null); @param params validated here;
  /// @param extra optional extra acceleration (truth model), may be null.
  ProximityModel(std::shared_ptr<const gravity::GravityModel> gravity, const ModelParams& params = {},
                 std::shared_ptr<const ExtraAcceleration> extra = nullptr);

  const ModelParams& params() const { return params_; }
  const std::shared_ptr<const gravity::GravityModel>& gravity() const { return gravity_; }
  const std::shared_ptr<const ExtraAcceleration>& extra_acceleration() const { return extra_; }
  /// Orbital rate n (rad/s).
  double mean_motion() const { return n_; }

  /// Angle theta(t) = theta_0 + (omega_A - n) t (rad) of x_A from x_L about z.
  double spin_angle(double t) const;
  /// C_AL(t): r_A = C_AL r_L.
  Eigen::Matrix3d C_AL(double t) const;
  /// q_A/L(t) with R(q_A/L) = C_AL (so3.hpp conventions).
  math::Quaternion q_AL(double t) const;

  /// Gravity acceleration a_L (m/s^2) and gradient G_L = C_AL^T G_A C_AL (1/s^2) at r_L (m), time t (s).
  void gravity_L(double t, const Eigen::Vector3d& r_L, Eigen::Vector3d& a_L, Eigen::Matrix3d& G_L) const;

  /// Continuous dynamics x' = f(t, x, u). Throws std::domain_error for non-finite arguments.
  StateVector f(double t, const StateVector& x, const InputVector& u) const;

  /// f and its Jacobians A = df/dx (12x12), B = df/du (12x6) at (t, x, u) (one gravity evaluation).
  /// Throws std::domain_error for non-finite arguments.
  void linearize(double t, const StateVector& x, const InputVector& u, StateVector& f_out, StateMatrix& A,
                 InputMatrix& B) const;

  /// Exact zero-order-hold discretisation over [t, t + dt] about (x_ref, u_ref):
  /// x(t + dt) ~= Ad x(t) + Bd u + cd, with A, B, c = f - A x_ref - B u_ref taken at the node's start
  /// time t and held over the step (the frame rotation of A within the step, |omega_A - n| dt
  /// ~ 8e-4 rad for dt = 2 s, is left to the model residual). One 19x19 exponential; no allocation.
  /// Non-finite input or result, and |phi| >= 2 pi - 1e-6 with Kinematics::Exact (Jr^-1 singular),
  /// give a status, not an exception; the gravity model's own errors (e.g. r = 0) propagate.
  DiscretizationStatus discretize(double t, double dt, const StateVector& x_ref, const InputVector& u_ref,
                                  StateMatrix& Ad, InputMatrix& Bd, StateVector& cd) const;

  /// Derivative of the 13-dimensional truth state [r, v, q_B/L, w] with the quaternion kinematics
  /// q' = 1/2 q (x) [w; 0] and C_BL = R(q)^T; disturbance = [acceleration in L (m/s^2); angular
  /// acceleration in B (rad/s^2)] added to v' and w'. No finiteness check (the propagator checks).
  TruthState truth_derivative(double t, const TruthState& s, const InputVector& u,
                              const Eigen::Matrix<double, 6, 1>& disturbance) const;

  /// Rotation-vector kinematics phi' for the configured variant.
  Eigen::Vector3d phi_dot(const Eigen::Vector3d& phi, const Eigen::Vector3d& omega_BL_B) const;

 private:
  void translational(double t, const Eigen::Vector3d& r, const Eigen::Vector3d& v, const Eigen::Vector3d& u_p,
                     Eigen::Vector3d& a_L, Eigen::Matrix3d* da_dr, Eigen::Matrix3d* da_dv) const;
  Eigen::Vector3d rotational(const Eigen::Matrix3d& C_BL, const Eigen::Vector3d& w,
                             const Eigen::Vector3d& T) const;

  std::shared_ptr<const gravity::GravityModel> gravity_;
  ModelParams params_;
  std::shared_ptr<const ExtraAcceleration> extra_;
  double n_{0.0};
  double srp_accel_{0.0};
  Eigen::Matrix3d J_inv_{Eigen::Matrix3d::Identity()};
};

/// Inverse right Jacobian Jr(phi)^-1 and the derivative d(Jr(phi)^-1 w)/dphi (3x3), accurate near
/// phi = 0 (series) and defined for |phi| < 2 pi (std::domain_error otherwise).
void right_jacobian_inverse_and_derivative(const Eigen::Vector3d& phi, const Eigen::Vector3d& w,
                                           Eigen::Matrix3d& Jr_inv, Eigen::Matrix3d& d_Jrinv_w_dphi);

/// Truth state -> model state: phi = log_map(q) (|phi| <= pi), then unwrapped onto the
/// representative phi + 2 pi k phi/|phi| (k in {-1, 0, 1}) nearest to phi_ref. A trajectory
/// crossing |phi| = pi thus stays continuous when phi_ref is the previous model state (|phi| may
/// then exceed pi; the model is valid for |phi| < 2 pi). Pass phi_ref = 0 for the principal value.
StateVector truth_to_state(const TruthState& s, const Eigen::Vector3d& phi_ref = Eigen::Vector3d::Zero());

/// Model state -> truth state: q_B/L = exp_map(phi).
TruthState state_to_truth(const StateVector& x);

}  // namespace tubempc::dynamics
