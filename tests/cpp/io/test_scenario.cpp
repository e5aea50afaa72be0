#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

#include "tubempc/io/scenario.hpp"

using tubempc::io::read_scenario;
using tubempc::io::ScenarioFile;
using tubempc::io::write_scenario;

namespace {

namespace fs = std::filesystem;

// Deterministic values with full 17-digit mantissas: scale * sin(seed + 0.7 i).
Eigen::MatrixXd filled(Eigen::Index rows, Eigen::Index cols, double seed, double scale) {
  Eigen::MatrixXd m(rows, cols);
  for (Eigen::Index i = 0; i < m.size(); ++i)
    m.data()[i] = scale * std::sin(seed + 0.7 * static_cast<double>(i));
  return m;
}

// A scenario whose every value is distinct and not exactly representable in few digits.
ScenarioFile sample(int T) {
  ScenarioFile s;
  s.model.params.kinematics = tubempc::dynamics::Kinematics::Exact;
  s.model.params.spin_angle0 = 0.1;
  s.model.params.inertia_B(0, 1) = s.model.params.inertia_B(1, 0) = 1.0 / 3.0;
  s.model.params.glide_slope_apex_A = Eigen::Vector3d(1.0 / 3.0, -2.0, 0.1);  // not the defaults
  s.model.params.glide_slope_axis_A = Eigen::Vector3d(0.1, 0.2, 1.0 / 3.0);
  s.model.density = 1260.0;
  s.model.shape = "shape.obj";
  s.truth = s.model;
  s.truth.density = 1260.0 * 1.1;
  s.truth.params.beta_srp *= 0.9;
  s.truth.params.srp_enabled = false;
  s.truth.params.kinematics = tubempc::dynamics::Kinematics::FirstOrder;  // version 1 calls it "paper"
  s.truth.shape = "/abs/truth shape.tab";
  s.truth.shape_unit_scale = 1000.0;
  s.propagator.substeps = 8;
  s.settings.horizon = 2;
  s.settings.dt = 2.0;
  s.settings.Q = Eigen::MatrixXd::Identity(12, 12) * (1.0 + 1e-16);
  s.settings.R = Eigen::VectorXd::LinSpaced(6, 1e3, 1e4).asDiagonal();
  s.settings.u_max = (Eigen::VectorXd(6) << 0.55, 0.55, 0.55, 3.0, 3.0, 3.0).finished();
  s.settings.input_cost = tubempc::mpc::InputCost::Deviation;
  s.settings.soft_terminal = true;              // set explicitly: the error test below edits its record
  s.settings.qp_preconditioner_iterations = 4;  // not the default: the round trip must carry it
  s.settings.qp_reg_lower_limit = 3e-9;
  s.settings.qp_retry_reg_lower_limit = 0.0;
  s.settings.linearization = tubempc::mpc::Linearization::EveryIteration;  // not the default
  s.settings.qp_solver = tubempc::mpc::QpSolver::Piqp;                     // not the default
  s.settings.active_set_max_iterations = 5;
  s.settings.G_structure = Eigen::MatrixXd::Ones(2, 12);
  s.reference.t0 = 0.25;
  s.reference.z = filled(12, T + 1, 1.0, 1e3);
  s.reference.u = filled(6, T, 2.0, 1e-2);
  s.has_controller = true;
  s.controller.measured_input = tubempc::control::MeasuredInput::ReferenceDeviation;  // not the default
  s.controller.identification_p.lambda = 0.96;
  s.controller.identification_p.w0 = filled(6, 1, 6.0, 1e-3);
  s.controller.identification_p.S0 = Eigen::VectorXd::LinSpaced(6, 1e-3, 4e-2).asDiagonal();
  s.controller.identification_p.prior_weight = 24.5;
  s.controller.identification_r = s.controller.identification_p;
  s.controller.identification_r.lambda = 0.98;
  s.controller.identification_r.S0 *= 1.0 / 3.0;
  s.controller.tube.redesign_margin = 0.2;
  s.controller.tube.alpha_search_period = 7;
  const auto design = [](double seed) {
    tubempc::control::SubsystemDesign d;
    d.K = filled(3, 6, seed, 0.1);
    d.alpha = 0.5 + 0.1 * std::sin(seed);
    d.P_W = Eigen::VectorXd::LinSpaced(6, 1.0 / 3.0, 2.0).asDiagonal();
    d.Pe = d.P_W * (1.0 + seed);
    return d;
  };
  s.tbmpc_designs.initial_p = design(7.0);
  s.tbmpc_designs.initial_r = design(8.0);
  s.ffa_designs.initial_p = design(9.0);
  s.ffa_designs.initial_r = design(10.0);
  s.ffa_designs.library_p = {design(11.0), design(12.0)};  // library_r stays empty
  s.tube.K = Eigen::MatrixXd::Zero(6, 12);
  s.tube.Pe = Eigen::MatrixXd::Zero(12, 12);
  s.tube.K.block(0, 0, 3, 6) = s.tbmpc_designs.initial_p.K;
  s.tube.K.block(3, 6, 3, 6) = s.tbmpc_designs.initial_r.K;
  s.tube.Pe.block(0, 0, 6, 6) = s.tbmpc_designs.initial_p.Pe;
  s.tube.Pe.block(6, 6, 6, 6) = s.tbmpc_designs.initial_r.Pe;
  s.x0 = filled(12, 1, 4.0, 1.0);
  s.x0(0) = -0.0;
  s.xf = filled(12, 1, 5.0, 1e-300);
  // version 4: the actuation-error sets, the navigation and the actuators, none at their defaults
  s.controller.actuation_error[0] = Eigen::Vector3d(1e-6, 2e-6, 1.0 / 3.0 * 1e-6).asDiagonal();
  s.controller.actuation_error[1] = Eigen::Vector3d(0.1, 0.2, 1.0 / 3.0).asDiagonal();
  s.controller.feedforward = true;  // version 5
  s.controller.feedforward_limit = 0.0123;
  tubempc::io::NavigationScenario& n = s.navigation;
  n.enabled = true;
  n.settings.altimeter.sigma = 1.0 / 3.0;
  n.settings.camera.C_BC << 0.0, 1.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 1.0;
  n.settings.camera.pixel_bias = Eigen::Vector2d(0.25, -1.0 / 7.0);
  n.settings.camera.width_px = 640;
  n.settings.imu.gyro_bias_sigma = 3e-6;
  n.settings.star_tracker.misalignment_B = Eigen::Vector3d(1e-5, -2e-5, 1.0 / 3.0 * 1e-5);
  n.settings.filter.camera.focal_length_px = 1000.0 / 3.0;
  n.settings.filter.innovation_gate = std::numeric_limits<double>::infinity();  // inf: no gate
  n.settings.filter.split = true;
  n.settings.filter.max_substeps = 9;
  n.settings.filter.gravity_relinearization_distance = 2.5;
  n.settings.filter.gravity_expansion_tolerance = 3e-8;
  n.settings.filter.covariance_step = 1.0 / 3.0;
  n.settings.initial_sigma = filled(9, 1, 3.0, 1.0).cwiseAbs();
  n.settings.period_noise_sigma = filled(9, 1, 13.0, 1e-3).cwiseAbs();
  n.settings.max_samples = 40;
  n.landmarks.resize(3);
  for (int i = 0; i < 3; ++i) {
    n.landmarks[static_cast<std::size_t>(i)].p_A = filled(3, 1, 20.0 + i, 250.0);
    n.landmarks[static_cast<std::size_t>(i)].normal_A = filled(3, 1, 30.0 + i, 1.0).normalized();
    n.landmarks[static_cast<std::size_t>(i)].face = 100 * i + 7;
  }
  n.seed = (std::uint64_t{1} << 40) + 1000003;
  n.error_set_scale = 26.217029655218103;
  tubempc::io::ActuatorScenario& a = s.actuators;
  a.enabled = true;
  a.thrusters.resize(2);
  for (int i = 0; i < 2; ++i) {
    tubempc::actuators::ThrusterSpec& t = a.thrusters[static_cast<std::size_t>(i)];
    t.position_B = filled(3, 1, 40.0 + i, 1.5);
    t.direction_B = filled(3, 1, 50.0 + i, 1.0).normalized();
    t.max_thrust = 22.0 / 3.0;
    t.min_on_time = 0.02;
    t.isp = 229.5;
    t.scale_error_bound = 0.05;
    t.scale_error = 0.05 / 3.0 * (i == 0 ? 1.0 : -1.0);
    t.misalignment_bound = 0.01;
    t.misalignment_B = Eigen::Vector3d(0.003, -0.001, 1.0 / 3.0 * 0.01);
  }
  a.thrusters[1].fault = tubempc::actuators::FaultKind::FailedOff;
  a.thrusters[1].fault_time = 37.5;
  a.wheels.resize(1);
  a.wheels[0].axis_B = Eigen::Vector3d(1.0, 1.0, 1.0).normalized();
  a.wheels[0].max_torque = 0.2;
  a.wheels[0].max_momentum = 50.0 / 3.0;
  a.momentum_dump.enabled = false;
  a.momentum_dump.time_constant = 100.0 / 3.0;
  a.wheel_momentum = Eigen::VectorXd::Constant(1, -1.0 / 3.0);
  a.settings.mass = 1500.0 / 7.0;
  a.settings.modulation.period = a.settings.allocation.period = s.settings.dt;
  a.settings.modulation.on_time_resolution = 1e-4;
  a.settings.allocation.residual_weight = filled(6, 1, 60.0, 1.0).cwiseAbs();
  a.settings.allocation.max_iterations = 77;
  tubempc::io::AbortScenario& ab = s.abort;
  ab.enabled = true;
  ab.settings.commit_step = T - 2;
  ab.settings.on_tube_uncertified = false;  // not the defaults
  ab.settings.disturbance_limit = std::numeric_limits<double>::infinity();
  ab.settings.input_nis_window = 7;
  ab.settings.input_nis_limit = 10.0 / 3.0;
  ab.command_step = T - 1;
  ab.hover.t0 = s.reference.t0;
  ab.hover.z = filled(12, T + 3, 70.0, 1e2);  // past the mission's end
  ab.hover.u = filled(6, T + 2, 71.0, 1e-3);
  ab.designs.initial_p = design(13.0);
  ab.designs.initial_r = design(14.0);
  ab.designs.library_p = {design(15.0)};
  ab.designs.library_r = {design(16.0), design(17.0)};
  return s;
}

void expect_same_bits(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, const char* what) {
  ASSERT_EQ(a.rows(), b.rows()) << what;
  ASSERT_EQ(a.cols(), b.cols()) << what;
  for (Eigen::Index i = 0; i < a.size(); ++i) {
    EXPECT_EQ(std::signbit(a.data()[i]), std::signbit(b.data()[i])) << what << "[" << i << "]";
    EXPECT_EQ(a.data()[i], b.data()[i]) << what << "[" << i << "]";
  }
}

class ScenarioFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / (std::string("tubempc_scenario_") + info->name() + "_" +
                                        std::to_string(reinterpret_cast<std::uintptr_t>(this)));
    fs::create_directories(dir_);
    path_ = (dir_ / "scenario.txt").string();
    write_scenario(path_, sample(3), "test scenario\nsecond comment line");
    std::ifstream in(path_);
    std::ostringstream text;
    text << in.rdbuf();
    text_ = text.str();
  }
  void TearDown() override { fs::remove_all(dir_); }

  // 1-based line number of the first line equal to `line` in the written file.
  long line_of(const std::string& line) const {
    std::istringstream in(text_);
    long n = 0;
    for (std::string l; std::getline(in, l);) {
      ++n;
      if (l == line) return n;
    }
    ADD_FAILURE() << "no line '" << line << "'";
    return -1;
  }

  // Text of the 1-based line n of the written file.
  std::string line_at(long n) const {
    std::istringstream in(text_);
    std::string l;
    for (long i = 0; i < n; ++i) std::getline(in, l);
    return l;
  }

  // Replaces the first occurrence of `from` in the written file, reads it and expects an error whose
  // message starts with "<path>:<line>: " (line 0: "<path>: ") and contains `needle`.
  void expect_error(const std::string& from, const std::string& to, long line,
                    const std::string& needle) const {
    std::string text = text_;
    const std::size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    const std::string path = (dir_ / "bad.txt").string();
    std::ofstream(path, std::ios::binary) << text;
    try {
      read_scenario(path);
      ADD_FAILURE() << "accepted: '" << from << "' -> '" << to << "'";
    } catch (const std::invalid_argument& e) {
      const std::string msg = e.what();
      const std::string prefix = line > 0 ? path + ":" + std::to_string(line) + ": " : path + ": ";
      EXPECT_EQ(msg.rfind(prefix, 0), 0u) << "expected the prefix '" << prefix << "' in: " << msg;
      EXPECT_NE(msg.find(needle), std::string::npos) << "expected '" << needle << "' in: " << msg;
    }
  }

  // The written file as version 3 wrote it: without the actuation-error sets, the navigation and the
  // actuators (the last records).
  std::string version_three() const {
    std::string text = text_;
    const auto cut = [&text](const std::string& from, const std::string& to) {
      const std::size_t a = text.find(from), b = to.empty() ? text.size() : text.find(to);
      ASSERT_NE(a, std::string::npos) << from;
      ASSERT_NE(b, std::string::npos) << to;
      text.erase(a, b - a);
    };
    cut("controller.actuation_error_p 3 3\n", "identification_p.");
    cut("navigation.enabled 1 1\n", "");
    text.replace(text.find("tubempc-scenario 6"), 18, "tubempc-scenario 3");
    return text;
  }

  fs::path dir_;
  std::string path_;
  std::string text_;
};

}  // namespace

