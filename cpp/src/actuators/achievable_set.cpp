// Inner box of the achievable wrenches and the actuation-error box (see achievable_set.hpp).
#include "tubempc/actuators/achievable_set.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace tubempc::actuators {

namespace {

// max |((1 + s) R d - d) . e| over |s| <= s_b and rotations R by at most theta, for unit d and e: R d ranges
// over the spherical cap of half-angle theta about d, whose projection on e is [cos(min(pi, a + theta)),
// cos(max(0, a - theta))] with a the angle between d and e.
double projected_error(const Eigen::Vector3d& d, const Eigen::Vector3d& e, double theta, double s_b) {
  const double c0 = std::clamp(d.dot(e), -1.0, 1.0);
  const double a = std::acos(c0);
  const double lo = std::cos(std::min(M_PI, a + theta)), hi = std::cos(std::max(0.0, a - theta));
  double worst = 0.0;
  for (double s : {-s_b, s_b})
    for (double c : {lo, hi}) worst = std::max(worst, std::abs((1.0 + s) * c - c0));
  return worst;
}

// Vertices of the force box |F_i| <= h_i cut by the octahedron |F_x| + |F_y| + |F_z| <= c (c = +inf: the box's
// eight corners). Every vertex has three independent active constraints among the box's six faces and the
// octahedron's eight: all 364 triples are solved and the feasible points kept (duplicates are harmless).
std::vector<Eigen::Vector3d> force_vertices(const Eigen::Vector3d& h, double c) {
  std::vector<Eigen::Vector3d> out;
  if (!std::isfinite(c) || c >= h.sum()) {
    for (int v = 0; v < 8; ++v)
      out.emplace_back((v & 1 ? 1.0 : -1.0) * h(0), (v & 2 ? 1.0 : -1.0) * h(1), (v & 4 ? 1.0 : -1.0) * h(2));
    return out;
  }
  std::vector<std::pair<Eigen::Vector3d, double>> planes;  // a . F = b
  for (int i = 0; i < 3; ++i)
    for (const double s : {1.0, -1.0}) planes.emplace_back(s * Eigen::Vector3d::Unit(i), h(i));
  for (int v = 0; v < 8; ++v)
    planes.emplace_back(Eigen::Vector3d((v & 1 ? 1.0 : -1.0), (v & 2 ? 1.0 : -1.0), (v & 4 ? 1.0 : -1.0)), c);
  const double tol = 1e-12 * std::max(c, h.maxCoeff());
  const int n = static_cast<int>(planes.size());
  for (int a = 0; a < n; ++a)
    for (int b = a + 1; b < n; ++b)
      for (int d = b + 1; d < n; ++d) {
        Eigen::Matrix3d M;
        M << planes[a].first.transpose(), planes[b].first.transpose(), planes[d].first.transpose();
        Eigen::FullPivLU<Eigen::Matrix3d> lu(M);
        if (lu.rank() < 3) continue;
        const Eigen::Vector3d F =
            lu.solve(Eigen::Vector3d(planes[a].second, planes[b].second, planes[d].second));
        if ((F.cwiseAbs() - h).maxCoeff() <= tol && F.cwiseAbs().sum() <= c + tol) out.push_back(F);
      }
  return out;
}

}  // namespace

void AchievableBoxSettings::validate() const {
  for (int i = 0; i < 6; ++i)
    if (!(std::isfinite(shape(i)) && shape(i) > 0.0))
      throw std::invalid_argument("achievable_box.shape: every entry must be finite and > 0");
  if (!(momentum_fraction >= 0.0 && momentum_fraction < 1.0))
    throw std::invalid_argument("achievable_box.momentum_fraction: must be in [0, 1)");
  if (bisection_steps < 1) throw std::invalid_argument("achievable_box.bisection_steps: must be >= 1");
  if (!std::isfinite(time)) throw std::invalid_argument("achievable_box.time: must be finite (s)");
}

