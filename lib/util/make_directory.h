#ifndef AQS_UTIL_MAKE_DIRECTORY_H_
#define AQS_UTIL_MAKE_DIRECTORY_H_

#include <string>

namespace aqs {

// Creates the directory `path` and any missing parents (an existing one is fine).
// Returns false with *error ("<path>: cannot create directory (<why>)") on failure.
bool MakeDirectory(const std::string& path, std::string* error);

// Removes `directory` and everything in it; a missing one is fine. False with *error
// ("<directory>: cannot remove (<why>)") on failure.
bool RemoveDirectory(const std::string& directory, std::string* error);

}  // namespace aqs

#endif  // AQS_UTIL_MAKE_DIRECTORY_H_
