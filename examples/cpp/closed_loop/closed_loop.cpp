// The whole mission of a scenario file (tubempc export-scenario) in C++ only: the shape loaded by the
// C++ loader, polyhedral gravity, the controller's 6-DOF model and its linearisation, the tube MPC
// (setup with the reference, TBMPC's fixed tube) and the truth propagation (dynamics::propagate, the
// scenario's integrator), without disturbance. The controller's state is the 12-state
// [r_L, v_L, phi, omega_BL_B]; the truth's the 13-state with the quaternion q_B/L. As in the Python
// closed loop (tubempc.closed_loop.simulate), after each propagation the measured state is
// x_{k+1} = truth_to_state(state, phi of zbar_{k+1}) (the rotation vector on the branch nearest to the
// reference) and the truth continues from state_to_truth(x_{k+1}).
//
// Prints per-step wall times (median, p99, max) of the whole step and of the MPC step alone, the
// step statuses, the final errors against x_f and the heap allocations made after setup (counted by
// interposing malloc and operator new, glibc only, not with sanitizers). Exit status: 0 success,
// 1 an allocation inside the MPC step, 2 bad arguments or input, 3 a failed truth propagation.
//
//   closed_loop SCENARIO_FILE [--json OUT.json]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <map>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include "tubempc/core/build_info.hpp"
#include "tubempc/dynamics/linearized_proximity.hpp"
#include "tubempc/dynamics/propagator.hpp"
#include "tubempc/dynamics/proximity_model.hpp"
#include "tubempc/gravity/polyhedron_gravity.hpp"
#include "tubempc/gravity/shape_io.hpp"
#include "tubempc/io/scenario.hpp"
#include "tubempc/math/so3.hpp"
#include "tubempc/mpc/tube_mpc.hpp"

// ---- allocation counter ------------------------------------------------------------------------
// Every malloc-family call and every operator new/delete inside an AllocationWindow is counted
// (tubempc/core/allocation_counter.hpp: glibc only, left out of sanitizer builds).
#include "tubempc/core/allocation_counter.hpp"

using namespace tubempc;

