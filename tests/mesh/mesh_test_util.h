#ifndef AQS_TESTS_MESH_MESH_TEST_UTIL_H_
#define AQS_TESTS_MESH_MESH_TEST_UTIL_H_

#include <gtest/gtest.h>

#include <string>

#include "mesh/tet_mesh.h"
#include "testing/test_meshes.h"

namespace aqs {
namespace testing {

// Success if `text` contains `part`; the failure message shows both.
inline ::testing::AssertionResult Contains(const std::string& text, const std::string& part) {
  if (text.find(part) != std::string::npos) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "\"" << text << "\" does not contain \"" << part << "\"";
}

inline double TotalSignedVolume(const TetMesh& mesh) {
  double total = 0;
  for (int t = 0; t < mesh.num_tets(); ++t) total += SignedTetVolume(mesh, mesh.vertices, t);
  return total;
}

}  // namespace testing
}  // namespace aqs

#endif  // AQS_TESTS_MESH_MESH_TEST_UTIL_H_
