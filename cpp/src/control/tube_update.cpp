#include "tubempc/control/tube_update.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace tubempc::control {

namespace {

SubMatrix sym(const SubMatrix& M) { return 0.5 * (M + M.transpose()); }

bool positive_definite(const SubMatrix& M) {
  if (!M.allFinite()) return false;
  return Eigen::LLT<SubMatrix>(sym(M)).info() == Eigen::Success;
}

}  // namespace

const char* to_string(Certification c) { return core::enum_name(c); }

const char* to_string(TubeStatus s) { return core::enum_name(s); }

bool certified(TubeStatus s) {
  return s == TubeStatus::Initial || s == TubeStatus::Lyapunov || s == TubeStatus::LyapunovNoMargin ||
         s == TubeStatus::Library || s == TubeStatus::LibraryNoMargin;
}

void SubsystemDesign::validate(const std::string& what) const {
  if (!K.allFinite()) throw std::invalid_argument(what + ".K: must be finite");
  if (!(std::isfinite(alpha) && alpha > 0.0 && alpha < 1.0))
    throw std::invalid_argument(what + ".alpha: must lie in (0, 1), got " + std::to_string(alpha));
  if (!positive_definite(P_W))
    throw std::invalid_argument(what + ".P_W: must be symmetric positive definite");
  if (!positive_definite(Pe)) throw std::invalid_argument(what + ".Pe: must be symmetric positive definite");
}

