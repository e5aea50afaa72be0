/// @file scenario.hpp
/// The scenario file: everything a C++ program needs to fly the closed loop the Python package sets
/// up (`tubempc export-scenario`, python/tubempc/results/export.py): the controller's and the truth's 6-DOF
/// models, the tube MPC's settings, the reference trajectory, the whole controller of both methods,
/// the initial and target states, the truth propagator's settings, and (version 4) the navigation
/// system and the actuators of one run. Plain text, versioned, exact (every double written with 17
/// significant digits, so reading gives back the same bits).
///
/// Format, version 6 (versions 1 to 5 are read too; see below)
/// -------------------------------------------------------------
/// - Line 1: `tubempc-scenario 5`. Lines starting with `#` (after optional blanks) and blank lines
///   are comments anywhere else.
/// - Then records in any order, each name at most once:
///   - numeric: a header line `<name> <rows> <cols>` followed by `rows` lines of `cols` numbers each
///     (a matrix row per line, row-major; `0 0` for an empty matrix, with no value lines). Numbers
///     are C-locale decimals (`%.17g`); `inf`/`-inf` only where noted, never `nan`. Integers and
///     flags (0 or 1) are numeric 1 x 1 records.
///   - text: a header line `<name> text` followed by one line holding the value (leading and
///     trailing blanks dropped; not empty).
/// - Names, sizes and units (n_x = 12, n_u = 6, T the mission's steps; "opt." = optional):
///
///   | record | size | meaning |
///   | --- | --- | --- |
///   | `model.<field>` | | every field of dynamics::ModelParams, as its for_each_field lists them (name, size, unit, optional): `model.kinematics` is text (`first_order` or `exact`; version 1: `paper`), `srp_enabled` a flag, `inertia_B` 3 3, the vectors 3 1 (the optional `glide_slope_apex_A`, `glide_slope_axis_A` may be left out, not written empty) |
///   | `model.density`, `.shape`, `.shape_unit_scale` | 1 1, text, 1 1 | the fields of io::BodyModel, as its for_each_field lists them: asteroid density (kg/m^3), shape file (gravity/shape_io.hpp, relative to the scenario's folder or absolute), metres per unit of the shape file |
///   | `truth.*` | | the same records for the simulated plant (the truth model) |
///   | `propagator.method` | text | `rk4` or `dopri5` |
///   | `propagator.substeps`, `.rtol`, `.atol`, `.max_steps`, `.initial_step` | 1 1 each | dynamics::PropagatorSettings (s for initial_step) |
///   | `mpc.<field>` | | every field of mpc::Settings, as mpc::Settings::for_each_field lists them (name, size in n_x, n_u and n_c = 2, unit, optional, may be `inf`): integers and flags (0 or 1) are 1 x 1, options are text with the names of their core::EnumNames table; an optional matrix may be `0 0` |
///   | `reference.t0` | 1 1 | time of node 0 (s) |
///   | `reference.z` | T+1 12 | reference states zbar_0..zbar_T, one node per row |
///   | `reference.u` | T 6 | reference inputs u_ref_0..u_ref_{T-1}, one node per row |
///   | `tube.K` | 6 12 | TBMPC's ancillary gain (versions 1-2 only; version 3: from `designs.tbmpc_*`) |
///   | `tube.Pe` | 12 12 | TBMPC's tube shape (versions 1-2 only) |
///   | `controller.measured_input` | text | `residual` or `reference_deviation` (control::MeasuredInput) |
///   | `identification_p.<field>`, `identification_r.<field>` | | every field of control::IdentifierSettings (translational, rotational), as its for_each_field lists them (sizes in n_w = 6) |
///   | `tube.redesign_margin` | 1 1 | control::TubePolicySettings::redesign_margin |
///   | `tube.alpha_search_period` | 1 1 | integer, steps |
///   | `designs.<m>_<s>.K`, `.alpha`, `.P_W`, `.Pe` | 3 6, 1 1, 6 6, 6 6 | initial LMI design of method `<m>` (`tbmpc`, `ffa`) and subsystem `<s>` (`p`, `r`) |
///   | `library_<s>.K`, `.alpha`, `.P_W`, `.Pe` | 3L 6, L 1, 6L 6, 6L 6 | TBMPC-FFA's library of L designs of subsystem `<s>`, stacked (`0 0` for L = 0) |
///   | `mission.x0` | 12 1 | initial state [r_L (m), v_L (m/s), phi (rad), omega_BL_B (rad/s)] |
///   | `mission.xf` | 12 1 | target state, same units |
///   | `controller.actuation_error_p`, `controller.actuation_error_r` | 3 3 each | control::ControllerSettings::actuation_error ((m/s^2)^2, (N m)^2) |
///   | `controller.feedforward` | 1 1 | control::ControllerSettings::feedforward (0/1; version 5; 0 in older files) |
///   | `controller.feedforward_limit` | 1 1 | control::ControllerSettings::feedforward_limit (version 5) |
///   | `navigation.enabled` | 1 1 | flag (NavigationScenario::enabled); the `navigation.*` records below only when 1 |
///   | `navigation.<sensor>.<field>` | | the true sensors: every field of nav::AltimeterSettings, CameraSettings, ImuSettings, StarTrackerSettings (`<sensor>` = `altimeter`, `camera`, `imu`, `star_tracker`), under their C++ names and sizes (integers and flags 1 1) |
///   | `navigation.filter.<sensor>.<field>`, `navigation.filter.<field>` | | nav::FilterSettings: its model of the four sensors, then `accel_model_noise`, `altimeter_terrain_sigma`, `innovation_gate` (may be `inf`), `gravity_relinearization_distance`, `gravity_expansion_tolerance`, `max_step`, `covariance_step`, `max_substeps`, `split` |
///   | `navigation.initial_sigma`, `navigation.period_noise_sigma`, `navigation.max_samples` | 9 1, 9 1, 1 1 | the rest of nav::NavigationSettings |
///   | `navigation.landmarks` | L 7 | the catalogue (frame A), one landmark per row: p_A (m), normal_A (unit), face (integer >= 0); L >= 1 |
///   | `navigation.seed` | 1 1 | NavigationScenario::seed, an integer in [0, 2^53] |
///   | `navigation.error_set_scale` | 1 1 | NavigationScenario::error_set_scale (> 0) |
///   | `actuators.enabled` | 1 1 | flag (ActuatorScenario::enabled); the `actuators.*` records below only when 1 |
///   | `actuators.thrusters`, `actuators.wheels` | 1 1 each | n (1 to kMaxThrusters) and m (0 to kMaxWheels) |
///   | `actuators.thrusters[<i>].<field>` | | every field of actuators::ThrusterSpec of thruster i = 0..n-1 (`fault` text: `none`, `failed_off`, `stuck_on`) |
///   | `actuators.wheels[<j>].<field>` | | every field of actuators::ReactionWheelSpec of wheel j = 0..m-1 |
///   | `actuators.momentum_dump.<field>` | | actuators::MomentumDumpSettings |
///   | `actuators.wheel_momentum` | m 1 | the wheels' initial momenta (N m s); `0 0` for m = 0 |
///   | `actuators.mass`, `actuators.modulation.<field>`, `actuators.allocation.<field>` | | actuators::ActuationSettings (both periods equal to `mpc.dt`) |
///   | `abort.enabled` | 1 1 | flag (AbortScenario::enabled, version 6); the `abort.*` records below only when 1 |
///   | `abort.<field>` | 1 1 each | every field of control::AbortSettings (commit_step < T an integer >= -1, flags, limits; `disturbance_limit` may be `inf`) |
///   | `abort.command_step` | 1 1 | integer in [-1, T) (AbortScenario::command_step) |
///   | `abort.hover.z`, `abort.hover.u` | T_h+1 12, T_h 6 | the abort's hover reference, one node per row, T_h >= T |
///   | `abort.designs_p.*`, `abort.designs_r.*`, `abort.library_p.*`, `abort.library_r.*` | | the abort controller's initial designs and libraries, as `designs.ffa_*` and `library_*` (libraries not empty) |
///
///   Optional records default to mpc::Settings' defaults (the structures to dense). Everything else
///   is required; unknown names are errors (a later version adds names and bumps the number).
///   Version 6 adds the safe abort (version-5 files read with the abort disabled); version 5 the feed-forward.
///   Version 4 adds the actuation-error sets, the navigation and the actuators; version-3 files read
///   with zero actuation-error sets, navigation and actuators disabled.
///   Version 3 adds the whole controller (control::Controller: identification, tube policy, designs and
///   libraries) and drops `tube.K`/`tube.Pe` (TBMPC's tube is `designs.tbmpc_*`). Version 2 files carry
///   TBMPC's tube only: ScenarioFile::has_controller is false for them.
///   Version 1 files are read too: they name the options `paper` (kinematics `first_order`, input
///   cost `absolute`) and `from_reference` (`deviation`), and carry `mpc.backend` (`active_set_piqp`
///   or `piqp`) and the flag `mpc.reuse_linearization` instead of `mpc.qp_solver` and `mpc.linearization`.
///
/// Example (abridged):
///
///     tubempc-scenario 4
///     # exported by tubempc 0.1.0
///     model.mu_sun 1 1
///     1.32712440018e+20
///     model.kinematics text
///     exact
///     mpc.u_max 6 1
///     0.55000000000000004
///     ...
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "tubempc/actuators/system.hpp"
#include "tubempc/control/abort.hpp"
#include "tubempc/control/controller.hpp"
#include "tubempc/dynamics/propagator.hpp"
#include "tubempc/dynamics/proximity_model.hpp"
#include "tubempc/mpc/tube_mpc.hpp"
#include "tubempc/nav/system.hpp"

