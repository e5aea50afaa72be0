#include "tubempc/control/abort.hpp"

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace tubempc::control {

const char* to_string(AbortMode m) { return core::enum_name(m); }

const char* to_string(AbortCause c) { return core::enum_name(c); }

void AbortSettings::validate() const {
  if (commit_step < -1)
    throw std::invalid_argument("abort.commit_step: must be >= -1, got " + std::to_string(commit_step));
  if (!(disturbance_limit > 0.0))  // +inf allowed: no limit; NaN refused
    throw std::invalid_argument("abort.disturbance_limit: must be > 0, got " +
                                std::to_string(disturbance_limit));
  if (input_nis_window < 1 || input_nis_window > kMaxInputNisWindow)
    throw std::invalid_argument("abort.input_nis_window: must be in [1, " +
                                std::to_string(kMaxInputNisWindow) + "], got " +
                                std::to_string(input_nis_window));
  if (!(input_nis_limit > 0.0))
    throw std::invalid_argument("abort.input_nis_limit: must be > 0, got " + std::to_string(input_nis_limit));
}

namespace {

// The abort's controller settings: its tube updated and certified at every step from the set-up library (no
// background designs: nothing outside the step decides the abort's tube).
ControllerSettings abort_controller_settings(ControllerSettings s) {
  s.method = Method::Ffa;
  s.tube.background_designs = false;
  return s;
}

const AbortSettings& validated(const AbortSettings& s) {
  s.validate();
  return s;
}

// Whether a subsystem's value exceeds the limit; a non-finite value (NaN: a state or set that cannot be judged)
// counts as beyond.
bool beyond(const std::array<double, 2>& values, double limit) {
  return !(values[0] <= limit) || !(values[1] <= limit);
}

}  // namespace

SafeAbort::SafeAbort(std::shared_ptr<const math::LinearizedModel> model, mpc::Settings mpc_settings,
                     ControllerSettings controller_settings, const AbortSettings& settings)
    : settings_(validated(settings)),
      controller_(std::move(model), std::move(mpc_settings),
                  abort_controller_settings(std::move(controller_settings))) {}

void SafeAbort::setup(const mpc::Reference& hover, const ControllerDesigns& designs) {
  if (designs.library_p.empty() || designs.library_r.empty())
    throw std::invalid_argument("SafeAbort::setup: the abort's designs need a library per subsystem");
  controller_.setup(hover, designs);
  decision_ = AbortDecision{};
  nis_ring_ = {};
  nis_next_ = 0;
}

void SafeAbort::reset() {
  controller_.reset();
  decision_ = AbortDecision{};
  nis_ring_ = {};
  nis_next_ = 0;
}

std::array<double, 2> SafeAbort::input_nis_mean() const {
  std::array<double, 2> sum{0.0, 0.0};
  for (int j = 0; j < settings_.input_nis_window; ++j)
    for (int s = 0; s < 2; ++s) sum[s] += nis_ring_[j][s];
  return {sum[0] / settings_.input_nis_window, sum[1] / settings_.input_nis_window};
}

const AbortDecision& SafeAbort::monitor(int k, const AbortTriggers& triggers, const Controller* descent) {
  if (k < 0) throw std::invalid_argument("SafeAbort::monitor: k must be >= 0, got " + std::to_string(k));
  if (decision_.mode == AbortMode::Aborting) return decision_;
  for (int s = 0; s < 2; ++s)  // the window: this step's value over the oldest (non-finite: counted as 0)
    nis_ring_[nis_next_][s] = std::isfinite(triggers.input_nis[s]) ? triggers.input_nis[s] : 0.0;
  nis_next_ = (nis_next_ + 1) % settings_.input_nis_window;
  const std::array<double, 2> nis = input_nis_mean();
  AbortCause cause = AbortCause::None;
  if (triggers.command)
    cause = AbortCause::Command;
  else if (triggers.navigation_fault && settings_.on_navigation_fault)
    cause = AbortCause::NavigationFault;
  else if (triggers.tube_uncertified && settings_.on_tube_uncertified)
    cause = AbortCause::TubeUncertified;
  else if (settings_.on_estimate_outside_tube && beyond(triggers.excursion, 1.0 + kExcursionTolerance))
    cause = AbortCause::EstimateOutsideTube;
  else if (settings_.on_input_nis && beyond(nis, settings_.input_nis_limit))
    cause = AbortCause::InputNis;
  else if (settings_.on_disturbance_beyond_limit &&
           beyond(triggers.disturbance_ratio, settings_.disturbance_limit))
    cause = AbortCause::DisturbanceBeyondLimit;
  else if (triggers.allocation_infeasible && settings_.on_allocation_infeasible)
    cause = AbortCause::AllocationInfeasible;
  const bool armed = k <= settings_.commit_step;
  decision_.mode = armed ? AbortMode::Armed : AbortMode::Committed;
  if (cause == AbortCause::None) return decision_;
  if (armed) {
    if (descent != nullptr) controller_.inherit_identification(*descent);
    decision_.mode = AbortMode::Aborting;
    decision_.cause = cause;
    decision_.entered_at = k;
  } else if (decision_.refused_cause == AbortCause::None) {
    decision_.refused_cause = cause;
    decision_.refused_at = k;
  }
  return decision_;
}

const ControlStep& SafeAbort::step(int k, const Eigen::Ref<const Eigen::VectorXd>& x_k) {
  return controller_.step(k, x_k);
}

void SafeAbort::set_estimation_error(const Eigen::Ref<const Eigen::MatrixXd>& P_est) {
  controller_.set_estimation_error(P_est);
}

}  // namespace tubempc::control
