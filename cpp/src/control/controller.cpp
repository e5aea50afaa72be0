#include "tubempc/control/controller.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "tubempc/actuators/achievable_set.hpp"
#include "tubempc/math/so3.hpp"

namespace tubempc::control {

namespace {

using Clock = std::chrono::steady_clock;

double seconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

constexpr int kNx = 12;
constexpr int kNu = 6;
}  // namespace

const char* to_string(Method m) { return core::enum_name(m); }

const char* to_string(MeasuredInput m) { return core::enum_name(m); }

Eigen::Matrix3d input_error_with_feedforward(const Eigen::Matrix3d& E, const Eigen::Vector3d& rho) {
  Eigen::Matrix3d box = 3.0 * rho.cwiseAbs2().asDiagonal().toDenseMatrix();
  const double a = E.trace(), b = box.trace();
  if (!(b > 0.0)) return E;
  if (!(a > 0.0)) return box;
  const double beta = std::sqrt(a / b);  // minimises the trace
  return (1.0 + 1.0 / beta) * E + (1.0 + beta) * box;
}

void ControllerSettings::validate() const {
  identification_p.validate("identification_p");
  identification_r.validate("identification_r");
  tube.validate();
  if (!(std::isfinite(feedforward_limit) && feedforward_limit > 0.0 && feedforward_limit < 1.0))
    throw std::invalid_argument("feedforward_limit: must be in (0, 1)");
  for (int s = 0; s < 2; ++s) {
    const Eigen::Matrix3d& E = actuation_error[s];
    const char* name = s == 0 ? "actuation_error[0]" : "actuation_error[1]";
    if (!E.allFinite() || !E.isApprox(E.transpose(), 1e-12) ||
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(E).eigenvalues().minCoeff() < -1e-12 * E.norm())
      throw std::invalid_argument(std::string(name) +
                                  ": must be finite, symmetric and positive semidefinite");
  }
}

Controller::Controller(std::shared_ptr<const math::LinearizedModel> model, mpc::Settings mpc_settings,
                       ControllerSettings settings)
    : model_(std::move(model)), settings_(std::move(settings)) {
  if (!model_) throw std::invalid_argument("Controller: model must not be null");
  if (model_->nx() != kNx || model_->nu() != kNu)
    throw std::invalid_argument(
        "Controller: the model must have 12 states and 6 inputs (translation + rotation)");
  settings_.tube.adaptive = settings_.method == Method::Ffa;
  settings_.validate();
  mpc_ = std::make_unique<mpc::TubeMPC>(model_, std::move(mpc_settings));
  const Eigen::VectorXd& u_max = mpc_->settings().u_max;
  u_max_ = {u_max.head(3).minCoeff(), u_max.tail(3).minCoeff()};
  if (settings_.feedforward && settings_.method == Method::Ffa)
    for (int s = 0; s < 2; ++s)
      settings_.actuation_error[s] = input_error_with_feedforward(
          settings_.actuation_error[s], settings_.feedforward_limit * u_max.segment<3>(3 * s));
  identifiers_ = {ForgettingFactorIdentifier(settings_.identification_p),
                  ForgettingFactorIdentifier(settings_.identification_r)};
  out_.u = Eigen::VectorXd::Zero(kNu);
  out_.tube.K = Eigen::MatrixXd::Zero(kNu, kNx);
  out_.tube.Pe = Eigen::MatrixXd::Zero(kNx, kNx);
  A_buf_ = Eigen::MatrixXd::Zero(kNx, kNx);
  B_buf_ = Eigen::MatrixXd::Zero(kNx, kNu);
  c_buf_ = Eigen::VectorXd::Zero(kNx);
}

Controller::~Controller() = default;

void Controller::setup(const mpc::Reference& reference, const ControllerDesigns& designs) {
  mpc_->setup(reference);
  reference_ = reference;
  const int T = mpc_->mission_steps();
  A_ref_.assign(T, {SubMatrix::Zero(), SubMatrix::Zero()});
  B_ref_.assign(T, {SubInputMatrix::Zero(), SubInputMatrix::Zero()});
  for (int k = 0; k < T; ++k) {  // the MPC's own data about the reference (setup computed them)
    mpc_->discretize(k, reference.z.col(k), reference.u.col(k), A_buf_, B_buf_, c_buf_);
    for (int s = 0; s < 2; ++s) {
      A_ref_[k][s] = A_buf_.block<6, 6>(6 * s, 6 * s);
      B_ref_[k][s] = B_buf_.block<6, 3>(6 * s, 3 * s);
    }
  }
  policies_.clear();
  policies_.reserve(2);
  policies_.emplace_back(settings_.tube, u_max_[0], designs.initial_p, designs.library_p, "designs.p");
  policies_.emplace_back(settings_.tube, u_max_[1], designs.initial_r, designs.library_r, "designs.r");
  restart();  // the MPC is fresh from its setup
}

void Controller::reset() {
  mpc_->reset();
  restart();
}

void Controller::restart() {
  for (auto& ident : identifiers_) ident.reset();
  for (auto& policy : policies_) policy.reset();
  last_k_ = -1;
  identified_k_ = -1;
  predicted_ = false;
  margin_lost_ = false;
}

void Controller::inherit_identification(const Controller& other) { identifiers_ = other.identifiers_; }

bool Controller::identify(int k, const Eigen::Ref<const Eigen::VectorXd>& x_k) {
  out_.identified = false;
  if (last_k_ < 0 || k != last_k_ + 1 || identified_k_ == k || x_k.size() != kNx) return false;
  identified_k_ = k;
  if (!predicted_) return false;
  out_.w_measured = x_k - x_pred_;
  out_.w_measured.segment<3>(6) =
      math::nearest_representative(x_k.segment<3>(6), x_pred_.segment<3>(6)) - x_pred_.segment<3>(6);
  out_.input_nis = {0.0, 0.0};
  if (!out_.w_measured.allFinite()) return false;
  for (int s = 0; s < 2; ++s) {
    // the input against the identified distribution before it is folded in (input_nis)
    const SubVector d = out_.w_measured.segment<6>(6 * s) - identifiers_[s].w_hat();
    const Eigen::LLT<SubMatrix> llt(identifiers_[s].S_hat());
    out_.input_nis[s] = llt.info() == Eigen::Success ? d.dot(llt.solve(d)) / 6.0 : 0.0;
    identifiers_[s].update(out_.w_measured.segment<6>(6 * s));
  }
  out_.identified = true;
  return true;
}

void Controller::predict(int k, const Eigen::Ref<const Eigen::VectorXd>& x_k) {
  predicted_ = false;
  if (settings_.measured_input == MeasuredInput::ReferenceDeviation) {
    x_pred_ = reference_.z.col(k + 1);
    predicted_ = true;
    return;
  }
  try {
    mpc_->discretize(k, x_k, out_.u, A_buf_, B_buf_, c_buf_);  // the gravity's blocks kept near the reference
  } catch (const std::exception&) {
    return;  // a non-finite state or model output: the next step identifies nothing
  }
  x_pred_.noalias() = A_buf_ * x_k;
  x_pred_.noalias() += B_buf_ * out_.u;
  x_pred_ += c_buf_;
  predicted_ = x_pred_.allFinite();
}

void Controller::feedforward() {
  out_.u_feedforward.setZero();
  if (!settings_.feedforward || settings_.method != Method::Ffa) return;
  const Eigen::VectorXd& u_max = mpc_->settings().u_max;
  for (int s = 0; s < 2; ++s) {
    const SubInputMatrix& B = out_.B[s];
    const Eigen::Matrix3d BtB = B.transpose() * B;
    const Eigen::Vector3d u_ff = -BtB.ldlt().solve(B.transpose() * identifiers_[s].w_hat());
    if (!u_ff.allFinite()) continue;
    for (int i = 0; i < 3; ++i) {
      const int j = 3 * s + i;
      const double rho = settings_.feedforward_limit * u_max(j);
      // Within its limit and the bounds, never further out than the MPC's own command.
      const double lo = std::max(-rho, std::min(-u_max(j) - out_.u(j), 0.0));
      const double hi = std::min(rho, std::max(u_max(j) - out_.u(j), 0.0));
      out_.u_feedforward(j) = std::clamp(u_ff(i), lo, hi);
      out_.u(j) += out_.u_feedforward(j);
    }
  }
}

void Controller::set_estimation_error(const Eigen::Ref<const Eigen::MatrixXd>& P_est) {
  if (P_est.size() == 0) {
    out_.tube.P_est.resize(0, 0);
    return;
  }
  if (P_est.rows() != kNx || P_est.cols() != kNx)
    throw std::invalid_argument("Controller::set_estimation_error: P_est must be 12 x 12 or empty");
  out_.tube.P_est = P_est;
}

const ControlStep& Controller::step(int k, const Eigen::Ref<const Eigen::VectorXd>& x_k) {
  if (policies_.empty()) throw std::invalid_argument("Controller::step: call setup first");
  const int T = mpc_->mission_steps();
  if (k < 0 || k >= T)
    throw std::invalid_argument("Controller::step: k = " + std::to_string(k) + " outside [0, " +
                                std::to_string(T) + ")");
  if (x_k.size() != kNx)
    throw std::invalid_argument("Controller::step: x_k must have 12 entries, got " +
                                std::to_string(x_k.size()));
  const auto t0 = Clock::now();
  if (identified_k_ != k) identify(k, x_k);
  const auto t1 = Clock::now();

  const bool adaptive = settings_.tube.adaptive;
  // a design is due every alpha_search_period steps, after a lost margin, and at a first step past k = 0 (the safe
  // abort's entry: its identification may have been inherited, abort.hpp)
  const bool due =
      adaptive && k > 0 && (k % settings_.tube.alpha_search_period == 0 || margin_lost_ || last_k_ < 0);
  bool lost = false;
  for (int s = 0; s < 2; ++s) {
    out_.A[s] = A_ref_[k][s];
    out_.B[s] = B_ref_[k][s];
    const IdentifierSettings& prior = identifiers_[s].settings();
    out_.disturbance_ratio[s] = cover_ratio(identifiers_[s].P_W(), prior.pw_scale * prior.S0);
    out_.P_W[s] = actuators::disturbance_with_actuation_error(identifiers_[s].P_W(), out_.B[s],
                                                              settings_.actuation_error[s]);
    const TubeStatus status = policies_[s].update(k, out_.A[s], out_.B[s], out_.P_W[s], due);
    const SubsystemTube& tube = policies_[s].tube();
    out_.tube_status[s] = status;
    out_.alpha[s] = tube.alpha;
    out_.residual[s] = tube.residual;
    out_.tube.K.block<3, 6>(3 * s, 6 * s) = tube.K;
    out_.tube.Pe.block<6, 6>(6 * s, 6 * s) = tube.Pe;
    const bool due_design = due && !settings_.tube.background_designs && status == TubeStatus::Library;
    if (adaptive && k > 0 && status != TubeStatus::Lyapunov && !due_design) lost = true;
  }
  out_.design_due = due;
  margin_lost_ = lost;
  const auto t2 = Clock::now();

  const mpc::StepResult& r = mpc_->step(k, x_k, out_.tube);
  out_.mpc = &r;
  out_.u = r.u;
  feedforward();
  const auto t3 = Clock::now();

  predict(k, x_k);
  last_k_ = k;
  const auto t4 = Clock::now();
  out_.timings.identify = seconds(t0, t1);
  out_.timings.tube = seconds(t1, t2);
  out_.timings.mpc = seconds(t2, t3);
  out_.timings.predict = seconds(t3, t4);
  out_.timings.total = seconds(t0, t4);
  return out_;
}

std::array<double, 2> Controller::excursion(const Eigen::Ref<const Eigen::VectorXd>& x) const {
  if (x.size() != kNx)
    throw std::invalid_argument("Controller::excursion: x must have 12 entries, got " +
                                std::to_string(x.size()));
  std::array<double, 2> out{0.0, 0.0};
  if (last_k_ < 0 || out_.mpc == nullptr) return out;
  for (int s = 0; s < 2; ++s) {
    SubVector e = x.segment<6>(6 * s) - out_.mpc->z.col(1).segment<6>(6 * s);
    if (s == 1)
      e.head<3>() = math::nearest_representative(x.segment<3>(6), out_.mpc->z.col(1).segment<3>(6)) -
                    out_.mpc->z.col(1).segment<3>(6);
    const Eigen::LLT<SubMatrix> llt(out_.tube.Pe.block<6, 6>(6 * s, 6 * s));
    const double v =
        llt.info() == Eigen::Success ? e.dot(llt.solve(e)) : std::numeric_limits<double>::infinity();
    out[s] = std::isnan(v) ? std::numeric_limits<double>::infinity() : v;  // a non-finite state is outside
  }
  return out;
}

bool Controller::adopt(int subsystem, const SubsystemDesign& design, int k_started) {
  if (subsystem < 0 || subsystem > 1 || policies_.empty()) return false;
  return policies_[subsystem].adopt(design, k_started);
}

const ForgettingFactorIdentifier& Controller::identifier(int subsystem) const {
  if (subsystem < 0 || subsystem > 1)
    throw std::invalid_argument("Controller::identifier: subsystem must be 0 or 1");
  return identifiers_[subsystem];
}

const TubePolicy& Controller::policy(int subsystem) const {
  if (subsystem < 0 || subsystem > 1 || policies_.empty())
    throw std::invalid_argument("Controller::policy: subsystem must be 0 or 1, after setup");
  return policies_[subsystem];
}

}  // namespace tubempc::control
