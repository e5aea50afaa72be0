// The whole mission of a scenario file (tubempc export-scenario) in C++ only, for TBMPC and TBMPC-FFA:
// the shape loaded by the C++ loader, polyhedral gravity, the controller's 6-DOF model, the whole
// controller (control::Controller: identification, certified tube update from the scenario's designs
// and library, tube MPC) and the truth propagation (dynamics::propagate, the scenario's integrator).
// The controller's state is the 12-state [r_L, v_L, phi, omega_BL_B]; the truth's the 13-state with
// the quaternion q_B/L. As in the Python closed loop (tubempc.sim.closed_loop.simulate), after each
// propagation the measured state is x_{k+1} = truth_to_state(state, phi of zbar_{k+1}) + w_k (the
// rotation vector on the branch nearest to the reference; w_k the additive disturbance, zero unless
// --disturbance gives a file of T rows of 12 values, e.g. a Python run's w_true) and the truth
// continues from state_to_truth(x_{k+1}).
//
// When the scenario file carries navigation (records navigation.*), the controller flies on the
// estimate of nav::NavigationSystem, as tubempc.sim.closed_loop does with [navigation]: the truth is
// propagated in sub-steps of the IMU's period, each sub-step's end (the last one after w_k) and its
// non-gravitational acceleration (the delivered u_p plus the truth's SRP) handed to
// NavigationSystem::step, and the controller's constraints are tightened by the estimation-error set
// c P_x (Controller::set_estimation_error). When it carries actuators (records actuators.*), each
// command goes through actuators::ActuationSystem (allocation, pulse modulation, the truth's thruster
// errors and faults, the wheels) and the plant receives the delivered input. When it carries the safe abort
// (records abort.*), control::SafeAbort supervises every step as tubempc.sim.closed_loop does: its monitor takes
// the last step's detections (a command at abort.command_step, the navigation's fault, an uncertified tube, the
// estimate's excursion in the last tube, the inputs' innovation, the identified set's ratio, an infeasible
// allocation) and, once it enters, the abort controller flies every later step (its monitor and steps are part of
// the controller's counted and allocation-checked call).
//
// Prints per method the summary of `tubempc run` (J_p, J_r, terminal error, steps outside the tube,
// tube statuses, fallbacks), per-step wall times (median, p99, max) of the controller step and its
// parts, and the heap allocations made after setup (counted by interposing malloc and operator new,
// glibc only, not with sanitizers). Exit status: 0 success, 1 an allocation inside a controller,
// navigation or actuation step, 2 bad arguments or input, 3 a failed truth propagation.
//
// --instructions (run under valgrind --tool=callgrind --collect-atstart=no --combine-dumps=yes): each
// controller, navigation and actuation step is bracketed by callgrind's client requests (collection on
// for the call alone, then a dump named "<method> <controller|navigation|actuation> <k>"), so that the
// profile holds one part per step with its instructions and calls (tubempc bench instructions reads the
// parts). The set-up calls and each period's truth propagation are dumped as parts of their own ("<method>
// setup <i>", "<method> truth <k>"): callgrind keeps the count of a call made with collection off until the
// call's arc next costs something, so an uncounted set-up or truth would charge its calls (not their
// instructions) to a step. Natively, the requests are a few no-op instructions outside the counted calls; the
// option needs <valgrind/callgrind.h> at build time and valgrind at run time.
//
//   closed_loop SCENARIO_FILE [--method tbmpc|ffa|both] [--disturbance W.txt] [--json OUT.json] [--instructions]
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <new>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "tubempc/actuators/system.hpp"
#include "tubempc/control/abort.hpp"
#include "tubempc/control/controller.hpp"
#include "tubempc/core/build_info.hpp"
#include "tubempc/dynamics/linearized_proximity.hpp"
#include "tubempc/dynamics/propagator.hpp"
#include "tubempc/dynamics/proximity_model.hpp"
#include "tubempc/gravity/expansion_hold.hpp"
#include "tubempc/gravity/polyhedron_gravity.hpp"
#include "tubempc/gravity/shape_io.hpp"
#include "tubempc/io/scenario.hpp"
#include "tubempc/math/so3.hpp"
#include "tubempc/mpc/tube_mpc.hpp"
#include "tubempc/nav/ray_caster.hpp"
#include "tubempc/nav/system.hpp"

// ---- allocation counter ------------------------------------------------------------------------
// Every malloc-family call and every operator new/delete inside an AllocationWindow is counted
// (tests/cpp/support/tubempc_testing/allocation_counter.hpp: glibc only, left out of sanitizer builds).
#include "tubempc_testing/allocation_counter.hpp"

// ---- instruction counting (callgrind's client requests) -----------------------------------------
#if defined(__has_include)
#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#define TUBEMPC_EXAMPLE_CALLGRIND 1
#endif
#endif

using namespace tubempc;

