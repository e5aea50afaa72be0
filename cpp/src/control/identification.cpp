#include "tubempc/control/identification.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace tubempc::control {

namespace {

[[noreturn]] void fail(const char* what, const char* field, const std::string& why) {
  throw std::invalid_argument(std::string(what) + "." + field + ": " + why);
}

SubMatrix sym(const SubMatrix& M) { return 0.5 * (M + M.transpose()); }

}  // namespace

void IdentifierSettings::validate(const char* what) const {
  if (!(std::isfinite(lambda) && lambda > 0.0 && lambda < 1.0))
    fail(what, "lambda", "must lie in (0, 1), got " + std::to_string(lambda));
  if (!w0.allFinite()) fail(what, "w0", "must be finite");
  if (!S0.allFinite()) fail(what, "S0", "must be finite");
  if ((S0 - S0.transpose()).cwiseAbs().maxCoeff() > 1e-12 * S0.cwiseAbs().maxCoeff())
    fail(what, "S0", "must be symmetric");
  Eigen::SelfAdjointEigenSolver<SubMatrix> eig(sym(S0), Eigen::EigenvaluesOnly);
  if (eig.info() != Eigen::Success || !(eig.eigenvalues().minCoeff() > 0.0))
    fail(what, "S0", "must be positive definite");
  if (!(std::isfinite(prior_weight) && prior_weight >= 0.0))
    fail(what, "prior_weight", "must be finite and >= 0, got " + std::to_string(prior_weight));
  if (!(std::isfinite(eig_floor) && eig_floor > 0.0))
    fail(what, "eig_floor", "must be finite and > 0, got " + std::to_string(eig_floor));
  if (!(std::isfinite(pw_scale) && pw_scale > 0.0))
    fail(what, "pw_scale", "must be finite and > 0, got " + std::to_string(pw_scale));
}

ForgettingFactorIdentifier::ForgettingFactorIdentifier(const IdentifierSettings& settings)
    : settings_(settings) {
  settings_.validate();
  q_ = std::exp(settings_.lambda - 1.0);
  d_ = settings_.S0.diagonal().cwiseSqrt();
  reset();
}

void ForgettingFactorIdentifier::reset() {
  w_hat_ = settings_.w0;
  S_ = sym(settings_.S0);
  zeta_ = settings_.prior_weight;
  k_ = 0;
  floor_covariance();
}

bool ForgettingFactorIdentifier::update(const SubVector& w_k) {
  if (!w_k.allFinite()) return false;
  const double zeta_next = q_ * (zeta_ + 1.0);
  const double g = q_ / zeta_next;
  const SubVector w_next = g * (zeta_ * w_hat_ + w_k);
  const SubVector dw = w_k - w_next;
  S_ = sym(g * (zeta_ * S_ + dw * dw.transpose()));
  w_hat_ = w_next;
  zeta_ = zeta_next;
  ++k_;
  floor_covariance();
  return true;
}

void ForgettingFactorIdentifier::floor_covariance() {
  const SubMatrix dd = d_ * d_.transpose();
  const SubMatrix Ss = sym(S_.cwiseQuotient(dd));
  Eigen::SelfAdjointEigenSolver<SubMatrix> eig(Ss);
  const SubVector lam = eig.eigenvalues().cwiseMax(settings_.eig_floor);
  const SubMatrix& V = eig.eigenvectors();
  const SubMatrix floored = V * lam.asDiagonal() * V.transpose();
  S_hat_ = sym(floored).cwiseProduct(dd);
}

}  // namespace tubempc::control