AchievableBox achievable_box(const ThrusterCluster& cluster, const ReactionWheels& wheels,
                             const AllocationSettings& allocation, double mass,
                             const AchievableBoxSettings& settings) {
  settings.validate();
  if (!(std::isfinite(mass) && mass > 0.0))
    throw std::invalid_argument("achievable_box.mass: must be finite and > 0 (kg)");
  // The cluster with its faults at settings.time, and wheels at rest whose momentum box is the worst one within
  // momentum_fraction.
  const ThrusterCluster& healthy = cluster;
  const double t = settings.time;
  std::vector<ReactionWheelSpec> specs;
  for (int j = 0; j < wheels.size(); ++j) {
    ReactionWheelSpec s = wheels.wheel(j);
    s.max_momentum *= 1.0 - settings.momentum_fraction;
    specs.push_back(s);
  }
  MomentumDumpSettings no_dump;
  no_dump.enabled = false;
  const ReactionWheels rest(specs, no_dump);
  Allocator alloc(healthy, rest, allocation);

  // Largest |w_i| any allocation reaches: no box beyond it.
  const auto& M = alloc.mapping();
  Eigen::VectorXd cap_x(M.cols());
  for (int j = 0; j < healthy.size(); ++j) cap_x(j) = healthy.max_thrust()(j);
  for (int j = 0; j < rest.size(); ++j)
    cap_x(healthy.size() + j) = std::min(rest.max_torque()(j), rest.max_momentum()(j) / allocation.period);
  const Vector6 cap = M.cwiseAbs() * cap_x;
  double s_hi = (cap.array() / settings.shape.array()).minCoeff() * (1.0 + 1e-9) + 1e-300;

  AchievableBox box;
  auto achievable = [&](double s) {
    for (int v = 0; v < 64; ++v) {
      Vector6 w;
      for (int i = 0; i < 6; ++i) w(i) = ((v >> i) & 1 ? 1.0 : -1.0) * s * settings.shape(i);
      ++box.vertices_checked;
      const AllocationStatus st = alloc.solve(healthy, rest, t, w).info.status;
      if (st != AllocationStatus::Ok && st != AllocationStatus::ThrusterFailed) return false;
    }
    return true;
  };
  auto largest_scale = [&]() {
    double lo = 0.0, hi = s_hi;
    if (achievable(hi)) return hi;
    for (int k = 0; k < settings.bisection_steps; ++k) {
      const double mid = 0.5 * (lo + hi);
      (achievable(mid) ? lo : hi) = mid;
    }
    return lo;
  };
  if (!achievable(0.0)) {  // e.g. a stuck-on thruster the others cannot balance
    box.empty = true;
    return box;
  }
  box.scale = largest_scale();
  if (settings.tolerate_one_failure) {
    Eigen::VectorXi off = Eigen::VectorXi::Zero(healthy.size());
    for (int j = 0; j < healthy.size(); ++j) {
      if (healthy.fault_at(j, t) != FaultKind::None) continue;  // already failed
      off.setZero();
      off(j) = 1;
      alloc.set_extra_failures(off);
      s_hi = box.scale;  // one failure never enlarges the box
      const double s = largest_scale();
      if (s < box.scale) {
        box.scale = s;
        box.limiting_failure = j;
      }
    }
  }
  box.half_width_B = box.scale * settings.shape;
  const double a_F = box.half_width_B.head<3>().minCoeff();
  box.input_half_width.head<3>().setConstant(a_F / (mass * std::sqrt(3.0)));
  box.input_half_width.tail<3>() = box.half_width_B.tail<3>();
  return box;
}

namespace {

// a_ij: the largest |(error of thruster j's unit force) . c_ij| (see ActuationErrorBound::misalignment_B).
Eigen::Matrix<double, 6, Eigen::Dynamic> misalignment_gains(const ThrusterCluster& cluster) {
  Eigen::Matrix<double, 6, Eigen::Dynamic> a =
      Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, cluster.size());
  for (int j = 0; j < cluster.size(); ++j) {
    const ThrusterSpec& s = cluster.thruster(j);
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d e_i = Eigen::Vector3d::Unit(i);
      a(i, j) = projected_error(s.direction_B, e_i, s.misalignment_bound, s.scale_error_bound);
      // Torque component i: (p x v) . e_i = v . (e_i x p).
      const Eigen::Vector3d q = e_i.cross(s.position_B);
      if (q.norm() > 0.0)
        a(3 + i, j) = q.norm() *
                      projected_error(s.direction_B, q / q.norm(), s.misalignment_bound, s.scale_error_bound);
    }
  }
  return a;
}