TEST_F(ScenarioFileTest, RoundTripIsBitExact) {
  const ScenarioFile a = sample(3);
  const ScenarioFile b = read_scenario(path_);
  EXPECT_EQ(b.directory, dir_.string());
  EXPECT_EQ(b.mission_steps(), 3);
  for (const auto& [x, y, name] :
       {std::tuple{&a.model, &b.model, "model"}, std::tuple{&a.truth, &b.truth, "truth"}}) {
    SCOPED_TRACE(name);
    EXPECT_EQ(x->params.mu_sun, y->params.mu_sun);
    EXPECT_EQ(x->params.orbit_radius, y->params.orbit_radius);
    EXPECT_EQ(x->params.beta_srp, y->params.beta_srp);
    EXPECT_EQ(x->params.srp_enabled, y->params.srp_enabled);
    expect_same_bits(x->params.inertia_B, y->params.inertia_B, "inertia_B");
    EXPECT_EQ(x->params.spin_rate, y->params.spin_rate);
    EXPECT_EQ(x->params.spin_angle0, y->params.spin_angle0);
    EXPECT_EQ(x->params.kinematics, y->params.kinematics);
    EXPECT_EQ(x->params.glide_slope_angle, y->params.glide_slope_angle);
    EXPECT_EQ(x->params.los_angle, y->params.los_angle);
    expect_same_bits(x->params.boresight_B, y->params.boresight_B, "boresight_B");
    expect_same_bits(x->params.glide_slope_apex_A, y->params.glide_slope_apex_A, "glide_slope_apex_A");
    expect_same_bits(x->params.glide_slope_axis_A, y->params.glide_slope_axis_A, "glide_slope_axis_A");
    EXPECT_EQ(x->density, y->density);
    EXPECT_EQ(x->shape, y->shape);
    EXPECT_EQ(x->shape_unit_scale, y->shape_unit_scale);
  }
  EXPECT_EQ(b.resolve(b.model.shape), (dir_ / "shape.obj").string());
  EXPECT_EQ(b.resolve(b.truth.shape), "/abs/truth shape.tab");
  EXPECT_EQ(b.propagator.method, a.propagator.method);
  EXPECT_EQ(b.propagator.substeps, 8);
  EXPECT_EQ(b.propagator.rtol, a.propagator.rtol);
  EXPECT_EQ(b.propagator.atol, a.propagator.atol);
  EXPECT_EQ(b.propagator.max_steps, a.propagator.max_steps);
  EXPECT_EQ(b.propagator.initial_step, a.propagator.initial_step);
  const auto &sa = a.settings, &sb = b.settings;
  EXPECT_EQ(sb.horizon, 2);
  EXPECT_EQ(sb.dt, sa.dt);
  expect_same_bits(sa.Q, sb.Q, "Q");
  expect_same_bits(sa.R, sb.R, "R");
  expect_same_bits(sa.u_max, sb.u_max, "u_max");
  EXPECT_EQ(sb.input_cost, tubempc::mpc::InputCost::Deviation);
  EXPECT_EQ(sb.initial_condition, sa.initial_condition);
  EXPECT_EQ(sb.scp_eps, sa.scp_eps);
  EXPECT_EQ(sb.scp_max_iterations, sa.scp_max_iterations);
  EXPECT_EQ(sb.trust_region, std::numeric_limits<double>::infinity());
  EXPECT_EQ(sb.qp_eps_abs, sa.qp_eps_abs);
  EXPECT_EQ(sb.qp_eps_rel, sa.qp_eps_rel);
  EXPECT_EQ(sb.qp_max_iterations, sa.qp_max_iterations);
  EXPECT_EQ(sb.qp_inaccurate_tol, sa.qp_inaccurate_tol);
  EXPECT_EQ(sb.time_limit, sa.time_limit);
  EXPECT_EQ(sb.soft_state_constraints, sa.soft_state_constraints);
  EXPECT_EQ(sb.soft_terminal, sa.soft_terminal);
  EXPECT_EQ(sb.soft_penalty, sa.soft_penalty);
  EXPECT_EQ(sb.riccati_tol, sa.riccati_tol);
  EXPECT_EQ(sb.riccati_max_iterations, sa.riccati_max_iterations);
  EXPECT_EQ(sb.kkt_solver, sa.kkt_solver);
  EXPECT_EQ(sb.qp_scale_cost, sa.qp_scale_cost);
  EXPECT_EQ(sb.linearization, sa.linearization);
  EXPECT_EQ(sb.qp_solver, sa.qp_solver);
  EXPECT_EQ(sb.active_set_max_iterations, sa.active_set_max_iterations);
  EXPECT_EQ(sb.qp_preconditioner_iterations, sa.qp_preconditioner_iterations);
  EXPECT_EQ(sb.qp_reg_lower_limit, sa.qp_reg_lower_limit);
  EXPECT_EQ(sb.qp_retry_reg_lower_limit, sa.qp_retry_reg_lower_limit);
  EXPECT_EQ(sb.A_structure.size(), 0);
  EXPECT_EQ(sb.B_structure.size(), 0);
  expect_same_bits(sa.G_structure, sb.G_structure, "G_structure");
  EXPECT_EQ(b.reference.t0, 0.25);
  expect_same_bits(a.reference.z, b.reference.z, "reference.z");
  expect_same_bits(a.reference.u, b.reference.u, "reference.u");
  expect_same_bits(a.tube.K, b.tube.K, "K");
  expect_same_bits(a.tube.Pe, b.tube.Pe, "Pe");
  ASSERT_TRUE(b.has_controller);
  EXPECT_EQ(b.controller.measured_input, a.controller.measured_input);
  for (const auto& [x, y] : {std::pair{&a.controller.identification_p, &b.controller.identification_p},
                             std::pair{&a.controller.identification_r, &b.controller.identification_r}}) {
    EXPECT_EQ(x->lambda, y->lambda);
    expect_same_bits(x->w0, y->w0, "w0");
    expect_same_bits(x->S0, y->S0, "S0");
    EXPECT_EQ(x->prior_weight, y->prior_weight);
    EXPECT_EQ(x->eig_floor, y->eig_floor);
    EXPECT_EQ(x->pw_scale, y->pw_scale);
  }
  EXPECT_EQ(b.controller.tube.redesign_margin, a.controller.tube.redesign_margin);
  EXPECT_EQ(b.controller.tube.alpha_search_period, 7);
  const auto same_design = [](const tubempc::control::SubsystemDesign& x,
                              const tubempc::control::SubsystemDesign& y) {
    expect_same_bits(x.K, y.K, "design K");
    EXPECT_EQ(x.alpha, y.alpha);
    expect_same_bits(x.P_W, y.P_W, "design P_W");
    expect_same_bits(x.Pe, y.Pe, "design Pe");
  };
  same_design(a.tbmpc_designs.initial_p, b.tbmpc_designs.initial_p);
  same_design(a.tbmpc_designs.initial_r, b.tbmpc_designs.initial_r);
  same_design(a.ffa_designs.initial_p, b.ffa_designs.initial_p);
  same_design(a.ffa_designs.initial_r, b.ffa_designs.initial_r);
  ASSERT_EQ(b.ffa_designs.library_p.size(), 2u);
  EXPECT_TRUE(b.ffa_designs.library_r.empty());
  for (std::size_t i = 0; i < 2; ++i) same_design(a.ffa_designs.library_p[i], b.ffa_designs.library_p[i]);
  expect_same_bits(a.x0, b.x0, "x0");
  expect_same_bits(a.xf, b.xf, "xf");
  for (int i = 0; i < 2; ++i)
    expect_same_bits(a.controller.actuation_error[static_cast<std::size_t>(i)],
                     b.controller.actuation_error[static_cast<std::size_t>(i)], "actuation_error");
  EXPECT_TRUE(b.controller.feedforward);
  EXPECT_EQ(b.controller.feedforward_limit, 0.0123);
  // navigation: a sample of each section (the text comparison below covers every record)
  const tubempc::io::NavigationScenario &na = a.navigation, &nb = b.navigation;
  ASSERT_TRUE(nb.enabled);
  EXPECT_EQ(nb.settings.altimeter.sigma, na.settings.altimeter.sigma);
  expect_same_bits(na.settings.camera.C_BC, nb.settings.camera.C_BC, "camera.C_BC");
  expect_same_bits(na.settings.camera.pixel_bias, nb.settings.camera.pixel_bias, "camera.pixel_bias");
  EXPECT_EQ(nb.settings.camera.width_px, 640);
  EXPECT_EQ(nb.settings.imu.gyro_bias_sigma, na.settings.imu.gyro_bias_sigma);
  expect_same_bits(na.settings.star_tracker.misalignment_B, nb.settings.star_tracker.misalignment_B,
                   "star_tracker.misalignment_B");
  EXPECT_EQ(nb.settings.filter.camera.focal_length_px, na.settings.filter.camera.focal_length_px);
  EXPECT_EQ(nb.settings.filter.innovation_gate, std::numeric_limits<double>::infinity());
  EXPECT_TRUE(nb.settings.filter.split);
  EXPECT_EQ(nb.settings.filter.max_substeps, 9);
  EXPECT_EQ(nb.settings.filter.gravity_relinearization_distance, 2.5);
  EXPECT_EQ(nb.settings.filter.gravity_expansion_tolerance, 3e-8);
  EXPECT_EQ(nb.settings.filter.covariance_step, 1.0 / 3.0);
  expect_same_bits(na.settings.initial_sigma, nb.settings.initial_sigma, "initial_sigma");
  expect_same_bits(na.settings.period_noise_sigma, nb.settings.period_noise_sigma, "period_noise_sigma");
  EXPECT_EQ(nb.settings.max_samples, 40);
  ASSERT_EQ(nb.landmarks.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    expect_same_bits(na.landmarks[i].p_A, nb.landmarks[i].p_A, "landmark p_A");
    expect_same_bits(na.landmarks[i].normal_A, nb.landmarks[i].normal_A, "landmark normal_A");
    EXPECT_EQ(nb.landmarks[i].face, na.landmarks[i].face);
  }
  EXPECT_EQ(nb.seed, na.seed);
  EXPECT_EQ(nb.error_set_scale, na.error_set_scale);
  // actuators
  const tubempc::io::ActuatorScenario &aa = a.actuators, &ab = b.actuators;
  ASSERT_TRUE(ab.enabled);
  ASSERT_EQ(ab.thrusters.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const auto &x = aa.thrusters[i], &y = ab.thrusters[i];
    expect_same_bits(x.position_B, y.position_B, "position_B");
    expect_same_bits(x.direction_B, y.direction_B, "direction_B");
    expect_same_bits(x.misalignment_B, y.misalignment_B, "misalignment_B");
    EXPECT_EQ(y.max_thrust, x.max_thrust);
    EXPECT_EQ(y.min_on_time, x.min_on_time);
    EXPECT_EQ(y.isp, x.isp);
    EXPECT_EQ(y.scale_error, x.scale_error);
    EXPECT_EQ(y.scale_error_bound, x.scale_error_bound);
    EXPECT_EQ(y.misalignment_bound, x.misalignment_bound);
    EXPECT_EQ(y.fault, x.fault);
    EXPECT_EQ(y.fault_time, x.fault_time);
  }
  EXPECT_EQ(ab.thrusters[1].fault, tubempc::actuators::FaultKind::FailedOff);
  ASSERT_EQ(ab.wheels.size(), 1u);
  expect_same_bits(aa.wheels[0].axis_B, ab.wheels[0].axis_B, "axis_B");
  EXPECT_EQ(ab.wheels[0].max_momentum, aa.wheels[0].max_momentum);
  EXPECT_FALSE(ab.momentum_dump.enabled);
  EXPECT_EQ(ab.momentum_dump.time_constant, aa.momentum_dump.time_constant);
  expect_same_bits(aa.wheel_momentum, ab.wheel_momentum, "wheel_momentum");
  EXPECT_EQ(ab.settings.mass, aa.settings.mass);
  EXPECT_EQ(ab.settings.modulation.on_time_resolution, 1e-4);
  expect_same_bits(aa.settings.allocation.residual_weight, ab.settings.allocation.residual_weight,
                   "residual_weight");
  EXPECT_EQ(ab.settings.allocation.max_iterations, 77);
  // the safe abort
  const tubempc::io::AbortScenario &ta = a.abort, &tb = b.abort;
  ASSERT_TRUE(tb.enabled);
  EXPECT_EQ(tb.settings.commit_step, 1);
  EXPECT_FALSE(tb.settings.on_tube_uncertified);
  EXPECT_TRUE(tb.settings.on_input_nis);
  EXPECT_EQ(tb.settings.disturbance_limit, std::numeric_limits<double>::infinity());
  EXPECT_EQ(tb.settings.input_nis_window, 7);
  EXPECT_EQ(tb.settings.input_nis_limit, ta.settings.input_nis_limit);
  EXPECT_EQ(tb.command_step, 2);
  EXPECT_EQ(tb.hover.t0, 0.25);
  expect_same_bits(ta.hover.z, tb.hover.z, "hover.z");
  expect_same_bits(ta.hover.u, tb.hover.u, "hover.u");
  expect_same_bits(ta.designs.initial_r.Pe, tb.designs.initial_r.Pe, "abort designs_r.Pe");
  ASSERT_EQ(tb.designs.library_r.size(), 2u);
  expect_same_bits(ta.designs.library_r[1].K, tb.designs.library_r[1].K, "abort library_r[1].K");
  EXPECT_EQ(tb.designs.library_p[0].alpha, ta.designs.library_p[0].alpha);

  // Writing what was read reproduces the file (the comment aside).
  const std::string again = (dir_ / "again.txt").string();
  write_scenario(again, b, "test scenario\nsecond comment line");
  std::ifstream in(again);
  std::ostringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), text_);
}