double lmi_residual(const SubMatrix& A, const SubInputMatrix& B, const SubGain& K, const SubMatrix& Pe,
                    const SubMatrix& P_W, double alpha) {
  const SubMatrix Pe_s = sym(Pe);
  const SubMatrix Acl = A + B * K;
  const SubMatrix M = Acl * Pe_s * Acl.transpose() / alpha + P_W / (1.0 - alpha) - Pe_s;
  const SubVector s = Pe_s.diagonal().cwiseSqrt().cwiseInverse();
  const SubMatrix Ms = sym(M.cwiseProduct(s * s.transpose()));
  if (!Ms.allFinite()) return std::numeric_limits<double>::infinity();
  Eigen::SelfAdjointEigenSolver<SubMatrix> eig(Ms, Eigen::EigenvaluesOnly);
  if (eig.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
  return eig.eigenvalues().maxCoeff();
}

Certification lyapunov_tube(const SubMatrix& A, const SubInputMatrix& B, const SubGain& K, double alpha,
                            const SubMatrix& P_W, double u_max, SubsystemTube& out) {
  // Pe = sum_j M^j Q (M^T)^j, M = A_K / sqrt(alpha), Q = P_W' / (1 - alpha), by doubling: after j
  // iterations X holds the first 2^j terms. The series converges iff rho(M) < 1, i.e. rho(A_K)^2 < alpha;
  // with Q > 0 a positive definite limit certifies that (Lyapunov). kLyapunovIterations bounds the cost
  // (tube_update.hpp).
  SubMatrix M = (A + B * K) / std::sqrt(alpha);
  SubMatrix X = sym(P_W) * (1.0 + kLyapunovMargin) / (1.0 - alpha);
  bool converged = false;
  for (int j = 0; j < kLyapunovIterations && !converged && X.allFinite(); ++j) {
    const SubMatrix increment = M * X * M.transpose();
    X += increment;
    converged = increment.cwiseAbs().maxCoeff() <= 1e-17 * X.cwiseAbs().maxCoeff();
    M = (M * M).eval();
  }
  const SubMatrix Pe = sym(X);
  if (!converged || !positive_definite(Pe)) return Certification::NotContractive;
  const double residual = lmi_residual(A, B, K, Pe, P_W, alpha);
  if (!(residual <= 0.0)) return Certification::InvarianceViolated;
  for (int i = 0; i < 3; ++i) {
    const double kpk = K.row(i) * Pe * K.row(i).transpose();
    if (!(std::sqrt(std::max(kpk, 0.0)) < u_max)) return Certification::EmptyTightening;
  }
  out.K = K;
  out.Pe = Pe;
  out.alpha = alpha;
  out.residual = residual;
  return Certification::Certified;
}

double cover_ratio(const SubMatrix& P, const SubMatrix& P_cover) {
  Eigen::LLT<SubMatrix> llt(sym(P_cover));
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
  SubMatrix X = llt.matrixL().solve(sym(P));
  X = llt.matrixL().solve(X.transpose().eval());
  Eigen::SelfAdjointEigenSolver<SubMatrix> eig(sym(X), Eigen::EigenvaluesOnly);
  if (eig.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
  return eig.eigenvalues().maxCoeff();
}

void TubePolicySettings::validate() const {
  if (!(std::isfinite(redesign_margin) && redesign_margin >= 0.0))
    throw std::invalid_argument("tube.redesign_margin: must be finite and >= 0, got " +
                                std::to_string(redesign_margin));
  if (alpha_search_period < 1)
    throw std::invalid_argument("tube.alpha_search_period: must be >= 1, got " +
                                std::to_string(alpha_search_period));
}

TubePolicy::TubePolicy(const TubePolicySettings& settings, double u_max, const SubsystemDesign& initial,
                       std::vector<SubsystemDesign> library, const std::string& what)
    : settings_(settings), u_max_(u_max), initial_(initial), library_(std::move(library)) {
  settings_.validate();
  if (!(std::isfinite(u_max) && u_max > 0.0))
    throw std::invalid_argument(what + ".u_max: must be finite and > 0, got " + std::to_string(u_max));
  initial_.validate(what + ".initial");
  for (std::size_t i = 0; i < library_.size(); ++i)
    library_[i].validate(what + ".library[" + std::to_string(i) + "]");
  std::stable_sort(library_.begin(), library_.end(), [](const SubsystemDesign& a, const SubsystemDesign& b) {
    return a.P_W.trace() < b.P_W.trace();
  });
  reset();
}

void TubePolicy::reset() {
  design_ = initial_;
  tube_.K = initial_.K;
  tube_.Pe = initial_.Pe;
  tube_.alpha = initial_.alpha;
  tube_.residual = 0.0;
  library_step_ = -1;
}

TubeStatus TubePolicy::update(int k, const SubMatrix& A, const SubInputMatrix& B, const SubMatrix& P_W,
                              bool design_due) {
  if (!settings_.adaptive || k == 0) {
    if (k == 0) reset();
    tube_.residual = lmi_residual(A, B, tube_.K, tube_.Pe, P_W, tube_.alpha);
    return settings_.adaptive ? TubeStatus::Initial : TubeStatus::Fixed;
  }
  const double m = settings_.redesign_margin;
  const SubMatrix P_margin = (1.0 + m) * P_W;
  if (design_due && !settings_.background_designs && from_library(A, B, P_margin, k))
    return TubeStatus::Library;
  if (lyapunov_tube(A, B, design_.K, design_.alpha, P_margin, u_max_, trial_) == Certification::Certified) {
    tube_ = trial_;
    return TubeStatus::Lyapunov;
  }
  if (m > 0.0 &&
      lyapunov_tube(A, B, design_.K, design_.alpha, P_W, u_max_, trial_) == Certification::Certified) {
    tube_ = trial_;
    return TubeStatus::LyapunovNoMargin;
  }
  if (from_library(A, B, P_margin, k)) return TubeStatus::Library;
  if (m > 0.0 && from_library(A, B, P_W, k)) return TubeStatus::LibraryNoMargin;
  tube_.residual = lmi_residual(A, B, tube_.K, tube_.Pe, P_W, tube_.alpha);  // the last tube, for this step
  return TubeStatus::Uncertified;
}

bool TubePolicy::from_library(const SubMatrix& A, const SubInputMatrix& B, const SubMatrix& P_W, int k) {
  const int n = static_cast<int>(library_.size());
  int first = n - 1;  // nothing covers P_W: only the largest design is tried
  for (int i = 0; i < n; ++i) {
    if (cover_ratio(P_W, library_[i].P_W) <= 1.0) {
      first = i;
      break;
    }
  }
  for (int i = std::max(first, 0); i < n; ++i) {
    const SubsystemDesign& d = library_[i];
    if (lyapunov_tube(A, B, d.K, d.alpha, P_W, u_max_, trial_) == Certification::Certified) {
      design_ = d;
      tube_ = trial_;
      library_step_ = k;
      return true;
    }
  }
  return false;
}

bool TubePolicy::adopt(const SubsystemDesign& design, int k_started) {
  if (!design.K.allFinite() || !std::isfinite(design.alpha) || !(design.alpha > 0.0 && design.alpha < 1.0))
    return false;
  if (k_started <= library_step_) return false;
  design_ = design;
  return true;
}

}  // namespace tubempc::control
