#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "mesh/lattice.h"
#include "mesh/mesh_io.h"
#include "mesh_test_util.h"
#include "testing/file_contents.h"
#include "testing/temp_dir.h"
#include "util/line_reader.h"

namespace aqs {
namespace {

using testing::Contains;

// One DataArray of a VTU file: its attributes and its whitespace-separated values.
struct DataArray {
  std::map<std::string, std::string> attributes;
  std::vector<std::string> values;
  std::string parent;  // enclosing element (Points, Cells, PointData, CellData)
};

// A small XML reader, enough for the files WriteVtu writes: checks that every element
// is closed in order, and collects the DataArrays. Returns false with *error otherwise.
bool ParseVtu(const std::string& text, std::vector<DataArray>* arrays,
              std::map<std::string, std::string>* piece, std::string* error) {
  std::vector<std::string> open;
  size_t pos = 0;
  if (text.rfind("<?xml", 0) != 0) {
    *error = "no XML declaration";
    return false;
  }
  pos = text.find("?>") + 2;
  DataArray* current = nullptr;
  while (true) {
    const size_t lt = text.find('<', pos);
    const std::string content = text.substr(pos, lt == std::string::npos ? lt : lt - pos);
    if (current != nullptr) {
      const std::vector<std::string> tokens = SplitTokens(content);
      current->values.insert(current->values.end(), tokens.begin(), tokens.end());
    } else if (!SplitTokens(content).empty()) {
      *error = "text outside a DataArray: " + content.substr(0, 40);
      return false;
    }
    if (lt == std::string::npos) break;
    const size_t gt = text.find('>', lt);
    if (gt == std::string::npos) {
      *error = "unterminated tag";
      return false;
    }
    std::string tag = text.substr(lt + 1, gt - lt - 1);
    pos = gt + 1;
    if (tag[0] == '/') {
      const std::string name = tag.substr(1);
      if (open.empty() || open.back() != name) {
        *error = "closing " + name + " does not match " + (open.empty() ? "nothing" : open.back());
        return false;
      }
      open.pop_back();
      if (name == "DataArray") current = nullptr;
      continue;
    }
    const bool self_closing = tag.back() == '/';
    if (self_closing) tag.pop_back();
    const size_t space = tag.find_first_of(" \n");
    const std::string name = tag.substr(0, space);
    std::map<std::string, std::string> attributes;
    for (size_t a = space; a != std::string::npos && a < tag.size();) {
      const size_t eq = tag.find('=', a);
      if (eq == std::string::npos) break;
      const std::string key = SplitTokens(tag.substr(a, eq - a)).at(0);
      const size_t q1 = tag.find('"', eq);
      const size_t q2 = tag.find('"', q1 + 1);
      if (q1 != eq + 1 || q2 == std::string::npos) {
        *error = "bad attribute in " + tag;
        return false;
      }
      attributes[key] = tag.substr(q1 + 1, q2 - q1 - 1);
      a = q2 + 1;
    }
    if (name == "Piece") *piece = attributes;
    if (name == "DataArray") {
      arrays->push_back({attributes, {}, open.empty() ? "" : open.back()});
      current = &arrays->back();
    }
    if (!self_closing) open.push_back(name);
  }
  if (!open.empty()) {
    *error = "unclosed " + open.back();
    return false;
  }
  return true;
}

using testing::ReadAll;

TEST(VtuWriterTest, WellFormedWithExactValues) {
  LatticeOptions options;
  options.type = LatticeType::kBcc;
  options.nx = 2;
  options.ny = 1;
  options.nz = 2;
  options.spacing = 0.1;
  const TetMesh mesh = MakeLatticeMesh(options);
  VtuField displacement{"displacement", 3, {}};
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    for (int i = 0; i < 3; ++i) displacement.values.push_back(v / 3.0 + i * 1e-9);
  }
  VtuField energy{"energy <J> & \"more\"", 1, {}};
  for (int t = 0; t < mesh.num_tets(); ++t) energy.values.push_back(t * 0.1);
  testing::TempDir dir;
  const std::string path = dir.File("out.vtu");
  std::string error;
  ASSERT_TRUE(WriteVtu(path, mesh, {displacement}, {energy}, &error)) << error;

  std::vector<DataArray> arrays;
  std::map<std::string, std::string> piece;
  ASSERT_TRUE(ParseVtu(ReadAll(path), &arrays, &piece, &error)) << error;
  EXPECT_EQ(piece["NumberOfPoints"], std::to_string(mesh.num_vertices()));
  EXPECT_EQ(piece["NumberOfCells"], std::to_string(mesh.num_tets()));
  std::map<std::string, const DataArray*> by_name;
  for (const DataArray& array : arrays)
    by_name[array.parent + "/" + array.attributes.at("Name")] = &array;
  ASSERT_EQ(arrays.size(), 6u);

