/// @file tube_update.hpp
/// The tube of each subsystem, step by step (docs/model.md "Tube MPC", "Tube update"; the paper's
/// Eq. 25 and Algorithm 1, step 1), with a cost known in advance: no semidefinite program runs here.
///
/// A tube of the ancillary law u = v + K e is the ellipsoid {e : e^T Pe^-1 e <= 1}. It is robustly
/// invariant for e+ = (A + B K) e + w, w^T P_W^-1 w <= 1, when for its alpha in (0, 1)
///
///     (A + B K) Pe (A + B K)^T / alpha + P_W / (1 - alpha) <= Pe.                          (*)
///
/// A tube is *certified* for a step when `lmi_residual` (the largest eigenvalue of (*)'s left minus
/// right side, scaled by diag(Pe)^-1/2) is <= 0 for the step's (A, B, P_W) and its input tightening is
/// non-empty (sqrt(K_i Pe K_i^T) < u_max for every input row i). The LMI designs (gains K and alphas)
/// come from set-up (Python, cvxpy): the initial design, a library of designs for a ladder of
/// disturbance sets, and optional background refinements offered through TubePolicy::adopt. Per step,
/// `lyapunov_tube` turns a design's (K, alpha) into the smallest tube of the family (*) for the step's
/// (A, B, P_W) by one 36 x 36 linear solve, and certifies it.
#pragma once

#include <Eigen/Dense>
#include <array>
#include <string>
#include <vector>

#include "tubempc/control/identification.hpp"

namespace tubempc::control {

/// A subsystem's input matrix B (6 x 3).
using SubInputMatrix = Eigen::Matrix<double, 6, 3>;
/// A subsystem's ancillary gain K (3 x 6).
using SubGain = Eigen::Matrix<double, 3, 6>;

/// An LMI design of one subsystem: its gain, alpha and the disturbance set it was designed for.
struct SubsystemDesign {
  SubGain K = SubGain::Zero();        ///< ancillary gain (input units per state unit)
  double alpha = 0.5;                 ///< contraction parameter of (*), in (0, 1)
  SubMatrix P_W = SubMatrix::Zero();  ///< disturbance set designed for (squared state units)
  SubMatrix Pe = SubMatrix::Zero();   ///< the design's tube about its own linearisation

