// Control allocation by a bounded least-squares active-set method (see allocation.hpp).
#include "tubempc/actuators/allocation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

namespace tubempc::actuators {

namespace {

enum : int { kFree = 0, kLower = 1, kUpper = 2, kFixed = 3 };

}  // namespace

Vector6 wrench_from_input(const Vector6& u, const Eigen::Matrix3d& C_BL, double mass) {
  Vector6 w;
  w.head<3>() = mass * (C_BL * u.head<3>());
  w.tail<3>() = u.tail<3>();
  return w;
}

Vector6 input_from_wrench(const Vector6& w_B, const Eigen::Matrix3d& C_BL, double mass) {
  Vector6 u;
  u.head<3>() = C_BL.transpose() * w_B.head<3>() / mass;
  u.tail<3>() = w_B.tail<3>();
  return u;
}

std::string to_string(AllocationStatus status) { return core::enum_name(status); }

void AllocationSettings::validate() const {
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!positive(period)) throw std::invalid_argument("allocation.period: must be finite and > 0 (s)");
  for (int i = 0; i < 6; ++i)
    if (!positive(residual_weight(i)))
      throw std::invalid_argument("allocation.residual_weight: every weight must be finite and > 0");
  if (!positive(thrust_weight))
    throw std::invalid_argument("allocation.thrust_weight: must be finite and > 0 (1/N)");
  if (!positive(wheel_weight))
    throw std::invalid_argument("allocation.wheel_weight: must be finite and > 0 (1/(N m))");
  if (!positive(dump_weight))
    throw std::invalid_argument("allocation.dump_weight: must be finite and > 0 (1/(N m))");
  if (max_iterations < 1) throw std::invalid_argument("allocation.max_iterations: must be >= 1");
  if (!positive(optimality_tolerance))
    throw std::invalid_argument("allocation.optimality_tolerance: must be > 0");
  if (!positive(remainder_tolerance))
    throw std::invalid_argument("allocation.remainder_tolerance: must be > 0");
  if (!(cone_test_scale > 0.0 && cone_test_scale <= 1.0))
    throw std::invalid_argument("allocation.cone_test_scale: must be in (0, 1]");
}

Allocator::Allocator(const ThrusterCluster& cluster, const ReactionWheels& wheels,
                     const AllocationSettings& settings)
    : settings_(settings), n_(cluster.size()), m_(wheels.size()), nv_(n_ + m_) {
  settings_.validate();
  M_ = Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, nv_);
  M_.leftCols(n_) = cluster.mapping();
  M_.block(3, n_, 3, m_) = wheels.axes_B();
  wx2_.resize(nv_);
  wx2_dump_.resize(nv_);
  for (int i = 0; i < nv_; ++i) {
    const double w = i < n_ ? settings_.thrust_weight : settings_.wheel_weight;
    const double wd = i < n_ ? settings_.thrust_weight : settings_.dump_weight;
    wx2_(i) = w * w;
    wx2_dump_(i) = wd * wd;
  }
  const Vector6 wr2 = settings_.residual_weight.cwiseAbs2();
  const Eigen::MatrixXd H = M_.transpose() * wr2.asDiagonal() * M_;
  H_ = H;
  H_dump_ = H;
  for (int i = 0; i < nv_; ++i) {
    H_(i, i) += wx2_(i);
    H_dump_(i, i) += wx2_dump_(i);
  }
  faults_ = Eigen::VectorXi::Constant(n_, -1);  // forces the first solve's set-up
  extra_off_ = Eigen::VectorXi::Zero(n_);
  for (VarVector* v : {&lo_, &hi_, &pref_, &g_, &x_, &x_cone_, &grad_, &xf_, &step_}) v->setZero(nv_);
  state_.setZero(nv_);
  free_.setZero(nv_);
  Hf_.setZero(nv_, nv_);
  llt_.compute(H_);  // sizes the factorisation's storage
  wheel_lo_ = Eigen::VectorXd::Zero(m_);
  wheel_hi_ = Eigen::VectorXd::Zero(m_);
  wheel_pref_ = Eigen::VectorXd::Zero(m_);
  result_.thrust = Eigen::VectorXd::Zero(n_);
  result_.wheel_torque = Eigen::VectorXd::Zero(m_);
}

void Allocator::set_extra_failures(const Eigen::VectorXi& failed_off) {
  if (failed_off.size() == 0) {
    extra_off_.setZero();
    return;
  }
  if (failed_off.size() != n_)
    throw std::invalid_argument("set_extra_failures: expected " + std::to_string(n_) + " flags");
  extra_off_ = failed_off;
}

double Allocator::weighted_inf(const Vector6& r) const {
  return (settings_.residual_weight.cwiseProduct(r)).cwiseAbs().maxCoeff();
}