namespace tubempc::io {

/// Version of the scenario format this library reads and writes.
inline constexpr int kScenarioFormatVersion = 6;

/// One 6-DOF model of the scenario: the inputs of gravity::load_shape, gravity::PolyhedronGravity
/// and dynamics::ProximityModel.
struct BodyModel {
  dynamics::ModelParams params;  ///< dynamics constants (SI; see dynamics::ModelParams)
  double density{1260.0};        ///< asteroid density (kg/m^3), finite and > 0
  std::string shape;             ///< shape file as written: relative to ScenarioFile::directory, or absolute
  double shape_unit_scale{1.0};  ///< metres per unit of the shape file, finite and > 0

  /// Checks density and shape_unit_scale (finite, > 0) and that shape is not empty.
  /// @throws std::invalid_argument naming the first bad field (`BodyModel.<field>`).
  void validate() const;

  /// The fields besides `params` (whose own table is dynamics::ModelParams::for_each_field), once:
  /// calls visit(info, pointer to the member) per member, in the order scenario files write them
  /// (after the ModelParams records). Drives the scenario file and the Python binding.
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit) {
    using core::FieldInfo;
    using B = BodyModel;
    visit(FieldInfo{"density", "kg/m^3", false, false, core::Dim::One, core::Dim::One,
                    "asteroid density (kg/m^3)"},
          &B::density);
    visit(FieldInfo{"shape", "", false, false, core::Dim::One, core::Dim::One,
                    "shape file as written (relative to ScenarioFile.directory or absolute)"},
          &B::shape);
    visit(FieldInfo{"shape_unit_scale", "", false, false, core::Dim::One, core::Dim::One,
                    "metres per unit of the shape file"},
          &B::shape_unit_scale);
  }
};

