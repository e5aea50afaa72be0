#include "tubempc/io/scenario.hpp"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "../core/text.hpp"

namespace tubempc::io {

namespace {

using core::text::format_double;

constexpr const char* kMagic = "tubempc-scenario";

// Options are read and written with their enum's names (core::EnumNames, the same as the
// configuration's and to_string's); format version 1 also named some otherwise (below), still read.
template <typename E>
using Options = std::initializer_list<std::pair<const char*, E>>;
// Version 1's other names of the kinematics and input costs (read in every version) and its mpc.backend.
const Options<dynamics::Kinematics> kKinematicsV1 = {{"paper", dynamics::Kinematics::FirstOrder}};
const Options<mpc::InputCost> kInputCostsV1 = {{"paper", mpc::InputCost::Absolute},
                                               {"from_reference", mpc::InputCost::Deviation}};

// The older names an option enum is also read under (none but for the two above).
template <typename E>
Options<E> older_names() {
  if constexpr (std::is_same_v<E, dynamics::Kinematics>) {
    return kKinematicsV1;
  } else if constexpr (std::is_same_v<E, mpc::InputCost>) {
    return kInputCostsV1;
  } else {
    return {};
  }
}
const Options<mpc::QpSolver> kBackendsV1 = {{"piqp", mpc::QpSolver::Piqp},
                                            {"active_set_piqp", mpc::QpSolver::ActiveSet}};

// The file name of an option with a core::EnumNames table.
template <typename E>
const char* option_name(E value) {
  if (!core::is_named(value)) {
    throw std::invalid_argument("write_scenario: option value " + std::to_string(static_cast<int>(value)) +
                                " has no name in the scenario format");
  }
  return core::enum_name(value);
}

// Size of a dimension in the scenario's model: 12 states, 6 inputs, 2 state constraints (glide slope
// and line of sight), 6 subsystem states; the fixed sizes as they are.
Eigen::Index scenario_size(core::Dim d) {
  switch (d) {
    case core::Dim::Nx:
      return dynamics::kNx;
    case core::Dim::Nu:
      return dynamics::kNu;
    case core::Dim::Nc:
      return 2;
    case core::Dim::Nw:
      return 6;
    default:
      return core::fixed_size(d);
  }
}

// One record as read: a text value, or a matrix, with the line of each value row (text: of the value).
struct Record {
  long line{0};
  bool is_text{false};
  std::string text;
  Eigen::MatrixXd values;
  std::vector<long> row_lines;
  long first_infinite_line{0};  // line of the first +-inf value, 0 if none
  bool used{false};
};

class Reader {
 public:
  explicit Reader(std::string path) : path_(std::move(path)) {}
  int version() const { return version_; }

  [[noreturn]] void fail(long line, const std::string& what) const {
    // What the message quotes from the file is printable ASCII, other bytes written \xNN: the message
    // stays valid UTF-8 (Python's ValueError) whatever the file holds.
    std::string text;
    for (const char ch : what) {
      const auto byte = static_cast<unsigned char>(ch);
      if (byte >= 0x20 && byte < 0x7f) {
        text += ch;
      } else {
        static constexpr char kHex[] = "0123456789abcdef";
        text += {'\\', 'x', kHex[byte >> 4], kHex[byte & 0xf]};
      }
    }
    throw std::invalid_argument(line > 0 ? path_ + ":" + std::to_string(line) + ": " + text
                                         : path_ + ": " + text);
  }

  void parse() {
    std::ifstream in(path_, std::ios::binary);
    if (!in) fail(0, std::string("cannot open the file (") + std::strerror(errno) + ")");
    std::vector<std::string_view> tokens;
    std::string raw;
    long number = 0;
    // The next line that is not blank or a comment; false at the end of the file.
    auto next = [&]() {
      while (std::getline(in, raw)) {
        ++number;
        core::text::split(raw, tokens);
        if (!tokens.empty() && tokens[0].front() != '#') return true;
      }
      if (in.bad()) fail(0, "read error after line " + std::to_string(number));
      return false;
    };
    if (!std::getline(in, raw)) fail(1, "empty file (expected the line '" + std::string(kMagic) + " 1')");
    number = 1;
    core::text::split(raw, tokens);
    std::int64_t version = 0;
    if (tokens.size() != 2 || tokens[0] != kMagic || !core::text::parse_int64(tokens[1], version)) {
      fail(1, "not a tubempc scenario file (the first line must be '" + std::string(kMagic) + " " +
                  std::to_string(kScenarioFormatVersion) + "')");
    }
    if (version < 1 || version > kScenarioFormatVersion) {
      fail(1, "format version " + std::to_string(version) +
                  " is not supported (this reader reads versions 1 to " +
                  std::to_string(kScenarioFormatVersion) + ")");
    }
    version_ = static_cast<int>(version);
    while (next()) {
      const std::string name(tokens[0]);
      Record rec;
      rec.line = number;
      if (records_.count(name) != 0) {
        fail(number, name + ": repeated record (first on line " + std::to_string(records_[name].line) + ")");
      }
      if (tokens.size() == 2 && tokens[1] == "text") {
        rec.is_text = true;
        if (!next()) fail(rec.line, name + ": the file ends before the text value");
        const std::size_t b = raw.find_first_not_of(" \t\r\v\f");
        const std::size_t e = raw.find_last_not_of(" \t\r\v\f");
        rec.text = raw.substr(b, e - b + 1);
        rec.row_lines.push_back(number);
      } else if (tokens.size() == 3) {
        std::int64_t rows = 0, cols = 0;
        if (!core::text::parse_int64(tokens[1], rows) || !core::text::parse_int64(tokens[2], cols) ||
            rows < 0 || cols < 0 || rows > 10'000'000 || cols > 10'000) {
          fail(number, name + ": bad size '" + std::string(tokens[1]) + " " + std::string(tokens[2]) +
                           "' (expected '<rows> <cols>', non-negative integers)");
        }
        if ((rows == 0) != (cols == 0)) fail(number, name + ": an empty matrix is written '0 0'");
        rec.values.resize(rows, cols);
        for (Eigen::Index i = 0; i < rows; ++i) {
          if (!next()) {
            fail(rec.line, name + ": the file ends after " + std::to_string(i) + " of " +
                               std::to_string(rows) + " rows");
          }
          if (tokens.size() != static_cast<std::size_t>(cols)) {
            fail(number, name + ": row " + std::to_string(i) + ": expected " + std::to_string(cols) +
                             " values, got " + std::to_string(tokens.size()));
          }
          for (Eigen::Index j = 0; j < cols; ++j) {
            double v = 0.0;
            const std::string_view t = tokens[static_cast<std::size_t>(j)];
            if (!core::text::parse_double(t, v)) {
              fail(number, name + ": row " + std::to_string(i) + ", column " + std::to_string(j) +
                               ": bad number '" + std::string(t.substr(0, 40)) + "'");
            }
            if (std::isnan(v)) {
              fail(number, name + ": row " + std::to_string(i) + ", column " + std::to_string(j) + ": NaN");
            }
            if (std::isinf(v) && rec.first_infinite_line == 0) rec.first_infinite_line = number;
            rec.values(i, j) = v;
          }
          rec.row_lines.push_back(number);
        }
      } else {
        fail(number, "bad record header '" + std::string(raw.substr(0, 80)) +
                         "' (expected '<name> <rows> <cols>' or '<name> text')");
      }
      records_.emplace(name, std::move(rec));
    }
  }