namespace {

using Clock = std::chrono::steady_clock;

using tubempc_testing::AllocationWindow;

#ifdef TUBEMPC_EXAMPLE_CALLGRIND
constexpr bool kCallgrindAvailable = true;
#else
constexpr bool kCallgrindAvailable = false;
#endif

// The instructions of one call, as one part of callgrind's profile: collection is on for the call
// alone (begin .. end) and the part is dumped under `label` right after; nothing when `on` is false.
class CountedCall {
 public:
  CountedCall(bool on, const char* method, const char* what, int k) : on_(on) {
    if (!on_) return;
    std::snprintf(label_, sizeof label_, "%s %s %d", method, what, k);
#ifdef TUBEMPC_EXAMPLE_CALLGRIND
    CALLGRIND_ZERO_STATS;
    CALLGRIND_TOGGLE_COLLECT;
#endif
  }
  ~CountedCall() {
    if (!on_) return;
#ifdef TUBEMPC_EXAMPLE_CALLGRIND
    CALLGRIND_TOGGLE_COLLECT;
    CALLGRIND_DUMP_STATS_AT(label_);
#endif
  }
  CountedCall(const CountedCall&) = delete;
  CountedCall& operator=(const CountedCall&) = delete;

 private:
  bool on_;
  char label_[64] = {};
};

// Whether this process runs under valgrind (false without the header).
bool running_on_valgrind() {
#ifdef TUBEMPC_EXAMPLE_CALLGRIND
  return RUNNING_ON_VALGRIND != 0;
#else
  return false;
#endif
}

struct Stats {
  double median, p99, max;  // s
};

// Median, 99th percentile (linear interpolation, as numpy.percentile) and maximum.
Stats stats(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  auto quantile = [&](double q) {
    const double pos = q * static_cast<double>(v.size() - 1);
    const auto lo = static_cast<std::size_t>(std::floor(pos));
    const std::size_t hi = std::min(lo + 1, v.size() - 1);
    return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
  };
  return {quantile(0.5), quantile(0.99), v.back()};
}

void write_array(std::FILE* f, const char* name, const double* data, std::size_t n, bool last = false) {
  std::fprintf(f, "    \"%s\": [", name);
  for (std::size_t i = 0; i < n; ++i) std::fprintf(f, "%s%.17g", i ? ", " : "", data[i]);
  std::fprintf(f, "]%s\n", last ? "" : ",");
}

void write_int_array(std::FILE* f, const char* name, const std::vector<int>& v, bool last = false) {
  std::fprintf(f, "        \"%s\": [", name);
  for (std::size_t i = 0; i < v.size(); ++i) std::fprintf(f, "%s%d", i ? ", " : "", v[i]);
  std::fprintf(f, "]%s\n", last ? "" : ",");
}

// A JSON string literal of s.
std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (const char ch : s) {
    if (ch == '"' || ch == '\\') {
      out += '\\';
      out += ch;
    } else if (static_cast<unsigned char>(ch) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(ch)));
      out += buf;
    } else {
      out += ch;
    }
  }
  return out + "\"";
}

int usage(const char* argv0) {
  std::fprintf(stderr,
               "usage: %s SCENARIO_FILE [--method tbmpc|ffa|both] [--disturbance W.txt] [--json OUT.json] "
               "[--instructions]\n",
               argv0);
  return 2;
}

// T rows of 12 whitespace-separated values (m, m/s, rad, rad/s); throws naming the line.
Eigen::MatrixXd read_disturbance(const std::string& path, int T) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(path + ": cannot open the file");
  Eigen::MatrixXd w(12, T);
  std::string line;
  for (int k = 0; k < T; ++k) {
    if (!std::getline(in, line))
      throw std::invalid_argument(path + ": expected " + std::to_string(T) + " rows");
    std::istringstream row(line);
    for (int i = 0; i < 12; ++i) {
      if (!(row >> w(i, k)) || !std::isfinite(w(i, k)))
        throw std::invalid_argument(path + ":" + std::to_string(k + 1) + ": expected 12 finite values");
    }
  }
  return w;
}

// What one step did, per step (the counters of the steps' results).
struct StepCounts {
  std::vector<int> scp_iterations;                  // QPs solved (mpc::StepResult::scp_iterations)
  std::vector<int> active_set_solves;               // of them by the active set
  std::vector<int> active_set_iterations;           // active-set factorisations (incl. failed tries)
  std::vector<int> active_set_failures;             // active-set tries that did not verify
  std::vector<int> qp_iterations;                   // PIQP interior-point iterations (one factorisation each)
  std::vector<int> model_evaluations;               // nodes discretised by the controller's model
  std::vector<int> mpc_status;                      // mpc::Status as its integer
  std::vector<int> navigation_gravity_evaluations;  // the filter's (nav::NavigationStep)
  std::vector<int> navigation_measurements;         // measurements folded in (camera: landmarks)
  std::vector<int> allocation_iterations;           // the actuators' allocation (active-set iterations)
};

// The heap memory a component's set-up keeps (retained) and the most it held at once (peak), in bytes
// (usable block sizes, AllocationWindow); -1: not counted (no glibc, or a sanitizer build).
struct SetupMemory {
  long long retained = -1, peak = -1;
  // Adds what `window` saw (a component set up in more than one window).
  void add(const AllocationWindow& window) {
    if (!tubempc_testing::kAllocationCounterEnabled) return;
    retained = std::max(retained, 0LL) + window.retained_bytes();
    peak = std::max(peak, 0LL) + window.peak_bytes();
  }
};

