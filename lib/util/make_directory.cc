#include "util/make_directory.h"

#include <filesystem>
#include <system_error>

namespace aqs {

bool MakeDirectory(const std::string& path, std::string* error) {
  std::error_code code;
  std::filesystem::create_directories(path, code);
  if (code) {
    *error = path + ": cannot create directory (" + code.message() + ")";
    return false;
  }
  return true;
}

bool RemoveDirectory(const std::string& directory, std::string* error) {
  std::error_code code;
  std::filesystem::remove_all(directory, code);
  if (code) {
    *error = directory + ": cannot remove (" + code.message() + ")";
    return false;
  }
  return true;
}

}  // namespace aqs