  // The record `name`, or null if it is absent and optional.
  Record* find(const std::string& name, bool required) {
    const auto it = records_.find(name);
    if (it == records_.end()) {
      if (required) fail(0, name + ": missing record");
      return nullptr;
    }
    it->second.used = true;
    return &it->second;
  }

  // A numeric record of the given size (rows < 0: any number of rows); `allow_empty` also takes 0 x 0.
  Record* numeric(const std::string& name, Eigen::Index rows, Eigen::Index cols, bool required = true,
                  bool allow_empty = false, bool allow_infinite = false) {
    Record* r = find(name, required);
    if (r == nullptr) return nullptr;
    if (r->is_text) fail(r->line, name + ": expected a numeric record, got a text record");
    const Eigen::Index n = r->values.rows(), m = r->values.cols();
    const bool empty_ok = allow_empty && n == 0 && m == 0;
    if (!empty_ok && ((rows >= 0 && n != rows) || m != cols)) {
      fail(r->line, name + ": expected size " + (rows >= 0 ? std::to_string(rows) : std::string("<rows>")) +
                        " x " + std::to_string(cols) + (allow_empty ? " (or 0 x 0)" : "") + ", got " +
                        std::to_string(n) + " x " + std::to_string(m));
    }
    if (!allow_infinite && r->first_infinite_line > 0)
      fail(r->first_infinite_line, name + ": infinite value");
    return r;
  }

  Eigen::MatrixXd matrix(const std::string& name, Eigen::Index rows, Eigen::Index cols) {
    return numeric(name, rows, cols)->values;
  }

  void optional_matrix(const std::string& name, Eigen::Index rows, Eigen::Index cols, Eigen::MatrixXd& out) {
    if (Record* r = numeric(name, rows, cols, false, true)) out = r->values;
  }

  template <int N>
  Eigen::Matrix<double, N, 1> vector(const std::string& name) {
    return numeric(name, N, 1)->values;
  }

  double scalar(const std::string& name) { return numeric(name, 1, 1)->values(0, 0); }

  void integer(const std::string& name, int& out, bool required = true) {
    Record* r = numeric(name, 1, 1, required);
    if (r == nullptr) return;
    const double v = r->values(0, 0);
    if (v != std::floor(v) || v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max()) {
      fail(r->row_lines[0], name + ": expected an integer, got " + format_double(v));
    }
    out = static_cast<int>(v);
  }

  void flag(const std::string& name, bool& out, bool required = true) {
    Record* r = numeric(name, 1, 1, required);
    if (r == nullptr) return;
    const double v = r->values(0, 0);
    if (v != 0.0 && v != 1.0) fail(r->row_lines[0], name + ": expected 0 or 1, got " + format_double(v));
    out = v == 1.0;
  }

  std::string text(const std::string& name) {
    Record* r = find(name, true);
    if (!r->is_text) fail(r->line, name + ": expected a text record ('" + name + " text')");
    return r->text;
  }

  template <typename E>
  void option(const std::string& name, const Options<E>& options, E& out, bool required = true) {
    Record* r = find(name, required);
    if (r == nullptr) return;
    if (!r->is_text) fail(r->line, name + ": expected a text record ('" + name + " text')");
    std::string known;
    for (const auto& [text, value] : options) {
      if (r->text == text) {
        out = value;
        return;
      }
      known += (known.empty() ? "'" : ", '") + std::string(text) + "'";
    }
    fail(r->row_lines[0], name + ": unknown value '" + r->text.substr(0, 40) + "' (known: " + known + ")");
  }