void Allocator::set_bounds(const ThrusterCluster& cluster, const ReactionWheels& wheels, double t) {
  bool changed = false;
  int failed = 0;
  for (int j = 0; j < n_; ++j) {
    const FaultKind k = cluster.fault_at(j, t);
    const int code = extra_off_(j) != 0 ? 1 : static_cast<int>(k);
    changed = changed || code != faults_(j);
    faults_(j) = code;
    failed += code != 0;
    const double f_max = cluster.max_thrust()(j);
    lo_(j) = code == static_cast<int>(FaultKind::StuckOn) ? f_max : 0.0;
    hi_(j) = code == static_cast<int>(FaultKind::None) ? f_max : lo_(j);
    pref_(j) = 0.0;
  }
  wheels.torque_bounds(settings_.period, wheel_lo_, wheel_hi_);
  wheels.preferred_torque(wheel_pref_);
  for (int j = 0; j < m_; ++j) {
    lo_(n_ + j) = wheel_lo_(j);
    hi_(n_ + j) = wheel_hi_(j);
    pref_(n_ + j) = std::clamp(wheel_pref_(j), wheel_lo_(j), wheel_hi_(j));
  }
  dumping_ = wheels.dumping();
  result_.info.resetup = changed;
  result_.info.failed_thrusters = failed;
  result_.info.dumping = dumping_;
}

int Allocator::active_set(const VarVector& g, VarVector& x, bool& converged) {
  const VarMatrix& H = dumping_ ? H_dump_ : H_;
  converged = false;
  double scale = 1.0;
  for (int i = 0; i < nv_; ++i) {
    x(i) = std::clamp(x(i), lo_(i), hi_(i));
    if (lo_(i) == hi_(i)) {
      state_(i) = kFixed;
    } else if (x(i) == lo_(i)) {
      state_(i) = kLower;
    } else if (x(i) == hi_(i)) {
      state_(i) = kUpper;
    } else {
      state_(i) = kFree;
    }
    scale = std::max(scale, std::abs(g(i)));
  }
  const double tol = settings_.optimality_tolerance * scale;
  for (int it = 1; it <= settings_.max_iterations; ++it) {
    int nf = 0;
    for (int i = 0; i < nv_; ++i)
      if (state_(i) == kFree) free_(nf++) = i;
    if (nf > 0) {
      // The minimiser over the free variables with the others at their bounds: H_FF x_F = g_F - H_FB x_B.
      Hf_.resize(nf, nf);
      xf_.resize(nf);
      for (int a = 0; a < nf; ++a) {
        const int i = free_(a);
        double rhs = g(i);
        for (int k = 0; k < nv_; ++k)
          if (state_(k) != kFree) rhs -= H(i, k) * x(k);
        xf_(a) = rhs;
        for (int b = 0; b < nf; ++b) Hf_(a, b) = H(i, free_(b));
      }
      llt_.compute(Hf_);
      if (llt_.info() != Eigen::Success) return it;
      llt_.solveInPlace(xf_);
      // Longest step towards it that stays within the bounds; the first bound hit joins the active set.
      double alpha = 1.0;
      int block = -1, block_state = kFree;
      for (int a = 0; a < nf; ++a) {
        const int i = free_(a);
        const double p = xf_(a) - x(i);
        if (xf_(a) < lo_(i) && p < 0.0) {
          const double s = (lo_(i) - x(i)) / p;
          if (s < alpha) alpha = s, block = i, block_state = kLower;
        } else if (xf_(a) > hi_(i) && p > 0.0) {
          const double s = (hi_(i) - x(i)) / p;
          if (s < alpha) alpha = s, block = i, block_state = kUpper;
        }
      }
      alpha = std::max(alpha, 0.0);
      for (int a = 0; a < nf; ++a) {
        const int i = free_(a);
        x(i) = std::clamp(x(i) + alpha * (xf_(a) - x(i)), lo_(i), hi_(i));
      }
      if (block >= 0) {
        x(block) = block_state == kLower ? lo_(block) : hi_(block);
        state_(block) = block_state;
        continue;
      }
    }
    // Optimal on this active set: release the bound whose multiplier has the wrong sign the most.
    int worst = -1;
    double worst_v = tol;
    for (int i = 0; i < nv_; ++i) {
      if (state_(i) != kLower && state_(i) != kUpper) continue;
      double grad = -g(i);
      for (int k = 0; k < nv_; ++k) grad += H(i, k) * x(k);
      const double v = state_(i) == kLower ? -grad : grad;
      if (v > worst_v) worst_v = v, worst = i;
    }
    if (worst < 0) {
      converged = true;
      return it;
    }
    state_(worst) = kFree;
  }
  return settings_.max_iterations;
}