void finish(ActuationErrorBound& e, double mass) {
  e.wrench_B = e.modulation_B + e.misalignment_B;
  e.input.head<3>().setConstant(e.wrench_B.head<3>().norm() / mass);
  e.input.tail<3>() = e.wrench_B.tail<3>();
  e.shape_p = Eigen::Matrix3d::Identity() * e.input(0) * e.input(0);
  e.shape_T = (3.0 * e.wrench_B.tail<3>().cwiseAbs2()).asDiagonal();
}

void check_common(const ThrusterCluster& cluster, const PulseModulator& modulator, double mass) {
  if (!(std::isfinite(mass) && mass > 0.0))
    throw std::invalid_argument("actuation_error_bound.mass: must be finite and > 0 (kg)");
  if (modulator.remainder().size() != cluster.size())
    throw std::invalid_argument("actuation_error_bound: the modulator and the cluster differ in size");
}

}  // namespace

ActuationErrorBound actuation_error_bound(const ThrusterCluster& cluster, const PulseModulator& modulator,
                                          double mass) {
  check_common(cluster, modulator, mass);
  ActuationErrorBound e;
  const double dt = modulator.settings().period;
  const Eigen::Matrix<double, 6, Eigen::Dynamic> a = misalignment_gains(cluster);
  for (int j = 0; j < cluster.size(); ++j) {
    const double F = cluster.max_thrust()(j);
    e.modulation_B +=
        cluster.mapping().col(j).cwiseAbs() * (F * modulator.on_time_error_bound(cluster, j) / dt);
    e.misalignment_B += a.col(j) * F;
  }
  e.thrust_norm = cluster.max_thrust().norm();
  finish(e, mass);
  return e;
}

ActuationErrorBound actuation_error_bound(const ThrusterCluster& cluster, const PulseModulator& modulator,
                                          double mass, const ReactionWheels& wheels,
                                          const AllocationSettings& allocation,
                                          const Vector6& command_half_width_B, double t,
                                          bool tolerate_one_failure, double command_force_norm) {
  check_common(cluster, modulator, mass);
  if (!(command_half_width_B.allFinite() && command_half_width_B.minCoeff() >= 0.0))
    throw std::invalid_argument("actuation_error_bound.command_half_width_B: must be finite and >= 0");
  if (!(command_force_norm > 0.0))
    throw std::invalid_argument("actuation_error_bound.command_force_norm: must be > 0 (N; inf: none)");
  ActuationErrorBound e = actuation_error_bound(cluster, modulator, mass);
  const std::vector<Eigen::Vector3d> forces =
      force_vertices(command_half_width_B.head<3>(), std::sqrt(3.0) * command_force_norm);
  // The thruster-only allocation (no wheels), its objective's maximum over the vertices of the box plus every
  // wheel torque.
  MomentumDumpSettings no_dump;
  no_dump.enabled = false;
  const ReactionWheels none({}, no_dump);
  Allocator alloc(cluster, none, allocation);
  const int m = wheels.size();
  const Vector6 wr = allocation.residual_weight;
  const double eps2 = allocation.thrust_weight * allocation.thrust_weight;
  double J_max = 0.0;
  auto sweep = [&]() {
    for (const Eigen::Vector3d& force : forces)
      for (long v = 0; v < (8L << m); ++v) {
        Vector6 w;
        w.head<3>() = force;
        for (int i = 0; i < 3; ++i) w(3 + i) = ((v >> i) & 1 ? 1.0 : -1.0) * command_half_width_B(3 + i);
        for (int j = 0; j < m; ++j)
          w.tail<3>() -= ((v >> (3 + j)) & 1 ? 1.0 : -1.0) * wheels.max_torque()(j) * wheels.axes_B().col(j);
        const AllocationResult& r = alloc.solve(cluster, none, t, w);
        if (r.info.status == AllocationStatus::MaxIterations) return false;
        J_max = std::max(J_max, wr.cwiseProduct(r.remainder_B).squaredNorm() + eps2 * r.thrust.squaredNorm());
      }
    return true;
  };
  bool converged = sweep();
  if (tolerate_one_failure) {
    Eigen::VectorXi off = Eigen::VectorXi::Zero(cluster.size());
    for (int j = 0; j < cluster.size() && converged; ++j) {
      off.setZero();
      off(j) = 1;
      alloc.set_extra_failures(off);
      converged = sweep();
    }
  }
  if (!converged) return e;  // no certified norm bound: the bound for any command
  e.thrust_norm = std::min(e.thrust_norm, std::sqrt(J_max * (1.0 + 1e-9)) / allocation.thrust_weight);
  const double dt = modulator.settings().period;
  Eigen::VectorXd carried(cluster.size());
  for (int j = 0; j < cluster.size(); ++j)
    carried(j) = cluster.max_thrust()(j) * modulator.on_time_excess_bound(cluster, j) / dt;
  const Eigen::Matrix<double, 6, Eigen::Dynamic> a = misalignment_gains(cluster);
  for (int i = 0; i < 6; ++i)
    e.misalignment_B(i) = std::min(e.misalignment_B(i), a.row(i).norm() * (e.thrust_norm + carried.norm()));
  finish(e, mass);
  return e;
}

