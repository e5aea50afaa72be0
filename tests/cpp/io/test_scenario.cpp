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

// A version-1 file (the option names before the one-name-per-option change) reads to the same scenario.
TEST_F(ScenarioFileTest, VersionOneFilesAreRead) {
  std::string text = text_;
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
  expect_error("tubempc-scenario 3", "tubempc-scenario 4", 1, "format version 4 is not supported");
  expect_error("tubempc-scenario 3", "tubempc 3", 1, "not a tubempc scenario file");
  const long mu = line_of("model.mu_sun 1 1");
  expect_error("model.mu_sun 1 1\n1.32712440018e+20", "model.mu_sun 1 1\n1.3271x", mu + 1,
               "model.mu_sun: row 0, column 0: bad number '1.3271x'");
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
  expect_error("mission.x0 12 1", "mission.x0 13 1", line_of("mission.xf 12 1"),
               "mission.x0: row 12: expected 1 values, got 3");
  const long xf = line_of("mission.xf 12 1");
  expect_error("mission.xf 12 1", "mission.xf 13 1", xf, "mission.xf: the file ends after 12 of 13 rows");
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