/// The navigation of a scenario (version 4: the records navigation.(field)): what nav::NavigationSystem is
/// constructed from, and the scale of the estimation-error set the controller's constraints are
/// tightened by (control::Controller::set_estimation_error).
struct NavigationScenario {
  bool enabled{false};               ///< whether the controller flies on the navigation's estimate
  nav::NavigationSettings settings;  ///< the true sensors, the filter and the sigmas
  /// The landmark catalogue (frame A): the generated one, then the site's (python/tubempc/scenario/navigation.py).
  std::vector<nav::Landmark> landmarks;
  std::uint64_t seed{0};  ///< the navigation system's seed (the run's seed + 1000003 in Python)
  /// c of the estimation-error set {e : e^T (c P_x)^-1 e <= 1} (the chi-square quantile of
  /// navigation.error_set_probability with 12 degrees of freedom), finite and > 0.
  double error_set_scale{1.0};
};

/// The actuators of a scenario (version 4: the records actuators.(field)): what actuators::ActuationSystem is
/// constructed from, the truth's thrusters of one run (nominal geometry, that run's scale and
/// misalignment errors, faults).
struct ActuatorScenario {
  bool enabled{false};                               ///< false: ideal actuators (the input is delivered)
  std::vector<actuators::ThrusterSpec> thrusters;    ///< the truth's thrusters, 1 to kMaxThrusters
  std::vector<actuators::ReactionWheelSpec> wheels;  ///< the wheels, 0 to kMaxWheels
  actuators::MomentumDumpSettings momentum_dump;     ///< the wheels' momentum-dump policy
  Eigen::VectorXd wheel_momentum;                    ///< the wheels' initial momenta (N m s, one per wheel)
  actuators::ActuationSettings settings;             ///< mass, modulation and allocation (period = mpc dt)
};