TEST_F(ScenarioFileTest, OptionalRecordsTakeDefaults) {
  std::string text = text_;
  for (const char* name : {"mpc.trust_region 1 1\ninf\n", "mpc.kkt_solver text\nsparse_ldlt\n",
                           "mpc.G_structure 2 12\n", "model.glide_slope_apex_A 3 1\n"}) {
    const std::size_t at = text.find(name);
    ASSERT_NE(at, std::string::npos) << name;
    std::size_t end = at + std::string(name).size();
    if (std::string(name) == "mpc.G_structure 2 12\n") end = text.find("reference.t0", at);
    if (std::string(name) == "model.glide_slope_apex_A 3 1\n")
      end = text.find("model.glide_slope_axis_A", at);
    text.erase(at, end - at);
  }
  std::ofstream(path_, std::ios::binary) << text;
  const ScenarioFile s = read_scenario(path_);
  EXPECT_EQ(s.settings.trust_region, tubempc::mpc::Settings{}.trust_region);
  EXPECT_EQ(s.settings.G_structure.size(), 0);
  EXPECT_EQ(s.model.params.glide_slope_apex_A, tubempc::dynamics::ModelParams{}.glide_slope_apex_A);
}

// A version-3 file (no actuation-error sets, navigation or actuators) reads with ideal actuators and
// without navigation; a version-4 record is unknown there.
TEST_F(ScenarioFileTest, VersionThreeFilesAreRead) {
  const std::string text = version_three();
  ASSERT_EQ(text.find("navigation."), std::string::npos);
  const std::string path = (dir_ / "v3.txt").string();
  std::ofstream(path, std::ios::binary) << text;
  const ScenarioFile fresh = read_scenario(path_), old = read_scenario(path);
  EXPECT_TRUE(old.has_controller);
  EXPECT_FALSE(old.navigation.enabled);
  EXPECT_FALSE(old.actuators.enabled);
  EXPECT_FALSE(old.abort.enabled);
  EXPECT_TRUE(old.controller.actuation_error[0].isZero(0.0) && old.controller.actuation_error[1].isZero(0.0));
  EXPECT_FALSE(old.controller.feedforward);
  EXPECT_EQ(old.controller.identification_p.lambda, fresh.controller.identification_p.lambda);
  expect_same_bits(old.ffa_designs.initial_r.Pe, fresh.ffa_designs.initial_r.Pe, "ffa_r.Pe");
  expect_same_bits(old.xf, fresh.xf, "xf");
  std::ofstream(path, std::ios::binary) << text << "navigation.enabled 1 1\n0\n";
  try {
    read_scenario(path);
    ADD_FAILURE() << "accepted a version-4 record in a version-3 file";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("navigation.enabled: unknown record name (format version 3)"),
              std::string::npos)
        << e.what();
  }
}

