#ifndef AQS_TESTING_FILE_CONTENTS_H_
#define AQS_TESTING_FILE_CONTENTS_H_

#include <string>

namespace aqs {
namespace testing {

// The bytes of the file at `path` (empty if it cannot be read).
std::string ReadAll(const std::string& path);

// The text of a sequence fit's frames.csv (`path`) with its seconds column (column 10,
// which differs between runs) replaced by "-": for comparing two runs' outputs.
std::string FramesCsvWithoutSeconds(const std::string& path);

}  // namespace testing
}  // namespace aqs

#endif  // AQS_TESTING_FILE_CONTENTS_H_