  // An option with a core::EnumNames table, also read under the names of `others` (older versions').
  template <typename E>
  void option(const std::string& name, E& out, bool required, const Options<E>& others = {}) {
    Record* r = find(name, required);
    if (r == nullptr) return;
    if (!r->is_text) fail(r->line, name + ": expected a text record ('" + name + " text')");
    if (core::enum_from_name(r->text, out)) return;
    std::string known = core::enum_names_list<E>();
    for (const auto& [text, value] : others) {
      if (r->text == text) {
        out = value;
        return;
      }
      known += ", '" + std::string(text) + "'";
    }
    fail(r->row_lines[0], name + ": unknown value '" + r->text.substr(0, 40) + "' (known: " + known + ")");
  }

  // Runs a validate() of the core and reports its message against the file.
  template <typename F>
  void validated(const std::string& what, F&& check) const {
    try {
      check();
    } catch (const std::invalid_argument& e) {
      fail(0, what + ": " + e.what());
    }
  }

  // Runs a validate() of the core whose message starts with a field's name ("<field>: <what>"): when
  // `base` + that name is a record of the file, reports it at the record's (first value) line,
  // otherwise as validated().
  template <typename F>
  void validated_field(const std::string& what, const std::string& base, F&& check) const {
    try {
      check();
    } catch (const std::invalid_argument& e) {
      const std::string message = e.what();
      const auto it = records_.find(base + message.substr(0, message.find(':')));
      if (it == records_.end()) fail(0, what + ": " + message);
      fail(it->second.row_lines.empty() ? it->second.line : it->second.row_lines[0], base + message);
    }
  }

  void check_all_used() const {
    for (const auto& [name, rec] : records_) {
      if (!rec.used)
        fail(rec.line, name + ": unknown record name (format version " + std::to_string(version_) + ")");
    }
  }

  long line_of(const std::string& name) const { return records_.at(name).line; }

 private:
  std::string path_;
  int version_ = 0;
  std::map<std::string, Record> records_;
};

// The records `prefix<name>` of the fields of a struct described by for_each_field (core::FieldInfo);
// a nested struct's are `prefix<name>.<field>`.
template <typename S>
struct FieldReader {
  Reader& r;
  S& s;
  std::string prefix;

  template <typename T>
  void operator()(const core::FieldInfo& f, T S::*member) const {
    if (!f.in_file) return;
    const std::string name = prefix + f.name;
    T& value = s.*member;
    if constexpr (core::has_fields<T>::value) {
      T::for_each_field(FieldReader<T>{r, value, name + "."});
    } else if constexpr (std::is_same_v<T, int>) {
      r.integer(name, value, !f.optional);
    } else if constexpr (std::is_same_v<T, bool>) {
      r.flag(name, value, !f.optional);
    } else if constexpr (std::is_same_v<T, double>) {
      if (const Record* rec = r.numeric(name, 1, 1, !f.optional, false, f.allow_infinite))
        value = rec->values(0, 0);
    } else if constexpr (std::is_same_v<T, std::string>) {
      value = r.text(name);
    } else if constexpr (std::is_enum_v<T>) {
      r.option(name, value, !f.optional, older_names<T>());
    } else {  // an Eigen matrix or vector; an optional dynamic-size one may be empty (0 x 0)
      constexpr bool fixed = T::SizeAtCompileTime != Eigen::Dynamic;
      if (Record* rec = r.numeric(name, scenario_size(f.rows), scenario_size(f.cols), !f.optional,
                                  f.optional && !fixed))
        value = rec->values;
    }
  }
};

// The records `prefix<name>` of one BodyModel (its ModelParams, then its own fields), validated.
void read_body(Reader& r, const std::string& prefix, BodyModel& body) {
  dynamics::ModelParams::for_each_field(FieldReader<dynamics::ModelParams>{r, body.params, prefix});
  BodyModel::for_each_field(FieldReader<BodyModel>{r, body, prefix});
  r.validated(prefix + "* (ModelParams)", [&] { body.params.validate(); });
  r.validated(prefix + "* (BodyModel)", [&] { body.validate(); });
}

void read_mpc(Reader& r, mpc::Settings& st) {
  const FieldReader<mpc::Settings> read{r, st, "mpc."};
  mpc::Settings::for_each_field([&](const core::FieldInfo& f, auto member) {
    const std::string_view name = f.name;
    // version 1: mpc.backend and the 0/1 flag mpc.reuse_linearization instead
    if (r.version() == 1 && (name == "qp_solver" || name == "linearization")) return;
    read(f, member);
  });
  if (r.version() == 1) {
    r.option("mpc.backend", kBackendsV1, st.qp_solver, false);
    bool reuse = true;
    r.flag("mpc.reuse_linearization", reuse, false);
    st.linearization = reuse ? mpc::Linearization::Reuse : mpc::Linearization::EveryIteration;
  }
  r.validated("mpc.* (mpc::Settings)", [&] { st.validate(dynamics::kNx, dynamics::kNu); });
}

void read_design(Reader& r, const std::string& prefix, control::SubsystemDesign& d) {
  d.K = r.matrix(prefix + "K", 3, 6);
  d.alpha = r.scalar(prefix + "alpha");
  d.P_W = r.matrix(prefix + "P_W", 6, 6);
  d.Pe = r.matrix(prefix + "Pe", 6, 6);
  r.validated(prefix + "*", [&] { d.validate(prefix.substr(0, prefix.size() - 1)); });
}

std::vector<control::SubsystemDesign> read_library(Reader& r, const std::string& prefix) {
  const Eigen::MatrixXd alpha = r.numeric(prefix + "alpha", -1, 1, true, true)->values;
  const Eigen::Index L = alpha.rows();
  const Eigen::MatrixXd K = r.numeric(prefix + "K", 3 * L, 6, true, L == 0)->values;
  const Eigen::MatrixXd P_W = r.numeric(prefix + "P_W", 6 * L, 6, true, L == 0)->values;
  const Eigen::MatrixXd Pe = r.numeric(prefix + "Pe", 6 * L, 6, true, L == 0)->values;
  std::vector<control::SubsystemDesign> out(static_cast<std::size_t>(L));
  for (Eigen::Index i = 0; i < L; ++i) {
    control::SubsystemDesign& d = out[static_cast<std::size_t>(i)];
    d.K = K.middleRows(3 * i, 3);
    d.alpha = alpha(i, 0);
    d.P_W = P_W.middleRows(6 * i, 6);
    d.Pe = Pe.middleRows(6 * i, 6);
    r.validated(prefix + "* (design " + std::to_string(i) + ")",
                [&] { d.validate(prefix + std::to_string(i)); });
  }
  return out;
}

// TBMPC's block-diagonal tube from its two subsystem designs.
mpc::Tube block_tube(const control::ControllerDesigns& d) {
  mpc::Tube t;
  t.K = Eigen::MatrixXd::Zero(dynamics::kNu, dynamics::kNx);
  t.Pe = Eigen::MatrixXd::Zero(dynamics::kNx, dynamics::kNx);
  t.K.block<3, 6>(0, 0) = d.initial_p.K;
  t.K.block<3, 6>(3, 6) = d.initial_r.K;
  t.Pe.block<6, 6>(0, 0) = d.initial_p.Pe;
  t.Pe.block<6, 6>(6, 6) = d.initial_r.Pe;
  return t;
}

// ---- writer ----------------------------------------------------------------------------------

class Writer {
 public:
  explicit Writer(std::ostream& out) : out_(out) {}

