// The fit job's readers on the vendored demo data (jobs/fit_job.h).

#include "jobs/fit_job.h"

#include <set>

#include <gtest/gtest.h>

#include "mesh/mesh_io.h"
#include "testing/source_data.h"
#include "testing/temp_dir.h"

namespace aqs {
namespace {

TEST(FitJobTest, DemoScanLandmarksAreTheirPosesVerticesPlusNoise) {
  // scripts/demo.sh fits the demo scan with these landmarks (aqs_fit --landmarks).
  SurfaceMesh pose;
  std::string error;
  ASSERT_TRUE(ReadObj(testing::IctFaceDemoPath("poses/mouthFunnel.obj"), &pose, &error)) << error;
  std::vector<int> vertices;
  Eigen::Matrix3Xd positions;
  ASSERT_TRUE(ReadMarkers(testing::IctFaceDemoPath("scans/mouthFunnel_landmarks.txt"),
                          pose.num_vertices(), &vertices, &positions, &error))
      << error;
  ASSERT_EQ(vertices.size(), 10u);
  EXPECT_EQ(std::set<int>(vertices.begin(), vertices.end()).size(), 10u);
  double sum = 0;
  for (size_t k = 0; k < vertices.size(); ++k) {
    const double d = (positions.col(k) - pose.vertices.col(vertices[k])).norm();
    EXPECT_LT(d, 0.6) << "landmark " << k << " (vertex " << vertices[k] << ")";
    sum += d;
  }
  // Noise of 0.1 cm per coordinate: a mean distance near 0.16.
  EXPECT_GT(sum / 10, 0.05);
  EXPECT_LT(sum / 10, 0.3);
}

// The marker reader's checks at both ends of the index range, of repeats and of empty
// files, by whole messages: a marker on vertex num_surface_vertices was one past the end
// (of the reader's table and of the surface), and no test had an index that close.
TEST(FitJobTest, ReadMarkersChecksTheIndexRangeAtBothEndsAndRepeats) {
  testing::TempDir dir;
  std::vector<int> vertices;
  Eigen::Matrix3Xd positions;
  std::string error;
  const std::string last = dir.Write("last.txt", "# the last vertex\n9 1 2 3\n0 0 0 0\n");
  ASSERT_TRUE(ReadMarkers(last, 10, &vertices, &positions, &error)) << error;
  EXPECT_EQ(vertices, (std::vector<int>{9, 0}));
  EXPECT_EQ(positions.col(0), Eigen::Vector3d(1, 2, 3));
  const std::string past = dir.Write("past.txt", "3 0 0 0\n10 0 0 0\n");
  EXPECT_FALSE(ReadMarkers(past, 10, &vertices, &positions, &error));
  EXPECT_EQ(error, past + ":2: surface vertex 10 is outside [0, 10)");
  const std::string negative = dir.Write("negative.txt", "-1 0 0 0\n");
  EXPECT_FALSE(ReadMarkers(negative, 10, &vertices, &positions, &error));
  EXPECT_EQ(error, negative + ":1: surface vertex -1 is outside [0, 10)");
  const std::string repeated = dir.Write("repeated.txt", "3 0 0 0\n# c\n3 1 1 1\n");
  EXPECT_FALSE(ReadMarkers(repeated, 10, &vertices, &positions, &error));
  EXPECT_EQ(error, repeated + ":3: vertex 3 is given again (first on line 1)");
  const std::string empty = dir.Write("empty.txt", "# nothing\n");
  EXPECT_FALSE(ReadMarkers(empty, 10, &vertices, &positions, &error));
  EXPECT_NE(error.find(empty + ": no markers"), std::string::npos) << error;
}

}  // namespace
}  // namespace aqs