// One method's flight.
struct Flight {
  std::string method;
  dynamics::StateVector x_final;
  double J_p = 0.0, J_r = 0.0;
  double error_position = 0.0, error_velocity = 0.0, error_attitude = 0.0, error_rate = 0.0;
  int steps_outside = 0, fallbacks = 0, scp_iterations = 0;
  double max_excursion[2] = {0.0, 0.0};
  double setup_s = 0.0;
  long allocations_controller = 0, allocations_truth = 0;
  long allocations_navigation = 0, allocations_actuation = 0;  // with navigation / actuators
  // set-up, per component; the controller's construction and its setup (the MPC's setup with its QP
  // solvers' workspaces, the reference discretised for the tube update, the designs, the estimation-error set)
  SetupMemory memory_controller_construction, memory_controller, memory_navigation, memory_actuation;
  SetupMemory memory_abort;  // the safe abort's construction and setup (with abort.*)
  // the safe abort (with abort.*): the cause and step of its entry, its steps, those on an uncertified tube and
  // its tubes' largest LMI residual
  bool abort_enabled = false;
  std::string abort_cause = "none";
  int abort_entered_at = -1, abort_steps = 0, abort_uncertified_steps = 0;
  double abort_max_residual = -std::numeric_limits<double>::infinity();
  std::map<std::string, int> statuses, tube_statuses;
  std::map<std::string, int> navigation_statuses, actuation_statuses;  // with navigation / actuators
  std::vector<double> time_controller, time_identify, time_tube, time_mpc;
  std::vector<double> time_navigation, time_actuation;  // per step, with navigation / actuators (s)
  double delta_v = 0.0, propellant = 0.0;               // actuators' totals (m/s, kg)
  long pulses = 0;
  double nav_error_position = 0.0;  // |r_L - r^_L| at the end (m), with navigation
  StepCounts counts;
  int exit_code = 0;
};

// The ray casters of the navigation's sensors (on the truth's shape) and filter (on the controller's).
struct Casters {
  std::shared_ptr<const nav::RayCaster> sensor, filter;
};

// The truth's non-gravitational acceleration besides the input: its SRP in L (M1), as
// tubempc.scenario.navigation.srp_acceleration.
Eigen::Vector3d srp_acceleration(const dynamics::ModelParams& p) {
  const double a = p.srp_enabled ? p.beta_srp / std::pow(p.orbit_radius, 2.0) : 0.0;
  return {a, 0.0, 0.0};
}