// A version-1 file (the option names before the one-name-per-option change) reads to the same scenario.
TEST_F(ScenarioFileTest, VersionOneFilesAreRead) {
  std::string text = version_three();
  const auto replace = [&text](const std::string& from, const std::string& to) {
    const std::size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
  };
  replace("tubempc-scenario 3", "tubempc-scenario 1");
  const ScenarioFile fresh = read_scenario(path_);
  // versions 1 and 2 carry TBMPC's tube instead of the controller
  const std::size_t c0 = text.find("controller.measured_input"), c1 = text.find("mission.x0");
  ASSERT_NE(c0, std::string::npos);
  std::ostringstream tube;
  tube << "tube.K 6 12\n"
       << fresh.tube.K.format(Eigen::IOFormat(17, Eigen::DontAlignCols, " ", "\n")) << "\n";
  tube << "tube.Pe 12 12\n"
       << fresh.tube.Pe.format(Eigen::IOFormat(17, Eigen::DontAlignCols, " ", "\n")) << "\n";
  text.replace(c0, c1 - c0, tube.str());
  // the truth's first-order kinematics under version 1's name (the model's stays "exact")
  ASSERT_EQ(fresh.truth.params.kinematics, tubempc::dynamics::Kinematics::FirstOrder);
  ASSERT_EQ(fresh.model.params.kinematics, tubempc::dynamics::Kinematics::Exact);
  replace("truth.kinematics text\nfirst_order", "truth.kinematics text\npaper");
  replace(std::string("mpc.input_cost text\n") + tubempc::mpc::to_string(fresh.settings.input_cost),
          fresh.settings.input_cost == tubempc::mpc::InputCost::Absolute
              ? "mpc.input_cost text\npaper"
              : "mpc.input_cost text\nfrom_reference");
  replace(std::string("mpc.qp_solver text\n") + tubempc::mpc::to_string(fresh.settings.qp_solver),
          fresh.settings.qp_solver == tubempc::mpc::QpSolver::Piqp ? "mpc.backend text\npiqp"
                                                                   : "mpc.backend text\nactive_set_piqp");
  replace(std::string("mpc.linearization text\n") + tubempc::mpc::to_string(fresh.settings.linearization),
          fresh.settings.linearization == tubempc::mpc::Linearization::Reuse
              ? "mpc.reuse_linearization 1 1\n1"
              : "mpc.reuse_linearization 1 1\n0");
  const std::string path = (dir_ / "v1.txt").string();
  std::ofstream(path, std::ios::binary) << text;
  const ScenarioFile old = read_scenario(path);
  EXPECT_EQ(old.model.params.kinematics, fresh.model.params.kinematics);
  EXPECT_EQ(old.truth.params.kinematics, fresh.truth.params.kinematics);
  EXPECT_EQ(old.settings.input_cost, fresh.settings.input_cost);
  EXPECT_EQ(old.settings.qp_solver, fresh.settings.qp_solver);
  EXPECT_EQ(old.settings.linearization, fresh.settings.linearization);
  EXPECT_FALSE(old.has_controller);
  EXPECT_TRUE(old.tube.Pe.isApprox(fresh.tube.Pe, 1e-15));
  // and a version-2 name in a version-1 file is unknown there
  std::ofstream(path, std::ios::binary) << text << "mpc.qp_solver text\npiqp\n";
  EXPECT_THROW(read_scenario(path), std::invalid_argument);
}