  /// Throws std::invalid_argument naming `what` for non-finite values, alpha outside (0, 1), or a
  /// P_W or Pe that is not symmetric positive definite.
  /// @param what name of the design in the message.
  void validate(const std::string& what) const;
};

/// A certified tube of one subsystem.
struct SubsystemTube {
  SubGain K = SubGain::Zero();       ///< ancillary gain
  SubMatrix Pe = SubMatrix::Zero();  ///< tube shape (squared state units)
  double alpha = 0.5;                ///< contraction parameter
  /// lmi_residual for the last update's (A, B) and set: the set it was certified for ((1 + margin) P_W,
  /// or P_W for the *_no_margin statuses; <= 0), or P_W for the fixed, initial and uncertified statuses
  /// (> 0 where the tube is not invariant for the identified set).
  double residual = 0.0;
};

/// Outcome of a certification (lyapunov_tube).
enum class Certification {
  Certified,       ///< (*) holds with residual <= 0 and the tightening is non-empty
  NotContractive,  ///< rho(A + B K)^2 >= alpha (no positive definite Lyapunov solution): no tube of the family
  InvarianceViolated,  ///< the solution misses (*) (residual > 0, rounding)
  EmptyTightening,     ///< sqrt(K_i Pe K_i^T) >= u_max for some input row i
};
/// @param c a certification outcome.
/// @return its name ("certified", "not_contractive", ...).
const char* to_string(Certification c);

/// Relative inflation of P_W in the Lyapunov update: keeps the tube strictly inside (*), which the
/// exact solution meets with equality.
inline constexpr double kLyapunovMargin = 1e-9;
/// Doubling iterations of the Lyapunov update at most: 2^40 terms of its series, enough (to 1e-17
/// relative) while rho(A_K)^2 / alpha <= 1 - 7e-11; beyond, the update reports NotContractive.
inline constexpr int kLyapunovIterations = 40;

/// The violation of (*) relative to Pe (dimensionless; <= 0 iff (*) holds). Allocation-free.
/// @param A   subsystem state matrix (6 x 6).
/// @param B   subsystem input matrix (6 x 3).
/// @param K   gain (3 x 6).
/// @param Pe  tube shape (6 x 6, symmetric positive diagonal).
/// @param P_W disturbance set (6 x 6).
/// @param alpha contraction parameter in (0, 1).
/// @return the largest eigenvalue of S^-1 M S^-1, M = (*)'s left side minus Pe, S = diag(Pe)^1/2.
double lmi_residual(const SubMatrix& A, const SubInputMatrix& B, const SubGain& K, const SubMatrix& Pe,
                    const SubMatrix& P_W, double alpha);

/// The certified Lyapunov update: for (K, alpha), Pe solving Pe = A_K Pe A_K^T / alpha + P_W' / (1 - alpha),
/// A_K = A + B K, P_W' = (1 + kLyapunovMargin) P_W (by doubling, at most kLyapunovIterations 6 x 6
/// iterations), checked against (*) and the input bound. Allocation-free, bounded cost.
/// @param A     subsystem state matrix.
/// @param B     subsystem input matrix.
/// @param K     gain of a design.
/// @param alpha its alpha.
/// @param P_W   the disturbance set to certify for.
/// @param u_max input bound (subsystem input units, m/s^2 or N m), > 0.
/// @param out   receives the tube (written only when Certified).
/// @return the outcome.
Certification lyapunov_tube(const SubMatrix& A, const SubInputMatrix& B, const SubGain& K, double alpha,
                            const SubMatrix& P_W, double u_max, SubsystemTube& out);

/// Largest generalised eigenvalue of (P, P_cover): <= 1 iff the ellipsoid of P lies in that of P_cover.
/// @param P       a disturbance set (symmetric positive semidefinite).
/// @param P_cover a covering candidate (symmetric positive definite).
/// @return lambda_max(P_cover^-1 P) (+inf if P_cover is not positive definite).
double cover_ratio(const SubMatrix& P, const SubMatrix& P_cover);

/// Settings of the tube update policy (TBMPC-FFA; TBMPC flies its initial tube).
struct TubePolicySettings {
  bool adaptive = true;          ///< false: TBMPC (the initial tube at every step)
  double redesign_margin = 0.2;  ///< certify for (1 + margin) P_W when possible (>= 0)
  int alpha_search_period = 10;  ///< a new design is due every this many steps (>= 1)
  /// true: the designs due are LMI designs that the caller (Python) computes in the background and
  /// offers through TubePolicy::adopt; false: the due design is taken from the library at once.
  bool background_designs = false;
  /// Throws std::invalid_argument naming the field.
  void validate() const;

  /// Calls visit(core::FieldInfo, member pointer) once per field: the scenario file's tube records
  /// (redesign_margin, alpha_search_period; adaptive and background_designs are set by the run) and the
  /// Python attributes ("One field table", docs/decisions.md).
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit);
};

/// How a step's tube came about (one per subsystem).
enum class TubeStatus {
  Fixed,             ///< TBMPC: the initial tube (certified for the prior at set-up)
  Initial,           ///< TBMPC-FFA at k = 0: the initial design's tube
  Lyapunov,          ///< the current design, certified for (1 + margin) P_W
  LyapunovNoMargin,  ///< the current design, certified for P_W only (the margin is used up)
  Library,           ///< a library design, certified for (1 + margin) P_W (it becomes the current design)
  LibraryNoMargin,   ///< a library design, certified for P_W only
  Uncertified,       ///< nothing certified for this step: the last certified tube is flown
};
/// @param s a tube status.
/// @return its name ("fixed", "lyapunov", "lyapunov_no_margin", ...).
const char* to_string(TubeStatus s);
/// @param s a tube status.
/// @return whether the step's tube is certified for the step's linearisation and identified P_W.
bool certified(TubeStatus s);

/// The tube of one subsystem, step by step. Set-up allocates; `update` does not.
class TubePolicy {
 public:
  /// @param settings the policy's settings (validated).
  /// @param u_max    the subsystem's input bound (> 0).
  /// @param initial  the design flown at k = 0 (and TBMPC's for the whole mission); its Pe is the
  ///                 initial tube (certified at set-up for the prior).
  /// @param library  designs for a ladder of disturbance sets, in any order (sorted here by
  ///                 trace(P_W)); may be empty (then nothing replaces an uncertified design).
  /// @param what     the subsystem's name in error messages.
  TubePolicy(const TubePolicySettings& settings, double u_max, const SubsystemDesign& initial,
             std::vector<SubsystemDesign> library, const std::string& what);