  const DataArray& points = *by_name.at("Points/Points");
  EXPECT_EQ(points.attributes.at("type"), "Float64");
  EXPECT_EQ(points.attributes.at("NumberOfComponents"), "3");
  ASSERT_EQ(points.values.size(), 3u * mesh.num_vertices());
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    for (int i = 0; i < 3; ++i) {
      double value = 0;
      ASSERT_TRUE(ParseDouble(points.values[3 * v + i], &value));
      EXPECT_EQ(value, mesh.vertices(i, v));
    }
  }
  const DataArray& connectivity = *by_name.at("Cells/connectivity");
  EXPECT_EQ(connectivity.attributes.at("type"), "Int64");
  ASSERT_EQ(connectivity.values.size(), 4u * mesh.num_tets());
  for (int t = 0; t < mesh.num_tets(); ++t) {
    for (int i = 0; i < 4; ++i)
      EXPECT_EQ(connectivity.values[4 * t + i], std::to_string(mesh.tets(i, t)));
  }
  const DataArray& offsets = *by_name.at("Cells/offsets");
  ASSERT_EQ(offsets.values.size(), static_cast<size_t>(mesh.num_tets()));
  EXPECT_EQ(offsets.values.back(), std::to_string(4 * mesh.num_tets()));
  const DataArray& types = *by_name.at("Cells/types");
  EXPECT_EQ(types.attributes.at("type"), "UInt8");
  ASSERT_EQ(types.values.size(), static_cast<size_t>(mesh.num_tets()));
  for (const std::string& type : types.values) EXPECT_EQ(type, "10");

  const DataArray& point_field = *by_name.at("PointData/displacement");
  EXPECT_EQ(point_field.attributes.at("NumberOfComponents"), "3");
  ASSERT_EQ(point_field.values.size(), displacement.values.size());
  for (size_t i = 0; i < displacement.values.size(); ++i) {
    double value = 0;
    ASSERT_TRUE(ParseDouble(point_field.values[i], &value));
    EXPECT_EQ(value, displacement.values[i]);
  }
  const DataArray& cell_field = *by_name.at("CellData/energy &lt;J&gt; &amp; &quot;more&quot;");
  EXPECT_EQ(cell_field.attributes.at("NumberOfComponents"), "1");
  ASSERT_EQ(cell_field.values.size(), static_cast<size_t>(mesh.num_tets()));
  double last = 0;
  ASSERT_TRUE(ParseDouble(cell_field.values.back(), &last));
  EXPECT_EQ(last, energy.values.back());
}

TEST(VtuWriterTest, NoFieldsAndUnwritablePath) {
  testing::TempDir dir;
  std::string error;
  ASSERT_TRUE(WriteVtu(dir.File("plain.vtu"), testing::UnitTet(), {}, {}, &error)) << error;
  std::vector<DataArray> arrays;
  std::map<std::string, std::string> piece;
  ASSERT_TRUE(ParseVtu(ReadAll(dir.File("plain.vtu")), &arrays, &piece, &error)) << error;
  EXPECT_EQ(arrays.size(), 4u);
  EXPECT_FALSE(WriteVtu("/nonexistent/dir/x.vtu", testing::UnitTet(), {}, {}, &error));
  EXPECT_TRUE(Contains(error, "/nonexistent/dir/x.vtu")) << error;
}

TEST(VtuWriterTest, RefusesNumbersThatAreNotFinite) {
  testing::TempDir dir;
  std::string error;
  const std::string path = dir.File("x.vtu");
  TetMesh mesh = testing::UnitTet();
  mesh.vertices(1, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(WriteVtu(path, mesh, {}, {}, &error));
  EXPECT_TRUE(Contains(error, "vertex 2 has a number that is not finite")) << error;
  const VtuField point{"displacement", 3, std::vector<double>(12, 0.0)};
  VtuField cell{"energy", 1, {std::numeric_limits<double>::infinity()}};
  EXPECT_FALSE(WriteVtu(path, testing::UnitTet(), {point}, {cell}, &error));
  EXPECT_TRUE(Contains(error, "cell field 'energy': entry 0 has a number that is not finite"))
      << error;
  VtuField bad_point = point;
  bad_point.values[10] = -std::numeric_limits<double>::infinity();
  EXPECT_FALSE(WriteVtu(path, testing::UnitTet(), {bad_point}, {}, &error));
  EXPECT_TRUE(Contains(error, "point field 'displacement': entry 3")) << error;
  EXPECT_FALSE(std::ifstream(path).good()) << "nothing is written";
  cell.values[0] = 1.5;
  EXPECT_TRUE(WriteVtu(path, testing::UnitTet(), {point}, {cell}, &error)) << error;
}

TEST(VtuWriterDeathTest, WrongFieldSizeIsAProgrammerError) {
  testing::TempDir dir;
  std::string error;
  const VtuField wrong{"f", 3, {1.0, 2.0}};
  EXPECT_DEATH(WriteVtu(dir.File("x.vtu"), testing::UnitTet(), {wrong}, {}, &error),
               "point field 'f' has 2 values; expected 4 entries x 3 components");
}

}  // namespace
}  // namespace aqs
