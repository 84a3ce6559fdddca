#include "testing/temp_dir.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <glog/logging.h>

namespace aqs {
namespace testing {

TempDir::TempDir() {
  const char* base = std::getenv("TMPDIR");
  std::string pattern = std::string(base && *base ? base : "/tmp") + "/aqs_test_XXXXXX";
  char* made = ::mkdtemp(pattern.data());
  CHECK(made != nullptr) << "mkdtemp failed for " << pattern;
  path_ = made;
}

TempDir::~TempDir() {
  const char* keep = std::getenv("AQS_KEEP_TEST_FILES");
  if (keep != nullptr && *keep != '\0' && *keep != '0') {
    LOG(INFO) << "kept " << path_ << " (AQS_KEEP_TEST_FILES)";
    return;
  }
  std::error_code ignored;
  std::filesystem::remove_all(path_, ignored);
}

std::string TempDir::File(const std::string& name) const { return path_ + "/" + name; }

std::string TempDir::Write(const std::string& name, const std::string& content) const {
  const std::string file = File(name);
  std::ofstream out(file, std::ios::binary);
  CHECK(out) << "cannot write " << file;
  out << content;
  return file;
}

}  // namespace testing
}  // namespace aqs