TEST_F(ScenarioFileTest, ErrorsNameFileLineAndRecord) {
  expect_error("tubempc-scenario 6", "tubempc-scenario 7", 1, "format version 7 is not supported");
  expect_error("tubempc-scenario 6", "tubempc 6", 1, "not a tubempc scenario file");
  const long mu = line_of("model.mu_sun 1 1");
  expect_error("model.mu_sun 1 1\n1.32712440018e+20", "model.mu_sun 1 1\n1.3271x", mu + 1,
               "model.mu_sun: row 0, column 0: bad number '1.3271x'");
  // bytes of the file quoted in a message: printable ASCII, the others \xNN (the message stays UTF-8)
  expect_error("model.mu_sun 1 1\n1.32712440018e+20", "model.mu_sun 1 1\n1.3\xae\t", mu + 1,
               "model.mu_sun: row 0, column 0: bad number '1.3\\xae'");
  expect_error("model.mu_sun 1 1\n1.32712440018e+20", "model.mu_sun 1 1\nnan", mu + 1,
               "model.mu_sun: row 0, column 0: NaN");
  expect_error("model.mu_sun 1 1\n1.32712440018e+20", "model.mu_sun 1 1\ninf", mu + 1,
               "model.mu_sun: infinite value");
  expect_error("model.mu_sun 1 1\n1.32712440018e+20", "model.mu_sun 1 2\n1 2", mu,
               "model.mu_sun: expected size 1 x 1, got 1 x 2");
  expect_error("model.mu_sun 1 1\n1.32712440018e+20", "model.mu_sun 1 x\n1", mu,
               "model.mu_sun: bad size '1 x'");
  expect_error("model.mu_sun 1 1\n1.32712440018e+20", "model.mu_sun text\n1", mu,
               "expected a numeric record");
  expect_error("model.mu_sun 1 1\n1.32712440018e+20", "model.mu_sun 1 1 1\n1", mu, "bad record header");
  expect_error("model.mu_sun 1 1\n1.32712440018e+20", "model.mu_sun 1 1\n1\nmodel.mu_sun 1 1\n2", mu + 2,
               "model.mu_sun: repeated record (first on line " + std::to_string(mu) + ")");
  expect_error("model.mu_sun 1 1\n1.32712440018e+20", "model.mu_sunn 1 1\n1", 0,
               "model.mu_sun: missing record");
  expect_error("model.mu_sun 1 1\n1.32712440018e+20", "model.mu_sun 1 1\n1\nmodel.extra 1 1\n1", mu + 2,
               "model.extra: unknown record name");
  expect_error("model.mu_sun 1 1\n1.32712440018e+20", "model.mu_sun 1 1\n-1", 0, "model.* (ModelParams): ");
  const long kin = line_of("model.kinematics text");
  expect_error("model.kinematics text\nexact", "model.kinematics text\nexactly", kin + 1,
               "model.kinematics: unknown value 'exactly' (known: 'first_order', 'exact', 'paper')");
  const long inertia = line_of("model.inertia_B 3 3");
  expect_error("model.inertia_B 3 3\n2750 0.33333333333333331 0",
               "model.inertia_B 3 3\n2750 0.33333333333333331", inertia + 1,
               "model.inertia_B: row 0: expected 3 values, got 2");
  expect_error("model.density 1 1\n1260", "model.density 1 1\n0", 0,
               "model.* (BodyModel): BodyModel.density: must be finite and > 0, got 0");
  // a fixed-size optional record may be left out, not written empty
  const long axis = line_of("model.glide_slope_axis_A 3 1");
  expect_error("model.glide_slope_axis_A 3 1\n" + line_at(axis + 1) + "\n" + line_at(axis + 2) + "\n" +
                   line_at(axis + 3) + "\n",
               "model.glide_slope_axis_A 0 0\n", axis,
               "model.glide_slope_axis_A: expected size 3 x 1, got 0 x 0");
  const long sub = line_of("propagator.substeps 1 1");
  expect_error("propagator.substeps 1 1\n8", "propagator.substeps 1 1\n8.5", sub + 1,
               "propagator.substeps: expected an integer, got 8.5");
  expect_error("propagator.substeps 1 1\n8", "propagator.substeps 1 1\n0", 0,
               "propagator.* (PropagatorSettings): ");
  const long soft = line_of("mpc.soft_terminal 1 1");
  expect_error("mpc.soft_terminal 1 1\n1", "mpc.soft_terminal 1 1\n2", soft + 1,
               "mpc.soft_terminal: expected 0 or 1");
  expect_error("mpc.u_max 6 1\n0.55000000000000004", "mpc.u_max 6 1\n-0.5", 0, "mpc.* (mpc::Settings): ");
  expect_error("mpc.trust_region 1 1\ninf", "mpc.trust_region 1 1\nnan", line_of("mpc.trust_region 1 1") + 1,
               "NaN");
  const long u = line_of("reference.u 3 6");
  expect_error("reference.u 3 6\n" + line_at(u + 1) + "\n", "reference.u 2 6\n", u,
               "reference.u: expected size 3 x 6, got 2 x 6");
  expect_error("designs.ffa_r.Pe 6 6", "designs.ffa_r.Pe 6 7", line_of("designs.ffa_r.Pe 6 6") + 1,
               "designs.ffa_r.Pe: row 0: expected 7 values");
  expect_error("designs.tbmpc_p.alpha 1 1\n", "designs.tbmpc_p.alpha 1 1\n1.5\n#", 0,
               "designs.tbmpc_p.alpha: must lie in (0, 1)");
  expect_error("identification_p.lambda 1 1\n0.95999999999999996", "identification_p.lambda 1 1\n1", 0,
               "identification_p.lambda: must lie in (0, 1)");
  expect_error("tube.alpha_search_period 1 1\n7", "tube.alpha_search_period 1 1\n0", 0,
               "tube.alpha_search_period: must be >= 1");
  const long ff = line_of("controller.feedforward_limit 1 1");
  expect_error("controller.feedforward_limit 1 1\n0.0123", "controller.feedforward_limit 1 1\n1.5", ff + 1,
               "controller.feedforward_limit: must be in (0, 1)");
  expect_error("mission.x0 12 1", "mission.x0 13 1", line_of("mission.xf 12 1"),
               "mission.x0: row 12: expected 1 values, got 3");
  const long last = line_of("abort.library_r.Pe 12 6");  // the file's last record
  expect_error("abort.library_r.Pe 12 6", "abort.library_r.Pe 13 6", last,
               "abort.library_r.Pe: the file ends after 12 of 13 rows");
}