  /// Back to the initial design.
  void reset();
  /// The tube for step k, for the step's (A, B) and identified P_W. Allocation-free; at most
  /// 2 + 3 x library size Lyapunov updates (a fixed bound). In order: at k = 0 the initial design
  /// (Initial); when a design is due without background designs, the smallest library design covering
  /// (1 + margin) P_W that certifies (Library); the current design for (1 + margin) P_W (Lyapunov), for
  /// P_W (LyapunovNoMargin); a library design for (1 + margin) P_W (Library), for P_W (LibraryNoMargin);
  /// else the last tube (Uncertified).
  /// @param k          step index (>= 0).
  /// @param A          subsystem state matrix of the step.
  /// @param B          subsystem input matrix of the step.
  /// @param P_W        identified disturbance set.
  /// @param design_due whether a new design is due at this step (a search step, or the margin was lost
  ///                   at the previous step); used without background designs.
  /// @return the status; the tube is `tube()`.
  TubeStatus update(int k, const SubMatrix& A, const SubInputMatrix& B, const SubMatrix& P_W,
                    bool design_due);
  /// Adopts a background LMI design (TubePolicySettings::background_designs), unless a library
  /// design taken at or after `k_started` is newer. Allocation-free.
  /// @param design    the design (validated only for finiteness: a non-finite one is refused).
  /// @param k_started the step whose data it was designed from.
  /// @return whether it was adopted.
  bool adopt(const SubsystemDesign& design, int k_started);

  /// @return the tube of the last update (the initial design's before any).
  const SubsystemTube& tube() const { return tube_; }
  /// @return the current design.
  const SubsystemDesign& design() const { return design_; }
  /// @return the library, sorted by trace(P_W).
  const std::vector<SubsystemDesign>& library() const { return library_; }
  /// @return the settings.
  const TubePolicySettings& settings() const { return settings_; }

 private:
  bool from_library(const SubMatrix& A, const SubInputMatrix& B, const SubMatrix& P_W, int k);
  TubePolicySettings settings_;
  double u_max_;
  SubsystemDesign initial_;
  std::vector<SubsystemDesign> library_;
  SubsystemDesign design_;
  SubsystemTube tube_;
  SubsystemTube trial_;
  int library_step_ = -1;  // step of the last design taken from the library
};

}  // namespace tubempc::control

namespace tubempc::core {

/// Names of control::Certification.
template <>
struct EnumNames<control::Certification> {
  /// The values, their identifiers and names.
  static constexpr std::array<EnumName<control::Certification>, 4> values{
      {{control::Certification::Certified, "Certified", "certified"},
       {control::Certification::NotContractive, "NotContractive", "not_contractive"},
       {control::Certification::InvarianceViolated, "InvarianceViolated", "invariance_violated"},
       {control::Certification::EmptyTightening, "EmptyTightening", "empty_tightening"}}};
};
/// Names of control::TubeStatus.
template <>
struct EnumNames<control::TubeStatus> {
  /// The values, their identifiers and names.
  static constexpr std::array<EnumName<control::TubeStatus>, 7> values{
      {{control::TubeStatus::Fixed, "Fixed", "fixed"},
       {control::TubeStatus::Initial, "Initial", "initial"},
       {control::TubeStatus::Lyapunov, "Lyapunov", "lyapunov"},
       {control::TubeStatus::LyapunovNoMargin, "LyapunovNoMargin", "lyapunov_no_margin"},
       {control::TubeStatus::Library, "Library", "library"},
       {control::TubeStatus::LibraryNoMargin, "LibraryNoMargin", "library_no_margin"},
       {control::TubeStatus::Uncertified, "Uncertified", "uncertified"}}};
};

}  // namespace tubempc::core

namespace tubempc::control {

// The table of TubePolicySettings::for_each_field.
template <typename V>
void TubePolicySettings::for_each_field(V&& visit) {
  using core::Dim;
  using core::FieldInfo;
  using S = TubePolicySettings;
  constexpr bool req = false, finite = false, in_file = true, not_in_file = false;
  constexpr Dim one = Dim::One;
  visit(FieldInfo{"adaptive", "", req, finite, one, one, "", not_in_file}, &S::adaptive);
  visit(FieldInfo{"redesign_margin", "", req, finite, one, one, "", in_file}, &S::redesign_margin);
  visit(FieldInfo{"alpha_search_period", "", req, finite, one, one, "", in_file}, &S::alpha_search_period);
  visit(FieldInfo{"background_designs", "", req, finite, one, one, "", not_in_file}, &S::background_designs);
}

}  // namespace tubempc::control