Flight fly(const io::ScenarioFile& scn, control::Method method,
           const std::shared_ptr<const dynamics::ProximityModel>& model,
           const dynamics::ProximityModel& truth, const Casters& casters, const Eigen::MatrixXd& disturbance,
           bool count_instructions) {
  Flight f;
  f.method = control::to_string(method);
  const char* name = control::to_string(method);
  const auto t_setup = Clock::now();
  control::ControllerSettings settings = scn.controller;
  settings.method = method;
  settings.tube.background_designs = false;  // no Python here: the library stands in for a due design
  std::optional<AllocationWindow> memory;    // each component's set-up, in bytes
  memory.emplace();
  control::Controller controller(std::make_shared<dynamics::LinearizedProximityModel>(model), scn.settings,
                                 settings);
  f.memory_controller_construction.add(*memory);
  memory.emplace();
  {
    const CountedCall counted(count_instructions, name, "setup", 0);
    controller.setup(scn.reference, method == control::Method::Tbmpc ? scn.tbmpc_designs : scn.ffa_designs);
  }
  f.memory_controller.add(*memory);
  memory.reset();
  // The safe abort: a second controller (TBMPC-FFA's, enforced by SafeAbort) about the hover, and the supervision.
  std::unique_ptr<control::SafeAbort> abort;
  control::AbortTriggers triggers;                  // the last step's detections
  const control::Controller* last_flier = nullptr;  // the controller that flew the last step
  if (scn.abort.enabled) {
    memory.emplace();
    abort = std::make_unique<control::SafeAbort>(std::make_shared<dynamics::LinearizedProximityModel>(model),
                                                 scn.settings, settings, scn.abort.settings);
    {
      const CountedCall counted(count_instructions, name, "setup", 1);
      abort->setup(scn.abort.hover, scn.abort.designs);
    }
    f.memory_abort.add(*memory);
    memory.reset();
    f.abort_enabled = true;
  }
  const int T = scn.mission_steps();
  const double dt = scn.settings.dt;
  for (auto* v : {&f.time_controller, &f.time_identify, &f.time_tube, &f.time_mpc})
    v->resize(static_cast<std::size_t>(T));
  dynamics::StateVector x = scn.x0;
  dynamics::TruthState state = dynamics::state_to_truth(x);
  // the run's held expansion of the truth's gravity (propagator.gravity_expansion_tolerance > 0), as the Python plant's
  gravity::ExpansionHold gravity_hold(0.0, scn.propagator.gravity_expansion_tolerance);

  // Navigation: the system of the run, the period's truth samples and the estimation-error set.
  const io::NavigationScenario& ns = scn.navigation;
  std::unique_ptr<nav::NavigationSystem> navigation;
  dynamics::StateVector x_hat = x;  // the state the controller is given
  Eigen::MatrixXd P_est(dynamics::kNx, dynamics::kNx);
  int n_sub = 1;
  double h = dt;
  Eigen::VectorXd t_sample;
  Eigen::Matrix<double, Eigen::Dynamic, dynamics::kNtruth, Eigen::RowMajor> truth_sample;
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> accel_sample;
  const Eigen::Vector3d srp_L = srp_acceleration(scn.truth.params);
  if (ns.enabled) {
    memory.emplace();
    navigation = std::make_unique<nav::NavigationSystem>(model, casters.sensor, casters.filter, ns.landmarks,
                                                         ns.settings, ns.seed);
    h = navigation->base_period();
    n_sub = static_cast<int>(std::lround(dt / h));
    t_sample.resize(n_sub);
    truth_sample.resize(n_sub, dynamics::kNtruth);
    accel_sample.resize(n_sub, 3);
    f.time_navigation.resize(static_cast<std::size_t>(T));
    const nav::NavigationStep* initial = nullptr;
    {
      const CountedCall counted(count_instructions, name, "setup", 2);
      initial = &navigation->initialize(scn.reference.t0, state, srp_L, scn.reference.z.col(0).segment<3>(6));
    }
    const nav::NavigationStep& est = *initial;
    f.memory_navigation.add(*memory);
    memory.reset();
    ++f.navigation_statuses[nav::to_string(est.status)];
    x_hat = est.x_hat;
    P_est.noalias() = ns.error_set_scale * est.P_x;
    memory.emplace();
    controller.set_estimation_error(P_est);  // the first call sizes the controller's storage
    f.memory_controller.add(*memory);
    memory.reset();
    if (abort) {
      memory.emplace();
      abort->set_estimation_error(P_est);
      f.memory_abort.add(*memory);
      memory.reset();
    }
  }
  // Actuators: the run's actuation system (the truth's thrusters, the wheels at their initial momenta).
  const io::ActuatorScenario& as = scn.actuators;
  std::unique_ptr<actuators::ActuationSystem> actuation;
  if (as.enabled) {
    memory.emplace();
    {
      actuators::ReactionWheels wheels(as.wheels, as.momentum_dump);
      wheels.set_momentum(as.wheel_momentum);
      actuation = std::make_unique<actuators::ActuationSystem>(actuators::ThrusterCluster(as.thrusters),
                                                               wheels, as.settings);
    }  // the wheels' copy released: the window keeps what the system holds
    f.memory_actuation.add(*memory);
    memory.reset();
    f.time_actuation.resize(static_cast<std::size_t>(T));
  }
  f.setup_s = std::chrono::duration<double>(Clock::now() - t_setup).count();
  for (int k = 0; k < T; ++k) {
    const double t_k = scn.reference.t0 + k * dt;
    dynamics::InputVector u;
    const control::ControlStep* step = nullptr;
    {
      AllocationWindow window;
      {
        const CountedCall counted(count_instructions, name, "controller", k);
        if (abort) {  // the supervision decides from the last step's detections (latched)
          // the state handed to this step in the tube the last step certified (counted with the step)
          if (last_flier != nullptr) triggers.excursion = last_flier->excursion(x_hat);
          triggers.command = k == scn.abort.command_step;
          abort->monitor(k, triggers, &controller);
        }
        if (abort && abort->aborting()) {
          if (navigation) abort->set_estimation_error(P_est);
          step = &abort->step(k, x_hat);
        } else {
          if (navigation) controller.set_estimation_error(P_est);
          step = &controller.step(k, x_hat);
        }
      }
      f.allocations_controller += window.count();
    }
    // the bookkeeping (strings, maps) is outside the counted window
    const control::ControlStep& r = *step;
    const bool aborting = abort && abort->aborting();
    const control::Controller& flier = aborting ? abort->controller() : controller;
    last_flier = &flier;
    triggers.tube_uncertified = r.tube_status[0] == control::TubeStatus::Uncertified ||
                                r.tube_status[1] == control::TubeStatus::Uncertified;
    triggers.disturbance_ratio = r.disturbance_ratio;
    triggers.input_nis = r.input_nis;
    if (aborting) {  // the abort's certification at every step it flies
      ++f.abort_steps;
      f.abort_uncertified_steps +=
          !(control::certified(r.tube_status[0]) && control::certified(r.tube_status[1]));
      f.abort_max_residual = std::max({f.abort_max_residual, r.residual[0], r.residual[1]});
    }
    u = r.u;
    const auto i = static_cast<std::size_t>(k);
    f.time_controller[i] = r.timings.total;
    f.time_identify[i] = r.timings.identify;
    f.time_tube[i] = r.timings.tube;
    f.time_mpc[i] = r.timings.mpc;
    ++f.statuses[mpc::to_string(r.mpc->status)];
    ++f.tube_statuses[std::string(control::to_string(r.tube_status[0])) + "/" +
                      control::to_string(r.tube_status[1])];
    f.fallbacks +=
        r.mpc->status == mpc::Status::FallbackShiftedPlan || r.mpc->status == mpc::Status::FallbackSafeInput;
    f.scp_iterations += r.mpc->scp_iterations;
    f.counts.scp_iterations.push_back(r.mpc->scp_iterations);
    f.counts.active_set_solves.push_back(r.mpc->active_set_solves);
    f.counts.active_set_iterations.push_back(r.mpc->active_set_iterations);
    f.counts.active_set_failures.push_back(r.mpc->active_set_failures);
    f.counts.qp_iterations.push_back(r.mpc->qp_iterations);
    f.counts.model_evaluations.push_back(r.mpc->model_evaluations);
    f.counts.mpc_status.push_back(static_cast<int>(r.mpc->status));
    // J_p, J_r of the paper's Eq. (54)-(55) (identity weights), the node k term
    const dynamics::StateVector e = x - scn.reference.z.col(k);
    f.J_p += e.head<6>().squaredNorm() + u.head<3>().squaredNorm();
    f.J_r += e.tail<6>().squaredNorm() + u.tail<3>().squaredNorm();
    dynamics::InputVector u_applied = u;
    if (actuation) {
      const actuators::ActuationStep* a = nullptr;
      const auto t_act = Clock::now();
      {
        AllocationWindow window;
        const Eigen::Matrix3d C_BL = math::rotation_matrix(state.segment<4>(6)).transpose();
        {
          const CountedCall counted(count_instructions, name, "actuation", k);
          a = &actuation->step(t_k, u, C_BL);
        }
        u_applied = a->u_delivered;
        triggers.allocation_infeasible = a->status == actuators::AllocationStatus::Infeasible;
        f.allocations_actuation += window.count();
      }
      f.time_actuation[i] = std::chrono::duration<double>(Clock::now() - t_act).count();
      ++f.actuation_statuses[actuators::to_string(a->status)];
      f.counts.allocation_iterations.push_back(a->allocation.iterations);
    }
    dynamics::PropagationResult p;
    {
      AllocationWindow window;
      // with navigation: n_sub sub-steps of h, each one's end a sample of the sensors (tubempc.scenario.navigation.propagate_sampled)
      const CountedCall counted(count_instructions, name, "truth", k);
      for (int j = 0; j < n_sub; ++j) {
        p = navigation
                ? dynamics::propagate(truth, t_k + j * h, state, u_applied, h, {}, scn.propagator,
                                      &gravity_hold)
                : dynamics::propagate(truth, t_k, state, u_applied, dt, {}, scn.propagator, &gravity_hold);
        if (p.status != dynamics::PropagationStatus::Success) break;
        state = p.state;
        if (navigation) {
          t_sample(j) = t_k + (j + 1) * h;
          truth_sample.row(j) = state.transpose();
          accel_sample.row(j) = (u_applied.head<3>() + srp_L).transpose();
        }
      }
      if (p.status == dynamics::PropagationStatus::Success) {
        x = dynamics::truth_to_state(state, scn.reference.z.col(k + 1).segment<3>(6));
        if (disturbance.size() > 0) x += disturbance.col(k);
        state = dynamics::state_to_truth(x);
      }
      f.allocations_truth += window.count();
    }
    if (p.status != dynamics::PropagationStatus::Success) {
      std::fprintf(stderr, "error: %s: truth propagation failed at step %d: %s\n", f.method.c_str(), k,
                   dynamics::to_string(p.status));
      f.exit_code = 3;
      return f;
    }
    if (navigation) {
      truth_sample.row(n_sub - 1) = state.transpose();  // the last sample is after the disturbance
      const nav::NavigationStep* est = nullptr;
      const auto t_nav = Clock::now();
      {
        AllocationWindow window;
        {
          const CountedCall counted(count_instructions, name, "navigation", k);
          est = &navigation->step(t_sample, truth_sample, accel_sample,
                                  scn.reference.z.col(k + 1).segment<3>(6));
        }
        x_hat = est->x_hat;
        P_est.noalias() = ns.error_set_scale * est->P_x;
        triggers.navigation_fault = est->fault_detected;
        f.allocations_navigation += window.count();
      }
      f.time_navigation[i] = std::chrono::duration<double>(Clock::now() - t_nav).count();
      ++f.navigation_statuses[nav::to_string(est->status)];
      f.counts.navigation_gravity_evaluations.push_back(est->gravity_evaluations);
      int folded = 0;
      for (const int n : est->accepted) folded += n;
      f.counts.navigation_measurements.push_back(folded);
    } else {
      x_hat = x;
    }
    // the excursion of the state the controller flies (with navigation: the estimate, in the certified tube)
    const std::array<double, 2> excursion = flier.excursion(x_hat);
    bool outside = false;
    for (int s = 0; s < 2; ++s) {
      f.max_excursion[s] = std::max(f.max_excursion[s], excursion[s]);
      outside = outside || excursion[s] > 1.0 + control::kExcursionTolerance;
    }
    f.steps_outside += outside;
  }
  if (abort && abort->decision().cause != control::AbortCause::None) {
    f.abort_cause = control::to_string(abort->decision().cause);
    f.abort_entered_at = abort->decision().entered_at;
  }
  const dynamics::StateVector& xf = scn.xf;
  f.x_final = x;
  f.nav_error_position = (x.head<3>() - x_hat.head<3>()).norm();
  if (actuation) {
    f.delta_v = actuation->totals().delta_v;
    f.propellant = actuation->totals().propellant;
    f.pulses = actuation->totals().pulses;
  }
  f.error_position = (x.segment<3>(0) - xf.segment<3>(0)).norm();
  f.error_velocity = (x.segment<3>(3) - xf.segment<3>(3)).norm();
  f.error_attitude =  // angle of the rotation from the target attitude to the final one (rad)
      math::log_map(
          math::quat_mul(math::quat_conj(math::exp_map(xf.segment<3>(6))), math::exp_map(x.segment<3>(6))))
          .norm();
  f.error_rate = (x.segment<3>(9) - xf.segment<3>(9)).norm();
  return f;
}

