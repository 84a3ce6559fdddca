#ifndef AQS_TESTING_TEMP_DIR_H_
#define AQS_TESTING_TEMP_DIR_H_

#include <string>

namespace aqs {
namespace testing {

// A fresh temporary directory, removed with its contents on destruction (kept when
// the environment variable AQS_KEEP_TEST_FILES is set and not 0, for debugging).
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::string& path() const { return path_; }
  // path() + "/" + name
  std::string File(const std::string& name) const;
  // Writes `content` to File(name) and returns that path.
  std::string Write(const std::string& name, const std::string& content) const;

 private:
  std::string path_;
};

}  // namespace testing
}  // namespace aqs

#endif  // AQS_TESTING_TEMP_DIR_H_
