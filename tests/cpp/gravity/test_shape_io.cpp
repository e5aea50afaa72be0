#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "gravity_test_meshes.hpp"
#include "tubempc/gravity/shape_io.hpp"

using tubempc::gravity::load_shape;
using tubempc::gravity::save_obj;
using tubempc::gravity::Shape;
using tubempc::gravity::ShapeRepair;

namespace {

namespace fs = std::filesystem;

// A fresh temporary folder per test, removed afterwards.
class ShapeIo : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / (std::string("tubempc_shape_io_") + info->name() + "_" +
                                        std::to_string(reinterpret_cast<std::uintptr_t>(this)));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write(const std::string& name, const std::string& content) const {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << content;
    return path;
  }

  // Expects load_shape to throw std::invalid_argument whose message starts with "<path>:<line>: "
  // (or "<path>: " for line 0) and contains `needle`.
  void expect_error(const std::string& name, const std::string& content, long line, const std::string& needle,
                    ShapeRepair repair = ShapeRepair::None) const {
    const std::string path = write(name, content);
    try {
      load_shape(path, 1.0, repair);
      ADD_FAILURE() << name << ": accepted, expected an error with '" << needle << "'";
    } catch (const std::invalid_argument& e) {
      const std::string msg = e.what();
      const std::string prefix = line > 0 ? path + ":" + std::to_string(line) + ": " : path + ": ";
      EXPECT_EQ(msg.rfind(prefix, 0), 0u) << "expected the prefix '" << prefix << "' in: " << msg;
      EXPECT_NE(msg.find(needle), std::string::npos) << "expected '" << needle << "' in: " << msg;
    }
  }

  fs::path dir_;
};

// The unit tetrahedron (0, e1, e2, e3), outward faces, as v/f text (1-based).
const std::string kTetra =
    "v 0 0 0\n"
    "v 1 0 0\n"
    "v 0 1 0\n"
    "v 0 0 1\n"
    "f 1 3 2\n"
    "f 1 2 4\n"
    "f 1 4 3\n"
    "f 2 3 4\n";

}  // namespace

TEST_F(ShapeIo, ReadsTableAndObjWithUnitScale) {
  for (const char* name : {"t.tab", "t.obj", "t.TAB", "t.txt"}) {
    const Shape s = load_shape(write(name, kTetra), 1000.0);
    EXPECT_EQ(s.n_vertices(), 4);
    EXPECT_EQ(s.n_faces(), 4);
    EXPECT_EQ(s.vertices()(1, 0), 1000.0) << name;
    EXPECT_NEAR(s.volume(), 1e9 / 6.0, 1e-6) << name;  // (1 km)^3 / 6
    EXPECT_EQ(s.faces()(0, 1), 2) << name;
  }
}

TEST_F(ShapeIo, ObjFeatures) {
  // Comments, ignored records, i/t/n tokens, relative indices, a w coordinate, CRLF line ends and a
  // quad (fan-triangulated): a unit cube.
  const std::string obj =
      "# cube\r\n"
      "mtllib none.mtl\r\n"
      "o cube\r\n"
      "v 0 0 0 1.0\r\n"
      "v 1 0 0\r\n"
      "v 1 1 0\r\n"
      "v 0 1 0\r\n"
      "v 0 0 1\r\n"
      "v 1 0 1\r\n"
      "v 1 1 1\r\n"
      "v 0 1 1   # trailing comment\r\n"
      "vn 0 0 -1\r\n"
      "vt 0 0\r\n"
      "g bottom\r\n"
      "usemtl rock\r\n"
      "s off\r\n"
      "f 1/1/1 4/1/1 3/1/1 2/1/1\r\n"
      "f 5//1 6//1 7//1 8//1\r\n"
      "f -8 -7 -3 -4\r\n"  // 1 2 6 5
      "f 2/1 3/1 7/1 6/1\r\n"
      "f 3 4 8 7\r\n"
      "f 4 1 5 8\r\n";
  const Shape s = load_shape(write("cube.obj", obj), 2.0);
  EXPECT_EQ(s.n_vertices(), 8);
  EXPECT_EQ(s.n_faces(), 12);
  EXPECT_NEAR(s.volume(), 8.0, 1e-12);
  EXPECT_LT((s.center_of_mass() - Eigen::Vector3d(1.0, 1.0, 1.0)).norm(), 1e-12);
}