/// The safe abort of a scenario (version 6: the records abort.(field)): what control::SafeAbort is set up with
/// (docs/model.md M52; Python: tubempc.sim.abort).
struct AbortScenario {
  bool enabled{false};              ///< whether the descent is supervised and may back away
  control::AbortSettings settings;  ///< the supervision: commit step, triggers and their limits
  /// The abort's hover reference: 12 x (T_h + 1) and 6 x T_h with T_h >= T (it runs past the mission's end);
  /// t0 is the mission reference's.
  mpc::Reference hover;
  control::ControllerDesigns
      designs;           ///< the abort controller's designs about the hover (libraries not empty)
  int command_step{-1};  ///< a commanded abort at this step (-1: none; [abort] command_time / dt)
};

/// Contents of a scenario file (see the file comment for the format).
struct ScenarioFile {
  /// Folder of the file read (relative shape paths are relative to it); empty if not read from a file.
  std::string directory;
  BodyModel model;                          ///< the controller's model (records `model.*`)
  BodyModel truth;                          ///< the simulated plant (records `truth.*`)
  dynamics::PropagatorSettings propagator;  ///< truth propagation per control period
  mpc::Settings settings;                   ///< tube MPC settings
  mpc::Reference reference;                 ///< zbar (12 x (T + 1)), u_ref (6 x T) as columns, t0 (s)
  mpc::Tube tube;                           ///< TBMPC's fixed tube: K (6 x 12), Pe (12 x 12)
  /// Whether the file carries the whole controller (version 3); the members below are valid only then.
  bool has_controller{false};
  /// The controller's settings (method set by the program flying it; version 3).
  control::ControllerSettings controller;
  control::ControllerDesigns tbmpc_designs;  ///< TBMPC's designs (no library; version 3)
  control::ControllerDesigns ffa_designs;    ///< TBMPC-FFA's initial designs and libraries (version 3)
  dynamics::StateVector x0{dynamics::StateVector::Zero()};  ///< initial state (m, m/s, rad, rad/s)
  dynamics::StateVector xf{dynamics::StateVector::Zero()};  ///< target state (same units)
  NavigationScenario navigation;  ///< the navigation (version 4; disabled in older files)
  ActuatorScenario actuators;     ///< the actuators (version 4; ideal in older files)
  AbortScenario abort;            ///< the safe abort (version 6; disabled in older files)

  /// @return the mission length T (steps): the number of reference inputs.
  int mission_steps() const { return static_cast<int>(reference.u.cols()); }
  /// A path written in the file (e.g. BodyModel::shape) made usable from the current directory.
  /// @param path relative to `directory`, or absolute.
  /// @return `directory`/path for a relative path; the path itself if absolute or if `directory` is empty.
  std::string resolve(const std::string& path) const;
};

/// Reads and validates a scenario file (format version 6, 5, 4, 3, 2 or 1).
/// @param path the scenario file.
/// @return its contents; `directory` is the file's folder. The shape files are not opened. The
///         navigation's and the actuators' settings are those their constructors accept (an
///         actuators::ActuationSystem is built to check them), the control period a whole number of
///         IMU periods (at most NavigationSettings::max_samples).
/// @throws std::invalid_argument `<path>:<line>: <record>: <what>` for a malformed record (bad header,
///         number or size, NaN, an infinity where none is allowed, a non-integer or out-of-range
///         integer, a flag other than 0/1, an unknown option, an unknown or repeated name), and
///         `<path>: <record>: <what>` for a missing record, an unreadable file, or values rejected by
///         ModelParams::validate, PropagatorSettings::validate, mpc::Settings::validate or the
///         size checks of the reference, the tube and the states; a navigation or actuator value a
///         validate() rejects is reported at its record's line.
ScenarioFile read_scenario(const std::string& path);

/// Writes a scenario file (format version 6) with every record, optional ones included.
/// @param path     file to create or overwrite.
/// @param scenario contents; shape paths are written as they are (relative ones stay relative).
/// @param comment  optional text written as `#` comment lines after the version line.
/// @throws std::invalid_argument if the contents have the wrong sizes for the format (12 states,
///         6 inputs), carry no controller (has_controller false), an enabled navigation without
///         landmarks or with a seed above 2^53, or enabled actuators without one momentum per wheel;
///         std::runtime_error naming the path when the file cannot be written.
void write_scenario(const std::string& path, const ScenarioFile& scenario, const std::string& comment = "");

}  // namespace tubempc::io
