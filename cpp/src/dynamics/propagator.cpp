#include "tubempc/dynamics/propagator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace tubempc::dynamics {
namespace {

void normalize_quaternion(TruthState& s) { s.segment<4>(6) /= s.segment<4>(6).norm(); }

struct Rhs {
  const ProximityModel& model;
  const InputVector& u;
  const Disturbance& d;
  int* evaluations;
  gravity::ExpansionHold* gravity_hold;  // nullptr: the field at every evaluation
  TruthState operator()(double t, const TruthState& s) const {
    ++*evaluations;
    // A stage built from a non-finite derivative propagates NaN to the step's status check instead
    // of reaching the gravity model or the quaternion normalisation (which would throw).
    constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
    if (!s.allFinite()) return TruthState::Constant(kNaN);
    const Disturbance6 w = d(t, s);
    if (!w.allFinite()) return TruthState::Constant(kNaN);
    if (gravity_hold != nullptr && !gravity_hold->hold(*model.gravity(), model.C_AL(t) * s.head<3>()))
      return TruthState::Constant(kNaN);
    return model.truth_derivative(t, s, u, w, gravity_hold);
  }
};

PropagationResult rk4(const Rhs& f, double t0, TruthState y, double dt, int substeps) {
  PropagationResult res;
  const double h = dt / substeps;
  double t = t0;
  for (int i = 0; i < substeps; ++i) {
    const TruthState k1 = f(t, y);
    const TruthState k2 = f(t + 0.5 * h, y + 0.5 * h * k1);
    const TruthState k3 = f(t + 0.5 * h, y + 0.5 * h * k2);
    const TruthState k4 = f(t + h, y + h * k3);
    TruthState y1 = y + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    if (!y1.allFinite()) {
      res.status = PropagationStatus::NonFinite;
      break;
    }
    normalize_quaternion(y1);
    y = y1;
    t = (i + 1 == substeps) ? t0 + dt : t + h;
    ++res.steps;
  }
  res.state = y;
  res.t = t;
  return res;
}

// Weighted RMS norm (Hairer, Norsett, Wanner, II.4).
double error_norm(const TruthState& err, const TruthState& y0, const TruthState& y1, double rtol,
                  double atol) {
  const TruthState scale = (atol + rtol * y0.cwiseAbs().cwiseMax(y1.cwiseAbs()).array()).matrix();
  return std::sqrt((err.cwiseQuotient(scale)).squaredNorm() / kNtruth);
}

PropagationResult dopri5(const Rhs& f, double t0, TruthState y, double dt, const PropagatorSettings& s) {
  // Dormand-Prince 5(4) tableau.
  constexpr double c2 = 1.0 / 5, c3 = 3.0 / 10, c4 = 4.0 / 5, c5 = 8.0 / 9;
  constexpr double a21 = 1.0 / 5;
  constexpr double a31 = 3.0 / 40, a32 = 9.0 / 40;
  constexpr double a41 = 44.0 / 45, a42 = -56.0 / 15, a43 = 32.0 / 9;
  constexpr double a51 = 19372.0 / 6561, a52 = -25360.0 / 2187, a53 = 64448.0 / 6561, a54 = -212.0 / 729;
  constexpr double a61 = 9017.0 / 3168, a62 = -355.0 / 33, a63 = 46732.0 / 5247, a64 = 49.0 / 176,
                   a65 = -5103.0 / 18656;
  constexpr double b1 = 35.0 / 384, b3 = 500.0 / 1113, b4 = 125.0 / 192, b5 = -2187.0 / 6784, b6 = 11.0 / 84;
  // e = b - b_hat (5th minus 4th order weights).
  constexpr double e1 = 71.0 / 57600, e3 = -71.0 / 16695, e4 = 71.0 / 1920, e5 = -17253.0 / 339200,
                   e6 = 22.0 / 525, e7 = -1.0 / 40;

  PropagationResult res;
  const double t_end = t0 + dt;
  double t = t0;
  res.state = y;
  res.t = t;
  if (dt == 0.0) return res;
  TruthState k1 = f(t, y);
  if (!k1.allFinite()) {
    res.status = PropagationStatus::NonFinite;
    return res;
  }
  double h = s.initial_step;
  if (h <= 0.0) {
    // Hairer's starting step (II.4, "Starting step size").
    const TruthState sc = (s.atol + s.rtol * y.cwiseAbs().array()).matrix();
    const double d0 = std::sqrt(y.cwiseQuotient(sc).squaredNorm() / kNtruth);
    const double d1 = std::sqrt(k1.cwiseQuotient(sc).squaredNorm() / kNtruth);
    double h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    h0 = std::min(h0, dt);
    const TruthState k_e = f(t + h0, y + h0 * k1);
    const double d2 = std::sqrt((k_e - k1).cwiseQuotient(sc).squaredNorm() / kNtruth) / h0;
    const double h1 =
        std::max(d1, d2) <= 1e-15 ? std::max(1e-6, h0 * 1e-3) : std::pow(0.01 / std::max(d1, d2), 1.0 / 5.0);
    h = std::min(100.0 * h0, h1);
  }
  h = std::min(h, dt);
  int budget = s.max_steps;
  bool non_finite_trial = false;
  while (t < t_end) {
    if (budget-- <= 0) {
      res.status = PropagationStatus::MaxStepsReached;
      break;
    }
    bool last = false;
    if (t + h >= t_end || t_end - (t + h) < 1e-12 * std::max(1.0, std::abs(t_end))) {
      h = t_end - t;
      last = true;
    }
    if (h < 1e-14 * std::max(1.0, std::abs(t))) {
      res.status = non_finite_trial ? PropagationStatus::NonFinite : PropagationStatus::StepTooSmall;
      break;
    }
    const TruthState k2 = f(t + c2 * h, y + h * (a21 * k1));
    const TruthState k3 = f(t + c3 * h, y + h * (a31 * k1 + a32 * k2));
    const TruthState k4 = f(t + c4 * h, y + h * (a41 * k1 + a42 * k2 + a43 * k3));
    const TruthState k5 = f(t + c5 * h, y + h * (a51 * k1 + a52 * k2 + a53 * k3 + a54 * k4));
    const TruthState k6 = f(t + h, y + h * (a61 * k1 + a62 * k2 + a63 * k3 + a64 * k4 + a65 * k5));
    TruthState y1 = y + h * (b1 * k1 + b3 * k3 + b4 * k4 + b5 * k5 + b6 * k6);
    const TruthState k7 = f(t + h, y1);
    const TruthState err = h * (e1 * k1 + e3 * k3 + e4 * k4 + e5 * k5 + e6 * k6 + e7 * k7);
    const double en = error_norm(err, y, y1, s.rtol, s.atol);
    if (!std::isfinite(en) || !y1.allFinite()) {
      // Non-finite trial: shrink hard; give up (NonFinite) once the step is negligible.
      non_finite_trial = true;
      ++res.rejected_steps;
      h *= 0.1;
      continue;
    }
    if (en <= 1.0) {
      t = last ? t_end : t + h;
      normalize_quaternion(y1);
      y = y1;
      // FSAL: k7 (at y1 before the O(tolerance) quaternion renormalisation) starts the next step.
      k1 = k7;
      ++res.steps;
      res.state = y;
      res.t = t;
      non_finite_trial = false;
      h *= std::min(5.0, std::max(0.2, 0.9 * std::pow(std::max(en, 1e-10), -0.2)));
    } else {
      ++res.rejected_steps;
      h *= std::max(0.2, 0.9 * std::pow(en, -0.2));
    }
  }
  if (res.status == PropagationStatus::Success && !res.state.allFinite())
    res.status = PropagationStatus::NonFinite;
  return res;
}

}  // namespace

