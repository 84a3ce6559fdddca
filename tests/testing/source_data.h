#ifndef AQS_TESTING_SOURCE_DATA_H_
#define AQS_TESTING_SOURCE_DATA_H_

#include <string>

#include <gtest/gtest.h>

#include "mesh/surface_mesh.h"

namespace aqs {
namespace testing {

// Path of a file under the source tree's data/ folder (the tree CMake passes in as
// AQS_SOURCE_DIR).
std::string DataPath(const std::string& relative);

// Path of a file of the vendored ICT face subset, data/ict-face-demo/NAME.
std::string IctFaceDemoPath(const std::string& name);

// Reads the surface data/ict-face-demo/NAME (OBJ) into *mesh; a failure naming the file
// if it is missing or unreadable (the vendored data belongs to the source tree: tests
// that need it fail rather than skip without it).
::testing::AssertionResult ReadIctFaceDemo(const std::string& name, SurfaceMesh* mesh);

}  // namespace testing
}  // namespace aqs

#endif  // AQS_TESTING_SOURCE_DATA_H_