namespace {

using Matrix6 = Eigen::Matrix<double, 6, 6>;

// log det(P_W / (1 - beta) + P_E / beta) at beta = 1 / (1 + e^-s); +inf if not positive definite.
double log_det_of_sum(const Matrix6& P_W, const Matrix6& P_E, double s) {
  const double beta = 1.0 / (1.0 + std::exp(-s));
  const Eigen::LLT<Matrix6> llt(P_W / (1.0 - beta) + P_E / beta);
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
  return 2.0 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
}

}  // namespace

Eigen::Matrix<double, 6, 6> disturbance_with_actuation_error(const Eigen::Matrix<double, 6, 6>& P_W,
                                                             const Eigen::Matrix<double, 6, 3>& B,
                                                             const Eigen::Matrix3d& E) {
  const Matrix6 P_E = B * E * B.transpose();
  // Start: the beta minimising the trace in the coordinates that make diag(P_W) = 1.
  double b2 = 0.0;
  for (int i = 0; i < 6; ++i) b2 += P_W(i, i) > 0.0 ? P_E(i, i) / P_W(i, i) : 0.0;
  const double b = std::sqrt(b2);
  if (!(b > 0.0) || !std::isfinite(b)) return P_W;
  const double s0 = std::log(b / std::sqrt(6.0));  // logit(b / (sqrt(6) + b))
  // Smallest volume: a grid of logit(beta) about s0, then golden-section refinement between the grid
  // points beside the best (fixed counts; any beta gives a containing ellipsoid).
  constexpr int kGrid = 33;
  constexpr double kSpan = 8.0, kStep = 2.0 * kSpan / (kGrid - 1);
  int best = kGrid / 2;
  double f_best = log_det_of_sum(P_W, P_E, s0);
  for (int i = 0; i < kGrid; ++i) {
    const double f = log_det_of_sum(P_W, P_E, s0 - kSpan + kStep * i);
    if (f < f_best) f_best = f, best = i;
  }
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  double lo = s0 - kSpan + kStep * (best - 1), hi = s0 - kSpan + kStep * (best + 1);
  double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo);
  double f1 = log_det_of_sum(P_W, P_E, x1), f2 = log_det_of_sum(P_W, P_E, x2);
  for (int it = 0; it < 30; ++it) {
    if (f1 <= f2) {
      hi = x2, x2 = x1, f2 = f1;
      x1 = hi - g * (hi - lo);
      f1 = log_det_of_sum(P_W, P_E, x1);
    } else {
      lo = x1, x1 = x2, f1 = f2;
      x2 = lo + g * (hi - lo);
      f2 = log_det_of_sum(P_W, P_E, x2);
    }
  }
  double s = s0 - kSpan + kStep * best;
  if (std::min(f1, f2) < f_best) s = f1 <= f2 ? x1 : x2;
  if (!std::isfinite(std::min(f_best, std::min(f1, f2)))) s = s0;
  const double beta = 1.0 / (1.0 + std::exp(-s));
  const Matrix6 P = P_W / (1.0 - beta) + P_E / beta;
  return 0.5 * (P + P.transpose());
}

}  // namespace tubempc::actuators