TEST_F(ScenarioFileTest, NavigationAndActuatorErrorsNameLineAndRecord) {
  expect_error("navigation.enabled 1 1\n1", "navigation.enabled 1 1\n2",
               line_of("navigation.enabled 1 1") + 1, "navigation.enabled: expected 0 or 1, got 2");
  const long seed = line_of("navigation.seed 1 1");
  expect_error("navigation.seed 1 1\n1099512627779", "navigation.seed 1 1\n-1", seed + 1,
               "navigation.seed: expected an integer in [0, 2^53], got -1");
  expect_error("navigation.seed 1 1\n1099512627779", "navigation.seed 1 1\n1e300", seed + 1,
               "navigation.seed: expected an integer in [0, 2^53]");
  expect_error("navigation.error_set_scale 1 1\n", "navigation.error_set_scale 1 1\n0\n#",
               line_of("navigation.error_set_scale 1 1") + 1,
               "navigation.error_set_scale: must be > 0, got 0");
  // the control period must be a whole number of IMU periods, at most max_samples of them
  expect_error("navigation.max_samples 1 1\n40", "navigation.max_samples 1 1\n10",
               line_of("navigation.imu.period 1 1"),
               "navigation.imu.period: the control period mpc.dt = 2 s");
  // a value a validate() rejects: at its record's line when the message names it
  const long landmarks = line_of("navigation.camera.max_landmarks 1 1");
  expect_error("navigation.camera.max_landmarks 1 1\n16", "navigation.camera.max_landmarks 1 1\n0",
               landmarks + 1, "navigation.camera.max_landmarks: ");
  const long filter_landmarks = line_of("navigation.filter.camera.max_landmarks 1 1");
  expect_error("navigation.filter.camera.max_landmarks 1 1\n16",
               "navigation.filter.camera.max_landmarks 1 1\n0", filter_landmarks + 1,
               "navigation.filter.camera.max_landmarks: ");
  expect_error("navigation.filter.max_step 1 1\n", "navigation.filter.max_step 1 1\n-1\n#",
               line_of("navigation.filter.max_step 1 1") + 1,
               "navigation.filter.max_step: must be finite and > 0");
  expect_error("navigation.camera.period 1 1\n2", "navigation.camera.period 1 1\n2.05",
               line_of("navigation.camera.period 1 1") + 1,
               "navigation.camera.period: must be an integer multiple of imu.period");
  expect_error("navigation.filter.innovation_gate 1 1\ninf", "navigation.filter.innovation_gate 1 1\nx",
               line_of("navigation.filter.innovation_gate 1 1") + 1, "bad number 'x'");
  expect_error("navigation.camera.max_range 1 1\n5000", "navigation.camera.max_range 1 1\ninf",
               line_of("navigation.camera.max_range 1 1") + 1, "navigation.camera.max_range: infinite value");
  const long lm = line_of("navigation.landmarks 3 7");
  expect_error(line_at(lm + 2), "1 2 3 1 0 1 7", lm + 2,
               "navigation.landmarks: row 1: normal_A must be a unit vector");
  expect_error(line_at(lm + 2), "1 2 3 1 0 0 7.5", lm + 2,
               "navigation.landmarks: row 1: face must be an integer");
  expect_error("navigation.landmarks 3 7", "navigation.landmarks 3 6", lm + 1,
               "row 0: expected 6 values, got 7");
  expect_error("actuators.thrusters 1 1\n2", "actuators.thrusters 1 1\n40",
               line_of("actuators.thrusters 1 1"), "actuators.thrusters: expected 1 to 32 thrusters, got 40");
  expect_error("actuators.thrusters 1 1\n2", "actuators.thrusters 1 1\n3", 0,
               "actuators.thrusters[2].position_B: missing record");
  expect_error("actuators.wheels 1 1\n1", "actuators.wheels 1 1\n0", line_of("actuators.wheel_momentum 1 1"),
               "actuators.wheel_momentum: expected size 0 x 1 (or 0 x 0), got 1 x 1");
  const long fault = line_of("actuators.thrusters[1].fault text");
  expect_error(
      "actuators.thrusters[1].fault text\nfailed_off", "actuators.thrusters[1].fault text\nstuck", fault + 1,
      "actuators.thrusters[1].fault: unknown value 'stuck' (known: 'none', 'failed_off', 'stuck_on')");
  expect_error("actuators.thrusters[0].scale_error_bound 1 1\n0.050000000000000003",
               "actuators.thrusters[0].scale_error_bound 1 1\n0.001",
               line_of("actuators.thrusters[0].scale_error 1 1") + 1,
               "actuators.thrusters[0].scale_error: must be finite with |scale_error| <= scale_error_bound");
  expect_error(
      "actuators.momentum_dump.stop_fraction 1 1\n", "actuators.momentum_dump.stop_fraction 1 1\n0.9\n#",
      line_of("actuators.momentum_dump.stop_fraction 1 1") + 1, "actuators.momentum_dump.stop_fraction: ");
  expect_error("actuators.wheel_momentum 1 1\n", "actuators.wheel_momentum 1 1\n-100\n#", 0,
               "actuators.* (ActuationSystem): ");
  expect_error("actuators.modulation.period 1 1\n2", "actuators.modulation.period 1 1\n1",
               line_of("actuators.modulation.period 1 1"),
               "actuators.modulation.period: must equal mpc.dt = 2 s, got 1");
  expect_error("actuators.allocation.max_iterations 1 1\n77", "actuators.allocation.max_iterations 1 1\n77.5",
               line_of("actuators.allocation.max_iterations 1 1") + 1, "expected an integer, got 77.5");
}