  void matrix(const std::string& name, const Eigen::MatrixXd& m) {
    out_ << name << ' ' << m.rows() << ' ' << m.cols() << '\n';
    for (Eigen::Index i = 0; i < m.rows(); ++i) {
      for (Eigen::Index j = 0; j < m.cols(); ++j) out_ << (j ? " " : "") << format_double(m(i, j));
      out_ << '\n';
    }
  }
  void scalar(const std::string& name, double v) { matrix(name, Eigen::MatrixXd::Constant(1, 1, v)); }
  void text(const std::string& name, const std::string& value) {
    const bool blank = value.find_first_not_of(" \t\r\v\f") == std::string::npos;
    if (blank || value.find('\n') != std::string::npos || value.front() == '#' ||
        std::isspace(static_cast<unsigned char>(value.front())) ||
        std::isspace(static_cast<unsigned char>(value.back()))) {
      throw std::invalid_argument("write_scenario: " + name +
                                  ": a text value must be one non-empty line without "
                                  "leading '#' or surrounding blanks, got '" +
                                  value + "'");
    }
    out_ << name << " text\n" << value << '\n';
  }

 private:
  std::ostream& out_;
};

// ---- navigation and actuator records (version 4) ---------------------------------------------

// Writes the records `prefix<name>` of the fields of a struct described by for_each_field
// (core::FieldInfo); a nested struct's are `prefix<name>.<field>`.
template <typename S>
struct FieldWriter {
  Writer& w;
  const S& s;
  std::string prefix;