void print_flight(const Flight& f) {
  std::printf(
      "%-6s J_p=%.10g J_r=%.10g terminal |dr|=%.3g m |dv|=%.3g m/s attitude %.3g rad rate %.3g rad/s\n",
      f.method.c_str(), f.J_p, f.J_r, f.error_position, f.error_velocity, f.error_attitude, f.error_rate);
  std::printf(
      "       steps outside the tube %d, fallback steps %d, largest excursion p/r %.3g/%.3g, %.2f SCP "
      "iterations per step, setup %.1f ms\n",
      f.steps_outside, f.fallbacks, f.max_excursion[0], f.max_excursion[1],
      static_cast<double>(f.scp_iterations) / static_cast<double>(f.time_mpc.size()), 1e3 * f.setup_s);
  std::printf("       %-28s %10s %10s %10s   [ms]\n", "per-step wall time", "median", "p99", "max");
  for (const auto& [name, v] :
       {std::pair{"controller step", &f.time_controller}, std::pair{"  identification", &f.time_identify},
        std::pair{"  tube update", &f.time_tube}, std::pair{"  MPC step", &f.time_mpc}}) {
    const Stats st = stats(*v);
    std::printf("       %-28s %10.3f %10.3f %10.3f\n", name, 1e3 * st.median, 1e3 * st.p99, 1e3 * st.max);
  }
  for (const auto& [name, v] :
       {std::pair{"navigation", &f.time_navigation}, std::pair{"actuation", &f.time_actuation}}) {
    if (v->empty()) continue;
    const Stats st = stats(*v);
    std::printf("       %-28s %10.3f %10.3f %10.3f\n", name, 1e3 * st.median, 1e3 * st.p99, 1e3 * st.max);
  }
  std::printf("       statuses:");
  for (const auto& [name, n] : f.statuses) std::printf(" %s %d", name.c_str(), n);
  std::printf("; tube statuses:");
  for (const auto& [name, n] : f.tube_statuses) std::printf(" %s %d", name.c_str(), n);
  if (!f.navigation_statuses.empty()) {
    std::printf("\n       navigation (final |r - r^| %.3g m):", f.nav_error_position);
    for (const auto& [name, n] : f.navigation_statuses) std::printf(" %s %d", name.c_str(), n);
  }
  if (f.abort_enabled) {
    std::printf("\n       safe abort: %s", f.abort_cause.c_str());
    if (f.abort_entered_at >= 0)
      std::printf(" at step %d, %d abort steps, %d on an uncertified tube, largest residual %.3g",
                  f.abort_entered_at, f.abort_steps, f.abort_uncertified_steps, f.abort_max_residual);
  }
  if (!f.actuation_statuses.empty()) {
    std::printf("\n       actuation (delta-v %.4g m/s, propellant %.4g kg, %ld pulses):", f.delta_v,
                f.propellant, f.pulses);
    for (const auto& [name, n] : f.actuation_statuses) std::printf(" %s %d", name.c_str(), n);
  }
  if (tubempc_testing::kAllocationCounterEnabled) {
    std::printf(
        "\n       heap allocations after setup: controller step %ld, navigation %ld, actuation %ld, truth "
        "propagation %ld\n",
        f.allocations_controller, f.allocations_navigation, f.allocations_actuation, f.allocations_truth);
    std::printf("       set-up memory kept (peak) [kB]:");
    for (const auto& [name, m] :
         {std::pair{"controller construction", &f.memory_controller_construction},
          std::pair{"controller setup", &f.memory_controller}, std::pair{"navigation", &f.memory_navigation},
          std::pair{"actuation", &f.memory_actuation}, std::pair{"safe abort", &f.memory_abort}})
      if (m->retained >= 0) std::printf(" %s %.1f (%.1f)", name, 1e-3 * m->retained, 1e-3 * m->peak);
    std::printf("\n");
  } else
    std::printf("\n       heap allocations: not counted (needs glibc and no sanitizer)\n");
}