const char* to_string(Integrator m) { return core::enum_name(m); }

const char* to_string(PropagationStatus s) { return core::enum_name(s); }

void PropagatorSettings::validate() const {
  if (method != Integrator::RK4 && method != Integrator::DOPRI5) {
    throw std::invalid_argument("PropagatorSettings.method: unknown value");
  }
  if (substeps < 1)
    throw std::invalid_argument("PropagatorSettings.substeps: must be >= 1, got " + std::to_string(substeps));
  if (!(std::isfinite(rtol) && rtol > 0.0))
    throw std::invalid_argument("PropagatorSettings.rtol: must be finite and > 0");
  if (!(std::isfinite(atol) && atol > 0.0))
    throw std::invalid_argument("PropagatorSettings.atol: must be finite and > 0");
  if (max_steps < 1)
    throw std::invalid_argument("PropagatorSettings.max_steps: must be >= 1, got " +
                                std::to_string(max_steps));
  if (!(std::isfinite(initial_step) && initial_step >= 0.0)) {
    throw std::invalid_argument("PropagatorSettings.initial_step: must be finite and >= 0 (s)");
  }
  if (!(std::isfinite(gravity_expansion_tolerance) && gravity_expansion_tolerance >= 0.0)) {
    throw std::invalid_argument(
        "PropagatorSettings.gravity_expansion_tolerance: must be finite and >= 0 (m/s^2)");
  }
}

PropagationResult propagate(const ProximityModel& model, double t0, const TruthState& state,
                            const InputVector& u, double dt, const Disturbance& disturbance,
                            const PropagatorSettings& settings, gravity::ExpansionHold* gravity_hold) {
  settings.validate();
  const double tol = settings.gravity_expansion_tolerance;
  if (tol > 0.0 && gravity_hold != nullptr &&
      (gravity_hold->tolerance() != tol || gravity_hold->min_distance() != 0.0)) {
    throw std::invalid_argument(
        "propagate: the gravity::ExpansionHold's tolerance must be "
        "PropagatorSettings.gravity_expansion_tolerance "
        "and its min_distance 0");
  }
  if (!(std::isfinite(dt) && dt >= 0.0))
    throw std::invalid_argument("propagate: dt must be finite and >= 0 (s)");
  PropagationResult res;
  res.state = state;
  res.t = t0;
  if (!std::isfinite(t0) || !state.allFinite() || !u.allFinite() || !disturbance.constant.allFinite()) {
    res.status = PropagationStatus::NonFinite;
    return res;
  }
  const double qn = state.segment<4>(6).norm();
  if (std::abs(qn - 1.0) > 1e-6) {
    throw std::invalid_argument(
        "propagate: quaternion q_B/L (state[6:10]) must be unit within 1e-6, norm = " + std::to_string(qn));
  }
  TruthState y = state;
  normalize_quaternion(y);
  int evaluations = 0;
  gravity::ExpansionHold call_hold(0.0, tol);  // without the run's hold: one for this call alone
  gravity::ExpansionHold* hold = tol > 0.0 ? (gravity_hold != nullptr ? gravity_hold : &call_hold) : nullptr;
  const Rhs f{model, u, disturbance, &evaluations, hold};
  if (dt == 0.0) {
    res.state = y;
    return res;
  }
  res = settings.method == Integrator::RK4 ? rk4(f, t0, y, dt, settings.substeps)
                                           : dopri5(f, t0, y, dt, settings);
  res.evaluations = evaluations;
  return res;
}

}  // namespace tubempc::dynamics
