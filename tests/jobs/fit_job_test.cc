// The fit job's readers on the vendored demo data (jobs/fit_job.h).

#include "jobs/fit_job.h"

#include <set>

#include <gtest/gtest.h>

#include "mesh/mesh_io.h"
#include "testing/source_data.h"

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

}  // namespace
}  // namespace aqs