void write_counts(std::FILE* out, const char* name, const std::map<std::string, int>& counts) {
  std::fprintf(out, "      \"%s\": {", name);
  bool first = true;
  for (const auto& [key, n] : counts) {
    std::fprintf(out, "%s%s: %d", first ? "" : ", ", json_string(key).c_str(), n);
    first = false;
  }
  std::fprintf(out, "},\n");
}

// "name": {"retained": bytes, "peak": bytes} (null: not counted or not flown), then `end`.
void write_memory(std::FILE* out, const char* name, const SetupMemory& m, const char* end) {
  if (m.retained < 0) {
    std::fprintf(out, "\"%s\": null%s", name, end);
  } else {
    std::fprintf(out, "\"%s\": {\"retained\": %lld, \"peak\": %lld}%s", name, m.retained, m.peak, end);
  }
}

void write_flight(std::FILE* out, const Flight& f, bool last) {
  std::fprintf(out, "    \"%s\": {\n", f.method.c_str());
  std::fprintf(out, "      \"J_p\": %.17g,\n      \"J_r\": %.17g,\n", f.J_p, f.J_r);
  std::fprintf(out,
               "      \"terminal_error\": {\"position\": %.17g, \"velocity\": %.17g, \"attitude\": %.17g, "
               "\"rate\": %.17g},\n",
               f.error_position, f.error_velocity, f.error_attitude, f.error_rate);
  std::fprintf(
      out,
      "      \"steps_outside_tube\": %d,\n      \"fallback_steps\": %d,\n      \"scp_iterations\": %d,\n",
      f.steps_outside, f.fallbacks, f.scp_iterations);
  std::fprintf(out, "      \"setup_s\": %.17g,\n      \"setup_memory_bytes\": {", f.setup_s);
  write_memory(out, "controller_construction", f.memory_controller_construction, ", ");
  write_memory(out, "controller_setup", f.memory_controller, ", ");
  write_memory(out, "navigation", f.memory_navigation, ", ");
  write_memory(out, "actuation", f.memory_actuation, ", ");
  write_memory(out, "abort", f.memory_abort, "},\n");
  if (f.abort_enabled) {
    char residual[32] = "null";  // no abort step flown
    if (f.abort_steps > 0) std::snprintf(residual, sizeof residual, "%.17g", f.abort_max_residual);
    std::fprintf(out,
                 "      \"abort\": {\"cause\": %s, \"entered_at_step\": %d, \"steps\": %d, "
                 "\"uncertified_steps\": %d, \"max_residual\": %s},\n",
                 json_string(f.abort_cause).c_str(), f.abort_entered_at, f.abort_steps,
                 f.abort_uncertified_steps, residual);
  } else {
    std::fprintf(out, "      \"abort\": null,\n");
  }
  std::fprintf(out, "      \"allocations_controller\": %ld,\n      \"allocations_truth\": %ld,\n",
               f.allocations_controller, f.allocations_truth);
  std::fprintf(out, "      \"allocations_navigation\": %ld,\n      \"allocations_actuation\": %ld,\n",
               f.allocations_navigation, f.allocations_actuation);
  std::fprintf(out, "      \"delta_v\": %.17g,\n      \"propellant\": %.17g,\n      \"pulses\": %ld,\n",
               f.delta_v, f.propellant, f.pulses);
  write_counts(out, "statuses", f.statuses);
  write_counts(out, "tube_statuses", f.tube_statuses);
  write_counts(out, "navigation_statuses", f.navigation_statuses);
  write_counts(out, "actuation_statuses", f.actuation_statuses);
  std::fprintf(out, "  ");
  write_array(out, "final_state", f.x_final.data(), dynamics::kNx);
  for (const auto& [name, v] :
       {std::pair{"time_controller_s", &f.time_controller}, std::pair{"time_identify_s", &f.time_identify},
        std::pair{"time_tube_s", &f.time_tube}, std::pair{"time_navigation_s", &f.time_navigation},
        std::pair{"time_actuation_s", &f.time_actuation}}) {
    std::fprintf(out, "  ");
    write_array(out, name, v->data(), v->size());
  }
  std::fprintf(out, "  ");
  write_array(out, "time_mpc_s", f.time_mpc.data(), f.time_mpc.size());
  std::fprintf(out, "      \"step_counts\": {\n");
  const StepCounts& c = f.counts;
  write_int_array(out, "scp_iterations", c.scp_iterations);
  write_int_array(out, "active_set_solves", c.active_set_solves);
  write_int_array(out, "active_set_iterations", c.active_set_iterations);
  write_int_array(out, "active_set_failures", c.active_set_failures);
  write_int_array(out, "qp_iterations", c.qp_iterations);
  write_int_array(out, "model_evaluations", c.model_evaluations);
  write_int_array(out, "mpc_status", c.mpc_status);
  write_int_array(out, "navigation_gravity_evaluations", c.navigation_gravity_evaluations);
  write_int_array(out, "navigation_measurements", c.navigation_measurements);
  write_int_array(out, "allocation_iterations", c.allocation_iterations, true);
  std::fprintf(out, "      }\n");
  std::fprintf(out, "    }%s\n", last ? "" : ",");
}

}  // namespace