const AllocationResult& Allocator::solve(const ThrusterCluster& cluster, const ReactionWheels& wheels,
                                         double t, const Vector6& w_B) {
  const auto t0 = std::chrono::steady_clock::now();
  if (cluster.size() != n_ || wheels.size() != m_)
    throw std::invalid_argument("allocate: expected " + std::to_string(n_) + " thrusters and " +
                                std::to_string(m_) + " wheels (the allocator's)");
  set_bounds(cluster, wheels, t);
  AllocationInfo& info = result_.info;
  info.iterations = 0;
  const Vector6 wr2 = settings_.residual_weight.cwiseAbs2();
  const VarVector& wx2 = dumping_ ? wx2_dump_ : wx2_;
  auto gradient = [&](const Vector6& w, const VarVector& pref, VarVector& g) {
    const Vector6 ww = wr2.cwiseProduct(w);
    for (int i = 0; i < nv_; ++i) g(i) = M_.col(i).dot(ww) + wx2(i) * pref(i);
  };
  auto wrench = [&](const VarVector& x) {
    Vector6 w = Vector6::Zero();
    for (int i = 0; i < nv_; ++i) w += M_.col(i) * x(i);
    return w;
  };
  bool converged = true;
  if (!w_B.allFinite()) {
    w_last_.setZero();
    for (int i = 0; i < nv_; ++i) x_(i) = i < n_ ? lo_(i) : std::clamp(0.0, lo_(i), hi_(i));
    result_.wrench_B = wrench(x_);
    result_.remainder_B.setZero();
    info.remainder_norm = 0.0;
    info.status = AllocationStatus::InvalidCommand;
  } else {
    w_last_ = w_B;
    gradient(w_B, pref_, g_);
    info.iterations = active_set(g_, x_, converged);
    result_.wrench_B = wrench(x_);
    result_.remainder_B = w_B - result_.wrench_B;
    info.remainder_norm = weighted_inf(result_.remainder_B);
    const double tol = settings_.remainder_tolerance * (weighted_inf(w_B) + 1.0);
    if (!converged || !x_.head(nv_).allFinite()) {
      info.status = AllocationStatus::MaxIterations;
    } else if (info.remainder_norm <= tol) {
      info.status = info.failed_thrusters > 0 ? AllocationStatus::ThrusterFailed : AllocationStatus::Ok;
    } else {
      // Is the direction producible? Allocate a small step c (w - w_base) from the actuators' rest point.
      const double c = settings_.cone_test_scale;
      for (int i = 0; i < nv_; ++i) x_cone_(i) = i < n_ ? lo_(i) : 0.0;
      const Vector6 w_base = wrench(x_cone_);
      const Vector6 w2 = w_base + c * (w_B - w_base);
      step_ = x_cone_;
      gradient(w2, step_, grad_);
      bool converged2 = true;
      info.iterations += active_set(grad_, x_cone_, converged2);
      const double r2 = weighted_inf(w2 - wrench(x_cone_));
      const bool producible = r2 <= settings_.remainder_tolerance * c * (weighted_inf(w_B - w_base) + 1.0);
      info.status = !converged2  ? AllocationStatus::MaxIterations
                    : producible ? AllocationStatus::Saturated
                                 : AllocationStatus::Infeasible;
    }
  }
  if (!x_.head(nv_).allFinite()) {  // defensive: never hand out a non-finite allocation
    for (int i = 0; i < nv_; ++i) x_(i) = i < n_ ? lo_(i) : 0.0;
    result_.wrench_B = wrench(x_);
    result_.remainder_B.setZero();
    info.status = AllocationStatus::MaxIterations;
  }
  result_.thrust = x_.head(n_);
  result_.wheel_torque = x_.segment(n_, m_);
  info.solve_time = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result_;
}

void Allocator::last_problem(Eigen::MatrixXd& A, Eigen::VectorXd& b, Eigen::VectorXd& lower,
                             Eigen::VectorXd& upper) const {
  const VarVector& wx2 = dumping_ ? wx2_dump_ : wx2_;
  A = Eigen::MatrixXd::Zero(6 + nv_, nv_);
  b = Eigen::VectorXd::Zero(6 + nv_);
  A.topRows(6) = settings_.residual_weight.asDiagonal() * M_;
  b.head(6) = settings_.residual_weight.cwiseProduct(w_last_);
  for (int i = 0; i < nv_; ++i) {
    const double wx = std::sqrt(wx2(i));
    A(6 + i, i) = wx;
    b(6 + i) = wx * pref_(i);
  }
  lower = lo_.head(nv_);
  upper = hi_.head(nv_);
}

}  // namespace tubempc::actuators
