#include "tubempc/control/abort.hpp"

#include <stdexcept>
#include <string>
#include <utility>

namespace tubempc::control {

const char* to_string(AbortMode m) { return core::enum_name(m); }

const char* to_string(AbortCause c) { return core::enum_name(c); }

void AbortSettings::validate() const {
  if (commit_step < -1)
    throw std::invalid_argument("abort.commit_step: must be >= -1, got " + std::to_string(commit_step));
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

}  // namespace

SafeAbort::SafeAbort(std::shared_ptr<const math::LinearizedModel> model, mpc::Settings mpc_settings,
                     ControllerSettings controller_settings, AbortSettings settings)
    : settings_(validated(settings)),
      controller_(std::move(model), std::move(mpc_settings),
                  abort_controller_settings(std::move(controller_settings))) {}

void SafeAbort::setup(const mpc::Reference& hover, const ControllerDesigns& designs) {
  if (designs.library_p.empty() || designs.library_r.empty())
    throw std::invalid_argument("SafeAbort::setup: the abort's designs need a library per subsystem");
  controller_.setup(hover, designs);
  decision_ = AbortDecision{};
}

void SafeAbort::reset() {
  controller_.reset();
  decision_ = AbortDecision{};
}

const AbortDecision& SafeAbort::monitor(int k, const AbortTriggers& triggers, const Controller* descent) {
  if (k < 0) throw std::invalid_argument("SafeAbort::monitor: k must be >= 0, got " + std::to_string(k));
  if (decision_.mode == AbortMode::Aborting) return decision_;
  AbortCause cause = AbortCause::None;
  if (triggers.command)
    cause = AbortCause::Command;
  else if (triggers.navigation_fault && settings_.on_navigation_fault)
    cause = AbortCause::NavigationFault;
  else if (triggers.tube_uncertified && settings_.on_tube_uncertified)
    cause = AbortCause::TubeUncertified;
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