TEST_F(ScenarioFileTest, AbortErrorsNameLineAndRecord) {
  const long commit = line_of("abort.commit_step 1 1");
  expect_error("abort.commit_step 1 1\n1", "abort.commit_step 1 1\n3", commit,
               "abort.commit_step: must be below T = 3, got 3");
  expect_error("abort.commit_step 1 1\n1", "abort.commit_step 1 1\n-2", commit + 1,
               "abort.commit_step: must be >= -1, got -2");
  expect_error("abort.input_nis_window 1 1\n7", "abort.input_nis_window 1 1\n33",
               line_of("abort.input_nis_window 1 1") + 1, "abort.input_nis_window: must be in [1, 32]");
  expect_error("abort.disturbance_limit 1 1\ninf", "abort.disturbance_limit 1 1\n0",
               line_of("abort.disturbance_limit 1 1") + 1, "abort.disturbance_limit: must be > 0");
  expect_error("abort.command_step 1 1\n2", "abort.command_step 1 1\n3", line_of("abort.command_step 1 1"),
               "abort.command_step: must be in [-1, 3), got 3");
  // a hover shorter than the mission: 3 nodes for T = 3
  const long hz = line_of("abort.hover.z 6 12");
  std::string text = text_;
  const std::size_t z0 = text.find("abort.hover.z 6 12\n"), u0 = text.find("abort.hover.u 5 6\n");
  ASSERT_NE(z0, std::string::npos);
  ASSERT_NE(u0, std::string::npos);
  std::istringstream rows(text.substr(u0));
  std::string u_text, line;
  std::getline(rows, line);
  for (int i = 0; i < 2; ++i) u_text += (std::getline(rows, line), line + "\n");
  std::istringstream zrows(text.substr(z0));
  std::string z_text;
  std::getline(zrows, line);
  for (int i = 0; i < 3; ++i) z_text += (std::getline(zrows, line), line + "\n");
  const std::size_t u_end = text.find("abort.designs_p.K");
  text.replace(z0, u_end - z0, "abort.hover.z 3 12\n" + z_text + "abort.hover.u 2 6\n" + u_text);
  const std::string path = (dir_ / "short.txt").string();
  std::ofstream(path, std::ios::binary) << text;
  try {
    read_scenario(path);
    ADD_FAILURE() << "accepted a hover shorter than the mission";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(
        std::string(e.what()).rfind(path + ":" + std::to_string(hz) + ": abort.hover.z: needs at least", 0),
        0u)
        << e.what();
  }
  // an abort controller without a library (written empty, refused when read)
  ScenarioFile no_library = sample(3);
  no_library.abort.designs.library_p.clear();
  const std::string empty = (dir_ / "no_library.txt").string();
  write_scenario(empty, no_library);
  try {
    read_scenario(empty);
    ADD_FAILURE() << "accepted an abort without a library";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("abort.library_p.alpha: the abort controller needs a library"),
              std::string::npos)
        << e.what();
  }
}

TEST(ScenarioFileErrors, MissingFileAndEmptyFile) {
  const std::string missing = (fs::temp_directory_path() / "tubempc_no_such_scenario.txt").string();
  try {
    read_scenario(missing);
    ADD_FAILURE() << "accepted a missing file";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind(missing + ": cannot open the file", 0), 0u) << e.what();
  }
  ScenarioFile s;  // default: no weights, no reference
  EXPECT_THROW(write_scenario((fs::temp_directory_path() / "tubempc_never.txt").string(), s),
               std::invalid_argument);
}