  template <typename T>
  void operator()(const core::FieldInfo& f, T S::*member) const {
    if (!f.in_file) return;
    const std::string name = prefix + f.name;
    const T& value = s.*member;
    if constexpr (core::has_fields<T>::value) {
      T::for_each_field(FieldWriter<T>{w, value, name + "."});
    } else if constexpr (std::is_same_v<T, bool>) {
      w.scalar(name, value ? 1.0 : 0.0);
    } else if constexpr (std::is_arithmetic_v<T>) {
      w.scalar(name, value);
    } else if constexpr (std::is_enum_v<T>) {
      w.text(name, option_name(value));
    } else if constexpr (std::is_same_v<T, std::string>) {
      w.text(name, value);
    } else {
      w.matrix(name, value);
    }
  }
};

// 2^53: the largest integer a double holds exactly (the navigation's seed is written as a number).
constexpr double kMaxExactInteger = 9007199254740992.0;
// Landmark rows: p_A (3), normal_A (3), face.
constexpr Eigen::Index kLandmarkColumns = 7;

void read_navigation(Reader& r, double dt, NavigationScenario& n) {
  r.flag("navigation.enabled", n.enabled);
  if (!n.enabled) return;
  using Settings = nav::NavigationSettings;
  Settings::for_each_field(FieldReader<Settings>{r, n.settings, "navigation."});
  const nav::NavigationSettings& st = n.settings;
  // the sensors, then the filter's model of them and its own fields, then the rest: each message names
  // its record ("camera.period" is navigation.camera.period or navigation.filter.camera.period)
  r.validated_field("navigation.* (NavigationSettings)", "navigation.", [&] {
    st.altimeter.validate();
    st.camera.validate();
    st.imu.validate();
    st.star_tracker.validate();
  });
  r.validated_field("navigation.filter.* (FilterSettings)", "navigation.filter.", [&] {
    st.filter.altimeter.validate();
    st.filter.camera.validate();
    st.filter.imu.validate();
    st.filter.star_tracker.validate();
  });
  r.validated_field("navigation.filter.* (FilterSettings)", "navigation.", [&] { st.filter.validate(); });
  r.validated_field("navigation.* (NavigationSettings)", "", [&] { st.validate(); });
  const double h = n.settings.imu.period;
  const double ratio = std::round(dt / h);
  if (!(ratio >= 1.0 && std::abs(ratio * h - dt) <= 1e-9 * dt && ratio <= n.settings.max_samples)) {
    r.fail(r.line_of("navigation.imu.period"),
           "navigation.imu.period: the control period mpc.dt = " + format_double(dt) +
               " s must be a whole number (at most navigation.max_samples = " +
               std::to_string(n.settings.max_samples) + ") of IMU periods, got " + format_double(h) + " s");
  }
  const Record* lm = r.numeric("navigation.landmarks", -1, kLandmarkColumns);
  const Eigen::Index L = lm->values.rows();
  if (L == 0) r.fail(lm->line, "navigation.landmarks: the catalogue is empty");
  n.landmarks.assign(static_cast<std::size_t>(L), nav::Landmark{});
  for (Eigen::Index i = 0; i < L; ++i) {
    nav::Landmark& l = n.landmarks[static_cast<std::size_t>(i)];
    const auto row = lm->values.row(i);
    l.p_A = row.segment<3>(0).transpose();
    l.normal_A = row.segment<3>(3).transpose();
    const double face = row(6);
    const std::string where = "navigation.landmarks: row " + std::to_string(i) + ": ";
    if (std::abs(l.normal_A.norm() - 1.0) > 1e-9)
      r.fail(lm->row_lines[static_cast<std::size_t>(i)], where + "normal_A must be a unit vector");
    if (!(face >= 0.0 && face == std::floor(face) && face <= std::numeric_limits<int>::max()))
      r.fail(lm->row_lines[static_cast<std::size_t>(i)],
             where + "face must be an integer >= 0, got " + format_double(face));
    l.face = static_cast<Eigen::Index>(face);
  }
  const Record* seed = r.numeric("navigation.seed", 1, 1);
  const double s = seed->values(0, 0);
  if (!(s >= 0.0 && s == std::floor(s) && s <= kMaxExactInteger))
    r.fail(seed->row_lines[0], "navigation.seed: expected an integer in [0, 2^53], got " + format_double(s));
  n.seed = static_cast<std::uint64_t>(s);
  const Record* scale = r.numeric("navigation.error_set_scale", 1, 1);
  n.error_set_scale = scale->values(0, 0);
  if (!(n.error_set_scale > 0.0))
    r.fail(scale->row_lines[0],
           "navigation.error_set_scale: must be > 0, got " + format_double(n.error_set_scale));
}

void read_actuators(Reader& r, double dt, ActuatorScenario& a) {
  r.flag("actuators.enabled", a.enabled);
  if (!a.enabled) return;
  int n = 0, m = 0;
  r.integer("actuators.thrusters", n);
  if (n < 1 || n > actuators::kMaxThrusters)
    r.fail(r.line_of("actuators.thrusters"), "actuators.thrusters: expected 1 to " +
                                                 std::to_string(actuators::kMaxThrusters) +
                                                 " thrusters, got " + std::to_string(n));
  r.integer("actuators.wheels", m);
  if (m < 0 || m > actuators::kMaxWheels)
    r.fail(r.line_of("actuators.wheels"), "actuators.wheels: expected 0 to " +
                                              std::to_string(actuators::kMaxWheels) + " wheels, got " +
                                              std::to_string(m));
  a.thrusters.assign(static_cast<std::size_t>(n), actuators::ThrusterSpec{});
  for (int i = 0; i < n; ++i) {
    const std::string prefix = "actuators.thrusters[" + std::to_string(i) + "]";
    actuators::ThrusterSpec& t = a.thrusters[static_cast<std::size_t>(i)];
    actuators::ThrusterSpec::for_each_field(FieldReader<actuators::ThrusterSpec>{r, t, prefix + "."});
    r.validated_field(prefix + ".*", "", [&] { t.validate(prefix); });
  }
  a.wheels.assign(static_cast<std::size_t>(m), actuators::ReactionWheelSpec{});
  for (int j = 0; j < m; ++j) {
    const std::string prefix = "actuators.wheels[" + std::to_string(j) + "]";
    actuators::ReactionWheelSpec& w = a.wheels[static_cast<std::size_t>(j)];
    actuators::ReactionWheelSpec::for_each_field(
        FieldReader<actuators::ReactionWheelSpec>{r, w, prefix + "."});
    r.validated_field(prefix + ".*", "", [&] { w.validate(prefix); });
  }
  using Dump = actuators::MomentumDumpSettings;
  Dump::for_each_field(FieldReader<Dump>{r, a.momentum_dump, "actuators.momentum_dump."});
  const Record* h = r.numeric("actuators.wheel_momentum", m, 1, true, m == 0);
  a.wheel_momentum = m == 0 ? Eigen::VectorXd() : Eigen::VectorXd(h->values.col(0));
  using Settings = actuators::ActuationSettings;
  Settings::for_each_field(FieldReader<Settings>{r, a.settings, "actuators."});
  r.validated_field("actuators.* (ActuationSettings)", "actuators.", [&] {
    a.momentum_dump.validate();
    a.settings.modulation.validate();
    a.settings.allocation.validate();
  });
  if (a.settings.modulation.period != dt)
    r.fail(r.line_of("actuators.modulation.period"),
           "actuators.modulation.period: must equal mpc.dt = " + format_double(dt) + " s, got " +
               format_double(a.settings.modulation.period));
  // Everything ActuationSystem's construction checks (sizes, momenta within limits, minimum on-times
  // within the period, the settings), against the file.
  r.validated("actuators.* (ActuationSystem)", [&] {
    actuators::ReactionWheels wheels(a.wheels, a.momentum_dump);
    wheels.set_momentum(a.wheel_momentum);
    const actuators::ActuationSystem system(actuators::ThrusterCluster(a.thrusters), wheels, a.settings);
  });
}

void write_navigation(Writer& w, const NavigationScenario& n) {
  w.scalar("navigation.enabled", n.enabled ? 1.0 : 0.0);
  if (!n.enabled) return;
  using Settings = nav::NavigationSettings;
  Settings::for_each_field(FieldWriter<Settings>{w, n.settings, "navigation."});
  Eigen::MatrixXd L(static_cast<Eigen::Index>(n.landmarks.size()), kLandmarkColumns);
  for (Eigen::Index i = 0; i < L.rows(); ++i) {
    const nav::Landmark& l = n.landmarks[static_cast<std::size_t>(i)];
    L.row(i) << l.p_A.transpose(), l.normal_A.transpose(), static_cast<double>(l.face);
  }
  w.matrix("navigation.landmarks", L);
  w.scalar("navigation.seed", static_cast<double>(n.seed));
  w.scalar("navigation.error_set_scale", n.error_set_scale);
}

void write_actuators(Writer& w, const ActuatorScenario& a) {
  w.scalar("actuators.enabled", a.enabled ? 1.0 : 0.0);
  if (!a.enabled) return;
  w.scalar("actuators.thrusters", static_cast<double>(a.thrusters.size()));
  w.scalar("actuators.wheels", static_cast<double>(a.wheels.size()));
  for (std::size_t i = 0; i < a.thrusters.size(); ++i) {
    actuators::ThrusterSpec::for_each_field(FieldWriter<actuators::ThrusterSpec>{
        w, a.thrusters[i], "actuators.thrusters[" + std::to_string(i) + "]."});
  }
  for (std::size_t j = 0; j < a.wheels.size(); ++j) {
    actuators::ReactionWheelSpec::for_each_field(FieldWriter<actuators::ReactionWheelSpec>{
        w, a.wheels[j], "actuators.wheels[" + std::to_string(j) + "]."});
  }
  using Dump = actuators::MomentumDumpSettings;
  Dump::for_each_field(FieldWriter<Dump>{w, a.momentum_dump, "actuators.momentum_dump."});
  w.matrix("actuators.wheel_momentum",
           a.wheels.empty() ? Eigen::MatrixXd(0, 0) : Eigen::MatrixXd(a.wheel_momentum));
  using Settings = actuators::ActuationSettings;
  Settings::for_each_field(FieldWriter<Settings>{w, a.settings, "actuators."});
}

void write_body(Writer& w, const std::string& prefix, const BodyModel& body) {
  dynamics::ModelParams::for_each_field(FieldWriter<dynamics::ModelParams>{w, body.params, prefix});
  BodyModel::for_each_field(FieldWriter<BodyModel>{w, body, prefix});
}

void write_design(Writer& w, const std::string& prefix, const control::SubsystemDesign& d) {
  w.matrix(prefix + "K", d.K);
  w.scalar(prefix + "alpha", d.alpha);
  w.matrix(prefix + "P_W", d.P_W);
  w.matrix(prefix + "Pe", d.Pe);
}

void write_library(Writer& w, const std::string& prefix, const std::vector<control::SubsystemDesign>& lib) {
  const auto L = static_cast<Eigen::Index>(lib.size());
  Eigen::MatrixXd K(3 * L, 6), alpha(L, 1), P_W(6 * L, 6), Pe(6 * L, 6);
  for (Eigen::Index i = 0; i < L; ++i) {
    const control::SubsystemDesign& d = lib[static_cast<std::size_t>(i)];
    K.middleRows(3 * i, 3) = d.K;
    alpha(i, 0) = d.alpha;
    P_W.middleRows(6 * i, 6) = d.P_W;
    Pe.middleRows(6 * i, 6) = d.Pe;
  }
  const Eigen::MatrixXd empty(0, 0);
  w.matrix(prefix + "K", L == 0 ? empty : K);
  w.matrix(prefix + "alpha", L == 0 ? empty : alpha);
  w.matrix(prefix + "P_W", L == 0 ? empty : P_W);
  w.matrix(prefix + "Pe", L == 0 ? empty : Pe);
}

// ---- the safe abort's records (version 6) -----------------------------------------------------

void read_abort(Reader& r, int T, double t0, AbortScenario& a) {
  r.flag("abort.enabled", a.enabled);
  if (!a.enabled) return;
  using Settings = control::AbortSettings;
  Settings::for_each_field(FieldReader<Settings>{r, a.settings, "abort."});
  r.validated_field("abort.* (AbortSettings)", "", [&] { a.settings.validate(); });
  if (a.settings.commit_step >= T)
    r.fail(r.line_of("abort.commit_step"), "abort.commit_step: must be below T = " + std::to_string(T) +
                                               ", got " + std::to_string(a.settings.commit_step));
  r.integer("abort.command_step", a.command_step);
  if (a.command_step < -1 || a.command_step >= T)
    r.fail(r.line_of("abort.command_step"), "abort.command_step: must be in [-1, " + std::to_string(T) +
                                                "), got " + std::to_string(a.command_step));
  a.hover.z = r.matrix("abort.hover.z", -1, dynamics::kNx).transpose();
  const Eigen::Index T_h = a.hover.z.cols() - 1;
  if (T_h < T)
    r.fail(r.line_of("abort.hover.z"), "abort.hover.z: needs at least T + 1 = " + std::to_string(T + 1) +
                                           " nodes, got " + std::to_string(T_h + 1));
  a.hover.u = r.matrix("abort.hover.u", T_h, dynamics::kNu).transpose();
  a.hover.t0 = t0;
  read_design(r, "abort.designs_p.", a.designs.initial_p);
  read_design(r, "abort.designs_r.", a.designs.initial_r);
  a.designs.library_p = read_library(r, "abort.library_p.");
  a.designs.library_r = read_library(r, "abort.library_r.");
  if (a.designs.library_p.empty() || a.designs.library_r.empty()) {
    const std::string name = a.designs.library_p.empty() ? "abort.library_p.alpha" : "abort.library_r.alpha";
    r.fail(r.line_of(name), name + ": the abort controller needs a library (SafeAbort::setup)");
  }
}

void write_abort(Writer& w, const AbortScenario& a) {
  w.scalar("abort.enabled", a.enabled ? 1.0 : 0.0);
  if (!a.enabled) return;
  using Settings = control::AbortSettings;
  Settings::for_each_field(FieldWriter<Settings>{w, a.settings, "abort."});
  w.scalar("abort.command_step", a.command_step);
  w.matrix("abort.hover.z", a.hover.z.transpose());
  w.matrix("abort.hover.u", a.hover.u.transpose());
  write_design(w, "abort.designs_p.", a.designs.initial_p);
  write_design(w, "abort.designs_r.", a.designs.initial_r);
  write_library(w, "abort.library_p.", a.designs.library_p);
  write_library(w, "abort.library_r.", a.designs.library_r);
}

void require_size(const char* name, const Eigen::MatrixXd& m, Eigen::Index rows, Eigen::Index cols) {
  if ((rows >= 0 && m.rows() != rows) || m.cols() != cols) {
    throw std::invalid_argument("write_scenario: " + std::string(name) + " has size " +
                                std::to_string(m.rows()) + " x " + std::to_string(m.cols()) + ", expected " +
                                (rows >= 0 ? std::to_string(rows) : std::string("<rows>")) + " x " +
                                std::to_string(cols));
  }
}

}  // namespace

void BodyModel::validate() const {
  const auto positive = [](double v, const char* field) {
    if (!(std::isfinite(v) && v > 0.0))
      throw std::invalid_argument(std::string("BodyModel.") + field + ": must be finite and > 0, got " +
                                  format_double(v));
  };
  positive(density, "density");
  positive(shape_unit_scale, "shape_unit_scale");
  if (shape.empty()) throw std::invalid_argument("BodyModel.shape: must not be empty");
}

std::string ScenarioFile::resolve(const std::string& path) const {
  const std::filesystem::path p(path);
  if (directory.empty() || p.is_absolute()) return path;
  return (std::filesystem::path(directory) / p).string();
}

ScenarioFile read_scenario(const std::string& path) {
  Reader r(path);
  r.parse();
  ScenarioFile s;
  s.directory = std::filesystem::path(path).parent_path().string();
  read_body(r, "model.", s.model);
  read_body(r, "truth.", s.truth);

  using Propagator = dynamics::PropagatorSettings;
  Propagator::for_each_field(FieldReader<Propagator>{r, s.propagator, "propagator."});
  r.validated("propagator.* (PropagatorSettings)", [&] { s.propagator.validate(); });

  read_mpc(r, s.settings);

  s.reference.t0 = r.scalar("reference.t0");
  s.reference.z = r.matrix("reference.z", -1, dynamics::kNx).transpose();
  const Eigen::Index T = s.reference.z.cols() - 1;
  if (T < 1)
    r.fail(r.line_of("reference.z"),
           "reference.z: needs at least 2 nodes (T >= 1), got " + std::to_string(T + 1));
  s.reference.u = r.matrix("reference.u", T, dynamics::kNu).transpose();
  if (r.version() < 3) {
    s.tube.K = r.matrix("tube.K", dynamics::kNu, dynamics::kNx);
    s.tube.Pe = r.matrix("tube.Pe", dynamics::kNx, dynamics::kNx);
  } else {
    s.has_controller = true;
    control::ControllerSettings& c = s.controller;
    r.option("controller.measured_input", c.measured_input, true);
    if (r.version() >= 4) {
      c.actuation_error[0] = r.matrix("controller.actuation_error_p", 3, 3);
      c.actuation_error[1] = r.matrix("controller.actuation_error_r", 3, 3);
    }
    if (r.version() >= 5) {
      r.flag("controller.feedforward", c.feedforward);
      c.feedforward_limit = r.scalar("controller.feedforward_limit");
    }
    using Identifier = control::IdentifierSettings;
    Identifier::for_each_field(FieldReader<Identifier>{r, c.identification_p, "identification_p."});
    Identifier::for_each_field(FieldReader<Identifier>{r, c.identification_r, "identification_r."});
    using Tube = control::TubePolicySettings;
    Tube::for_each_field(FieldReader<Tube>{r, c.tube, "tube."});
    r.validated_field("controller.*, identification_*, tube.* (ControllerSettings)", "controller.",
                      [&] { c.validate(); });
    read_design(r, "designs.tbmpc_p.", s.tbmpc_designs.initial_p);
    read_design(r, "designs.tbmpc_r.", s.tbmpc_designs.initial_r);
    read_design(r, "designs.ffa_p.", s.ffa_designs.initial_p);
    read_design(r, "designs.ffa_r.", s.ffa_designs.initial_r);
    s.ffa_designs.library_p = read_library(r, "library_p.");
    s.ffa_designs.library_r = read_library(r, "library_r.");
    s.tube = block_tube(s.tbmpc_designs);
  }
  s.x0 = r.vector<dynamics::kNx>("mission.x0");
  s.xf = r.vector<dynamics::kNx>("mission.xf");
  if (r.version() >= 4) {
    read_navigation(r, s.settings.dt, s.navigation);
    read_actuators(r, s.settings.dt, s.actuators);
  }
  if (r.version() >= 6) read_abort(r, s.mission_steps(), s.reference.t0, s.abort);
  r.check_all_used();
  return s;
}

void write_scenario(const std::string& path, const ScenarioFile& s, const std::string& comment) {
  const mpc::Settings& st = s.settings;
  require_size("settings.Q", st.Q, dynamics::kNx, dynamics::kNx);
  require_size("settings.R", st.R, dynamics::kNu, dynamics::kNu);
  require_size("settings.u_max", st.u_max, dynamics::kNu, 1);
  require_size("reference.z", s.reference.z, dynamics::kNx, s.reference.z.cols());
  require_size("reference.u", s.reference.u, dynamics::kNu, s.reference.z.cols() - 1);
  if (!s.has_controller)
    throw std::invalid_argument(
        "write_scenario: the scenario carries no controller (has_controller is false)");

  if (s.navigation.enabled && s.navigation.landmarks.empty())
    throw std::invalid_argument("write_scenario: navigation.landmarks: the catalogue is empty");
  if (s.navigation.enabled && static_cast<double>(s.navigation.seed) > kMaxExactInteger)
    throw std::invalid_argument("write_scenario: navigation.seed: must be at most 2^53");
  if (s.actuators.enabled &&
      s.actuators.wheel_momentum.size() != static_cast<Eigen::Index>(s.actuators.wheels.size()))
    throw std::invalid_argument("write_scenario: actuators.wheel_momentum: one momentum per wheel is needed");
  if (s.abort.enabled) {
    require_size("abort.hover.z", s.abort.hover.z, dynamics::kNx, s.abort.hover.z.cols());
    require_size("abort.hover.u", s.abort.hover.u, dynamics::kNu, s.abort.hover.z.cols() - 1);
    if (s.abort.hover.u.cols() < s.mission_steps())
      throw std::invalid_argument("write_scenario: abort.hover: shorter than the mission");
  }

  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw std::runtime_error(path + ": cannot open for writing (" + std::strerror(errno) + ")");
  out << kMagic << ' ' << kScenarioFormatVersion << '\n';
  std::size_t start = 0;
  while (!comment.empty() && start <= comment.size()) {
    const std::size_t end = comment.find('\n', start);
    out << "# " << comment.substr(start, end == std::string::npos ? std::string::npos : end - start) << '\n';
    if (end == std::string::npos) break;
    start = end + 1;
  }
  Writer w(out);
  write_body(w, "model.", s.model);
  write_body(w, "truth.", s.truth);
  using Propagator = dynamics::PropagatorSettings;
  Propagator::for_each_field(FieldWriter<Propagator>{w, s.propagator, "propagator."});
  mpc::Settings::for_each_field(FieldWriter<mpc::Settings>{w, st, "mpc."});
  w.scalar("reference.t0", s.reference.t0);
  w.matrix("reference.z", s.reference.z.transpose());
  w.matrix("reference.u", s.reference.u.transpose());
  const control::ControllerSettings& c = s.controller;
  w.text("controller.measured_input", option_name(c.measured_input));
  w.matrix("controller.actuation_error_p", c.actuation_error[0]);
  w.matrix("controller.actuation_error_r", c.actuation_error[1]);
  w.scalar("controller.feedforward", c.feedforward ? 1.0 : 0.0);
  w.scalar("controller.feedforward_limit", c.feedforward_limit);
  using Identifier = control::IdentifierSettings;
  Identifier::for_each_field(FieldWriter<Identifier>{w, c.identification_p, "identification_p."});
  Identifier::for_each_field(FieldWriter<Identifier>{w, c.identification_r, "identification_r."});
  using Tube = control::TubePolicySettings;
  Tube::for_each_field(FieldWriter<Tube>{w, c.tube, "tube."});
  write_design(w, "designs.tbmpc_p.", s.tbmpc_designs.initial_p);
  write_design(w, "designs.tbmpc_r.", s.tbmpc_designs.initial_r);
  write_design(w, "designs.ffa_p.", s.ffa_designs.initial_p);
  write_design(w, "designs.ffa_r.", s.ffa_designs.initial_r);
  write_library(w, "library_p.", s.ffa_designs.library_p);
  write_library(w, "library_r.", s.ffa_designs.library_r);
  w.matrix("mission.x0", s.x0);
  w.matrix("mission.xf", s.xf);
  write_navigation(w, s.navigation);
  write_actuators(w, s.actuators);
  write_abort(w, s.abort);
  out.close();
  if (!out) throw std::runtime_error(path + ": write failed (" + std::strerror(errno) + ")");
}

}  // namespace tubempc::io
