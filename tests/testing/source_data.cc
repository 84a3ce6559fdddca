#include "testing/source_data.h"

#include "mesh/mesh_io.h"

namespace aqs {
namespace testing {

std::string DataPath(const std::string& relative) {
  return std::string(AQS_SOURCE_DIR) + "/data/" + relative;
}

std::string IctFaceDemoPath(const std::string& name) { return DataPath("ict-face-demo/" + name); }

::testing::AssertionResult ReadIctFaceDemo(const std::string& name, SurfaceMesh* mesh) {
  const std::string path = IctFaceDemoPath(name);
  std::string error;
  if (ReadObj(path, mesh, &error)) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure()
         << "cannot read the vendored ICT face data " << path << ": " << error;
}

}  // namespace testing
}  // namespace aqs
