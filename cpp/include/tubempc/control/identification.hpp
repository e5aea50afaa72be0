/// @file identification.hpp
/// Forgetting-factor identification of one subsystem's exogenous input (docs/model.md
/// "Disturbance identification"; the paper's Eq. 26-29). With q = e^(lambda - 1):
///
///     zeta_{k+1} = q (zeta_k + 1)
///     w^_{k+1}   = q / zeta_{k+1} (zeta_k w^_k + w_k)
///     S^_{k+1}   = q / zeta_{k+1} (zeta_k S^_k + (w_k - w^_{k+1}) (w_k - w^_{k+1})^T)
///
/// zeta_0 = `prior_weight` keeps the prior (w^_0, S^_0) as a pseudo-measurement of that weight (0: the
/// paper's literal recursion, which forgets the prior at the first update). The reported covariance has
/// its eigenvalues floored, in the coordinates scaled by the prior's standard deviations, at `eig_floor`;
/// the recursion itself stays exact. The tube is designed for P_W = pw_scale S^ (9: the 3-sigma reading).
/// The same recursion in Python (tubempc.testing.identification) is this class's test oracle.
#pragma once

#include <Eigen/Dense>

#include "tubempc/core/fields.hpp"

namespace tubempc::control {

/// A subsystem's state (6: position and velocity, or attitude and rate).
using SubVector = Eigen::Matrix<double, 6, 1>;
/// A subsystem's state matrix (6 x 6).
using SubMatrix = Eigen::Matrix<double, 6, 6>;

/// Settings of one subsystem's identifier (the subsystem's SI units: m, m/s or rad, rad/s).
struct IdentifierSettings {
  double lambda = 0.96;                         ///< forgetting factor, in (0, 1)
  SubVector w0 = SubVector::Zero();             ///< prior mean w^_0 (subsystem state units)
  SubMatrix S0 = SubMatrix::Identity() * 1e-4;  ///< prior covariance S^_0 (symmetric positive definite)
  double prior_weight = 1.0;                    ///< zeta_0 >= 0, finite
  double eig_floor = 1e-6;                      ///< floor of the scaled eigenvalues of S^ (> 0)
  double pw_scale = 9.0;                        ///< P_W = pw_scale S^ (> 0)

  /// Throws std::invalid_argument naming the field (`what` is prefixed to it, e.g. "identification_p").
  /// @param what name of the subsystem's settings in the message.
  void validate(const char* what = "identifier") const;

  /// The fields, once (core::FieldInfo; scenario records identification_p.name and _r): calls
  /// visit(info, pointer to the member) for each member.
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit) {
    using core::Dim;
    using core::FieldInfo;
    visit(FieldInfo{"lambda", "", false, false}, &IdentifierSettings::lambda);
    visit(FieldInfo{"w0", "subsystem state units", false, false, Dim::Nw, Dim::One}, &IdentifierSettings::w0);
    visit(FieldInfo{"S0", "", false, false, Dim::Nw, Dim::Nw}, &IdentifierSettings::S0);
    visit(FieldInfo{"prior_weight", "", false, false}, &IdentifierSettings::prior_weight);
    visit(FieldInfo{"eig_floor", "", false, false}, &IdentifierSettings::eig_floor);
    visit(FieldInfo{"pw_scale", "", false, false}, &IdentifierSettings::pw_scale);
  }
};

/// The recursive estimate of one subsystem's exogenous input; allocation-free after construction.
class ForgettingFactorIdentifier {
 public:
  /// Validates the settings and starts at the prior.
  /// @param settings the identifier's settings (validated: std::invalid_argument).
  explicit ForgettingFactorIdentifier(const IdentifierSettings& settings = IdentifierSettings{});

  /// Back to the prior (k = 0).
  void reset();
  /// Folds the measured input w_k in. A non-finite w_k is not folded in (the estimate is kept).
  /// @param w_k the measured exogenous input (subsystem state units).
  /// @return false if w_k was not finite (and was ignored), true otherwise.
  bool update(const SubVector& w_k);

  /// @return the mean estimate w^_k (subsystem state units).
  const SubVector& w_hat() const { return w_hat_; }
  /// @return the covariance estimate S^_k, symmetric, eigenvalue-floored (squared state units).
  const SubMatrix& S_hat() const { return S_hat_; }
  /// @return the disturbance set's shape P_W = pw_scale S^_k.
  SubMatrix P_W() const { return settings_.pw_scale * S_hat_; }
  /// @return zeta_k, the weight of the estimate.
  double zeta() const { return zeta_; }
  /// @return the number of inputs folded in.
  int updates() const { return k_; }
  /// @return q = e^(lambda - 1).
  double q() const { return q_; }
  /// @return the settings.
  const IdentifierSettings& settings() const { return settings_; }

 private:
  void floor_covariance();
  IdentifierSettings settings_;
  double q_ = 0.0;
  SubVector d_;  // sqrt(diag(S0))
  SubVector w_hat_;
  SubMatrix S_;      // the exact recursion
  SubMatrix S_hat_;  // S_ floored
  double zeta_ = 0.0;
  int k_ = 0;
};

}  // namespace tubempc::control
