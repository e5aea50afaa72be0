#include "tubempc/gravity/shape_io.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "../core/text.hpp"

namespace tubempc::gravity {

namespace {

using core::text::parse_double;
using core::text::parse_int64;

// `s` with every byte that is not part of a valid UTF-8 sequence, and every ASCII control byte,
// written as \xNN, so that a message quoting file content is valid UTF-8 (Python can decode it).
std::string printable_utf8(std::string_view s) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  out.reserve(s.size());
  auto escape = [&](unsigned char c) { out += {'\\', 'x', kHex[c >> 4], kHex[c & 15]}; };
  for (std::size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c < 0x80) {
      if (c < 0x20 || c == 0x7f)
        escape(c);
      else
        out += static_cast<char>(c);
      ++i;
      continue;
    }
    // Length of the sequence and the valid range of its second byte (RFC 3629).
    std::size_t n = 0;
    unsigned char lo = 0x80, hi = 0xbf;
    if (c >= 0xc2 && c <= 0xdf)
      n = 2;
    else if (c >= 0xe0 && c <= 0xef) {
      n = 3;
      if (c == 0xe0) lo = 0xa0;
      if (c == 0xed) hi = 0x9f;
    } else if (c >= 0xf0 && c <= 0xf4) {
      n = 4;
      if (c == 0xf0) lo = 0x90;
      if (c == 0xf4) hi = 0x8f;
    }
    bool ok = n > 0 && i + n <= s.size();
    for (std::size_t k = 1; ok && k < n; ++k) {
      const auto b = static_cast<unsigned char>(s[i + k]);
      ok = k == 1 ? (b >= lo && b <= hi) : (b >= 0x80 && b <= 0xbf);
    }
    if (ok) {
      out.append(s.substr(i, n));
      i += n;
    } else {
      escape(c);
      ++i;
    }
  }
  return out;
}

[[noreturn]] void fail(const std::string& path, long line, const std::string& what) {
  const std::string where = printable_utf8(path) + (line > 0 ? ":" + std::to_string(line) : std::string());
  throw std::invalid_argument(where + ": " + printable_utf8(what));
}

void check_unit_scale(double unit_scale) {
  if (!(std::isfinite(unit_scale) && unit_scale > 0.0)) {
    throw std::invalid_argument("shape file: unit_scale must be finite and > 0 (metres per file unit), got " +
                                std::to_string(unit_scale));
  }
}

bool is_table(const std::string& path) {
  const std::size_t dot = path.find_last_of('.');
  const std::size_t slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return false;
  std::string ext = path.substr(dot);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext == ".tab";
}

bool ignored_obj_record(std::string_view tag) {
  static constexpr std::string_view kIgnored[] = {"vn", "vt", "vp", "g", "o", "s", "l", "usemtl", "mtllib"};
  return std::find(std::begin(kIgnored), std::end(kIgnored), tag) != std::end(kIgnored);
}

std::string quoted(std::string_view s) {
  constexpr std::size_t kMax = 40;
  return "'" + std::string(s.substr(0, kMax)) + (s.size() > kMax ? "...'" : "'");
}

// The line of face (or vertex) `index` named in Shape's message "Shape: face <index> ...", if any.
long line_of(const std::string& message, const char* word, const std::vector<long>& lines) {
  const std::string key = std::string(word) + " ";
  for (std::size_t at = message.find(key); at != std::string::npos; at = message.find(key, at + 1)) {
    const bool word_start = at == 0 || !std::isalpha(static_cast<unsigned char>(message[at - 1]));
    std::size_t i = at + key.size();
    std::size_t j = i;
    while (j < message.size() && std::isdigit(static_cast<unsigned char>(message[j]))) ++j;
    if (word_start && j > i) {
      const std::size_t k = std::stoul(message.substr(i, j - i));
      return k < lines.size() ? lines[k] : 0;
    }
  }
  return 0;
}

}  // namespace

