#include "mesh/ply_io.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>

#include "mesh/mesh_io.h"
#include "mesh_test_util.h"
#include "testing/temp_dir.h"
#include "util/input_file.h"

namespace aqs {
namespace {

using testing::Contains;

// Appends the bytes of `value` (as type T) in little- or big-endian order.
template <typename T>
void AppendBytes(T value, bool big_endian, std::string* out) {
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  const std::uint16_t one = 1;
  unsigned char first = 0;
  std::memcpy(&first, &one, 1);
  const bool host_little = first == 1;
  if (big_endian == host_little) std::reverse(bytes, bytes + sizeof(T));
  out->append(reinterpret_cast<const char*>(bytes), sizeof(T));
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Reading `content` as file `name` fails with a message naming the file and containing
// `part`.
void ExpectReadError(const std::string& name, const std::string& content, const std::string& part) {
  testing::TempDir dir;
  const std::string path = dir.Write(name, content);
  Eigen::Matrix3Xd points = Eigen::Matrix3Xd::Constant(3, 2, 7.0);
  std::string error;
  EXPECT_FALSE(ReadPointCloud(path, &points, &error)) << "accepted " << name;
  EXPECT_TRUE(Contains(error, path)) << error;
  EXPECT_TRUE(Contains(error, part)) << error;
  EXPECT_EQ(points, Eigen::Matrix3Xd::Constant(3, 2, 7.0)) << "output changed on failure";
}

const Eigen::Matrix3Xd kPoints = (Eigen::Matrix3Xd(3, 4) << 0.1, -2.5, 3.0, 1e-7,  //
                                  1.0 / 3.0, 4.25, -0.0, 12345.678,                 //
                                  -1.5, 0.0, 2.0, -9.75)
                                     .finished();

TEST(PlyColorTest, ViridisEndsAndClamping) {
  using Rgb = std::array<std::uint8_t, 3>;
  EXPECT_EQ(ScalarColor(0.0, 2.0), (Rgb{68, 1, 84}));
  EXPECT_EQ(ScalarColor(-1.0, 2.0), (Rgb{68, 1, 84}));
  EXPECT_EQ(ScalarColor(std::nan(""), 2.0), (Rgb{68, 1, 84}));
  EXPECT_EQ(ScalarColor(1.0, 2.0), (Rgb{33, 144, 140}));
  EXPECT_EQ(ScalarColor(2.0, 2.0), (Rgb{253, 231, 37}));
  EXPECT_EQ(ScalarColor(50.0, 2.0), (Rgb{253, 231, 37}));
  // Half way between the colours at 7/8 and 1.
  EXPECT_EQ(ScalarColor(15.0 / 16.0, 1.0), (Rgb{212, 226, 44}));
}

TEST(PlyColorTest, PercentileColorMaxIsThe95thPercentile) {
  std::vector<double> values;
  for (int i = 99; i >= 0; --i) values.push_back(i);  // 0 .. 99, in reverse
  EXPECT_EQ(PercentileColorMax(values), 95.0);
  EXPECT_EQ(PercentileColorMax({}), 1e-12);
  EXPECT_EQ(PercentileColorMax({0.0, 0.0}), 1e-12);
  EXPECT_EQ(PercentileColorMax({2.0}), 2.0);
}

// The evaluation's error-map scale is numpy's default 98th percentile (what the report's
// pictures use: np.percentile([1, 2, 3, 4], 98) = 3.94), so that its PLY fields and its
// pictures of a pose share one scale (they were the 95th and the 98th percentile).
TEST(PlyColorTest, ErrorMapScaleIsNumpysPercentile98) {
  EXPECT_NEAR(ErrorMapScale({4, 1, 3, 2}), 3.94, 1e-12);
  std::vector<double> values;
  for (int i = 100; i >= 0; --i) values.push_back(i);
  EXPECT_NEAR(ErrorMapScale(values), 98.0, 1e-12);
  EXPECT_EQ(ErrorMapScale({}), 1.0);
  EXPECT_EQ(ErrorMapScale({0.0, 0.0}), 1.0);
  EXPECT_EQ(ErrorMapScale({0.5}), 0.5);
}

TEST(PlyWriteTest, WrittenFileReadsBackExactly) {
  testing::TempDir dir;
  SurfaceMesh surface;
  surface.vertices = kPoints;
  surface.triangles.resize(3, 2);
  surface.triangles << 0, 0, 1, 2, 2, 3;
  const std::vector<double> values = {0.0, 0.5, 1.0, 3.0};
  const std::string path = dir.File("error.ply");
  std::string error;
  ASSERT_TRUE(WritePlyWithScalar(path, surface, values, 1.0, &error)) << error;
  const std::string text = ReadFile(path);
  EXPECT_EQ(text.rfind("ply\nformat ascii 1.0\n", 0), 0u) << text;
  EXPECT_TRUE(Contains(text, "element vertex 4\nproperty double x\nproperty double y\n"
                             "property double z\nproperty uchar red\nproperty uchar green\n"
                             "property uchar blue\nproperty double value\n"
                             "element face 2\nproperty list uchar int vertex_indices\n"
                             "end_header\n"));
  EXPECT_TRUE(Contains(text, "\n0.1 0.3333333333333333 -1.5 68 1 84 0\n")) << text;
  EXPECT_TRUE(Contains(text, " 253 231 37 3\n3 0 1 2\n3 0 2 3\n")) << text;
  Eigen::Matrix3Xd points;
  ASSERT_TRUE(ReadPointCloud(path, &points, &error)) << error;
  EXPECT_EQ(points, kPoints);  // exact

  // Polygons are written as they are.
  SurfaceMesh quad;
  quad.vertices = kPoints;
  quad.face_offsets = {0, 4};
  quad.face_vertices = {0, 1, 2, 3};
  quad.triangles.resize(3, 2);
  quad.triangles << 0, 0, 1, 2, 2, 3;
  quad.triangle_face = {0, 0};
  ASSERT_TRUE(WritePlyWithScalar(path, quad, values, 1.0, &error)) << error;
  EXPECT_TRUE(Contains(ReadFile(path), "element face 1\n"));
  EXPECT_TRUE(Contains(ReadFile(path), "\n4 0 1 2 3\n"));
  ASSERT_TRUE(ReadPointCloud(path, &points, &error)) << error;
  EXPECT_EQ(points, kPoints);

  // A non-finite value is refused (and the file is left as it was).
  const std::string before = ReadFile(path);
  EXPECT_FALSE(WritePlyWithScalar(path, quad, {0.0, std::nan(""), 1.0, 2.0}, 1.0, &error));
  EXPECT_TRUE(Contains(error, path)) << error;
  EXPECT_TRUE(Contains(error, "vertex 1")) << error;
  EXPECT_EQ(ReadFile(path), before);
  // An unwritable path.
  EXPECT_FALSE(WritePlyWithScalar(dir.File("missing/dir/a.ply"), quad, values, 1.0, &error));
  EXPECT_FALSE(error.empty());
}

TEST(PointCloudReadTest, AsciiWithExtraPropertiesAndElements) {
  testing::TempDir dir;
  const std::string path = dir.Write("scan.PLY",
                                     "ply\r\n"
                                     "format ascii 1.0\r\n"
                                     "comment made by hand\r\n"
                                     "obj_info scanner 1\r\n"
                                     "element camera 1\r\n"
                                     "property float view_px\r\n"
                                     "property list uchar float params\r\n"
                                     "element vertex 3\r\n"
                                     "property float32 nx\r\n"
                                     "property int z\r\n"
                                     "property double x\r\n"
                                     "property list int uint8 tags\r\n"
                                     "property float y\r\n"
                                     "property uchar red\r\n"
                                     "element face 1\r\n"
                                     "property list uchar int vertex_indices\r\n"
                                     "end_header\r\n"
                                     "0.5 3 1 2 3\r\n"
                                     "nan -1 0.25 0 7.5 255\r\n"
                                     "\r\n"
                                     "0 2 -3e2 2 9 9 -0.125 0\r\n"
                                     "1 12 0.5 1 4 1e30 7\r\n"
                                     "3 0 1 2\r\n");
  Eigen::Matrix3Xd points;
  std::string error;
  ASSERT_TRUE(ReadPointCloud(path, &points, &error)) << error;
  Eigen::Matrix3Xd expected(3, 3);
  expected << 0.25, -300, 0.5,  //
      7.5, -0.125, 1e30,        //
      -1, 2, 12;
  EXPECT_EQ(points, expected);
}

// More data than the header counts is an error (the extra points would be dropped),
// in ASCII and binary files; every ASCII value is parsed as its declared type.
TEST(PointCloudReadTest, DataBeyondTheHeaderAndTypedValues) {
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
      "property float z\nproperty uchar red\nend_header\n";
  ExpectReadError("extra.ply", header + "0 0 0 1\n1 1 1 2\n2 2 2 3\n",
                  "extra.ply:11: data after the last of the header's elements (2 'vertex' "
                  "records): the header's counts are smaller than the data");
  ExpectReadError("hex.ply", header + "0 0 0x10 1\n1 1 1 2\n",
                  "hex.ply:9: expected a finite number for property 'z' of vertex 0, got '0x10'");
  ExpectReadError("range.ply", header + "0 0 0 1\n1 1 1 256\n",
                  "range.ply:10: expected an integer in the range of type uchar for property "
                  "'red' of 'vertex' record 1, got '256'");
  ExpectReadError("word.ply", header + "0 0 0 red\n1 1 1 2\n",
                  "expected an integer in the range of type uchar for property 'red'");
  // Trailing blank lines are fine.
  testing::TempDir dir;
  Eigen::Matrix3Xd points;
  std::string error;
  ASSERT_TRUE(ReadPointCloud(dir.Write("ok.ply", header + "0 0 0 1\n1 1 1 2\n\n\n"), &points,
                             &error))
      << error;
  EXPECT_EQ(points.cols(), 2);
  // Binary: bytes after the last element.
  std::string binary =
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty double x\n"
      "property double y\nproperty double z\nend_header\n";
  for (double v : {1.0, 2.0, 3.0}) AppendBytes(v, false, &binary);
  ASSERT_TRUE(ReadPointCloud(dir.Write("one.ply", binary), &points, &error)) << error;
  for (double v : {4.0, 5.0, 6.0}) AppendBytes(v, false, &binary);
  ExpectReadError("two.ply", binary, "data after the last of the header's elements");
}

TEST(PointCloudReadTest, OverlongLinesAndNonRegularFiles) {
  std::string text = "ply\nformat ascii 1.0\ncomment ";
  text.append(static_cast<size_t>(kMaxLineBytes), 'x');
  ExpectReadError("long.ply", text + "\n", "long.ply:3: the line is longer than");
  testing::TempDir dir;
  Eigen::Matrix3Xd points;
  std::string error;
  EXPECT_FALSE(ReadPointCloud(dir.path() + "/", &points, &error));
  std::filesystem::create_directories(dir.File("d.ply"));
  EXPECT_FALSE(ReadPointCloud(dir.File("d.ply"), &points, &error));
  EXPECT_TRUE(Contains(error, "is a directory")) << error;
}

TEST(PointCloudReadTest, Obj) {
  testing::TempDir dir;
  const std::string path =
      dir.Write("scan.obj", "v 1 2 3\nv 4 5 6 0.5 0.5 0.5\nvn 0 0 1\nf 1 2 1\n");
  Eigen::Matrix3Xd points;
  std::string error;
  ASSERT_TRUE(ReadPointCloud(path, &points, &error)) << error;
  EXPECT_EQ(points, (Eigen::Matrix3Xd(3, 2) << 1, 4, 2, 5, 3, 6).finished());
  ExpectReadError("empty.obj", "# nothing\n", "no points");
  ExpectReadError("bad.obj", "v 1 2 nan\n", "bad.obj:1:");
}

// A binary PLY with a face element before and after the vertices (list properties to
// skip), extra vertex properties of several types, x y z as float or double.
std::string BinaryPly(bool big_endian, bool doubles, const Eigen::Matrix3Xd& points) {
  const char* type = doubles ? "double" : "float";
  std::string out = std::string("ply\nformat ") +
                    (big_endian ? "binary_big_endian" : "binary_little_endian") +
                    " 1.0\n"
                    "comment hand made\n"
                    "element face 2\n"
                    "property list uchar int vertex_indices\n"
                    "property ushort flags\n"
                    "element vertex " +
                    std::to_string(points.cols()) +
                    "\n"
                    "property " + type + " x\n"
                    "property int16 id\n"
                    "property " + type + " y\n"
                    "property list uint16 float64 weights\n"
                    "property " + type + " z\n"
                    "property uchar red\n"
                    "element edge 1\n"
                    "property list int32 uint32 vertex_indices\n"
                    "property char crease\n"
                    "end_header\n";
  // Faces: a triangle and a quad.
  AppendBytes<std::uint8_t>(3, big_endian, &out);
  for (int v : {0, 1, 2}) AppendBytes<std::int32_t>(v, big_endian, &out);
  AppendBytes<std::uint16_t>(10, big_endian, &out);
  AppendBytes<std::uint8_t>(4, big_endian, &out);
  for (int v : {0, 1, 2, 3}) AppendBytes<std::int32_t>(v, big_endian, &out);
  AppendBytes<std::uint16_t>(11, big_endian, &out);
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    auto coordinate = [&](double value) {
      if (doubles) {
        AppendBytes<double>(value, big_endian, &out);
      } else {
        AppendBytes<float>(static_cast<float>(value), big_endian, &out);
      }
    };
    coordinate(points(0, i));
    AppendBytes<std::int16_t>(static_cast<std::int16_t>(-i), big_endian, &out);
    coordinate(points(1, i));
    AppendBytes<std::uint16_t>(static_cast<std::uint16_t>(i % 3), big_endian, &out);
    for (int k = 0; k < i % 3; ++k) AppendBytes<double>(0.5 * k, big_endian, &out);
    coordinate(points(2, i));
    AppendBytes<std::uint8_t>(200, big_endian, &out);
  }
  AppendBytes<std::int32_t>(2, big_endian, &out);
  AppendBytes<std::uint32_t>(0, big_endian, &out);
  AppendBytes<std::uint32_t>(1, big_endian, &out);
  AppendBytes<std::int8_t>(-1, big_endian, &out);
  return out;
}

TEST(PointCloudReadTest, BinaryBothEndiannessesFloatAndDouble) {
  testing::TempDir dir;
  for (bool big_endian : {false, true}) {
    for (bool doubles : {false, true}) {
      const std::string path = dir.Write("scan.ply", BinaryPly(big_endian, doubles, kPoints));
      Eigen::Matrix3Xd points;
      std::string error;
      ASSERT_TRUE(ReadPointCloud(path, &points, &error)) << error;
      const Eigen::Matrix3Xd expected =
          doubles ? kPoints : Eigen::Matrix3Xd(kPoints.cast<float>().cast<double>());
      EXPECT_EQ(points, expected) << "big endian " << big_endian << ", doubles " << doubles;
    }
  }
}

TEST(PointCloudReadTest, BinaryIntegerCoordinatesAndNoLists) {
  testing::TempDir dir;
  std::string content =
      "ply\nformat binary_big_endian 1.0\nelement vertex 2\n"
      "property uint8 x\nproperty int32 y\nproperty uint z\nproperty float nx\nend_header\n";
  for (int i = 0; i < 2; ++i) {
    AppendBytes<std::uint8_t>(static_cast<std::uint8_t>(250 + i), true, &content);
    AppendBytes<std::int32_t>(-70000 * (i + 1), true, &content);
    AppendBytes<std::uint32_t>(4000000000u + i, true, &content);
    AppendBytes<float>(std::numeric_limits<float>::quiet_NaN(), true, &content);  // ignored
  }
  const std::string path = dir.Write("ints.ply", content);
  Eigen::Matrix3Xd points;
  std::string error;
  ASSERT_TRUE(ReadPointCloud(path, &points, &error)) << error;
  EXPECT_EQ(points, (Eigen::Matrix3Xd(3, 2) << 250, 251, -70000, -140000, 4e9, 4e9 + 1).finished());
}

TEST(PointCloudReadTest, Malformed) {
  ExpectReadError("a.ply", "", "not a PLY file");
  ExpectReadError("a.ply", "plx\nformat ascii 1.0\nend_header\n",
                  "a.ply:1: not a PLY file: the first line must be 'ply'");
  ExpectReadError("a.ply", "ply\nformat utf8 1.0\nelement vertex 0\nend_header\n",
                  "a.ply:2: unknown PLY format 'utf8'");
  ExpectReadError("a.ply", "ply\nformat ascii 2.0\nend_header\n", "a.ply:2: unsupported PLY version");
  ExpectReadError("a.ply",
                  "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                  "end_header\n1 2\n",
                  "a.ply:3: the vertex element has no property 'z'");
  ExpectReadError("a.ply",
                  "ply\nformat ascii 1.0\nelement vertex 1\nproperty float y\nproperty float z\n"
                  "end_header\n1 2\n",
                  "a.ply:3: the vertex element has no property 'x'");
  ExpectReadError("a.ply",
                  "ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar float x\n"
                  "property float y\nproperty float z\nend_header\n1 1 2 3\n",
                  "a.ply:3: property 'x' of the vertex element is a list");
  ExpectReadError("a.ply",
                  "ply\nformat ascii 1.0\nelement vertex 1\nproperty float16 x\nend_header\n",
                  "a.ply:4: unsupported property type 'float16'");
  ExpectReadError("a.ply",
                  "ply\nformat ascii 1.0\nelement face 1\nproperty list float int idx\n"
                  "end_header\n",
                  "a.ply:4: the count type of list property 'idx' must be an integer type");
  ExpectReadError("a.ply", "ply\nformat ascii 1.0\nelement face 0\nend_header\n",
                  "no vertex element");
  ExpectReadError("a.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n",
                  "without 'end_header'");
  ExpectReadError("a.ply", "ply\nelement vertex 1\nend_header\n", "no 'format' line");
  ExpectReadError("a.ply", "ply\nformat ascii 1.0\nproperty float x\nend_header\n",
                  "a.ply:3: a 'property' line before any 'element' line");
  ExpectReadError("a.ply", "ply\nformat ascii 1.0\nelement vertex -2\nend_header\n",
                  "a.ply:3: expected 'element <name> <count>'");
  ExpectReadError("a.ply", "ply\nformat ascii 1.0\nvertex 1\nend_header\n",
                  "a.ply:3: unknown PLY header keyword 'vertex'");

  const std::string xyz =
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n";
  ExpectReadError("a.ply", xyz + "1 2 3\n", "a.ply:8: truncated: the file ends after 1 of 2 'vertex'");
  ExpectReadError("a.ply", xyz + "1 2 3\n4 5\n", "a.ply:9: too few values in 'vertex' record 1");
  ExpectReadError("a.ply", xyz + "1 2 3\n4 5 6 7\n", "a.ply:9: too many values in 'vertex' record 1");
  ExpectReadError("a.ply", xyz + "1 2 3\n4 nan 6\n",
                  "a.ply:9: expected a finite number for property 'y' of vertex 1, got 'nan'");
  ExpectReadError("a.ply", xyz + "1 2 3\n4 inf 6\n", "a.ply:9: expected a finite number");
  ExpectReadError("a.ply", xyz + "1 2 3\n4 x5 6\n", "got 'x5'");
  ExpectReadError("a.ply",
                  "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                  "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                  "end_header\n1 2 3\n4 0 1\n",
                  "a.ply:11: too few values in 'face' record 0: list 'vertex_indices' has 4 items");
  ExpectReadError("a.ply", "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\n"
                           "property float y\nproperty float z\nend_header\n",
                  "no points");

  // Binary: truncated inside the vertices, inside a face list after them, in a fixed-size
  // element before them; a NaN coordinate.
  const std::string full = BinaryPly(false, true, kPoints);
  const size_t header_end = full.find("end_header\n") + 11;
  ExpectReadError("b.ply", full.substr(0, full.size() - 10),
                  "b.ply: truncated: the file ends in element 'edge' (record 0 of 1)");
  ExpectReadError("b.ply", full.substr(0, header_end + 40 + 20),
                  "truncated: the file ends in element 'vertex' (record 0 of 4)");
  ExpectReadError("b.ply", full.substr(0, header_end + 5),
                  "truncated: the file ends in element 'face' (record 0 of 2)");
  std::string fixed =
      "ply\nformat binary_little_endian 1.0\nelement normal 3\nproperty float nx\n"
      "element vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  AppendBytes<float>(1.0f, false, &fixed);
  ExpectReadError("c.ply", fixed, "truncated: the file ends in element 'normal'");
  Eigen::Matrix3Xd bad = kPoints;
  bad(2, 3) = std::numeric_limits<double>::infinity();
  ExpectReadError("d.ply", BinaryPly(true, true, bad), "d.ply: vertex 3 has a non-finite coordinate (z = inf)");
  bad(2, 3) = std::numeric_limits<double>::quiet_NaN();
  ExpectReadError("d.ply", BinaryPly(false, false, bad), "vertex 3 has a non-finite coordinate (z = nan)");

  ExpectReadError("scan.xyz", "1 2 3\n", "unknown point-cloud file extension '.xyz' (expected .obj or .ply)");
  ExpectReadError("scan", "1 2 3\n", "(expected .obj or .ply)");
  Eigen::Matrix3Xd points;
  std::string error;
  EXPECT_FALSE(ReadPointCloud("/nonexistent/scan.ply", &points, &error));
  EXPECT_TRUE(Contains(error, "/nonexistent/scan.ply: cannot open")) << error;
}

}  // namespace
}  // namespace aqs