TEST_F(ShapeIo, MalformedFilesNameTheLine) {
  const std::string head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n";  // lines 1-4
  expect_error("bad_number.tab", "v 0 0 0\nv 1 0 x0\n", 2, "bad number 'x0'");
  expect_error("nan.tab", "v 0 0 0\nv 1 nan 0\n", 2, "non-finite number 'nan'");
  expect_error("inf.obj", "v 0 0 0\n\nv 1 0 -inf\n", 3, "non-finite");
  expect_error("huge.obj", "v 0 0 1e999\n", 1, "bad number '1e999'");
  expect_error("short_v.tab", "v 0 0\n", 1, "3 coordinates, got 2");
  expect_error("long_v.tab", "v 0 0 0 1\n", 1, "exactly 3 coordinates, got 4");
  expect_error("short_f.obj", head + "f 1 2\n", 5, "at least 3 vertex indices, got 2");
  expect_error("quad.tab", head + "f 1 2 3 4\n", 5, "exactly 3 vertex indices, got 4");
  expect_error("index_text.tab", head + "f 1 2 b\n", 5, "bad vertex index 'b'");
  expect_error("index_float.tab", head + "f 1 2 3.0\n", 5, "bad vertex index '3.0'");
  expect_error("index_zero.obj", head + "f 0 1 2\n", 5, "vertex index 0");
  expect_error("index_range.tab", head + "f 1 3 2\nf 1 2 9\n", 6,
               "vertex index 9 out of range (the file has 4");
  expect_error("index_rel.obj", head + "f -1 -2 -5\n", 5, "relative vertex index -5 with only 4 vertices");
  expect_error("index_neg.tab", head + "f -1 -2 -3\n", 5, "negative vertex index");
  expect_error("unknown.tab", head + "vn 0 0 1\n", 5, "unknown record 'vn'");
  expect_error("unknown.obj", head + "\n# c\nfoo 1 2\n", 7, "unknown record 'foo'");
  expect_error("binary.obj", std::string("v 0 0 0\nv \0 1", 13), 2, "binary data");
  expect_error("empty.obj", "", 0, "no vertex records");
  expect_error("no_faces.obj", head, 0, "no face records");
  // Mesh errors found by Shape are mapped back to the face's line.
  expect_error("degenerate.tab", kTetra + "f 1 1 2\n", 9, "face 4 is degenerate");
  expect_error("duplicate.tab", head + "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 1 3\n", 8, "face 3 duplicates face 0");
  expect_error("open.obj", head + "v 1 1 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 5 4\n", 8,
               "of face 2 belongs to no other face");
  expect_error("flipped.tab", head + "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 4 3\n", 8, "face 3");
  // ... which ShapeRepair::Orient repairs.
  const Shape repaired = load_shape(write("flipped_ok.tab", head + "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 4 3\n"),
                                    1.0, ShapeRepair::Orient);
  EXPECT_EQ(repaired.n_flipped_faces(), 1);
}

TEST_F(ShapeIo, QuotedBytesAreEscapedToValidUtf8) {
  // Invalid UTF-8 (a lone continuation byte, an overlong form, a control byte) is written \xNN;
  // valid multi-byte characters are kept.
  expect_error("bytes.obj", "v 0 0 0\nv 1 \x80\xc0\xaf\x01 0\n", 2, R"(bad number '\x80\xc0\xaf\x01')");
  expect_error("bytes2.obj", "v 0 0 0\nv 1 2\x80\xc0\xaf\x01 0\n", 2, R"('2\x80\xc0\xaf\x01')");
  expect_error("bytes3.obj", "v 0 0 0\nv 1 \xc3\xa9 0\n", 2, "'\xc3\xa9'");
}

TEST_F(ShapeIo, MissingFileAndBadScale) {
  const std::string missing = (dir_ / "missing.obj").string();
  try {
    load_shape(missing, 1.0);
    ADD_FAILURE() << "accepted a missing file";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind(missing + ": cannot open the file", 0), 0u) << e.what();
  }
  const std::string path = write("t.tab", kTetra);
  EXPECT_THROW(load_shape(path, 0.0), std::invalid_argument);
  EXPECT_THROW(load_shape(path, std::nan("")), std::invalid_argument);
  EXPECT_THROW(save_obj((dir_ / "no" / "such" / "dir.obj").string(), load_shape(path, 1.0)),
               std::runtime_error);
}

TEST_F(ShapeIo, RoundTripIsExactInMetres) {
  const gravity_test::Mesh m =
      gravity_test::box(-1.0 / 3.0, 2.0 / 7.0, -5.5, 1e-3, 12345.678901234567, 12399.1);
  const Shape s(m.v, m.f);
  const std::string path = (dir_ / "box.obj").string();
  save_obj(path, s);
  const Shape r = load_shape(path, 1.0);
  EXPECT_EQ(r.vertices(), s.vertices());  // bit for bit: 17 significant digits
  EXPECT_EQ(r.faces(), s.faces());
  EXPECT_EQ(r.volume(), s.volume());
  // In km: one rounding of the division and one of the multiplication.
  save_obj(path, s, 1000.0);
  const Shape k = load_shape(path, 1000.0);
  EXPECT_EQ(k.faces(), s.faces());
  EXPECT_LE((k.vertices() - s.vertices()).cwiseAbs().maxCoeff(), 4e-16 * s.vertices().cwiseAbs().maxCoeff());
}

TEST(ShapeIoBennu, RadarModelMatchesFileAndPythonLoader) {
  const std::string path = std::string(TUBEMPC_SHARED_DATA_DIR) + "/101955bennu.tab";
  std::ifstream in(path);
  if (!in) GTEST_SKIP() << path << " is not present";
  // Independent count of the records.
  long n_v = 0, n_f = 0;
  for (std::string line; std::getline(in, line);) {
    n_v += line.rfind("v ", 0) == 0;
    n_f += line.rfind("f ", 0) == 0;
  }
  const Shape s = load_shape(path, 1000.0);  // km -> m
  EXPECT_EQ(s.n_vertices(), n_v);
  EXPECT_EQ(s.n_faces(), n_f);
  EXPECT_EQ(2 * s.n_faces(), s.n_vertices() * 4 - 8);  // closed genus-0 mesh: F = 2 V - 4
  // tubempc.scenario.shapes.load_shape(path, unit="km").volume (the Python loader, same mesh code) printed
  // 62265648.66795519 m^3; docs/model.md "Gravity" quotes 6.2266e7 m^3.
  EXPECT_NEAR(s.volume(), 62265648.66795519, 1e-9 * 6.2e7);
  EXPECT_NEAR(s.mean_radius(), 245.9, 0.05);
}