Shape load_shape(const std::string& path, double unit_scale, ShapeRepair repair) {
  check_unit_scale(unit_scale);
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, 0, std::string("cannot open the file (") + std::strerror(errno) + ")");
  const bool table = is_table(path);

  std::vector<double> coords;         // 3 per vertex (file units)
  std::vector<std::int64_t> corners;  // 3 per triangle (0-based)
  std::vector<long> vertex_lines, face_lines;
  std::vector<std::string_view> tokens;
  std::vector<std::int64_t> polygon;
  std::string raw;
  long number = 0;
  while (std::getline(in, raw)) {
    ++number;
    if (raw.find('\0') != std::string::npos) fail(path, number, "binary data in a text shape file");
    std::string_view line(raw);
    line = line.substr(0, line.find('#'));
    core::text::split(line, tokens);
    if (tokens.empty()) continue;
    const std::string_view tag = tokens[0];
    if (tag == "v") {
      const std::size_t n = tokens.size() - 1;
      if (n < 3 || (table && n != 3)) {
        fail(path, number,
             "vertex record needs " + std::string(table ? "exactly " : "") + "3 coordinates, got " +
                 std::to_string(n));
      }
      for (std::size_t k = 1; k < tokens.size(); ++k) {
        double x = 0.0;
        if (!parse_double(tokens[k], x)) fail(path, number, "vertex: bad number " + quoted(tokens[k]));
        if (!std::isfinite(x)) fail(path, number, "vertex: non-finite number " + quoted(tokens[k]));
        if (k <= 3) coords.push_back(x * unit_scale);
      }
      vertex_lines.push_back(number);
    } else if (tag == "f") {
      const std::size_t n = tokens.size() - 1;
      if (n < 3 || (table && n != 3)) {
        fail(path, number,
             "face record needs " + std::string(table ? "exactly 3" : "at least 3") +
                 " vertex indices, got " + std::to_string(n));
      }
      const auto n_vertices = static_cast<std::int64_t>(vertex_lines.size());
      polygon.clear();
      for (std::size_t k = 1; k < tokens.size(); ++k) {
        const std::string_view token = tokens[k];
        const std::string_view index_text = table ? token : token.substr(0, token.find('/'));
        std::int64_t i = 0;
        if (!parse_int64(index_text, i)) fail(path, number, "face: bad vertex index " + quoted(token));
        if (i == 0) fail(path, number, "face: vertex index 0 (indices are 1-based)");
        if (table && i < 0) fail(path, number, "face: negative vertex index " + quoted(token));
        // OBJ: -m is the m-th vertex back from the last one defined so far.
        const std::int64_t zero_based = i > 0 ? i - 1 : n_vertices + i;
        if (zero_based < 0 || (i < 0 && zero_based >= n_vertices)) {
          fail(path, number,
               "face: relative vertex index " + std::to_string(i) + " with only " +
                   std::to_string(n_vertices) + " vertices defined before this line");
        }
        polygon.push_back(zero_based);
      }
      for (std::size_t k = 1; k + 1 < polygon.size(); ++k) {  // fan: (v1, v_k+1, v_k+2)
        corners.insert(corners.end(), {polygon[0], polygon[k], polygon[k + 1]});
        face_lines.push_back(number);
      }
    } else if (!table && ignored_obj_record(tag)) {
      continue;
    } else {
      fail(path, number,
           "unknown record " + quoted(tag) + (table ? " (a v/f table has only 'v' and 'f' lines)" : ""));
    }
  }
  if (in.bad()) fail(path, 0, "read error after line " + std::to_string(number));
  if (vertex_lines.empty()) fail(path, 0, "no vertex records ('v x y z')");
  if (face_lines.empty()) fail(path, 0, "no face records ('f i j k')");

  const auto n_v = static_cast<Eigen::Index>(vertex_lines.size());
  const auto n_f = static_cast<Eigen::Index>(face_lines.size());
  for (Eigen::Index j = 0; j < n_f; ++j) {  // absolute indices may point past the last vertex
    for (int c = 0; c < 3; ++c) {
      const std::int64_t i = corners[static_cast<std::size_t>(3 * j + c)];
      if (i >= n_v) {
        fail(path, face_lines[static_cast<std::size_t>(j)],
             "face: vertex index " + std::to_string(i + 1) + " out of range (the file has " +
                 std::to_string(n_v) + " vertices)");
      }
    }
  }
  Vertices v = Eigen::Map<const Vertices>(coords.data(), n_v, 3);
  Faces f = Eigen::Map<const Faces>(corners.data(), n_f, 3);
  try {
    return Shape(std::move(v), std::move(f), repair);
  } catch (const std::invalid_argument& e) {
    // Shape numbers faces (after fan triangulation) and vertices 0-based in file order: name the line.
    const std::string message = e.what();
    long line = line_of(message, "face", face_lines);
    if (line == 0) line = line_of(message, "vertex", vertex_lines);
    fail(path, line, message + " [vertex and face numbers 0-based, in file order]");
  }
}

void save_obj(const std::string& path, const Shape& shape, double unit_scale) {
  check_unit_scale(unit_scale);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out)
    throw std::runtime_error(printable_utf8(path) + ": cannot open for writing (" + std::strerror(errno) +
                             ")");
  out << "# written by tubempc::gravity::save_obj: " << shape.n_vertices() << " vertices, " << shape.n_faces()
      << " faces, " << core::text::format_double(unit_scale) << " m per unit\n";
  const Vertices& v = shape.vertices();
  for (Eigen::Index i = 0; i < v.rows(); ++i) {
    out << "v " << core::text::format_double(v(i, 0) / unit_scale) << ' '
        << core::text::format_double(v(i, 1) / unit_scale) << ' '
        << core::text::format_double(v(i, 2) / unit_scale) << '\n';
  }
  const Faces& f = shape.faces();
  for (Eigen::Index j = 0; j < f.rows(); ++j)
    out << "f " << f(j, 0) + 1 << ' ' << f(j, 1) + 1 << ' ' << f(j, 2) + 1 << '\n';
  out.close();
  if (!out) throw std::runtime_error(printable_utf8(path) + ": write failed (" + std::strerror(errno) + ")");
}

}  // namespace tubempc::gravity