namespace {

using Clock = std::chrono::steady_clock;

using tubempc::core::AllocationWindow;

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
  std::fprintf(f, "  \"%s\": [", name);
  for (std::size_t i = 0; i < n; ++i) std::fprintf(f, "%s%.17g", i ? ", " : "", data[i]);
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
  std::fprintf(stderr, "usage: %s SCENARIO_FILE [--json OUT.json]\n", argv0);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string scenario_path, json_path;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--json" && i + 1 < argc) {
      json_path = argv[++i];
    } else if (!arg.empty() && arg[0] != '-' && scenario_path.empty()) {
      scenario_path = arg;
    } else {
      return usage(argv[0]);
    }
  }
  if (scenario_path.empty()) return usage(argv[0]);

  io::Scenario scn;
  std::shared_ptr<const dynamics::ProximityModel> model;
  std::shared_ptr<const dynamics::ProximityModel> truth;
  try {
    scn = io::read_scenario(scenario_path);
    const std::string shape_file = scn.resolve(scn.controller.shape);
    gravity::Shape shape = gravity::load_shape(shape_file, scn.controller.shape_unit_scale);
    const std::string truth_file = scn.resolve(scn.truth.shape);
    gravity::Shape truth_shape =
        truth_file == shape_file && scn.truth.shape_unit_scale == scn.controller.shape_unit_scale
            ? shape
            : gravity::load_shape(truth_file, scn.truth.shape_unit_scale);
    std::printf("tubempc %s: %s (T = %d steps of %g s, N = %d); shape %s: %ld faces\n",
                core::build_info().version.c_str(), scenario_path.c_str(), scn.mission_steps(),
                scn.settings.dt, scn.settings.horizon, shape_file.c_str(),
                static_cast<long>(shape.n_faces()));
    model = std::make_shared<dynamics::ProximityModel>(
        std::make_shared<gravity::PolyhedronGravity>(std::move(shape), scn.controller.density),
        scn.controller.params);
    truth = std::make_shared<dynamics::ProximityModel>(
        std::make_shared<gravity::PolyhedronGravity>(std::move(truth_shape), scn.truth.density),
        scn.truth.params);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }

  if constexpr (tubempc::core::kAllocationCounterEnabled) {
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

  // Setup: everything the loop needs is allocated here.
  const auto t_setup = Clock::now();
  auto plant = std::make_shared<dynamics::LinearizedProximityModel>(model);
  mpc::TubeMPC controller(plant, scn.settings);
  controller.setup(scn.reference);
  const int T = scn.mission_steps();
  const double dt = scn.settings.dt;
  std::vector<double> time_step(static_cast<std::size_t>(T)), time_mpc(static_cast<std::size_t>(T)),
      time_mpc_internal(static_cast<std::size_t>(T));
  std::vector<mpc::Status> statuses(static_cast<std::size_t>(T)), failures(static_cast<std::size_t>(T));
  const double setup_s = std::chrono::duration<double>(Clock::now() - t_setup).count();
  dynamics::StateVector x = scn.x0;
  dynamics::TruthState state = dynamics::state_to_truth(x);
  long allocations_mpc = 0, allocations_truth = 0;
  int scp_iterations = 0;

  for (int k = 0; k < T; ++k) {
    const double t_k = scn.reference.t0 + k * dt;
    const auto a = Clock::now();
    dynamics::InputVector u;
    {
      AllocationWindow window;
      const mpc::StepResult& r = controller.step(k, x, scn.tube);
      u = r.u;
      statuses[static_cast<std::size_t>(k)] = r.status;
      failures[static_cast<std::size_t>(k)] = r.failure;
      time_mpc_internal[static_cast<std::size_t>(k)] = r.timings.total;
      scp_iterations += r.scp_iterations;
      allocations_mpc += window.count();
    }
    const auto b = Clock::now();
    dynamics::PropagationResult p;
    {
      AllocationWindow window;
      p = dynamics::propagate(*truth, t_k, state, u, dt, {}, scn.propagator);
      x = dynamics::truth_to_state(p.state, scn.reference.z.col(k + 1).segment<3>(6));
      state = dynamics::state_to_truth(x);
      allocations_truth += window.count();
    }
    const auto c = Clock::now();
    if (p.status != dynamics::PropagationStatus::Success) {
      std::fprintf(stderr, "error: truth propagation failed at step %d: %s\n", k,
                   dynamics::to_string(p.status));
      return 3;
    }
    time_mpc[static_cast<std::size_t>(k)] = std::chrono::duration<double>(b - a).count();
    time_step[static_cast<std::size_t>(k)] = std::chrono::duration<double>(c - a).count();
  }

  std::map<std::string, int> status_counts, failure_counts;
  for (int k = 0; k < T; ++k) {
    ++status_counts[mpc::to_string(statuses[static_cast<std::size_t>(k)])];
    if (failures[static_cast<std::size_t>(k)] != mpc::Status::Solved) {
      ++failure_counts[mpc::to_string(failures[static_cast<std::size_t>(k)])];
    }
  }
  const Stats s_step = stats(time_step), s_mpc = stats(time_mpc), s_int = stats(time_mpc_internal);
  const dynamics::StateVector& xf = scn.xf;
  const double err_r = (x.segment<3>(0) - xf.segment<3>(0)).norm();
  const double err_v = (x.segment<3>(3) - xf.segment<3>(3)).norm();
  const double err_att =  // angle of the rotation from the target attitude to the final one (rad)
      math::log_map(
          math::quat_mul(math::quat_conj(math::exp_map(xf.segment<3>(6))), math::exp_map(x.segment<3>(6))))
          .norm();
  const double err_w = (x.segment<3>(9) - xf.segment<3>(9)).norm();

  std::printf("setup %.1f ms; mission of %d steps, %.2f SCP iterations per step\n", 1e3 * setup_s, T,
              static_cast<double>(scp_iterations) / T);
  std::printf("%-34s %10s %10s %10s   [ms]\n", "per-step wall time", "median", "p99", "max");
  std::printf("  %-32s %10.3f %10.3f %10.3f\n", "step (MPC + truth propagation)", 1e3 * s_step.median,
              1e3 * s_step.p99, 1e3 * s_step.max);
  std::printf("  %-32s %10.3f %10.3f %10.3f\n", "MPC step", 1e3 * s_mpc.median, 1e3 * s_mpc.p99,
              1e3 * s_mpc.max);
  std::printf("  %-32s %10.3f %10.3f %10.3f\n", "MPC step (StepResult timings)", 1e3 * s_int.median,
              1e3 * s_int.p99, 1e3 * s_int.max);
  std::printf("statuses:");
  for (const auto& [name, n] : status_counts) std::printf(" %s %d", name.c_str(), n);
  if (!failure_counts.empty()) {
    std::printf("; fallback causes:");
    for (const auto& [name, n] : failure_counts) std::printf(" %s %d", name.c_str(), n);
  }
  std::printf(
      "\nfinal error vs x_f: position %.4g m, velocity %.4g m/s, attitude %.4g rad, rate %.4g rad/s\n", err_r,
      err_v, err_att, err_w);
  const bool counted = tubempc::core::kAllocationCounterEnabled;
  if (counted)
    std::printf("heap allocations after setup: MPC step %ld, truth propagation %ld\n", allocations_mpc,
                allocations_truth);
  else
    std::printf("heap allocations: not counted (needs glibc and no sanitizer)\n");

  if (!json_path.empty()) {
    std::FILE* f = std::fopen(json_path.c_str(), "w");
    if (f == nullptr) {
      std::fprintf(stderr, "error: cannot write %s\n", json_path.c_str());
      return 2;
    }
    std::fprintf(f, "{\n  \"scenario\": %s,\n  \"steps\": %d,\n  \"setup_s\": %.17g,\n",
                 json_string(scenario_path).c_str(), T, setup_s);
    std::fprintf(f, "  \"scp_iterations\": %d,\n", scp_iterations);
    std::fprintf(
        f, "  \"allocations_counted\": %s,\n  \"allocations_mpc\": %ld,\n  \"allocations_truth\": %ld,\n",
        counted ? "true" : "false", allocations_mpc, allocations_truth);
    std::fprintf(f, "  \"statuses\": {");
    bool first = true;
    for (const auto& [name, n] : status_counts) {
      std::fprintf(f, "%s\"%s\": %d", first ? "" : ", ", name.c_str(), n);
      first = false;
    }
    std::fprintf(f, "},\n");
    write_array(f, "final_state", x.data(), dynamics::kNx);
    write_array(f, "time_step_s", time_step.data(), time_step.size());
    write_array(f, "time_mpc_s", time_mpc.data(), time_mpc.size());
    write_array(f, "time_mpc_internal_s", time_mpc_internal.data(), time_mpc_internal.size(), true);
    std::fprintf(f, "}\n");
    std::fclose(f);
  }
  if (allocations_mpc > 0) {
    std::fprintf(stderr, "error: the MPC step allocated %ld times after setup\n", allocations_mpc);
    return 1;
  }
  return 0;
}