int main(int argc, char** argv) {
  std::string scenario_path, json_path, disturbance_path, method_arg = "both";
  bool count_instructions = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--instructions") {
      count_instructions = true;
    } else if (arg == "--json" && i + 1 < argc) {
      json_path = argv[++i];
    } else if (arg == "--disturbance" && i + 1 < argc) {
      disturbance_path = argv[++i];
    } else if (arg == "--method" && i + 1 < argc) {
      method_arg = argv[++i];
    } else if (!arg.empty() && arg[0] != '-' && scenario_path.empty()) {
      scenario_path = arg;
    } else {
      return usage(argv[0]);
    }
  }
  if (scenario_path.empty() || (method_arg != "both" && method_arg != "tbmpc" && method_arg != "ffa"))
    return usage(argv[0]);
  if (count_instructions && !(kCallgrindAvailable && running_on_valgrind())) {
    std::fprintf(stderr, "error: --instructions needs %s\n",
                 kCallgrindAvailable ? "a run under valgrind --tool=callgrind --collect-atstart=no"
                                     : "<valgrind/callgrind.h> at build time (Debian: valgrind)");
    return 2;
  }

  io::ScenarioFile scn;
  std::shared_ptr<const dynamics::ProximityModel> model;
  std::shared_ptr<const dynamics::ProximityModel> truth;
  Casters casters;
  Eigen::MatrixXd disturbance;
  SetupMemory memory_scenario, memory_models;  // the scenario file; the two gravity models and ray casters
  try {
    std::optional<AllocationWindow> memory;
    memory.emplace();
    scn = io::read_scenario(scenario_path);
    memory_scenario.add(*memory);
    memory.emplace();
    if (!scn.has_controller)
      throw std::invalid_argument(scenario_path + ": a version-" +
                                  std::to_string(io::kScenarioFormatVersion) +
                                  " scenario (with the controller) is needed; export it again");
    const std::string shape_file = scn.resolve(scn.model.shape);
    gravity::Shape shape = gravity::load_shape(shape_file, scn.model.shape_unit_scale);
    const std::string truth_file = scn.resolve(scn.truth.shape);
    const bool same_shape =
        truth_file == shape_file && scn.truth.shape_unit_scale == scn.model.shape_unit_scale;
    gravity::Shape truth_shape =
        same_shape ? shape : gravity::load_shape(truth_file, scn.truth.shape_unit_scale);
    std::printf("tubempc %s: %s (T = %d steps of %g s, N = %d); shape %s: %ld faces\n",
                core::build_info().version.c_str(), scenario_path.c_str(), scn.mission_steps(),
                scn.settings.dt, scn.settings.horizon, shape_file.c_str(),
                static_cast<long>(shape.n_faces()));
    if (scn.navigation.enabled) {  // the filter ray-casts the controller's shape, the sensors the truth's
      casters.filter = std::make_shared<nav::RayCaster>(shape);
      casters.sensor = same_shape ? casters.filter : std::make_shared<nav::RayCaster>(truth_shape);
      std::printf("navigation: %zu landmarks, IMU period %g s, seed %llu\n", scn.navigation.landmarks.size(),
                  scn.navigation.settings.imu.period, static_cast<unsigned long long>(scn.navigation.seed));
    }
    if (scn.actuators.enabled)
      std::printf("actuators: %zu thrusters, %zu wheels, mass %g kg\n", scn.actuators.thrusters.size(),
                  scn.actuators.wheels.size(), scn.actuators.settings.mass);
    model = std::make_shared<dynamics::ProximityModel>(
        std::make_shared<gravity::PolyhedronGravity>(std::move(shape), scn.model.density), scn.model.params);
    truth = std::make_shared<dynamics::ProximityModel>(
        std::make_shared<gravity::PolyhedronGravity>(std::move(truth_shape), scn.truth.density),
        scn.truth.params);
    memory_models.add(*memory);
    memory.reset();
    if (!disturbance_path.empty()) disturbance = read_disturbance(disturbance_path, scn.mission_steps());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }

  if constexpr (tubempc_testing::kAllocationCounterEnabled) {
    // The counter sees allocations (called through volatile pointers, which the compiler cannot elide).
    void* (*volatile allocate)(std::size_t) = std::malloc;
    void (*volatile release)(void*) = std::free;
    AllocationWindow window;
    release(allocate(64));
    if (window.count() != 2) {
      std::fprintf(stderr, "error: the allocation counter saw %ld of 2 calls\n", window.count());
      return 2;
    }
  }

  std::vector<Flight> flights;
  for (const control::Method m : {control::Method::Tbmpc, control::Method::Ffa}) {
    if (method_arg != "both" && method_arg != control::to_string(m)) continue;
    try {
      flights.push_back(fly(scn, m, model, *truth, casters, disturbance, count_instructions));
    } catch (const std::exception& e) {
      std::fprintf(stderr, "error: %s: %s\n", control::to_string(m), e.what());
      return 2;
    }
    if (flights.back().exit_code != 0) return flights.back().exit_code;
    print_flight(flights.back());
  }
  if (flights.size() == 2 && flights[0].J_p > 0.0)
    std::printf("TBMPC-FFA J_p is %.1f %% below TBMPC's\n", 100.0 * (1.0 - flights[1].J_p / flights[0].J_p));

  if (!json_path.empty()) {
    std::FILE* f = std::fopen(json_path.c_str(), "w");
    if (f == nullptr) {
      std::fprintf(stderr, "error: cannot write %s\n", json_path.c_str());
      return 2;
    }
    const core::BuildInfo& build = core::build_info();
    std::fprintf(f,
                 "{\n  \"scenario\": %s,\n  \"steps\": %d,\n  \"allocations_counted\": %s,\n  \"build\": "
                 "{\"version\": %s, \"compiler\": %s, \"cxx_flags\": %s, \"eigen_simd\": %s},\n",
                 json_string(scenario_path).c_str(), scn.mission_steps(),
                 tubempc_testing::kAllocationCounterEnabled ? "true" : "false",
                 json_string(build.version).c_str(), json_string(build.compiler).c_str(),
                 json_string(build.cxx_flags).c_str(), json_string(build.eigen_simd).c_str());
    std::fprintf(f, "  \"setup_memory_bytes\": {");
    write_memory(f, "scenario", memory_scenario, ", ");
    write_memory(f, "models_and_ray_casters", memory_models, "},\n");
    std::fprintf(f, "  \"methods\": {\n");
    for (std::size_t i = 0; i < flights.size(); ++i) write_flight(f, flights[i], i + 1 == flights.size());
    std::fprintf(f, "  }\n}\n");
    std::fclose(f);
  }
  for (const Flight& fl : flights) {
    if (fl.allocations_controller > 0 || fl.allocations_navigation > 0 || fl.allocations_actuation > 0) {
      std::fprintf(
          stderr, "error: %s: allocations after setup: controller step %ld, navigation %ld, actuation %ld\n",
          fl.method.c_str(), fl.allocations_controller, fl.allocations_navigation, fl.allocations_actuation);
      return 1;
    }
  }
  return 0;
}
